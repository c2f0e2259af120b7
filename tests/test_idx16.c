/* Indexed16 and Indexed16SOA4 (Rouwé §3.6, §3.7): lossless, so every hit is the one of
 * idx32-soa4 (the same floats into the same watertight kernels) and the brute force's
 * triangle; their leaves are as small as the format says; meshes that 16-bit indices cannot
 * reach are PRT_ERROR_LIMIT; a leaf naming a vertex past the buffer does not load; saving
 * and loading keeps every hit. Expected values follow from the format (docs/formats.md). */
#include "bvh/codecs/idx16.h"
#include "bvh/codecs/idx16_soa4.h"
#include "support/meshes.h"
#include "support/reference.h"
#include "support/repr.h"

static const char *const g_specs[] = {
    "quad:idx16",      "wide8:idx16",      "aabb:idx16,leaf=3",      "skd:idx16",
    "quad:idx16-soa4", "wide8:idx16-soa4", "aabb:idx16-soa4,leaf=5", "quad-half:idx16-soa4"};

static bool same_hit(prt_hit a, prt_hit b) { return a.prim == b.prim && a.t == b.t && a.u == b.u && a.v == b.v; }

TEST(test_idx16_hits_are_idx32_soa4_hits_and_the_brute_force_triangles) {
    prt_mesh *meshes[] = {mesh_grid(90), mesh_random_soup(4000, 17)};
    for (size_t i = 0; i < COUNT_OF(meshes); i++) {
        const prt_mesh *m = meshes[i];
        prt_ray *rays = rays_random(m, 4000, 31 + i);
        prt_hit *exact = malloc(4000 * sizeof *exact);
        double *edge = malloc(4000 * sizeof *edge);
        for (size_t r = 0; r < 4000; r++) exact[r] = ref_intersect(m, &rays[r], &edge[r]);
        prt_accel *ref;
        CHECK_OK(prt_build(m, "quad:idx32-soa4", NULL, &ref));
        for (size_t s = 0; ref && s < COUNT_OF(g_specs); s++) {
            prt_accel *a;
            CHECK_OK(prt_build(m, g_specs[s], NULL, &a));
            if (!a) continue;
            CHECK_MSG(repr_vertex_error(a) == 0, "%s states a vertex error", g_specs[s]);
            size_t differ = 0, wrong = 0, hits = 0;
            for (size_t r = 0; r < 4000; r++) {
                prt_ray r1 = rays[r], r2 = rays[r];
                prt_hit want, got;
                prt_intersect1(ref, &r1, &want);
                prt_intersect1(a, &r2, &got);
                differ += !same_hit(got, want);
                differ += prt_occluded1(a, &rays[r]) != (want.prim != PRT_INVALID);
                hits += got.prim != PRT_INVALID;
                if (edge[r] > 1e-4 || exact[r].prim == PRT_INVALID) wrong += got.prim != exact[r].prim;
            }
            CHECK_MSG(differ == 0 && wrong == 0 && hits > 400,
                      "mesh %zu %s: %zu differ from idx32-soa4, %zu from the brute force (%zu hits)", i, g_specs[s],
                      differ, wrong, hits);
            prt_accel_free(a);
        }
        prt_accel_free(ref);
        free(rays), free(exact), free(edge);
    }
    for (size_t i = 0; i < COUNT_OF(meshes); i++) prt_mesh_free(meshes[i]);
}

/* Leaf geometry: idx16-soa4 a 4-byte head and 24 bytes per (padded) block of 4, idx16 a
 * 4-byte head and 12 bytes per (padded) pair; plus the shared 12 bytes per vertex and one
 * NaN vertex, plus the 4-byte IDS entry per triangle. */
TEST(test_idx16_geometry_is_six_bytes_per_triangle_plus_the_heads) {
    prt_mesh *m = mesh_grid(100);
    const size_t T = m->triangle_count, V = m->vertex_count;
    const char *specs[] = {"quad:idx16", "quad:idx16-soa4"};
    const size_t pad_per_leaf[] = {6, 18};
    for (size_t s = 0; s < COUNT_OF(specs); s++) {
        prt_accel *a;
        CHECK_OK(prt_build(m, specs[s], NULL, &a));
        if (!a) continue;
        prt_stats st;
        prt_accel_stats(a, &st);
        size_t lo = 6 * T + 4 * st.leaves + 12 * (V + 1) + 4 * T, hi = lo + pad_per_leaf[s] * st.leaves;
        CHECK_MSG(st.bytes_geometry >= lo && st.bytes_geometry <= hi,
                  "%s: %zu bytes of geometry, the format says %zu..%zu", specs[s], (size_t)st.bytes_geometry, lo, hi);
        printf("     %s: %.2f B/tri of geometry\n", specs[s], (double)st.bytes_geometry / (double)T);
        prt_accel_free(a);
    }
    prt_mesh_free(m);
}

/* 65535 vertices and the NaN padding vertex fill the 16-bit range; one more does not fit. */
TEST(test_idx16_more_than_65535_vertices_is_a_limit) {
    prt_mesh *big = mesh_random_soup(70000 / 3 + 1, 5); /* 70002 vertices */
    prt_mesh *fits = mesh_random_soup(65535 / 3, 6);    /* 65535 vertices */
    CHECK(big && big->vertex_count > 65535 && fits && fits->vertex_count == 65535);
    const char *codecs[] = {"quad:idx16", "quad:idx16-soa4"};
    for (size_t s = 0; big && fits && s < COUNT_OF(codecs); s++) {
        prt_accel *a = NULL;
        prt_status st = prt_build(big, codecs[s], NULL, &a);
        CHECK_MSG(st == PRT_ERROR_LIMIT && a == NULL, "%s over %zu vertices: %s", codecs[s], big->vertex_count,
                  prt_status_string(st));
        CHECK_MSG(strstr(prt_last_error(), "16-bit") != NULL, "message: %s", prt_last_error());
        CHECK_OK(prt_build(fits, codecs[s], NULL, &a));
        prt_accel_free(a);
    }
    prt_mesh_free(big), prt_mesh_free(fits);
}

/* A leaf must name vertices of the buffer and a first triangle inside the tree. */
TEST(test_idx16_leaf_outside_the_buffer_is_invalid) {
    float vertices[3 * 10] = {0}; /* 9 mesh vertices and the NaN one */
    bvh_shared sh = {.data = (const uint8_t *)vertices, .size = sizeof vertices, .triangles = 8};
    uint8_t leaf[IDX16_HEAD_BYTES + IDX16_SOA4_BLOCK_BYTES] = {0};
    uint16_t nine = 9, ten = 10;
    memcpy(leaf + IDX16_HEAD_BYTES + 2 * 11, &nine, 2); /* vertex 2 of lane 3: the NaN vertex */
    CHECK(idx16_soa4_leaf_valid(leaf, 4, &sh));
    memcpy(leaf + IDX16_HEAD_BYTES + 2 * 11, &ten, 2);
    CHECK(!idx16_soa4_leaf_valid(leaf, 4, &sh));
    memcpy(leaf + IDX16_HEAD_BYTES + 2 * 11, &nine, 2);
    uint32_t id0 = 8; /* the tree has 8 triangles */
    memcpy(leaf, &id0, 4);
    CHECK(!idx16_soa4_leaf_valid(leaf, 4, &sh));

    uint8_t pair[IDX16_HEAD_BYTES + 2 * IDX16_TRI_BYTES] = {0};
    memcpy(pair + IDX16_HEAD_BYTES + 2 * 5, &nine, 2);
    CHECK(idx16_leaf_valid(pair, 2, &sh));
    memcpy(pair + IDX16_HEAD_BYTES + 2 * 5, &ten, 2); /* vertex 2 of the second triangle */
    CHECK(!idx16_leaf_valid(pair, 2, &sh));
}

TEST(test_idx16_save_and_load_keep_every_hit) {
    prt_mesh *m = mesh_grid(40);
    prt_ray *rays = rays_random(m, 2000, 8);
    char path[512];
    snprintf(path, sizeof path, "%s/test_idx16_roundtrip.prt", PRT_BINARY_DIR);
    for (size_t s = 0; s < COUNT_OF(g_specs); s++) {
        prt_accel *a, *b = NULL;
        CHECK_OK(prt_build(m, g_specs[s], NULL, &a));
        if (!a) continue;
        CHECK_OK(prt_accel_save(a, path));
        CHECK_OK(prt_accel_load(path, &b));
        size_t differ = 0;
        for (size_t r = 0; b && r < 2000; r++) {
            prt_ray r1 = rays[r], r2 = rays[r];
            prt_hit h1, h2;
            prt_intersect1(a, &r1, &h1), prt_intersect1(b, &r2, &h2);
            differ += !same_hit(h1, h2);
        }
        CHECK_MSG(b && differ == 0, "%s: %zu of 2000 hits changed by saving and loading", g_specs[s], differ);
        prt_accel_free(a), prt_accel_free(b);
    }
    remove(path);
    free(rays);
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_idx16_hits_are_idx32_soa4_hits_and_the_brute_force_triangles);
    RUN(test_idx16_geometry_is_six_bytes_per_triangle_plus_the_heads);
    RUN(test_idx16_more_than_65535_vertices_is_a_limit);
    RUN(test_idx16_leaf_outside_the_buffer_is_invalid);
    RUN(test_idx16_save_and_load_keep_every_hit);
    TEST_END();
}
