/* The Embree wrapper's stand-ins for builds without Embree (CMake compiles bench/embree_*.c
 * only when it finds Embree): every entry point exists, creation says PRT_ERROR_UNSUPPORTED. */
#include "bench.h"

#ifndef PRT_HAVE_EMBREE

#include "core/common.h"

#include <math.h>
#include <string.h>

bool bench_embree_available(void) { return false; }

prt_status bench_embree_create(const prt_mesh *m, const bench_embree_options *options, bench_embree **out) {
    (void)m, (void)options;
    *out = NULL;
    return prt__fail(PRT_ERROR_UNSUPPORTED, "this build has no Embree (libembree-dev was not found by CMake)");
}

void bench_embree_free(bench_embree *e) { (void)e; }

void bench_embree_closest_points(const bench_embree *e, const float *points, size_t n, prt_closest *out) {
    (void)e, (void)points, (void)n, (void)out;
}

/* Unreachable without a bench_embree; defined so callers link. */
void bench_embree_intersect(const bench_embree *e, prt_ray *r, prt_hit *h) {
    (void)e, (void)r;
    h->t = INFINITY, h->u = h->v = 0.0f, h->prim = PRT_INVALID, h->geom = 0;
}

void bench_embree_intersect_coherent(const bench_embree *e, prt_ray *rays, prt_hit *hits, uint32_t n) {
    for (uint32_t i = 0; i < n; i++) bench_embree_intersect(e, &rays[i], &hits[i]);
}

prt_status bench_embree_accel(const prt_mesh *m, const bench_embree_options *options, prt_accel **out) {
    (void)m, (void)options;
    *out = NULL;
    return prt__fail(PRT_ERROR_UNSUPPORTED, "this build has no Embree (libembree-dev was not found by CMake)");
}

bool bench_embree_occluded(const bench_embree *e, const prt_ray *r) {
    (void)e, (void)r;
    return false;
}

void bench_embree_intersect_stream(const bench_embree *e, prt_ray *rays, prt_hit *hits, size_t n, int threads) {
    (void)threads;
    for (size_t i = 0; i < n; i++) bench_embree_intersect(e, &rays[i], &hits[i]);
}

void bench_embree_occluded_stream(const bench_embree *e, const prt_ray *rays, uint8_t *occluded, size_t n,
                                  int threads) {
    (void)e, (void)rays, (void)threads;
    memset(occluded, 0, n);
}

void bench_embree_stats(const bench_embree *e, prt_stats *s) {
    (void)e;
    memset(s, 0, sizeof *s);
}

bench_backend bench_backend_embree(bench_embree *e, const char *name) {
    (void)e;
    bench_backend b = {name ? name : "embree", NULL, NULL, NULL, NULL, NULL, NULL, NULL, NULL};
    return b;
}

#else
/* ISO C forbids an empty translation unit. */
typedef int bench_no_embree_unused;
#endif
