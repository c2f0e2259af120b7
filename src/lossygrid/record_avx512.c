/* The sub-grid record kernels of record.h in 16-lane AVX-512 (Benthin et al.: "AVX-512 can
 * take two rows"): the 25 grid vertices five to a row in two 16-lane halves, decoded and
 * sheared in two passes each, and two rows of eight cell triangles tested per pass, their
 * vertices picked out of both halves by one two-source permute each. Every lane meets the
 * operations of the 8-lane kernels in the same order, so the answers are theirs bit for
 * bit. Compiled for AVX-512 (the library targets AVX2) and used only where the CPU has it
 * (lg_avx512_usable, traverse.c, which is not compiled for AVX-512). */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/* Everything in this file, the walks instantiated below included, compiled for AVX-512, so
 * that the record kernels inline into the stream's walk. */
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f,avx512bw,avx512dq,avx512vl,avx512vbmi"))), apply_to = function)
#else
#pragma GCC target("avx512f,avx512bw,avx512dq,avx512vl,avx512vbmi")
#endif
#define LG_AVX512_FILE 1
#endif

#include "bvh/layouts/wide8_box.h"
#include "bvh/traverse.h"
#include "lossygrid/lossygrid.h"
#include "lossygrid/record.h"

#if LG_AVX512_FILE
#include <immintrin.h>

#define LG16 __attribute__((target("avx512f,avx512bw,avx512dq,avx512vl,avx512vbmi")))
#define LG16_INLINE static inline __attribute__((always_inline)) LG16

/* lg_disp_decode8 for one half's sixteen codes, the same operations lane by lane; d[i] is
 * component comp[i] (the ray's kx, ky, kz: the arrays stay in registers, where an index
 * known only at run time would put them in memory). */
LG16_INLINE void lg16_disp(int enc, __m512i c, float scale, float inner_scale, __mmask16 inner, const int comp[3],
                           __m512 d[3]) {
    const __m512i one = _mm512_set1_epi32(1);
    if (enc == LG_ENC_FIX) {
        const __m512 s = _mm512_mask_blend_ps(inner, _mm512_set1_ps(scale), _mm512_set1_ps(inner_scale));
        for (int i = 0; i < 3; i++)
            d[i] = _mm512_mul_ps(
                _mm512_cvtepi32_ps(_mm512_srai_epi32(_mm512_sll_epi32(c, _mm_cvtsi32_si128(24 - 8 * comp[i])), 24)), s);
    } else if (enc == LG_ENC_OCT) {
        const __m512i e = _mm512_and_si512(_mm512_srli_epi32(c, 13), _mm512_set1_epi32(63));
        const __m512i m = _mm512_and_si512(_mm512_srli_epi32(c, 19), _mm512_set1_epi32(31));
        const __mmask16 nonzero = _mm512_test_epi32_mask(e, e);
        const __m512i bits = _mm512_or_si512(_mm512_slli_epi32(_mm512_add_epi32(e, _mm512_set1_epi32(86)), 23),
                                             _mm512_slli_epi32(m, 18));
        const __m512 len = _mm512_castsi512_ps(_mm512_maskz_mov_epi32(nonzero, bits));
        const __m512i idx = _mm512_slli_epi32(_mm512_and_si512(_mm512_srli_epi32(c, 3), _mm512_set1_epi32(1023)), 2);
        for (int i = 0; i < 3; i++) {
            const int k = comp[i];
            const __m512 p = _mm512_mul_ps(_mm512_i32gather_ps(idx, lg_dirs[0] + k, 4), len);
            const __m512i sign = _mm512_slli_epi32(_mm512_and_si512(_mm512_srl_epi32(c, _mm_cvtsi32_si128(k)), one), 31);
            d[i] = _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(p), sign));
        }
    } else {
        const __m512 s = _mm512_castsi512_ps(_mm512_slli_epi32(
            _mm512_add_epi32(_mm512_and_si512(_mm512_srli_epi32(c, 3), _mm512_set1_epi32(63)), _mm512_set1_epi32(81)), 23));
        for (int i = 0; i < 3; i++) {
            const int k = comp[i];
            const __m512i q = _mm512_and_si512(_mm512_srl_epi32(c, _mm_cvtsi32_si128(9 + 5 * k)), _mm512_set1_epi32(31));
            const __m512 p = _mm512_mul_ps(_mm512_cvtepi32_ps(q), s);
            const __m512i sign = _mm512_slli_epi32(_mm512_and_si512(_mm512_srl_epi32(c, _mm_cvtsi32_si128(k)), one), 31);
            d[i] = _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(p), sign));
        }
    }
}

/* The column (vertex i of its row) of each lane of the two halves. */
static const int32_t lg16_column[2][16] = {{0, 1, 2, 3, 4, 0, 1, 2, 3, 4, 0, 1, 2, 3, 4, 0},
                                           {1, 2, 3, 4, 0, 1, 2, 3, 4, 0, 1, 2, 3, 4, 0, 0}};

/* lg_grid_decode in the five-to-a-row layout: w[i][h] is component comp[i] of lanes 16 h ..
 * 16 h + 15, vertex (i, j) in lane 5 j + i; the patch point and the sum as lg_grid_decode
 * computes them. */
LG16_INLINE void lg16_decode(const lg_grid_rec *g, const int comp[3], __m512 w[3][2]) {
    const lg_res_tables *t = &lg_res[g->res & 15];
    const __m512i bytes = _mm512_loadu_si512((const void *)((const uint8_t *)g + LG_DISP_OFFSET));
    const float scale = lg_fix_scale(g->scale), inner_scale = lg_fix_scale(lg_inner_scale(g));
    /* The patch's bottom and top edges at each column (lanes 0-7, as lg_grid_decode's a
     * and b), then spread to the lanes of each column. */
    const __m512 u1 = _mm512_castps256_ps512(_mm256_loadu_ps(t->u1)), u = _mm512_castps256_ps512(_mm256_loadu_ps(t->u));
    __m512 a[3], b[3];
    for (int i = 0; i < 3; i++) {
        const int k = comp[i];
        a[i] = _mm512_add_ps(_mm512_mul_ps(_mm512_set1_ps(g->corner[0][k]), u1), _mm512_mul_ps(_mm512_set1_ps(g->corner[1][k]), u));
        b[i] = _mm512_add_ps(_mm512_mul_ps(_mm512_set1_ps(g->corner[2][k]), u1), _mm512_mul_ps(_mm512_set1_ps(g->corner[3][k]), u));
    }
    for (int h = 0; h < 2; h++) {
        const __m512i c = _mm512_maskz_permutexvar_epi8(t->code_keep[h], _mm512_loadu_si512((const void *)t->code_perm[h]), bytes);
        __m512 d[3];
        lg16_disp(g->kind, c, scale, inner_scale, t->cinner[h], comp, d);
        const __m512i column = _mm512_loadu_si512((const void *)lg16_column[h]);
        const __m512 v1 = _mm512_loadu_ps(&t->cv1[16 * h]), v = _mm512_loadu_ps(&t->cv[16 * h]);
        for (int i = 0; i < 3; i++) {
            const __m512 ac = _mm512_permutexvar_ps(column, a[i]), bc = _mm512_permutexvar_ps(column, b[i]);
            w[i][h] = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(ac, v1), _mm512_mul_ps(bc, v)), d[i]);
        }
    }
}

/* The ray's constants, as prt__rayx8t holds them, in sixteen lanes, the origin in the
 * order kx, ky, kz (comp). */
typedef struct lg16_ray {
    __m512 org[3], sx, sy, sz, tnear;
    int comp[3];
} lg16_ray;

LG16_INLINE void lg16_ray_init(lg16_ray *x, const prt__rayx *r) {
    x->comp[0] = r->kx, x->comp[1] = r->ky, x->comp[2] = r->kz;
    for (int i = 0; i < 3; i++) x->org[i] = _mm512_set1_ps(r->org[x->comp[i]]);
    x->sx = _mm512_set1_ps(r->sx), x->sy = _mm512_set1_ps(r->sy), x->sz = _mm512_set1_ps(r->sz);
    x->tnear = _mm512_set1_ps(r->tnear);
}

/* lg_shear's operations on both halves (w in the ray's component order). */
LG16_INLINE void lg16_shear(__m512 w[3][2], const lg16_ray *r, __m512 x[2], __m512 y[2], __m512 z[2]) {
    for (int h = 0; h < 2; h++) {
        const __m512 az = _mm512_sub_ps(w[2][h], r->org[2]);
        x[h] = _mm512_sub_ps(_mm512_sub_ps(w[0][h], r->org[0]), _mm512_mul_ps(r->sx, az));
        y[h] = _mm512_sub_ps(_mm512_sub_ps(w[1][h], r->org[1]), _mm512_mul_ps(r->sy, az));
        z[h] = _mm512_mul_ps(r->sz, az);
    }
}

/* The vertices of the sixteen triangles of cell rows 2 p (lanes 0-7) and 2 p + 1 (lanes
 * 8-15) as lanes of the two halves, lg_row_index's choice by each cell's diagonal bit: lane
 * l = 8 r + 2 x + h of a pass reads bit l / 2 of its diagonal byte. With that bit clear,
 * (x, x + 1, x + 6) for h = 0 and (x, x + 6, x + 5) for h = 1, rows up from the row's first
 * lane; set, the first vertex of h = 1 moves to x + 1 and the third of h = 0 to x + 5. */
static const int32_t lg16_lane_shift[16] = {0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7};
static const int32_t lg16_h[16] = {0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1};
static const int32_t lg16_first[3][16] = {{0, 0, 1, 1, 2, 2, 3, 3, 5, 5, 6, 6, 7, 7, 8, 8},
                                          {1, 6, 2, 7, 3, 8, 4, 9, 6, 11, 7, 12, 8, 13, 9, 14},
                                          {6, 5, 7, 6, 8, 7, 9, 8, 11, 10, 12, 11, 13, 12, 14, 13}};

LG16_INLINE void lg16_indices(unsigned diag, int p, __m512i *ia, __m512i *ib, __m512i *ic) {
    const __m512i one = _mm512_set1_epi32(1), row = _mm512_set1_epi32(10 * p);
    const __m512i odd = _mm512_and_si512(
        _mm512_srlv_epi32(_mm512_set1_epi32((int)(diag >> (8 * p) & 255)), _mm512_loadu_si512((const void *)lg16_lane_shift)), one);
    const __m512i h = _mm512_loadu_si512((const void *)lg16_h);
    *ia = _mm512_add_epi32(_mm512_add_epi32(_mm512_loadu_si512((const void *)lg16_first[0]), row), _mm512_and_si512(odd, h));
    *ib = _mm512_add_epi32(_mm512_loadu_si512((const void *)lg16_first[1]), row);
    *ic = _mm512_sub_epi32(_mm512_add_epi32(_mm512_loadu_si512((const void *)lg16_first[2]), row), _mm512_andnot_si512(h, odd));
}

/* The edge functions of the lanes in zero, where one was 0, again in double precision, as
 * prt__tri8_fix_edges does (a: ax, ay, bx, by, cx, cy; e: u, v, w). Its operands go
 * through memory only on this path, so the hot path keeps them in registers. */
PRT_NOINLINE static void lg16_fix_edges(unsigned zero, const float a[6][16], float e[3][16]) {
    for (unsigned m = zero; m; m &= m - 1) {
        const int i = __builtin_ctz(m);
        prt__tri_edges_double(a[0][i], a[1][i], a[2][i], a[3][i], a[4][i], a[5][i], &e[0][i], &e[1][i], &e[2][i]);
    }
}

/* lg_row_hit's watertight test on the sixteen triangles of pass p (cell rows 2 p, 2 p + 1)
 * of the lanes in valid: the mask of those hit in [tnear, tfar], with t (+inf elsewhere),
 * u and v set when non-zero. */
LG16_INLINE __mmask16 lg16_rows_hit(const __m512 x[2], const __m512 y[2], const __m512 z[2], unsigned diag, int p,
                                    __mmask16 valid, const lg16_ray *r, __m512 tfar, __m512 *t_out, __m512 *u_out,
                                    __m512 *v_out) {
    __m512i ia, ib, ic;
    lg16_indices(diag, p, &ia, &ib, &ic);
    const __m512 ax = _mm512_permutex2var_ps(x[0], ia, x[1]), ay = _mm512_permutex2var_ps(y[0], ia, y[1]);
    const __m512 bx = _mm512_permutex2var_ps(x[0], ib, x[1]), by = _mm512_permutex2var_ps(y[0], ib, y[1]);
    const __m512 cx = _mm512_permutex2var_ps(x[0], ic, x[1]), cy = _mm512_permutex2var_ps(y[0], ic, y[1]);
    __m512 u = _mm512_sub_ps(_mm512_mul_ps(cx, by), _mm512_mul_ps(cy, bx));
    __m512 v = _mm512_sub_ps(_mm512_mul_ps(ax, cy), _mm512_mul_ps(ay, cx));
    __m512 w = _mm512_sub_ps(_mm512_mul_ps(bx, ay), _mm512_mul_ps(by, ax));
    const __m512 zero = _mm512_setzero_ps();
    const __mmask16 any_zero = (_mm512_cmp_ps_mask(u, zero, _CMP_EQ_OQ) | _mm512_cmp_ps_mask(v, zero, _CMP_EQ_OQ) |
                                _mm512_cmp_ps_mask(w, zero, _CMP_EQ_OQ)) & valid;
    if (PRT_UNLIKELY(any_zero)) {
        float a[6][16], e[3][16];
        _mm512_storeu_ps(a[0], ax), _mm512_storeu_ps(a[1], ay), _mm512_storeu_ps(a[2], bx);
        _mm512_storeu_ps(a[3], by), _mm512_storeu_ps(a[4], cx), _mm512_storeu_ps(a[5], cy);
        _mm512_storeu_ps(e[0], u), _mm512_storeu_ps(e[1], v), _mm512_storeu_ps(e[2], w);
        lg16_fix_edges(any_zero, (const float(*)[16])a, e);
        u = _mm512_loadu_ps(e[0]), v = _mm512_loadu_ps(e[1]), w = _mm512_loadu_ps(e[2]);
    }
    const __mmask16 mixed = _mm512_cmp_ps_mask(_mm512_min_ps(_mm512_min_ps(u, v), w), zero, _CMP_LT_OQ) &
                            _mm512_cmp_ps_mask(_mm512_max_ps(_mm512_max_ps(u, v), w), zero, _CMP_GT_OQ);
    const __m512 det = _mm512_add_ps(_mm512_add_ps(u, v), w);
    const __mmask16 inside = valid & ~mixed & _mm512_cmp_ps_mask(det, zero, _CMP_NEQ_UQ);
    if (!inside) return 0;
    const __m512 az = _mm512_permutex2var_ps(z[0], ia, z[1]), bz = _mm512_permutex2var_ps(z[0], ib, z[1]);
    const __m512 cz = _mm512_permutex2var_ps(z[0], ic, z[1]);
    const __m512 T = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(u, az), _mm512_mul_ps(v, bz)), _mm512_mul_ps(w, cz));
    const __m512 t = _mm512_div_ps(T, det);
    const __mmask16 ok =
        inside & _mm512_cmp_ps_mask(t, r->tnear, _CMP_GE_OQ) & _mm512_cmp_ps_mask(t, tfar, _CMP_LE_OQ);
    if (ok) {
        *t_out = _mm512_mask_blend_ps(ok, _mm512_set1_ps(INFINITY), t);
        *u_out = _mm512_div_ps(v, det);
        *v_out = _mm512_div_ps(w, det);
    }
    return ok;
}

/* The triangle lanes of one cell row holding a cell (2 rx of 8). */
static inline __mmask16 lg16_row_lanes(int rx) { return (__mmask16)((1u << (2 * rx)) - 1); }

/* Closest hit of one ray with a sub-grid record: lg_record_hit's answer. Both rows of a
 * pass are tested against the same tfar and taken together (the nearest, ties to the
 * smaller id), which is what taking them one after the other gives. */
LG16_INLINE void lg16_grid_hit(const lg_grid_rec *g, const lg16_ray *r, const bvh_shared *sh, prt__hitx *h) {
    __m512 w[3][2], x[2], y[2], z[2];
    lg16_decode(g, r->comp, w);
    lg16_shear(w, r, x, y, z);
    const int rx = lg_rx(g), ry = lg_ry(g);
    const __mmask16 row = lg16_row_lanes(rx);
    for (int p = 0; 2 * p < ry; p++) {
        const __mmask16 valid = (__mmask16)(row | (2 * p + 1 < ry ? row << 8 : 0));
        __m512 t, u, v;
        const __mmask16 mask = lg16_rows_hit(x, y, z, g->diag, p, valid, r, _mm512_set1_ps(h->t), &t, &u, &v);
        if (!mask) continue;
        float tt[16], uu[16], vv[16];
        uint32_t ids[16];
        _mm512_storeu_ps(tt, t), _mm512_storeu_ps(uu, u), _mm512_storeu_ps(vv, v);
        for (unsigned l = mask; l; l &= l - 1) {
            const int lane = __builtin_ctz(l), lr = 2 * p + (lane >> 3), k = 2 * (lr * rx + (lane >> 1 & 3)) + (lane & 1);
            ids[lane] = g->first + (uint32_t)k;
            lg_rotate_uv(g->rot[k >> 2 & 7] >> (2 * (k & 3)) & 3, &uu[lane], &vv[lane]);
        }
        bvh_take_nearest_seq(h, tt, uu, vv, ids, mask, _mm512_reduce_min_ps(t), sh);
    }
}

LG16_INLINE void lg16_records_hit(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrec_ray *c,
                                   const lg16_ray *r16, prt__hitx *h) {
    for (uint32_t i = 0; i < n; i++, leaf += LG_RECORD_BYTES) {
        if (leaf[127] == LG_KIND_TRIS) {
            lg_decoded d;
            lg_record_decode(leaf, &d);
            lg_record_hit(leaf, &d, r, c, h);
        } else {
            lg16_grid_hit((const lg_grid_rec *)leaf, r16, c->sh, h);
        }
    }
}

LG16 void lg_records16_hit(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrec_ray *c, prt__hitx *h) {
    lg16_ray r16;
    lg16_ray_init(&r16, r);
    lg16_records_hit(leaf, n, r, c, &r16, h);
}

LG16 bool lg_records16_block(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrec_ray *c, float tfar) {
    lg16_ray r16;
    lg16_ray_init(&r16, r);
    const __m512 tf = _mm512_set1_ps(tfar);
    for (uint32_t i = 0; i < n; i++, leaf += LG_RECORD_BYTES) {
        if (leaf[127] == LG_KIND_TRIS) {
            lg_decoded d;
            lg_record_decode(leaf, &d);
            if (lg_record_blocks(&d, r, c, tfar)) return true;
            continue;
        }
        const lg_grid_rec *g = (const lg_grid_rec *)leaf;
        __m512 w[3][2], x[2], y[2], z[2];
        lg16_decode(g, r16.comp, w);
        lg16_shear(w, &r16, x, y, z);
        const int rx = lg_rx(g), ry = lg_ry(g);
        const __mmask16 row = lg16_row_lanes(rx);
        for (int p = 0; 2 * p < ry; p++) {
            const __mmask16 valid = (__mmask16)(row | (2 * p + 1 < ry ? row << 8 : 0));
            __m512 t, u, v;
            if (lg16_rows_hit(x, y, z, g->diag, p, valid, &r16, tf, &t, &u, &v)) return true;
        }
    }
    return false;
}

/* The decoded vertices in lg_grid_decode's layout, for the tests. */
LG16 void lg_grid_decode16(const lg_grid_rec *g, float out[3][5][8]) {
    __m512 w[3][2];
    const int comp[3] = {0, 1, 2};
    lg16_decode(g, comp, w);
    float lanes[3][32];
    for (int k = 0; k < 3; k++) _mm512_storeu_ps(lanes[k], w[k][0]), _mm512_storeu_ps(lanes[k] + 16, w[k][1]);
    for (int k = 0; k < 3; k++)
        for (int j = 0; j < 5; j++)
            for (int i = 0; i < 8; i++) out[k][j][i] = i < 5 ? lanes[k][5 * j + i] : NAN;
}

/* The wide8 template's walks over the 16-lane kernels, inlined. */
typedef struct lgrec16_ray {
    lgrec_ray c; /* exact-triangle records */
    lg16_ray r16;
} lgrec16_ray;
enum { lgrec16_block = lgrec_block, lgrec16_align = lgrec_align, lgrec16_seq_ids = lgrec_seq_ids };
static inline size_t lgrec16_leaf_bytes(uint32_t n) { return lgrec_leaf_bytes(n); }
LG16_INLINE void lgrec16_ray_init(lgrec16_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    lgrec_ray_init(&c->c, r, sh);
    lg16_ray_init(&c->r16, r);
}
LG16_INLINE void lgrec16_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrec16_ray *c, prt__hitx *h) {
    lg16_records_hit(leaf, n, r, &c->c, &c->r16, h);
}
LG16_INLINE bool lgrec16_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrec16_ray *c, float tfar) {
    return lg_records16_block(leaf, n, r, &c->c, tfar);
}
#define CODEC lgrec16
#include "bvh/layouts/wide8_kernels.inc"
#undef CODEC

void lg_trace_stream_w16(const uint8_t *blob, const bvh_shared *sh, prt_ray *rays, prt_hit *hits, size_t n) {
    wide8_stream_lgrec16(blob, sh, rays, hits, n);
}
bool lg_trace_any_w16(const uint8_t *blob, const bvh_shared *sh, const prt_ray *r) {
    return wide8_occluded1_lgrec16(blob, sh, r);
}
/* Closest-hit single rays take lossygrid's own walk (lg_trace1_w16, traverse.c). */
static __attribute__((unused)) void (*const lg_template16_unused)(const uint8_t *, const bvh_shared *, prt_ray *,
                                                                  prt_hit *) = wide8_intersect1_lgrec16;

#if defined(__clang__)
#pragma clang attribute pop
#endif

#else
void lg_records16_hit(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrec_ray *c, prt__hitx *h) {
    lgrec_intersect(leaf, n, r, c, h);
}
bool lg_records16_block(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const lgrec_ray *c, float tfar) {
    return lgrec_occluded(leaf, n, r, c, tfar);
}
void lg_grid_decode16(const lg_grid_rec *g, float out[3][5][8]) {
    lg_grid_vertices v;
    lg_grid_decode(g, &v);
    memcpy(out, &v, sizeof v);
}
void lg_trace_stream_w16(const uint8_t *blob, const bvh_shared *sh, prt_ray *rays, prt_hit *hits, size_t n) {
    lg_trace_stream(blob, sh, rays, hits, n);
}
bool lg_trace_any_w16(const uint8_t *blob, const bvh_shared *sh, const prt_ray *r) { return lg_trace_any(blob, sh, r); }
#endif
