/* Embree rebuilt every frame (see embree_animate.h). The vertex buffer is Embree's own
 * (rtcSetNewGeometryBuffer, 16-byte stride); an update copies the positions in, marks the
 * buffer changed and commits geometry and scene: with a DYNAMIC scene and LOW quality
 * Embree rebuilds its BVH with its fast builder. */
#include "embree_animate.h"
#include "core/common.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

struct bench_embree_anim {
    RTCDevice device;
    RTCScene scene;
    RTCGeometry geom;
    float *vertices; /* Embree's buffer, 4 floats a vertex */
    size_t vertex_count;
};

void bench_embree_anim_free(bench_embree_anim *e) {
    if (!e) return;
    if (e->scene) rtcReleaseScene(e->scene);
    if (e->geom) rtcReleaseGeometry(e->geom);
    if (e->device) rtcReleaseDevice(e->device);
    free(e);
}

prt_status bench_embree_anim_create(const prt_mesh *m, int threads, bench_embree_anim **out) {
    *out = NULL;
    if (!m || !m->triangle_count || m->triangle_count > 0xFFFFFFFFu || m->vertex_count > 0xFFFFFFFFu)
        return prt__fail(PRT_ERROR_ARGUMENT, "embree: empty mesh or more than 2^32 elements");
    bench_embree_anim *e = calloc(1, sizeof *e);
    if (!e) return PRT_ERROR_NOMEM;
    char config[64] = "";
    if (threads > 0) snprintf(config, sizeof config, "threads=%d", threads);
    e->device = rtcNewDevice(config[0] ? config : NULL);
    if (!e->device) {
        free(e);
        return prt__fail(PRT_ERROR_UNSUPPORTED, "embree: rtcNewDevice failed");
    }
    e->scene = rtcNewScene(e->device);
    rtcSetSceneFlags(e->scene, RTC_SCENE_FLAG_DYNAMIC);
    rtcSetSceneBuildQuality(e->scene, RTC_BUILD_QUALITY_LOW);
    e->geom = rtcNewGeometry(e->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(e->geom, RTC_BUILD_QUALITY_LOW);
    e->vertex_count = m->vertex_count;
    e->vertices = rtcSetNewGeometryBuffer(e->geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 16, m->vertex_count);
    uint32_t *idx = rtcSetNewGeometryBuffer(e->geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, m->triangle_count);
    if (!e->vertices || !idx) {
        bench_embree_anim_free(e);
        return prt__fail(PRT_ERROR_NOMEM, "embree: buffers");
    }
    memcpy(idx, m->triangles, 12 * m->triangle_count);
    rtcAttachGeometryByID(e->scene, e->geom, 0);
    prt_status s = bench_embree_anim_update(e, m->vertices);
    if (s) {
        bench_embree_anim_free(e);
        return s;
    }
    *out = e;
    return PRT_OK;
}

prt_status bench_embree_anim_update(bench_embree_anim *e, const float *vertices) {
    for (size_t i = 0; i < e->vertex_count; i++) {
        memcpy(&e->vertices[4 * i], &vertices[3 * i], 12);
        e->vertices[4 * i + 3] = 0.0f;
    }
    rtcUpdateGeometryBuffer(e->geom, RTC_BUFFER_TYPE_VERTEX, 0);
    rtcCommitGeometry(e->geom);
    rtcCommitScene(e->scene);
    if (rtcGetDeviceError(e->device) != RTC_ERROR_NONE)
        return prt__fail(PRT_ERROR_UNSUPPORTED, "embree: commit failed");
    return PRT_OK;
}

void bench_embree_anim_intersect16(const bench_embree_anim *e, const prt_ray *rays, prt_hit *hits, int count) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    _Alignas(64) struct RTCRayHit16 q;
    _Alignas(64) int valid[16];
    for (int i = 0; i < 16; i++) {
        valid[i] = i < count ? -1 : 0;
        const prt_ray *r = &rays[i < count ? i : 0];
        q.ray.org_x[i] = r->org[0], q.ray.org_y[i] = r->org[1], q.ray.org_z[i] = r->org[2];
        q.ray.dir_x[i] = r->dir[0], q.ray.dir_y[i] = r->dir[1], q.ray.dir_z[i] = r->dir[2];
        q.ray.tnear[i] = r->tnear, q.ray.tfar[i] = r->tfar, q.ray.time[i] = 0;
        q.ray.mask[i] = 0xFFFFFFFFu, q.ray.id[i] = (unsigned)i, q.ray.flags[i] = 0;
        q.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID, q.hit.primID[i] = RTC_INVALID_GEOMETRY_ID;
        q.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect16(valid, e->scene, &ctx, &q);
    for (int i = 0; i < count; i++) {
        if (q.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID) hits[i] = (prt_hit){INFINITY, 0, 0, PRT_INVALID, 0};
        else hits[i] = (prt_hit){q.ray.tfar[i], q.hit.u[i], q.hit.v[i], q.hit.primID[i], 0};
    }
}

void bench_embree_anim_occluded16(const bench_embree_anim *e, const prt_ray *rays, uint8_t *occluded, int count) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    _Alignas(64) struct RTCRay16 q;
    _Alignas(64) int valid[16];
    for (int i = 0; i < 16; i++) {
        valid[i] = i < count ? -1 : 0;
        const prt_ray *r = &rays[i < count ? i : 0];
        q.org_x[i] = r->org[0], q.org_y[i] = r->org[1], q.org_z[i] = r->org[2];
        q.dir_x[i] = r->dir[0], q.dir_y[i] = r->dir[1], q.dir_z[i] = r->dir[2];
        q.tnear[i] = r->tnear, q.tfar[i] = r->tfar, q.time[i] = 0;
        q.mask[i] = 0xFFFFFFFFu, q.id[i] = (unsigned)i, q.flags[i] = 0;
    }
    rtcOccluded16(valid, e->scene, &ctx, &q);
    /* Embree sets tfar to -inf for every occluded ray. */
    for (int i = 0; i < count; i++) occluded[i] = q.tfar[i] == -INFINITY;
}
