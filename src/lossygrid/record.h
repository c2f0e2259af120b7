/* The 128-byte records under lossygrid's wide8 nodes: a compressed 5x5 vertex sub-grid
 * (Benthin et al., Listing 1, rearranged) or, for triangles that fit no grid, up to eight
 * triangles over nine exact vertices. Both end in a kind byte. The traversal kernels
 * (lgrec_*) follow the BVH codec interface (bvh/codecs/codec.h) so that the wide8
 * traversal template inlines them. */
#ifndef PRT_LOSSYGRID_RECORD_H
#define PRT_LOSSYGRID_RECORD_H

#include "bvh/codecs/nearest.h"
#include "geom/triangle.h"
#include "lossygrid/displacement.h"

#define LG_RECORD_BYTES 128
enum { LG_KIND_GRID_OCT = LG_ENC_OCT, LG_KIND_GRID_EXP = LG_ENC_EXP, LG_KIND_TRIS = 2 };

/* A sub-grid of rx x ry quads (1..4 each). Grid vertex (i, j), i <= rx, j <= ry, is the
 * bilinear patch over the four exact corners at u = i / rx, v = j / ry, plus a decoded
 * displacement for each of the others, in row-major order (corners skipped). Shared
 * borders of sub-grids of one grid see the same corners, weights and codes, so they decode
 * to the same bits (§4.3). Cell triangles and diag as in extract.h; rot holds 2 bits per
 * cell triangle: its mesh triangle's first vertex. */
typedef struct lg_grid_rec {
    float corner[4][3]; /* (0, 0), (rx, 0), (0, ry), (rx, ry) */
    uint32_t first;     /* accel position of cell triangle 0; the others follow */
    uint8_t rot[8];
    uint16_t diag;
    uint8_t disp[21][3];
    uint8_t res; /* rx - 1 | (ry - 1) << 2 */
    uint8_t pad;
    uint8_t kind; /* LG_KIND_GRID_OCT or LG_KIND_GRID_EXP: the displacement encoding */
} lg_grid_rec;

/* count triangles, each three 4-bit indices into v (nibble 3 k + c, low nibble first),
 * vertices in the mesh triangle's order: exact and lossless. */
#define LG_TRI_VERTS 9
#define LG_TRI_MAX 8
typedef struct lg_tri_rec {
    float v[LG_TRI_VERTS][3];
    uint32_t first;
    uint8_t idx[12];
    uint8_t count, verts, pad;
    uint8_t kind; /* LG_KIND_TRIS */
} lg_tri_rec;

_Static_assert(sizeof(lg_grid_rec) == LG_RECORD_BYTES && sizeof(lg_tri_rec) == LG_RECORD_BYTES, "records are 128 bytes");

static inline int lg_rx(const lg_grid_rec *g) { return (g->res & 3) + 1; }
static inline int lg_ry(const lg_grid_rec *g) { return (g->res >> 2 & 3) + 1; }
static inline int lg_tri_index(const lg_tri_rec *t, int k, int c) {
    const int nib = 3 * k + c;
    return t->idx[nib >> 1] >> (4 * (nib & 1)) & 15;
}

static inline float lg_lerp(float a, float b, float w1, float w) { return a * w1 + b * w; }

/* Decode a sub-grid's vertices into x, y, z (index 5 j + i); the others become NaN so
 * triangles past the resolution never hit. The encoder calls this too. */
static inline void lg_grid_decode(const lg_grid_rec *g, float *restrict x, float *restrict y, float *restrict z) {
    const int rx = lg_rx(g), ry = lg_ry(g), enc = g->kind;
    float *out[3] = {x, y, z};
    for (int i = 0; i < 25; i++) x[i] = y[i] = z[i] = NAN;
    int slot = 0;
    for (int j = 0; j <= ry; j++) {
        const float v = (float)j / (float)ry, v1 = 1.0f - v;
        for (int i = 0; i <= rx; i++) {
            const float u = (float)i / (float)rx, u1 = 1.0f - u;
            const bool corner = (i == 0 || i == rx) && (j == 0 || j == ry);
            float d[3] = {0, 0, 0};
            if (!corner) lg_disp_decode(enc, lg_disp_load(g->disp[slot++]), d);
            for (int k = 0; k < 3; k++) {
                float p;
                if (corner) p = g->corner[(i == rx) + 2 * (j == ry)][k];
                else {
                    const float a = lg_lerp(g->corner[0][k], g->corner[1][k], u1, u);
                    const float b = lg_lerp(g->corner[2][k], g->corner[3][k], u1, u);
                    p = lg_lerp(a, b, v1, v) + d[k];
                }
                out[k][5 * j + i] = p;
            }
        }
    }
}

/* --- kernels for the wide8 traversal template (CODEC = lgrec) ------------------------ */

enum { lgrec_block = 1, lgrec_align = 64, lgrec_seq_ids = 1 };

typedef struct lgrec_ray {
    prt__rayx8t r8;
    const bvh_shared *sh;
} lgrec_ray;

static inline size_t lgrec_leaf_bytes(uint32_t n) { return (size_t)n * LG_RECORD_BYTES; }

static inline void lgrec_ray_init(lgrec_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    prt__rayx8t_init(&c->r8, r);
    c->sh = sh;
}

/* The eight cell triangles of row y (lane 2 x + h) in SOA form for prt__tri8_hit. */
static inline void lg_grid_row(const lg_grid_rec *g, const float *x, const float *y, const float *z, int row,
                               float p[72]) {
    const float *src[3] = {x, y, z};
    for (int cx = 0; cx < 4; cx++) {
        const int c00 = 5 * row + cx, c10 = c00 + 1, c01 = c00 + 5, c11 = c00 + 6;
        const bool odd = g->diag >> (row * 4 + cx) & 1;
        const int tri[2][3] = {{c00, c10, odd ? c01 : c11}, {odd ? c10 : c00, c11, c01}};
        for (int h = 0; h < 2; h++)
            for (int c = 0; c < 9; c++) p[c * 8 + 2 * cx + h] = src[c % 3][tri[h][c / 3]];
    }
}

/* Barycentrics (u, v) of the cell triangle, re-expressed for its mesh triangle, whose
 * vertex 0 is the cell triangle's vertex rot. */
static inline void lg_rotate_uv(int rot, float *u, float *v) {
    const float b[3] = {1.0f - *u - *v, *u, *v};
    const float nu = b[(rot + 1) % 3], nv = b[(rot + 2) % 3];
    *u = nu, *v = nv;
}

static inline void lg_tri_soa(const lg_tri_rec *t, float p[72]) {
    for (int k = 0; k < LG_TRI_MAX; k++)
        for (int c = 0; c < 9; c++) p[c * 8 + k] = k < t->count ? t->v[lg_tri_index(t, k, c / 3)][c % 3] : NAN;
}

/* Closest hit over the hit lanes of one 8-triangle block whose lane l is accel position
 * first + pos[l] (rot: per-lane rotation for sub-grid cells, NULL for exact triangles). */
static inline void lg_take(prt__hitx *h, vf8 t, vf8 u, vf8 v, unsigned mask, const uint32_t *ids, const int *rot,
                           const bvh_shared *sh) {
    float tt[8], uu[8], vv[8];
    memcpy(tt, &t, sizeof tt), memcpy(uu, &u, sizeof uu), memcpy(vv, &v, sizeof vv);
    if (rot)
        for (unsigned m = mask; m; m &= m - 1) lg_rotate_uv(rot[__builtin_ctz(m)], &uu[__builtin_ctz(m)], &vv[__builtin_ctz(m)]);
    bvh_take_nearest_seq(h, tt, uu, vv, ids, mask, vf8_hmin(t), sh);
}

PRT_INLINE void lgrec_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrec_ray *c, prt__hitx *h) {
    for (uint32_t i = 0; i < n; i++, leaf += LG_RECORD_BYTES) {
        float p[72] __attribute__((aligned(32)));
        vf8 t, u, v;
        uint32_t ids[8];
        if (leaf[127] == LG_KIND_TRIS) {
            const lg_tri_rec *tr = (const lg_tri_rec *)leaf;
            lg_tri_soa(tr, p);
            const unsigned mask = (unsigned)prt__tri8_hit(r, &c->r8, p, vf8_set1(h->t), &t, &u, &v);
            if (!mask) continue;
            for (int k = 0; k < 8; k++) ids[k] = tr->first + (uint32_t)k;
            lg_take(h, t, u, v, mask, ids, NULL, c->sh);
            continue;
        }
        const lg_grid_rec *g = (const lg_grid_rec *)leaf;
        float x[25], y[25], z[25];
        lg_grid_decode(g, x, y, z);
        const int rx = lg_rx(g), ry = lg_ry(g);
        for (int row = 0; row < ry; row++) {
            lg_grid_row(g, x, y, z, row, p);
            const unsigned mask = (unsigned)prt__tri8_hit(r, &c->r8, p, vf8_set1(h->t), &t, &u, &v);
            if (!mask) continue;
            int rot[8];
            for (int l = 0; l < 8; l++) {
                const int k = 2 * (row * rx + (l >> 1)) + (l & 1);
                ids[l] = g->first + (uint32_t)k;
                rot[l] = k < 32 ? g->rot[k >> 2] >> (2 * (k & 3)) & 3 : 0;
            }
            lg_take(h, t, u, v, mask, ids, rot, c->sh);
        }
    }
}

PRT_INLINE bool lgrec_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrec_ray *c, float tfar) {
    const vf8 tf = vf8_set1(tfar);
    for (uint32_t i = 0; i < n; i++, leaf += LG_RECORD_BYTES) {
        float p[72] __attribute__((aligned(32)));
        vf8 t, u, v;
        if (leaf[127] == LG_KIND_TRIS) {
            lg_tri_soa((const lg_tri_rec *)leaf, p);
            if (prt__tri8_hit(r, &c->r8, p, tf, &t, &u, &v)) return true;
            continue;
        }
        const lg_grid_rec *g = (const lg_grid_rec *)leaf;
        float x[25], y[25], z[25];
        lg_grid_decode(g, x, y, z);
        for (int row = 0; row < lg_ry(g); row++) {
            lg_grid_row(g, x, y, z, row, p);
            if (prt__tri8_hit(r, &c->r8, p, tf, &t, &u, &v)) return true;
        }
    }
    return false;
}

#endif
