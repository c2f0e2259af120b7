/* Cache eviction for the cold figure: stream-read a buffer larger than the last-level cache.
 *
 * How RayCastTest does it (Utils/CacheTrasher.h, TestRaycast.cpp RunTest): before each timed
 * batch of 1024 rays it _mm_clflush()es, line by line, exactly the memory the test will touch:
 * the ray array, the output array and the test's own tree and triangle buffers (TrashCache()).
 * FLUSH_CACHE_AFTER_EVERY_RAY (off for the paper's tables) does the same around every single
 * ray. The batch time is then divided by the ray count: the paper's "Time 1024 Rays (µs)"
 * columns are microseconds per ray, each batch starting from cold caches.
 *
 * What we do instead: we cannot clflush what we cannot see. An accel is opaque (a loaded .prt
 * is an mmap, a built one lives in packrt's allocations) and Embree never tells us where its
 * BVH is. So before each batch we read, once, every cache line of a buffer twice the size of the
 * last-level cache: with any LRU-like replacement that evicts every line the previous batch
 * touched, from every level, for every backend alike, rays and hits included (what
 * CacheTrasher::sTrash(mRayCasts / out) did). The buffer is only read: dirty lines would have to
 * be written back when the timed batch evicts them, charging the flush to the batch. The
 * per-batch flush matches the paper's default (not FLUSH_CACHE_AFTER_EVERY_RAY). */
#include "bench.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define BENCH_MIB ((size_t)1 << 20)

static unsigned char *g_buffer;
static size_t g_size;
static volatile uint64_t g_sink; /* keeps the reads from being optimised away */

/* Last-level cache size in bytes: glibc's sysconf, then sysfs, then a guess. */
static size_t llc_bytes(void) {
    long s = -1;
#ifdef _SC_LEVEL3_CACHE_SIZE
    s = sysconf(_SC_LEVEL3_CACHE_SIZE);
    if (s <= 0) s = sysconf(_SC_LEVEL2_CACHE_SIZE);
#endif
    if (s > 0) return (size_t)s;
    FILE *f = fopen("/sys/devices/system/cpu/cpu0/cache/index3/size", "r");
    if (f) {
        unsigned long kb = 0;
        if (fscanf(f, "%luK", &kb) == 1 && kb) s = (long)(kb * 1024);
        fclose(f);
    }
    return s > 0 ? (size_t)s : 32 * BENCH_MIB;
}

size_t bench_cache_flush_default_bytes(void) {
    /* Twice the LLC, at least 32 MiB. At most 1 GiB: virtual machines report the sum of all
     * the host's L3 slices (508 MiB on the EPYC we develop on) while a core only ever fills
     * its own slice (32 MiB there); 1 GiB covers both readings at ~0.1 s per flush. */
    size_t n = 2 * llc_bytes();
    if (n < 32 * BENCH_MIB) n = 32 * BENCH_MIB;
    if (n > 1024 * BENCH_MIB) n = 1024 * BENCH_MIB;
    return n;
}

void bench_cache_flush(size_t flush_bytes) {
    size_t want = flush_bytes ? flush_bytes : bench_cache_flush_default_bytes();
    if (want != g_size) {
        free(g_buffer);
        g_buffer = malloc(want);
        g_size = g_buffer ? want : 0;
        /* Touch every page now so the first flush does not time page faults into nothing. */
        if (g_buffer) memset(g_buffer, 1, g_size);
    }
    if (!g_buffer) return;
    uint64_t sum = 0;
    for (size_t i = 0; i < g_size; i += 64) sum += g_buffer[i];
    g_sink = sum;
}
