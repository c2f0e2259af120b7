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
static inline vf4 vf4_load(const float *p) {
    vf4 v;
    memcpy(&v, p, sizeof v);
    return v;
}

#if defined(__SSE4_1__)
static inline vf4 vf4_min(vf4 a, vf4 b) { return (vf4)_mm_min_ps((__m128)a, (__m128)b); }
static inline vf4 vf4_max(vf4 a, vf4 b) { return (vf4)_mm_max_ps((__m128)a, (__m128)b); }
static inline int vi4_mask(vi4 m) { return _mm_movemask_ps((__m128)m); }
static inline vf4 vf4_select(vi4 m, vf4 a, vf4 b) { return (vf4)_mm_blendv_ps((__m128)b, (__m128)a, (__m128)m); }
#else
/* min/max return the second operand when either is NaN, like SSE. */
static inline vf4 vf4_min(vf4 a, vf4 b) {
    vf4 r;
    for (int i = 0; i < 4; i++) r[i] = a[i] < b[i] ? a[i] : b[i];
    return r;
}
static inline vf4 vf4_max(vf4 a, vf4 b) {
    vf4 r;
    for (int i = 0; i < 4; i++) r[i] = a[i] > b[i] ? a[i] : b[i];
    return r;
}
static inline int vi4_mask(vi4 m) {
    int r = 0;
    for (int i = 0; i < 4; i++) r |= (m[i] < 0) << i;
    return r;
}
static inline vf4 vf4_select(vi4 m, vf4 a, vf4 b) {
    vf4 r;
    for (int i = 0; i < 4; i++) r[i] = m[i] ? a[i] : b[i];
    return r;
}
#endif

/* Horizontal minimum, broadcast. */
static inline float vf4_hmin(vf4 a) {
    vf4 b = vf4_min(a, __builtin_shufflevector(a, a, 2, 3, 0, 1));
    b = vf4_min(b, __builtin_shufflevector(b, b, 1, 0, 3, 2));
    return b[0];
}

/* 8 lanes: AVX where the target has it (x86-64-v3 and up), plain loops otherwise. */
typedef float vf8 __attribute__((vector_size(32)));
typedef int32_t vi8 __attribute__((vector_size(32)));

static inline vf8 vf8_set1(float x) { return (vf8){x, x, x, x, x, x, x, x}; }
static inline vf8 vf8_load(const float *p) {
    vf8 v;
    memcpy(&v, p, sizeof v);
    return v;
}

static inline void vf8_store(float *p, vf8 v) { memcpy(p, &v, sizeof v); }
static inline vi8 vi8_load(const int32_t *p) {
    vi8 v;
    memcpy(&v, p, sizeof v);
    return v;
}
static inline void vi8_store(int32_t *p, vi8 v) { memcpy(p, &v, sizeof v); }
static inline vi8 vi8_select(vi8 m, vi8 a, vi8 b) { return (m & a) | (~m & b); }

/* In place: c[k][l] = (input c[l])[k], an 8x8 transpose in three rounds of shuffles (rows
 * of 8 floats to columns: AoS records to SoA lanes and back). */
static inline void vf8_transpose8(vf8 c[8]) {
    vf8 t[8], u[8];
    for (int i = 0; i < 8; i += 2) {
        t[i] = __builtin_shufflevector(c[i], c[i + 1], 0, 8, 1, 9, 4, 12, 5, 13);
        t[i + 1] = __builtin_shufflevector(c[i], c[i + 1], 2, 10, 3, 11, 6, 14, 7, 15);
    }
    for (int i = 0; i < 8; i += 4) {
        u[i] = __builtin_shufflevector(t[i], t[i + 2], 0, 1, 8, 9, 4, 5, 12, 13);
        u[i + 1] = __builtin_shufflevector(t[i], t[i + 2], 2, 3, 10, 11, 6, 7, 14, 15);
        u[i + 2] = __builtin_shufflevector(t[i + 1], t[i + 3], 0, 1, 8, 9, 4, 5, 12, 13);
        u[i + 3] = __builtin_shufflevector(t[i + 1], t[i + 3], 2, 3, 10, 11, 6, 7, 14, 15);
    }
    for (int i = 0; i < 4; i++) {
        c[i] = __builtin_shufflevector(u[i], u[i + 4], 0, 1, 2, 3, 8, 9, 10, 11);
        c[i + 4] = __builtin_shufflevector(u[i], u[i + 4], 4, 5, 6, 7, 12, 13, 14, 15);
    }
}

#if defined(__AVX__)
static inline vf8 vf8_min(vf8 a, vf8 b) { return (vf8)_mm256_min_ps((__m256)a, (__m256)b); }
static inline vf8 vf8_max(vf8 a, vf8 b) { return (vf8)_mm256_max_ps((__m256)a, (__m256)b); }
static inline int vi8_mask(vi8 m) { return _mm256_movemask_ps((__m256)m); }
static inline vf8 vf8_select(vi8 m, vf8 a, vf8 b) { return (vf8)_mm256_blendv_ps((__m256)b, (__m256)a, (__m256)m); }
#else
static inline vf8 vf8_min(vf8 a, vf8 b) {
    vf8 r;
    for (int i = 0; i < 8; i++) r[i] = a[i] < b[i] ? a[i] : b[i];
    return r;
}
static inline vf8 vf8_max(vf8 a, vf8 b) {
    vf8 r;
    for (int i = 0; i < 8; i++) r[i] = a[i] > b[i] ? a[i] : b[i];
    return r;
}
static inline int vi8_mask(vi8 m) {
    int r = 0;
    for (int i = 0; i < 8; i++) r |= (m[i] < 0) << i;
    return r;
}
static inline vf8 vf8_select(vi8 m, vf8 a, vf8 b) {
    vf8 r;
    for (int i = 0; i < 8; i++) r[i] = m[i] ? a[i] : b[i];
    return r;
}
#endif

/* Lane l: p[k[l]], k in [0, 8) (p[0 .. 8) readable). */
static inline vf8 vf8_permute8(const float *p, vi8 k) {
#if defined(__AVX2__)
    return (vf8)_mm256_permutevar8x32_ps((__m256)vf8_load(p), (__m256i)k);
#else
    vf8 r;
    for (int i = 0; i < 8; i++) r[i] = p[k[i] & 7];
    return r;
#endif
}

/* Eight bytes widened to floats (quantized box planes). */
static inline vf8 vf8_from_u8(const uint8_t *p) {
#if defined(__AVX2__)
    return (vf8)_mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64((const __m128i *)p)));
#else
    vf8 r;
    for (int i = 0; i < 8; i++) r[i] = (float)p[i];
    return r;
#endif
}

/* Correctly rounded square roots, the same bits as sqrtf on every path. */
static inline vf8 vf8_sqrt(vf8 a) {
#if defined(__AVX__)
    return (vf8)_mm256_sqrt_ps((__m256)a);
#else
    vf8 r;
    for (int i = 0; i < 8; i++) r[i] = __builtin_sqrtf(a[i]);
    return r;
#endif
}

/* a * b + c with one rounding, the same bits as C's fmaf on every path. */
static inline vf8 vf8_fmadd(vf8 a, vf8 b, vf8 c) {
#if defined(__FMA__)
    return (vf8)_mm256_fmadd_ps((__m256)a, (__m256)b, (__m256)c);
#else
    vf8 r;
    for (int i = 0; i < 8; i++) r[i] = __builtin_fmaf(a[i], b[i], c[i]);
    return r;
#endif
}

/* Bit l set where a[l] <= b[l] (false where either is NaN). */
static inline unsigned vf8_le_bits(vf8 a, vf8 b) { return (unsigned)vi8_mask(a <= b); }

static inline float vf8_hmin(vf8 a) {
    vf4 lo = __builtin_shufflevector(a, a, 0, 1, 2, 3), hi = __builtin_shufflevector(a, a, 4, 5, 6, 7);
    return vf4_hmin(vf4_min(lo, hi));
}

static inline float vf8_hmax(vf8 a) {
    vf4 lo = __builtin_shufflevector(a, a, 0, 1, 2, 3), hi = __builtin_shufflevector(a, a, 4, 5, 6, 7);
    vf4 b = vf4_max(lo, hi);
    b = vf4_max(b, __builtin_shufflevector(b, b, 2, 3, 0, 1));
    b = vf4_max(b, __builtin_shufflevector(b, b, 1, 0, 3, 2));
    return b[0];
}

#endif
