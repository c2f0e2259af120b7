/* Stand-ins for bench/embree_animate.c in builds without Embree. */
#include "embree_animate.h"

#ifndef PRT_HAVE_EMBREE

#include "core/common.h"

#include <math.h>

prt_status bench_embree_anim_create(const prt_mesh *m, int threads, bench_embree_anim **out) {
    (void)m, (void)threads;
    *out = NULL;
    return prt__fail(PRT_ERROR_UNSUPPORTED, "this build has no Embree (libembree-dev was not found by CMake)");
}

prt_status bench_embree_anim_update(bench_embree_anim *e, const float *vertices) {
    (void)e, (void)vertices;
    return PRT_ERROR_UNSUPPORTED;
}

void bench_embree_anim_intersect16(const bench_embree_anim *e, const prt_ray *rays, prt_hit *hits, int count) {
    (void)e, (void)rays;
    for (int i = 0; i < count; i++) hits[i] = (prt_hit){INFINITY, 0, 0, PRT_INVALID, 0};
}

void bench_embree_anim_occluded16(const bench_embree_anim *e, const prt_ray *rays, uint8_t *occluded, int count) {
    (void)e, (void)rays;
    for (int i = 0; i < count; i++) occluded[i] = 0;
}

void bench_embree_anim_free(bench_embree_anim *e) { (void)e; }

#endif
