/* Embree for animated scenes (packrt animate --vs embree): one triangle mesh in a scene
 * with RTC_SCENE_FLAG_DYNAMIC and RTC_BUILD_QUALITY_LOW, rebuilt from new vertex positions
 * every frame, traced with 16-wide packets (rtcIntersect16) as the coherent-grid paper's
 * competitors trace primary rays. bench/embree_animate.c with Embree, stubs in
 * bench/no_embree_animate.c without. */
#ifndef PRT_BENCH_EMBREE_ANIMATE_H
#define PRT_BENCH_EMBREE_ANIMATE_H

#include "packrt.h"

typedef struct bench_embree_anim bench_embree_anim;

/* threads bounds Embree's build threads (0: all cores). PRT_ERROR_UNSUPPORTED without Embree. */
prt_status bench_embree_anim_create(const prt_mesh *m, int threads, bench_embree_anim **out);
/* Copy new positions of m's vertices in and rebuild (rtcCommitScene). */
prt_status bench_embree_anim_update(bench_embree_anim *e, const float *vertices);
/* Closest hits of up to 16 rays (rtcIntersect16, coherent context). */
void bench_embree_anim_intersect16(const bench_embree_anim *e, const prt_ray *rays, prt_hit *hits, int count);
/* Any hit of up to 16 rays (rtcOccluded16, coherent context): occluded[i] = 1 when blocked. */
void bench_embree_anim_occluded16(const bench_embree_anim *e, const prt_ray *rays, uint8_t *occluded, int count);
void bench_embree_anim_free(bench_embree_anim *e);

#endif
