/* Ray-Strips (src/strips/): every option against the brute-force reference on connected
 * and poorly connected meshes; the structure itself (every triangle in exactly one strip,
 * strip triangles are the mesh's, s-kd planes bound their halves, strips on a connected
 * mesh are long); rays through strip vertices and edges all hit; .prt files whose
 * top level or records are damaged behind the checksums are errors, never crashes. */
#include "api/accel.h"
#include "mesh/mesh.h"
#include "strips/strips.h"
#include "support/meshes.h"
#include "support/reference.h"
#include "support/repr.h"
#include "test.h"

#include <stdlib.h>
#include <unistd.h>

#define EDGE_EPS 1e-4

static const char *const g_specs[] = {
    "raystrips",
    "raystrips,leaf=2,split=f32,strip=meshopt",
    "raystrips,leaf=1",
    "raystrips,leaf=4,split=q16",
    "raystrips,leaf=8",
    "raystrips,leaf=8,split=q16,chunk=32",
    "raystrips,strip=rt",
    "raystrips,strip=rt,leaf=4,split=q16,chunk=1024",
    "raystrips,chunk=4,leaf=2,split=q16",
    "raystrips,chunk=16384,leaf=1,split=f32,mat=u16", /* strips cut to fit a leaf */
};

/* Closest hits (prim and t) and any hits against the reference on rays away from edges. */
static void expect_matches_reference(const prt_mesh *m, const char *spec, const prt_ray *rays, size_t n) {
    prt_accel *a;
    if (!repr_build(m, spec, &a)) return;
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
        if (ok && got.prim != PRT_INVALID) {
            ok = fabs((double)got.t - want.t) <= 1e-5 * diag && got.u >= -1e-4f && got.v >= -1e-4f &&
                 got.u + got.v <= 1.0001f;
            /* The barycentrics name the mesh triangle's own vertices 1 and 2. */
            const uint32_t *t = m->triangles + 3 * (size_t)got.prim;
            for (int k = 0; k < 3 && ok; k++) {
                const double p = (1.0 - got.u - got.v) * m->vertices[3 * t[0] + k] + got.u * m->vertices[3 * t[1] + k] +
                                 got.v * m->vertices[3 * t[2] + k];
                ok = fabs(p - (rays[i].org[k] + (double)got.t * rays[i].dir[k])) <= 1e-4 * diag;
            }
        }
        wrong += !ok;
        occ_wrong += prt_occluded1(a, &rays[i]) != (want.prim != PRT_INVALID);
    }
    CHECK_MSG(compared > n / 2 && wrong == 0 && occ_wrong == 0,
              "%s: %zu rays compared, %zu closest and %zu any hits wrong", spec, compared, wrong, occ_wrong);
    prt_accel_free(a);
}

TEST(test_every_option_matches_brute_force_on_a_connected_grid) {
    prt_mesh *m = mesh_grid(48);
    prt_ray *rays = rays_random(m, 3000, 1);
    for (size_t i = 0; i < COUNT_OF(g_specs); i++) expect_matches_reference(m, g_specs[i], rays, 3000);
    free(rays);
    prt_mesh_free(m);
}

TEST(test_every_option_matches_brute_force_on_a_soup_without_connectivity) {
    prt_mesh *m = mesh_random_soup(2000, 2);
    prt_ray *rays = rays_random(m, 3000, 3);
    for (size_t i = 0; i < COUNT_OF(g_specs); i++) expect_matches_reference(m, g_specs[i], rays, 3000);
    free(rays);
    prt_mesh_free(m);
}

TEST(test_bunny_matches_brute_force) {
    const char *path = ref_shared_path("bunny.ply");
    if (!path) SKIP("../shared/data/bunny.ply is absent");
    prt_mesh *m;
    prt_status s = prt_mesh_load(path, &m);
    CHECK_OK(s);
    if (s) return;
    prt_ray *rays = rays_random(m, 1500, 4);
    const char *specs[] = {"raystrips", "raystrips,leaf=2,split=f32,strip=meshopt", "raystrips,leaf=4,split=f32"};
    for (size_t i = 0; i < COUNT_OF(specs); i++) expect_matches_reference(m, specs[i], rays, 1500);
    free(rays);
    prt_mesh_free(m);
}

/* Whether the accel's vertex i is where the mesh's vertex j is (the accel renumbers its
 * vertices and merges those at one position). */
static bool same_vertex(const rs_accel *a, uint32_t i, const prt_mesh *m, uint32_t j) {
    if (i >= a->vertex_count) return false;
    const float *p = a->vertices + 3 * (size_t)i, *q = m->vertices + 3 * (size_t)j;
    return p[0] == q[0] && p[1] == q[1] && p[2] == q[2];
}

/* Walks the records in the top level's leaves: every hittable mesh triangle appears once,
 * each strip triangle has the mesh triangle's vertices, and each s-kd node's planes bound
 * its halves' vertices (q16: decoded on the grid of the node holding the record). Returns
 * the number of strips. */
static size_t check_structure(const prt_mesh *m, const char *spec) {
    prt_accel *acc;
    if (!repr_build(m, spec, &acc)) return 0;
    const rs_accel *a = (const rs_accel *)acc;
    uint8_t *seen = calloc(m->triangle_count, 1);
    size_t bad_tri = 0, bad_plane = 0, twice = 0, live = 0, strips = 0, max_n = 0;
    for (size_t q = 0; q < a->node_count; q++) {
        const wide8_node *node = &a->nodes[q];
        const rs_grid g = rs_grid_of(node);
        for (int slot = __builtin_popcount(node->imask); slot < 8 && node->meta[slot]; slot++) {
            size_t w, end;
            rs_leaf_range(node, slot, &w, &end);
            for (; w < end; w += rs_entry_size(a->geometry + w, &a->fmt), strips++) {
                const rs_strip st = rs_strip_at(a->geometry + w + a->fmt.no_ids, &a->fmt);
                if (st.n > max_n) max_n = st.n;
                for (uint32_t k = 0; k < st.n; k++) {
                    if (rs_dead(&st, k)) continue;
                    const uint32_t id = rs_id(&st, k), prim = id >> RS_ID_SHIFT, code = id & 7;
                    const uint32_t *t = m->triangles + 3 * (size_t)prim, *p = st.index + k;
                    live++;
                    twice += seen[prim]++ > 0;
                    /* Vertex 1 and 2 of the mesh triangle sit where the code says; vertex 0 in the rest. */
                    const int p1 = rs_perm[code][0], p2 = rs_perm[code][1];
                    bad_tri += code >= 6 || !same_vertex(a, p[p1], m, t[1]) || !same_vertex(a, p[p2], m, t[2]) ||
                               !same_vertex(a, p[3 - p1 - p2], m, t[0]);
                }
                /* Planes: recompute the halves' boxes the way the layout defines them. */
                typedef struct visit {
                    uint32_t node, first, count;
                } visit;
                visit todo[64];
                int top = 0;
                todo[top++] = (visit){0, 0, st.n};
                while (top) {
                    const visit v = todo[--top];
                    if (v.count <= a->fmt.leaf) continue;
                    const uint32_t groups = rs_groups(v.count, a->fmt.leaf), lg = (groups + 1) / 2,
                                   nl = lg * a->fmt.leaf;
                    const uint32_t fl = st.flags[v.node], k = fl & 3;
                    const bool rev = fl & RS_FLAG_REVERSE;
                    float lo = INFINITY, hi = -INFINITY;
                    /* lower half: its maximum is at most the first plane; upper: its minimum at least the second. */
                    const uint32_t lf = rev ? v.first + nl : v.first, lc = rev ? v.count - nl : nl;
                    const uint32_t uf = rev ? v.first : v.first + nl, uc = rev ? nl : v.count - nl;
                    for (uint32_t j = lf; j < lf + lc + 2; j++) hi = fmaxf(hi, a->vertices[3 * st.index[j] + k]);
                    for (uint32_t j = uf; j < uf + uc + 2; j++) lo = fminf(lo, a->vertices[3 * st.index[j] + k]);
                    float p1, p2;
                    if (a->fmt.q16) {
                        const uint16_t *qq = (const uint16_t *)st.splits + 2 * v.node;
                        p1 = rs_q16_plane(qq[0], &g, (int)k), p2 = rs_q16_plane(qq[1], &g, (int)k);
                    } else {
                        p1 = ((const float *)st.splits)[2 * v.node], p2 = ((const float *)st.splits)[2 * v.node + 1];
                    }
                    bad_plane += !(hi <= p1 && lo >= p2);
                    todo[top++] = (visit){v.node + 1, v.first, nl};
                    todo[top++] = (visit){v.node + lg, v.first + nl, v.count - nl};
                }
            }
        }
    }
    size_t missing = 0;
    for (size_t t = 0; t < m->triangle_count; t++) missing += !seen[t] && !prt__mesh_triangle_degenerate(m, t);
    CHECK_MSG(
        !bad_tri && !bad_plane && !twice && !missing && live == acc->triangles_built && strips == a->strip_count,
        "%s: %zu wrong strip triangles, %zu planes that cut their half, %zu twice, %zu missing, %zu of %zu strips",
        spec, bad_tri, bad_plane, twice, missing, strips, a->strip_count);
    /* An entry fits a leaf (255 units): longer strips are cut. */
    CHECK_MSG(max_n <= 255 * RS_UNIT / 4, "%s: a strip of %zu triangles", spec, max_n);
    free(seen);
    prt_accel_free(acc);
    return strips;
}

TEST(test_strips_hold_every_triangle_once_under_bounding_planes) {
    prt_mesh *grid = mesh_grid(40), *soup = mesh_random_soup(1500, 5);
    for (size_t i = 0; i < COUNT_OF(g_specs); i++) {
        check_structure(grid, g_specs[i]);
        check_structure(soup, g_specs[i]);
    }
    prt_mesh_free(grid), prt_mesh_free(soup);
}

TEST(test_connected_mesh_gives_long_strips_and_a_soup_single_triangles) {
    prt_mesh *grid = mesh_grid(40), *soup = mesh_random_soup(1500, 5);
    const char *specs[] = {"raystrips,strip=meshopt,chunk=128", "raystrips,strip=rt,chunk=128"};
    for (size_t i = 0; i < COUNT_OF(specs); i++) {
        const size_t g = check_structure(grid, specs[i]), s = check_structure(soup, specs[i]);
        /* 3200 triangles in chunks of 128: a strip per chunk would be 25 long. */
        /* meshoptimizer strips for vertex caches (4 to 6 long here); ours aim for length. */
        CHECK_MSG(g > 0 && grid->triangle_count / g >= (i ? 12u : 4u), "%s: %zu strips over %zu grid triangles",
                  specs[i], g, grid->triangle_count);
        CHECK_MSG(s == soup->triangle_count, "%s: %zu strips over %zu unconnected triangles", specs[i], s,
                  soup->triangle_count);
    }
    prt_mesh_free(grid), prt_mesh_free(soup);
}

TEST(test_rays_at_vertices_and_edge_midpoints_of_a_grid_all_hit) {
    /* Interior vertices and edge midpoints, from above and slanted: a ray there lies on an
     * edge shared by two strip triangles, often of different strips. */
    const uint32_t n = 24;
    prt_mesh *m = mesh_grid(n);
    for (size_t i = 0; i < COUNT_OF(g_specs); i++) {
        prt_accel *a;
        if (!repr_build(m, g_specs[i], &a)) continue;
        size_t misses = 0, rays = 0;
        for (size_t t = 0; t < m->triangle_count; t++)
            for (int e = 0; e < 3; e++) {
                const float *p = m->vertices + 3 * m->triangles[3 * t + e],
                            *q = m->vertices + 3 * m->triangles[3 * t + (e + 1) % 3];
                const float target[2][3] = {{p[0], p[1], p[2]},
                                            {0.5f * (p[0] + q[0]), 0.5f * (p[1] + q[1]), 0.5f * (p[2] + q[2])}};
                for (int j = 0; j < 2; j++) {
                    if (target[j][0] <= 0 || target[j][0] >= 1 || target[j][2] <= 0 || target[j][2] >= 1) continue;
                    const float o[3] = {target[j][0] + 0.3f, 2.0f, target[j][2] - 0.2f};
                    prt_ray r = {{o[0], o[1], o[2]},
                                 0,
                                 {target[j][0] - o[0], target[j][1] - o[1], target[j][2] - o[2]},
                                 INFINITY};
                    prt_hit h;
                    prt_ray r2 = r;
                    prt_intersect1(a, &r2, &h);
                    misses += h.prim == PRT_INVALID || !prt_occluded1(a, &r);
                    rays++;
                }
            }
        CHECK_MSG(misses == 0, "%s: %zu of %zu rays through vertices and edges missed", g_specs[i], misses, rays);
        prt_accel_free(a);
    }
    prt_mesh_free(m);
}

/* A saved image of spec over m, read back into 64-byte aligned memory. */
static uint8_t *saved_image(const prt_mesh *m, const char *spec, size_t *size) {
    prt_accel *a = NULL;
    *size = 0;
    uint32_t *order = malloc(m->triangle_count * sizeof *order);
    prt_build_options o = {.triangle_order = order};
    CHECK_OK(prt_build(m, spec, &o, &a));
    free(order);
    if (!a) return NULL;
    char path[256];
    snprintf(path, sizeof path, "%s/packrt_test_raystrips_%d.prt", P_tmpdir, (int)getpid());
    CHECK_OK(prt_accel_save(a, path));
    prt_accel_free(a);
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    *size = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *img = aligned_alloc(64, (*size + 63) / 64 * 64);
    if (fread(img, 1, *size, f) != *size) *size = 0;
    fclose(f);
    remove(path);
    return img;
}

TEST(test_damaged_records_and_nodes_behind_the_checksums_are_errors) {
    prt_mesh *m = mesh_grid(12);
    const char *specs[] = {"raystrips", "raystrips,split=f32,leaf=2,strip=meshopt", "raystrips,ids=none,mat=u16"};
    for (size_t sp = 0; sp < COUNT_OF(specs); sp++) {
        size_t size;
        uint8_t *img = saved_image(m, specs[sp], &size);
        if (!img) continue;
        prt_accel *a = NULL;
        CHECK_OK(prt__accel_open(img, size, true, &a));
        prt_accel_free(a);
        size_t blob_len = 0;
        /* Every word of the nodes and records set to values that break one rule each. */
        const uint32_t values[] = {0xFFFFFFFFu, 0x80000000u, 0x7FFFFFFFu, 0x10000u, 0, 1, 3, 0x07070707u, 12345678u};
        const uint32_t tags[] = {PRT_FOURCC('R', 'S', 'W', '8'), PRT_FOURCC('M', 'E', 'T', 'A')};
        size_t rejected = 0, tried = 0;
        for (size_t t = 0; t < COUNT_OF(tags); t++) {
            size_t len = 0;
            prt_file_info info;
            prt_reader r;
            CHECK_OK(prt__file_open(img, size, false, &info, &r));
            size_t off = 0;
            for (uint32_t i = 0; i < r.count; i++)
                if (r.sections[i].tag == tags[t]) off = r.sections[i].offset, len = r.sections[i].size;
            if (tags[t] == PRT_FOURCC('R', 'S', 'W', '8')) blob_len = len;
            for (size_t w = 0; w + 4 <= len; w += 4)
                for (size_t v = 0; v < COUNT_OF(values); v++) {
                    uint8_t *bad = aligned_alloc(64, (size + 63) / 64 * 64);
                    memcpy(bad, img, size);
                    memcpy(bad + off + w, &values[v], 4);
                    if (memcmp(bad, img, size)) {
                        prt_accel *b = NULL;
                        tried++;
                        if (prt__accel_open(bad, size, false, &b) != PRT_OK) rejected++;
                        else {
                            /* Accepted (a plane or a box moved): rays must still be safe. */
                            prt_ray *rays = rays_random(m, 64, w);
                            for (int i = 0; i < 64; i++) {
                                prt_hit h;
                                prt_intersect1(b, &rays[i], &h);
                                prt_occluded1(b, &rays[i]);
                                /* META states the mesh's triangle count the ids are checked against. */
                                CHECK(h.prim == PRT_INVALID || h.prim < m->triangle_count ||
                                      tags[t] == PRT_FOURCC('M', 'E', 'T', 'A'));
                            }
                            free(rays);
                            prt_accel_free(b);
                        }
                    }
                    free(bad);
                }
        }
        CHECK_MSG(blob_len > 0 && rejected > tried / 3, "%s: %zu of %zu damaged images rejected", specs[sp], rejected,
                  tried);
        free(img);
    }
    prt_mesh_free(m);
}

/* Specs whose packets are traced as packets: 4x4 (the default) and 2x2. */
static const char *const g_packet_specs[] = {
    "raystrips",
    "raystrips,packet=2x2",
    "raystrips,leaf=2,split=f32,strip=meshopt,packet=2x2",
    "raystrips,leaf=2,split=f32,strip=meshopt,packet=4x4",
    "raystrips,leaf=1,packet=4x4",
    "raystrips,chunk=4,leaf=2,split=q16,packet=4x4",
    "raystrips,leaf=4,split=f32,chunk=1024,packet=4x4",
};

/* Every packet of `per` consecutive rays (width w) gives each ray exactly its single-ray
 * hit and shrinks its tfar the same, and its any-hit packet each ray's prt_occluded1.
 * Returns the number of rays that hit. */
static size_t expect_packets_match_single_rays(const prt_accel *a, const char *spec, const prt_ray *rays, uint32_t n,
                                               uint32_t w, uint32_t per) {
    prt_ray *r1 = malloc(n * sizeof *r1), *r2 = malloc(n * sizeof *r2);
    prt_hit *h1 = malloc(n * sizeof *h1), *h2 = malloc(n * sizeof *h2);
    uint8_t *occ = malloc(n);
    memcpy(r1, rays, n * sizeof *rays), memcpy(r2, rays, n * sizeof *rays);
    for (uint32_t k = 0; k < n; k++) prt_intersect1(a, &r1[k], &h1[k]);
    for (uint32_t k = 0; k < n; k += per) {
        prt_packet p = {r2 + k, h2 + k, n - k < per ? n - k : per, w};
        prt_intersect_packet(a, &p);
        const prt_packet q = {(prt_ray *)rays + k, NULL, p.count, w};
        prt_occluded_packet(a, &q, occ + k);
    }
    size_t diff = 0, odiff = 0, hits = 0;
    for (uint32_t k = 0; k < n; k++) {
        diff += memcmp(&h1[k], &h2[k], sizeof h1[k]) != 0 || memcmp(&r1[k], &r2[k], sizeof r1[k]) != 0;
        odiff += occ[k] != prt_occluded1(a, &rays[k]);
        hits += h1[k].prim != PRT_INVALID;
    }
    CHECK_MSG(diff == 0, "%s, packets of %u, width %u: %zu of %u packet rays differ", spec, per, w, diff, n);
    CHECK_MSG(odiff == 0, "%s, any-hit packets of %u: %zu of %u rays differ", spec, per, odiff, n);
    free(r1), free(r2), free(h1), free(h2), free(occ);
    return hits;
}

/* Rays from one eye aimed at the mesh's vertices and edge midpoints, in mesh order (so a
 * packet's rays are coherent): each hit lies on a box or s-kd plane or a shared edge, where
 * an entry distance may round above the hit's t. Packets visit leaves in another order
 * than single rays; without the culls' slack (rs_strip_trace, rsw_slot_leaf) a strip dropped
 * a nearer hit or an equal t's smaller id in one order and not the other (torus of 30,000
 * triangles: 6 and 12 of 40,000 rays). */
TEST(test_packets_of_rays_aimed_at_vertices_give_the_single_ray_hits) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_generate("torus", 30000, 1, &m));
    if (!m) return;
    const char *specs[] = {"raystrips,leaf=1", "raystrips,leaf=2,split=f32,strip=meshopt"};
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    const float eyes[2][3] = {{2.2f * hi[0] - 1.2f * lo[0], 1.7f * hi[1] - 0.7f * lo[1], 1.4f * hi[2] - 0.4f * lo[2]},
                              {1.6f * lo[0] - 0.6f * hi[0], 2.1f * lo[1] - 1.1f * hi[1], 0.5f * (lo[2] + hi[2])}};
    const uint32_t half = 2 * (uint32_t)(m->triangle_count / 3), n = 2 * half;
    prt_ray *rays = malloc(n * sizeof *rays);
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t j = i % half, *tri = m->triangles + 3 * (size_t)(3 * (j / 2));
        const float *eye = eyes[i / half];
        rays[i] = (prt_ray){{eye[0], eye[1], eye[2]}, 0, {0, 0, 0}, INFINITY};
        for (int k = 0; k < 3; k++) {
            const float a = m->vertices[3 * tri[0] + k], b = m->vertices[3 * tri[1] + k];
            rays[i].dir[k] = (j & 1 ? 0.5f * (a + b) : a) - eye[k];
        }
    }
    for (size_t i = 0; i < COUNT_OF(specs); i++) {
        prt_accel *a;
        if (!repr_build(m, specs[i], &a)) continue;
        const size_t hits = expect_packets_match_single_rays(a, specs[i], rays, n, 8, 64);
        CHECK_MSG(hits > n / 2, "%s: %zu of %u rays hit", specs[i], hits, n);
        prt_accel_free(a);
    }
    free(rays);
    prt_mesh_free(m);
}

/* Packets (4x4 or 2x2 blocks, or runs of 16 or 4) give every ray exactly its single-ray hit:
 * coherent camera rays over the grid (some off its edges), in packets of several widths
 * and counts. */
TEST(test_packets_give_the_single_ray_hits) {
    prt_mesh *m = mesh_grid(40);
    const uint32_t res = 32, n = res * res;
    prt_ray *rays = malloc(n * sizeof *rays);
    for (uint32_t y = 0; y < res; y++)
        for (uint32_t x = 0; x < res; x++) {
            const float tx = -0.1f + 1.2f * (float)x / res, tz = -0.1f + 1.2f * (float)y / res;
            rays[y * res + x] = (prt_ray){{0.5f, 1.5f, -0.8f}, 0, {tx - 0.5f, -1.5f, tz + 0.8f}, INFINITY};
        }
    const uint32_t widths[][2] = {{2, 4},  {4, 16}, {8, 64}, {16, 256}, {12, 48},
                                  {6, 36}, {4, 12}, {3, 9},  {1, 7},    {1, 16}};
    for (size_t i = 0; i < COUNT_OF(g_packet_specs); i++) {
        prt_accel *a;
        if (!repr_build(m, g_packet_specs[i], &a)) continue;
        for (size_t w = 0; w < COUNT_OF(widths); w++) {
            const size_t hits =
                expect_packets_match_single_rays(a, g_packet_specs[i], rays, n, widths[w][0], widths[w][1]);
            CHECK_MSG(hits > n / 2 && hits < n, "%s: %zu of %u rays hit", g_packet_specs[i], hits, n);
        }
        prt_accel_free(a);
    }
    free(rays);
    prt_mesh_free(m);
}

/* Packets of unrelated rays: random rays over a soup and a grid diverge at the first node,
 * enter different chunks and strips, and many miss; a packet whose rays all miss, and
 * packets holding invalid rays (NaN direction, tnear > tfar), answer as single rays do. */
TEST(test_packets_of_diverging_and_missing_rays_give_the_single_ray_hits) {
    prt_mesh *meshes[] = {mesh_random_soup(1500, 31), mesh_grid(30)};
    const uint32_t n = 1024;
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++) {
        prt_ray *rays = rays_random(meshes[mi], n, 32 + (uint64_t)mi);
        /* Rays 0..15 point away from the mesh (all miss); a few invalid ones elsewhere. */
        for (uint32_t k = 0; k < 16; k++)
            for (int c = 0; c < 3; c++) rays[k].dir[c] = -rays[k].dir[c];
        rays[40].dir[1] = NAN, rays[77].tnear = 2.0f, rays[77].tfar = 1.0f;
        for (size_t i = 0; i < COUNT_OF(g_packet_specs); i++) {
            prt_accel *a;
            if (!repr_build(meshes[mi], g_packet_specs[i], &a)) continue;
            const uint32_t widths[][2] = {{4, 16}, {2, 4}, {16, 16}, {1, 5}};
            for (size_t w = 0; w < COUNT_OF(widths); w++) {
                const size_t hits =
                    expect_packets_match_single_rays(a, g_packet_specs[i], rays, n, widths[w][0], widths[w][1]);
                CHECK_MSG(hits > n / 8 && hits < n - 16, "%s: %zu of %u rays hit", g_packet_specs[i], hits, n);
            }
            prt_accel_free(a);
        }
        free(rays);
        prt_mesh_free(meshes[mi]);
    }
}

/* mesh with a material per triangle that no two neighbours share. */
static void add_materials(prt_mesh *m) {
    CHECK_OK(prt_mesh_add_materials(m));
    for (size_t t = 0; t < m->triangle_count; t++) m->materials[t] = (uint16_t)(t * 7919u + 3u);
}

/* ids=none (hits name positions, mapped back through prt_build_options.triangle_order) and
 * mat=u16 (hits return the triangle's material in geom) give the default's hits bit for
 * bit, single rays and 4x4 and 2x2 packets, built and after a save and load; ids=none
 * takes less memory and mat=u16 two bytes a live triangle (rounded up per strip) more. */
TEST(test_ids_none_and_materials_give_the_default_hits) {
    prt_mesh *grid = mesh_grid(40), *soup = mesh_random_soup(800, 41);
    prt_mesh *meshes[] = {grid, soup};
    /* Each against the first spec of its row (the same strips with ids and no materials). */
    const char *specs[][2] = {
        {"raystrips", "raystrips,ids=none"},
        {"raystrips", "raystrips,mat=u16"},
        {"raystrips", "raystrips,ids=none,mat=u16,packet=4x4"},
        {"raystrips,leaf=2,split=f32,strip=meshopt", "raystrips,leaf=2,split=f32,strip=meshopt,ids=none,mat=u16"}};
    const uint32_t n = 2048;
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++) {
        prt_mesh *m = meshes[mi];
        add_materials(m);
        prt_ray *rays = rays_random(m, n, 42 + (uint64_t)mi);
        prt_hit *want = malloc(n * sizeof *want), *got = malloc(n * sizeof *got);
        uint32_t *order = malloc(m->triangle_count * sizeof *order);
        for (size_t i = 0; i < COUNT_OF(specs); i++) {
            prt_accel *ref;
            if (!repr_build(m, specs[i][0], &ref)) continue;
            prt_stats sref;
            prt_accel_stats(ref, &sref);
            size_t hits = 0;
            for (uint32_t k = 0; k < n; k++) {
                prt_ray r = rays[k];
                prt_intersect1(ref, &r, &want[k]);
                hits += want[k].prim != PRT_INVALID;
            }
            prt_accel_free(ref);
            CHECK(hits > n / 4);
            const bool no_ids = strstr(specs[i][1], "ids=none") != NULL, mat = strstr(specs[i][1], "mat=u16") != NULL;
            prt_build_options o = {.triangle_order = order};
            prt_accel *built = NULL, *loaded = NULL;
            CHECK_OK(prt_build(m, specs[i][1], &o, &built));
            if (!built) continue;
            char path[256];
            snprintf(path, sizeof path, "%s/packrt_test_raystrips_ids_%d.prt", P_tmpdir, (int)getpid());
            CHECK_OK(prt_accel_save(built, path));
            CHECK_OK(prt_accel_load(path, &loaded));
            remove(path);
            prt_stats st;
            prt_accel_stats(built, &st);
            /* Memory: ids=none drops 4-byte ids (at least 3 bytes a triangle on the grid's
             * long strips); materials add 2 bytes a live triangle, a strip's rounded up to a word. */
            const size_t tri = st.triangles_built;
            const long extra = (long)st.bytes_geometry - (long)sref.bytes_geometry;
            const long mat_lo = mat ? 2 * (long)tri : 0, mat_hi = mat ? 4 * (long)tri : 0;
            const long id_lo = no_ids ? -4 * (long)tri : 0, id_hi = no_ids ? (mi == 0 ? -3 * (long)tri : -1) : 0;
            CHECK_MSG(extra >= mat_lo + id_lo && extra <= mat_hi + id_hi,
                      "%s: %ld geometry bytes more than the default", specs[i][1], extra);
            CHECK(!mat || strstr(st.detail, "materials") != NULL);
            const prt_accel *accels[] = {built, loaded};
            for (size_t ai = 0; ai < 2 && loaded; ai++)
                for (int mode = 0; mode < 3; mode++) {
                    prt_ray *r = malloc(n * sizeof *r);
                    memcpy(r, rays, n * sizeof *r);
                    for (uint32_t k = 0; k < n; k += 16) {
                        prt_packet p = {r + k, got + k, 16, mode == 1 ? 4 : 2};
                        if (mode) prt_intersect_packet(accels[ai], &p);
                        else
                            for (uint32_t j = k; j < k + 16; j++) prt_intersect1(accels[ai], &r[j], &got[j]);
                    }
                    size_t diff = 0;
                    for (uint32_t k = 0; k < n; k++) {
                        prt_hit h = got[k];
                        if (no_ids && h.prim != PRT_INVALID) h.prim = h.prim < tri ? order[h.prim] : PRT_INVALID - 1;
                        const uint32_t geom = mat && h.prim < m->triangle_count ? m->materials[h.prim] : 0;
                        diff += h.prim != want[k].prim || h.t != want[k].t || h.u != want[k].u || h.v != want[k].v ||
                                h.geom != geom;
                    }
                    CHECK_MSG(diff == 0, "%s (%s, %s): %zu of %u hits differ from the default's", specs[i][1],
                              ai ? "loaded" : "built",
                              mode == 0   ? "single rays"
                              : mode == 1 ? "4x4"
                                          : "runs",
                              diff, n);
                    free(r);
                }
            prt_accel_free(built), prt_accel_free(loaded);
        }
        free(order), free(want), free(got), free(rays);
    }
    prt_mesh_free(grid), prt_mesh_free(soup);
}

/* Threads stripify contiguous runs of chunks: the records and nodes do not depend on the
 * thread count. */
TEST(test_build_is_the_same_on_one_and_two_threads) {
    prt_mesh *m = mesh_grid(70); /* 9800 triangles: the SAH builders fork tasks from 8192 */
    const char *specs[] = {"raystrips", "raystrips,leaf=2,split=f32,strip=meshopt,chunk=32"};
    for (size_t i = 0; i < COUNT_OF(specs); i++) {
        prt_build_options one = {.threads = 1}, two = {.threads = 2};
        prt_accel *a = NULL, *b = NULL;
        CHECK_OK(prt_build(m, specs[i], &one, &a));
        CHECK_OK(prt_build(m, specs[i], &two, &b));
        if (a && b) {
            const rs_accel *x = (const rs_accel *)a, *y = (const rs_accel *)b;
            CHECK_MSG(x->blob_bytes == y->blob_bytes && x->node_count == y->node_count &&
                          x->vertex_count == y->vertex_count && !memcmp(x->blob, y->blob, x->blob_bytes) &&
                          !memcmp(x->vertices, y->vertices, 12 * x->vertex_count),
                      "%s: one and two threads build different structures", specs[i]);
        }
        prt_accel_free(a), prt_accel_free(b);
    }
    prt_mesh_free(m);
}

TEST(test_single_triangle_and_bad_options) {
    prt_mesh *m;
    CHECK_OK(prt_mesh_create(3, 1, &m));
    const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint32_t t[3] = {0, 1, 2};
    memcpy(m->vertices, v, sizeof v), memcpy(m->triangles, t, sizeof t);
    prt_accel *a = NULL;
    CHECK_OK(prt_build(m, "raystrips", NULL, &a));
    if (a) {
        CHECK(!strcmp(prt_accel_spec(a), "raystrips,chunk=16,leaf=8,split=q16,strip=rt,packet=4x4"));
        prt_ray r = {{0.25f, 0.5f, 1}, 0, {0, 0, -1}, INFINITY};
        prt_hit h;
        prt_intersect1(a, &r, &h);
        CHECK(h.prim == 0 && h.t == 1.0f && h.u == 0.25f && h.v == 0.5f);
        prt_accel_free(a);
    }
    const char *bad[] = {"raystrips,leaf=3",    "raystrips,leaf=16",      "raystrips,chunk=2",
                         "raystrips,split=f16", "raystrips,strip=stripe", "raystrips,ids=none",
                         "raystrips,ids=some",  "raystrips,mat=u8",       "raystrips:float3"};
    for (size_t i = 0; i < COUNT_OF(bad); i++) {
        a = NULL;
        CHECK_MSG(prt_build(m, bad[i], NULL, &a) == PRT_ERROR_ARGUMENT && a == NULL, "%s was accepted", bad[i]);
    }
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_every_option_matches_brute_force_on_a_connected_grid);
    RUN(test_every_option_matches_brute_force_on_a_soup_without_connectivity);
    RUN(test_bunny_matches_brute_force);
    RUN(test_strips_hold_every_triangle_once_under_bounding_planes);
    RUN(test_connected_mesh_gives_long_strips_and_a_soup_single_triangles);
    RUN(test_rays_at_vertices_and_edge_midpoints_of_a_grid_all_hit);
    RUN(test_damaged_records_and_nodes_behind_the_checksums_are_errors);
    RUN(test_packets_give_the_single_ray_hits);
    RUN(test_packets_of_diverging_and_missing_rays_give_the_single_ray_hits);
    RUN(test_packets_of_rays_aimed_at_vertices_give_the_single_ray_hits);
    RUN(test_ids_none_and_materials_give_the_default_hits);
    RUN(test_build_is_the_same_on_one_and_two_threads);
    RUN(test_single_triangle_and_bad_options);
    TEST_END();
}
