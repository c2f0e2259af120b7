/* Every crossing along a ray (prt_intersect_all): the family's walk visits every leaf the
 * segment passes through, geom/crossing.h's test counts each crossing once, and the list is
 * sorted by t, then prim. */
#include "api/query.h"
#include "core/common.h"
#include "geom/crossing.h"

#include <omp.h>
#include <stdlib.h>

/* One ray's crossings: kept in a small array, grown on the heap past it; or only counted. */
typedef struct cross_list {
    prt_hit *hits;
    uint32_t count, cap;
    bool keep, nomem;
    prt_hit local[64];
} cross_list;

static void cross_leaf(prt__query *q, const float *v, const uint32_t *prims, uint32_t n) {
    cross_list *c = q->user;
    for (uint32_t i = 0; i < n; i++, v += 9) {
        float t, u, w;
        if (!prt__tri_cross(&q->ray, v, v + 3, v + 6, q->tfar, &t, &u, &w)) continue;
        if (c->keep && c->count == c->cap && !c->nomem) {
            const uint32_t cap = c->cap * 2;
            prt_hit *h = prt__alloc((size_t)cap * sizeof *h);
            if (h) {
                memcpy(h, c->hits, (size_t)c->count * sizeof *h);
                if (c->hits != c->local) prt__free(c->hits);
                c->hits = h, c->cap = cap;
            } else {
                c->nomem = true; /* counted from here on, not kept: the caller reports it */
            }
        }
        if (c->keep && c->count < c->cap) c->hits[c->count] = (prt_hit){t, u, w, prims[i], 0};
        c->count++;
    }
}

static int hit_order(const void *x, const void *y) {
    const prt_hit *a = x, *b = y;
    if (a->t != b->t) return a->t < b->t ? -1 : 1;
    return a->prim < b->prim ? -1 : a->prim > b->prim;
}

/* Crossings of one ray (a checked): the nearest min(count, max) into hits; false on
 * failed allocation. */
static bool cross_one(const prt_accel *a, const prt_ray *r, prt_hit *hits, uint32_t max, uint32_t *count) {
    cross_list c = {.hits = NULL, .cap = 64, .keep = max > 0};
    c.hits = c.local;
    *count = 0;
    if (!prt__ray_valid(r)) return true;
    prt__query q = {.kind = PRT__QUERY_RAY, .tfar = r->tfar, .leaf = cross_leaf, .user = &c};
    prt__rayx_init(&q.ray, r);
    prt__query_walk(a, &q);
    *count = c.count;
    if (c.keep && !c.nomem) {
        qsort(c.hits, c.count, sizeof *c.hits, hit_order);
        memcpy(hits, c.hits, (size_t)(c.count < max ? c.count : max) * sizeof *hits);
    }
    if (c.hits != c.local) prt__free(c.hits);
    return !c.nomem;
}

prt_status prt_intersect_all(const prt_accel *a, const prt_ray *r, prt_hit *hits, uint32_t max, uint32_t *count) {
    prt_status s = prt__query_check(a, "prt_intersect_all");
    if (s) return s;
    if (!r || !count || (max && !hits))
        return prt__fail(PRT_ERROR_ARGUMENT, "prt_intersect_all: r and count must be set, and hits when max > 0");
    if (!cross_one(a, r, hits, max, count))
        return prt__fail(PRT_ERROR_NOMEM, "prt_intersect_all: out of memory for the crossings of one ray");
    return prt__query_done(a, "prt_intersect_all");
}

prt_status prt_intersect_all_stream(const prt_accel *a, const prt_ray *rays, size_t n, uint32_t *counts,
                                    const uint64_t *offsets, prt_hit *hits, int threads) {
    prt_status s = prt__query_check(a, "prt_intersect_all_stream");
    if (s) return s;
    if (n && (!rays || !counts || (hits && !offsets)))
        return prt__fail(PRT_ERROR_ARGUMENT,
                         "prt_intersect_all_stream: rays and counts must be set, and offsets with hits");
    if (hits)
        for (size_t i = 0; i < n; i++)
            if (offsets[i + 1] < offsets[i])
                return prt__fail(PRT_ERROR_ARGUMENT, "prt_intersect_all_stream: offsets[%zu] > offsets[%zu]", i, i + 1);
    bool nomem = false;
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 64) reduction(|| : nomem)
    for (size_t i = 0; i < n; i++) {
        const uint64_t room = hits ? offsets[i + 1] - offsets[i] : 0;
        const uint32_t max = room > UINT32_MAX ? UINT32_MAX : (uint32_t)room;
        if (!cross_one(a, &rays[i], hits ? hits + offsets[i] : NULL, max, &counts[i])) nomem = true;
    }
    if (nomem) return prt__fail(PRT_ERROR_NOMEM, "prt_intersect_all_stream: out of memory for the crossings of a ray");
    return prt__query_done(a, "prt_intersect_all_stream");
}
