/* Internal definitions shared by every packrt source file: allocation, errors, macros. */
#ifndef PRT_CORE_COMMON_H
#define PRT_CORE_COMMON_H

#include "packrt.h"

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define PRT_INLINE static inline __attribute__((always_inline))
#define PRT_NOINLINE __attribute__((noinline))
/* Neither inlined nor cloned per caller's constants (GCC's noipa; clang has no such cloning
 * of static functions worth stopping, so noinline there). */
#if defined(__clang__)
#define PRT_NOIPA __attribute__((noinline))
#else
#define PRT_NOIPA __attribute__((noipa))
#endif
#define PRT_LIKELY(x) __builtin_expect(!!(x), 1)
#define PRT_UNLIKELY(x) __builtin_expect(!!(x), 0)
#define PRT_ARRAY_SIZE(a) (sizeof(a) / sizeof((a)[0]))
#define PRT_MIN(a, b) ((a) < (b) ? (a) : (b))
#define PRT_MAX(a, b) ((a) > (b) ? (a) : (b))

/* Allocation through the user's hooks, counted for prt_memory_usage. Every block is
 * 64-byte aligned (a cache line, enough for any SIMD width we use). */
void *prt__alloc(size_t size);
void *prt__calloc(size_t count, size_t size);
void *prt__realloc(void *p, size_t size);
void prt__free(void *p);

/* size * count with overflow check: SIZE_MAX on overflow, which prt__alloc refuses. */
PRT_INLINE size_t prt__mul_size(size_t a, size_t b) {
    size_t r;
    return __builtin_mul_overflow(a, b, &r) ? SIZE_MAX : r;
}

/* Record a failure message for prt_last_error() and return s. printf-style. */
prt_status prt__fail(prt_status s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
void prt__clear_error(void);

/* Monotonic wall clock in seconds. */
double prt__now(void);
/* CPU seconds of the calling thread: unlike the wall clock, it does not grow while other
 * processes hold the core (timings on a shared machine, per-phase build costs). */
double prt__thread_seconds(void);

/* Number of threads to use for a request of n (0 = all cores). */
int prt__threads(int n);

#endif
