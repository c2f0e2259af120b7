/* Closest points, exactly: every lossless representation's answer (distance, triangle,
 * barycentrics) is the double-precision brute force's over every triangle (geom/closest.h
 * per triangle, the smallest id among equally near ones), bit for bit; in particular the
 * wide8 layout's own SIMD point walk (bvh/layouts/wide8_point.c) against the generic walk's
 * layouts, and the out-of-core kd-tree's walk through its block cache. Points near the surface, far from it, and on the
 * integer grid cube, where many triangles are equally near. (strip codecs clear low vertex bits: not lossless here.) */
#include "test.h"
#include "core/rng.h"
#include "geom/closest.h"
#include "support/meshes.h"
#include "support/repr.h"

static const char *g_specs[] = {"wide8:idx8-soa4",   "wide8:idx8-soa4,collapse=fill",
                                "wide8:float3-soa8", "wide8:float3",
                                "wide8:idx32",       "aabb:float3",
                                "quad:idx8-soa4",    "ooc"};

/* The answer over every triangle, as prt_closest_points states it. */
static prt_closest brute_force(const prt_mesh *m, const float *p) {
    const double pd[3] = {p[0], p[1], p[2]};
    double best = INFINITY, bu = 0, bv = 0;
    uint32_t prim = PRT_INVALID;
    for (uint32_t k = 0; k < m->triangle_count; k++) {
        double v[3][3], u, w;
        for (int j = 0; j < 3; j++)
            for (int x = 0; x < 3; x++) v[j][x] = m->vertices[3 * (size_t)m->triangles[3 * (size_t)k + j] + x];
        const double d2 = prt__closest_on_triangle(pd, v[0], v[1], v[2], &u, &w);
        if (d2 < best) best = d2, bu = u, bv = w, prim = k;
    }
    return (prt_closest){{0, 0, 0}, (float)sqrt(best), (float)bu, (float)bv, prim};
}

static void check_exact(const prt_mesh *m, const float *pts, size_t n, const char *what) {
    prt_closest *want = malloc(n * sizeof *want), *got = malloc(n * sizeof *got);
    for (size_t i = 0; i < n; i++) want[i] = brute_force(m, pts + 3 * i);
    for (size_t s = 0; s < COUNT_OF(g_specs); s++) {
        prt_accel *a;
        if (!repr_build(m, g_specs[s], &a)) continue;
        CHECK_OK(prt_closest_points(a, pts, n, INFINITY, got, 1));
        size_t wrong = 0, first = n;
        for (size_t i = 0; i < n; i++) {
            const bool bad = got[i].distance != want[i].distance || got[i].prim != want[i].prim ||
                             got[i].u != want[i].u || got[i].v != want[i].v;
            if (bad && first == n) first = i;
            wrong += bad;
        }
        CHECK_MSG(wrong == 0, "%s on %s: %zu of %zu answers differ (first: point %zu, got %u at %.9g, want %u at %.9g)",
                  g_specs[s], what, wrong, n, first, first < n ? got[first].prim : 0,
                  first < n ? (double)got[first].distance : 0.0, first < n ? want[first].prim : 0,
                  first < n ? (double)want[first].distance : 0.0);
        prt_accel_free(a);
    }
    free(want), free(got);
}

TEST(test_closest_points_equal_double_brute_force_near_and_far) {
    prt_mesh *bulb = NULL;
    CHECK_OK(prt_mesh_generate("mandelbulb", 4000, 1, &bulb));
    float lo[3], hi[3];
    prt_mesh_bounds(bulb, lo, hi);
    enum { N = 200 };
    static float pts[3 * N];
    prt_rng rng = prt_rng_seed(11, 0);
    for (size_t i = 0; i < N; i++) {
        if (i % 2) { /* far: in the bounds grown by half their size each side */
            for (int k = 0; k < 3; k++) pts[3 * i + k] = lo[k] + (hi[k] - lo[k]) * (2 * prt_rng_float(&rng) - 0.5f);
            continue;
        }
        /* near: a vertex moved by up to 1% of the extent */
        const float *v = bulb->vertices + 3 * (size_t)(prt_rng_u32(&rng) % bulb->vertex_count);
        for (int k = 0; k < 3; k++) pts[3 * i + k] = v[k] + 0.01f * (hi[k] - lo[k]) * (2 * prt_rng_float(&rng) - 1);
    }
    check_exact(bulb, pts, N, "mandelbulb");
    prt_mesh_free(bulb);
}

TEST(test_closest_points_equal_double_brute_force_on_grid_ties) {
    prt_mesh *cube = mesh_grid_cube(4);
    enum { N = 7 * 7 * 7 };
    static float pts[3 * N];
    /* Integer and half-integer points in and around the cube: many equally near triangles. */
    for (int i = 0; i < N; i++)
        pts[3 * i] = -1 + 1.0f * (i % 7), pts[3 * i + 1] = -0.5f + 1.0f * (i / 7 % 7),
                pts[3 * i + 2] = -1 + 1.0f * (i / 49);
    check_exact(cube, pts, N, "grid cube");
    prt_mesh_free(cube);
}

int main(void) {
    RUN(test_closest_points_equal_double_brute_force_near_and_far);
    RUN(test_closest_points_equal_double_brute_force_on_grid_ties);
    TEST_END();
}
