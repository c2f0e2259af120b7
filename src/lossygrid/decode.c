/* lossygrid's records as the mesh queries see them (api/query.h): decoded to triangles in
 * the mesh's vertex order, the sub-grid cells exactly as the record kernels build them
 * (lg_row_hit, from lg_row_index), so that the generic BVH walk (bvh/walk.c) over the wide8
 * nodes answers every query on lossygrid too. */
#include "lossygrid/lossygrid.h"
#include "lossygrid/record.h"

/* Vertex (i, j) of a decoded sub-grid. */
static void grid_vertex(const lg_grid_vertices *gv, int i, int j, float out[3]) {
    for (int k = 0; k < 3; k++) {
        float row[8];
        memcpy(row, &gv->w[k][j], sizeof row);
        out[k] = row[i];
    }
}

uint32_t lg_record_triangles(const uint8_t *leaf, uint32_t count, const bvh_shared *sh, float *v, uint32_t *ids) {
    (void)sh;
    uint32_t n = 0;
    for (uint32_t r = 0; r < count; r++, leaf += LG_RECORD_BYTES) {
        if (leaf[127] == LG_KIND_TRIS) {
            lg_tri_rec t;
            memcpy(&t, leaf, sizeof t);
            for (int k = 0; k < t.count && k < LG_TRI_MAX; k++, n++) {
                for (int c = 0; c < 3; c++) memcpy(v + 9 * n + 3 * c, t.v[lg_tri_index(&t, k, c)], 12);
                ids[n] = t.first + (uint32_t)k;
            }
            continue;
        }
        lg_grid_rec g;
        memcpy(&g, leaf, sizeof g);
        lg_grid_vertices gv;
        lg_grid_decode(&g, &gv);
        const int rx = lg_rx(&g), ry = lg_ry(&g);
        for (int row = 0; row < ry; row++) {
            const unsigned diag = g.diag >> (4 * row) & 15;
            for (int x = 0; x < rx; x++)
                for (int h = 0; h < 2; h++, n++) {
                    const int lane = 2 * x + h, k = 2 * (row * rx + x) + h;
                    /* lg_row_index: 0..7 a column of the row below, 8..15 of the row above. */
                    float cell[3][3];
                    for (int c = 0; c < 3; c++) {
                        const int at = lg_row_index[diag][c][lane];
                        grid_vertex(&gv, at & 7, row + (at >> 3), cell[c]);
                    }
                    /* Mesh vertex i is cell vertex (rot + i) % 3 (lg_rotate_uv). */
                    const int rot = g.rot[k >> 2 & 7] >> (2 * (k & 3)) & 3;
                    for (int c = 0; c < 3; c++) memcpy(v + 9 * n + 3 * c, cell[(rot + c) % 3], 12);
                    ids[n] = g.first + (uint32_t)k;
                }
        }
    }
    return n;
}
