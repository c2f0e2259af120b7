/* QuadTreeHalfFloat (Rouwé 2019, §5.7): the QuadTree's 4-wide node with its child boxes
 * in half floats, 64 bytes. Node format, blob layout and the half-float conversions shared
 * by the encoder (quad_half.c), its kernels (quad_half_kernels.inc) and the tests.
 *
 * Blob: a 64-byte header, the nodes (64 bytes each, node 0 the root, depth first, so
 * every node is cache-line aligned when the blob is), then every leaf block.
 *
 * Unlike the paper, a plane is not stored as an absolute half float but relative to the
 * root box: plane = fmaf(h, scale[k], centre[k]) with a power-of-two scale per axis that
 * maps the root box into [-2^14, 2^14]. Absolute halves (11 bits, at most 65504) turn a
 * mesh at 1e5 into boxes clamped to [65504, inf] that every ray hits, and a mesh at 1e-6
 * scale into subnormal steps wider than its triangles; relative ones keep 11 bits of the
 * root box's extent at any offset or scale, for one fma per plane. The encoder rounds each
 * plane outward and checks the very fmaf the kernel computes, so every decoded box
 * contains its child's true box, bit for bit. */
#ifndef PRT_BVH_LAYOUTS_QUAD_HALF_H
#define PRT_BVH_LAYOUTS_QUAD_HALF_H

#include "core/common.h"

#include <math.h>
#if defined(__F16C__)
#include <immintrin.h>
#endif

/* Child reference: 0 = empty slot (its box is [+inf, -inf]); bit 31 clear: the node index
 * of an inner child (never 0, the root); bit 31 set: a leaf of ((ref >> 27) & 15) + 1
 * triangles whose block starts 4 * (ref & QH_OFFSET_MASK) bytes after the geometry. */
#define QH_LEAF 0x80000000u
#define QH_COUNT_SHIFT 27
#define QH_OFFSET_MASK ((1u << QH_COUNT_SHIFT) - 1)
#define QH_HEADER_BYTES 64
#define QH_NODE_BYTES 64
#define QH_STACK (3 * BVH_MAX_DEPTH + 4)

typedef struct qh_node {
    uint16_t box[24]; /* lo_x[4], hi_x[4], lo_y[4], hi_y[4], lo_z[4], hi_z[4] */
    uint32_t child[4];
} qh_node;

_Static_assert(sizeof(qh_node) == QH_NODE_BYTES, "quad-half node is one cache line");

typedef struct qh_header {
    float centre[3]; /* plane = fmaf(half, scale[k], centre[k]) */
    float scale[3];  /* powers of two */
    uint32_t nodes;
    uint32_t reserved; /* 0 */
    uint64_t geometry; /* byte offset of the first leaf block */
    uint8_t pad[24];
} qh_header;

_Static_assert(sizeof(qh_header) == QH_HEADER_BYTES, "quad-half header is one cache line");

static inline uint32_t qh_leaf_count(uint32_t ref) { return ((ref >> QH_COUNT_SHIFT) & 15) + 1; }

#define QH_HALF_POS_INF 0x7C00u
#define QH_HALF_NEG_INF 0xFC00u

/* The float value of half-float bits h (exact; NaNs stay NaN). */
static inline float qh_half_to_float(uint16_t h) {
    uint32_t sign = (uint32_t)(h & 0x8000) << 16, e = (h >> 10) & 31, m = h & 0x3FF;
    float f;
    if (e == 0) {
        f = ldexpf((float)m, -24); /* zero or subnormal */
        return sign ? -f : f;
    }
    uint32_t bits = sign | (e == 31 ? 0x7F800000u | m << 13 : (e + 112) << 23 | m << 13);
    memcpy(&f, &bits, 4);
    return f;
}

static inline bool qh_half_is_nan(uint16_t h) { return (h & 0x7C00) == 0x7C00 && (h & 0x3FF); }

/* The half float nearest x in the direction up (toward +inf) or down (toward -inf): the
 * smallest half >= x, or the largest half <= x. Beyond the half range that is +-65504 or
 * +-inf, whichever lies on the right side. x must not be NaN. Returns its bits. */
static inline uint16_t qh_half_round(float x, bool up) {
    if (isinf(x)) return x > 0 ? QH_HALF_POS_INF : QH_HALF_NEG_INF;
    int e;
    frexpf(x, &e); /* |x| in [2^(e-1), 2^e): halves there are 2^(e-11) apart */
    const float step = ldexpf(1.0f, e - 11 < -24 ? -24 : e - 11);
    const float q = (up ? ceilf(x / step) : floorf(x / step)) * step; /* exact: step is a power of two */
    if (q > 65504.0f) return up ? QH_HALF_POS_INF : 0x7BFF;
    if (q < -65504.0f) return up ? 0xFBFF : QH_HALF_NEG_INF;
    const uint16_t sign = signbit(q) ? 0x8000 : 0;
    const float a = fabsf(q);
    if (a < 0x1p-14f) return (uint16_t)(sign | (uint16_t)(a * 0x1p24f)); /* subnormal (or zero) */
    uint32_t bits;
    memcpy(&bits, &a, 4);
    return (uint16_t)(sign | (((bits >> 23) - 112) << 10) | ((bits >> 13) & 0x3FF));
}

/* The next half float after h toward +inf (up) or -inf; infinities stay. */
static inline uint16_t qh_half_next(uint16_t h, bool up) {
    if (h == (up ? QH_HALF_POS_INF : QH_HALF_NEG_INF)) return h;
    int key = h & 0x8000 ? -(int)(h & 0x7FFF) : (int)h; /* halves ordered as integers */
    key += up ? 1 : -1;
    return (uint16_t)(key < 0 ? 0x8000 | -key : key);
}

/* Eight halves to floats: F16C where the target has it, else the exact scalar loop. */
static inline void qh_halves_to_floats(const uint16_t *h, float out[8]) {
#if defined(__F16C__)
    _mm256_storeu_ps(out, _mm256_cvtph_ps(_mm_loadu_si128((const __m128i *)h)));
#else
    for (int i = 0; i < 8; i++) out[i] = qh_half_to_float(h[i]);
#endif
}

/* A plane as traversal decodes it. */
static inline float qh_plane(uint16_t h, float scale, float centre) { return fmaf(qh_half_to_float(h), scale, centre); }

#endif
