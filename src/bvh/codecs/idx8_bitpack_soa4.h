/* Indexed8BitPackSOA4 (Rouwé 2019, §3.9): the smallest codec. One tree-wide buffer of
 * compressed vertices, a u64 each (21 bits per component over the mesh bounds, §3.4), laid
 * out in leaf order; per leaf the buffer position its indices count from and its first
 * triangle id (seq_ids), then per block of four triangles their 8-bit vertex indices in
 * SOA order (vertex 0 of the four, vertex 1, vertex 2): 8 + 12 bytes per block.
 *
 * The buffer and the leaf format are vertex_window.h's (greedy reuse in a 192-entry
 * window, so every leaf reaches its vertices with 8-bit indices). Lossy: every vertex lies
 * within the stated vertex error of its mesh vertex; a mesh vertex appended twice decodes
 * to the same bits both times, so neighbouring triangles stay watertight. Padding lanes
 * repeat one vertex three times: zero area, never hit (and turned to NaN when decoded). */
#ifndef PRT_BVH_CODECS_IDX8_BITPACK_SOA4_H
#define PRT_BVH_CODECS_IDX8_BITPACK_SOA4_H

#include "bvh/codecs/codec.h"
#include "bvh/codecs/nearest.h"
#include "bvh/codecs/vertex_window.h"
#include "geom/triangle.h"

#include <assert.h>
#include <math.h>

#define IDX8BP_HEAD_BYTES VW_HEAD_BYTES
#define IDX8BP_BLOCK_BYTES VW_BLOCK_BYTES
#define IDX8BP_BITS 21
#define IDX8BP_MASK ((1u << IDX8BP_BITS) - 1)
enum { idx8_bitpack_soa4_block = 4, idx8_bitpack_soa4_align = 4, idx8_bitpack_soa4_seq_ids = 1 };

/* Head of the shared buffer (32 bytes), followed by `count` u64 vertices. */
typedef struct idx8bp_header {
    float lo[3], step[3]; /* vertex = lo + q * step, per component */
    float vertex_error;   /* the largest decoded-to-mesh vertex distance */
    uint32_t count;
} idx8bp_header;

_Static_assert(sizeof(idx8bp_header) == 32, "idx8-bitpack-soa4 header is 32 bytes");

typedef struct idx8_bitpack_soa4_ray {
    prt__rayx4t r4;
    const uint8_t *vertices; /* the u64 entries */
    float lo[3], step[3];
    const bvh_shared *sh;
} idx8_bitpack_soa4_ray;

static inline size_t idx8_bitpack_soa4_leaf_bytes(uint32_t n) { return vw_leaf_bytes(n); }

/* One component as decoded: the same expression everywhere (kernel, error). */
static inline float idx8bp_decode(float lo, float step, uint32_t q) { return lo + (float)q * step; }

/* --- building ------------------------------------------------------------------------- */

/* m: triangles in leaf order, rewritten in place to buffer positions. */
static inline prt_status idx8_bitpack_soa4_shared_remap(prt_mesh *m, uint8_t **data, size_t *size) {
    idx8bp_header hd = {{0}, {0}, 0, 0};
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi); /* before the indices become buffer positions */
    for (int k = 0; k < 3; k++) hd.lo[k] = lo[k], hd.step[k] = (hi[k] - lo[k]) / (float)IDX8BP_MASK;
    uint32_t *source = NULL, len = 0;
    prt_status s = vw_build(m, "idx8-bitpack-soa4", &source, &len);
    if (s) return s;
    hd.count = len;
    const size_t bytes = sizeof hd + (size_t)len * 8;
    uint8_t *out = prt__alloc(bytes);
    if (!out) {
        prt__free(source);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for a %zu-byte vertex buffer", bytes);
    }
    double err = 0;
    for (uint32_t e = 0; e < len; e++) {
        const float *v = m->vertices + 3 * (size_t)source[e];
        uint64_t word = 0;
        double d2 = 0;
        for (int k = 0; k < 3; k++) {
            float q = hd.step[k] > 0 ? roundf((v[k] - hd.lo[k]) / hd.step[k]) : 0.0f;
            uint32_t qi = q < 0 ? 0 : q > (float)IDX8BP_MASK ? IDX8BP_MASK : (uint32_t)q;
            word |= (uint64_t)qi << (IDX8BP_BITS * k);
            double d = (double)idx8bp_decode(hd.lo[k], hd.step[k], qi) - (double)v[k];
            d2 += d * d;
        }
        memcpy(out + sizeof hd + 8 * (size_t)e, &word, 8);
        if (d2 > err * err) err = sqrt(d2);
    }
    prt__free(source);
    /* Stated as a float that is not below the true maximum. */
    hd.vertex_error = (float)err;
    if ((double)hd.vertex_error < err) hd.vertex_error = nextafterf(hd.vertex_error, INFINITY);
    memcpy(out, &hd, sizeof hd);
    *data = out;
    *size = bytes;
    return PRT_OK;
}

/* ids are consecutive (seq_ids) and m's indices are buffer positions (shared_remap). */
static inline void idx8_bitpack_soa4_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    vw_encode(dst, m, ids, n);
}

#define idx8_bitpack_soa4_shared_build NULL

static inline double idx8_bitpack_soa4_vertex_error(const bvh_shared *sh) {
    idx8bp_header hd;
    if (sh->size < sizeof hd) return 0;
    memcpy(&hd, sh->data, sizeof hd);
    return hd.vertex_error;
}

/* The buffer is whole and every index of the leaf names an entry of it. */
static inline bool idx8_bitpack_soa4_leaf_valid(const uint8_t *leaf, uint32_t n, const bvh_shared *sh) {
    idx8bp_header hd;
    if (sh->size < sizeof hd) return false;
    memcpy(&hd, sh->data, sizeof hd);
    if (sh->size != sizeof hd + 8 * (size_t)hd.count) return false;
    for (int k = 0; k < 3; k++)
        if (!isfinite(hd.lo[k]) || !isfinite(hd.step[k]) || hd.step[k] < 0) return false;
    return vw_leaf_valid(leaf, n, hd.count, sh);
}

/* --- traversal ------------------------------------------------------------------------ */

static inline void idx8_bitpack_soa4_ray_init(idx8_bitpack_soa4_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    prt__rayx4t_init(&c->r4, r);
    idx8bp_header hd;
    memcpy(&hd, sh->data, sizeof hd);
    for (int k = 0; k < 3; k++) c->lo[k] = hd.lo[k], c->step[k] = hd.step[k];
    c->vertices = sh->data + sizeof hd;
    c->sh = sh;
}

/* Decode a block's 12 vertices into the SOA form the SIMD kernel reads: per vertex of the
 * four triangles, the four words in one register, each component masked out and widened
 * to float, then lo + q * step as idx8bp_decode computes it (same bits). */
PRT_INLINE void idx8bp_gather(const uint8_t *block, const uint8_t *base, const idx8_bitpack_soa4_ray *c, float p[36]) {
    const vi4 pad = vw_padding(block); /* NaN: never hit, and no zero edge functions */
    const vf4 nan = vf4_set1(NAN);
#if defined(__AVX2__)
    const __m256i mask = _mm256_set1_epi64x(IDX8BP_MASK), low = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
    for (int v = 0; v < 3; v++) {
        long long w[4];
        for (int l = 0; l < 4; l++) memcpy(&w[l], base + 8 * (size_t)block[4 * v + l], 8);
        const __m256i words = _mm256_setr_epi64x(w[0], w[1], w[2], w[3]);
        for (int k = 0; k < 3; k++) {
            const __m256i q = _mm256_and_si256(_mm256_srli_epi64(words, IDX8BP_BITS * k), mask);
            const vf4 qf = (vf4)_mm_cvtepi32_ps(_mm256_castsi256_si128(_mm256_permutevar8x32_epi32(q, low)));
            const vf4 x = vf4_select(pad, nan, vf4_set1(c->lo[k]) + qf * vf4_set1(c->step[k]));
            memcpy(p + 4 * (3 * v + k), &x, sizeof x);
        }
    }
#else
    for (int v = 0; v < 3; v++)
        for (int l = 0; l < 4; l++) {
            uint64_t w;
            memcpy(&w, base + 8 * (size_t)block[4 * v + l], 8);
            for (int k = 0; k < 3; k++)
                p[4 * (3 * v + k) + l] =
                    pad[l] ? NAN : idx8bp_decode(c->lo[k], c->step[k], (uint32_t)(w >> (IDX8BP_BITS * k)) & IDX8BP_MASK);
        }
    (void)nan;
#endif
}

PRT_INLINE void idx8_bitpack_soa4_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r,
                                            const idx8_bitpack_soa4_ray *c, prt__hitx *h) {
    uint32_t first, id0;
    memcpy(&first, leaf, 4);
    memcpy(&id0, leaf + 4, 4);
    const uint8_t *base = c->vertices + 8 * (size_t)first;
    leaf += IDX8BP_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += IDX8BP_BLOCK_BYTES) {
        float p[36];
        idx8bp_gather(leaf, base, c, p);
        vf4 t, u, v;
        int mask = prt__tri4_hit(r, &c->r4, p, vf4_set1(h->t), &t, &u, &v);
        if (!mask) continue;
        const uint32_t ids[4] = {id0 + 4 * b, id0 + 4 * b + 1, id0 + 4 * b + 2, id0 + 4 * b + 3};
        float tt[4], uu[4], vv[4];
        memcpy(tt, &t, sizeof tt), memcpy(uu, &u, sizeof uu), memcpy(vv, &v, sizeof vv);
        bvh_take_nearest_seq(h, tt, uu, vv, ids, (unsigned)mask, vf4_hmin(t), c->sh);
    }
}

PRT_INLINE bool idx8_bitpack_soa4_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r,
                                           const idx8_bitpack_soa4_ray *c, float tfar) {
    uint32_t first;
    memcpy(&first, leaf, 4);
    const uint8_t *base = c->vertices + 8 * (size_t)first;
    leaf += IDX8BP_HEAD_BYTES;
    const vf4 tf = vf4_set1(tfar);
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += IDX8BP_BLOCK_BYTES) {
        float p[36];
        idx8bp_gather(leaf, base, c, p);
        vf4 t, u, v;
        if (prt__tri4_hit(r, &c->r4, p, tf, &t, &u, &v)) return true;
    }
    return false;
}

#endif
