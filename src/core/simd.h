/* Thin 4-wide SIMD wrappers (vf4, vi4) so kernels read like math. GCC/clang vector
 * extensions give the arithmetic; the few operations they lack use SSE where present and
 * a plain loop otherwise, so a scalar build of every kernel always compiles. */
#ifndef PRT_CORE_SIMD_H
#define PRT_CORE_SIMD_H

#include <stdint.h>
#include <string.h>
#if defined(__SSE4_1__)
#include <immintrin.h>
#endif

typedef float vf4 __attribute__((vector_size(16)));
typedef int32_t vi4 __attribute__((vector_size(16))); /* comparison masks: -1 true, 0 false */

static inline vf4 vf4_set1(float x) { return (vf4){x, x, x, x}; }
static inline vf4 vf4_load(const float *p) { vf4 v; memcpy(&v, p, sizeof v); return v; }
static inline void vf4_store(float *p, vf4 v) { memcpy(p, &v, sizeof v); }

#if defined(__SSE4_1__)
static inline vf4 vf4_min(vf4 a, vf4 b) { return (vf4)_mm_min_ps((__m128)a, (__m128)b); }
static inline vf4 vf4_max(vf4 a, vf4 b) { return (vf4)_mm_max_ps((__m128)a, (__m128)b); }
static inline int vi4_mask(vi4 m) { return _mm_movemask_ps((__m128)m); }
static inline vf4 vf4_select(vi4 m, vf4 a, vf4 b) { return (vf4)_mm_blendv_ps((__m128)b, (__m128)a, (__m128)m); }
#else
/* min/max return the second operand when either is NaN, like SSE. */
static inline vf4 vf4_min(vf4 a, vf4 b) { vf4 r; for (int i = 0; i < 4; i++) r[i] = a[i] < b[i] ? a[i] : b[i]; return r; }
static inline vf4 vf4_max(vf4 a, vf4 b) { vf4 r; for (int i = 0; i < 4; i++) r[i] = a[i] > b[i] ? a[i] : b[i]; return r; }
static inline int vi4_mask(vi4 m) { int r = 0; for (int i = 0; i < 4; i++) r |= (m[i] < 0) << i; return r; }
static inline vf4 vf4_select(vi4 m, vf4 a, vf4 b) { vf4 r; for (int i = 0; i < 4; i++) r[i] = m[i] ? a[i] : b[i]; return r; }
#endif

/* Horizontal minimum, broadcast. */
static inline float vf4_hmin(vf4 a) {
    vf4 b = vf4_min(a, __builtin_shufflevector(a, a, 2, 3, 0, 1));
    b = vf4_min(b, __builtin_shufflevector(b, b, 1, 0, 3, 2));
    return b[0];
}

#endif
