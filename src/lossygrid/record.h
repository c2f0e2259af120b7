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

#include <stddef.h>

#define LG_RECORD_BYTES 128
/* A sub-grid's kind byte is its displacement encoding; exact triangles come after. */
enum { LG_KIND_TRIS = LG_ENC_COUNT };

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
    uint8_t res;   /* rx - 1 | (ry - 1) << 2 | k << 4, k: LG_ENC_FIX's shift inside the sub-grid */
    uint8_t scale; /* LG_ENC_FIX: the grid's exponent byte; else 0 */
    uint8_t kind;  /* the displacement encoding, LG_ENC_* */
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

_Static_assert(offsetof(lg_grid_rec, disp) == LG_DISP_OFFSET, "codes where the decoder's tables expect them");
_Static_assert(sizeof(lg_grid_rec) == LG_RECORD_BYTES && sizeof(lg_tri_rec) == LG_RECORD_BYTES,
               "records are 128 bytes");

static inline int lg_rx(const lg_grid_rec *g) { return (g->res & 3) + 1; }
static inline int lg_ry(const lg_grid_rec *g) { return (g->res >> 2 & 3) + 1; }
/* The exponent byte of LG_ENC_FIX inside the sub-grid (on its border: scale). */
static inline uint8_t lg_inner_scale(const lg_grid_rec *g) { return (uint8_t)(g->scale - (g->res >> 4)); }
static inline int lg_tri_index(const lg_tri_rec *t, int k, int c) {
    const int nib = 3 * k + c;
    return t->idx[nib >> 1] >> (4 * (nib & 1)) & 15;
}

static inline float lg_lerp(float a, float b, float w1, float w) { return a * w1 + b * w; }

/* The grid vertices of a sub-grid as traversal sees them (and as the encoder measures
 * them), one 8-lane row per grid row: lane i of w[k][j] is component k of vertex (i, j),
 * NaN past rx so those triangles never hit; rows past ry are not written (not read). The patch point is
 * lg_lerp(lg_lerp(c00, c10, 1 - u, u), lg_lerp(c01, c11, 1 - u, u), 1 - v, v), the same
 * operations whichever sub-grid of a grid evaluates a shared border. */
typedef struct lg_grid_vertices {
    vf8 w[3][5];
} lg_grid_vertices;

static inline vf8 lg_gather(const float *base, vi8 idx) {
#if defined(__AVX2__)
    return (vf8)_mm256_i32gather_ps(base, (__m256i)idx, 4);
#else
    vf8 r;
    for (int i = 0; i < 8; i++) r[i] = base[idx[i]];
    return r;
#endif
}

/* lg_disp_decode for eight codes at once, bit for bit. */
static inline void lg_disp_decode8(int enc, vi8 c, uint8_t scale, uint8_t inner_scale, vi8 inner, vf8 d[3]) {
    const vi8 one = {1, 1, 1, 1, 1, 1, 1, 1};
    if (enc == LG_ENC_FIX) {
        const vf8 s = vf8_select(inner, vf8_set1(lg_fix_scale(inner_scale)), vf8_set1(lg_fix_scale(scale)));
        for (int k = 0; k < 3; k++) d[k] = __builtin_convertvector(c << (24 - 8 * k) >> 24, vf8) * s;
    } else if (enc == LG_ENC_OCT) {
        const vi8 e = c >> 13 & 63, m = c >> 19 & 31, zero = e == 0;
        const vf8 len = (vf8)(((e + 86) << 23 | m << 18) & ~zero);
        const vi8 idx = (c >> 3 & 1023) << 2;
        for (int k = 0; k < 3; k++) d[k] = (vf8)((vi8)(lg_gather(lg_dirs[0] + k, idx) * len) ^ (c >> k & one) << 31);
    } else {
        const vf8 scale = (vf8)(((c >> 3 & 63) + 81) << 23);
        for (int k = 0; k < 3; k++)
            d[k] = (vf8)((vi8)(__builtin_convertvector(c >> (9 + 5 * k) & 31, vf8) * scale) ^ (c >> k & one) << 31);
    }
}

/* The 24-bit codes of the eight lanes of grid row j (0 where a lane has none: a corner,
 * or past the resolution). A row's codes lie within 15 bytes: one 16-byte load, copied to
 * both halves of a vector and shuffled into the lanes (a gather costs several times that). */
static inline vi8 lg_codes(const lg_grid_rec *g, const lg_res_tables *t, int j) {
#if defined(__AVX2__)
    const __m128i row = _mm_loadu_si128((const __m128i *)(const void *)((const uint8_t *)g + t->row_load[j]));
    const __m256i both = _mm256_broadcastsi128_si256(row);
    return (vi8)_mm256_shuffle_epi8(both, _mm256_loadu_si256((const __m256i *)(const void *)t->row_shuffle[j]));
#else
    vi8 c;
    for (int i = 0; i < 8; i++) {
        const int32_t at = t->code_at[8 * j + i];
        c[i] = at < 0 ? 0 : (int32_t)lg_disp_load((const uint8_t *)g + at);
    }
    return c;
#endif
}

static inline void lg_grid_decode(const lg_grid_rec *g, lg_grid_vertices *out) {
    const lg_res_tables *t = &lg_res[g->res & 15];
    const int rows = lg_ry(g) + 1;
    const uint8_t inner_scale = lg_inner_scale(g);
    /* The patch's bottom and top edges at each column: the same for every row. */
    const vf8 u1 = vf8_load(&t->u1[0]), u = vf8_load(&t->u[0]);
    vf8 a[3], b[3];
    for (int k = 0; k < 3; k++) {
        a[k] = vf8_set1(g->corner[0][k]) * u1 + vf8_set1(g->corner[1][k]) * u;
        b[k] = vf8_set1(g->corner[2][k]) * u1 + vf8_set1(g->corner[3][k]) * u;
    }
    for (int j = 0; j < rows; j++) {
        vf8 d[3];
        vi8 inner;
        memcpy(&inner, &t->inner[8 * j], sizeof inner);
        lg_disp_decode8(g->kind, lg_codes(g, t, j), g->scale, inner_scale, inner, d);
        const vf8 v1 = vf8_load(&t->v1[8 * j]), v = vf8_load(&t->v[8 * j]);
        for (int k = 0; k < 3; k++) out->w[k][j] = (a[k] * v1 + b[k] * v) + d[k];
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

/* The grid vertices moved into the ray's sheared space once per sub-grid, as the
 * watertight test moves each triangle vertex (geom/triangle_simd.inc): x, y after the
 * shear, z scaled. A vertex shared by several triangles is transformed once and the same
 * bits reach all of them, so the edge test stays watertight across the sub-grid. */
typedef struct lg_sheared {
    vf8 x[5], y[5], z[5];
} lg_sheared;

static inline void lg_shear(const lg_grid_vertices *g, int rows, const prt__rayx *r, const prt__rayx8t *rw,
                            lg_sheared *o) {
    const int kx = r->kx, ky = r->ky, kz = r->kz;
    for (int j = 0; j < rows; j++) {
        const vf8 az = g->w[kz][j] - rw->o[2]; /* rw->o: the origin's axes kx, ky, kz */
        o->x[j] = (g->w[kx][j] - rw->o[0]) - rw->sx * az;
        o->y[j] = (g->w[ky][j] - rw->o[1]) - rw->sy * az;
        o->z[j] = rw->sz * az;
    }
}

/* Lanes of one row by index (the low 3 bits of idx). */
static inline vf8 lg_permute(vf8 v, vi8 idx) {
#if defined(__AVX2__)
    return (vf8)_mm256_permutevar8x32_ps((__m256)v, (__m256i)idx);
#else
    return __builtin_shuffle(v, idx & 7);
#endif
}

/* A cell triangle's first vertex is always on the row below and its third on the row
 * above (lg_row_index, extract.h); its second is (x + 1) below for h = 0 and above for
 * h = 1, whatever the diagonal: one permute each for the first and third, a fixed
 * permute and blend for the second. */
static inline vf8 lg_second(vf8 below, vf8 above) {
    const vi8 idx = {1, 1, 2, 2, 3, 3, 4, 4}, odd = {0, -1, 0, -1, 0, -1, 0, -1};
    return vf8_select(odd, lg_permute(above, idx), lg_permute(below, idx));
}

/* The watertight test (geom/triangle_simd.inc, the same operations in the same order) on
 * the eight triangles of cell row `row`, lane 2 x + h: the mask of lanes hit in
 * [tnear, tfar], with t (+inf elsewhere), u and v set when non-zero. */
static inline int lg_row_hit(const lg_sheared *s, int row, unsigned diag, const prt__rayx8t *rw, vf8 tfar, vf8 *t_out,
                             vf8 *u_out, vf8 *v_out) {
    vi8 ia, ic;
    memcpy(&ia, lg_row_index[diag][0], 32), memcpy(&ic, lg_row_index[diag][2], 32);
    const vf8 ax = lg_permute(s->x[row], ia), ay = lg_permute(s->y[row], ia);
    const vf8 bx = lg_second(s->x[row], s->x[row + 1]), by = lg_second(s->y[row], s->y[row + 1]);
    const vf8 cx = lg_permute(s->x[row + 1], ic), cy = lg_permute(s->y[row + 1], ic);
    vf8 u = cx * by - cy * bx;
    vf8 v = ax * cy - ay * cx;
    vf8 w = bx * ay - by * ax;
    const vf8 zero = vf8_set1(0.0f);
    const vi8 any_zero = (u == zero) | (v == zero) | (w == zero);
    if (PRT_UNLIKELY(vi8_mask(any_zero))) {
        /* Copies: were the operands themselves passed by address, the compiler would keep
         * all nine in memory, stored on every row, for this rare path. */
        vf8 a[6] = {ax, ay, bx, by, cx, cy}, e[3] = {u, v, w};
        prt__tri8_fix_edges(any_zero, &a[0], &a[1], &a[2], &a[3], &a[4], &a[5], &e[0], &e[1], &e[2]);
        u = e[0], v = e[1], w = e[2];
    }
    const vi8 mixed = (vf8_min(vf8_min(u, v), w) < zero) & (vf8_max(vf8_max(u, v), w) > zero);
    const vf8 det = u + v + w;
    const vi8 inside = ~mixed & (det != zero);
    if (!vi8_mask(inside)) return 0;
    const vf8 az = lg_permute(s->z[row], ia), bz = lg_second(s->z[row], s->z[row + 1]);
    const vf8 cz = lg_permute(s->z[row + 1], ic);
    const vf8 T = u * az + v * bz + w * cz;
    const vf8 t = T / det;
    const vi8 ok = inside & (t >= rw->tnear) & (t <= tfar);
    const int mask = vi8_mask(ok);
    if (mask) {
        *t_out = vf8_select(ok, t, vf8_set1(INFINITY));
        *u_out = v / det;
        *v_out = w / det;
    }
    return mask;
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
        for (unsigned m = mask; m; m &= m - 1)
            lg_rotate_uv(rot[__builtin_ctz(m)], &uu[__builtin_ctz(m)], &vv[__builtin_ctz(m)]);
    bvh_take_nearest_seq(h, tt, uu, vv, ids, mask, vf8_hmin(t), sh);
}

/* A record as decoded once for any number of rays: the exact triangles in SOA form, or the
 * sub-grid's vertices (lossygrid/traverse.c decodes once per packet). */
typedef struct lg_decoded {
    const lg_grid_rec *g; /* NULL: exact triangles in p */
    int rx, ry;
    union {
        float p[72] __attribute__((aligned(32)));
        lg_grid_vertices gv;
    };
} lg_decoded;

static inline void lg_record_decode(const uint8_t *rec, lg_decoded *d) {
    if (rec[127] == LG_KIND_TRIS) {
        d->g = NULL;
        lg_tri_soa((const lg_tri_rec *)rec, d->p);
        return;
    }
    d->g = (const lg_grid_rec *)rec;
    d->rx = lg_rx(d->g), d->ry = lg_ry(d->g);
    lg_grid_decode(d->g, &d->gv);
}

/* Closest hit of one ray with a decoded record (the record's bytes at rec). */
PRT_INLINE void lg_record_hit(const uint8_t *rec, const lg_decoded *d, const prt__rayx *r, const lgrec_ray *c,
                              prt__hitx *h) {
    vf8 t, u, v;
    uint32_t ids[8];
    if (!d->g) {
        const lg_tri_rec *tr = (const lg_tri_rec *)rec;
        const unsigned mask = (unsigned)prt__tri8_hit(r, &c->r8, d->p, vf8_set1(h->t), &t, &u, &v);
        if (!mask) return;
        for (int k = 0; k < 8; k++) ids[k] = tr->first + (uint32_t)k;
        lg_take(h, t, u, v, mask, ids, NULL, c->sh);
        return;
    }
    const lg_grid_rec *g = d->g;
    lg_sheared sh;
    lg_shear(&d->gv, d->ry + 1, r, &c->r8, &sh);
    for (int row = 0; row < d->ry; row++) {
        const unsigned mask =
            (unsigned)lg_row_hit(&sh, row, g->diag >> (4 * row) & 15, &c->r8, vf8_set1(h->t), &t, &u, &v);
        if (!mask) continue;
        int rot[8];
        for (unsigned l = mask; l; l &= l - 1) {
            const int lane = __builtin_ctz(l), k = 2 * (row * d->rx + (lane >> 1)) + (lane & 1);
            ids[lane] = g->first + (uint32_t)k;
            rot[lane] = g->rot[k >> 2 & 7] >> (2 * (k & 3)) & 3;
        }
        lg_take(h, t, u, v, mask, ids, rot, c->sh);
    }
}

PRT_INLINE void lgrec_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrec_ray *c, prt__hitx *h) {
    for (uint32_t i = 0; i < n; i++, leaf += LG_RECORD_BYTES) {
        lg_decoded d;
        lg_record_decode(leaf, &d);
        lg_record_hit(leaf, &d, r, c, h);
    }
}

/* Whether one ray meets a decoded record within [tnear, tfar]. */
PRT_INLINE bool lg_record_blocks(const lg_decoded *d, const prt__rayx *r, const lgrec_ray *c, float tfar) {
    const vf8 tf = vf8_set1(tfar);
    vf8 t, u, v;
    if (!d->g) return prt__tri8_hit(r, &c->r8, d->p, tf, &t, &u, &v) != 0;
    lg_sheared sh;
    lg_shear(&d->gv, d->ry + 1, r, &c->r8, &sh);
    for (int row = 0; row < d->ry; row++)
        if (lg_row_hit(&sh, row, d->g->diag >> (4 * row) & 15, &c->r8, tf, &t, &u, &v)) return true;
    return false;
}

PRT_INLINE bool lgrec_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrec_ray *c, float tfar) {
    for (uint32_t i = 0; i < n; i++, leaf += LG_RECORD_BYTES) {
        lg_decoded d;
        lg_record_decode(leaf, &d);
        if (lg_record_blocks(&d, r, c, tfar)) return true;
    }
    return false;
}

#endif
