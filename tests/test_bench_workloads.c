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
        double along = -((double)r->org[0] * r->dir[0] + (double)r->org[1] * r->dir[1] + (double)r->org[2] * r->dir[2]) / dl;
        double miss = sqrt(fmax(0, o * o - along * along));
        bad += fabs(o - R) > 1e-4 * R || miss > R / 4 * 1.0001 || fabs(dl - 1) > 1e-5 || r->tnear != 0 || !isinf(r->tfar);
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

int main(void) {
    RUN(test_random_rays_are_deterministic_and_prefix_stable);
    RUN(test_primary_tiles_cover_every_pixel_once);
    RUN(test_shadow_rays_end_at_the_light);
    TEST_END();
}
