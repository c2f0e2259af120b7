/* Welding while reading: a hash table from exact vertex positions to vertex indices, so a
 * triangle soup (STL stores three corners per triangle) becomes an indexed mesh as it is
 * parsed, without first holding the soup (which would cost 36 bytes a triangle). */
#ifndef PRT_MESH_WELD_TABLE_H
#define PRT_MESH_WELD_TABLE_H

#include "mesh/source.h"

/* Open addressing with linear probing. A slot holds the position's bits and index + 1 (0:
 * empty), so a probe touches one cache line and never the vertex array: lookups are
 * random accesses over a table larger than the caches, and callers that know the next
 * corners prefetch their slots (weld_table_prefetch) to overlap those misses. */
typedef struct weld_slot {
    uint32_t bits[3];
    uint32_t index1;
} weld_slot;

/* Entries in the small direct-mapped cache of recent positions in front of the table: mesh
 * files list triangles with locality, so most corners repeat a position seen a few hundred
 * triangles before, found there without a miss on the large table. */
#define WELD_CACHE ((size_t)1 << 14)

typedef struct weld_table {
    weld_slot *cache; /* WELD_CACHE entries, each a copy of a table slot (or empty) */
    weld_slot *slot;
    size_t cap; /* a power of two; count stays below 3/4 of it */
    size_t count;
} weld_table;

/* Room for n distinct positions without regrowing (also allocates the cache: call it first). */
prt_status weld_table_reserve(weld_table *w, size_t n, const char *name);
void weld_table_free(weld_table *w);

/* The key of position p (finite, checked by the caller): -0 is made +0, one place. */
PRT_INLINE uint64_t weld_table_hash(const float *p) {
    uint32_t b[3];
    for (int k = 0; k < 3; k++) {
        float x = p[k] == 0.0f ? 0.0f : p[k];
        memcpy(&b[k], &x, 4);
    }
    uint64_t h = ((uint64_t)b[0] << 32 | b[1]) * 0x9E3779B97F4A7C15ull;
    h ^= (h >> 29) ^ ((uint64_t)b[2] * 0xC2B2AE3D27D4EB4Full);
    h *= 0xFF51AFD7ED558CCDull;
    return h ^ (h >> 32);
}

PRT_INLINE void weld_table_prefetch(const weld_table *w, uint64_t hash) {
    if (w->cap) __builtin_prefetch(&w->slot[hash & (w->cap - 1)]);
}

/* The index of p when the cache knows it (else UINT32_MAX); prefetches its table slot on a
 * miss, for the weld_table_corner that follows. */
PRT_INLINE uint32_t weld_table_cached(const weld_table *w, const float *p, uint64_t hash) {
    const weld_slot *e = &w->cache[(hash >> 40) & (WELD_CACHE - 1)];
    uint32_t b[3];
    for (int k = 0; k < 3; k++) {
        float x = p[k] == 0.0f ? 0.0f : p[k];
        memcpy(&b[k], &x, 4);
    }
    if (e->index1 && e->bits[0] == b[0] && e->bits[1] == b[1] && e->bits[2] == b[2]) return e->index1 - 1;
    weld_table_prefetch(w, hash);
    return UINT32_MAX;
}

/* The index of the vertex at p (hash: weld_table_hash(p)) in a, appending it to a when no
 * vertex there has p's exact position; remembered in the cache. */
prt_status weld_table_corner(weld_table *w, mesh_arrays *a, const float p[3], uint64_t hash, uint32_t *index);

#endif
