/* Shadow packets (prt_occluded_packet; cgrid's src/cgrid/shadow.c, Wald 2006 §4.6): for
 * every ray the packet's answer is prt_occluded1's, on a floor under floating triangles,
 * a triangle soup and the BART robots and kitchen (when ../shared/data is present); with
 * shadow rays cast from the hit points and from the light, lights outside and inside the
 * grid, packets whose hit points spread (pixels on the background, invalid rays), every
 * packet size and option; splitting spread packets visits fewer cells; representations
 * without packet traversal answer through the generic fallback. */
#include "cgrid/cgrid.h"
#include "support/meshes.h"
#include "support/reference.h"
#include "support/repr.h"
#include "test.h"

#include <stdlib.h>

/* A wavy floor (the grid mesh) with a soup of small triangles floating above it. */
static prt_mesh *floor_and_soup(void) {
    prt_mesh *f = mesh_grid(30), *s = mesh_random_soup(800, 21), *m = NULL;
    if (f && s && !prt_mesh_create(f->vertex_count + s->vertex_count, f->triangle_count + s->triangle_count, &m)) {
        memcpy(m->vertices, f->vertices, 12 * f->vertex_count);
        for (size_t i = 0; i < s->vertex_count; i++) {
            const float *p = s->vertices + 3 * i;
            float *q = m->vertices + 3 * (f->vertex_count + i);
            q[0] = 0.15f + 0.7f * p[0], q[1] = 0.2f + 0.3f * p[1], q[2] = 0.15f + 0.7f * p[2];
        }
        memcpy(m->triangles, f->triangles, 12 * f->triangle_count);
        for (size_t i = 0; i < 3 * s->triangle_count; i++)
            m->triangles[3 * f->triangle_count + i] = s->triangles[i] + (uint32_t)f->vertex_count;
    }
    prt_mesh_free(f);
    prt_mesh_free(s);
    return m;
}

/* Camera rays in w x w pixel blocks (res a multiple of w) from eye toward target. */
static void camera_rays(const float eye[3], const float target[3], uint32_t res, uint32_t w, float fov, prt_ray *rays) {
    float d[3], up[3] = {0, 1, 0}, x[3], y[3];
    float l = 0;
    for (int k = 0; k < 3; k++) d[k] = target[k] - eye[k], l += d[k] * d[k];
    l = sqrtf(l);
    for (int k = 0; k < 3; k++) d[k] /= l;
    if (fabsf(d[1]) > 0.9f) up[0] = 1, up[1] = 0;
    x[0] = d[1] * up[2] - d[2] * up[1], x[1] = d[2] * up[0] - d[0] * up[2], x[2] = d[0] * up[1] - d[1] * up[0];
    l = sqrtf(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (int k = 0; k < 3; k++) x[k] /= l;
    y[0] = x[1] * d[2] - x[2] * d[1], y[1] = x[2] * d[0] - x[0] * d[2], y[2] = x[0] * d[1] - x[1] * d[0];
    size_t i = 0;
    for (uint32_t by = 0; by < res; by += w)
        for (uint32_t bx = 0; bx < res; bx += w)
            for (uint32_t py = by; py < by + w; py++)
                for (uint32_t px = bx; px < bx + w; px++) {
                    float sx = (px + 0.5f) / res * 2 - 1, sy = (py + 0.5f) / res * 2 - 1;
                    prt_ray *r = &rays[i++];
                    for (int k = 0; k < 3; k++) r->org[k] = eye[k], r->dir[k] = d[k] + fov * (sx * x[k] + sy * y[k]);
                    r->tnear = 0, r->tfar = INFINITY;
                }
}

/* Shadow rays for the camera rays' closest hits toward the light: from each hit point
 * (from_light false) or from the light to it (true), stopping 1e-3 short of either end.
 * Missed pixels take a point far behind the scene (the background: hit points of a packet
 * spread); every 97th ray is invalid (NaN), which must answer 0. */
static void shadow_rays(const prt_accel *a, prt_ray *cam, size_t n, uint32_t w, const float light[3], bool from_light,
                        prt_ray *out) {
    static prt_hit hits[PRT_PACKET_MAX];
    for (size_t base = 0; base < n; base += (size_t)w * w) {
        prt_packet p = {cam + base, hits, w * w, w};
        prt_intersect_packet(a, &p);
        for (uint32_t i = 0; i < w * w; i++) {
            const prt_ray *c = &cam[base + i];
            float t = hits[i].prim != PRT_INVALID ? hits[i].t : 3.0f;
            float hp[3];
            for (int k = 0; k < 3; k++) hp[k] = c->org[k] + c->dir[k] * t;
            prt_ray *r = &out[base + i];
            for (int k = 0; k < 3; k++) {
                r->org[k] = from_light ? light[k] : hp[k];
                r->dir[k] = from_light ? hp[k] - light[k] : light[k] - hp[k];
            }
            r->tnear = 1e-3f, r->tfar = 1.0f - 1e-3f;
            if ((base + i) % 97 == 5) r->org[1] = NAN;
        }
    }
}

typedef struct tally {
    size_t rays, occluded, wrong;
} tally;

/* prt_occluded_packet over w x w packets of rays against prt_occluded1 for each ray. */
static void compare(const prt_accel *a, const prt_ray *rays, size_t n, uint32_t w, tally *t, const char *what) {
    for (size_t base = 0; base + (size_t)w * w <= n; base += (size_t)w * w) {
        uint8_t occ[PRT_PACKET_MAX];
        memset(occ, 7, sizeof occ);
        prt_packet p = {(prt_ray *)rays + base, NULL, w * w, w};
        prt_occluded_packet(a, &p, occ);
        for (uint32_t i = 0; i < w * w; i++) {
            const bool want = prt_occluded1(a, &rays[base + i]);
            if (occ[i] != (uint8_t)want && t->wrong < 3)
                fprintf(stderr, "    %s: ray %zu: packet %u, single %d\n", what, base + i, occ[i], want);
            t->wrong += occ[i] != (uint8_t)want;
            t->occluded += want;
            t->rays++;
        }
    }
}

static void expect_tally(const tally *t, const char *what) {
    CHECK_MSG(t->wrong == 0, "%s: %zu of %zu rays differ from prt_occluded1", what, t->wrong, t->rays);
    /* A test that cannot fail would see only lit or only shadowed rays. */
    CHECK_MSG(t->occluded > t->rays / 50 && t->occluded < t->rays - t->rays / 50, "%s: %zu of %zu occluded", what,
              t->occluded, t->rays);
}

TEST(test_shadow_packets_equal_single_rays_on_generated_scenes) {
    prt_mesh *meshes[] = {floor_and_soup(), mesh_random_soup(3000, 5)};
    const char *specs[] = {"cgrid",
                           "cgrid,spread=0",
                           "cgrid,spread=1",
                           "cgrid,packet=4",
                           "cgrid,packet=2",
                           "cgrid,lambda=2",
                           "cgrid,mailbox=off,cull=off,macro=0",
                           "cgrid,tri=wald"};
    /* Lights above, low and to the side, below, and inside the grid. */
    const float lights[][3] = {{0.3f, 3.0f, 0.4f}, {-2.0f, 0.6f, 0.5f}, {0.5f, -2.5f, 1.5f}, {0.5f, 0.35f, 0.5f}};
    const float eyes[][3] = {{0.5f, 1.6f, -1.4f}, {1.9f, 0.9f, 1.6f}};
    const float target[3] = {0.5f, 0.2f, 0.5f};
    static prt_ray cam[48 * 48], sh[48 * 48];
    const uint32_t widths[] = {4, 8, 16};
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++) {
        if (!meshes[mi]) {
            CHECK(meshes[mi]);
            continue;
        }
        for (size_t si = 0; si < COUNT_OF(specs); si++) {
            prt_accel *a;
            if (!repr_build(meshes[mi], specs[si], &a)) continue;
            tally t = {0, 0, 0};
            for (size_t e = 0; e < COUNT_OF(eyes); e++)
                for (size_t wi = 0; wi < COUNT_OF(widths); wi++)
                    for (size_t li = 0; li < COUNT_OF(lights); li++)
                        for (int from_light = 0; from_light < 2; from_light++) {
                            camera_rays(eyes[e], target, 48, widths[wi], 0.8f, cam);
                            shadow_rays(a, cam, 48 * 48, widths[wi], lights[li], from_light, sh);
                            compare(a, sh, 48 * 48, widths[wi], &t, specs[si]);
                        }
            char what[128];
            snprintf(what, sizeof what, "%s on mesh %zu", specs[si], mi);
            expect_tally(&t, what);
            prt_accel_free(a);
        }
        prt_mesh_free(meshes[mi]);
    }
}

/* Packets whose rays point every way (a light in the middle of the soup, hit points all
 * around it), random rays, and rays parallel to an axis. */
TEST(test_incoherent_and_axis_parallel_shadow_packets) {
    prt_mesh *m = mesh_random_soup(3000, 7);
    prt_accel *a;
    if (!repr_build(m, "cgrid", &a)) {
        prt_mesh_free(m);
        return;
    }
    prt_ray *rr = rays_random(m, 4096, 11);
    tally t = {0, 0, 0};
    for (size_t i = 0; i < 4096; i++) rr[i].tfar = 0.5f + (float)(i % 7) * 0.2f;
    compare(a, rr, 4096, 16, &t, "random rays");
    /* From points all around the light at the centre (every sign along every axis). */
    uint64_t s = 5;
    for (size_t i = 0; i < 4096; i++) {
        prt_ray *r = &rr[i];
        float d[3];
        for (int k = 0; k < 3; k++) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            d[k] = (float)((s >> 40) & 0xffffff) / 16777216.0f - 0.5f;
            r->org[k] = 0.5f + d[k];
            r->dir[k] = -d[k];
        }
        if (i % 11 == 0) r->dir[0] = 0, r->dir[1] = 0; /* parallel to z */
        r->tnear = 1e-3f, r->tfar = 1.0f;
    }
    compare(a, rr, 4096, 8, &t, "rays toward a light inside");
    expect_tally(&t, "incoherent packets");
    free(rr);
    prt_accel_free(a);
    prt_mesh_free(m);
}

/* A packet of two clusters of hit points far apart, both toward one light: split (the
 * default) it visits fewer cells than as one frustum (spread=0), with the same answers. */
TEST(test_splitting_spread_packets_visits_fewer_cells) {
    prt_mesh *m = floor_and_soup();
    prt_accel *split, *whole;
    if (!m || !repr_build(m, "cgrid", &split)) {
        prt_mesh_free(m);
        return;
    }
    if (!repr_build(m, "cgrid,spread=0", &whole)) {
        prt_accel_free(split);
        prt_mesh_free(m);
        return;
    }
    prt_ray rays[64];
    const float light[3] = {0.5f, 2.0f, 0.5f};
    for (int i = 0; i < 64; i++) {
        const float x = (i % 8) * 0.005f + (i < 32 ? 0.05f : 0.9f), z = (i / 8 % 4) * 0.005f + 0.1f;
        const float p[3] = {x, 0.06f, z};
        for (int k = 0; k < 3; k++) rays[i].org[k] = p[k], rays[i].dir[k] = light[k] - p[k];
        rays[i].tnear = 1e-3f, rays[i].tfar = 1.0f;
    }
    uint8_t o1[64], o2[64];
    prt_packet p = {rays, NULL, 64, 8};
    prt__cgrid_counters_reset();
    prt_occluded_packet(split, &p, o1);
    const cg_counters cs = prt__cgrid_counters_get();
    prt__cgrid_counters_reset();
    prt_occluded_packet(whole, &p, o2);
    const cg_counters cw = prt__cgrid_counters_get();
    CHECK(!memcmp(o1, o2, sizeof o1));
    for (int i = 0; i < 64; i++) CHECK(o1[i] == prt_occluded1(split, &rays[i]));
    CHECK_MSG(cs.packets >= 2 && cw.packets == 1 && cs.cells < cw.cells,
              "split: %llu packets %llu cells; whole: %llu, %llu", (unsigned long long)cs.packets,
              (unsigned long long)cs.cells, (unsigned long long)cw.packets, (unsigned long long)cw.cells);
    prt_accel_free(split);
    prt_accel_free(whole);
    prt_mesh_free(m);
}

/* Representations without packet traversal answer through prt_occluded1; packets longer
 * than PRT_PACKET_MAX are answered whole. */
TEST(test_generic_fallback_and_long_packets) {
    prt_mesh *m = floor_and_soup();
    const char *specs[] = {"aabb:float3", "cgrid"};
    static prt_ray cam[32 * 32], sh[32 * 32];
    const float eye[3] = {0.5f, 1.6f, -1.4f}, target[3] = {0.5f, 0.2f, 0.5f}, light[3] = {0.3f, 3.0f, 0.4f};
    for (size_t si = 0; m && si < COUNT_OF(specs); si++) {
        prt_accel *a;
        if (!repr_build(m, specs[si], &a)) continue;
        camera_rays(eye, target, 32, 8, 0.8f, cam);
        shadow_rays(a, cam, 32 * 32, 8, light, false, sh);
        tally t = {0, 0, 0};
        compare(a, sh, 32 * 32, 8, &t, specs[si]);
        expect_tally(&t, specs[si]);
        static uint8_t occ[32 * 32];
        prt_packet p = {sh, NULL, 300, 20}; /* 300 > PRT_PACKET_MAX */
        prt_occluded_packet(a, &p, occ);
        size_t wrong = 0;
        for (size_t i = 0; i < 300; i++) wrong += occ[i] != (uint8_t)prt_occluded1(a, &sh[i]);
        CHECK_MSG(wrong == 0, "%s: %zu of 300 rays of a long packet wrong", specs[si], wrong);
        prt_accel_free(a);
    }
    prt_mesh_free(m);
}

/* BART robots and kitchen frame 0: views from outside and lights above, beside and inside. */
TEST(test_bart_shadow_packets) {
    const char *names[] = {"bart_robots/robots_000.ply.gz", "bart_kitchen/kitchen_000.ply.gz"};
    static prt_ray cam[64 * 64], sh[64 * 64];
    int done = 0;
    for (size_t ni = 0; ni < COUNT_OF(names); ni++) {
        const char *path = ref_shared_path(names[ni]);
        if (!path) continue;
        prt_mesh *m = NULL;
        CHECK_OK(prt_mesh_load(path, &m));
        prt_accel *a;
        if (!m || !repr_build(m, "cgrid", &a)) {
            prt_mesh_free(m);
            continue;
        }
        float lo[3], hi[3], c[3], ext[3];
        prt_mesh_bounds(m, lo, hi);
        for (int k = 0; k < 3; k++) c[k] = 0.5f * (lo[k] + hi[k]), ext[k] = hi[k] - lo[k];
        const float eye[3] = {c[0] + 0.9f * ext[0], c[1] + 0.6f * ext[1], c[2] + 1.1f * ext[2]};
        const float lights[][3] = {{c[0] + 0.2f * ext[0], hi[1] + ext[1], c[2]},
                                   {lo[0] - 0.5f * ext[0], c[1] + 0.1f * ext[1], c[2] + 0.3f * ext[2]},
                                   {c[0] + 0.1f * ext[0], c[1] + 0.2f * ext[1], c[2] - 0.1f * ext[2]}};
        tally t = {0, 0, 0};
        for (size_t li = 0; li < COUNT_OF(lights); li++)
            for (int from_light = 0; from_light < 2; from_light++) {
                camera_rays(eye, c, 64, 8, 0.5f, cam);
                shadow_rays(a, cam, 64 * 64, 8, lights[li], from_light, sh);
                compare(a, sh, 64 * 64, 8, &t, names[ni]);
            }
        expect_tally(&t, names[ni]);
        done++;
        prt_accel_free(a);
        prt_mesh_free(m);
    }
    if (!done) SKIP("../shared/data is absent");
}

int main(void) {
    RUN(test_shadow_packets_equal_single_rays_on_generated_scenes);
    RUN(test_incoherent_and_axis_parallel_shadow_packets);
    RUN(test_splitting_spread_packets_visits_fewer_cells);
    RUN(test_generic_fallback_and_long_packets);
    RUN(test_bart_shadow_packets);
    TEST_END();
}
