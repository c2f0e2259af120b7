/* The Indexed8 codecs (Rouwé §3.9; idx8-soa4 with float vertices, idx8-bitpack-soa4 with
 * packed ones): shared vertices are stored once while in reach of the 8-bit indices, the
 * stated vertex error bounds the quantization and every hit, the float variant answers
 * exactly as Float3SOA4, ids=none hands out the order it hits in, and a leaf that reaches
 * past the vertex buffer does not load. Expected sizes follow from the format
 * (docs/formats.md), not from the code. */
#include "bvh/codecs/idx8_bitpack_soa4.h"
#include "support/meshes.h"
#include "support/reference.h"
#include "support/repr.h"

#include <float.h>

/* A fan of n triangles around one centre vertex: every triangle shares it, so the buffer
 * must append it again whenever it falls out of the 8-bit window. */
static prt_mesh *fan(uint32_t n) {
    prt_mesh *m;
    if (prt_mesh_create(n + 2, n, &m)) return NULL;
    m->vertices[0] = m->vertices[1] = m->vertices[2] = 0.0f;
    for (uint32_t i = 0; i <= n; i++) {
        float a = 6.2831853f * (float)i / (float)(n + 1);
        m->vertices[3 * (i + 1) + 0] = cosf(a), m->vertices[3 * (i + 1) + 1] = 0.1f * sinf(3 * a),
                                  m->vertices[3 * (i + 1) + 2] = sinf(a);
    }
    for (uint32_t i = 0; i < n; i++)
        m->triangles[3 * i] = 0, m->triangles[3 * i + 1] = i + 1, m->triangles[3 * i + 2] = i + 2;
    return m;
}

static prt_stats stats_of(const prt_mesh *m, const char *spec) {
    prt_stats st = {0};
    uint32_t *order = malloc(m->triangle_count * sizeof *order);
    prt_build_options o = {.triangle_order = order};
    prt_accel *a = NULL;
    CHECK_OK(prt_build(m, spec, &o, &a));
    if (a) prt_accel_stats(a, &st);
    prt_accel_free(a);
    free(order);
    return st;
}

/* Rays of n random ones (seed 21) that quad:idx8-soa4 and quad:float3-soa4 built over m
 * answer differently, closest hit (bit for bit) or any hit; SIZE_MAX if a build fails. */
static size_t differ_from_float3_soa4(const prt_mesh *m, size_t n) {
    prt_accel *a = NULL, *b = NULL;
    CHECK_OK(prt_build(m, "quad:idx8-soa4", NULL, &a));
    CHECK_OK(prt_build(m, "quad:float3-soa4", NULL, &b));
    prt_ray *rays = rays_random(m, n, 21);
    size_t differ = a && b ? 0 : SIZE_MAX;
    for (size_t i = 0; a && b && i < n; i++) {
        prt_ray r1 = rays[i], r2 = rays[i];
        prt_hit h1, h2;
        prt_intersect1(a, &r1, &h1);
        prt_intersect1(b, &r2, &h2);
        differ += h1.prim != h2.prim || memcmp(&h1.t, &h2.t, 4) || memcmp(&h1.u, &h2.u, 4) || memcmp(&h1.v, &h2.v, 4);
        differ += prt_occluded1(a, &rays[i]) != prt_occluded1(b, &rays[i]);
    }
    free(rays);
    prt_accel_free(a), prt_accel_free(b);
    return differ;
}

/* Float entries: 12 bytes per entry instead of 8, otherwise the same buffer; the same
 * vertex floats through the same kernel give Float3SOA4's hits bit for bit. */
TEST(test_idx8_float_is_exactly_float3_soa4) {
    prt_mesh *soup = mesh_random_soup(20000, 3), *g = mesh_grid(100);
    prt_stats ss = stats_of(soup, "wide8:idx8-soa4,ids=none"), gs = stats_of(g, "wide8:idx8-soa4,ids=none");
    double soup_b = (double)ss.bytes_geometry / (double)soup->triangle_count;
    double grid_b = (double)gs.bytes_geometry / (double)g->triangle_count;
    CHECK_MSG(soup_b >= 39.0, "soup: %.2f B/tri of geometry, the format needs at least 39", soup_b);
    CHECK_MSG(grid_b < 14.0, "grid: %.2f B/tri of geometry: shared vertices are not reused", grid_b);
    CHECK(ss.vertex_error == 0 && gs.vertex_error == 0);
    const prt_mesh *meshes[] = {soup, g};
    for (size_t mi = 0; mi < 2; mi++) {
        size_t differ = differ_from_float3_soa4(meshes[mi], 5000);
        CHECK_MSG(differ == 0, "mesh %zu: %zu of 5000 rays answered differently from float3-soa4", mi, differ);
    }
    prt_mesh_free(soup), prt_mesh_free(g);
}

TEST(test_idx8_bitpack_reuses_shared_vertices) {
    /* A soup shares nothing: three 8-byte entries per triangle, plus 3 bytes of indices.
     * A grid has half a vertex per triangle: well under one entry each. */
    prt_mesh *soup = mesh_random_soup(20000, 3), *g = mesh_grid(100);
    prt_stats ss = stats_of(soup, "quad:idx8-bitpack-soa4,ids=none");
    prt_stats gs = stats_of(g, "quad:idx8-bitpack-soa4,ids=none");
    double soup_b = (double)ss.bytes_geometry / (double)soup->triangle_count;
    double grid_b = (double)gs.bytes_geometry / (double)g->triangle_count;
    CHECK_MSG(soup_b >= 27.0, "soup: %.2f B/tri of geometry, the format needs at least 27", soup_b);
    CHECK_MSG(grid_b < 12.0, "grid: %.2f B/tri of geometry: shared vertices are not reused", grid_b);
    printf("     geometry: soup %.2f B/tri, grid %.2f B/tri\n", soup_b, grid_b);
    prt_mesh_free(soup), prt_mesh_free(g);
}

/* Reuse goes by position: a grid whose triangles each have their own three vertices (an
 * exported CAD part, the level's pieces) takes the bytes the welded grid takes, and the
 * float variant still answers as Float3SOA4 does on the unwelded mesh. */
TEST(test_idx8_reuses_vertices_by_position_not_index) {
    prt_mesh *g = mesh_grid(100), *u = mesh_unwelded(g);
    const char *specs[] = {"quad:idx8-bitpack-soa4,ids=none", "wide8:idx8-soa4,ids=none"};
    for (int k = 0; k < 2; k++) {
        prt_stats gs = stats_of(g, specs[k]), us = stats_of(u, specs[k]);
        CHECK_MSG(us.bytes_geometry == gs.bytes_geometry, "%s: unwelded grid %zu geometry bytes, welded %zu", specs[k],
                  (size_t)us.bytes_geometry, (size_t)gs.bytes_geometry);
    }
    size_t differ = differ_from_float3_soa4(u, 3000);
    CHECK_MSG(differ == 0, "%zu of 3000 rays answered differently from float3-soa4 on the unwelded grid", differ);
    prt_mesh_free(g), prt_mesh_free(u);
}

/* Rounding to the nearest of 2^21 - 1 steps moves a component by at most half a step,
 * and decoding lo + q * step adds float rounding of the coordinates' magnitude. */
TEST(test_idx8_bitpack_error_within_the_quantization_step) {
    prt_mesh *meshes[] = {mesh_grid(60), mesh_random_soup(5000, 9), fan(3000)};
    for (size_t i = 0; i < COUNT_OF(meshes); i++) {
        const prt_mesh *m = meshes[i];
        float lo[3], hi[3];
        prt_mesh_bounds(m, lo, hi);
        double half_step2 = 0, big = 0;
        for (int k = 0; k < 3; k++) {
            double s = ((double)hi[k] - lo[k]) / (double)IDX8BP_MASK;
            half_step2 += 0.25 * s * s;
            big = fmax(big, fmax(fabs(lo[k]), fabs(hi[k])));
        }
        double bound = sqrt(half_step2) + 4 * sqrt(3.0) * big * (double)FLT_EPSILON;
        prt_accel *a;
        CHECK_OK(prt_build(m, "wide8:idx8-bitpack-soa4", NULL, &a));
        if (!a) continue;
        double err = repr_vertex_error(a);
        CHECK_MSG(err > 0 && err <= bound, "mesh %zu: stated error %.3g, bound %.3g", i, err, bound);
        /* Every hit within the stated error of the brute force's. */
        prt_ray *rays = rays_random(m, 3000, 5 + i);
        double tol = 1e-5 * ref_diagonal(m);
        size_t wrong = 0;
        for (size_t r = 0; r < 3000; r++) {
            double edge;
            prt_hit want = ref_intersect(m, &rays[r], &edge), got;
            prt_ray ray = rays[r];
            prt_intersect1(a, &ray, &got);
            wrong += !ref_lossy_acceptable(m, &rays[r], &got, &want, err, tol);
        }
        CHECK_MSG(wrong == 0, "mesh %zu: %zu of 3000 hits outside the error bound", i, wrong);
        free(rays);
        prt_accel_free(a);
    }
    for (size_t i = 0; i < COUNT_OF(meshes); i++) prt_mesh_free(meshes[i]);
}

/* ids=none: hits name positions in the accel's order, which maps them to the mesh ids the
 * ids=mesh build answers with. */
TEST(test_idx8_bitpack_ids_none_hands_out_its_order) {
    prt_mesh *m = mesh_grid(80);
    uint32_t *order = malloc(m->triangle_count * sizeof *order);
    prt_build_options o = {.triangle_order = order};
    prt_accel *with_ids, *without;
    CHECK_OK(prt_build(m, "quad:idx8-bitpack-soa4", NULL, &with_ids));
    CHECK_OK(prt_build(m, "quad:idx8-bitpack-soa4,ids=none", &o, &without));
    CHECK(prt_build(m, "quad:idx8-bitpack-soa4,ids=none", NULL, &(prt_accel *){NULL}) == PRT_ERROR_ARGUMENT);
    prt_ray *rays = rays_random(m, 2000, 4);
    size_t hits = 0, same = 0;
    for (size_t i = 0; with_ids && without && i < 2000; i++) {
        prt_ray r1 = rays[i], r2 = rays[i];
        prt_hit h1, h2;
        prt_intersect1(with_ids, &r1, &h1);
        prt_intersect1(without, &r2, &h2);
        if (h1.prim == PRT_INVALID) {
            same += h2.prim == PRT_INVALID;
            continue;
        }
        hits++;
        same += h2.prim < m->triangle_count && order[h2.prim] == h1.prim && h1.t == h2.t;
    }
    CHECK_MSG(same == 2000 && hits > 500, "%zu of 2000 rays agree (%zu hits)", same, hits);
    free(rays), free(order);
    prt_accel_free(with_ids), prt_accel_free(without);
    prt_mesh_free(m);
}

/* The fan's centre is shared by every triangle: it is appended again each time it leaves
 * the window, and every leaf still reaches all its vertices with 8-bit indices. */
TEST(test_idx8_bitpack_shared_vertex_beyond_the_window) {
    prt_mesh *m = fan(20000);
    const char *specs[] = {"aabb:idx8-bitpack-soa4,leaf=16", "wide8:idx8-bitpack-soa4,leaf=16",
                           "quad-half:idx8-bitpack-soa4,leaf=1"};
    for (size_t s = 0; s < COUNT_OF(specs); s++) {
        prt_accel *a;
        CHECK_OK(prt_build(m, specs[s], NULL, &a));
        if (!a) continue;
        /* Rays straight down onto the fan, every one on a triangle. */
        size_t missed = 0;
        for (int i = 0; i < 2000; i++) {
            float ang = 6.2831853f * ((float)i + 0.5f) / 2000.0f, rad = 0.3f + 0.5f * (float)(i % 7) / 7.0f;
            prt_ray r = {{rad * cosf(ang), 2.0f, rad * sinf(ang)}, 0, {0, -1, 0}, INFINITY};
            prt_hit h;
            prt_intersect1(a, &r, &h);
            missed += h.prim == PRT_INVALID;
        }
        CHECK_MSG(missed == 0, "%s: %zu of 2000 rays onto the fan missed", specs[s], missed);
        prt_accel_free(a);
    }
    prt_mesh_free(m);
}

/* A leaf must only name entries of the buffer, and the buffer must be what its head says. */
TEST(test_idx8_bitpack_leaf_outside_the_buffer_is_invalid) {
    uint8_t shared[32 + 8 * 10] = {0};
    idx8bp_header hd = {{0, 0, 0}, {1, 1, 1}, 0, 10};
    memcpy(shared, &hd, sizeof hd);
    bvh_shared sh = {.data = shared, .size = sizeof shared, .triangles = 4};
    uint8_t leaf[IDX8BP_HEAD_BYTES + IDX8BP_BLOCK_BYTES] = {0};
    uint32_t first = 5;
    memcpy(leaf, &first, 4);
    leaf[IDX8BP_HEAD_BYTES + 3] = 4; /* entry 9: the last one */
    CHECK(idx8_bitpack_soa4_leaf_valid(leaf, 4, &sh));
    leaf[IDX8BP_HEAD_BYTES + 3] = 5; /* entry 10: one past */
    CHECK(!idx8_bitpack_soa4_leaf_valid(leaf, 4, &sh));
    leaf[IDX8BP_HEAD_BYTES + 3] = 0;
    sh.size -= 8; /* the head claims more entries than there are */
    CHECK(!idx8_bitpack_soa4_leaf_valid(leaf, 4, &sh));
    sh.size += 8;
    hd.step[1] = NAN;
    memcpy(shared, &hd, sizeof hd);
    CHECK(!idx8_bitpack_soa4_leaf_valid(leaf, 4, &sh));
}

int main(void) {
    RUN(test_idx8_float_is_exactly_float3_soa4);
    RUN(test_idx8_bitpack_reuses_shared_vertices);
    RUN(test_idx8_reuses_vertices_by_position_not_index);
    RUN(test_idx8_bitpack_error_within_the_quantization_step);
    RUN(test_idx8_bitpack_ids_none_hands_out_its_order);
    RUN(test_idx8_bitpack_shared_vertex_beyond_the_window);
    RUN(test_idx8_bitpack_leaf_outside_the_buffer_is_invalid);
    TEST_END();
}
