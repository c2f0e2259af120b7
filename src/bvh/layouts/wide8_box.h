/* The 8-lane box test of the wide8 node (wide8.h): per-ray constants and the slab test
 * on a node's eight decoded child boxes. Shared by the BVH family's wide8 kernels and by
 * every representation that packs its own leaves under wide8 nodes (lossygrid). */
#ifndef PRT_BVH_LAYOUTS_WIDE8_BOX_H
#define PRT_BVH_LAYOUTS_WIDE8_BOX_H

#include "bvh/layouts/wide8.h"
#include "core/simd.h"
#include "geom/ray.h"

/* Per-ray constants of the 8-lane box test, and the blob's header fields. */
typedef struct wide8_ray {
    vf8 org[3], inv[3];
    float tnear;
    int near[3], far[3]; /* row of q holding the near and far plane on each axis */
    uint64_t geometry;
    uint32_t grain;
} wide8_ray;

static inline void wide8_ray_init(wide8_ray *w, const prt__rayx *r, const uint8_t *blob) {
    for (int k = 0; k < 3; k++) {
        w->org[k] = vf8_set1(r->org[k]);
        w->inv[k] = vf8_set1(r->inv[k]);
        w->near[k] = 2 * k + r->neg[k];
        w->far[k] = 2 * k + 1 - r->neg[k];
    }
    w->tnear = r->tnear;
    wide8_header hd;
    memcpy(&hd, blob, sizeof hd);
    w->geometry = hd.geometry;
    w->grain = hd.grain;
}

/* Bit mask of the occupied slots: inner ones and leaves (non-zero meta). */
static inline unsigned wide8_occupied(const wide8_node *n) {
#if defined(__SSE4_1__)
    __m128i meta = _mm_loadl_epi64((const __m128i *)n->meta);
    unsigned zero = (unsigned)_mm_movemask_epi8(_mm_cmpeq_epi8(meta, _mm_setzero_si128())) & 0xFF;
    return n->imask | (~zero & 0xFF);
#else
    unsigned m = n->imask;
    for (int i = 0; i < 8; i++) m |= (unsigned)(n->meta[i] != 0) << i;
    return m;
#endif
}

/* The per-axis scales 2^(e - 127) of a node: its three exponent bytes moved into the
 * exponent field of three lanes at once, then broadcast. */
static inline void wide8_scales(const wide8_node *n, vf8 s[3]) {
#if defined(__AVX2__)
    int32_t bytes;
    memcpy(&bytes, n->e, 4); /* e[0..2] and imask, whose lane is ignored */
    const __m256 e = _mm256_castps128_ps256(_mm_castsi128_ps(_mm_slli_epi32(_mm_cvtepu8_epi32(_mm_cvtsi32_si128(bytes)), 23)));
    s[0] = (vf8)_mm256_permutevar8x32_ps(e, _mm256_set1_epi32(0));
    s[1] = (vf8)_mm256_permutevar8x32_ps(e, _mm256_set1_epi32(1));
    s[2] = (vf8)_mm256_permutevar8x32_ps(e, _mm256_set1_epi32(2));
#else
    for (int k = 0; k < 3; k++) s[k] = vf8_set1(wide8_scale(n->e[k]));
#endif
}

/* The robust slab test of geom/box.h on the eight child boxes, given each axis's near and
 * far planes as decoded. The far distance grows by 2^-21 of its magnitude (one fma on
 * |tmax|), more than the 2 gamma(3) that makes the test conservative (Ize 2013), as
 * box.h's two-sided scaling does. */
static inline unsigned wide8_slab(const vf8 near[3], const vf8 far[3], unsigned occupied, const wide8_ray *w,
                                  float tfar, vf8 *tentry) {
    vf8 tmin = vf8_set1(w->tnear), tmax = vf8_set1(tfar);
    for (int k = 0; k < 3; k++) {
        tmin = vf8_max((near[k] - w->org[k]) * w->inv[k], tmin); /* NaN in the first operand: tmin */
        tmax = vf8_min((far[k] - w->org[k]) * w->inv[k], tmax);
    }
    const vi8 magnitude = (vi8)tmax & (vi8){0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF};
    tmax = vf8_fmadd((vf8)magnitude, vf8_set1(0x1p-21f), tmax);
    *tentry = tmin;
    return (unsigned)vi8_mask(tmin <= tmax) & occupied;
}

/* Plane row `row` of node n decoded (row 2k: lower planes of axis k, 2k + 1: upper), the
 * same operations whether for one ray or for a packet. */
static inline vf8 wide8_plane(const wide8_node *n, const vf8 s[3], int row) {
    return vf8_fmadd(vf8_from_u8(n->q[row]), s[row / 2], vf8_set1(n->p[row / 2]));
}

/* The slab test on the node's eight child boxes for one ray: only its near and far planes
 * are decoded. */
static inline unsigned wide8_box_hit(const wide8_node *n, const wide8_ray *w, float tfar, vf8 *tentry) {
    vf8 s[3], near[3], far[3];
    wide8_scales(n, s);
    for (int k = 0; k < 3; k++) near[k] = wide8_plane(n, s, w->near[k]), far[k] = wide8_plane(n, s, w->far[k]);
    return wide8_slab(near, far, wide8_occupied(n), w, tfar, tentry);
}

#endif
