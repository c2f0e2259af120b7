/* BitPack vertices (Rouwé 2019, §3.4): a vertex in one u64, 21 bits per component,
 * x | y << 21 | z << 42, decoded as lo + q * step with step = (hi - lo) / (2^21 - 1) over a
 * box. The buffer of such vertices that the Indexed BitPack codecs share (§3.8, §3.9) is a
 * 32-byte head (bpv_header) and the u64 entries. Used by idx16/idx32-bitpack-soa4 (buffer),
 * bitpack (words in the leaves, box per leaf) and idx8-bitpack-soa4 (buffer in leaf order). */
#ifndef PRT_BVH_CODECS_BITPACK_VERTICES_H
#define PRT_BVH_CODECS_BITPACK_VERTICES_H

#include "bvh/codecs/codec.h"
#include "core/simd.h"
#include "geom/triangle.h"

#include <math.h>

#define BPV_BITS 21
#define BPV_MASK ((1u << BPV_BITS) - 1)

/* Head of a shared buffer (32 bytes, idx8-bitpack-soa4's too), followed by `count` u64. */
typedef struct bpv_header {
    float lo[3], step[3]; /* vertex = lo + q * step, per component */
    float vertex_error;   /* the largest decoded-to-mesh vertex distance */
    uint32_t count;
} bpv_header;

_Static_assert(sizeof(bpv_header) == 32, "bitpack vertex buffer head is 32 bytes");

/* One component as decoded: the same expression everywhere (kernels, error). */
static inline float bpv_decode(float lo, float step, uint32_t q) { return lo + (float)q * step; }

/* Quantization over the box [lo, hi]: lo and step per component. */
static inline void bpv_grid(const float lo[3], const float hi[3], float out_lo[3], float step[3]) {
    for (int k = 0; k < 3; k++) out_lo[k] = lo[k], step[k] = (hi[k] - lo[k]) / (float)BPV_MASK;
}

/* v packed to the nearest grid point; *d2 receives the squared decoded-to-v distance. */
static inline uint64_t bpv_pack(const float v[3], const float lo[3], const float step[3], double *d2) {
    uint64_t word = 0;
    *d2 = 0;
    for (int k = 0; k < 3; k++) {
        float q = step[k] > 0 ? roundf((v[k] - lo[k]) / step[k]) : 0.0f;
        uint32_t qi = q < 0 ? 0 : q > (float)BPV_MASK ? BPV_MASK : (uint32_t)q;
        word |= (uint64_t)qi << (BPV_BITS * k);
        double d = (double)bpv_decode(lo[k], step[k], qi) - (double)v[k];
        *d2 += d * d;
    }
    return word;
}

/* A distance as a float that is not below it. */
static inline float bpv_round_up(double err) {
    float f = (float)err;
    return (double)f < err ? nextafterf(f, INFINITY) : f;
}

/* The shared buffer of count entries, entry e holding vertex source[e] of m (source NULL:
 * entry e is vertex e), quantized over the box lo, hi. */
static inline prt_status bpv_buffer_build_in(const prt_mesh *m, const uint32_t *source, uint32_t count,
                                             const float lo[3], const float hi[3], uint8_t **data, size_t *size) {
    bpv_header hd = {{0}, {0}, 0, count};
    bpv_grid(lo, hi, hd.lo, hd.step);
    const size_t bytes = sizeof hd + (size_t)count * 8;
    uint8_t *out = prt__alloc(bytes);
    if (!out) return prt__fail(PRT_ERROR_NOMEM, "out of memory for a %zu-byte vertex buffer", bytes);
    double err = 0;
    for (uint32_t e = 0; e < count; e++) {
        double d2;
        uint64_t word = bpv_pack(m->vertices + 3 * (size_t)(source ? source[e] : e), hd.lo, hd.step, &d2);
        memcpy(out + sizeof hd + 8 * (size_t)e, &word, 8);
        if (d2 > err * err) err = sqrt(d2);
    }
    hd.vertex_error = bpv_round_up(err);
    memcpy(out, &hd, sizeof hd);
    *data = out;
    *size = bytes;
    return PRT_OK;
}

/* The same over the bounds of m's triangles. */
static inline prt_status bpv_buffer_build(const prt_mesh *m, const uint32_t *source, uint32_t count, uint8_t **data,
                                          size_t *size) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    return bpv_buffer_build_in(m, source, count, lo, hi, data, size);
}

/* Loading: the buffer is what its head says, with a finite grid. */
static inline bool bpv_buffer_valid(const bvh_shared *sh, bpv_header *hd) {
    if (sh->size < sizeof *hd) return false;
    memcpy(hd, sh->data, sizeof *hd);
    if (sh->size != sizeof *hd + 8 * (size_t)hd->count) return false;
    for (int k = 0; k < 3; k++)
        if (!isfinite(hd->lo[k]) || !isfinite(hd->step[k]) || hd->step[k] < 0) return false;
    return true;
}

static inline double bpv_buffer_error(const bvh_shared *sh) {
    bpv_header hd;
    if (sh->size < sizeof hd) return 0;
    memcpy(&hd, sh->data, sizeof hd);
    return hd.vertex_error;
}

/* The decodes below without SIMD: w[v * lanes + l] is vertex v of lane l. */
static inline void bpv_decode_lanes(const uint64_t *w, int lanes, const float lo[3], const float step[3],
                                    const int comp[3], const int32_t *pad, float *p) {
    for (int v = 0; v < 3; v++)
        for (int l = 0; l < lanes; l++)
            for (int k = 0; k < 3; k++)
                p[lanes * (3 * v + k) + l] =
                    pad[l] && v < 2 && k == 2
                        ? NAN
                        : bpv_decode(lo[k], step[k], (uint32_t)(w[v * lanes + l] >> (BPV_BITS * comp[k])) & BPV_MASK);
}

/* Decode the 12 words of a block of four triangles (w[v][lane]: vertex v of each) into the
 * SOA form the 4-wide kernel reads, row k of each vertex holding component comp[k] (the
 * caller's order: the watertight test's axes kx, ky, kz, so that its inputs sit at fixed
 * places and stay in registers), decoded with lo[k] and step[k] given in that order too.
 * Lanes in pad get NaN for kz of vertices 0 and 1 (padding lanes repeat one vertex: their
 * exactly zero edge functions would send the block to the double-precision fallback): every
 * sheared coordinate but c's, so all three edge functions, t and det are NaN, and the lane
 * never hits, as with nine NaN coordinates, for 2 blends instead of 9. Per vertex, the four
 * words in one register, each component shifted and masked out and widened to float,
 * then lo + q * step as bpv_decode computes it (same bits). */
PRT_INLINE void bpv_decode4(const uint64_t w[3][4], const float lo[3], const float step[3], const int comp[3], vi4 pad,
                            float p[36]) {
    const vf4 nan = vf4_set1(NAN);
#if defined(__AVX2__)
    const __m256i mask = _mm256_set1_epi64x(BPV_MASK), low = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
    for (int v = 0; v < 3; v++) {
        __m256i words;
        memcpy(&words, w[v], sizeof words);
        for (int k = 0; k < 3; k++) {
            const __m256i q = _mm256_and_si256(_mm256_srl_epi64(words, _mm_cvtsi32_si128(BPV_BITS * comp[k])), mask);
            const vf4 qf = (vf4)_mm_cvtepi32_ps(_mm256_castsi256_si128(_mm256_permutevar8x32_epi32(q, low)));
            vf4 x = vf4_set1(lo[k]) + qf * vf4_set1(step[k]);
            if (v < 2 && k == 2) x = vf4_select(pad, nan, x); /* enough: see above */
            memcpy(p + 4 * (3 * v + k), &x, sizeof x);
        }
    }
#else
    int32_t pads[4];
    memcpy(pads, &pad, sizeof pads);
    bpv_decode_lanes(&w[0][0], 4, lo, step, comp, pads, p);
    (void)nan;
#endif
}

/* bpv_decode4 for two blocks at once (w[v][0..3] the first block's words, w[v][4..7] the
 * second's), into the SOA form of the 8-wide test: each lane gets bpv_decode4's bits. */
PRT_INLINE void bpv_decode8(const uint64_t w[3][8], const float lo[3], const float step[3], const int comp[3], vi8 pad,
                            float p[72]) {
    const vf8 nan = vf8_set1(NAN);
#if defined(__AVX2__)
    /* A component of both blocks' words is under 2^21: the second block's shifted into the
     * upper half of each 64-bit lane, then the halves put in lane order. */
    const __m256i mask = _mm256_set1_epi64x(BPV_MASK), order = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
    for (int v = 0; v < 3; v++) {
        __m256i wa, wb;
        memcpy(&wa, w[v], sizeof wa), memcpy(&wb, w[v] + 4, sizeof wb);
        for (int k = 0; k < 3; k++) {
            const __m128i sh = _mm_cvtsi32_si128(BPV_BITS * comp[k]);
            const __m256i qa = _mm256_and_si256(_mm256_srl_epi64(wa, sh), mask);
            const __m256i qb = _mm256_and_si256(_mm256_srl_epi64(wb, sh), mask);
            const __m256i q = _mm256_permutevar8x32_epi32(_mm256_or_si256(qa, _mm256_slli_epi64(qb, 32)), order);
            vf8 x = vf8_set1(lo[k]) + (vf8)_mm256_cvtepi32_ps(q) * vf8_set1(step[k]);
            if (v < 2 && k == 2) x = vf8_select(pad, nan, x); /* bpv_decode4 says why */
            memcpy(p + 8 * (3 * v + k), &x, sizeof x);
        }
    }
#else
    int32_t pads[8];
    memcpy(pads, &pad, sizeof pads);
    bpv_decode_lanes(&w[0][0], 8, lo, step, comp, pads, p);
    (void)nan;
#endif
}

/* Per-ray constants of the Indexed BitPack codecs' leaves (idx8/idx16/idx32-bitpack-soa4):
 * the buffer's grid in the watertight test's axis order kx, ky, kz (bpv_decode4's comp),
 * the origin in that order too. */
typedef struct bpv_ray {
    prt__rayx4t r4;          /* for the 4-wide test, or */
    prt__rayx8t r8;          /* for the 8-wide one (idx8-bitpack-soa4: two blocks at a time) */
    const uint8_t *vertices; /* the u64 entries */
    float lo[3], step[3];    /* of components comp[0], comp[1], comp[2] */
    int comp[3];             /* kx, ky, kz */
    const bvh_shared *sh;
} bpv_ray;

PRT_INLINE void bpv_ray_init(bpv_ray *c, const prt__rayx *r, const bvh_shared *sh, int lanes) {
    if (lanes == 8) prt__rayx8t_init_renamed(&c->r8, r);
    else prt__rayx4t_init_renamed(&c->r4, r);
    bpv_header hd;
    memcpy(&hd, sh->data, sizeof hd);
    c->comp[0] = r->kx, c->comp[1] = r->ky, c->comp[2] = r->kz;
    for (int k = 0; k < 3; k++) c->lo[k] = hd.lo[c->comp[k]], c->step[k] = hd.step[c->comp[k]];
    c->vertices = sh->data + sizeof hd;
    c->sh = sh;
}

/* The constants bpv_ray_init sets for the gathers, with the axes not renamed (comp 0, 1, 2):
 * for the decode functions, which give vertices in world order (the same bits). */
static inline void bpv_ray_world(bpv_ray *c, const bvh_shared *sh) {
    memset(c, 0, sizeof *c);
    bpv_header hd;
    memcpy(&hd, sh->data, sizeof hd);
    for (int k = 0; k < 3; k++) c->comp[k] = k, c->lo[k] = hd.lo[k], c->step[k] = hd.step[k];
    c->vertices = sh->data + sizeof hd;
    c->sh = sh;
}

/* Lanes whose vertex 0 and vertex 1 are the same index (padding), as an all-ones mask. */
static inline vi4 bpv_same_index4(const uint32_t i0[4], const uint32_t i1[4]) {
    return (vi4){-(int32_t)(i0[0] == i1[0]), -(int32_t)(i0[1] == i1[1]), -(int32_t)(i0[2] == i1[2]),
                 -(int32_t)(i0[3] == i1[3])};
}

#endif
