/* The block cache (Áfra 2012 §5; cache.h says how its two access paths differ). */
#include "ooc/cache.h"

#include <errno.h>
#include <lz4.h>
#include <stdlib.h>
#include <time.h>
#include <unistd.h>
#include <zlib.h>

enum { SLOT_FREE, SLOT_LOADING, SLOT_LOADED, SLOT_PUBLISHED };
enum { BLOCK_NONE, BLOCK_LOADING, BLOCK_LOADED, BLOCK_BAD };

#define NO_BLOCK UINT32_MAX

/* Wait on c->loaded, at most a millisecond: a put or a dropped fetch job does not signal. */
static void wait_a_little(ooc_cache *c) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    ts.tv_nsec += 1000000;
    if (ts.tv_nsec >= 1000000000) ts.tv_sec++, ts.tv_nsec -= 1000000000;
    pthread_cond_timedwait(&c->loaded, &c->mu, &ts);
}

static uint64_t now_ns(void) { return (uint64_t)(prt__now() * 1e9); }

/* Read and check block b into dst (a slot). */
static bool load_block(ooc_cache *c, uint32_t b, uint8_t *dst) {
    const ooc_block_entry *e = &c->table[b];
    static _Thread_local uint8_t zbuf[OOC_BLOCK + 1024];
    uint64_t t0 = now_ns();
    const uint8_t *src;
    if (c->mem) {
        src = c->mem + e->offset;
    } else {
        size_t got = 0;
        while (got < e->size) {
            ssize_t r = pread(c->fd, zbuf + got, e->size - got, (off_t)(e->offset + got));
            if (r <= 0) {
                if (r < 0 && errno == EINTR) continue;
                return false;
            }
            got += (size_t)r;
        }
        src = zbuf;
    }
    if (c->verify && (uint32_t)crc32(0L, src, e->size) != e->crc) return false;
    if (e->size == e->raw) memcpy(dst, src, e->raw);
    else if (LZ4_decompress_safe((const char *)src, (char *)dst, (int)e->size, OOC_BLOCK) != (int)e->raw) return false;
    if (e->kind == OOC_BLOCK_TRIS) {
        /* The traversal trusts a triangle block's two section offsets: check them once. */
        uint16_t h[2];
        if (e->raw < 4) return false;
        memcpy(h, dst, 4);
        if (h[0] < 4 || h[0] > h[1] || h[1] > e->raw || (h[1] - h[0]) % sizeof(ooc_tri) || (e->raw - h[1]) % 12)
            return false;
    }
    atomic_fetch_add(&c->loads, 1);
    atomic_fetch_add(&c->bytes_read, e->size);
    atomic_fetch_add(&c->bytes_raw, e->raw);
    atomic_fetch_add(&c->decode_ns, now_ns() - t0);
    return true;
}

static uint8_t *slot_ptr(const ooc_cache *c, uint32_t s) { return c->slot_mem + (size_t)s * OOC_BLOCK; }

/* Pin slot s for block b if it still holds it (see the eviction in take_slot). */
static bool pin(ooc_cache *c, uint32_t b, uint32_t s) {
    if (!c->pinning) return true;
    atomic_fetch_add(&c->slots[s].pins, 1);
    if (atomic_load(&c->map[b]) == s + 1) return true;
    atomic_fetch_sub(&c->slots[s].pins, 1);
    return false;
}

/* A slot for a new block, under the mutex: a free one, else the least recently used
 * published one that nothing pins and (for LOD frames) the last frame did not touch.
 * NO_BLOCK when none can be had. */
static uint32_t take_slot(ooc_cache *c, uint32_t min_age) {
    uint32_t frame = atomic_load(&c->frame);
    for (;;) {
        uint32_t best = NO_BLOCK, best_stamp = UINT32_MAX;
        for (uint32_t s = 0; s < c->nslots; s++) {
            if (c->slots[s].state == SLOT_FREE) return s;
            if (c->slots[s].state != SLOT_PUBLISHED || atomic_load(&c->slots[s].pins)) continue;
            uint32_t st = atomic_load_explicit(&c->slots[s].stamp, memory_order_relaxed);
            if (frame - st < min_age) continue;
            if (st < best_stamp) best_stamp = st, best = s;
        }
        if (best == NO_BLOCK) return NO_BLOCK;
        /* Unpublish, then look at the pins: a reader pins before it re-reads the map, so
         * either it sees the map cleared or we see its pin. */
        uint32_t old = atomic_load(&c->slots[best].block);
        atomic_store(&c->map[old], 0);
        /* The same handshake with LOD queries, which count themselves before reading the map:
         * either one sees the map cleared or we see it running (then nothing is evicted). */
        if (min_age == 0 && atomic_load(&c->lod_active)) {
            atomic_store(&c->map[old], best + 1);
            return NO_BLOCK;
        }
        if (atomic_load(&c->slots[best].pins)) {
            atomic_store(&c->map[old], best + 1);
            atomic_store_explicit(&c->slots[best].stamp, frame, memory_order_relaxed); /* skip it next time */
            continue;
        }
        atomic_store(&c->bstate[old], BLOCK_NONE);
        atomic_store(&c->slots[best].block, NO_BLOCK);
        c->slots[best].state = SLOT_FREE;
        return best;
    }
}

static void publish(ooc_cache *c, uint32_t s) {
    uint32_t b = atomic_load(&c->slots[s].block);
    c->slots[s].state = SLOT_PUBLISHED;
    atomic_store_explicit(&c->slots[s].stamp, atomic_load(&c->frame), memory_order_relaxed);
    atomic_store(&c->bstate[b], BLOCK_NONE);
    atomic_store(&c->map[b], s + 1);
}

const uint8_t *ooc_cache_get(ooc_cache *c, uint32_t b, uint32_t *size) {
    *size = c->table[b].raw;
    for (;;) {
        uint32_t s = atomic_load_explicit(&c->map[b], memory_order_acquire);
        if (s && pin(c, b, s - 1)) {
            uint32_t f = atomic_load_explicit(&c->frame, memory_order_relaxed);
            if (atomic_load_explicit(&c->slots[s - 1].stamp, memory_order_relaxed) != f)
                atomic_store_explicit(&c->slots[s - 1].stamp, f, memory_order_relaxed);
            return slot_ptr(c, s - 1);
        }
        if (atomic_load(&c->bstate[b]) == BLOCK_BAD) return NULL;
        pthread_mutex_lock(&c->mu);
        if (atomic_load(&c->map[b])) {
            pthread_mutex_unlock(&c->mu);
            continue;
        }
        uint8_t st = atomic_load(&c->bstate[b]);
        if (st == BLOCK_BAD) {
            pthread_mutex_unlock(&c->mu);
            return NULL;
        }
        if (st == BLOCK_LOADING) { /* a fetcher or another thread is at it */
            wait_a_little(c);
            pthread_mutex_unlock(&c->mu);
            continue;
        }
        if (st == BLOCK_LOADED) { /* fetched for a later frame: exact queries take it now */
            for (uint32_t i = 0; i < c->nslots; i++)
                if (c->slots[i].state == SLOT_LOADED && atomic_load(&c->slots[i].block) == b) publish(c, i);
            pthread_mutex_unlock(&c->mu);
            continue;
        }
        uint32_t slot = take_slot(c, 0);
        if (slot == NO_BLOCK) { /* every slot pinned or loading: wait a little for one */
            wait_a_little(c);
            pthread_mutex_unlock(&c->mu);
            continue;
        }
        c->slots[slot].state = SLOT_LOADING;
        atomic_store(&c->slots[slot].block, b);
        atomic_store(&c->bstate[b], BLOCK_LOADING);
        pthread_mutex_unlock(&c->mu);
        bool ok = load_block(c, b, slot_ptr(c, slot));
        pthread_mutex_lock(&c->mu);
        if (ok) {
            publish(c, slot);
        } else {
            atomic_fetch_add(&c->failures, 1);
            atomic_store(&c->bstate[b], BLOCK_BAD);
            atomic_store(&c->slots[slot].block, NO_BLOCK);
            c->slots[slot].state = SLOT_FREE;
        }
        pthread_cond_broadcast(&c->loaded);
        pthread_mutex_unlock(&c->mu);
        if (!ok) return NULL;
    }
}

const uint8_t *ooc_cache_try(ooc_cache *c, uint32_t b, uint32_t *size) {
    *size = c->table[b].raw;
    /* No pin: during a frame only exact queries evict, and they are not mixed with it. */
    uint32_t s = atomic_load_explicit(&c->map[b], memory_order_acquire);
    if (s) {
        /* Store only when it changes: a shared line written by every ray would bounce
         * between the cores. */
        uint32_t f = atomic_load_explicit(&c->frame, memory_order_relaxed);
        if (atomic_load_explicit(&c->slots[s - 1].stamp, memory_order_relaxed) != f)
            atomic_store_explicit(&c->slots[s - 1].stamp, f, memory_order_relaxed);
        return slot_ptr(c, s - 1);
    }
    if (atomic_fetch_add_explicit(&c->want[b], 1, memory_order_relaxed) == 0) {
        uint32_t i = atomic_fetch_add(&c->nrequests, 1);
        if (i < c->request_cap) c->requests[i] = b;
    }
    return NULL;
}

static void *fetcher(void *arg) {
    ooc_cache *c = arg;
    pthread_mutex_lock(&c->mu);
    for (;;) {
        while (!c->quit && c->next_job >= c->njobs) pthread_cond_wait(&c->work, &c->mu);
        if (c->quit) break;
        uint32_t b = c->job_block[c->next_job], slot = c->job_slot[c->next_job];
        c->next_job++;
        c->in_flight++;
        pthread_mutex_unlock(&c->mu);
        bool ok = load_block(c, b, slot_ptr(c, slot));
        pthread_mutex_lock(&c->mu);
        c->in_flight--;
        if (ok) {
            c->slots[slot].state = SLOT_LOADED; /* published at the next cache update (§5.2) */
            atomic_store(&c->bstate[b], BLOCK_LOADED);
        } else {
            atomic_fetch_add(&c->failures, 1);
            atomic_store(&c->bstate[b], BLOCK_BAD);
            atomic_store(&c->slots[slot].block, NO_BLOCK);
            c->slots[slot].state = SLOT_FREE;
        }
        pthread_cond_broadcast(&c->loaded);
    }
    pthread_mutex_unlock(&c->mu);
    return NULL;
}

static int by_key(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

void ooc_cache_frame(ooc_cache *c, ooc_frame_info *info) {
    pthread_mutex_lock(&c->mu);
    uint32_t frame = atomic_load(&c->frame);
    ooc_frame_info fi = {0};
    /* Publish what the fetchers finished; count the working set and residents. */
    for (uint32_t s = 0; s < c->nslots; s++) {
        if (c->slots[s].state == SLOT_LOADED) publish(c, s);
        if (c->slots[s].state == SLOT_PUBLISHED) {
            fi.resident++;
            fi.working_set += atomic_load_explicit(&c->slots[s].stamp, memory_order_relaxed) == frame;
        }
    }
    /* Jobs not started are dropped: the new requests decide what comes next. */
    for (uint32_t j = c->next_job; j < c->njobs; j++) {
        atomic_store(&c->bstate[c->job_block[j]], BLOCK_NONE);
        atomic_store(&c->slots[c->job_slot[j]].block, NO_BLOCK);
        c->slots[c->job_slot[j]].state = SLOT_FREE;
    }
    c->njobs = c->next_job = 0;
    uint32_t n = PRT_MIN(atomic_load(&c->nrequests), c->request_cap);
    fi.requested = n;
    /* Highest priority first (§5.3: how many rays asked), then by block id. */
    for (uint32_t i = 0; i < n; i++)
        c->order[i] = (uint64_t)(UINT32_MAX - atomic_load_explicit(&c->want[c->requests[i]], memory_order_relaxed))
                          << 32 |
                      c->requests[i];
    qsort(c->order, n, sizeof *c->order, by_key);
    for (uint32_t i = 0; i < n; i++) c->requests[i] = (uint32_t)c->order[i];
    atomic_store(&c->frame, frame + 1);
    for (uint32_t i = 0; i < n && c->njobs < c->max_jobs; i++) {
        uint32_t b = c->requests[i];
        if (atomic_load(&c->map[b]) || atomic_load(&c->bstate[b]) != BLOCK_NONE) continue;
        /* Never evict what the frame just used (min_age 2: not touched in it). */
        uint32_t s = take_slot(c, 2);
        if (s == NO_BLOCK) break;
        c->slots[s].state = SLOT_LOADING;
        atomic_store(&c->slots[s].block, b);
        atomic_store(&c->bstate[b], BLOCK_LOADING);
        c->job_block[c->njobs] = b, c->job_slot[c->njobs] = s;
        c->njobs++;
    }
    for (uint32_t i = 0; i < n; i++) atomic_store_explicit(&c->want[c->requests[i]], 0, memory_order_relaxed);
    atomic_store(&c->nrequests, 0);
    fi.pending = c->njobs + c->in_flight;
    pthread_cond_broadcast(&c->work);
    pthread_mutex_unlock(&c->mu);
    if (info) *info = fi;
}

prt_status ooc_cache_init(ooc_cache *c, int fd, const uint8_t *mem, const ooc_block_entry *table, uint32_t nblocks,
                          uint32_t nslots, int fetchers) {
    memset(c, 0, sizeof *c);
    pthread_mutex_init(&c->mu, NULL);
    pthread_cond_init(&c->loaded, NULL);
    pthread_cond_init(&c->work, NULL);
    c->sync_ready = true;
    c->fd = fd, c->mem = mem, c->table = table, c->nblocks = nblocks;
    nslots = PRT_MAX(nslots, OOC_MIN_SLOTS);
    if (nslots > nblocks) nslots = PRT_MAX(nblocks, 1u);
    c->nslots = nslots;
    c->pinning = nslots < nblocks;
    c->request_cap = nblocks;
    c->max_jobs = PRT_MIN(nslots / 4 + 1, 4096u);
    c->slot_mem = prt__alloc(prt__mul_size(nslots, OOC_BLOCK));
    c->slots = prt__calloc(nslots, sizeof *c->slots);
    c->map = prt__calloc(PRT_MAX(nblocks, 1), sizeof *c->map);
    c->bstate = prt__calloc(PRT_MAX(nblocks, 1), sizeof *c->bstate);
    c->want = prt__calloc(PRT_MAX(nblocks, 1), sizeof *c->want);
    c->requests = prt__calloc(PRT_MAX(nblocks, 1), sizeof *c->requests);
    c->order = prt__calloc(PRT_MAX(nblocks, 1), sizeof *c->order);
    c->job_block = prt__calloc(c->max_jobs, sizeof *c->job_block);
    c->job_slot = prt__calloc(c->max_jobs, sizeof *c->job_slot);
    if (!c->slot_mem || !c->slots || !c->map || !c->bstate || !c->want || !c->requests || !c->order || !c->job_block ||
        !c->job_slot) {
        ooc_cache_free(c);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for a block cache of %u slots", nslots);
    }
    for (uint32_t s = 0; s < nslots; s++) atomic_store(&c->slots[s].block, NO_BLOCK);
    c->want_fetchers = fetchers;
    return PRT_OK;
}

void ooc_cache_start_fetchers(ooc_cache *c) {
    if (c->fetchers || c->want_fetchers <= 0) return;
    c->fetchers = prt__calloc((size_t)c->want_fetchers, sizeof *c->fetchers);
    if (!c->fetchers) return; /* LOD queries then see no loads: the image stays coarse */
    for (int i = 0; i < c->want_fetchers; i++) {
        if (pthread_create(&c->fetchers[i], NULL, fetcher, c)) break;
        c->nfetchers++;
    }
}

void ooc_cache_free(ooc_cache *c) {
    if (c->sync_ready) {
        pthread_mutex_lock(&c->mu);
        c->quit = true;
        pthread_cond_broadcast(&c->work);
        pthread_mutex_unlock(&c->mu);
        for (int i = 0; i < c->nfetchers; i++) pthread_join(c->fetchers[i], NULL);
        pthread_mutex_destroy(&c->mu);
        pthread_cond_destroy(&c->loaded);
        pthread_cond_destroy(&c->work);
    }
    prt__free(c->fetchers);
    prt__free(c->slot_mem);
    prt__free(c->slots);
    prt__free(c->map);
    prt__free(c->bstate);
    prt__free(c->want);
    prt__free(c->requests);
    prt__free(c->order);
    prt__free(c->job_block);
    prt__free(c->job_slot);
    memset(c, 0, sizeof *c);
}
