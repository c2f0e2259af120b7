/* Sub-grid compression (Benthin et al., §4): the four corners kept exact as the control
 * points of a bilinear patch, every other vertex a 3-byte displacement off the patch. The
 * error is measured on what lg_grid_decode gives back, the vertices traversal will see. */
#include "lossygrid/encode.h"

#include <math.h>

void lg_grid_encode(const prt_mesh *m, const lg_source *src, int enc, lg_grid_rec *rec, prt_aabb *box,
                    lg_grid_error *err) {
    memset(rec, 0, sizeof *rec);
    const int rx = src->rx, ry = src->ry;
    rec->res = (uint8_t)((rx - 1) | (ry - 1) << 2);
    rec->kind = (uint8_t)enc;
    rec->diag = src->diag;
    for (int k = 0; k < 2 * rx * ry; k++) rec->rot[k >> 2] |= (uint8_t)(src->rot[k] << (2 * (k & 3)));
    const int cidx[4] = {0, rx, 5 * ry, 5 * ry + rx};
    for (int c = 0; c < 4; c++) memcpy(rec->corner[c], &m->vertices[3 * (size_t)src->v[cidx[c]]], 12);
    int slot = 0;
    for (int j = 0; j <= ry; j++) {
        const float v = (float)j / (float)ry, v1 = 1.0f - v;
        for (int i = 0; i <= rx; i++) {
            if ((i == 0 || i == rx) && (j == 0 || j == ry)) continue;
            const float u = (float)i / (float)rx, u1 = 1.0f - u;
            float p[3], got[3];
            for (int k = 0; k < 3; k++) /* the patch point, as lg_grid_decode computes it */
                p[k] = lg_lerp(lg_lerp(rec->corner[0][k], rec->corner[1][k], u1, u),
                               lg_lerp(rec->corner[2][k], rec->corner[3][k], u1, u), v1, v);
            const uint32_t code = lg_disp_encode(enc, p, &m->vertices[3 * (size_t)src->v[5 * j + i]], got);
            rec->disp[slot][0] = (uint8_t)code, rec->disp[slot][1] = (uint8_t)(code >> 8),
            rec->disp[slot][2] = (uint8_t)(code >> 16);
            slot++;
        }
    }
    float x[25], y[25], z[25];
    lg_grid_decode(rec, x, y, z);
    *box = prt_aabb_empty();
    *err = (lg_grid_error){0, 0, 0, 0};
    for (int j = 0; j <= ry; j++)
        for (int i = 0; i <= rx; i++) {
            const int k = 5 * j + i;
            const float d[3] = {x[k], y[k], z[k]};
            prt_aabb_grow_point(box, d);
            const float *want = &m->vertices[3 * (size_t)src->v[k]];
            double e2 = 0;
            for (int c = 0; c < 3; c++) e2 += ((double)d[c] - want[c]) * ((double)d[c] - want[c]);
            err->max = fmax(err->max, sqrt(e2));
            err->sum2 += e2;
            err->vertices++;
        }
    double diag2 = 0;
    for (int c = 0; c < 3; c++) diag2 += ((double)box->hi[c] - box->lo[c]) * ((double)box->hi[c] - box->lo[c]);
    err->diag = sqrt(diag2);
}
