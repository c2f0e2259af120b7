/* BVHs built with update=refit (bvh_accel.c, builders/refit.c): prt_accel_update refits the
 * boxes for moved vertices and encodes the tree again. After every update the hits equal
 * the brute-force reference on the moved mesh and those of the same spec built from
 * scratch on it (same triangle test, so the same prim and t); a triangle flat when built
 * is hit once its vertices open it; bad vertices leave the accel as it was; a loaded or
 * plain BVH says why it cannot update; strip codecs refuse the option. */
#include "mesh/gen.h"
#include "support/meshes.h"
#include "support/reference.h"
#include "support/repr.h"
#include "test.h"

#include <stdlib.h>
#include <unistd.h>

#define EDGE_EPS 1e-4

/* Lossless codecs of every kind of shared data: inline floats (one at a time, SOA), an
 * index buffer, 8-bit windows remapped per build (seq_ids), under four layouts and two
 * builders. */
static const char *const g_specs[] = {
    "quad:float3-soa4,update=refit",
    "aabb:float3,update=refit",
    "wide8:idx8-soa4,update=refit",
    "skd:idx32,update=refit",
    "wide8:float3-soa8,update=refit,split=morton",
    "aabb-compressed:idx32-soa4,update=refit",
};

/* Closest and any hits of a against the reference on m (rays away from edges), and
 * closest hits equal to those of b, built from scratch on m (every ray). */
static void expect_matches(const prt_mesh *m, prt_accel *a, prt_accel *b, const char *what, uint64_t seed) {
    const size_t n = 1500;
    prt_ray *rays = rays_random(m, n, seed);
    const double diag = ref_diagonal(m);
    size_t compared = 0, wrong = 0, occ_wrong = 0, differ = 0, hits = 0;
    for (size_t i = 0; i < n && rays; i++) {
        prt_ray r = rays[i], rb = rays[i];
        prt_hit got, fresh;
        prt_intersect1(a, &r, &got);
        prt_intersect1(b, &rb, &fresh);
        differ += got.prim != fresh.prim || got.t != fresh.t;
        hits += got.prim != PRT_INVALID;
        double edge;
        const prt_hit want = ref_intersect(m, &rays[i], &edge);
        if (edge < EDGE_EPS) continue;
        compared++;
        bool ok = got.prim == want.prim && (got.prim == PRT_INVALID || fabs((double)got.t - want.t) <= 1e-5 * diag);
        if (!ok && wrong < 3)
            fprintf(stderr, "    %s ray %zu: got %u t %g, want %u t %g\n", what, i, got.prim, (double)got.t, want.prim,
                    (double)want.t);
        wrong += !ok;
        occ_wrong += prt_occluded1(a, &rays[i]) != (want.prim != PRT_INVALID);
    }
    CHECK_MSG(compared > n / 2 && hits > n / 4 && wrong == 0 && occ_wrong == 0 && differ == 0,
              "%s: %zu rays compared, %zu hits, %zu closest and %zu any hits wrong, %zu differ from a fresh build",
              what, compared, hits, wrong, occ_wrong, differ);
    free(rays);
}

TEST(test_refit_follows_a_deforming_mesh) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("twist", 6000, 1, &m));
    if (!m) return;
    prt_mesh *moved = mesh_transformed(m, 1.0f, 0.0f);
    for (size_t i = 0; i < COUNT_OF(g_specs); i++) {
        prt_accel *a;
        if (!repr_build(m, g_specs[i], &a)) continue;
        CHECK(strstr(prt_accel_spec(a), "update=refit") != NULL);
        for (int f = 1; f <= 3; f++) {
            gen_twist_frame(m, 0.15f * (float)f, moved->vertices);
            CHECK_OK(prt_accel_update(a, moved->vertices));
            prt_accel *b = NULL;
            char plain[96];
            snprintf(plain, sizeof plain, "%s", g_specs[i]);
            *strstr(plain, ",update=refit") = 0;
            strcat(plain, strstr(g_specs[i], ",update=refit") + strlen(",update=refit"));
            if (!repr_build(moved, plain, &b)) break;
            char what[128];
            snprintf(what, sizeof what, "%s, frame %d", g_specs[i], f);
            expect_matches(moved, a, b, what, 10 + (uint64_t)f);
            float lo[3], hi[3], alo[3], ahi[3];
            prt_mesh_bounds(moved, lo, hi);
            prt_accel_bounds(a, alo, ahi);
            CHECK_MSG(!memcmp(lo, alo, sizeof lo) && !memcmp(hi, ahi, sizeof hi), "%s: bounds not refitted", what);
            prt_accel_free(b);
        }
        prt_accel_free(a);
    }
    prt_mesh_free(moved);
    prt_mesh_free(m);
}

/* The walking toys: rigid parts moving far from where the tree was split. */
TEST(test_refit_follows_walking_toys) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("toys", 5000, 3, &m));
    if (!m) return;
    prt_mesh *moved = mesh_transformed(m, 1.0f, 0.0f);
    prt_accel *a, *b;
    if (repr_build(m, "wide8:idx8-soa4,update=refit", &a)) {
        gen_toys_frame(m, 3, 0.4f, moved->vertices);
        CHECK_OK(prt_accel_update(a, moved->vertices));
        if (repr_build(moved, "wide8:idx8-soa4", &b)) {
            expect_matches(moved, a, b, "toys at t=0.4", 7);
            prt_accel_free(b);
        }
        prt_accel_free(a);
    }
    prt_mesh_free(moved);
    prt_mesh_free(m);
}

/* A triangle flat when the tree was built stays in it: once its vertices open it, the
 * refitted tree finds it. */
TEST(test_refit_finds_a_triangle_that_was_flat) {
    prt_mesh *g = mesh_grid(8), *m;
    CHECK_OK(prt_mesh_create(g->vertex_count + 3, g->triangle_count + 1, &m));
    if (!m) {
        prt_mesh_free(g);
        return;
    }
    memcpy(m->vertices, g->vertices, 12 * g->vertex_count);
    memcpy(m->triangles, g->triangles, 12 * g->triangle_count);
    /* Three collinear points above the grid, along x at y = 2. */
    const float flat[9] = {0.2f, 2.0f, 0.5f, 0.5f, 2.0f, 0.5f, 0.8f, 2.0f, 0.5f};
    memcpy(m->vertices + 3 * g->vertex_count, flat, sizeof flat);
    const uint32_t v0 = (uint32_t)g->vertex_count, last = (uint32_t)g->triangle_count;
    m->triangles[3 * last] = v0, m->triangles[3 * last + 1] = v0 + 1, m->triangles[3 * last + 2] = v0 + 2;
    CHECK(prt_mesh_count_degenerate(m) == 1);
    prt_mesh *moved = mesh_transformed(m, 1.0f, 0.0f);
    moved->vertices[3 * (v0 + 1) + 2] = 0.9f; /* the middle vertex moves off the line: a triangle in y = 2 */
    for (size_t i = 0; i < COUNT_OF(g_specs); i++) {
        prt_accel *a;
        if (!repr_build(m, g_specs[i], &a)) continue;
        prt_ray r = {{0.5f, 3.0f, 0.6f}, 0.0f, {0.0f, -1.0f, 0.0f}, INFINITY};
        prt_hit h;
        prt_intersect1(a, &r, &h);
        CHECK_MSG(h.prim != last, "%s: hit the flat triangle", g_specs[i]);
        CHECK_OK(prt_accel_update(a, moved->vertices));
        r.tfar = INFINITY;
        prt_intersect1(a, &r, &h);
        CHECK_MSG(h.prim == last && fabsf(h.t - 1.0f) < 1e-6f, "%s: after opening it: prim %u t %g", g_specs[i], h.prim,
                  (double)h.t);
        CHECK(prt_occluded1(a, &(prt_ray){{0.5f, 3.0f, 0.6f}, 0.0f, {0.0f, -1.0f, 0.0f}, 1.5f}));
        prt_accel_free(a);
    }
    prt_mesh_free(moved);
    prt_mesh_free(m);
    prt_mesh_free(g);
}

TEST(test_refit_refusals_and_bad_vertices) {
    prt_mesh *m = mesh_grid(20);
    prt_mesh *moved = mesh_transformed(m, 1.0f, 0.25f);
    prt_accel *a = NULL, *b = NULL;
    /* Strip codecs rebuild strips from the leaves: refused, with the reason. */
    CHECK(prt_build(m, "aabb:strip,update=refit", NULL, &a) == PRT_ERROR_ARGUMENT && !a);
    CHECK(strstr(prt_last_error(), "strip") != NULL);
    CHECK(prt_build(m, "aabb:float3,update=sometimes", NULL, &a) == PRT_ERROR_ARGUMENT);
    /* A BVH built without the option says how to get one that updates. */
    if (repr_build(m, "aabb:float3", &a)) {
        CHECK(prt_accel_update(a, moved->vertices) == PRT_ERROR_UNSUPPORTED);
        CHECK(strstr(prt_last_error(), "update=refit") != NULL);
        prt_accel_free(a);
    }
    if (!repr_build(m, "quad:float3-soa4,update=refit", &a)) goto done;
    /* Bad vertices: an error, and the accel still answers for the mesh it had. */
    moved->vertices[7] = NAN;
    CHECK(prt_accel_update(a, moved->vertices) == PRT_ERROR_MESH);
    moved->vertices[7] = 1e31f;
    CHECK(prt_accel_update(a, moved->vertices) == PRT_ERROR_LIMIT);
    if (repr_build(m, "quad:float3-soa4", &b)) {
        expect_matches(m, a, b, "after refused updates", 3);
        prt_accel_free(b);
    }
    /* Saved and loaded: answers as the built one, but keeps no tree to refit. */
    char path[] = "/tmp/test_refit_XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    if (fd >= 0) close(fd);
    CHECK_OK(prt_accel_save(a, path));
    b = NULL;
    CHECK_OK(prt_accel_load(path, &b));
    if (b) {
        expect_matches(m, b, a, "loaded", 4);
        moved->vertices[7] = 0.0f;
        CHECK(prt_accel_update(b, moved->vertices) == PRT_ERROR_UNSUPPORTED);
        CHECK(strstr(prt_last_error(), "loaded") != NULL);
        prt_accel_free(b);
    }
    unlink(path);
    prt_accel_free(a);
done:
    prt_mesh_free(moved);
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_refit_follows_a_deforming_mesh);
    RUN(test_refit_follows_walking_toys);
    RUN(test_refit_finds_a_triangle_that_was_flat);
    RUN(test_refit_refusals_and_bad_vertices);
    TEST_END();
}
