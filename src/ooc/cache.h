/* The block cache (Áfra 2012 §5): a fixed number of 64 KB slots, a block-to-slot table,
 * fetcher threads that read and decompress requested blocks into slots reserved for
 * them, and a cache update between frames as the one synchronisation point of rendering.
 *
 * Two ways to get a block:
 *  - ooc_cache_get (exact queries): loads a missing block on the calling thread and waits
 *    for it. While the cache is smaller than the file, the block is pinned until
 *    ooc_cache_put, and a block is evicted only when nothing pins it.
 *  - ooc_cache_try (LOD rendering): answers only from blocks published at the last cache
 *    update, else records a request and answers NULL. ooc_cache_frame publishes what the
 *    fetchers loaded, turns the requests into fetch jobs by priority, and evicts the least
 *    recently used blocks that the last frame did not touch. */
#ifndef PRT_OOC_CACHE_H
#define PRT_OOC_CACHE_H

#include "ooc/ooc.h"

#include <pthread.h>

typedef struct ooc_slot {
    _Atomic uint32_t block; /* UINT32_MAX: free */
    _Atomic uint32_t pins;
    _Atomic uint32_t stamp; /* frame of the last access (lock-free store, §5.1) */
    uint32_t state;         /* SLOT_*, under the mutex */
} ooc_slot;

typedef struct ooc_cache {
    int fd;             /* file source, or -1 */
    const uint8_t *mem; /* memory source (a whole block file image), or NULL */
    const ooc_block_entry *table;
    uint32_t nblocks;
    uint32_t nslots;
    bool pinning; /* fewer slots than blocks: exact queries pin what they use */
    uint8_t *slot_mem;
    ooc_slot *slots;
    _Atomic uint32_t *map;   /* block -> slot + 1 when published, else 0 */
    _Atomic uint8_t *bstate; /* block: BLOCK_* */
    _Atomic uint32_t *want;  /* requests since the last update (priority, §5.3) */
    uint32_t *requests;      /* blocks with want > 0, appended lock-free */
    uint64_t *order;         /* sort keys of the requests */
    _Atomic uint32_t nrequests;
    uint32_t request_cap;
    _Atomic uint32_t frame;
    _Atomic uint32_t lod_active; /* LOD queries running (pinning caches only): no eviction meanwhile */
    pthread_mutex_t mu;
    pthread_cond_t loaded, work;
    /* Fetch jobs (block, slot), taken in order by the fetchers. */
    uint32_t *job_block, *job_slot;
    uint32_t njobs, next_job;
    uint32_t in_flight;
    pthread_t *fetchers;
    int nfetchers;
    int want_fetchers; /* started by the first cache update */
    bool quit;
    bool sync_ready;
    bool verify;       /* check each block's crc32 (off only for fuzzing) */
    uint32_t max_jobs; /* per update, from the expected bandwidth */
    /* Counters. */
    _Atomic uint64_t loads, bytes_read, bytes_raw, failures;
    _Atomic uint64_t decode_ns;
} ooc_cache;

#define OOC_MIN_SLOTS 64u /* a few per thread in flight, pinned, plus fetch jobs */

/* slots: at least OOC_MIN_SLOTS; fetchers: threads for ooc_cache_try's requests (0: none). */
prt_status ooc_cache_init(ooc_cache *c, int fd, const uint8_t *mem, const ooc_block_entry *table, uint32_t nblocks,
                          uint32_t nslots, int fetchers);
void ooc_cache_free(ooc_cache *c);
/* Start want_fetchers fetcher threads unless running (LOD rendering needs them). */
void ooc_cache_start_fetchers(ooc_cache *c);

/* The raw bytes of block b and their size, or NULL when it cannot be loaded (a corrupt
 * block: counted in failures). Pair with ooc_cache_put(c, b). */
const uint8_t *ooc_cache_get(ooc_cache *c, uint32_t b, uint32_t *size);
static inline void ooc_cache_put(ooc_cache *c, uint32_t b) {
    if (c->pinning) {
        uint32_t s = atomic_load_explicit(&c->map[b], memory_order_relaxed);
        if (s) atomic_fetch_sub(&c->slots[s - 1].pins, 1);
    }
}
/* Around each LOD query: LOD queries read published blocks without pins, so while one runs
 * exact queries (in the same frame, on other threads) load into free slots only and
 * otherwise wait rather than evict a block it may be reading (issue 31: a block refilled
 * under a LOD walk read as corrupt). Only caches smaller than their file evict mid-frame. */
static inline void ooc_cache_lod_begin(ooc_cache *c) {
    if (c->pinning) atomic_fetch_add(&c->lod_active, 1);
}
static inline void ooc_cache_lod_end(ooc_cache *c) {
    if (c->pinning) atomic_fetch_sub(&c->lod_active, 1);
}
/* Without waiting: the block if it is published, else NULL (and the block is requested). */
const uint8_t *ooc_cache_try(ooc_cache *c, uint32_t b, uint32_t *size);
/* The same, with the published case inline (a LOD frame enters millions of blocks); the
 * call only records a request. */
static inline const uint8_t *ooc_cache_try_inline(ooc_cache *c, uint32_t b, uint32_t *size) {
    uint32_t s = atomic_load_explicit(&c->map[b], memory_order_acquire);
    if (!s) return ooc_cache_try(c, b, size);
    *size = c->table[b].raw;
    /* Store only when it changes: a shared line written by every ray would bounce
     * between the cores. */
    uint32_t f = atomic_load_explicit(&c->frame, memory_order_relaxed);
    if (atomic_load_explicit(&c->slots[s - 1].stamp, memory_order_relaxed) != f)
        atomic_store_explicit(&c->slots[s - 1].stamp, f, memory_order_relaxed);
    return c->slot_mem + (size_t)(s - 1) * OOC_BLOCK;
}

/* The cache update between frames. */
typedef struct ooc_frame_info {
    uint32_t working_set; /* blocks touched in the frame that ended */
    uint32_t resident;    /* blocks in the cache */
    uint32_t requested;   /* distinct blocks requested in that frame */
    uint32_t pending;     /* fetch jobs not finished */
} ooc_frame_info;
void ooc_cache_frame(ooc_cache *c, ooc_frame_info *info);

#endif
