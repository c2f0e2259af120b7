/* The benchmark's ray workloads are what every comparison stands on: deterministic, of the
 * documented shape (random rays start on the sphere of radius R around the centre and aim
 * inside R/4; primary tiles cover each pixel once; shadow rays end at the light). */
#include "bench.h"
#include "support/meshes.h"
#include "test.h"

TEST(test_random_rays_are_deterministic_and_prefix_stable) {
    float lo[3] = {-1, -2, -3}, hi[3] = {1, 2, 3};
    bench_rays a, b, c;
    CHECK_OK(bench_rays_random(lo, hi, 4096, 5, &a));
    CHECK_OK(bench_rays_random(lo, hi, 4096, 5, &b));
    CHECK_OK(bench_rays_random(lo, hi, 1024, 5, &c));
    CHECK(memcmp(a.rays, b.rays, 4096 * sizeof(prt_ray)) == 0);
    CHECK(memcmp(a.rays, c.rays, 1024 * sizeof(prt_ray)) == 0);
    /* Enlarged by 10% per side: half diagonal of (2.4, 4.8, 7.2). */
    double R = 0.5 * sqrt(2.4 * 2.4 + 4.8 * 4.8 + 7.2 * 7.2);
    size_t bad = 0;
    for (size_t i = 0; i < a.count; i++) {
        const prt_ray *r = &a.rays[i];
        double o = sqrt((double)r->org[0] * r->org[0] + (double)r->org[1] * r->org[1] + (double)r->org[2] * r->org[2]);
        /* Closest approach of the ray line to the centre must be within R/4. */
        double dl = sqrt((double)r->dir[0] * r->dir[0] + (double)r->dir[1] * r->dir[1] + (double)r->dir[2] * r->dir[2]);
        double along =
            -((double)r->org[0] * r->dir[0] + (double)r->org[1] * r->dir[1] + (double)r->org[2] * r->dir[2]) / dl;
        double miss = sqrt(fmax(0, o * o - along * along));
        bad +=
            fabs(o - R) > 1e-4 * R || miss > R / 4 * 1.0001 || fabs(dl - 1) > 1e-5 || r->tnear != 0 || !isinf(r->tfar);
    }
    CHECK_MSG(bad == 0, "%zu of %zu random rays off the documented shape", bad, a.count);
    bench_rays_free(&a), bench_rays_free(&b), bench_rays_free(&c);
}

TEST(test_primary_tiles_cover_every_pixel_once) {
    float lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    bench_camera cam;
    bench_camera_default(lo, hi, &cam);
    bench_rays r;
    CHECK_OK(bench_rays_primary(&cam, 37, 21, 8, &r)); /* partial tiles at both edges */
    CHECK(r.count == 37 * 21);
    unsigned char *seen = calloc(r.count, 1);
    size_t covered = 0;
    for (size_t t = 0; t < bench_rays_tile_count(&r); t++) {
        size_t first;
        uint32_t count, width;
        bench_rays_tile(&r, t, &first, &count, &width);
        for (size_t i = first; i < first + count; i++) covered += !seen[i]++;
    }
    CHECK(covered == r.count);
    for (uint32_t y = 0; y < 21; y++)
        for (uint32_t x = 0; x < 37; x++) CHECK(bench_rays_pixel_index(&r, x, y) < r.count);
    free(seen);
    bench_rays_free(&r);
}

TEST(test_shadow_rays_end_at_the_light) {
    prt_mesh *m = mesh_random_soup(2000, 4);
    float lo[3], hi[3], light[3];
    prt_mesh_bounds(m, lo, hi);
    bench_camera cam;
    bench_camera_default(lo, hi, &cam);
    bench_light_default(lo, hi, light);
    bench_rays primary, shadow;
    CHECK_OK(bench_rays_primary(&cam, 64, 64, 8, &primary));
    bench_accel a;
    CHECK_OK(bench_build(m, "quad:float3-soa4", 0, &a));
    prt_hit *hits;
    CHECK_OK(bench_trace_hits(&a, &primary, &hits));
    size_t nhit = 0;
    for (size_t i = 0; i < primary.count; i++) nhit += hits[i].prim != PRT_INVALID;
    CHECK_OK(bench_rays_shadow(m, &primary, hits, light, 1e-4f, &shadow));
    CHECK(shadow.count == nhit && nhit > 0 && shadow.any_hit);
    size_t bad = 0;
    for (size_t i = 0; i < shadow.count; i++) {
        const prt_ray *r = &shadow.rays[i];
        double end[3];
        for (int k = 0; k < 3; k++) end[k] = r->org[k] + (double)r->dir[k] * r->tfar;
        double d = sqrt((end[0] - light[0]) * (end[0] - light[0]) + (end[1] - light[1]) * (end[1] - light[1]) +
                        (end[2] - light[2]) * (end[2] - light[2]));
        bad += d > 1e-3;
    }
    CHECK_MSG(bad == 0, "%zu shadow rays do not end at the light", bad);
    free(hits);
    bench_rays_free(&primary), bench_rays_free(&shadow);
    bench_accel_free(&a);
    prt_mesh_free(m);
}

/* The benchmark's check of a lossy representation: answers within the stated vertex error
 * pass, answers beyond it count, for closest hits and for occlusion (a flat square in
 * y = 0, rays straight down inside one of its triangles, far from its edges; err 0.01). */
TEST(test_lossy_check_counts_only_answers_beyond_the_bound) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_create(4, 2, &m));
    if (!m) return;
    const float v[12] = {-1, 0, -1, 1, 0, -1, 1, 0, 1, -1, 0, 1};
    const uint32_t t[6] = {0, 2, 1, 0, 3, 2};
    memcpy(m->vertices, v, sizeof v), memcpy(m->triangles, t, sizeof t);
    enum { N = 4 };
    prt_ray rays[N];
    prt_hit ref[N], got[N];
    for (int i = 0; i < N; i++) {
        rays[i] = (prt_ray){{0.35f + 0.1f * (float)i, 1.0f, -0.3f}, 0.0f, {0.0f, -1.0f, 0.0f}, INFINITY};
        ref[i] = (prt_hit){1.0f, 0.3f, 0.3f, 0, 0};
        got[i] = ref[i];
    }
    got[1].t = 1.005f;                              /* half the error away: within */
    got[2].t = 1.1f;                                /* ten times the error: beyond */
    got[3].prim = PRT_INVALID, got[3].t = INFINITY; /* a miss in the middle of a face: beyond */
    const bench_lossy lossy = {m, rays, 0.01, 1e-6};
    bench_check c;
    bench_check_hits(got, ref, N, 2.8, &lossy, &c);
    CHECK_MSG(c.lossy && c.beyond_bound == 2, "%zu rays beyond the bound, want 2", c.beyond_bound);
    CHECK(bench_check_bad(&c));
    bench_check_hits(got, ref, 2, 2.8, &lossy, &c);
    CHECK(c.beyond_bound == 0 && !bench_check_bad(&c));
    /* Occlusion: segments ending 0.005 above the square (within) or 0.5 above (beyond) may
     * not be blocked; one crossing the middle of a face may not be open. */
    prt_ray sr[3] = {{{0.5f, 1, -0.3f}, 0, {0, -1, 0}, 0.995f},
                     {{0.5f, 1, -0.3f}, 0, {0, -1, 0}, 0.5f},
                     {{0.5f, 1, -0.3f}, 0, {0, -1, 0}, 2.0f}};
    const uint8_t occ[3] = {1, 1, 0}, exact[3] = {0, 0, 1};
    const bench_lossy sl = {m, sr, 0.01, 1e-6};
    bench_check_occluded(occ, exact, 3, &sl, &c);
    CHECK_MSG(c.hit_miss == 3 && c.beyond_bound == 2, "%zu disagreements, %zu beyond the bound, want 3 and 2",
              c.hit_miss, c.beyond_bound);
    bench_check_occluded(occ, exact, 1, &sl, &c);
    CHECK(c.hit_miss == 1 && c.beyond_bound == 0 && !bench_check_bad(&c));
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_random_rays_are_deterministic_and_prefix_stable);
    RUN(test_primary_tiles_cover_every_pixel_once);
    RUN(test_shadow_rays_end_at_the_light);
    RUN(test_lossy_check_counts_only_answers_beyond_the_bound);
    TEST_END();
}
