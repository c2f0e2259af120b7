/* 16-lane SIMD wrappers (vf16, vi16) for packets of 16 rays, so a kernel reads like math:
 * one AVX-512 register where the target has it, else two 8-lane halves (simd.h's vf8:
 * AVX registers on x86-64-v3, plain loops elsewhere). Not GCC's 64-byte generic vectors:
 * without AVX-512, GCC lowers their comparisons lane by lane (vcomiss, seta, ...), which
 * made a "SIMD" packet step cost as much as the scalar loop. min/max follow the SSE rule
 * (a < b ? a : b), as the scalar MINF/MAXF of the kernels do, so both give the same bits. */
#ifndef PRT_CORE_SIMD16_H
#define PRT_CORE_SIMD16_H

#include "core/simd.h"

#define PRT_SIMD16_INLINE static inline __attribute__((always_inline))

#if defined(__AVX512F__) && defined(__AVX512DQ__)
#include <immintrin.h>
#define PRT_SIMD16_NATIVE 1 /* vf16 is one register: GCC's operators and comparisons apply */
typedef float vf16 __attribute__((vector_size(64)));
typedef int32_t vi16 __attribute__((vector_size(64))); /* comparison masks: -1 true, 0 false */
/* A broadcast: (vf16){0} + x would cost an addition and turn -0 into +0. */
PRT_SIMD16_INLINE vf16 vf16_set1(float x) { return (vf16)_mm512_set1_ps(x); }
PRT_SIMD16_INLINE vi16 vi16_set1(int32_t x) { return (vi16){0} + x; }
PRT_SIMD16_INLINE vf16 vf16_add(vf16 a, vf16 b) { return a + b; }
PRT_SIMD16_INLINE vf16 vf16_sub(vf16 a, vf16 b) { return a - b; }
PRT_SIMD16_INLINE vf16 vf16_mul(vf16 a, vf16 b) { return a * b; }
PRT_SIMD16_INLINE vi16 vf16_lt(vf16 a, vf16 b) { return a < b; }
PRT_SIMD16_INLINE vi16 vf16_gt(vf16 a, vf16 b) { return a > b; }
PRT_SIMD16_INLINE vi16 vf16_le(vf16 a, vf16 b) { return a <= b; }
/* m: comparison masks (-1 / 0), so the sign bit is the whole lane: one blend, not three
 * bitwise operations on a mask first widened from a mask register. With those, min / max
 * as selects and set1 as an addition, wide8's bunny packets ran 10-23% slower. */
PRT_SIMD16_INLINE vf16 vf16_select(vi16 m, vf16 a, vf16 b) {
    return (vf16)_mm512_mask_blend_ps(_mm512_movepi32_mask((__m512i)m), (__m512)b, (__m512)a);
}
PRT_SIMD16_INLINE vi16 vi16_select(vi16 m, vi16 a, vi16 b) { return (m & a) | (~m & b); }
PRT_SIMD16_INLINE uint32_t vi16_mask(vi16 m) { return (uint32_t)_mm512_movepi32_mask((__m512i)m); }
/* vi16_mask(vf16_le(a, b)) straight from the comparison's mask register, without the
 * round trip through a vector. */
PRT_SIMD16_INLINE uint32_t vf16_le_bits(vf16 a, vf16 b) {
    return (uint32_t)_mm512_cmp_ps_mask((__m512)a, (__m512)b, _CMP_LE_OQ);
}
/* a * b + c with one rounding, as fmaf. */
PRT_SIMD16_INLINE vf16 vf16_fmadd(vf16 a, vf16 b, vf16 c) {
    return (vf16)_mm512_fmadd_ps((__m512)a, (__m512)b, (__m512)c);
}
PRT_SIMD16_INLINE float vf16_hmax(vf16 a) { return _mm512_reduce_max_ps((__m512)a); }
/* The SSE rule a < b ? a : b (and a > b ? a : b) in one instruction. */
PRT_SIMD16_INLINE vf16 vf16_min(vf16 a, vf16 b) { return (vf16)_mm512_min_ps((__m512)a, (__m512)b); }
PRT_SIMD16_INLINE vf16 vf16_max(vf16 a, vf16 b) { return (vf16)_mm512_max_ps((__m512)a, (__m512)b); }
/* Lane l: p[k[l]], k in [0, 8) (p[0 .. 8) readable). */
PRT_SIMD16_INLINE vf16 vf16_permute8(const float *p, vi16 k) {
    return (vf16)_mm512_permutexvar_ps((__m512i)k, _mm512_castps256_ps512(_mm256_loadu_ps(p)));
}
#else
#define PRT_SIMD16_NATIVE 0
typedef struct vf16 {
    vf8 lo, hi;
} vf16;
typedef struct vi16 {
    vi8 lo, hi;
} vi16;
PRT_SIMD16_INLINE vf16 vf16_set1(float x) { return (vf16){vf8_set1(x), vf8_set1(x)}; }
PRT_SIMD16_INLINE vi16 vi16_set1(int32_t x) {
    const vi8 v = {x, x, x, x, x, x, x, x};
    return (vi16){v, v};
}
PRT_SIMD16_INLINE vf16 vf16_add(vf16 a, vf16 b) { return (vf16){a.lo + b.lo, a.hi + b.hi}; }
PRT_SIMD16_INLINE vf16 vf16_sub(vf16 a, vf16 b) { return (vf16){a.lo - b.lo, a.hi - b.hi}; }
PRT_SIMD16_INLINE vf16 vf16_mul(vf16 a, vf16 b) { return (vf16){a.lo * b.lo, a.hi * b.hi}; }
PRT_SIMD16_INLINE vi16 vf16_lt(vf16 a, vf16 b) { return (vi16){a.lo < b.lo, a.hi < b.hi}; }
PRT_SIMD16_INLINE vi16 vf16_gt(vf16 a, vf16 b) { return (vi16){a.lo > b.lo, a.hi > b.hi}; }
PRT_SIMD16_INLINE vi16 vf16_le(vf16 a, vf16 b) { return (vi16){a.lo <= b.lo, a.hi <= b.hi}; }
PRT_SIMD16_INLINE vf16 vf16_select(vi16 m, vf16 a, vf16 b) {
    return (vf16){vf8_select(m.lo, a.lo, b.lo), vf8_select(m.hi, a.hi, b.hi)};
}
PRT_SIMD16_INLINE vi16 vi16_select(vi16 m, vi16 a, vi16 b) {
    return (vi16){(m.lo & a.lo) | (~m.lo & b.lo), (m.hi & a.hi) | (~m.hi & b.hi)};
}
/* Bit i set when lane i of m is true. */
PRT_SIMD16_INLINE uint32_t vi16_mask(vi16 m) { return (uint32_t)vi8_mask(m.lo) | (uint32_t)vi8_mask(m.hi) << 8; }
PRT_SIMD16_INLINE uint32_t vf16_le_bits(vf16 a, vf16 b) { return vi16_mask(vf16_le(a, b)); }
PRT_SIMD16_INLINE vf16 vf16_fmadd(vf16 a, vf16 b, vf16 c) {
    return (vf16){vf8_fmadd(a.lo, b.lo, c.lo), vf8_fmadd(a.hi, b.hi, c.hi)};
}
PRT_SIMD16_INLINE float vf16_hmax(vf16 a) { return vf8_hmax(vf8_max(a.lo, a.hi)); }
PRT_SIMD16_INLINE vf16 vf16_permute8(const float *p, vi16 k) {
    return (vf16){vf8_permute8(p, k.lo), vf8_permute8(p, k.hi)};
}
PRT_SIMD16_INLINE vf16 vf16_min(vf16 a, vf16 b) { return vf16_select(vf16_lt(a, b), a, b); }
PRT_SIMD16_INLINE vf16 vf16_max(vf16 a, vf16 b) { return vf16_select(vf16_gt(a, b), a, b); }
#endif

PRT_SIMD16_INLINE vf16 vf16_load(const float *p) {
    vf16 v;
    memcpy(&v, p, sizeof v);
    return v;
}
PRT_SIMD16_INLINE void vf16_store(float *p, vf16 v) { memcpy(p, &v, sizeof v); }
PRT_SIMD16_INLINE vi16 vi16_load(const int32_t *p) {
    vi16 v;
    memcpy(&v, p, sizeof v);
    return v;
}
PRT_SIMD16_INLINE void vi16_store(int32_t *p, vi16 v) { memcpy(p, &v, sizeof v); }

#endif
