/* Failed allocations (issue 31): with an allocator (prt_set_allocator) that refuses the
 * k-th allocation, for every k up to the number a small build makes, building each
 * representation family and rendering a small image ends in PRT_ERROR_NOMEM with a
 * message (or succeeds, where packrt can do without the block), holds no packrt memory
 * afterwards (prt_memory_usage; ASan's leak checker in build-asan), and the next normal
 * build works. */
#include "support/meshes.h"
#include "test.h"

#include <stdatomic.h>

static atomic_long g_count;   /* allocations since armed */
static atomic_long g_fail_at; /* 1-based index of the allocation to refuse; 0: none */
static atomic_int g_armed;

static void *counting_alloc(size_t n) {
    if (atomic_load(&g_armed)) {
        long c = atomic_fetch_add(&g_count, 1) + 1;
        if (c == atomic_load(&g_fail_at)) return NULL;
    }
    return malloc(n);
}

typedef struct scenario {
    const char *name;
    const char *spec;
    int render; /* 0: build only; 1: build outside, render counted; 2: save and load counted */
    int update; /* also prt_accel_update (cgrid) inside the counted part */
    prt_mesh *(*mesh)(void);
    int threads; /* 0: one; else this many (OpenMP paths: the order of allocations varies) */
} scenario;

static prt_mesh *grid(void) { return mesh_grid(8); } /* 128 connected triangles */
static prt_mesh *soup(void) { return mesh_random_soup(200, 3); }
static prt_mesh *big_soup(void) { return mesh_random_soup(20000, 5); }
static prt_mesh *mid_soup(void) { return mesh_random_soup(3000, 6); }

static const scenario g_cases[] = {
    {"aabb:float3", "aabb:float3", 0, 0, soup, 0},
    {"aabb-split:bitpack", "aabb-split:bitpack", 0, 0, soup, 0},
    {"quad:idx8-bitpack-soa4", "quad:idx8-bitpack-soa4", 0, 0, grid, 0},
    {"skd:float3-soa4", "skd:float3-soa4", 0, 0, soup, 0},
    {"wide8:strip-bitpack", "wide8:strip-bitpack", 0, 0, grid, 0},
    {"aabb:idx16,ids=none", "aabb:idx16,ids=none", 0, 0, grid, 0},
    {"raystrips", "raystrips", 0, 0, grid, 0},
    {"lossygrid", "lossygrid", 0, 0, grid, 0},
    {"cgrid + update", "cgrid", 0, 1, soup, 0},
    {"ooc in memory", "ooc", 0, 0, grid, 0},
    {"render aabb:float3 ao", "aabb:float3", 1, 0, grid, 0},
    {"render ooc lod", "ooc", 1, 0, grid, 0},
    {"save+load quad:bitpack", "quad:bitpack", 2, 0, grid, 0},
    {"save+load ooc", "ooc", 2, 0, grid, 0},
    {"aabb:float3 2 threads", "aabb:float3", 0, 0, big_soup, 2},
    {"wide8:idx32 2 threads", "wide8:idx32", 0, 0, big_soup, 2},
    {"ooc 2 threads", "ooc", 0, 0, mid_soup, 2},
    {"cgrid 2 threads", "cgrid", 0, 1, big_soup, 2},
    {"render ao 2 threads", "quad:float3-soa4", 1, 0, big_soup, 2},
};

static prt_hit g_probe; /* the probe ray's answer in the run being checked */

/* The counted work of one scenario: PRT_OK, or the first failure. */
static prt_status run(const scenario *c, prt_mesh *m, prt_accel *prebuilt) {
    const int threads = c->threads ? c->threads : 1;
    prt_build_options o = {.threads = threads};
    if (c->render == 2) {
        const char *path = test_tmp_path("alloc_fail.prt");
        atomic_store(&g_armed, 1);
        prt_status s = prt_accel_save(prebuilt, path);
        prt_accel *a = NULL;
        if (!s) s = prt_accel_load(path, &a);
        atomic_store(&g_armed, 0);
        prt_accel_free(a);
        unlink(path);
        return s;
    }
    if (c->render) {
        prt_render_options r = {.width = 16, .height = 12, .threads = threads, .spp = 2};
        r.shade = strcmp(c->spec, "ooc") ? PRT_SHADE_AO : PRT_SHADE_SHADOWS;
        r.lod_pixels = strcmp(c->spec, "ooc") ? 0.0f : 1.0f;
        prt_image img = {0};
        atomic_store(&g_armed, 1);
        prt_status s = prt_render(prebuilt, m, NULL, &r, &img);
        atomic_store(&g_armed, 0);
        prt_image_free(&img);
        return s;
    }
    prt_accel *a = NULL;
    uint32_t *order = strstr(c->spec, "ids=none") ? malloc(m->triangle_count * sizeof *order) : NULL;
    o.triangle_order = order;
    atomic_store(&g_armed, 1);
    prt_status s = prt_build(m, c->spec, &o, &a);
    if (!s && c->update) {
        for (size_t i = 0; i < 3 * m->vertex_count; i++) m->vertices[i] += 0.01f;
        s = prt_accel_update(a, m->vertices);
    }
    atomic_store(&g_armed, 0);
    if (!s) {
        /* The accel answers like a fresh one: one ray through the middle hits or misses alike. */
        float lo[3], hi[3];
        prt_accel_bounds(a, lo, hi);
        prt_ray ray = {{0.5f * (lo[0] + hi[0]), hi[1] + 1, 0.5f * (lo[2] + hi[2])}, 0, {0, -1, 0}, INFINITY};
        prt_intersect1(a, &ray, &g_probe);
    }
    prt_accel_free(a);
    free(order);
    return s;
}

TEST(test_every_failed_allocation_is_a_clean_error) {
    prt_set_allocator(counting_alloc, free);
    long total_k = 0, total_ok = 0;
    for (size_t i = 0; i < COUNT_OF(g_cases); i++) {
        const scenario *c = &g_cases[i];
        const char *only = getenv("PRT_ALLOC_CASE"); /* one scenario, when debugging */
        if (only && *only && !strstr(c->name, only)) continue;
        prt_mesh *m = c->mesh();
        prt_accel *pre = NULL;
        if (c->render) {
            prt_build_options o = {.threads = c->threads ? c->threads : 1};
            CHECK_OK(prt_build(m, c->spec, &o, &pre));
        }
        size_t before;
        prt_memory_usage(&before, NULL);
        atomic_store(&g_fail_at, 0);
        atomic_store(&g_count, 0);
        prt_status s = run(c, m, pre);
        long n = atomic_load(&g_count);
        const prt_hit probe = g_probe;
        CHECK_MSG(s == PRT_OK, "%s: the uninjured run failed: %s", c->name, prt_last_error());
        int tolerated = 0;
        /* Every k up to 400; past that, 400 ks spread evenly (the runtime stays seconds). */
        const long stride = n > 400 ? (n + 399) / 400 : 1;
        long tried = 0;
        for (long k = 1; k <= n; k += (k < 400 ? 1 : stride)) {
            tried++;
            prt_accel *dummy = NULL;
            (void)prt_accel_load("/nonexistent/marker", &dummy); /* a known message to replace */
            atomic_store(&g_count, 0);
            atomic_store(&g_fail_at, k);
            s = run(c, m, pre);
            atomic_store(&g_fail_at, 0);
            if (s == PRT_OK) {
                tolerated++;
                CHECK_MSG(!memcmp(&probe, &g_probe, sizeof probe), "%s: allocation %ld refused: another answer",
                          c->name, k);
            } else {
                CHECK_MSG(s == PRT_ERROR_NOMEM, "%s: allocation %ld of %ld: %s: %s", c->name, k, n,
                          prt_status_string(s), prt_last_error());
                CHECK_MSG(!strstr(prt_last_error(), "marker") && *prt_last_error(), "%s: allocation %ld: no message",
                          c->name, k);
            }
            size_t now;
            prt_memory_usage(&now, NULL);
            CHECK_MSG(now == before, "%s: allocation %ld of %ld: %zu bytes still held", c->name, k, n, now - before);
        }
        /* The library works afterwards. */
        atomic_store(&g_count, 0);
        CHECK_MSG(run(c, m, pre) == PRT_OK, "%s: a normal run after the failures: %s", c->name, prt_last_error());
        fprintf(
            stderr,
            "  %-24s %5ld allocations, %5ld of them refused one at a time: %ld clean errors, %d runs did without it\n",
            c->name, n, tried, tried - tolerated, tolerated);
        total_k += tried, total_ok += tolerated;
        prt_accel_free(pre);
        prt_mesh_free(m);
    }
    fprintf(stderr, "  %ld failed allocations in all\n", total_k);
    prt_set_allocator(NULL, NULL);
}

int main(void) {
    RUN(test_every_failed_allocation_is_a_clean_error);
    TEST_END();
}
