/* The 8-lane box test of the wide8 node (wide8.h): per-ray constants and the slab test
 * on a node's eight decoded child boxes. Shared by the BVH family's wide8 kernels and by
 * every representation that packs its own leaves under wide8 nodes (lossygrid). */
#ifndef PRT_BVH_LAYOUTS_WIDE8_BOX_H
#define PRT_BVH_LAYOUTS_WIDE8_BOX_H

#include "bvh/layouts/wide8.h"
#include "core/simd.h"
#include "geom/ray.h"

#include <math.h>
#include <stddef.h>

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
    const __m256 e =
        _mm256_castps128_ps256(_mm_castsi128_ps(_mm_slli_epi32(_mm_cvtepu8_epi32(_mm_cvtsi32_si128(bytes)), 23)));
    s[0] = (vf8)_mm256_permutevar8x32_ps(e, _mm256_set1_epi32(0));
    s[1] = (vf8)_mm256_permutevar8x32_ps(e, _mm256_set1_epi32(1));
    s[2] = (vf8)_mm256_permutevar8x32_ps(e, _mm256_set1_epi32(2));
#else
    for (int k = 0; k < 3; k++) s[k] = vf8_set1(wide8_scale(n->e[k]));
#endif
}

/* The far distances grown by WIDE8_FAR_SLACK of their magnitude (one fma on |tmax|): more
 * than the 2 gamma(3) that makes the slab test conservative (Ize 2013). */
#define WIDE8_FAR_SLACK 0x1p-21f
static inline vf8 wide8_far_widen(vf8 tmax) {
    const vi8 magnitude = (vi8)tmax & 0x7FFFFFFF;
    return vf8_fmadd((vf8)magnitude, vf8_set1(WIDE8_FAR_SLACK), tmax);
}

/* wide8_far_widen of one distance, lane for lane the same bits. A stacked entry is culled
 * only when its entry distance exceeds the nearest hit so widened: the node test accepted it
 * against that bound, and an entry distance can round above the t of a hit inside its box
 * (the decoded-plane and wide8_nf_hit tests lower no entry distance), which without the slack
 * dropped a nearer hit or an equal-t tie's smaller id (lossygrid, rays aimed at vertices). */
static inline float wide8_far_widen1(float t) { return fmaf(fabsf(t), WIDE8_FAR_SLACK, t); }

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
    *tentry = tmin;
    return (unsigned)vi8_mask(tmin <= wide8_far_widen(tmax)) & occupied;
}

/* Plane row `row` of node n decoded (row 2k: lower planes of axis k, 2k + 1: upper), the
 * same operations whether for one ray or for a packet. */
static inline vf8 wide8_plane(const wide8_node *n, const vf8 s[3], int row) {
    return vf8_fmadd(vf8_from_u8(n->q[row]), s[row / 2], vf8_set1(n->p[row / 2]));
}

/* The slab test on the node's eight child boxes for one ray: only its near and far planes
 * are decoded. */
PRT_INLINE unsigned wide8_box_hit(const wide8_node *n, const wide8_ray *w, float tfar, vf8 *tentry) {
    vf8 s[3], near[3], far[3];
    wide8_scales(n, s);
    for (int k = 0; k < 3; k++) near[k] = wide8_plane(n, s, w->near[k]), far[k] = wide8_plane(n, s, w->far[k]);
    return wide8_slab(near, far, wide8_occupied(n), w, tfar, tentry);
}

/* wide8_box_hit as WIDE8_NF (lossygrid's single rays, Ray-Strips' top level and packets):
 * the byte offsets of the ray's near and far plane rows kept with its constants,
 * each axis's scale made from its exponent byte in a scalar register, the same operations
 * in the same order (the same hits), and the exit distances returned too (Ray-Strips bounds
 * a strip's s-kd interval by them). */
typedef struct wide8_nfray {
    wide8_ray w;
    size_t qn[3], qf[3];
} wide8_nfray;

static inline void wide8_nfray_init(wide8_nfray *c, const prt__rayx *r, const uint8_t *blob) {
    wide8_ray_init(&c->w, r, blob);
    for (int k = 0; k < 3; k++)
        c->qn[k] = offsetof(wide8_node, q) + 8 * (size_t)c->w.near[k],
        c->qf[k] = offsetof(wide8_node, q) + 8 * (size_t)c->w.far[k];
}

PRT_INLINE unsigned wide8_nf_hit(const wide8_node *n, const wide8_nfray *c, float tfar, vf8 *tn, vf8 *tf) {
    const uint8_t *nb = (const uint8_t *)n;
    vf8 tmin = vf8_set1(c->w.tnear), tmax = vf8_set1(tfar);
    for (int k = 0; k < 3; k++) {
        const vf8 s = vf8_set1(wide8_scale(n->e[k])), p = vf8_set1(n->p[k]);
        const vf8 np = vf8_fmadd(vf8_from_u8(nb + c->qn[k]), s, p), fp = vf8_fmadd(vf8_from_u8(nb + c->qf[k]), s, p);
        tmin = vf8_max((np - c->w.org[k]) * c->w.inv[k], tmin); /* NaN in the first operand: tmin */
        tmax = vf8_min((fp - c->w.org[k]) * c->w.inv[k], tmax);
    }
    tmax = wide8_far_widen(tmax);
    *tn = tmin, *tf = tmax;
    return (unsigned)vi8_mask(tmin <= tmax) & wide8_occupied(n);
}

/* The header fields child_ref reads, without the rest of a wide8_ray. */
static inline void wide8_ray_header(wide8_ray *w, const uint8_t *blob) {
    wide8_header hd;
    memcpy(&hd, blob, sizeof hd);
    w->geometry = hd.geometry;
    w->grain = hd.grain;
}

/* Per-ray constants of the folded box test (wide8_fold_hit), broadcast. */
typedef struct wide8_fold {
    vf8 inv[3];
    vf8 cnear[3], cfar[3]; /* -org * inv, lowered / raised by the error bound E */
    vf8 tnear;
    uint32_t near[3], far[3]; /* byte offset in a node of the q row holding each axis's near / far planes */
} wide8_fold;

/* Whether the folded test suits blob: E (wide8_fold_init) grows with the mesh's distance
 * from the coordinate origin, not with its size, so the fold pays only for a mesh near the
 * origin: true when on every axis |p| <= 768 s at the root, i.e. the root box lies within
 * about three times its extent of the origin; otherwise use wide8_box_hit. */
static inline bool wide8_fold_suits(const uint8_t *blob) {
    wide8_node root;
    memcpy(&root, blob + WIDE8_HEADER_BYTES, sizeof root);
    bool near_origin = true;
    for (int k = 0; k < 3; k++) near_origin &= fabsf(root.p[k]) <= 768.0f * wide8_scale(root.e[k]);
    return near_origin;
}

/* The ray's constants for blob (from its root node). E per axis, 2^-19 (M + |org|) |inv|
 * + 2^-126 with M = |p| + 256 s of the root, bounds the folded test's error at every
 * node: wide8_fold_hit says why. */
PRT_INLINE void wide8_fold_init(wide8_fold *w, const prt__rayx *r, const uint8_t *blob) {
    /* x, y, z in the lanes of 4-lane vectors (lane 3 cleared), then broadcast. */
    const vi4 xyz = {-1, -1, -1, 0}, abs = {0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF};
    const uint8_t *root = blob + WIDE8_HEADER_BYTES;
    vf4 p, org, inv;
    memcpy(&p, root + offsetof(wide8_node, p), 16); /* lane 3: the exponent bytes */
    memcpy(&org, r->org, 16), memcpy(&inv, r->inv, 16);
    p = (vf4)((vi4)p & xyz), org = (vf4)((vi4)org & xyz), inv = (vf4)((vi4)inv & xyz);
    uint32_t eb;
    memcpy(&eb, root + offsetof(wide8_node, e), 4);
    const vi4 s = (vi4){(int32_t)(eb & 0xFF), (int32_t)(eb >> 8 & 0xFF), (int32_t)(eb >> 16 & 0xFF), 0} << 23;
    /* Lane by lane the scalar expressions wide8_fold_hit's proof bounds, in the same order. */
    const vf4 m = (vf4)((vi4)p & abs) + 256.0f * (vf4)s, ainv = (vf4)((vi4)inv & abs);
    vf4 e = (m + (vf4)((vi4)org & abs)) * ainv * 0x1p-19f + 0x1p-126f;
    /* An infinite inv makes every distance on that axis NaN or infinite on the right side
     * (wide8_fold_hit), with no error to bound. */
    e = (vf4)((vi4)e & (ainv != vf4_set1(INFINITY)));
    const vf4 c = -(org * inv), cn = c - e, cf = c + e;
    for (int k = 0; k < 3; k++) {
        w->inv[k] = vf8_set1(inv[k]);
        w->cnear[k] = vf8_set1(cn[k]);
        w->cfar[k] = vf8_set1(cf[k]);
        w->near[k] = (uint32_t)offsetof(wide8_node, q) + 8 * (uint32_t)(2 * k + r->neg[k]);
        w->far[k] = (uint32_t)offsetof(wide8_node, q) + 8 * (uint32_t)(2 * k + 1 - r->neg[k]);
    }
    w->tnear = vf8_set1(r->tnear);
}

/* Lanes: the float 2^(e - 127) of the byte e that is the top byte of the 4 bytes at p
 * (a node's exponent byte k with p = n->e + k - 3, inside the node). */
PRT_INLINE vf8 wide8_scale8(const uint8_t *p) {
    int32_t x;
    memcpy(&x, p, 4);
    typedef uint32_t vu8 __attribute__((vector_size(32)));
    const vu8 v = (vu8)(vi8){x, x, x, x, x, x, x, x};
    return (vf8)((v >> 1) & 0x7F800000u);
}

/* The slab test on the node's eight child boxes for one ray, with the quantization folded
 * into the ray (after Ylitie et al. 2017, §3.3): a plane's distance is one fma from its
 * byte q, q * (s inv) + (p inv - org inv), where decoding the plane first (wide8_box_hit)
 * costs an fma, a subtraction and a multiplication in a chain.
 *
 * Conservative: the folded form rounds differently from the box the encoder checked
 * (fmaf(q, s, p), which may differ from p + q s by u |P|, u = 2^-24), and its terms can be
 * far larger than the distance. With M = |p| + 256 s of the root and |P|, |p| <= M, q s <=
 * 2.1 M at every node (the root box holds every node box; a node's s is at most 4/255 of
 * its extent or 2^-125, and each plane within one step of its subtree), the errors of inv, of org *
 * inv, of the near / far constants, of p * inv + c and of the final fma add up to less than
 * u (11 M + 5 |org|) |inv| + 3u E; near distances are lowered and far ones raised by E =
 * 2^-19 (M + |org|) |inv| + 2^-126 (underflow), which covers it. So every child box the
 * exact slab test on the decoded box hits is hit, and each entry distance is at most the
 * exact one (the stack's cull at h.t stays conservative). On an axis where inv is
 * infinite (a zero direction component, E = 0) a distance is NaN, or infinite only where
 * the origin lies outside the slab; the min/max operand order ignores NaN. */
PRT_INLINE unsigned wide8_fold_hit(const wide8_node *n, const wide8_fold *w, float tfar, vf8 *tentry) {
    const uint8_t *b = (const uint8_t *)n;
    vf8 tmin = w->tnear, tmax = vf8_set1(tfar);
    for (int k = 0; k < 3; k++) {
        const vf8 si = wide8_scale8(b + offsetof(wide8_node, e) + k - 3) * w->inv[k];
        const vf8 p = vf8_set1(n->p[k]);
        const vf8 on = vf8_fmadd(p, w->inv[k], w->cnear[k]), of = vf8_fmadd(p, w->inv[k], w->cfar[k]);
        /* NaN in the first operand: the second, so an undefined distance culls nothing. */
        tmin = vf8_max(vf8_fmadd(vf8_from_u8(b + w->near[k]), si, on), tmin);
        tmax = vf8_min(vf8_fmadd(vf8_from_u8(b + w->far[k]), si, of), tmax);
    }
    *tentry = tmin;
    return (unsigned)vi8_mask(tmin <= tmax) & wide8_occupied(n);
}

/* The three node tests, one walk's choice (wide8_kernels.inc's `test`, a constant in each
 * instantiated walk): the folded one (wide8_fold_hit), the decoded-plane one
 * (wide8_box_hit), or wide8_nf_hit, which also returns the exit distances (Ray-Strips
 * bounds a strip's s-kd walk by them; lossygrid's records measured faster with it). */
enum { WIDE8_FOLD, WIDE8_PLANES, WIDE8_NF };

/* Per-ray constants of the chosen test (the others' left unset); c.w always holds the
 * blob's header fields child_ref reads. */
typedef struct wide8_test {
    wide8_nfray c;
    wide8_fold f;
} wide8_test;

PRT_INLINE void wide8_test_init(wide8_test *t, const prt__rayx *r, const uint8_t *blob, const int test) {
    if (test == WIDE8_FOLD) wide8_ray_header(&t->c.w, blob), wide8_fold_init(&t->f, r, blob);
    else if (test == WIDE8_PLANES) wide8_ray_init(&t->c.w, r, blob);
    else wide8_nfray_init(&t->c, r, blob);
}

/* The occupied slots of node n whose boxes the ray enters before tfar, their entry distances
 * in *tn and, for WIDE8_NF only, their exit distances in *tf. */
PRT_INLINE unsigned wide8_test_hit(const wide8_node *n, const wide8_test *t, float tfar, vf8 *tn, vf8 *tf,
                                   const int test) {
    if (test == WIDE8_FOLD) return wide8_fold_hit(n, &t->f, tfar, tn);
    if (test == WIDE8_PLANES) return wide8_box_hit(n, &t->c.w, tfar, tn);
    return wide8_nf_hit(n, &t->c, tfar, tn, tf);
}

#endif
