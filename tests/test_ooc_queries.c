/* The mesh queries on out-of-core block files (ooc/query.c): opened from disk with a cache
 * smaller than the file (evicting and reloading blocks as they go), on several threads,
 * closest points, every crossing and containment answer exactly as a BVH of the same mesh
 * (both exact: the same distances, triangles and barycentrics, the same crossings), and a
 * few closest points as the double brute force; a corrupt block or node met by a query's
 * walk is an error, never an answer (nor a walk without end). (test_queries_mesh and test_closest_exact run "ooc"
 * through their brute-force and closed-mesh checks too.) */
#include "core/rng.h"
#include "geom/closest.h"
#include "ooc/ooc_accel.h"
#include "support/files.h"
#include "support/meshes.h"
#include "support/repr.h"

#include <math.h>

/* n points: even ones near the surface (a vertex moved by up to 1% of the extent), odd ones
 * anywhere in the bounds grown by half their size each side. */
static float *points_near_and_far(const prt_mesh *m, size_t n, uint64_t seed) {
    float lo[3], hi[3], *p = malloc(3 * n * sizeof *p);
    prt_mesh_bounds(m, lo, hi);
    prt_rng rng = prt_rng_seed(seed, 0);
    for (size_t i = 0; i < n; i++) {
        const float *v = m->vertices + 3 * (size_t)(prt_rng_u32(&rng) % m->vertex_count);
        for (int k = 0; k < 3; k++) {
            const float e = hi[k] - lo[k], r = 2 * prt_rng_float(&rng) - 1;
            p[3 * i + k] = i % 2 ? lo[k] + e * (0.5f + r) : v[k] + 0.01f * e * r;
        }
    }
    return p;
}

/* The closest distance over every triangle in double (geom/closest.h per triangle). */
static float brute_force_distance(const prt_mesh *m, const float *p) {
    const double pd[3] = {p[0], p[1], p[2]};
    double best = INFINITY;
    for (size_t k = 0; k < m->triangle_count; k++) {
        double v[3][3], u, w;
        for (int j = 0; j < 3; j++)
            for (int x = 0; x < 3; x++) v[j][x] = m->vertices[3 * (size_t)m->triangles[3 * k + j] + x];
        best = fmin(best, prt__closest_on_triangle(pd, v[0], v[1], v[2], &u, &w));
    }
    return (float)sqrt(best);
}

static void check_closest_points(const prt_accel *a, const prt_accel *ref, const prt_mesh *m) {
    enum { N = 400 };
    float *p = points_near_and_far(m, N, 5);
    prt_closest got[N], want[N];
    CHECK_OK(prt_closest_points(a, p, N, INFINITY, got, 3));
    CHECK_OK(prt_closest_points(ref, p, N, INFINITY, want, 1));
    size_t differ = 0, brute = 0;
    for (size_t i = 0; i < N; i++) {
        differ += got[i].distance != want[i].distance || got[i].prim != want[i].prim || got[i].u != want[i].u ||
                  got[i].v != want[i].v;
        if (i < 16) brute += got[i].distance != brute_force_distance(m, p + 3 * i);
    }
    CHECK_MSG(differ == 0, "%zu of %d closest points differ from the BVH's", differ, N);
    CHECK_MSG(brute == 0, "%zu of 16 closest distances differ from the brute force's", brute);
    /* Within a maximum distance: the near points only. */
    CHECK_OK(prt_closest_points(a, p, N, 0.02f, got, 2));
    size_t found = 0;
    for (size_t i = 0; i < N; i++) {
        const bool in = want[i].distance <= 0.02f;
        found += in;
        CHECK(in ? got[i].prim == want[i].prim : got[i].prim == PRT_INVALID);
    }
    CHECK(found > N / 4 && found < N);
    /* A point that is not finite has no closest point, and is no error. */
    const float nan_point[3] = {NAN, 0, 0};
    CHECK_OK(prt_closest_points(a, nan_point, 1, INFINITY, got, 1));
    CHECK(got[0].prim == PRT_INVALID && got[0].distance == INFINITY);
    free(p);
}

static void check_crossings_and_containment(const prt_accel *a, const prt_accel *ref, const prt_mesh *m) {
    enum { R = 300, MAX = 64 };
    prt_ray *rays = rays_random(m, R, 9);
    size_t differ = 0, crossings = 0;
    for (size_t i = 0; i < R; i++) {
        prt_hit h[MAX], g[MAX];
        uint32_t n = 0, k = 0;
        CHECK_OK(prt_intersect_all(a, &rays[i], h, MAX, &n));
        CHECK_OK(prt_intersect_all(ref, &rays[i], g, MAX, &k));
        bool same = n == k;
        for (uint32_t j = 0; same && j < PRT_MIN(n, (uint32_t)MAX); j++)
            same = h[j].t == g[j].t && h[j].prim == g[j].prim;
        differ += !same, crossings += k;
    }
    CHECK_MSG(differ == 0, "%zu of %d rays cross differently", differ, R);
    CHECK(crossings > R); /* rays through the model cross it several times */
    enum { N = 300 };
    float *p = points_near_and_far(m, N, 8);
    uint8_t in[N], want[N];
    CHECK_OK(prt_contains(a, p, N, in, 3));
    CHECK_OK(prt_contains(ref, p, N, want, 1));
    size_t inside = 0;
    differ = 0;
    for (size_t i = 0; i < N; i++) differ += in[i] != want[i], inside += want[i] & PRT_INSIDE;
    CHECK_MSG(differ == 0 && inside > 0, "%zu of %d containment answers differ (%zu inside)", differ, N, inside);
    free(p), free(rays);
}

TEST(test_queries_on_a_file_through_a_small_cache_answer_as_a_bvh) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("mandelbulb", 150000, 3, &m));
    if (!m) return;
    const char *path = test_tmp_path("queries.ooc");
    prt_accel *built = NULL, *a = NULL, *ref = NULL;
    CHECK_OK(prt_build(m, "ooc", NULL, &built));
    if (built) CHECK_OK(prt_accel_save(built, path));
    prt_accel_free(built);
    prt_open_options oo = {.cache_bytes = 1}; /* the minimum: 64 slots, fewer than the blocks */
    CHECK_OK(prt_accel_open(path, &oo, &a));
    CHECK_OK(prt_build(m, "wide8:idx8-soa4", NULL, &ref));
    if (a && ref) {
        check_closest_points(a, ref, m);
        check_crossings_and_containment(a, ref, m);
        prt_cache_info info;
        prt_accel_frame(a, &info);
        CHECK_MSG(info.blocks_loaded_total > info.blocks, "%llu loads of %llu blocks: the cache never evicted",
                  (unsigned long long)info.blocks_loaded_total, (unsigned long long)info.blocks);
        CHECK_OK(prt_accel_check(a));
    }
    prt_accel_free(a), prt_accel_free(ref);
    remove(path);
    prt_mesh_free(m);
}

/* Every triangle block of a file made unreadable (its stored bytes 0xFF: an LZ4 stream that
 * overruns its block, or section offsets past the block), opened without the checksums
 * that would refuse it at once: the queries that reach a leaf fail with
 * PRT_ERROR_CORRUPT naming the query. */
TEST(test_queries_meeting_a_corrupt_block_are_an_error) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("sphere", 20000, 2, &m));
    if (!m) return;
    const char *path = test_tmp_path("corrupt.ooc");
    prt_accel *built = NULL;
    CHECK_OK(prt_build(m, "ooc", NULL, &built));
    if (built) CHECK_OK(prt_accel_save(built, path));
    prt_accel_free(built);
    size_t size = 0;
    uint8_t *d = file_get(path, &size);
    ooc_accel *o = NULL;
    if (d && size > sizeof(ooc_header)) {
        ooc_header h;
        memcpy(&h, d, sizeof h);
        for (uint32_t b = 0; b < h.block_count; b++) {
            ooc_block_entry e;
            memcpy(&e, d + h.table_offset + b * sizeof e, sizeof e);
            if (e.kind == OOC_BLOCK_TRIS) memset(d + e.offset, 0xFF, e.size);
        }
        CHECK_OK(ooc_open(d, size, -1, 0, "corrupt.ooc", NULL, false, &o));
    }
    if (o) {
        const prt_accel *a = &o->base;
        const float p[6] = {0.2f, 0.1f, 0.0f, NAN, 0, 0};
        prt_closest c[2];
        CHECK(prt_closest_points(a, p, 2, INFINITY, c, 1) == PRT_ERROR_CORRUPT);
        CHECK(strstr(prt_last_error(), "prt_closest_points") != NULL);
        uint8_t in[2];
        CHECK(prt_contains(a, p, 2, in, 1) == PRT_ERROR_CORRUPT);
        const prt_ray r = {{0, 0, -3}, 0, {0, 0.01f, 1}, INFINITY};
        prt_hit hits[4];
        uint32_t n;
        CHECK(prt_intersect_all(a, &r, hits, 4, &n) == PRT_ERROR_CORRUPT);
        prt_accel_free((prt_accel *)a);
    }
    free(d);
    remove(path);
    prt_mesh_free(m);
}

/* A corrupt node whose two children are itself (the root, changed in the cache after it was
 * read): each level doubles the paths, so only the walk's count of the nodes a tree can have
 * ends it, with an error rather than after 2^96 visits. */
TEST(test_a_node_pointing_back_at_itself_ends_the_walk_with_an_error) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("sphere", 5000, 2, &m));
    prt_accel *a = NULL;
    if (m) CHECK_OK(prt_build(m, "ooc", NULL, &a));
    if (a) {
        ooc_accel *o = (ooc_accel *)a;
        uint32_t size;
        uint8_t *blk = (uint8_t *)(uintptr_t)ooc_cache_get(&o->cache, o->h.root_block, &size);
        CHECK(blk && o->h.root_offset + 8 <= size);
        if (blk) {
            uint32_t w0;
            memcpy(&w0, blk + o->h.root_offset, 4);
            CHECK(w0 & OOC_INNER);
            w0 = (w0 & ~(0xFFFCu | 0x7FFu << 18 | OOC_LOD)) | OOC_LEFT | OOC_RIGHT; /* both children at offset 0 */
            memcpy(blk + o->h.root_offset, &w0, 4);
            ooc_cache_put(&o->cache, o->h.root_block);
        }
        const float p[3] = {0.1f, 0.2f, 0.3f};
        float w;
        CHECK(prt_winding_number(a, p, 1, &w, 1) == PRT_ERROR_CORRUPT);
        prt_closest c;
        CHECK(prt_closest_points(a, p, 1, INFINITY, &c, 1) == PRT_ERROR_CORRUPT);
    }
    prt_accel_free(a);
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_queries_on_a_file_through_a_small_cache_answer_as_a_bvh);
    RUN(test_queries_meeting_a_corrupt_block_are_an_error);
    RUN(test_a_node_pointing_back_at_itself_ends_the_walk_with_an_error);
    TEST_END();
}
