/* The wide8 layout's invariants: every quantized child box, decoded exactly as traversal
 * decodes it, contains every vertex of every triangle below that child (the boxes are
 * conservative, whatever the coordinates' magnitude), every triangle is stored once, and
 * meshes far from the origin or at tiny scale give exactly the brute-force hits. */
#include "bvh/bvh.h"
#include "bvh/layouts/wide8_box.h"
#include "core/rng.h"
#include "support/meshes.h"
#include "support/prims.h"
#include "support/reference.h"
#include "test.h"

/* The codec the walk can read: float3 leaves hold their vertices and ids (40 bytes each). */
#define TRI_BYTES 40

typedef struct walk {
    const bvh_blob *b;
    wide8_header hd;
    uint8_t *seen; /* per mesh triangle */
    size_t violations, planes;
} walk;

/* Grows box by every vertex below slot i of node n; returns the number of triangles. */
static size_t slot_bounds(walk *w, const wide8_node *n, int i, prt_aabb *box);

static size_t node_bounds(walk *w, uint32_t index, prt_aabb *box) {
    wide8_node n;
    memcpy(&n, w->b->data + WIDE8_HEADER_BYTES + (size_t)index * WIDE8_NODE_BYTES, sizeof n);
    size_t tris = 0;
    for (int i = 0; i < 8; i++) {
        if (!(n.imask >> i & 1) && n.meta[i] == 0) continue;
        prt_aabb child = prt_aabb_empty();
        tris += slot_bounds(w, &n, i, &child);
        /* The decoded box, computed as wide8_box_hit computes it. */
        for (int k = 0; k < 3; k++) {
            float s = wide8_scale(n.e[k]);
            float lo = fmaf((float)n.q[2 * k][i], s, n.p[k]), hi = fmaf((float)n.q[2 * k + 1][i], s, n.p[k]);
            w->planes += 2;
            if (lo > child.lo[k] || hi < child.hi[k]) w->violations++;
        }
        for (int k = 0; k < 3; k++) {
            box->lo[k] = fminf(box->lo[k], child.lo[k]);
            box->hi[k] = fmaxf(box->hi[k], child.hi[k]);
        }
    }
    return tris;
}

static size_t slot_bounds(walk *w, const wide8_node *n, int i, prt_aabb *box) {
    if (n->imask >> i & 1) return node_bounds(w, n->child + (uint32_t)i, box);
    uint32_t start = i ? n->meta[i - 1] : 0;
    size_t off = w->hd.geometry + 4 * (size_t)n->leaf + (size_t)start * w->hd.grain;
    size_t count = (size_t)(n->meta[i] - start) * w->hd.grain / TRI_BYTES;
    for (size_t t = 0; t < count; t++) {
        float v[9];
        uint32_t id;
        memcpy(v, w->b->data + off + t * TRI_BYTES, sizeof v);
        memcpy(&id, w->b->data + off + t * TRI_BYTES + 36, 4);
        w->seen[id]++;
        for (int k = 0; k < 9; k++) {
            box->lo[k % 3] = fminf(box->lo[k % 3], v[k]);
            box->hi[k % 3] = fmaxf(box->hi[k % 3], v[k]);
        }
    }
    return count;
}

/* Builds wide8:float3 over m with the given leaf size and checks the invariants. */
static void check_conservative(const prt_mesh *m, int leaf, const char *what) {
    bvh_prim *p = mesh_prims(m);
    bvh_build_params bp = {.split = BVH_SPLIT_SAH, .max_leaf = leaf, .block = 1, .threads = 1};
    bvh_tree tree;
    CHECK_OK(bvh_build(p, m->triangle_count, &bp, &tree));
    bvh_blob blob;
    CHECK_OK(bvh_layout_wide8.encode(&tree, &bvh_codecs[BVH_CODEC_float3], m, &blob));
    CHECK_OK(bvh_layout_wide8.validate(&blob, &bvh_codecs[BVH_CODEC_float3], &(bvh_shared){0}));
    walk w = {&blob, {0}, calloc(m->triangle_count, 1), 0, 0};
    memcpy(&w.hd, blob.data, sizeof w.hd);
    prt_aabb all = prt_aabb_empty();
    size_t tris = node_bounds(&w, 0, &all);
    size_t once = 0;
    for (size_t t = 0; t < m->triangle_count; t++) once += w.seen[t] == 1;
    CHECK_MSG(w.violations == 0, "%s, leaf %d: %zu of %zu decoded planes cut into their subtree", what, leaf,
              w.violations, w.planes);
    CHECK_MSG(tris == m->triangle_count && once == m->triangle_count, "%s: %zu triangles stored, %zu of %zu once", what,
              tris, once, m->triangle_count);
    free(w.seen);
    prt__free(blob.data);
    bvh_tree_free(&tree);
    free(p);
}

TEST(test_wide8_child_boxes_contain_their_triangles) {
    prt_mesh *soup = mesh_random_soup(3000, 7), *same = mesh_same_centroid(200);
    prt_mesh *far = mesh_transformed(soup, 1.0f, 1e6f), *tiny = mesh_transformed(soup, 1e-4f, 0.0f);
    prt_mesh *tiny_far = mesh_transformed(soup, 1e-3f, -3e4f), *flat = mesh_transformed(soup, 1.0f, 0.0f);
    for (size_t i = 0; i < flat->vertex_count; i++) flat->vertices[3 * i + 2] = 0.25f; /* zero extent in z */
    const struct {
        const prt_mesh *m;
        const char *name;
    } cases[] = {{soup, "unit soup"},          {same, "same centroid"},           {far, "soup at 1e6"},
                 {tiny, "soup at 1e-4 scale"}, {tiny_far, "small soup far away"}, {flat, "flat soup"}};
    for (size_t c = 0; c < COUNT_OF(cases); c++)
        for (int leaf = 1; leaf <= 16; leaf *= 4) check_conservative(cases[c].m, leaf, cases[c].name);
    prt_mesh_free(soup), prt_mesh_free(same), prt_mesh_free(far), prt_mesh_free(tiny), prt_mesh_free(tiny_far),
        prt_mesh_free(flat);
}

/* Hits equal the double-precision brute force, away from edges, for the codecs of every
 * kernel family, on meshes whose magnitude stresses the quantization grid. */
TEST(test_wide8_far_and_tiny_meshes_hit_as_brute_force) {
    prt_mesh *soup = mesh_random_soup(2000, 11);
    prt_mesh *meshes[] = {mesh_transformed(soup, 1.0f, 1e6f), mesh_transformed(soup, 1e-4f, 0.0f),
                          mesh_transformed(soup, 1e-2f, -1e3f)};
    const char *specs[] = {"wide8:float3", "wide8:float3-soa4", "wide8:float3-soa8", "wide8:idx32-soa4"};
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++) {
        prt_ray *rays = rays_random(meshes[mi], 2000, 3 + mi);
        for (size_t s = 0; s < COUNT_OF(specs); s++) {
            prt_accel *a;
            CHECK_OK(prt_build(meshes[mi], specs[s], NULL, &a));
            if (!a) continue;
            size_t wrong = 0, compared = 0;
            for (size_t i = 0; i < 2000; i++) {
                double edge;
                prt_hit want = ref_intersect(meshes[mi], &rays[i], &edge), got;
                if (want.prim != PRT_INVALID && edge < 1e-4) continue; /* grazing an edge: either side is right */
                prt_ray r = rays[i];
                prt_intersect1(a, &r, &got);
                compared++;
                bool same_hit = got.prim == want.prim || (got.prim != PRT_INVALID && want.prim != PRT_INVALID &&
                                                          fabsf(got.t - want.t) <= 1e-6f * fabsf(want.t));
                wrong += !same_hit;
                wrong += prt_occluded1(a, &rays[i]) != (want.prim != PRT_INVALID);
            }
            CHECK_MSG(wrong == 0 && compared > 500, "%s on mesh %zu: %zu of %zu rays differ", specs[s], mi, wrong,
                      compared);
            prt_accel_free(a);
        }
        free(rays);
        prt_mesh_free(meshes[mi]);
    }
    prt_mesh_free(soup);
}

/* One leaf of 16 float3 triangles per slot fills 128 of the 255 grains a node can
 * address; the largest leaf size the spec allows must always build. */
TEST(test_wide8_largest_leaves_fit_the_meta_bits) {
    prt_mesh *soup = mesh_random_soup(5000, 5);
    const char *specs[] = {"wide8:float3,leaf=16", "wide8:idx32,leaf=16", "wide8:float3-soa4,leaf=16",
                           "wide8:float3-soa8,leaf=16", "wide8:float3,leaf=16,split=fixed"};
    for (size_t s = 0; s < COUNT_OF(specs); s++) {
        prt_accel *a = NULL;
        CHECK_OK(prt_build(soup, specs[s], NULL, &a));
        prt_accel_free(a);
    }
    prt_mesh_free(soup);
}

/* The exact slab test, in double, on slot i's box decoded as the encoder checked it
 * (fmaf(q, s, p)): whether the ray's [tnear, tfar] meets it, and where it enters. An axis
 * with a zero direction component bounds nothing when the origin lies in the slab and
 * misses otherwise. */
static bool exact_slab(const wide8_node *n, int i, const prt_ray *r, double *entry) {
    double tmin = r->tnear, tmax = r->tfar;
    for (int k = 0; k < 3; k++) {
        const float s = wide8_scale(n->e[k]);
        const double lo = fmaf((float)n->q[2 * k][i], s, n->p[k]), hi = fmaf((float)n->q[2 * k + 1][i], s, n->p[k]);
        if (r->dir[k] == 0.0f) {
            if (r->org[k] < lo || r->org[k] > hi) return false;
            continue;
        }
        double a = (lo - r->org[k]) / r->dir[k], b = (hi - r->org[k]) / r->dir[k];
        if (a > b) {
            const double x = a;
            a = b, b = x;
        }
        tmin = a > tmin ? a : tmin, tmax = b < tmax ? b : tmax;
    }
    *entry = tmin;
    return tmin <= tmax;
}

/* A coordinate near slot plane values of node n on axis k: on a plane, a few ulps off it,
 * or anywhere around the node. */
static float near_plane(prt_rng *g, const wide8_node *n, int k) {
    const float s = wide8_scale(n->e[k]);
    const float plane = fmaf((float)(prt_rng_u32(g) & 0xFF), s, n->p[k]);
    switch (prt_rng_u32(g) % 4) {
    case 0: return plane;
    case 1: return nextafterf(plane, prt_rng_u32(g) & 1 ? INFINITY : -INFINITY);
    case 2: return plane + (prt_rng_float(g) - 0.5f) * 8.0f * s;
    default: return n->p[k] + (prt_rng_float(g) * 3.0f - 1.0f) * 255.0f * s;
    }
}

/* The folded box test of the traversal (wide8_fold_hit) hits every child box the exact
 * slab test hits, and never reports an entry past the exact one, on meshes near the
 * origin, far from it (where the kernels use the decoded planes instead) and tiny, for rays from inside, on and around
 * each node's planes, with zero, tiny and ordinary direction components. */
TEST(test_wide8_folded_box_test_is_conservative) {
    prt_mesh *soup = mesh_random_soup(3000, 7);
    prt_mesh *meshes[] = {mesh_transformed(soup, 1.0f, 0.0f), mesh_transformed(soup, 1.0f, 1e6f),
                          mesh_transformed(soup, 1e-4f, 0.0f), mesh_transformed(soup, 1e-3f, -3e4f)};
    prt_rng g = prt_rng_seed(17, 3);
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++) {
        bvh_prim *p = mesh_prims(meshes[mi]);
        bvh_build_params bp = {.split = BVH_SPLIT_SAH, .max_leaf = 4, .block = 1, .threads = 1};
        bvh_tree tree;
        CHECK_OK(bvh_build(p, meshes[mi]->triangle_count, &bp, &tree));
        bvh_blob blob;
        CHECK_OK(bvh_layout_wide8.encode(&tree, &bvh_codecs[BVH_CODEC_float3], meshes[mi], &blob));
        wide8_header hd;
        memcpy(&hd, blob.data, sizeof hd);
        size_t missed = 0, late = 0, hits = 0, wrong_choice = 0;
        for (uint32_t q = 0; q < hd.nodes; q++) {
            const wide8_node *n = (const wide8_node *)(blob.data + WIDE8_HEADER_BYTES + (size_t)q * WIDE8_NODE_BYTES);
            for (int ray = 0; ray < 64; ray++) {
                prt_ray r;
                for (int k = 0; k < 3; k++) {
                    r.org[k] = near_plane(&g, n, k);
                    const uint32_t kind = prt_rng_u32(&g) % 8;
                    r.dir[k] = kind == 0   ? 0.0f
                               : kind == 1 ? (prt_rng_float(&g) - 0.5f) * 1e-6f
                                           : prt_rng_float(&g) - 0.5f;
                }
                if (r.dir[0] == 0.0f && r.dir[1] == 0.0f && r.dir[2] == 0.0f) r.dir[0] = 1.0f;
                r.tnear = prt_rng_u32(&g) & 1 ? 0.0f : -INFINITY;
                r.tfar = INFINITY;
                prt__rayx x;
                prt__rayx_init(&x, &r);
                wide8_fold f;
                /* The kernels fold only for meshes near the origin (the soups at 0). */
                const bool near_origin = mi == 0 || mi == 2;
                wide8_fold_init(&f, &x, blob.data);
                if (wide8_fold_suits(blob.data) != near_origin) wrong_choice++;
                vf8 tentry;
                const unsigned mask = wide8_fold_hit(n, &f, r.tfar, &tentry);
                const unsigned occupied = wide8_occupied(n);
                for (int i = 0; i < 8; i++) {
                    double entry;
                    if (!(occupied >> i & 1) || !exact_slab(n, i, &r, &entry)) continue;
                    hits++;
                    if (!(mask >> i & 1)) missed++;
                    else if (tentry[i] > entry) late++;
                }
            }
        }
        CHECK_MSG(missed == 0 && late == 0 && hits > 1000 && wrong_choice == 0,
                  "mesh %zu: %zu of %zu exact hits missed, %zu entered late, %zu rays chose the wrong test", mi, missed,
                  hits, late, wrong_choice);
        prt__free(blob.data);
        bvh_tree_free(&tree);
        free(p);
        prt_mesh_free(meshes[mi]);
    }
    prt_mesh_free(soup);
}

/* collapse=fill trades traversal for fewer nodes: never more nodes than the SAH's collapse
 * of the same binary tree, the same closest hits and any hits (the same triangles under a
 * differently grouped tree, exact codecs), and a saved file keeps its collapse. */
TEST(test_wide8_filled_collapse_same_hits_no_more_nodes) {
    prt_mesh *m = mesh_grid(90);
    const char *pairs[][2] = {{"wide8:float3-soa4", "wide8:float3-soa4,collapse=fill"},
                              {"wide8:idx8-soa4,leaf=12", "wide8:idx8-soa4,leaf=12,collapse=fill"}};
    prt_ray *rays = rays_random(m, 3000, 17);
    for (size_t p = 0; p < COUNT_OF(pairs); p++) {
        prt_accel *sah = NULL, *fill = NULL, *loaded = NULL;
        CHECK_OK(prt_build(m, pairs[p][0], NULL, &sah));
        CHECK_OK(prt_build(m, pairs[p][1], NULL, &fill));
        char *path = test_tmp_path("filled.prt");
        if (fill) CHECK_OK(prt_accel_save(fill, path));
        CHECK_OK(prt_accel_load(path, &loaded));
        remove(path);
        if (!sah || !fill || !loaded) {
            prt_accel_free(sah), prt_accel_free(fill), prt_accel_free(loaded);
            continue;
        }
        prt_stats a, b;
        prt_accel_stats(sah, &a), prt_accel_stats(fill, &b);
        CHECK_MSG(b.nodes <= a.nodes && b.bytes_tree <= a.bytes_tree, "%s: %zu nodes, the SAH collapse %zu",
                  pairs[p][1], (size_t)b.nodes, (size_t)a.nodes);
        CHECK_MSG(strstr(prt_accel_spec(loaded), "collapse=fill") != NULL, "loaded spec %s", prt_accel_spec(loaded));
        size_t differ = 0, hits = 0;
        for (size_t i = 0; i < 3000; i++) {
            prt_ray r1 = rays[i], r2 = rays[i], r3 = rays[i];
            prt_hit h1, h2, h3;
            prt_intersect1(sah, &r1, &h1), prt_intersect1(fill, &r2, &h2), prt_intersect1(loaded, &r3, &h3);
            hits += h1.prim != PRT_INVALID;
            differ += h1.prim != h2.prim || h1.t != h2.t || h2.prim != h3.prim || h2.t != h3.t;
            differ += prt_occluded1(sah, &rays[i]) != prt_occluded1(fill, &rays[i]);
        }
        CHECK_MSG(differ == 0 && hits > 500, "%s: %zu of 3000 rays differ (%zu hits)", pairs[p][1], differ, hits);
        prt_accel_free(sah), prt_accel_free(fill), prt_accel_free(loaded);
    }
    free(rays);
    prt_mesh_free(m);
}

/* The kernels take a leaf's grain from the codec (a constant per codec, as wide8_pack
 * chooses it), not from the blob. A blob whose header halves the grain and doubles every
 * leaf end describes the very same leaf bytes, so every other check passes, yet the
 * kernels would read each leaf at twice its offset: validation refuses it. */
TEST(test_wide8_blob_with_another_grain_is_refused) {
    prt_mesh *m = mesh_random_soup(500, 3);
    bvh_prim *p = mesh_prims(m);
    bvh_build_params bp = {.split = BVH_SPLIT_SAH, .max_leaf = 8, .block = 1, .threads = 1};
    bvh_tree tree;
    CHECK_OK(bvh_build(p, m->triangle_count, &bp, &tree));
    const bvh_codec *c = &bvh_codecs[BVH_CODEC_float3_soa4];
    bvh_blob blob;
    CHECK_OK(bvh_layout_wide8.encode(&tree, c, m, &blob));
    CHECK_OK(bvh_layout_wide8.validate(&blob, c, &(bvh_shared){0}));
    wide8_header hd;
    memcpy(&hd, blob.data, sizeof hd);
    CHECK_MSG(hd.grain == 160, "float3-soa4 leaves: 160 bytes a block, grain %u", hd.grain);
    hd.grain /= 2;
    memcpy(blob.data, &hd, sizeof hd);
    bool fits = true;
    for (uint32_t q = 0; q < hd.nodes; q++) {
        wide8_node n;
        uint8_t *at = blob.data + WIDE8_HEADER_BYTES + (size_t)q * WIDE8_NODE_BYTES;
        memcpy(&n, at, sizeof n);
        for (int i = 0; i < 8; i++) fits &= n.meta[i] < 128, n.meta[i] = (uint8_t)(2 * n.meta[i]);
        memcpy(at, &n, sizeof n);
    }
    CHECK(fits);
    CHECK(bvh_layout_wide8.validate(&blob, c, &(bvh_shared){0}) == PRT_ERROR_CORRUPT);
    prt__free(blob.data);
    bvh_tree_free(&tree);
    free(p);
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_wide8_child_boxes_contain_their_triangles);
    RUN(test_wide8_far_and_tiny_meshes_hit_as_brute_force);
    RUN(test_wide8_largest_leaves_fit_the_meta_bits);
    RUN(test_wide8_folded_box_test_is_conservative);
    RUN(test_wide8_filled_collapse_same_hits_no_more_nodes);
    RUN(test_wide8_blob_with_another_grain_is_refused);
    TEST_END();
}
