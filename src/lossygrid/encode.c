/* Sub-grid compression (Benthin et al., §4): the four corners kept exact as the control
 * points of a bilinear patch, every other vertex a 3-byte displacement off the patch. The
 * error is measured on what lg_grid_decode gives back, the vertices traversal will see. */
#include "lossygrid/encode.h"

#include <math.h>
#include <omp.h>

/* Everything but the displacements: resolution, encoding, diagonals, rotations, corners. */
static void grid_header(const prt_mesh *m, const lg_source *src, int enc, uint8_t scale, lg_grid_rec *rec) {
    memset(rec, 0, sizeof *rec);
    const int rx = src->rx, ry = src->ry;
    rec->res = (uint8_t)((rx - 1) | (ry - 1) << 2);
    rec->kind = (uint8_t)enc;
    rec->scale = enc == LG_ENC_FIX ? scale : 0;
    rec->diag = src->diag;
    for (int k = 0; k < 2 * rx * ry; k++) rec->rot[k >> 2] |= (uint8_t)(src->rot[k] << (2 * (k & 3)));
    const int cidx[4] = {0, rx, 5 * ry, 5 * ry + rx};
    for (int c = 0; c < 4; c++) memcpy(rec->corner[c], &m->vertices[3 * (size_t)src->v[cidx[c]]], 12);
}

/* The patch point under lane l, as lg_grid_decode computes it. */
static void patch_point(const lg_grid_rec *rec, const lg_res_tables *t, int l, float p[3]) {
    for (int k = 0; k < 3; k++)
        p[k] = lg_lerp(lg_lerp(rec->corner[0][k], rec->corner[1][k], t->u1[l], t->u[l]),
                       lg_lerp(rec->corner[2][k], rec->corner[3][k], t->u1[l], t->u[l]), t->v1[l], t->v[l]);
}

float lg_grid_max_displacement(const prt_mesh *m, const lg_source *src) {
    lg_grid_rec rec;
    grid_header(m, src, LG_ENC_OCT, 0, &rec);
    const lg_res_tables *t = &lg_res[rec.res];
    float mx = 0;
    for (int slot = 0; slot < 21 && t->slot_lane[slot] >= 0; slot++) {
        const int l = t->slot_lane[slot];
        float p[3];
        patch_point(&rec, t, l, p);
        const float *want = &m->vertices[3 * (size_t)src->v[5 * (l >> 3) + (l & 7)]];
        for (int k = 0; k < 3; k++) mx = fmaxf(mx, fabsf(want[k] - p[k]));
    }
    return mx;
}

void lg_grid_encode(const prt_mesh *m, const lg_source *src, int enc, uint8_t scale, lg_grid_rec *rec, prt_aabb *box,
                    lg_grid_error *err) {
    grid_header(m, src, enc, scale, rec);
    const int rx = src->rx, ry = src->ry;
    const lg_res_tables *t = &lg_res[rec->res];
    if (enc == LG_ENC_FIX) { /* inside: the finest scale that still reaches the largest displacement there */
        float inner = 0;
        for (int slot = 0; slot < 21 && t->slot_lane[slot] >= 0; slot++) {
            const int l = t->slot_lane[slot];
            float p[3];
            patch_point(rec, t, l, p);
            const float *want = &m->vertices[3 * (size_t)src->v[5 * (l >> 3) + (l & 7)]];
            for (int k = 0; k < 3 && t->inner[l]; k++) inner = fmaxf(inner, fabsf(want[k] - p[k]));
        }
        const uint8_t s = lg_fix_exponent(inner);
        const int shift = s >= scale ? 0 : scale - s > 15 ? 15 : scale - s;
        rec->res = (uint8_t)(rec->res | shift << 4);
    }
    for (int slot = 0; slot < 21 && t->slot_lane[slot] >= 0; slot++) {
        const int l = t->slot_lane[slot];
        float p[3], got[3];
        patch_point(rec, t, l, p);
        const uint8_t s = t->inner[l] ? lg_inner_scale(rec) : scale;
        const uint32_t code = lg_disp_encode(enc, s, p, &m->vertices[3 * (size_t)src->v[5 * (l >> 3) + (l & 7)]], got);
        rec->disp[slot][0] = (uint8_t)code, rec->disp[slot][1] = (uint8_t)(code >> 8),
        rec->disp[slot][2] = (uint8_t)(code >> 16);
    }
    lg_grid_vertices gv;
    lg_grid_decode(rec, &gv);
    *box = prt_aabb_empty();
    *err = (lg_grid_error){0, 0, 0, 0};
    for (int j = 0; j <= ry; j++)
        for (int i = 0; i <= rx; i++) {
            const float d[3] = {gv.w[0][j][i], gv.w[1][j][i], gv.w[2][j][i]};
            prt_aabb_grow_point(box, d);
            const float *want = &m->vertices[3 * (size_t)src->v[5 * j + i]];
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

prt_status lg_encode_subgrids(const prt_mesh *m, const lg_extraction *ex, int enc, int threads, lg_grid_rec *recs,
                              prt_aabb *boxes, lg_grid_error *errs) {
    const size_t ng = ex->subgrid_count;
    float *grid_max = NULL; /* LG_ENC_FIX: per grid, its largest displacement component */
    if (enc == LG_ENC_FIX && !(grid_max = prt__calloc(ex->grid_count + 1, sizeof *grid_max)))
        return prt__fail(PRT_ERROR_NOMEM, "lossygrid: out of memory for %zu grids", ex->grid_count);
    /* Below a few thousand sub-grids the loops run on one thread: waking and joining the
     * others cost more than the work (1 s for 300 triangles on a busy 2-core machine). */
    const int nth = threads > 0 ? threads : omp_get_max_threads();
    if (grid_max) {
#pragma omp parallel for schedule(dynamic, 256) num_threads(nth) if (ng >= 4096)
        for (size_t i = 0; i < ng; i++) errs[i].max = lg_grid_max_displacement(m, &ex->subgrids[i]);
        for (size_t i = 0; i < ng; i++)
            grid_max[ex->subgrids[i].grid] = fmaxf(grid_max[ex->subgrids[i].grid], (float)errs[i].max);
    }
#pragma omp parallel for schedule(dynamic, 256) num_threads(nth) if (ng >= 4096)
    for (size_t i = 0; i < ng; i++) {
        const uint8_t scale = grid_max ? lg_fix_exponent(grid_max[ex->subgrids[i].grid]) : 0;
        lg_grid_encode(m, &ex->subgrids[i], enc, scale, &recs[i], &boxes[i], &errs[i]);
    }
    prt__free(grid_max);
    return PRT_OK;
}
