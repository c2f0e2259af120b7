/* The BitPack codecs (Rouwé §3.4, §3.5, §3.8): every stated vertex error lies within half a
 * quantization step of the format (plus float rounding) and bounds every hit; meshes that
 * 16-bit indices cannot reach are PRT_ERROR_LIMIT; a crafted leaf that reaches outside
 * what it may does not load; saving and loading keeps every hit and the stated error.
 * Expected values follow from the format (docs/formats.md), not from the code. */
#include "bvh/codecs/bitpack.h"
#include "bvh/codecs/bitpack_soa4.h"
#include "bvh/codecs/idx16_bitpack_soa4.h"
#include "bvh/codecs/idx32_bitpack_soa4.h"
#include "bvh/codecs/lattice.h"
#include "support/lossy.h"
#include "support/meshes.h"
#include "support/reference.h"
#include "support/repr.h"

#include <float.h>

static double largest_coordinate(const prt_mesh *m) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    double big = 0;
    for (int k = 0; k < 3; k++) big = fmax(big, fmax(fabs(lo[k]), fabs(hi[k])));
    return big;
}

/* Half a step of `steps` over the mesh bounds per component, plus the float rounding of
 * lo + q * step at the coordinates' magnitude. A leaf's or block's grid spans at most the
 * mesh bounds, so this bounds the per-leaf and per-block codecs too. */
static double grid_bound(const prt_mesh *m, double steps) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    double half_step2 = 0;
    for (int k = 0; k < 3; k++) {
        double s = ((double)hi[k] - lo[k]) / steps;
        half_step2 += 0.25 * s * s;
    }
    return sqrt(half_step2) + 4 * sqrt(3.0) * largest_coordinate(m) * (double)FLT_EPSILON;
}

TEST(test_indexed_bitpack_error_within_the_mesh_grid_step) {
    prt_mesh *meshes[] = {mesh_grid(60), mesh_random_soup(3000, 9)};
    const char *specs[] = {"wide8:idx16-bitpack-soa4", "quad:idx32-bitpack-soa4", "aabb:idx32-bitpack-soa4,leaf=7"};
    for (size_t i = 0; i < COUNT_OF(meshes); i++)
        for (size_t s = 0; s < COUNT_OF(specs); s++) {
            prt_accel *a;
            CHECK_OK(prt_build(meshes[i], specs[s], NULL, &a));
            if (!a) continue;
            double err = repr_vertex_error(a), bound = grid_bound(meshes[i], BPV_MASK);
            CHECK_MSG(err > 0 && err <= bound, "mesh %zu %s: stated error %.3g, bound %.3g", i, specs[s], err, bound);
            size_t wrong = lossy_hits_outside_the_bound(meshes[i], a, 2000, 5 + i);
            CHECK_MSG(wrong == 0, "mesh %zu %s: %zu of 2000 hits outside the error bound", i, specs[s], wrong);
            prt_accel_free(a);
        }
    for (size_t i = 0; i < COUNT_OF(meshes); i++) prt_mesh_free(meshes[i]);
}

/* Half a cell per component of the tree's lattice (codecs/lattice.h, docs/formats.md): the
 * smallest power of two with which the mesh bounds span `steps` - 1 cells; the decode is
 * exact, so nothing is added for rounding but a hair for the error's own float. */
static double lattice_bound(const prt_mesh *m, double steps) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    double half_cell2 = 0;
    for (int k = 0; k < 3; k++) {
        const double span = (double)hi[k] - lo[k], cell = span > 0 ? exp2(ceil(log2(span / (steps - 1)))) : 0;
        half_cell2 += 0.25 * cell * cell;
    }
    return sqrt(half_cell2) * (1 + 1e-6);
}

/* bitpack-soa4, bitpack and strip-bitpack round the mesh to one lattice per tree and
 * encode each block or leaf on it exactly: the error they state (measured over every leaf)
 * lies within half a cell of the mesh-wide lattice of 2^16, 2^21 or 2^20 steps, and bounds
 * every hit. */
TEST(test_bitpack_lattice_errors_are_measured_and_bound_hits) {
    prt_mesh *grid = mesh_grid(60), *soup = mesh_random_soup(3000, 9);
    prt_mesh *meshes[] = {grid, soup, mesh_transformed(soup, 3.0f, 1000.0f)};
    const char *specs[] = {"quad:bitpack-soa4", "wide8:bitpack-soa4", "aabb:bitpack-soa4,leaf=6",
                           "quad:bitpack",      "skd:bitpack",        "wide8:strip-bitpack"};
    for (size_t i = 0; i < COUNT_OF(meshes); i++)
        for (size_t s = 0; s < COUNT_OF(specs); s++) {
            prt_accel *a;
            CHECK_OK(prt_build(meshes[i], specs[s], NULL, &a));
            if (!a) continue;
            const double steps = strstr(specs[s], "soa4") ? 65536.0 : strstr(specs[s], "strip") ? 1048576.0 : 2097152.0;
            double err = repr_vertex_error(a), bound = lattice_bound(meshes[i], steps - 1);
            /* Just below 1024 floats lie 2^-14 apart, no closer than the cells of a span of 3
             * (2^-14 for 2^16 steps, finer for more): every vertex is on the lattice already
             * and nothing is lost. */
            const bool coarse_floats = i == 2;
            CHECK_MSG((err > 0 || coarse_floats) && err <= bound, "mesh %zu %s: stated error %.3g, bound %.3g", i,
                      specs[s], err, bound);
            size_t wrong = lossy_hits_outside_the_bound(meshes[i], a, 2000, 15 + i);
            CHECK_MSG(wrong == 0, "mesh %zu %s: %zu of 2000 hits outside the error bound", i, specs[s], wrong);
            prt_accel_free(a);
        }
    for (size_t i = 0; i < COUNT_OF(meshes); i++) prt_mesh_free(meshes[i]);
}

/* The lattice (codecs/lattice.h): any run of rounded vertices, given the grid a leaf takes
 * (its lower corner and bvh_lattice_step of its span), is lo + q * step for integers
 * q <= mask, and decodes to the rounded vertex bit for bit; rounding moved no coordinate
 * more than half a cell. Meshes near the origin and far from it (where floats are spaced
 * wider than the cell), with runs of 1 to 16 triangles anywhere in the mesh. */
TEST(test_bitpack_lattice_runs_decode_exactly) {
    prt_mesh *soup = mesh_random_soup(2000, 4);
    prt_mesh *meshes[] = {soup, mesh_transformed(soup, 1e-3f, 4096.0f), mesh_transformed(soup, 100.0f, -7.0f)};
    const uint32_t masks[] = {BSOA_MASK, BPV_MASK};
    size_t inexact = 0, runs = 0, moved_too_far = 0;
    for (size_t i = 0; i < COUNT_OF(meshes); i++)
        for (size_t mk = 0; mk < COUNT_OF(masks); mk++) {
            const prt_mesh *m = meshes[i];
            float *v = malloc(12 * m->vertex_count);
            bvh_lattice_snap(m, m->vertices, masks[mk], v);
            float lo[3], hi[3];
            prt_mesh_bounds(m, lo, hi);
            for (int k = 0; k < 3; k++) {
                const double cell = exp2(ceil(log2(((double)hi[k] - lo[k]) / (masks[mk] - 1))));
                for (size_t x = 0; x < m->vertex_count; x++)
                    moved_too_far += fabs((double)v[3 * x + k] - m->vertices[3 * x + k]) > 0.5 * cell;
            }
            for (size_t first = 0; first < m->triangle_count; first += 7) {
                const size_t n = 1 + first % 16;
                if (first + n > m->triangle_count) break;
                float rlo[3] = {INFINITY, INFINITY, INFINITY}, rhi[3] = {-INFINITY, -INFINITY, -INFINITY};
                for (size_t c = 3 * first; c < 3 * (first + n); c++)
                    for (int k = 0; k < 3; k++)
                        rlo[k] = fminf(rlo[k], v[3 * m->triangles[c] + k]),
                        rhi[k] = fmaxf(rhi[k], v[3 * m->triangles[c] + k]);
                for (int k = 0; k < 3; k++) {
                    const float step = bvh_lattice_step((double)rhi[k] - rlo[k], masks[mk]);
                    for (size_t c = 3 * first; c < 3 * (first + n); c++) {
                        const float x = v[3 * m->triangles[c] + k];
                        const double q = step > 0 ? ((double)x - rlo[k]) / step : 0;
                        inexact += q != floor(q) || q > masks[mk] || bpv_decode(rlo[k], step, (uint32_t)q) != x;
                    }
                }
                runs++;
            }
            free(v);
        }
    CHECK_MSG(inexact == 0 && moved_too_far == 0 && runs > 1000,
              "%zu coordinates of %zu runs inexact, %zu moved too far", inexact, runs, moved_too_far);
    for (size_t i = 0; i < COUNT_OF(meshes); i++) prt_mesh_free(meshes[i]);
}

/* A bitpack-soa4 leaf: its first id inside the tree, a count its size allows and finite
 * grids; a bitpack leaf: its first id inside the tree and a finite grid. */
TEST(test_bitpack_crafted_leaves_are_invalid) {
    bvh_shared sh = {.triangles = 8};
    uint8_t leaf[BSOA_HEAD_BYTES + 2 * BSOA_BLOCK_BYTES] = {0};
    uint32_t count = 6;
    memcpy(leaf + 4, &count, 4);
    CHECK(bitpack_soa4_leaf_valid(leaf, 8, &sh));
    count = 4; /* one block, but the size holds two */
    memcpy(leaf + 4, &count, 4);
    CHECK(!bitpack_soa4_leaf_valid(leaf, 8, &sh));
    count = 6;
    memcpy(leaf + 4, &count, 4);
    const float nan = NAN;
    memcpy(leaf + BSOA_HEAD_BYTES + BSOA_BLOCK_BYTES + 72 + 4, &nan, 4); /* scale y of block 1 */
    CHECK(!bitpack_soa4_leaf_valid(leaf, 8, &sh));

    uint8_t bp[BITPACK_HEAD_BYTES + 2 * BITPACK_TRI_BYTES] = {0};
    CHECK(bitpack_leaf_valid(bp, 2, &sh));
    const float neg = -1;
    memcpy(bp + 4 + 12, &neg, 4); /* step x */
    CHECK(!bitpack_leaf_valid(bp, 2, &sh));
    memset(bp, 0, sizeof bp);
    uint32_t id0 = 8; /* the tree has 8 triangles */
    memcpy(bp, &id0, 4);
    CHECK(!bitpack_leaf_valid(bp, 2, &sh));
}

/* Leaves: a 4-byte head and 12 indices per (padded) block of 4; the buffer a 32-byte head
 * and 8 bytes per mesh vertex; plus the 4-byte IDS entry per triangle. */
TEST(test_indexed_bitpack_geometry_follows_the_format) {
    prt_mesh *m = mesh_grid(100);
    const size_t T = m->triangle_count, V = m->vertex_count;
    const char *specs[] = {"quad:idx16-bitpack-soa4", "quad:idx32-bitpack-soa4"};
    const size_t index_bytes[] = {2, 4};
    for (size_t s = 0; s < COUNT_OF(specs); s++) {
        prt_accel *a;
        CHECK_OK(prt_build(m, specs[s], NULL, &a));
        if (!a) continue;
        prt_stats st;
        prt_accel_stats(a, &st);
        size_t lo = 3 * index_bytes[s] * T + 4 * st.leaves + 32 + 8 * V + 4 * T,
               hi = lo + 9 * index_bytes[s] * st.leaves;
        CHECK_MSG(st.bytes_geometry >= lo && st.bytes_geometry <= hi,
                  "%s: %zu bytes of geometry, the format says %zu..%zu", specs[s], (size_t)st.bytes_geometry, lo, hi);
        printf("     %s: %.2f B/tri of geometry\n", specs[s], (double)st.bytes_geometry / (double)T);
        prt_accel_free(a);
    }
    prt_mesh_free(m);
}

/* 16-bit indices reach 65536 entries (no padding vertex: padding repeats a vertex). */
TEST(test_idx16_bitpack_more_than_65536_vertices_is_a_limit) {
    prt_mesh *big = mesh_random_soup(70000 / 3 + 1, 5); /* 70002 vertices */
    prt_mesh *fits = mesh_random_soup(65536 / 3, 6);    /* 65535 vertices */
    prt_accel *a = NULL;
    prt_status st = prt_build(big, "quad:idx16-bitpack-soa4", NULL, &a);
    CHECK_MSG(st == PRT_ERROR_LIMIT && a == NULL, "%zu vertices: %s", big->vertex_count, prt_status_string(st));
    CHECK_MSG(strstr(prt_last_error(), "16-bit") != NULL, "message: %s", prt_last_error());
    CHECK_OK(prt_build(big, "quad:idx32-bitpack-soa4", NULL, &a));
    prt_accel_free(a);
    CHECK_OK(prt_build(fits, "quad:idx16-bitpack-soa4", NULL, &a));
    prt_accel_free(a);
    prt_mesh_free(big), prt_mesh_free(fits);
}

/* A leaf must name entries of the buffer and a first triangle inside the tree, and the
 * buffer must be what its head says. */
TEST(test_indexed_bitpack_leaf_outside_the_buffer_is_invalid) {
    uint8_t shared[32 + 8 * 10] = {0};
    bpv_header hd = {{0, 0, 0}, {1, 1, 1}, 0, 10};
    memcpy(shared, &hd, sizeof hd);
    bvh_shared sh = {.data = shared, .size = sizeof shared, .triangles = 8};
    uint8_t l16[4 + 24] = {0}, l32[4 + 48] = {0};
    uint16_t nine16 = 9, ten16 = 10;
    uint32_t nine32 = 9, ten32 = 10;
    memcpy(l16 + 4 + 2 * 11, &nine16, 2), memcpy(l32 + 4 + 4 * 11, &nine32, 4);
    CHECK(idx16_bitpack_soa4_leaf_valid(l16, 4, &sh) && idx32_bitpack_soa4_leaf_valid(l32, 4, &sh));
    memcpy(l16 + 4 + 2 * 11, &ten16, 2), memcpy(l32 + 4 + 4 * 11, &ten32, 4);
    CHECK(!idx16_bitpack_soa4_leaf_valid(l16, 4, &sh) && !idx32_bitpack_soa4_leaf_valid(l32, 4, &sh));
    memcpy(l16 + 4 + 2 * 11, &nine16, 2), memcpy(l32 + 4 + 4 * 11, &nine32, 4);
    uint32_t id0 = 8; /* the tree has 8 triangles */
    memcpy(l32, &id0, 4);
    CHECK(!idx32_bitpack_soa4_leaf_valid(l32, 4, &sh));
    sh.size -= 8; /* the head claims more entries than there are */
    CHECK(!idx16_bitpack_soa4_leaf_valid(l16, 4, &sh));
    sh.size += 8;
    hd.step[2] = -1;
    memcpy(shared, &hd, sizeof hd);
    CHECK(!idx16_bitpack_soa4_leaf_valid(l16, 4, &sh));
}

TEST(test_bitpack_save_and_load_keep_every_hit_and_the_error) {
    prt_mesh *m = mesh_grid(40);
    prt_ray *rays = rays_random(m, 2000, 8);
    char path[512];
    snprintf(path, sizeof path, "%s/test_bitpack_roundtrip.prt", PRT_BINARY_DIR);
    const char *specs[] = {"quad:idx16-bitpack-soa4", "wide8:idx32-bitpack-soa4", "wide8:bitpack-soa4", "aabb:bitpack"};
    for (size_t s = 0; s < COUNT_OF(specs); s++) {
        prt_accel *a, *b = NULL;
        CHECK_OK(prt_build(m, specs[s], NULL, &a));
        if (!a) continue;
        CHECK_OK(prt_accel_save(a, path));
        CHECK_OK(prt_accel_load(path, &b));
        size_t differ = 0;
        for (size_t r = 0; b && r < 2000; r++) {
            prt_ray r1 = rays[r], r2 = rays[r];
            prt_hit h1, h2;
            prt_intersect1(a, &r1, &h1), prt_intersect1(b, &r2, &h2);
            differ += h1.prim != h2.prim || h1.t != h2.t || h1.u != h2.u || h1.v != h2.v;
        }
        CHECK_MSG(b && differ == 0, "%s: %zu of 2000 hits changed by saving and loading", specs[s], differ);
        CHECK_MSG(b && repr_vertex_error(a) > 0 && repr_vertex_error(a) == repr_vertex_error(b),
                  "%s: error %.3g, loaded %.3g", specs[s], repr_vertex_error(a), b ? repr_vertex_error(b) : -1.0);
        prt_accel_free(a), prt_accel_free(b);
    }
    remove(path);
    free(rays);
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_indexed_bitpack_error_within_the_mesh_grid_step);
    RUN(test_bitpack_lattice_errors_are_measured_and_bound_hits);
    RUN(test_bitpack_lattice_runs_decode_exactly);
    RUN(test_bitpack_crafted_leaves_are_invalid);
    RUN(test_indexed_bitpack_geometry_follows_the_format);
    RUN(test_idx16_bitpack_more_than_65536_vertices_is_a_limit);
    RUN(test_indexed_bitpack_leaf_outside_the_buffer_is_invalid);
    RUN(test_bitpack_save_and_load_keep_every_hit_and_the_error);
    TEST_END();
}
