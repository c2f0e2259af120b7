/* The wide8 packet walks (bvh/layouts/wide8_packet.inc): prt_intersect_packet,
 * prt_occluded_packet and prt_occluded_stream answer every ray bit for bit as prt_intersect1 and prt_occluded1 do
 * (t, triangle, u, v, the shrunk tfar), for every codec on wide8 and every instruction set
 * this host runs: coherent camera tiles of 1 to 256 rays, packets of mixed octants, invalid
 * rays, tnear / tfar windows, axis-parallel rays, and rays through the shared edges and
 * vertices of a grid cube and rays starting on them (a hit at t = +0 or -0), on a mesh near the origin and one far from
 * it; tiles across the diagonal (rays of two dominant axes in one vector) and shadow rays of a tile, which the leaf
 * test over rays takes; bounces off a tile's hits in all directions (packets of close origins, rays walking on
 * alone where they part); prt_intersect_stream too. */
#include "bvh/bvh.h"
#include "core/isa.h"
#include "core/rng.h"
#include "support/meshes.h"
#include "support/repr.h"
#include "test.h"

#define MAX_RAYS 1024

/* A set of rays traced in packets of `size`. */
typedef struct ray_set {
    const char *name;
    prt_ray rays[MAX_RAYS];
    uint32_t n, size;
} ray_set;

/* The centre of m's bounding box and its width along x. */
static void mesh_frame(const prt_mesh *m, float c[3], float *size) {
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < m->vertex_count; i++)
        for (int k = 0; k < 3; k++)
            lo[k] = fminf(lo[k], m->vertices[3 * i + k]), hi[k] = fmaxf(hi[k], m->vertices[3 * i + k]);
    for (int k = 0; k < 3; k++) c[k] = (lo[k] + hi[k]) / 2;
    *size = hi[0] - lo[0];
}

/* A pinhole camera's tile of w x h rays looking at the mesh's centre from outside it. */
static void camera_tile(const prt_mesh *m, ray_set *s, uint32_t w, uint32_t h, const char *name) {
    float c[3], size;
    mesh_frame(m, c, &size);
    const float eye[3] = {c[0] + 0.3f * size, c[1] + 0.4f * size, c[2] + 2.0f * size};
    s->name = name, s->n = 0, s->size = w * h;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            prt_ray *r = &s->rays[s->n++];
            const float px = c[0] + size * (0.3f * ((float)x / (float)w - 0.5f)),
                        py = c[1] + size * (0.3f * ((float)y / (float)h - 0.5f));
            *r = (prt_ray){{eye[0], eye[1], eye[2]}, 0.0f, {px - eye[0], py - eye[1], c[2] - eye[2]}, INFINITY};
        }
}

/* Random rays through the mesh (every octant in one packet), with invalid rays and tnear /
 * tfar windows mixed in. */
static void mixed_rays(const prt_mesh *m, ray_set *s, uint32_t n, uint32_t size) {
    prt_ray *r = rays_random(m, n, 5);
    memcpy(s->rays, r, n * sizeof *r);
    free(r);
    prt_rng g = prt_rng_seed(9, 0);
    for (uint32_t i = 0; i < n; i++) {
        prt_ray *x = &s->rays[i];
        switch (i % 11) {
        case 0: x->org[1] = NAN; break;
        case 1: x->dir[0] = x->dir[1] = x->dir[2] = 0.0f; break;
        case 2: x->tnear = 2.0f, x->tfar = 1.0f; break;
        case 3:
        case 4: x->tnear = prt_rng_float(&g), x->tfar = x->tnear + 2.0f * prt_rng_float(&g); break;
        case 5: x->dir[i % 3] = 0.0f; break; /* an infinite reciprocal */
        case 6: x->tnear = -1.0f, x->tfar = 0.5f * prt_rng_float(&g); break;
        default: break;
        }
    }
    s->name = "mixed octants, invalid rays, tnear / tfar windows", s->n = n, s->size = size;
}

/* Rays with integer origins and directions through the grid cube's edges and vertices,
 * 64 from each of a few integer eye points: many exact ties between triangles. */
static void edge_rays(ray_set *s, uint32_t n) {
    /* Far enough that 64 rays from one eye are coherent (packets, not single rays). */
    static const float eyes[4][3] = {{-30, -20, -50}, {49, 37, 61}, {3, 3, -46}, {-44, 3, 3}};
    s->n = 0;
    for (uint32_t i = 0; i < n; i++) {
        const float *e = eyes[i / 64 % 4];
        const float to[3] = {(float)(i % 7), (float)(i / 7 % 7), (float)(i / 49 % 7)};
        s->rays[s->n++] = (prt_ray){{e[0], e[1], e[2]}, 0.0f, {to[0] - e[0], to[1] - e[1], to[2] - e[2]}, INFINITY};
    }
    s->name = "through shared edges and vertices", s->size = 64;
}

/* Rays starting on the mesh's vertices (tnear 0), 64 at a time toward one far point: each
 * hits the triangles around its vertex at t = 0, some computed +0 and some -0, and packets
 * must keep the sign the single ray reports. */
static void vertex_origin_rays(const prt_mesh *m, ray_set *s, uint32_t n) {
    static const float far[4][3] = {{-300, -200, -500}, {490, 370, 610}, {30, 30, -460}, {-440, 30, 30}};
    s->n = 0;
    for (uint32_t i = 0; i < n; i++) {
        const float *o = m->vertices + 3 * (size_t)((i * 7u) % m->vertex_count), *f = far[i / 64 % 4];
        s->rays[s->n++] = (prt_ray){{o[0], o[1], o[2]}, 0.0f, {f[0] - o[0], f[1] - o[1], f[2] - o[2]}, INFINITY};
    }
    s->name = "starting on vertices", s->size = 64;
}

/* A tile of w x w rays from far off along the diagonal (1, 0, 1): the dominant axis of the
 * rays is x for some and z for others within one vector of eight, which the leaf test over
 * rays picks per lane (geom/triangle_rays.h). */
static void diagonal_tile(const prt_mesh *m, ray_set *s, uint32_t w) {
    float c[3], size;
    mesh_frame(m, c, &size);
    const float eye[3] = {c[0] - 2.0f * size, c[1], c[2] - 2.0f * size};
    s->name = "diagonal tile, mixed dominant axes", s->n = 0, s->size = w * w;
    for (uint32_t y = 0; y < w; y++)
        for (uint32_t x = 0; x < w; x++) {
            /* Targets on the plane through c across the diagonal: x - z varies with x. */
            const float d = size * 0.2f * ((float)x / (float)w - 0.5f), e = size * 0.2f * ((float)y / (float)w - 0.5f);
            const float to[3] = {c[0] + d, c[1] + e, c[2] - d};
            s->rays[s->n++] =
                (prt_ray){{eye[0], eye[1], eye[2]}, 0.0f, {to[0] - eye[0], to[1] - eye[1], to[2] - eye[2]}, INFINITY};
        }
}

/* Shadow rays of a camera tile: from each hit of s, a point just off the surface, towards
 * one light, with tfar at the light (any hits and closest hits with a window). */
static void shadow_tile(const prt_accel *a, const ray_set *cam, ray_set *s) {
    const float light[3] = {cam->rays[0].org[0] + 3.0f, cam->rays[0].org[1] + 40.0f, cam->rays[0].org[2] - 5.0f};
    s->n = 0;
    for (uint32_t i = 0; i < cam->n; i++) {
        prt_ray r = cam->rays[i];
        prt_hit h;
        prt_intersect1(a, &r, &h);
        const float t = h.prim == PRT_INVALID ? 1.0f : h.t * 0.999f;
        const float o[3] = {r.org[0] + t * r.dir[0], r.org[1] + t * r.dir[1], r.org[2] + t * r.dir[2]};
        s->rays[s->n++] =
            (prt_ray){{o[0], o[1], o[2]}, 0.0f, {light[0] - o[0], light[1] - o[1], light[2] - o[2]}, 1.0f};
    }
    s->name = "shadow rays of a tile", s->size = 64;
}

/* Bounces of narrow camera tiles (1/50 of the mesh's width): from each hit, a point just
 * off the surface, in a direction drawn over the whole sphere (into the surface too), every
 * 3rd with a short tfar as ambient-occlusion rays have; 64 consecutive rays from one tile,
 * the next 64 from another far from it (spread: 0) or the same (1). The origins of 64 lie
 * close, the directions spread: they are traced as packets (wide8_packet_worth) whose rays
 * part after a few nodes and walk on alone (slice_alone); with spread, packets of 256 are
 * not (they are streamed). */
static void bounce_rays(const prt_accel *a, const prt_mesh *m, ray_set *s, uint32_t n, uint32_t packet, int spread) {
    float c[3], size;
    mesh_frame(m, c, &size);
    const float eye[3] = {c[0] + 0.3f * size, c[1] + 0.4f * size, c[2] + 2.0f * size};
    prt_rng g = prt_rng_seed(17, 0);
    s->n = 0;
    for (uint32_t i = 0; s->n < n && i < 64 * n; i++) {
        const float sx = spread ? 0.3f * (float)(s->n / 64 % 2) - 0.15f : 0.0f;
        const float sy = spread ? 0.3f * (float)(s->n / 128 % 2) - 0.15f : 0.0f;
        const float px = c[0] + size * (sx + 0.02f * (prt_rng_float(&g) - 0.5f)),
                    py = c[1] + size * (sy + 0.02f * (prt_rng_float(&g) - 0.5f));
        prt_ray r = {{eye[0], eye[1], eye[2]}, 0.0f, {px - eye[0], py - eye[1], c[2] - eye[2]}, INFINITY};
        prt_hit h;
        prt_intersect1(a, &r, &h);
        if (h.prim == PRT_INVALID) continue;
        const float t = h.t * 0.9999f;
        float d[3];
        do
            for (int k = 0; k < 3; k++) d[k] = 2.0f * prt_rng_float(&g) - 1.0f;
        while (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > 1.0f || d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < 1e-4f);
        s->rays[s->n] = (prt_ray){{r.org[0] + t * r.dir[0], r.org[1] + t * r.dir[1], r.org[2] + t * r.dir[2]},
                                  0.0f,
                                  {d[0], d[1], d[2]},
                                  s->n % 3 ? INFINITY : 0.05f * size};
        s->n++;
    }
    s->name = "bounces from a narrow tile's hits", s->size = packet;
}

/* Packets of s against single rays on a; returns the rays that differ. */
static size_t packet_differences(const prt_accel *a, const ray_set *s, size_t *hits) {
    static prt_ray single[MAX_RAYS], packed[MAX_RAYS], streamed[MAX_RAYS];
    static prt_hit hs[MAX_RAYS], hp[MAX_RAYS], hst[MAX_RAYS];
    static uint8_t os[MAX_RAYS], op[MAX_RAYS], ostream[MAX_RAYS];
    memcpy(single, s->rays, s->n * sizeof *single), memcpy(packed, s->rays, s->n * sizeof *packed);
    for (uint32_t i = 0; i < s->n; i++) prt_intersect1(a, &single[i], &hs[i]), os[i] = prt_occluded1(a, &s->rays[i]);
    for (uint32_t first = 0; first < s->n; first += s->size) {
        const uint32_t count = s->n - first < s->size ? s->n - first : s->size;
        prt_packet p = {packed + first, hp + first, count, count < 16 ? count : 16};
        prt_intersect_packet(a, &p);
        p.rays = (prt_ray *)s->rays + first, p.hits = NULL;
        prt_occluded_packet(a, &p, op + first);
    }
    prt_occluded_stream(a, s->rays, ostream, s->n, 1);
    memcpy(streamed, s->rays, s->n * sizeof *streamed);
    prt_intersect_stream(a, streamed, hst, s->n, 1);
    size_t differ = 0;
    for (uint32_t i = 0; i < s->n; i++) {
        *hits += hs[i].prim != PRT_INVALID;
        differ += os[i] != ostream[i] || hs[i].prim != hp[i].prim || memcmp(&hs[i].t, &hp[i].t, 4) ||
                  memcmp(&hs[i].u, &hp[i].u, 4) || memcmp(&hs[i].v, &hp[i].v, 4) ||
                  memcmp(&single[i].tfar, &packed[i].tfar, 4) || os[i] != op[i] ||
                  memcmp(&hs[i], &hst[i], sizeof hs[i]) || memcmp(&single[i].tfar, &streamed[i].tfar, 4);
    }
    return differ;
}

/* Build spec with PRT_ISA set to isa. */
static prt_status build_for(const prt_mesh *m, const char *spec, const char *isa, prt_accel **a) {
    setenv("PRT_ISA", isa, 1);
    *a = NULL;
    prt_status s = prt_build(m, spec, NULL, a);
    unsetenv("PRT_ISA");
    return s;
}

/* Every codec on wide8, every instruction set this host runs, every ray set of mesh m, and
 * the shadow rays of camera tile sets[cam] (cam >= 0). */
static void check_mesh(const char *what, const prt_mesh *m, const ray_set *sets, int nsets, int cam) {
    for (int isa = 0; isa < PRT__ISA_COUNT; isa++) {
        if (!prt__isa_runs((prt__isa)isa)) continue;
        for (int c = 0; c < BVH_CODEC_COUNT; c++) {
            char spec[64];
            snprintf(spec, sizeof spec, "wide8:%s", bvh_codecs[c].name);
            prt_accel *a = NULL;
            prt_status st = build_for(m, spec, prt__isa_name((prt__isa)isa), &a);
            if (st == PRT_ERROR_LIMIT) continue;
            CHECK_MSG(st == PRT_OK, "%s: %s", spec, prt_last_error());
            if (!a) continue;
            for (int k = 0; k < nsets; k++) {
                size_t hits = 0;
                const size_t differ = packet_differences(a, &sets[k], &hits);
                CHECK_MSG(differ == 0, "%s, %s, %s, %s (packets of %u): %zu of %u rays differ", spec,
                          prt__isa_name((prt__isa)isa), what, sets[k].name, sets[k].size, differ, sets[k].n);
                CHECK_MSG(hits >= sets[k].n / 8, "%s, %s: %s: only %zu hits: the comparison sees too little", spec,
                          what, sets[k].name, hits);
            }
            if (cam >= 0) {
                static ray_set shadow;
                shadow_tile(a, &sets[cam], &shadow);
                size_t hits = 0;
                const size_t differ = packet_differences(a, &shadow, &hits);
                CHECK_MSG(differ == 0, "%s, %s, %s, %s: %zu of %u rays differ", spec, prt__isa_name((prt__isa)isa),
                          what, shadow.name, differ, shadow.n);
            }
            static ray_set bounce;
            for (int spread = 0; spread < 3; spread++) {
                const uint32_t size = spread == 0 ? 64 : 256;
                bounce_rays(a, m, &bounce, 512, size, spread == 2);
                size_t hits = 0;
                const size_t differ = packet_differences(a, &bounce, &hits);
                CHECK_MSG(differ == 0, "%s, %s, %s, %s (packets of %u, %s): %zu of %u rays differ", spec,
                          prt__isa_name((prt__isa)isa), what, bounce.name, size, spread == 2 ? "4 tiles" : "1 tile",
                          differ, bounce.n);
                CHECK_MSG(bounce.n == 512 && hits >= bounce.n / 8,
                          "%s: %s: %u rays, %zu hits: the comparison sees too little", spec, bounce.name, bounce.n,
                          hits);
            }
            prt_accel_free(a);
        }
    }
}

TEST(test_packets_answer_as_single_rays_on_every_codec_and_isa) {
    prt_mesh *soup = mesh_random_soup(1500, 3);
    prt_mesh *far = mesh_transformed(soup, 1.0f, 5000.0f); /* wide8_fold_suits: false */
    static ray_set sets[7];
    const prt_mesh *meshes[2] = {soup, far};
    for (int mi = 0; mi < 2; mi++) {
        camera_tile(meshes[mi], &sets[0], 1, 1, "one ray");
        camera_tile(meshes[mi], &sets[1], 7, 1, "a row of 7");
        camera_tile(meshes[mi], &sets[2], 8, 8, "8x8 tile");
        camera_tile(meshes[mi], &sets[3], 16, 16, "16x16 tile");
        camera_tile(meshes[mi], &sets[4], 32, 32, "32x32 image in 4x4 packets"), sets[4].size = 16;
        mixed_rays(meshes[mi], &sets[5], 512, mi ? 64 : 256);
        diagonal_tile(meshes[mi], &sets[6], 16);
        check_mesh(mi ? "far mesh" : "near mesh", meshes[mi], sets, 7, 3);
    }
    prt_mesh_free(soup);
    prt_mesh_free(far);
}

TEST(test_packets_through_shared_edges_and_vertices) {
    prt_mesh *cube = mesh_grid_cube(6);
    static ray_set sets[2];
    edge_rays(&sets[0], 512);
    vertex_origin_rays(cube, &sets[1], 512);
    check_mesh("grid cube", cube, sets, 2, -1);
    prt_mesh_free(cube);
}

int main(void) {
    RUN(test_packets_answer_as_single_rays_on_every_codec_and_isa);
    RUN(test_packets_through_shared_edges_and_vertices);
    TEST_END();
}
