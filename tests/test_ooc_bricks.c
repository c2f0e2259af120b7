/* The out-of-core build of a procedural source by bricks (ooc_build_bricks, docs/ooc.md):
 * with a budget of a few thousand triangles it splits bricks many levels deep and
 * regenerates them in core, and its file holds the generator's stream exactly: the same
 * triangle count, and exact queries answer as a BVH over the stream's triangles and as the
 * file the sifting path builds from the same stream. Bad budgets and paths are errors. */
#include "support/meshes.h"
#include "support/repr.h"

#include "api/accel.h"
#include "mesh/gen.h"
#include "ooc/ooc_build.h"

#include <unistd.h>

#define BULB 120000 /* triangles requested */

/* The generator's stream as a mesh of separate triangles: mesh triangle i is stream
 * triangle i, corners in the stream's order. */
typedef struct soup {
    float *v;
    size_t n, cap;
} soup;

static prt_status soup_sink(void *user, const float *tris, size_t count, uint64_t first_id) {
    soup *s = user;
    if (first_id != s->n) return PRT_ERROR_ARGUMENT;
    if (s->n + count > s->cap) {
        size_t cap = 2 * (s->n + count);
        float *q = realloc(s->v, cap * 9 * sizeof *q);
        if (!q) return PRT_ERROR_NOMEM;
        s->v = q, s->cap = cap;
    }
    memcpy(s->v + 9 * s->n, tris, count * 9 * sizeof *tris);
    s->n += count;
    return PRT_OK;
}

static prt_mesh *stream_mesh(void) {
    soup s = {NULL, 0, 0};
    prt_mesh *m = NULL;
    CHECK_OK(gen_mandelbulb_stream(BULB, 1, 0, soup_sink, &s, NULL));
    if (s.n && prt_mesh_create(3 * s.n, s.n, &m) == PRT_OK) {
        memcpy(m->vertices, s.v, s.n * 9 * sizeof *s.v);
        for (size_t i = 0; i < 3 * s.n; i++) m->triangles[i] = (uint32_t)i;
    }
    free(s.v);
    CHECK(m != NULL);
    return m;
}

/* The sifting path over the same generator (the stream spooled and split by passes). */
static prt_status build_sifted(const char *out, uint64_t budget) {
    prt_spec spec;
    ooc_build_job job;
    ooc_header h;
    memset(&job, 0, sizeof job);
    memset(&h, 0, sizeof h);
    prt_status s = prt__spec_parse("ooc", &spec);
    if (!s) s = ooc_parse_spec(&spec, &job.params);
    if (s) return s;
    prt__spec_format(&spec, h.spec, sizeof h.spec);
    job.out_path = out;
    job.memory_budget = budget;
    job.sift_generated = true;
    return ooc_build_generated("mandelbulb", BULB, 1, &job, &h);
}

/* Rays from outside toward the bulb and rays from points near its surface outward in
 * every direction (grazing the bricks' faces, where split planes fall). */
static prt_ray *bulb_rays(const prt_mesh *m, size_t n) {
    prt_ray *r = rays_random(m, n, 17);
    uint64_t x = 0x9E3779B97F4A7C15ull;
    for (size_t i = 0; r && i < n; i += 2) {
        const float *v = m->vertices + 9 * (size_t)(i * 7919 % m->triangle_count);
        for (int c = 0; c < 3; c++) {
            x ^= x << 13, x ^= x >> 7, x ^= x << 17;
            r[i].org[c] = (v[c] + v[3 + c] + v[6 + c]) / 3.0f + 0.01f * ((float)(x >> 40) / (float)(1 << 24) - 0.5f);
            x ^= x << 13, x ^= x >> 7, x ^= x << 17;
            r[i].dir[c] = (float)(x >> 40) / (float)(1 << 23) - 1.0f;
        }
        r[i].tnear = 0.0f, r[i].tfar = INFINITY;
    }
    return r;
}

TEST(test_brick_build_holds_the_generator_stream_exactly) {
    prt_mesh *m = stream_mesh();
    const char *bricks = test_tmp_path("bricks.ooc"), *sifted = test_tmp_path("sifted.ooc");
    /* 1 MB: in-core subtrees of 4096 triangles, about 30 of them. */
    prt_build_options o = {.memory_budget = 1 << 20};
    CHECK_OK(prt_build_generated("mandelbulb", BULB, 1, "ooc", bricks, &o));
    CHECK_OK(build_sifted(sifted, 1 << 20));
    prt_accel *a = NULL, *b = NULL, *ref = NULL;
    CHECK_OK(prt_accel_open(bricks, NULL, &a));
    CHECK_OK(prt_accel_open(sifted, NULL, &b));
    if (m) CHECK_OK(prt_build(m, "aabb:float3", NULL, &ref));
    if (a && b && ref) {
        prt_stats sa, sb;
        prt_accel_stats(a, &sa);
        prt_accel_stats(b, &sb);
        CHECK_MSG(sa.triangles == m->triangle_count && sb.triangles == m->triangle_count,
                  "triangles: bricks %zu, sifted %zu, stream %zu", sa.triangles, sb.triangles, m->triangle_count);
        CHECK_MSG(sa.triangles_built == sb.triangles_built, "hittable: bricks %zu, sifted %zu", sa.triangles_built,
                  sb.triangles_built);
        CHECK_MSG(sa.triangles > BULB / 2 && sa.triangles < 2 * BULB, "%zu triangles for %d asked", sa.triangles, BULB);
        prt_ray *rays = bulb_rays(m, 6000);
        CHECK(repr_same_hits(a, ref, rays, 6000, "bricks against the BVH") > 2000);
        CHECK(repr_same_hits(a, b, rays, 6000, "bricks against sifted") > 2000);
        CHECK_OK(prt_accel_check(a));
        free(rays);
    }
    prt_accel_free(a);
    prt_accel_free(b);
    prt_accel_free(ref);
    remove(bricks), remove(sifted);
    prt_mesh_free(m);
}

/* A budget below the in-core minimum, and an output nobody can create, fail with a
 * message and leave no file behind. */
TEST(test_brick_build_errors_are_clear) {
    const char *out = test_tmp_path("small.ooc");
    prt_build_options o = {.memory_budget = 100000};
    CHECK(prt_build_generated("mandelbulb", 20000, 1, "ooc", out, &o) == PRT_ERROR_LIMIT);
    CHECK_MSG(strstr(prt_last_error(), "--memory") != NULL, "message: %s", prt_last_error());
    CHECK(access(out, F_OK) != 0);
    CHECK(prt_build_generated("mandelbulb", 20000, 1, "ooc", "/nonexistent-dir/x.ooc", NULL) == PRT_ERROR_IO);
    CHECK_MSG(strstr(prt_last_error(), "/nonexistent-dir/x.ooc") != NULL, "message: %s", prt_last_error());
}

int main(void) {
    RUN(test_brick_build_holds_the_generator_stream_exactly);
    RUN(test_brick_build_errors_are_clear);
    TEST_END();
}
