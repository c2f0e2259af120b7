/* Benchmark ray workloads (docs/benchmark.md): Rouwé's random rays, tiled primary rays, shadow and
 * diffuse rays from primary hits. Everything is a pure function of its inputs and the seed, so
 * every backend, run and machine casts exactly the same rays. */
#include "bench.h"

#include "core/rng.h"
#include "core/vec.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define BENCH_PI 3.14159265358979323846f

static inline uint32_t min_u32(uint32_t a, uint32_t b) { return a < b ? a : b; }

static const char *const g_names[BENCH_WORKLOAD_COUNT] = {"random", "primary", "shadow", "diffuse"};

const char *bench_workload_name(bench_workload w) { return (unsigned)w < BENCH_WORKLOAD_COUNT ? g_names[w] : "?"; }

bool bench_workload_parse(const char *name, bench_workload *out) {
    for (int i = 0; i < BENCH_WORKLOAD_COUNT; i++)
        if (!strcmp(name, g_names[i])) {
            *out = (bench_workload)i;
            return true;
        }
    return false;
}

void bench_rays_free(bench_rays *r) {
    if (!r) return;
    free(r->rays);
    free(r->pixel);
    memset(r, 0, sizeof *r);
}

static prt_status alloc_rays(bench_rays *out, bench_workload kind, size_t count) {
    memset(out, 0, sizeof *out);
    out->kind = kind;
    out->rays = malloc((count ? count : 1) * sizeof *out->rays);
    if (!out->rays) return PRT_ERROR_NOMEM;
    out->count = count;
    return PRT_OK;
}

static double diagonal(const float lo[3], const float hi[3]) {
    double d = 0;
    for (int k = 0; k < 3; k++) d += ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
    return sqrt(d);
}

/* ---- random ---------------------------------------------------------------------------- */

/* Uniform direction on the unit sphere (z uniform in [-1, 1], angle uniform). */
static prt_vec3 unit_sphere(prt_rng *g) {
    float z = 1.0f - 2.0f * prt_rng_float(g);
    float phi = 2.0f * BENCH_PI * prt_rng_float(g);
    float s = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    return prt_v3(s * cosf(phi), s * sinf(phi), z);
}

prt_status bench_rays_random(const float lo[3], const float hi[3], size_t count, uint64_t seed, bench_rays *out) {
    prt_status s = alloc_rays(out, BENCH_RANDOM, count);
    if (s) return s;
    /* RayCastTest (TestRaycast.cpp) enlarges the bounds by 10% of their size on each side "so
     * we'll do some raycasts around the edges", takes radius = half the enlarged diagonal, and
     * draws origin = radius * sRandom(), target = radius / 4 * sRandom() about the centre.
     * Its sRandom() draws theta uniformly in [0, pi], which crowds points at the poles, and
     * puts the target on the small sphere's surface. We use the unbiased version:
     * origin uniform on the sphere, target uniform inside the small ball. Same scale, same
     * hit rate in spirit; no pole artefacts that depend on the mesh's orientation. */
    prt_vec3 l = prt_v3_load(lo), h = prt_v3_load(hi);
    prt_vec3 d = prt_v3_sub(h, l);
    prt_vec3 elo = prt_v3_sub(l, prt_v3_scale(d, 0.1f)), ehi = prt_v3_add(h, prt_v3_scale(d, 0.1f));
    prt_vec3 mid = prt_v3_scale(prt_v3_add(elo, ehi), 0.5f);
    float radius = 0.5f * prt_v3_len(prt_v3_sub(ehi, elo));
    if (!(radius > 0.0f)) radius = 1.0f; /* a single point: any sphere around it will do */
    /* One sequential stream: ray i depends on the seed and on i only, so the first 1024 rays
     * (the paper's batch) are the same whatever the count. */
    prt_rng g = prt_rng_seed(seed, 0x52414e44u /* "RAND" */);
    for (size_t i = 0; i < count; i++) {
        prt_vec3 o = prt_v3_add(mid, prt_v3_scale(unit_sphere(&g), radius));
        float rr = 0.25f * radius * cbrtf(prt_rng_float(&g));
        prt_vec3 t = prt_v3_add(mid, prt_v3_scale(unit_sphere(&g), rr));
        prt_vec3 dir = prt_v3_norm(prt_v3_sub(t, o));
        prt_ray *r = &out->rays[i];
        r->org[0] = o.x, r->org[1] = o.y, r->org[2] = o.z, r->tnear = 0.0f;
        r->dir[0] = dir.x, r->dir[1] = dir.y, r->dir[2] = dir.z, r->tfar = INFINITY;
    }
    return PRT_OK;
}

/* ---- primary --------------------------------------------------------------------------- */

void bench_camera_default(const float lo[3], const float hi[3], bench_camera *c) {
    /* The library's default framing, so benchmark primary rays are the renderer's rays. */
    prt_camera pc;
    prt_camera_default(lo, hi, &pc);
    memcpy(c->eye, pc.eye, sizeof c->eye);
    memcpy(c->target, pc.target, sizeof c->target);
    memcpy(c->up, pc.up, sizeof c->up);
    c->fov_y_deg = pc.fov_y_deg;
}

size_t bench_rays_tile_count(const bench_rays *r) {
    if (!r->tile || !r->width || !r->height) return 1;
    size_t tx = (r->width + r->tile - 1) / r->tile, ty = (r->height + r->tile - 1) / r->tile;
    return tx * ty;
}

void bench_rays_tile(const bench_rays *r, size_t i, size_t *first, uint32_t *count, uint32_t *width) {
    if (!r->tile || !r->width || !r->height) {
        *first = 0, *count = (uint32_t)r->count, *width = (uint32_t)r->count;
        return;
    }
    uint32_t T = r->tile, ntx = (r->width + T - 1) / T;
    uint32_t tx = (uint32_t)(i % ntx), ty = (uint32_t)(i / ntx);
    uint32_t w = min_u32(T, r->width - tx * T), h = min_u32(T, r->height - ty * T);
    /* Full tile rows above hold T * width rays; tiles to the left in this row are h tall. */
    *first = (size_t)ty * T * r->width + (size_t)tx * T * h;
    *count = w * h;
    *width = w;
}

size_t bench_rays_pixel_index(const bench_rays *r, uint32_t x, uint32_t y) {
    if (!r->tile) return (size_t)y * r->width + x;
    uint32_t T = r->tile, tx = x / T, ty = y / T;
    uint32_t w = min_u32(T, r->width - tx * T), h = min_u32(T, r->height - ty * T);
    return (size_t)ty * T * r->width + (size_t)tx * T * h + (size_t)(y - ty * T) * w + (x - tx * T);
}

prt_status bench_rays_primary(const bench_camera *c, uint32_t width, uint32_t height, uint32_t tile, bench_rays *out) {
    if (!width || !height) return PRT_ERROR_ARGUMENT;
    prt_status s = alloc_rays(out, BENCH_PRIMARY, (size_t)width * height);
    if (s) return s;
    out->width = width, out->height = height, out->tile = tile ? tile : 8;
    prt_vec3 eye = prt_v3_load(c->eye);
    prt_vec3 fwd = prt_v3_norm(prt_v3_sub(prt_v3_load(c->target), eye));
    prt_vec3 right = prt_v3_norm(prt_v3_cross(fwd, prt_v3_load(c->up)));
    prt_vec3 up = prt_v3_cross(right, fwd);
    float ty = tanf(0.5f * c->fov_y_deg * BENCH_PI / 180.0f), tx = ty * (float)width / (float)height;
    for (uint32_t y = 0; y < height; y++)
        for (uint32_t x = 0; x < width; x++) {
            float sx = (2.0f * ((float)x + 0.5f) / (float)width - 1.0f) * tx;
            float sy = (1.0f - 2.0f * ((float)y + 0.5f) / (float)height) * ty;
            prt_vec3 d = prt_v3_norm(prt_v3_add(fwd, prt_v3_add(prt_v3_scale(right, sx), prt_v3_scale(up, sy))));
            prt_ray *r = &out->rays[bench_rays_pixel_index(out, x, y)];
            r->org[0] = eye.x, r->org[1] = eye.y, r->org[2] = eye.z, r->tnear = 0.0f;
            r->dir[0] = d.x, r->dir[1] = d.y, r->dir[2] = d.z, r->tfar = INFINITY;
        }
    return PRT_OK;
}

/* ---- secondary rays from primary hits -------------------------------------------------- */

void bench_light_default(const float lo[3], const float hi[3], float light[3]) {
    float r = 0.5f * (float)diagonal(lo, hi);
    if (!(r > 0.0f)) r = 1.0f;
    /* Above (+y), in front (+z, the camera's side) and to the left (-x): the camera sees both
     * lit and shadowed surfaces. 2.5 radii out, well outside the bounds. */
    prt_vec3 dir = prt_v3_norm(prt_v3(-0.5f, 1.0f, 0.6f));
    for (int k = 0; k < 3; k++) light[k] = 0.5f * (lo[k] + hi[k]) + 2.5f * r * (&dir.x)[k];
}

/* Hit point and unit geometric normal facing the incoming ray, or false for a miss or a hit
 * naming a triangle the mesh does not have. */
static bool hit_frame(const prt_mesh *m, const prt_ray *ray, const prt_hit *h, prt_vec3 *p, prt_vec3 *n) {
    if (h->prim == PRT_INVALID || h->prim >= m->triangle_count) return false;
    const uint32_t *t = &m->triangles[3 * (size_t)h->prim];
    prt_vec3 a = prt_v3_load(&m->vertices[3 * (size_t)t[0]]);
    prt_vec3 b = prt_v3_load(&m->vertices[3 * (size_t)t[1]]);
    prt_vec3 c = prt_v3_load(&m->vertices[3 * (size_t)t[2]]);
    /* The barycentric point rather than org + t * dir: it lies on the triangle whatever the
     * error in t, so the offset below is measured from the surface. */
    float w = 1.0f - h->u - h->v;
    *p = prt_v3_add(prt_v3_scale(a, w), prt_v3_add(prt_v3_scale(b, h->u), prt_v3_scale(c, h->v)));
    prt_vec3 g = prt_v3_cross(prt_v3_sub(b, a), prt_v3_sub(c, a));
    float len = prt_v3_len(g);
    if (!(len > 0.0f)) return false;
    g = prt_v3_scale(g, 1.0f / len);
    if (prt_v3_dot(g, prt_v3_load(ray->dir)) > 0.0f) g = prt_v3_scale(g, -1.0f);
    *n = g;
    return true;
}

static size_t count_hits(const prt_mesh *m, const bench_rays *primary, const prt_hit *hits) {
    size_t n = 0;
    for (size_t i = 0; i < primary->count; i++) {
        prt_vec3 p, nn;
        n += hit_frame(m, &primary->rays[i], &hits[i], &p, &nn);
    }
    return n;
}

static prt_status alloc_secondary(bench_rays *out, bench_workload kind, size_t count) {
    prt_status s = alloc_rays(out, kind, count);
    if (s) return s;
    out->pixel = malloc((count ? count : 1) * sizeof *out->pixel);
    if (!out->pixel) {
        bench_rays_free(out);
        return PRT_ERROR_NOMEM;
    }
    return PRT_OK;
}

prt_status bench_rays_shadow(const prt_mesh *m, const bench_rays *primary, const prt_hit *hits, const float light[3],
                             float eps, bench_rays *out) {
    prt_status s = alloc_secondary(out, BENCH_SHADOW, count_hits(m, primary, hits));
    if (s) return s;
    out->any_hit = true;
    prt_vec3 L = prt_v3_load(light);
    size_t k = 0;
    for (size_t i = 0; i < primary->count; i++) {
        prt_vec3 p, n;
        if (!hit_frame(m, &primary->rays[i], &hits[i], &p, &n)) continue;
        prt_vec3 o = prt_v3_add(p, prt_v3_scale(n, eps));
        prt_vec3 d = prt_v3_sub(L, o);
        float dist = prt_v3_len(d);
        d = prt_v3_scale(d, 1.0f / dist);
        prt_ray *r = &out->rays[k];
        r->org[0] = o.x, r->org[1] = o.y, r->org[2] = o.z, r->tnear = 0.0f;
        r->dir[0] = d.x, r->dir[1] = d.y, r->dir[2] = d.z, r->tfar = dist;
        out->pixel[k++] = (uint32_t)i;
    }
    return PRT_OK;
}

prt_status bench_rays_diffuse(const prt_mesh *m, const bench_rays *primary, const prt_hit *hits, uint64_t seed,
                              float eps, bench_rays *out) {
    prt_status s = alloc_secondary(out, BENCH_DIFFUSE, count_hits(m, primary, hits));
    if (s) return s;
    size_t k = 0;
    for (size_t i = 0; i < primary->count; i++) {
        prt_vec3 p, n;
        if (!hit_frame(m, &primary->rays[i], &hits[i], &p, &n)) continue;
        /* A generator per pixel: the bounce from pixel i is the same whatever other pixels hit. */
        prt_rng g = prt_rng_seed(seed ^ 0xD1FF05Eull, (uint64_t)i);
        float r1 = prt_rng_float(&g), r2 = prt_rng_float(&g);
        /* Cosine-weighted hemisphere (Malley): uniform disc point lifted to the hemisphere. */
        float phi = 2.0f * BENCH_PI * r1, sr = sqrtf(r2);
        float lx = sr * cosf(phi), ly = sr * sinf(phi), lz = sqrtf(fmaxf(0.0f, 1.0f - r2));
        /* Orthonormal basis about n (Duff et al. 2017, branchless). */
        float sign = copysignf(1.0f, n.z), a = -1.0f / (sign + n.z), b = n.x * n.y * a;
        prt_vec3 t1 = prt_v3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
        prt_vec3 t2 = prt_v3(b, sign + n.y * n.y * a, -n.y);
        prt_vec3 d =
            prt_v3_norm(prt_v3_add(prt_v3_add(prt_v3_scale(t1, lx), prt_v3_scale(t2, ly)), prt_v3_scale(n, lz)));
        prt_vec3 o = prt_v3_add(p, prt_v3_scale(n, eps));
        prt_ray *r = &out->rays[k];
        r->org[0] = o.x, r->org[1] = o.y, r->org[2] = o.z, r->tnear = 0.0f;
        r->dir[0] = d.x, r->dir[1] = d.y, r->dir[2] = d.z, r->tfar = INFINITY;
        out->pixel[k++] = (uint32_t)i;
    }
    return PRT_OK;
}

prt_status bench_trace_hits(const bench_accel *b, const bench_rays *r, prt_hit **hits) {
    *hits = malloc((r->count ? r->count : 1) * sizeof **hits);
    prt_ray *copy = malloc((r->count ? r->count : 1) * sizeof *copy);
    if (!*hits || !copy) {
        free(*hits), free(copy);
        *hits = NULL;
        return PRT_ERROR_NOMEM;
    }
    memcpy(copy, r->rays, r->count * sizeof *copy);
    prt_intersect_stream(b->accel, copy, *hits, r->count, 0);
    free(copy);
    if (b->order)
        for (size_t i = 0; i < r->count; i++)
            if ((*hits)[i].prim != PRT_INVALID) (*hits)[i].prim = b->order[(*hits)[i].prim];
    return PRT_OK;
}
