/* Coherent grid (src/cgrid/): every option against the brute-force reference (closest and
 * any hit) on connected, soup and same-centroid meshes; prt_accel_update against brute force
 * on the moved mesh (generated and a BART frame); frustum packets of every size give
 * exactly the single-ray hits, also for packets whose rays disagree in direction sign,
 * axis-parallel packets with different origins and rays starting inside the grid;
 * degenerate triangles never hit; save/load of an updated grid; the counters behave
 * (mailboxing never adds tests). */
#include "cgrid/cgrid.h"
#include "support/meshes.h"
#include "support/reference.h"
#include "support/repr.h"
#include "test.h"

#include <stdlib.h>
#include <unistd.h>

#define EDGE_EPS 1e-4

static const char *const g_specs[] = {
    "cgrid",
    "cgrid,lambda=1,macro=0",
    "cgrid,lambda=16,macro=2",
    "cgrid,packet=1",
    "cgrid,mailbox=off,cull=off,macro=3",
    "cgrid,packet=2,lambda=3",
    "cgrid,tri=wald",
};

/* Closest and any hits of single rays against the reference on rays away from edges. */
static void expect_matches_reference(const prt_mesh *m, prt_accel *a, const char *what, const prt_ray *rays, size_t n) {
    const double diag = ref_diagonal(m);
    size_t compared = 0, wrong = 0, occ_wrong = 0;
    for (size_t i = 0; i < n; i++) {
        double edge;
        const prt_hit want = ref_intersect(m, &rays[i], &edge);
        if (edge < EDGE_EPS) continue;
        prt_ray r = rays[i];
        prt_hit got;
        prt_intersect1(a, &r, &got);
        compared++;
        bool ok = got.prim == want.prim;
        if (ok && got.prim != PRT_INVALID) ok = fabs((double)got.t - want.t) <= 1e-5 * diag && r.tfar == got.t;
        if (!ok && wrong < 3)
            fprintf(stderr, "    %s ray %zu: got %u t %g, want %u t %g\n", what, i, got.prim, (double)got.t, want.prim,
                    (double)want.t);
        wrong += !ok;
        occ_wrong += prt_occluded1(a, &rays[i]) != (want.prim != PRT_INVALID);
    }
    CHECK_MSG(compared > n / 2 && wrong == 0 && occ_wrong == 0,
              "%s: %zu rays compared, %zu closest and %zu any hits wrong", what, compared, wrong, occ_wrong);
}

/* Packets of the given rays (count a multiple of w*w) give bit-identical hits to prt_intersect1. */
static void expect_packets_match_single(prt_accel *a, const char *what, const prt_ray *rays, size_t n, uint32_t w) {
    size_t wrong = 0, hits = 0;
    for (size_t base = 0; base + (size_t)w * w <= n; base += (size_t)w * w) {
        prt_ray pr[PRT_PACKET_MAX];
        prt_hit ph[PRT_PACKET_MAX];
        memcpy(pr, rays + base, sizeof(prt_ray) * w * w);
        prt_packet p = {pr, ph, w * w, w};
        prt_intersect_packet(a, &p);
        for (uint32_t i = 0; i < w * w; i++) {
            prt_ray r = rays[base + i];
            prt_hit h;
            prt_intersect1(a, &r, &h);
            bool ok =
                h.prim == ph[i].prim &&
                (h.prim == PRT_INVALID || (h.t == ph[i].t && h.u == ph[i].u && h.v == ph[i].v && pr[i].tfar == h.t));
            if (!ok && wrong < 3)
                fprintf(stderr, "    %s: packet ray %zu: packet %u t %.9g, single %u t %.9g\n", what, base + i,
                        ph[i].prim, (double)ph[i].t, h.prim, (double)h.t);
            wrong += !ok;
            hits += h.prim != PRT_INVALID;
        }
    }
    CHECK_MSG(wrong == 0, "%s: %zu of %zu packet rays differ from single rays", what, wrong, n);
    CHECK_MSG(hits > 0, "%s: no ray hit anything (a test that cannot fail)", what);
}

/* Camera rays in w x w pixel blocks: the eye on the bounding sphere along view direction
 * -axis_dir, tiles ordered block by block. rays: res*res entries, res a multiple of w. */
static void camera_rays(const prt_mesh *m, const float view[3], uint32_t res, uint32_t w, prt_ray *rays) {
    float lo[3], hi[3], c[3], ext = 0;
    prt_mesh_bounds(m, lo, hi);
    for (int k = 0; k < 3; k++) c[k] = 0.5f * (lo[k] + hi[k]), ext = fmaxf(ext, hi[k] - lo[k]);
    float d[3] = {view[0], view[1], view[2]};
    float l = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++) d[k] /= l;
    float up[3] = {0, 1, 0};
    if (fabsf(d[1]) > 0.9f) up[0] = 1, up[1] = 0;
    float x[3] = {d[1] * up[2] - d[2] * up[1], d[2] * up[0] - d[0] * up[2], d[0] * up[1] - d[1] * up[0]};
    l = sqrtf(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (int k = 0; k < 3; k++) x[k] /= l;
    float y[3] = {x[1] * d[2] - x[2] * d[1], x[2] * d[0] - x[0] * d[2], x[0] * d[1] - x[1] * d[0]};
    float eye[3];
    for (int k = 0; k < 3; k++) eye[k] = c[k] - 1.5f * ext * d[k];
    size_t i = 0;
    for (uint32_t by = 0; by < res; by += w)
        for (uint32_t bx = 0; bx < res; bx += w)
            for (uint32_t py = by; py < by + w; py++)
                for (uint32_t px = bx; px < bx + w; px++) {
                    float sx = (px + 0.5f) / res * 2 - 1, sy = (py + 0.5f) / res * 2 - 1;
                    prt_ray *r = &rays[i++];
                    for (int k = 0; k < 3; k++) r->org[k] = eye[k], r->dir[k] = d[k] + 0.45f * (sx * x[k] + sy * y[k]);
                    r->tnear = 0, r->tfar = INFINITY;
                }
}

static const float g_views[][3] = {{0, 0, 1},  {0, 0, -1}, {1, 0, 0},         {-1, 0, 0},      {0, 1, 0},
                                   {0, -1, 0}, {1, 1, 1},  {-0.3f, 0.5f, -1}, {0.2f, -1, 0.4f}};

TEST(test_every_option_matches_brute_force) {
    prt_mesh *meshes[] = {mesh_grid(40), mesh_random_soup(2000, 2), mesh_same_centroid(300)};
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++) {
        prt_ray *rays = rays_random(meshes[mi], 1500, 10 + mi);
        for (size_t i = 0; i < COUNT_OF(g_specs); i++) {
            prt_accel *a;
            if (!repr_build(meshes[mi], g_specs[i], &a)) continue;
            char what[96];
            snprintf(what, sizeof what, "%s on mesh %zu", g_specs[i], mi);
            expect_matches_reference(meshes[mi], a, what, rays, 1500);
            prt_accel_free(a);
        }
        free(rays);
        prt_mesh_free(meshes[mi]);
    }
}

TEST(test_canonical_spec_spells_every_option_and_bad_options_fail) {
    prt_mesh *m = mesh_grid(4);
    prt_accel *a = NULL;
    CHECK_OK(prt_build(m, "cgrid", NULL, &a));
    if (a)
        CHECK_MSG(
            !strcmp(prt_accel_spec(a), "cgrid,lambda=6,macro=6,packet=0,mailbox=on,cull=on,tri=watertight,spread=8"),
            "%s", prt_accel_spec(a));
    prt_accel_free(a);
    a = NULL;
    CHECK_OK(prt_build(m, "cgrid,cull=off,spread=0,packet=4,lambda=3", NULL, &a));
    if (a)
        CHECK_MSG(
            !strcmp(prt_accel_spec(a), "cgrid,lambda=3,macro=6,packet=4,mailbox=on,cull=off,tri=watertight,spread=0"),
            "%s", prt_accel_spec(a));
    prt_accel_free(a);
    const char *bad[] = {"cgrid,packet=3",  "cgrid,lambda=0",   "cgrid,macro=99", "cgrid,mailbox=maybe",
                         "cgrid,spread=-1", "cgrid,tri=moller", "cgrid,foo=1",    "cgrid:float3"};
    for (size_t i = 0; i < COUNT_OF(bad); i++) {
        a = NULL;
        CHECK_MSG(prt_build(m, bad[i], NULL, &a) != PRT_OK && !a, "%s was accepted", bad[i]);
        prt_accel_free(a);
    }
    prt_mesh_free(m);
}

/* Camera packets from many directions, every packet size: the same hits as single rays. */
TEST(test_packets_of_every_size_equal_single_rays) {
    prt_mesh *meshes[] = {mesh_grid(40), mesh_random_soup(3000, 5)};
    static prt_ray rays[64 * 64];
    const char *specs[] = {"cgrid",
                           "cgrid,packet=2",
                           "cgrid,packet=4",
                           "cgrid,macro=0,mailbox=off,cull=off",
                           "cgrid,lambda=2,macro=3",
                           "cgrid,tri=wald"};
    const uint32_t widths[] = {2, 4, 8, 16};
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++)
        for (size_t si = 0; si < COUNT_OF(specs); si++) {
            prt_accel *a;
            if (!repr_build(meshes[mi], specs[si], &a)) continue;
            for (size_t v = 0; v < COUNT_OF(g_views); v++)
                for (size_t wi = 0; wi < COUNT_OF(widths); wi++) {
                    camera_rays(meshes[mi], g_views[v], 32, widths[wi], rays);
                    char what[128];
                    snprintf(what, sizeof what, "%s mesh %zu view %zu %ux%u", specs[si], mi, v, widths[wi], widths[wi]);
                    expect_packets_match_single(a, what, rays, 32 * 32, widths[wi]);
                }
            prt_accel_free(a);
        }
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++) prt_mesh_free(meshes[mi]);
}

/* Packets whose rays disagree in sign (half +K, half -K, some zero along K), incoherent
 * random packets, axis-parallel packets with different origins, rays starting inside. */
TEST(test_mixed_sign_axis_parallel_and_inside_packets) {
    prt_mesh *m = mesh_random_soup(3000, 7);
    prt_accel *a;
    if (!repr_build(m, "cgrid", &a)) {
        prt_mesh_free(m);
        return;
    }
    static prt_ray rays[4096];
    uint64_t s = 99;
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
#define RND() ((s = s * 6364136223846793005ull + 1442695040888963407ull), (float)((s >> 40) & 0xffffff) / 16777216.0f)
    /* Mixed signs: rays from a point inside, fanned in both directions along x. */
    for (int i = 0; i < 4096; i++) {
        prt_ray *r = &rays[i];
        int pk = i / 64, j = i % 64;
        for (int k = 0; k < 3; k++)
            r->org[k] = lo[k] + (hi[k] - lo[k]) * (0.3f + 0.4f * (float)((pk * 7 + k * 3) % 11) / 10.0f);
        r->dir[0] = (j % 2 ? 1.0f : -1.0f) * (j % 8 == 0 ? 0.0f : 1.0f);
        r->dir[1] = 0.2f * (RND() - 0.5f) + (j % 8 == 0 ? 1.0f : 0.0f);
        r->dir[2] = 0.2f * (RND() - 0.5f);
        r->tnear = 0, r->tfar = INFINITY;
    }
    expect_packets_match_single(a, "mixed-sign packets", rays, 4096, 8);
    expect_matches_reference(m, a, "mixed-sign rays", rays, 4096);
    /* Axis-parallel packets: one direction, origins on a plane (not a common origin). */
    for (int axis = 0; axis < 3; axis++)
        for (int sg = -1; sg <= 1; sg += 2) {
            for (int i = 0; i < 1024; i++) {
                prt_ray *r = &rays[i];
                int pk = i / 64, j = i % 64;
                for (int k = 0; k < 3; k++) {
                    r->org[k] = lo[k] + (hi[k] - lo[k]) * (0.05f + 0.9f * (float)((pk % 4) * 8 + j % 8) / 32.0f);
                    if (k == (axis + 2) % 3)
                        r->org[k] = lo[k] + (hi[k] - lo[k]) * (0.05f + 0.9f * (float)((pk / 4) * 8 + j / 8) / 32.0f);
                    r->dir[k] = k == axis ? (float)sg : 0.0f;
                }
                r->org[axis] = sg > 0 ? lo[axis] - 0.5f : hi[axis] + 0.5f;
                if (pk % 3 == 0) r->org[axis] = 0.5f * (lo[axis] + hi[axis]); /* starting inside the grid */
                r->tnear = pk % 5 == 0 ? 0.1f : 0.0f, r->tfar = pk % 7 == 0 ? 0.6f : INFINITY;
            }
            char what[64];
            snprintf(what, sizeof what, "axis-parallel %c%c", sg > 0 ? '+' : '-', "xyz"[axis]);
            expect_packets_match_single(a, what, rays, 1024, 8);
            expect_matches_reference(m, a, what, rays, 1024);
        }
    /* Incoherent packets: random rays, 16 x 16. */
    prt_ray *rr = rays_random(m, 2048, 3);
    expect_packets_match_single(a, "random 16x16 packets", rr, 2048, 16);
    free(rr);
#undef RND
    prt_accel_free(a);
    prt_mesh_free(m);
}

/* Twist the mesh about y and wave it: a deformation that moves every vertex differently. */
static void deform(const prt_mesh *m, float time, float *out) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    for (size_t i = 0; i < m->vertex_count; i++) {
        const float *p = m->vertices + 3 * i;
        float h = (p[1] - lo[1]) / (hi[1] - lo[1] + 1e-6f);
        float ang = time * (h + 0.3f * p[0]);
        float c = cosf(ang), s = sinf(ang);
        out[3 * i + 0] = c * p[0] - s * p[2];
        out[3 * i + 1] = p[1] + 0.1f * sinf(3.0f * p[0] + time);
        out[3 * i + 2] = s * p[0] + c * p[2] + 0.5f * time;
    }
}

TEST(test_update_matches_brute_force_on_the_moved_mesh) {
    prt_mesh *m = mesh_grid(40);
    prt_mesh *moved = mesh_transformed(m, 1.0f, 0.0f);
    prt_accel *a;
    if (!repr_build(m, "cgrid", &a)) return;
    for (int f = 1; f <= 3; f++) {
        deform(m, 0.7f * (float)f, moved->vertices);
        CHECK_OK(prt_accel_update(a, moved->vertices));
        prt_ray *rays = rays_random(moved, 1500, 20 + f);
        char what[64];
        snprintf(what, sizeof what, "update to frame %d", f);
        expect_matches_reference(moved, a, what, rays, 1500);
        static prt_ray cam[32 * 32];
        camera_rays(moved, g_views[f], 32, 8, cam);
        expect_packets_match_single(a, what, cam, 32 * 32, 8);
        float lo[3], hi[3], blo[3], bhi[3];
        prt_mesh_bounds(moved, lo, hi);
        prt_accel_bounds(a, blo, bhi);
        CHECK(!memcmp(lo, blo, sizeof lo) && !memcmp(hi, bhi, sizeof hi));
        free(rays);
    }
    /* Save the updated grid, load it, update the loaded one back to the first frame. */
    char path[] = "/tmp/test_cgrid_XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    if (fd >= 0) close(fd);
    CHECK_OK(prt_accel_save(a, path));
    prt_accel *b = NULL;
    CHECK_OK(prt_accel_load(path, &b));
    if (b) {
        prt_ray *rays = rays_random(moved, 1000, 40);
        expect_matches_reference(moved, b, "loaded after update", rays, 1000);
        CHECK_OK(prt_accel_update(b, m->vertices));
        free(rays);
        rays = rays_random(m, 1000, 41);
        expect_matches_reference(m, b, "loaded, updated back", rays, 1000);
        free(rays);
        prt_accel_free(b);
    }
    unlink(path);
    /* Bad vertices leave the accel as it was. */
    moved->vertices[5] = NAN;
    CHECK(prt_accel_update(a, moved->vertices) == PRT_ERROR_MESH);
    moved->vertices[5] = 1e31f;
    CHECK(prt_accel_update(a, moved->vertices) == PRT_ERROR_LIMIT);
    CHECK(prt_accel_update(a, NULL) == PRT_ERROR_ARGUMENT);
    prt_accel_free(a);
    /* Representations without update say so (BVHs update with update=refit: test_refit). */
    CHECK_OK(prt_build(m, "lossygrid", NULL, &a));
    if (a) {
        CHECK(prt_accel_update(a, m->vertices) == PRT_ERROR_UNSUPPORTED);
        CHECK(strstr(prt_last_error(), "cannot be updated") != NULL);
        prt_accel_free(a);
    }
    prt_mesh_free(moved);
    prt_mesh_free(m);
}

TEST(test_degenerate_triangles_never_hit) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_create(6, 4, &m));
    if (!m) return;
    const float v[18] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 2, 0, 3, 3, 0, 0.5f, 0.5f, 0};
    const uint32_t t[12] = {0, 1, 2, 0, 3, 4, /* collinear */ 1, 1, 2, /* repeated */ 5, 5, 5};
    memcpy(m->vertices, v, sizeof v);
    memcpy(m->triangles, t, sizeof t);
    prt_accel *a;
    CHECK_OK(prt_build(m, "cgrid", NULL, &a));
    if (!a) return;
    prt_stats st;
    prt_accel_stats(a, &st);
    CHECK_MSG(st.triangles == 4 && st.triangles_built == 1, "%zu %zu", st.triangles, st.triangles_built);
    /* Rays through the degenerate ones' points: along -z through (2.5, 2.5) and (0.5, 0.5). */
    prt_ray r = {{2.5f, 2.5f, 1}, 0, {0, 0, -1}, INFINITY};
    prt_hit h;
    prt_intersect1(a, &r, &h);
    CHECK(h.prim == PRT_INVALID);
    r = (prt_ray){{0.25f, 0.25f, 1}, 0, {0, 0, -1}, INFINITY};
    prt_intersect1(a, &r, &h);
    CHECK(h.prim == 0 && h.t == 1.0f);
    /* Update so that triangle 0 becomes degenerate and the collinear one a real triangle. */
    float w[18];
    memcpy(w, v, sizeof w);
    w[6] = 2, w[7] = 0; /* vertex 2 onto the line of 0 and 1 */
    w[12] = 0, w[13] = 3;
    CHECK_OK(prt_accel_update(a, w));
    prt_accel_stats(a, &st);
    CHECK_MSG(st.triangles_built == 1, "%zu", st.triangles_built);
    r = (prt_ray){{0.25f, 0.5f, 1}, 0, {0, 0, -1}, INFINITY};
    prt_intersect1(a, &r, &h);
    CHECK_MSG(h.prim == 1, "prim %u", h.prim);
    prt_accel_free(a);
    prt_mesh_free(m);
}

/* Counters: mailboxing and culling never add tests, packets visit fewer cells than rays. */
TEST(test_counters_follow_the_paper) {
    prt_mesh *m = mesh_grid(60);
    static prt_ray cam[256 * 256], tmp[256 * 256];
    camera_rays(m, g_views[6], 256, 8, cam); /* rays denser than cells, as at 1024^2 in the paper */
    const char *specs[] = {"cgrid,macro=0,mailbox=off,cull=off", "cgrid,macro=0,mailbox=on,cull=off", "cgrid,macro=0",
                           "cgrid,macro=0,packet=1"};
    cg_counters c[4];
    for (int i = 0; i < 4; i++) {
        prt_accel *a;
        CHECK_OK(prt_build(m, specs[i], NULL, &a));
        if (!a) return;
        memcpy(tmp, cam, sizeof cam);
        prt__cgrid_counters_reset();
        for (int p = 0; p < 1024; p++) {
            prt_hit hits[64];
            prt_packet pk = {tmp + 64 * p, hits, 64, 8};
            prt_intersect_packet(a, &pk);
        }
        c[i] = prt__cgrid_counters_get();
        prt_accel_free(a);
    }
    CHECK_MSG(c[1].tests <= c[0].tests && c[2].tests <= c[1].tests && c[2].tests > 0, "%llu %llu %llu",
              (unsigned long long)c[0].tests, (unsigned long long)c[1].tests, (unsigned long long)c[2].tests);
    CHECK_MSG(c[1].mailboxed > 0 && c[2].culled > 0, "mailboxed %llu culled %llu", (unsigned long long)c[1].mailboxed,
              (unsigned long long)c[2].culled);
    CHECK_MSG(c[2].cells < c[3].cells && c[3].dda_rays == 256 * 256 && c[2].packets > 0, "cells %llu vs %llu",
              (unsigned long long)c[2].cells, (unsigned long long)c[3].cells);
    prt_mesh_free(m);
}

/* BART robots: build on frame 0, update to frame 10; brute force and packets on frame 10. */
TEST(test_bart_frame_update) {
    const char *p0 = ref_shared_path("bart_robots/robots_000.ply.gz");
    const char *p10 = p0 ? ref_shared_path("bart_robots/robots_010.ply.gz") : NULL;
    if (!p0 || !p10) SKIP("../shared/data is absent");
    char path0[512];
    snprintf(path0, sizeof path0, "%s", p0);
    prt_mesh *m0 = NULL, *m10 = NULL;
    CHECK_OK(prt_mesh_load(path0, &m0));
    CHECK_OK(prt_mesh_load(p10, &m10));
    if (!m0 || !m10) return;
    CHECK(m0->triangle_count == m10->triangle_count && m0->vertex_count == m10->vertex_count);
    prt_accel *a;
    CHECK_OK(prt_build(m0, "cgrid", NULL, &a));
    if (a) {
        CHECK_OK(prt_accel_update(a, m10->vertices));
        prt_ray *rays = rays_random(m10, 400, 77);
        expect_matches_reference(m10, a, "robots frame 10 after update", rays, 400);
        free(rays);
        static prt_ray cam[64 * 64];
        camera_rays(m10, g_views[7], 64, 8, cam);
        expect_packets_match_single(a, "robots 8x8", cam, 64 * 64, 8);
        camera_rays(m10, g_views[0], 64, 16, cam);
        expect_packets_match_single(a, "robots 16x16", cam, 64 * 64, 16);
        prt_accel_free(a);
    }
    prt_mesh_free(m0);
    prt_mesh_free(m10);
}

/* Damage behind the checksums (verify_crc off): every damaged file is an error or a grid
 * that answers rays without a crash (the sanitizer build checks the memory). */
TEST(test_damaged_files_are_errors_never_crashes) {
    prt_mesh *m = mesh_random_soup(300, 9);
    prt_accel *a;
    CHECK_OK(prt_build(m, "cgrid,lambda=2", NULL, &a));
    if (!a) return;
    char path[] = "/tmp/test_cgrid_dmg_XXXXXX";
    int fd = mkstemp(path);
    if (fd >= 0) close(fd);
    CHECK_OK(prt_accel_save(a, path));
    prt_accel_free(a);
    FILE *f = fopen(path, "rb");
    CHECK(f != NULL);
    if (!f) return;
    fseek(f, 0, SEEK_END);
    size_t size = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *orig = malloc(size), *buf = aligned_alloc(64, (size + 63) / 64 * 64);
    CHECK(fread(orig, 1, size, f) == size);
    fclose(f);
    unlink(path);
    prt_ray *rays = rays_random(m, 64, 5);
    uint64_t s = 12345;
    size_t opened = 0, refused = 0;
    for (int it = 0; it < 400; it++) {
        memcpy(buf, orig, size);
        int flips = 1 + it % 4;
        for (int k = 0; k < flips; k++) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            size_t at = 256 + (size_t)(s >> 33) % (size - 256);
            buf[at] ^= (uint8_t)(1u << ((s >> 20) & 7));
            if (it % 7 == 0) buf[at] = 0xff;
        }
        prt_accel *b = NULL;
        if (prt__accel_open(buf, size, false, &b) != PRT_OK) {
            refused++;
            continue;
        }
        opened++;
        for (int i = 0; i < 64; i++) {
            prt_ray r = rays[i];
            prt_hit h;
            prt_intersect1(b, &r, &h);
            (void)prt_occluded1(b, &rays[i]);
        }
        prt_ray pr[64];
        prt_hit ph[64];
        memcpy(pr, rays, sizeof pr);
        prt_packet p = {pr, ph, 64, 8};
        prt_intersect_packet(b, &p);
        prt_accel_free(b);
    }
    CHECK_MSG(refused > 0 && opened > 0, "opened %zu refused %zu", opened, refused);
    free(rays);
    free(orig);
    free(buf);
    prt_mesh_free(m);
}

/* Above CG_BUILD_GRAIN triangles a thread the build runs on several threads, each owning a
 * slab of z slices of cells (build.c): the grid must be the one a single thread builds, byte
 * for byte in its file, with the same macrocell flags, and answer the same. */
static size_t file_bytes(const char *path, uint8_t **out) {
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    fseek(f, 0, SEEK_END);
    size_t n = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    *out = malloc(n);
    if (!*out || fread(*out, 1, n, f) != n) n = 0;
    fclose(f);
    return n;
}

/* Saved sections after the header (whose build time differs). */
static size_t saved_body(prt_accel *a, uint8_t **out) {
    char path[] = "/tmp/test_cgrid_par_XXXXXX";
    int fd = mkstemp(path);
    if (fd >= 0) close(fd);
    CHECK_OK(prt_accel_save(a, path));
    size_t n = file_bytes(path, out);
    unlink(path);
    return n;
}

/* The macrocell flags the build set in its prefix-sum pass equal the definition (§2.4): a
 * block is occupied when any cell below holds a reference, read from the cell starts. */
static size_t macro_flags_wrong(const prt_accel *a) {
    const cg_grid *g = &((const cg_accel *)a)->g;
    size_t wrong = 0;
    if (!g->macro) return 0;
    for (uint32_t mz = 0; mz < g->mres[2]; mz++)
        for (uint32_t my = 0; my < g->mres[1]; my++)
            for (uint32_t mx = 0; mx < g->mres[0]; mx++) {
                bool occ = false;
                for (uint32_t z = mz * g->macro; z < (mz + 1) * g->macro && z < g->res[2]; z++)
                    for (uint32_t y = my * g->macro; y < (my + 1) * g->macro && y < g->res[1]; y++)
                        for (uint32_t x = mx * g->macro; x < (mx + 1) * g->macro && x < g->res[0]; x++) {
                            size_t c = ((size_t)z * g->res[1] + y) * g->res[0] + x;
                            occ |= g->cell_start[c + 1] != g->cell_start[c];
                        }
                wrong += g->mflags[((size_t)mz * g->mres[1] + my) * g->mres[0] + mx] != occ;
            }
    return wrong;
}

static void expect_thread_counts_agree(const prt_mesh *m, const float *moved, const char *spec, const char *what) {
    static const int counts[] = {1, 2, 3, 7};
    prt_accel *a[4] = {NULL};
    uint8_t *body[4] = {NULL};
    size_t len[4] = {0};
    for (int k = 0; k < 4; k++) {
        prt_build_options o = {.threads = counts[k]};
        CHECK_OK(prt_build(m, spec, &o, &a[k]));
        if (!a[k]) continue;
        CHECK_MSG(macro_flags_wrong(a[k]) == 0, "%s, %d threads, built: macrocell flags wrong", what, counts[k]);
        CHECK_OK(prt_accel_update(a[k], moved));
        CHECK_MSG(macro_flags_wrong(a[k]) == 0, "%s, %d threads, updated: macrocell flags wrong", what, counts[k]);
        len[k] = saved_body(a[k], &body[k]);
    }
    for (int k = 1; k < 4; k++)
        CHECK_MSG(len[k] == len[0] && len[0] > 256 && body[k] && body[0] &&
                      !memcmp(body[0] + 256, body[k] + 256, len[0] - 256),
                  "%s: the file of %d threads (%zu bytes) differs from one thread's (%zu bytes)", what, counts[k],
                  len[k], len[0]);
    for (int k = 0; k < 4; k++) prt_accel_free(a[k]), free(body[k]);
}

TEST(test_parallel_build_equals_single_thread_build) {
    /* A deformed grid (refs spread over many z slices), the same grid flat (every
     * reference in one z slice: one thread's slab holds all), and a soup with degenerate
     * triangles, each over several build threads. */
    prt_mesh *m = mesh_grid(250);                  /* 125k triangles */
    CHECK(m->triangle_count > 3 * CG_BUILD_GRAIN); /* so up to 4 threads build it */
    prt_mesh *moved = mesh_transformed(m, 1.0f, 0.0f);
    deform(m, 0.9f, moved->vertices);
    expect_thread_counts_agree(m, moved->vertices, "cgrid", "deformed grid");
    expect_thread_counts_agree(m, moved->vertices, "cgrid,lambda=2,macro=5", "deformed grid, lambda 2, macro 5");
    expect_thread_counts_agree(moved, m->vertices, "cgrid,macro=0", "flat grid, no macrocells");
    prt_mesh *soup = mesh_random_soup(3 * CG_BUILD_GRAIN, 21);
    for (size_t t = 0; t < soup->triangle_count; t += 97) /* collapse some: never inserted */
        memcpy(soup->vertices + 3 * soup->triangles[3 * t + 1], soup->vertices + 3 * soup->triangles[3 * t], 12);
    prt_mesh *soup2 = mesh_transformed(soup, 0.8f, 0.1f);
    expect_thread_counts_agree(soup, soup2->vertices, "cgrid,macro=3", "soup with degenerate triangles");

    /* The answers agree too. */
    prt_build_options one = {.threads = 1}, two = {.threads = 2};
    prt_accel *a = NULL, *b = NULL;
    CHECK_OK(prt_build(m, "cgrid", &one, &a));
    CHECK_OK(prt_build(m, "cgrid", &two, &b));
    if (a && b) {
        CHECK_OK(prt_accel_update(a, moved->vertices));
        CHECK_OK(prt_accel_update(b, moved->vertices));
        prt_ray *rays = rays_random(moved, 2000, 8);
        size_t wrong = 0;
        for (size_t i = 0; i < 2000; i++) {
            prt_ray r1 = rays[i], r2 = rays[i];
            prt_hit h1, h2;
            prt_intersect1(a, &r1, &h1);
            prt_intersect1(b, &r2, &h2);
            wrong += h1.prim != h2.prim || h1.t != h2.t;
        }
        CHECK_MSG(wrong == 0, "%zu rays differ", wrong);
        free(rays);
    }
    prt_accel_free(a);
    prt_accel_free(b);
    prt_mesh_free(soup2);
    prt_mesh_free(soup);
    prt_mesh_free(moved);
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_every_option_matches_brute_force);
    RUN(test_canonical_spec_spells_every_option_and_bad_options_fail);
    RUN(test_packets_of_every_size_equal_single_rays);
    RUN(test_mixed_sign_axis_parallel_and_inside_packets);
    RUN(test_update_matches_brute_force_on_the_moved_mesh);
    RUN(test_degenerate_triangles_never_hit);
    RUN(test_counters_follow_the_paper);
    RUN(test_bart_frame_update);
    RUN(test_damaged_files_are_errors_never_crashes);
    RUN(test_parallel_build_equals_single_thread_build);
    TEST_END();
}
