/* Allocation hooks and the byte counter behind prt_memory_usage. Each block carries a
 * 64-byte header holding its size and the raw pointer, so frees can be counted and
 * blocks are cache-line aligned whatever the user's allocator returns. */
#include "core/common.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <sys/mman.h>

#define HEADER 64

static void *(*g_alloc)(size_t) = malloc;
static void (*g_free)(void *) = free;
static atomic_size_t g_current;
static atomic_size_t g_peak;

void prt_set_allocator(void *(*alloc)(size_t), void (*dealloc)(void *)) {
    g_alloc = alloc ? alloc : malloc;
    g_free = dealloc ? dealloc : free;
}

void prt_memory_usage(size_t *current, size_t *peak) {
    if (current) *current = atomic_load(&g_current);
    if (peak) *peak = atomic_load(&g_peak);
}

void prt_memory_reset_peak(void) { atomic_store(&g_peak, atomic_load(&g_current)); }

static void count_add(size_t n) {
    size_t now = atomic_fetch_add(&g_current, n) + n;
    size_t peak = atomic_load(&g_peak);
    while (now > peak && !atomic_compare_exchange_weak(&g_peak, &peak, now)) {}
}

/* Blocks of 2 MiB and more start on a 2 MiB boundary and ask for transparent huge pages
 * (MADV_HUGEPAGE, as Embree does for its BVH): builders and loaders fill hundreds of MB
 * front to back, and with 4 KiB pages a page fault per 4 KiB took a third to a half of a
 * build (docs/results/foundation.md, "Huge pages"). Only the block's whole 2 MiB pages are
 * named, so none holds more memory than asked for; a hint, whichever allocator gave it. */
#define HUGE_PAGE ((size_t)2 << 20)

void *prt__alloc(size_t size) {
    if (size == 0) size = 1;
    const size_t align = size >= HUGE_PAGE ? HUGE_PAGE : HEADER;
    if (size > SIZE_MAX - HEADER - align) return NULL;
    uint8_t *raw = g_alloc(size + HEADER + align);
    if (!raw) return NULL;
    uint8_t *p = (uint8_t *)(((uintptr_t)raw + HEADER + align - 1) & ~(uintptr_t)(align - 1));
#if defined(MADV_HUGEPAGE)
    if (align == HUGE_PAGE) (void)madvise(p, size & ~(HUGE_PAGE - 1), MADV_HUGEPAGE);
#endif
    ((size_t *)(p - HEADER))[0] = size;
    ((void **)(p - HEADER))[1] = raw;
    count_add(size);
    return p;
}

void *prt__calloc(size_t count, size_t size) {
    size_t n = prt__mul_size(count, size);
    void *p = prt__alloc(n);
    if (p) memset(p, 0, n ? n : 1);
    return p;
}

void prt__free(void *p) {
    if (!p) return;
    uint8_t *q = p;
    size_t size = ((size_t *)(q - HEADER))[0];
    void *raw = ((void **)(q - HEADER))[1];
    atomic_fetch_sub(&g_current, size);
    g_free(raw);
}

void *prt__realloc(void *p, size_t size) {
    if (!p) return prt__alloc(size);
    size_t old = ((size_t *)((uint8_t *)p - HEADER))[0];
    void *q = prt__alloc(size);
    if (!q) return NULL;
    memcpy(q, p, old < size ? old : size);
    prt__free(p);
    return q;
}

void prt_free(void *p) { prt__free(p); }
