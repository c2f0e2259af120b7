/* Queries of every representation against the brute-force double-precision reference:
 * hit/miss agree on every ray away from edges, t within 1e-5 of the scene diagonal, the
 * same primitive wherever the hit is unambiguous; any-hit agrees with closest-hit; the
 * stream and packet paths give what prt_intersect1 gives. */
#include "support/meshes.h"
#include "support/reference.h"
#include "support/repr.h"
#include "test.h"

/* A hit closer than this (in barycentric units) to an edge may legitimately go to either
 * neighbour, or slip through the reference's own non-watertight test. */
#define EDGE_EPS 1e-4
#define T_TOL 1e-5

typedef struct agreement {
    size_t rays, compared, hitmiss, prim, t;
} agreement;

/* Reference answers for a ray set, computed once and shared by every representation. */
typedef struct reference {
    prt_hit *hit;
    double *edge;
} reference;

static reference reference_of(const prt_mesh *m, const prt_ray *rays, size_t n) {
    reference ref = {malloc(n * sizeof(prt_hit)), malloc(n * sizeof(double))};
#pragma omp parallel for schedule(dynamic, 16)
    for (size_t i = 0; i < n; i++) ref.hit[i] = ref_intersect(m, &rays[i], &ref.edge[i]);
    return ref;
}

static void reference_free(reference *r) {
    free(r->hit);
    free(r->edge);
}

static agreement compare_with_reference(const prt_mesh *m, const char *spec, const prt_ray *rays, size_t n,
                                        const reference *ref) {
    agreement g = {n, 0, 0, 0, 0};
    prt_accel *a;
    if (!repr_build(m, spec, &a)) return g;
    double diag = ref_diagonal(m), err = repr_vertex_error(a);
    for (size_t i = 0; i < n; i++) {
        prt_hit want = ref->hit[i];
        prt_ray r = rays[i];
        prt_hit got;
        if (err > 0) { /* lossy: within the stated bound, edges included */
            prt_intersect1(a, &r, &got);
            g.compared++;
            g.hitmiss += !ref_lossy_acceptable(m, &rays[i], &got, &want, err, T_TOL * diag);
            g.hitmiss += (got.prim != PRT_INVALID) != prt_occluded1(a, &rays[i]);
            continue;
        }
        if (ref->edge[i] < EDGE_EPS) continue;
        prt_intersect1(a, &r, &got);
        g.compared++;
        bool hw = want.prim != PRT_INVALID, hg = got.prim != PRT_INVALID;
        if (hw != hg) {
            g.hitmiss++;
            continue;
        }
        if (!hw) continue;
        if (fabs((double)got.t - want.t) > T_TOL * diag) g.t++;
        /* The same primitive, unless packrt's triangle is hit at the same t (a tie). */
        double t_other;
        if (got.prim != want.prim &&
            !(ref_hits_triangle(m, &rays[i], got.prim, &t_other) && fabs(t_other - want.t) <= T_TOL * diag))
            g.prim++;
        /* Any-hit must agree with the closest hit on the same ray. */
        if (!prt_occluded1(a, &rays[i])) g.hitmiss++;
    }
    prt_accel_free(a);
    CHECK_MSG(g.compared > n / 2, "%s: only %zu of %zu rays were unambiguous", spec, g.compared, n);
    CHECK_MSG(g.hitmiss == 0 && g.prim == 0 && g.t == 0,
              "%s: %zu rays compared, %zu hit/miss (lossy: outside the bound), %zu prim, %zu t disagreements", spec,
              g.compared, g.hitmiss, g.prim, g.t);
    return g;
}

static void all_representations(const prt_mesh *m, const prt_ray *rays, size_t n) {
    reference ref = reference_of(m, rays, n);
    for (size_t i = 0; i < prt_repr_count(); i++) compare_with_reference(m, prt_repr_name(i), rays, n, &ref);
    reference_free(&ref);
}

TEST(test_every_representation_matches_brute_force_on_random_soup) {
    prt_mesh *m = mesh_random_soup(2000, 1);
    prt_ray *rays = rays_random(m, 5000, 2);
    all_representations(m, rays, 5000);
    free(rays);
    prt_mesh_free(m);
}

TEST(test_every_splitter_matches_brute_force) {
    static const char *specs[] = {"aabb:float3,split=mean",
                                  "aabb:float3,split=longest,leaf=2",
                                  "quad:float3-soa4,split=morton,leaf=16",
                                  "quad:float3-soa4,split=fixed,leaf=8",
                                  "aabb:float3-soa4,split=fixed,leaf=1",
                                  "quad:float3,leaf=1"};
    prt_mesh *m = mesh_random_soup(1500, 3);
    prt_ray *rays = rays_random(m, 3000, 4);
    reference ref = reference_of(m, rays, 3000);
    for (size_t i = 0; i < COUNT_OF(specs); i++) compare_with_reference(m, specs[i], rays, 3000, &ref);
    reference_free(&ref);
    free(rays);
    prt_mesh_free(m);
}

TEST(test_bunny_matches_brute_force) {
    const char *path = ref_shared_path("bunny.ply");
    if (!path) SKIP("../shared/data/bunny.ply is absent");
    prt_mesh *m;
    prt_status s = prt_mesh_load(path, &m);
    CHECK_OK(s);
    if (s) return;
    prt_ray *rays = rays_random(m, 2500, 5);
    all_representations(m, rays, 2500);
    free(rays);
    prt_mesh_free(m);
}

TEST(test_stream_and_packet_equal_single_rays) {
    prt_mesh *m = mesh_random_soup(3000, 9);
    size_t n = 8000;
    prt_ray *rays = rays_random(m, n, 10);
    /* Invalid rays among them: streams that trace several rays at once skip them as misses. */
    for (size_t i = 5; i < n; i += 499) rays[i].dir[i % 3] = NAN;
    for (size_t i = 7; i < n; i += 503) rays[i].tnear = 2.0f, rays[i].tfar = 1.0f;
    for (size_t k = 0; k < prt_repr_count(); k++) {
        prt_accel *a;
        if (!repr_build(m, prt_repr_name(k), &a)) continue;
        prt_ray *r1 = malloc(n * sizeof *r1), *r2 = malloc(n * sizeof *r2), *r3 = malloc(n * sizeof *r3);
        prt_hit *h1 = malloc(n * sizeof *h1), *h2 = malloc(n * sizeof *h2), *h3 = malloc(n * sizeof *h3);
        uint8_t *occ = malloc(n);
        memcpy(r1, rays, n * sizeof *r1), memcpy(r2, rays, n * sizeof *r2), memcpy(r3, rays, n * sizeof *r3);
        for (size_t i = 0; i < n; i++) prt_intersect1(a, &r1[i], &h1[i]);
        prt_intersect_stream(a, r2, h2, n, 2);
        for (size_t i = 0; i < n; i += 16) {
            prt_packet p = {r3 + i, h3 + i, (uint32_t)(n - i < 16 ? n - i : 16), 4};
            prt_intersect_packet(a, &p);
        }
        prt_occluded_stream(a, rays, occ, n, 2);
        size_t diff = 0, occ_diff = 0;
        for (size_t i = 0; i < n; i++) {
            diff += memcmp(&h1[i], &h2[i], sizeof h1[i]) != 0 || memcmp(&h1[i], &h3[i], sizeof h1[i]) != 0;
            diff += memcmp(&r1[i], &r2[i], sizeof r1[i]) != 0;
            occ_diff += occ[i] != (h1[i].prim != PRT_INVALID);
        }
        CHECK_MSG(diff == 0 && occ_diff == 0, "%s: %zu stream/packet and %zu occluded differences", prt_repr_name(k),
                  diff, occ_diff);
        free(r1), free(r2), free(r3), free(h1), free(h2), free(h3), free(occ);
        prt_accel_free(a);
    }
    free(rays);
    prt_mesh_free(m);
}

/* A packet longer than PRT_PACKET_MAX: the rays past it are answered one by one, so every
 * ray of it equals its single-ray answer, for each family with packet traversal. */
TEST(test_packets_past_the_maximum_answer_every_ray) {
    static const char *specs[] = {"wide8:float3-soa8", "wide8:idx8-soa4", "lossygrid", "raystrips", "cgrid"};
    prt_mesh *m = mesh_random_soup(1000, 21);
    const uint32_t n = PRT_PACKET_MAX + 44;
    prt_ray *rays = rays_random(m, n, 22);
    prt_ray *r1 = malloc(n * sizeof *r1), *r2 = malloc(n * sizeof *r2);
    prt_hit *h1 = malloc(n * sizeof *h1), *h2 = malloc(n * sizeof *h2);
    uint8_t *o1 = malloc(n), *o2 = malloc(n);
    for (size_t k = 0; k < COUNT_OF(specs); k++) {
        prt_accel *a;
        if (!repr_build(m, specs[k], &a)) continue;
        memcpy(r1, rays, n * sizeof *r1), memcpy(r2, rays, n * sizeof *r2);
        for (uint32_t i = 0; i < n; i++) prt_intersect1(a, &r1[i], &h1[i]), o1[i] = prt_occluded1(a, &rays[i]);
        prt_packet p = {r2, h2, n, n};
        prt_intersect_packet(a, &p);
        prt_occluded_packet(a, &p, o2);
        size_t diff = 0, hits = 0;
        for (uint32_t i = 0; i < n; i++) {
            diff += h1[i].prim != h2[i].prim || memcmp(&h1[i].t, &h2[i].t, 4) || o1[i] != o2[i];
            hits += h1[i].prim != PRT_INVALID;
        }
        CHECK_MSG(diff == 0 && hits > n / 8, "%s: %zu of %u rays differ, %zu hits", specs[k], diff, n, hits);
        prt_accel_free(a);
    }
    free(rays), free(r1), free(r2), free(h1), free(h2), free(o1), free(o2);
    prt_mesh_free(m);
}

TEST(test_hit_shrinks_ray_and_miss_leaves_it) {
    prt_mesh *m = mesh_random_soup(500, 12);
    prt_ray *rays = rays_random(m, 2000, 13);
    prt_accel *a;
    CHECK_OK(prt_build(m, "quad:float3-soa4", NULL, &a));
    for (size_t i = 0; i < 2000; i++) {
        prt_ray r = rays[i];
        prt_hit h;
        prt_intersect1(a, &r, &h);
        if (h.prim == PRT_INVALID) CHECK(r.tfar == rays[i].tfar && isinf(h.t));
        else CHECK(r.tfar == h.t && h.u >= 0 && h.v >= 0 && h.u + h.v <= 1.0001f);
    }
    prt_accel_free(a);
    free(rays);
    prt_mesh_free(m);
}

TEST(test_tnear_and_tfar_bound_the_hit_interval) {
    /* One triangle in the plane z = 1, a ray along +z from the origin. */
    prt_mesh *m;
    CHECK_OK(prt_mesh_create(3, 1, &m));
    float v[9] = {-1, -1, 1, 1, -1, 1, 0, 1, 1};
    uint32_t t[3] = {0, 1, 2};
    memcpy(m->vertices, v, sizeof v), memcpy(m->triangles, t, sizeof t);
    for (size_t k = 0; k < prt_repr_count(); k++) {
        prt_accel *a;
        if (!repr_build(m, prt_repr_name(k), &a)) continue;
        prt_ray r = {{0, 0, 0}, 0, {0, 0, 1}, INFINITY};
        prt_hit h;
        prt_intersect1(a, &r, &h);
        CHECK(h.prim == 0 && repr_t_near(a, h.t, 1.0f));
        prt_ray shorter = {{0, 0, 0}, 0, {0, 0, 1}, 0.999f}, later = {{0, 0, 0}, 1.001f, {0, 0, 1}, 5};
        prt_ray exact = {{0, 0, 0}, 1.0f, {0, 0, 1}, 1.0f};
        CHECK(!prt_occluded1(a, &shorter) && !prt_occluded1(a, &later) && prt_occluded1(a, &exact));
        prt_ray nan_ray = {{NAN, 0, 0}, 0, {0, 0, 1}, INFINITY}, zero_dir = {{0, 0, 0}, 0, {0, 0, 0}, INFINITY};
        prt_intersect1(a, &nan_ray, &h);
        CHECK(h.prim == PRT_INVALID);
        prt_intersect1(a, &zero_dir, &h);
        CHECK(h.prim == PRT_INVALID && !prt_occluded1(a, &zero_dir));
        prt_accel_free(a);
    }
    prt_mesh_free(m);
}

TEST(test_degenerate_triangles_are_never_hit) {
    /* A collinear triangle and one with a repeated index lie exactly on the ray's path. */
    prt_mesh *m;
    CHECK_OK(prt_mesh_create(6, 3, &m));
    float v[18] = {-1, 0,  1, 0, 0,  1, 1, 0, 1, /* collinear along x at z = 1 */
                   -1, -1, 3, 1, -1, 3, 0, 1, 3};
    uint32_t t[9] = {0, 1, 2, 3, 3, 4, 3, 4, 5};
    memcpy(m->vertices, v, sizeof v), memcpy(m->triangles, t, sizeof t);
    CHECK(prt_mesh_count_degenerate(m) == 2);
    for (size_t k = 0; k < prt_repr_count(); k++) {
        prt_accel *a;
        if (!repr_build(m, prt_repr_name(k), &a)) continue;
        prt_stats st;
        prt_accel_stats(a, &st);
        CHECK(st.triangles == 3 && st.triangles_built == 1);
        prt_ray r = {{0, 0, 0}, 0, {0, 0, 1}, INFINITY};
        prt_hit h;
        prt_intersect1(a, &r, &h);
        CHECK_MSG(h.prim == 2 && repr_t_near(a, h.t, 3.0f), "%s: prim %u t %g", prt_repr_name(k), h.prim, (double)h.t);
        prt_accel_free(a);
    }
    prt_mesh_free(m);
}

TEST(test_all_degenerate_mesh_is_an_error) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_create(3, 1, &m));
    float v[9] = {0, 0, 0, 1, 1, 1, 2, 2, 2};
    uint32_t t[3] = {0, 1, 2};
    memcpy(m->vertices, v, sizeof v), memcpy(m->triangles, t, sizeof t);
    prt_accel *a = (prt_accel *)1;
    CHECK(prt_build(m, "aabb:float3", NULL, &a) == PRT_ERROR_MESH && a == NULL);
    CHECK(strstr(prt_last_error(), "degenerate") != NULL);
    prt_mesh_free(m);
}

TEST(test_bad_specs_are_rejected_with_a_reason) {
    prt_mesh *m = mesh_random_soup(10, 1);
    static const char *bad[] = {"",
                                "nosuch:float3",
                                "aabb:nosuch",
                                "aabb:float3,leaf=0",
                                "aabb:float3,leaf=17",
                                "aabb:float3,split=magic",
                                "aabb:float3,colour=red",
                                "aabb:float3,leaf",
                                "aabb:float3,leaf=4,leaf=8"};
    for (size_t i = 0; i < COUNT_OF(bad); i++) {
        prt_accel *a = NULL;
        prt_status s = prt_build(m, bad[i], NULL, &a);
        CHECK_MSG(s == PRT_ERROR_ARGUMENT && a == NULL && *prt_last_error(), "'%s' gave %s", bad[i],
                  prt_status_string(s));
    }
    prt_accel *a;
    CHECK_OK(prt_build(m, "quad:float3-soa4,leaf=8", NULL, &a));
    CHECK(strcmp(prt_accel_spec(a), "quad:float3-soa4,leaf=8,split=sah") == 0);
    prt_accel_free(a);
    prt_mesh_free(m);
}

/* The closed cube [-1, 1]^3, 12 triangles, outward winding. */
static prt_mesh *unit_cube(void) {
    static const float v[24] = {-1, -1, -1, 1, -1, -1, 1, 1, -1, -1, 1, -1, -1, -1, 1, 1, -1, 1, 1, 1, 1, -1, 1, 1};
    static const uint32_t t[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                   3, 7, 6, 3, 6, 2, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5};
    prt_mesh *m;
    if (prt_mesh_create(8, 12, &m)) return NULL;
    memcpy(m->vertices, v, sizeof v), memcpy(m->triangles, t, sizeof t);
    return m;
}

TEST(test_axis_aligned_ray_in_a_face_plane_hits) {
    /* Origin and path exactly in the plane y = 1 of the cube's top face, direction with a
     * zero y component of either sign: the slab test must not cull the cube. */
    prt_mesh *m = unit_cube();
    for (size_t k = 0; k < prt_repr_count(); k++) {
        prt_accel *a;
        if (!repr_build(m, prt_repr_name(k), &a)) continue;
        for (int sign = 0; sign < 2; sign++) {
            float y0 = sign ? -0.0f : 0.0f;
            prt_ray r = {{-5, 1, 0.3f}, 0, {1, y0, 0}, INFINITY};
            prt_hit h;
            prt_intersect1(a, &r, &h);
            CHECK_MSG(h.prim != PRT_INVALID && repr_t_near(a, h.t, 4.0f), "%s, dir y %s0: prim %u t %g",
                      prt_repr_name(k), sign ? "-" : "+", h.prim, (double)h.t);
        }
        prt_accel_free(a);
    }
    prt_mesh_free(m);
}

TEST(test_negative_tnear_finds_hits_behind_the_origin) {
    /* A flat quad at z = 0 behind a ray starting at z = 5 going +z, tnear = -inf. */
    prt_mesh *m;
    CHECK_OK(prt_mesh_create(4, 2, &m));
    float v[12] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
    uint32_t t[6] = {0, 1, 2, 0, 2, 3};
    memcpy(m->vertices, v, sizeof v), memcpy(m->triangles, t, sizeof t);
    for (size_t k = 0; k < prt_repr_count(); k++) {
        prt_accel *a;
        if (!repr_build(m, prt_repr_name(k), &a)) continue;
        prt_ray r = {{0.3f, 0.2f, 5}, -INFINITY, {0, 0, 1}, INFINITY};
        prt_hit h;
        prt_intersect1(a, &r, &h);
        CHECK_MSG(h.prim != PRT_INVALID && repr_t_near(a, h.t, -5.0f), "%s: prim %u t %g", prt_repr_name(k), h.prim,
                  (double)h.t);
        CHECK(prt_occluded1(a, &r));
        prt_accel_free(a);
    }
    prt_mesh_free(m);
}

TEST(test_equal_t_ties_pick_the_smallest_triangle_id) {
    /* Five copies of one triangle (ids 0..4) and a ray through the cube's face diagonal,
     * where two triangles meet at the same t: every representation names the smallest id. */
    prt_mesh *m;
    CHECK_OK(prt_mesh_create(3, 5, &m));
    float v[9] = {-1, -1, 1, 1, -1, 1, 0, 1, 1};
    memcpy(m->vertices, v, sizeof v);
    for (int i = 0; i < 15; i++) m->triangles[i] = (uint32_t)(i % 3);
    prt_mesh *cube = unit_cube();
    for (size_t k = 0; k < prt_repr_count(); k++) {
        prt_accel *a, *c;
        if (!repr_build(m, prt_repr_name(k), &a)) continue;
        if (!repr_build(cube, prt_repr_name(k), &c)) {
            prt_accel_free(a);
            continue;
        }
        prt_ray r = {{0.1f, 0, 0}, 0, {0, 0, 1}, INFINITY}, rc = {{0.25f, 0.25f, -5}, 0, {0, 0, 1}, INFINITY};
        prt_hit h, hc;
        prt_intersect1(a, &r, &h);
        prt_intersect1(c, &rc, &hc);
        CHECK_MSG(h.prim == 0 && repr_t_near(a, h.t, 1.0f), "%s: copies: prim %u", prt_repr_name(k), h.prim);
        CHECK_MSG(hc.prim == 0 && repr_t_near(c, hc.t, 4.0f), "%s: diagonal: prim %u t %g", prt_repr_name(k), hc.prim,
                  (double)hc.t);
        prt_accel_free(a), prt_accel_free(c);
    }
    prt_mesh_free(cube);
    prt_mesh_free(m);
}

/* The covering set against brute force on a 300-triangle soup scaled by `scale`, rays from
 * around it; with unit directions t is a distance, so the tolerance (a fraction of the
 * diagonal) holds for tiny meshes too. */
static void expect_brute_force_at_scale(float scale, bool unit_dirs) {
    prt_mesh *soup = mesh_random_soup(300, 4), *m = mesh_transformed(soup, scale, 0.0f);
    prt_ray *rays = rays_random(m, 300, 8);
    for (size_t i = 0; unit_dirs && i < 300; i++) {
        const double len = sqrt((double)rays[i].dir[0] * rays[i].dir[0] + (double)rays[i].dir[1] * rays[i].dir[1] +
                                (double)rays[i].dir[2] * rays[i].dir[2]);
        for (int k = 0; k < 3; k++) rays[i].dir[k] = (float)(rays[i].dir[k] / len);
    }
    reference ref = reference_of(m, rays, 300);
    for (size_t i = 0; i < prt_repr_count(); i++)
        if (repr_in_cover(prt_repr_name(i))) compare_with_reference(m, prt_repr_name(i), rays, 300, &ref);
    reference_free(&ref);
    free(rays);
    prt_mesh_free(soup), prt_mesh_free(m);
}

/* Up to the coordinate limit every representation still answers as brute force (t near
 * 1e12 too), and down to the smallest extent. */
TEST(test_meshes_at_the_coordinate_limit_match_brute_force) {
    expect_brute_force_at_scale(0.9f * PRT_MAX_COORDINATE, false);
}

TEST(test_meshes_at_the_smallest_extent_match_brute_force) { expect_brute_force_at_scale(1.2f * PRT_MIN_EXTENT, true); }

TEST(test_coordinates_beyond_the_limit_are_rejected) {
    prt_mesh *m = mesh_random_soup(4, 1);
    m->vertices[4] = 2.0f * PRT_MAX_COORDINATE;
    prt_accel *a = NULL;
    CHECK(prt_build(m, "quad:float3-soa4", NULL, &a) == PRT_ERROR_LIMIT && a == NULL);
    CHECK(strstr(prt_last_error(), "magnitude") != NULL);
    prt_mesh_free(m);
    /* And a mesh too small for single precision: rejected rather than silently missed. */
    prt_mesh *soup = mesh_random_soup(40, 2), *tiny = mesh_transformed(soup, 0.1f * PRT_MIN_EXTENT, 0.0f);
    CHECK(prt_build(tiny, "lossygrid", NULL, &a) == PRT_ERROR_LIMIT && a == NULL);
    CHECK(strstr(prt_last_error(), "spans") != NULL);
    prt_mesh_free(soup), prt_mesh_free(tiny);
}

TEST(test_ids_none_hits_map_through_the_triangle_order) {
    /* Codecs with one id per leaf can drop the id map (ids=none): their hits must then be
     * the default build's hits renumbered by prt_build_options.triangle_order. */
    prt_mesh *m = mesh_random_soup(1500, 21);
    size_t n = 3000, tested = 0;
    prt_ray *rays = rays_random(m, n, 22);
    uint32_t *order = malloc(m->triangle_count * sizeof *order);
    for (size_t k = 0; k < prt_repr_count(); k++) {
        char spec[128];
        snprintf(spec, sizeof spec, "%s,ids=none", prt_repr_name(k));
        prt_build_options o = {.triangle_order = order};
        prt_accel *a, *b;
        prt_status s = prt_build(m, spec, &o, &b);
        if (s == PRT_ERROR_ARGUMENT) continue; /* stores ids per triangle: no map to drop */
        CHECK_MSG(s == PRT_OK, "%s: %s", spec, prt_last_error());
        if (s) continue;
        if (!repr_build(m, prt_repr_name(k), &a)) {
            prt_accel_free(b);
            continue;
        }
        prt_stats sa, sb;
        prt_accel_stats(a, &sa), prt_accel_stats(b, &sb);
        /* The map costs 4 bytes a triangle; lossygrid's compact one less (about 2.1);
         * raystrips trades its ids and turn bits for a 4-bit code a strip triangle (at most
         * 4 bytes a triangle less: exactly 4 on this soup of one-triangle strips). */
        const bool compact = !strncmp(spec, "lossygrid", 9), codes = !strncmp(spec, "raystrips", 9);
        CHECK_MSG(compact ? sb.bytes_geometry < sa.bytes_geometry &&
                                sa.bytes_geometry < sb.bytes_geometry + 4 * sb.triangles_built
                  : codes ? sb.bytes_geometry < sa.bytes_geometry &&
                                sa.bytes_geometry <= sb.bytes_geometry + 4 * sb.triangles_built
                          : sb.bytes_geometry + 4 * sb.triangles_built == sa.bytes_geometry,
                  "%s: %zu geometry bytes, %zu with ids", spec, sb.bytes_geometry, sa.bytes_geometry);
        size_t differ = 0;
        for (size_t i = 0; i < n; i++) {
            prt_ray r1 = rays[i], r2 = rays[i];
            prt_hit h1, h2;
            prt_intersect1(a, &r1, &h1), prt_intersect1(b, &r2, &h2);
            if (h2.prim != PRT_INVALID) h2.prim = h2.prim < sb.triangles_built ? order[h2.prim] : PRT_INVALID - 1;
            differ += h1.prim != h2.prim || h1.t != h2.t;
        }
        CHECK_MSG(differ == 0, "%s: %zu of %zu rays differ from the build with ids", spec, differ, n);
        tested++;
        prt_accel_free(a), prt_accel_free(b);
    }
    free(order), free(rays);
    prt_mesh_free(m);
    if (!tested) SKIP("no registered codec stores one id per leaf");
}

int main(void) {
    RUN(test_every_representation_matches_brute_force_on_random_soup);
    RUN(test_every_splitter_matches_brute_force);
    RUN(test_bunny_matches_brute_force);
    RUN(test_stream_and_packet_equal_single_rays);
    RUN(test_packets_past_the_maximum_answer_every_ray);
    RUN(test_hit_shrinks_ray_and_miss_leaves_it);
    RUN(test_tnear_and_tfar_bound_the_hit_interval);
    RUN(test_degenerate_triangles_are_never_hit);
    RUN(test_all_degenerate_mesh_is_an_error);
    RUN(test_bad_specs_are_rejected_with_a_reason);
    RUN(test_axis_aligned_ray_in_a_face_plane_hits);
    RUN(test_negative_tnear_finds_hits_behind_the_origin);
    RUN(test_equal_t_ties_pick_the_smallest_triangle_id);
    RUN(test_meshes_at_the_coordinate_limit_match_brute_force);
    RUN(test_meshes_at_the_smallest_extent_match_brute_force);
    RUN(test_coordinates_beyond_the_limit_are_rejected);
    RUN(test_ids_none_hits_map_through_the_triangle_order);
    TEST_END();
}
