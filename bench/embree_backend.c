/* Embree 3 as a reference and as a benchmark backend: one triangle geometry over shared buffers,
 * hits converted to prt_hit so results compare hit for hit, memory counted with Embree's own
 * memory monitor. Compiled only when CMake finds Embree (bench/no_embree.c otherwise). */
#include "bench.h"

#include "core/common.h"
#include "geom/closest.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct bench_embree {
    RTCDevice device;
    RTCScene scene;
    float *vertices;   /* x, y, z, pad: Embree reads vertices with 16-byte loads */
    uint32_t *indices; /* 3 per triangle */
    size_t vertex_count, triangle_count;
    atomic_llong monitor_bytes; /* net bytes Embree has allocated, from its memory monitor */
    long long tree_bytes;
    double build_seconds;
    char error[256]; /* last message from Embree's error callback (any thread) */
};

/* Embree reports every allocation it makes (positive before, negative after a free or a failed
 * allocation): the running sum is what it holds. Builds run on many threads: atomic. */
static bool em_monitor(void *user, ssize_t bytes, bool post) {
    (void)post;
    atomic_fetch_add(&((bench_embree *)user)->monitor_bytes, (long long)bytes);
    return true;
}

static void em_error(void *user, enum RTCError code, const char *str) {
    bench_embree *e = user;
    snprintf(e->error, sizeof e->error, "Embree error %d: %s", (int)code, str ? str : "");
}

bool bench_embree_available(void) { return true; }

void bench_embree_free(bench_embree *e) {
    if (!e) return;
    if (e->scene) rtcReleaseScene(e->scene);
    if (e->device) rtcReleaseDevice(e->device);
    free(e->vertices);
    free(e->indices);
    free(e);
}

prt_status bench_embree_create(const prt_mesh *m, const bench_embree_options *options, bench_embree **out) {
    *out = NULL;
    bench_embree_options o = {0};
    if (options) o = *options;
    if (!m || !m->triangle_count || m->triangle_count > 0xFFFFFFFFu || m->vertex_count > 0xFFFFFFFFu)
        return prt__fail(PRT_ERROR_ARGUMENT, "embree: empty mesh or more than 2^32 elements");
    bench_embree *e = calloc(1, sizeof *e);
    if (!e) return PRT_ERROR_NOMEM;
    /* Queries run on our threads (the caller's for the one-thread figures, an OpenMP team for
     * the others), so no "threads=1" device is needed for them: threads=N bounds the build
     * only, as prt_build_options.threads does for packrt. */
    char config[64] = "";
    if (o.threads > 0) snprintf(config, sizeof config, "threads=%d", o.threads);
    e->device = rtcNewDevice(config[0] ? config : NULL);
    if (!e->device) {
        free(e);
        return prt__fail(PRT_ERROR_UNSUPPORTED, "embree: rtcNewDevice failed (%d)", (int)rtcGetDeviceError(NULL));
    }
    rtcSetDeviceErrorFunction(e->device, em_error, e);
    rtcSetDeviceMemoryMonitorFunction(e->device, em_monitor, e);

    double t0 = prt__now();
    long long before = atomic_load(&e->monitor_bytes);
    e->vertex_count = m->vertex_count;
    e->triangle_count = m->triangle_count;
    /* Aligned so Embree may use aligned 16-byte loads on the vertex buffer. */
    e->vertices = aligned_alloc(64, ((16 * m->vertex_count + 63) / 64) * 64);
    e->indices = malloc(12 * m->triangle_count);
    if (!e->vertices || !e->indices) {
        bench_embree_free(e);
        return PRT_ERROR_NOMEM;
    }
    for (size_t i = 0; i < m->vertex_count; i++) {
        memcpy(&e->vertices[4 * i], &m->vertices[3 * i], 12);
        e->vertices[4 * i + 3] = 0.0f;
    }
    memcpy(e->indices, m->triangles, 12 * m->triangle_count);

    e->scene = rtcNewScene(e->device);
    int flags = (o.robust ? RTC_SCENE_FLAG_ROBUST : 0) | (o.compact ? RTC_SCENE_FLAG_COMPACT : 0);
    rtcSetSceneFlags(e->scene, (enum RTCSceneFlags)flags);
    if (o.quality >= 1 && o.quality <= 3) rtcSetSceneBuildQuality(e->scene, (enum RTCBuildQuality)(o.quality - 1));
    RTCGeometry g = rtcNewGeometry(e->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, e->vertices, 0, 16, m->vertex_count);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, e->indices, 0, 12, m->triangle_count);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(e->scene, g, 0); /* geomID 0: prt_hit.geom is 0 too */
    rtcReleaseGeometry(g);
    rtcCommitScene(e->scene);
    e->build_seconds = prt__now() - t0;
    e->tree_bytes = atomic_load(&e->monitor_bytes) - before;
    if (rtcGetDeviceError(e->device) != RTC_ERROR_NONE || e->error[0]) {
        prt_status s = prt__fail(PRT_ERROR_UNSUPPORTED, "embree: %s", e->error[0] ? e->error : "build failed");
        bench_embree_free(e);
        return s;
    }
    *out = e;
    return PRT_OK;
}

void bench_embree_stats(const bench_embree *e, prt_stats *s) {
    memset(s, 0, sizeof *s);
    s->triangles = e->triangle_count;
    s->triangles_built = e->triangle_count;
    /* The split rule (docs/benchmark.md): "tree" is everything Embree allocated and still holds
     * after the build, as its memory monitor counts it: BVH nodes and the triangle data Embree
     * copies into its leaves (Triangle4 & co.). "geometry" is the shared buffers it reads,
     * which the application owns: 16 bytes per padded vertex, 12 per triangle. */
    s->bytes_tree = e->tree_bytes > 0 ? (size_t)e->tree_bytes : 0;
    s->bytes_geometry = 16 * e->vertex_count + 12 * e->triangle_count;
    s->bytes_other = 0;
    s->build_seconds = e->build_seconds;
}

/* ---- conversions ----------------------------------------------------------------------- */

static inline void em_ray(const prt_ray *r, struct RTCRay *q, unsigned id) {
    q->org_x = r->org[0], q->org_y = r->org[1], q->org_z = r->org[2], q->tnear = r->tnear;
    q->dir_x = r->dir[0], q->dir_y = r->dir[1], q->dir_z = r->dir[2], q->time = 0.0f;
    q->tfar = r->tfar, q->mask = 0xFFFFFFFFu, q->id = id, q->flags = 0;
}

static inline void em_rayhit(const prt_ray *r, struct RTCRayHit *q, unsigned id) {
    em_ray(r, &q->ray, id);
    q->hit.geomID = RTC_INVALID_GEOMETRY_ID;
    q->hit.primID = RTC_INVALID_GEOMETRY_ID;
    q->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

static inline void em_hit(const struct RTCRayHit *q, prt_hit *h) {
    if (q->hit.geomID == RTC_INVALID_GEOMETRY_ID) {
        h->t = INFINITY, h->u = h->v = 0.0f, h->prim = PRT_INVALID, h->geom = 0;
    } else {
        h->t = q->ray.tfar, h->u = q->hit.u, h->v = q->hit.v, h->prim = q->hit.primID, h->geom = 0;
    }
}

/* ---- the reference API (tests) ---------------------------------------------------------- */

void bench_embree_intersect(const bench_embree *e, prt_ray *r, prt_hit *h) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit q;
    em_rayhit(r, &q, 0);
    rtcIntersect1(e->scene, &ctx, &q);
    em_hit(&q, h);
    if (h->prim != PRT_INVALID) r->tfar = h->t;
}

bool bench_embree_occluded(const bench_embree *e, const prt_ray *r) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay q;
    em_ray(r, &q, 0);
    rtcOccluded1(e->scene, &ctx, &q);
    return q.tfar < 0.0f; /* Embree marks an occluded ray with tfar = -inf */
}

void bench_embree_intersect_coherent(const bench_embree *e, prt_ray *rays, prt_hit *hits, uint32_t n) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    _Alignas(64) struct RTCRayHit q[PRT_PACKET_MAX];
    n = n < PRT_PACKET_MAX ? n : PRT_PACKET_MAX;
    for (uint32_t i = 0; i < n; i++) em_rayhit(&rays[i], &q[i], i);
    rtcIntersect1M(e->scene, &ctx, q, n, sizeof q[0]);
    for (uint32_t i = 0; i < n; i++) {
        em_hit(&q[i], &hits[i]);
        if (hits[i].prim != PRT_INVALID) rays[i].tfar = hits[i].t;
    }
}

void bench_embree_intersect_stream(const bench_embree *e, prt_ray *rays, prt_hit *hits, size_t n, int threads) {
    long ln = (long)n;
#pragma omp parallel for schedule(dynamic, 64) num_threads(prt__threads(threads))
    for (long i = 0; i < ln; i++) bench_embree_intersect(e, &rays[i], &hits[i]);
}

void bench_embree_occluded_stream(const bench_embree *e, const prt_ray *rays, uint8_t *occluded, size_t n,
                                  int threads) {
    long ln = (long)n;
#pragma omp parallel for schedule(dynamic, 64) num_threads(prt__threads(threads))
    for (long i = 0; i < ln; i++) occluded[i] = bench_embree_occluded(e, &rays[i]);
}

/* ---- the benchmark backend -------------------------------------------------------------- */

/* Rays are converted once at load; a pristine copy restores them before each timed run. */
struct bench_batch {
    bench_rays layout;                 /* kind, count, tiles (rays borrowed) */
    struct RTCRayHit *work, *pristine; /* closest hit */
    struct RTCRay *rwork, *rpristine;  /* any hit */
};

static bench_batch *em_load(void *self, const bench_rays *r) {
    (void)self;
    bench_batch *b = calloc(1, sizeof *b);
    if (!b) return NULL;
    size_t n = r->count ? r->count : 1;
    b->layout = *r;
    b->layout.pixel = NULL;
    if (r->any_hit) {
        b->rwork = aligned_alloc(64, ((n * sizeof(struct RTCRay) + 63) / 64) * 64);
        b->rpristine = aligned_alloc(64, ((n * sizeof(struct RTCRay) + 63) / 64) * 64);
        if (!b->rwork || !b->rpristine) goto fail;
        for (size_t i = 0; i < r->count; i++) em_ray(&r->rays[i], &b->rpristine[i], (unsigned)i);
    } else {
        b->work = aligned_alloc(64, ((n * sizeof(struct RTCRayHit) + 63) / 64) * 64);
        b->pristine = aligned_alloc(64, ((n * sizeof(struct RTCRayHit) + 63) / 64) * 64);
        if (!b->work || !b->pristine) goto fail;
        for (size_t i = 0; i < r->count; i++) em_rayhit(&r->rays[i], &b->pristine[i], (unsigned)i);
    }
    return b;
fail:
    free(b->rwork), free(b->rpristine), free(b->work), free(b->pristine), free(b);
    return NULL;
}

static void em_reset(void *self, bench_batch *b) {
    (void)self;
    if (b->rwork) memcpy(b->rwork, b->rpristine, b->layout.count * sizeof *b->rwork);
    else memcpy(b->work, b->pristine, b->layout.count * sizeof *b->work);
}

static void em_single(void *self, bench_batch *b, size_t first, size_t count) {
    const bench_embree *e = self;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    if (b->rwork)
        for (size_t i = first; i < first + count; i++) rtcOccluded1(e->scene, &ctx, &b->rwork[i]);
    else
        for (size_t i = first; i < first + count; i++) rtcIntersect1(e->scene, &ctx, &b->work[i]);
}

/* Rays per rtcIntersect1M call for untiled sets: long enough for Embree's stream code to
 * gather packets, short enough to balance threads. */
#define EM_CHUNK 256

static void em_stream(void *self, bench_batch *b, int threads) {
    const bench_embree *e = self;
    bool tiles = b->layout.tile != 0;
    long chunks = tiles ? (long)bench_rays_tile_count(&b->layout) : (long)((b->layout.count + EM_CHUNK - 1) / EM_CHUNK);
#pragma omp parallel num_threads(threads) if (threads > 1)
    {
        struct RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        /* A tile is a coherent packet: tell Embree, which then traces it in SIMD packets. */
        ctx.flags = tiles ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
#pragma omp for schedule(dynamic, 4)
        for (long c = 0; c < chunks; c++) {
            size_t first;
            uint32_t count, width;
            if (tiles) {
                bench_rays_tile(&b->layout, (size_t)c, &first, &count, &width);
            } else {
                first = (size_t)c * EM_CHUNK;
                count = (uint32_t)(b->layout.count - first < EM_CHUNK ? b->layout.count - first : EM_CHUNK);
            }
            if (b->rwork) rtcOccluded1M(e->scene, &ctx, &b->rwork[first], count, sizeof *b->rwork);
            else rtcIntersect1M(e->scene, &ctx, &b->work[first], count, sizeof *b->work);
        }
    }
}

static void em_results(void *self, const bench_batch *b, prt_hit *hits, uint8_t *occluded) {
    (void)self;
    if (hits && b->work)
        for (size_t i = 0; i < b->layout.count; i++) em_hit(&b->work[i], &hits[i]);
    if (occluded && b->rwork)
        for (size_t i = 0; i < b->layout.count; i++) occluded[i] = b->rwork[i].tfar < 0.0f;
}

static void em_unload(void *self, bench_batch *b) {
    (void)self;
    if (!b) return;
    free(b->rwork), free(b->rpristine), free(b->work), free(b->pristine), free(b);
}

static void em_stats(void *self, prt_stats *s) { bench_embree_stats(self, s); }

bench_backend bench_backend_embree(bench_embree *e, const char *name) {
    bench_backend b = {
        name ? name : "embree", e, em_load, em_reset, em_single, em_stream, em_results, em_unload, em_stats};
    return b;
}

/* Closest points the way Embree's closest_point tutorial finds them: rtcPointQuery walks the
 * BVH by the query sphere and calls back for every triangle it reaches; the callback takes
 * the triangle's closest point and shrinks the sphere. The callback computes in double with
 * the same function as packrt (geom/closest.h), so the two differ only in their walks. */
typedef struct em_closest {
    const bench_embree *e;
    double d2, u, v;
    uint32_t prim;
} em_closest;

static bool em_closest_cb(struct RTCPointQueryFunctionArguments *args) {
    em_closest *c = args->userPtr;
    const bench_embree *e = c->e;
    const uint32_t *t = e->indices + 3 * (size_t)args->primID;
    double v[3][3];
    for (int k = 0; k < 3; k++)
        for (int x = 0; x < 3; x++) v[k][x] = e->vertices[4 * (size_t)t[k] + x];
    const double p[3] = {args->query->x, args->query->y, args->query->z};
    double u, w;
    const double d2 = prt__closest_on_triangle(p, v[0], v[1], v[2], &u, &w);
    if (d2 > c->d2 || (d2 == c->d2 && args->primID > c->prim)) return false;
    c->d2 = d2, c->u = u, c->v = w, c->prim = args->primID;
    args->query->radius = (float)sqrt(d2) * 1.0000002f; /* never below the true distance */
    return true;
}

void bench_embree_closest_points(const bench_embree *e, const float *points, size_t n, prt_closest *out) {
    for (size_t i = 0; i < n; i++) {
        const float *p = points + 3 * i;
        struct RTCPointQuery q = {p[0], p[1], p[2], 0.0f, INFINITY};
        struct RTCPointQueryContext ctx;
        rtcInitPointQueryContext(&ctx);
        em_closest c = {e, INFINITY, 0, 0, PRT_INVALID};
        rtcPointQuery(e->scene, &q, &ctx, em_closest_cb, &c);
        out[i] = (prt_closest){{0, 0, 0}, INFINITY, 0, 0, PRT_INVALID};
        if (c.prim == PRT_INVALID) continue;
        const uint32_t *t = e->indices + 3 * (size_t)c.prim;
        for (int x = 0; x < 3; x++) {
            const double a = e->vertices[4 * (size_t)t[0] + x], b = e->vertices[4 * (size_t)t[1] + x];
            const double d = e->vertices[4 * (size_t)t[2] + x];
            out[i].point[x] = (float)(a + c.u * (b - a) + c.v * (d - a));
        }
        out[i].distance = (float)sqrt(c.d2), out[i].u = (float)c.u, out[i].v = (float)c.v, out[i].prim = c.prim;
    }
}
