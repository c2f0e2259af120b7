/* The generic walks' view of every BVH (bvh_layout.root / children, bvh_codec.decode), for
 * every node layout, node order and collapse crossed with every codec, as built and as
 * saved and loaded: walking the whole tree and decoding every leaf gives each hit-able mesh
 * triangle exactly once (ids mapped as prt_intersect1 maps them), its vertices the mesh's
 * (lossless) or within the stated vertex error (lossy), inside the decoded box of its leaf
 * and of every ancestor; and the nearest scalar watertight hit over all decoded triangles is
 * prt_intersect1's hit bit for bit, so the decoded triangles are exactly the ones the
 * kernels test. */
#include "api/accel.h"
#include "bvh/bvh.h"
#include "bvh/codecs/strip.h"
#include "bvh/strip_leaves.h"
#include "geom/ray.h"
#include "geom/triangle.h"
#include "support/meshes.h"
#include "test.h"

/* Every layout object behind a spec: the 8 layouts, aabb's three other node orders and
 * wide8's filled collapse. */
static const char *const g_layouts[] = {
    "aabb",
    "aabb,order=df-leaves-last",
    "aabb,order=bf",
    "aabb,order=bf-leaves-last",
    "aabb-split",
    "aabb-pns",
    "aabb-compressed",
    "quad",
    "quad-half",
    "skd",
    "wide8",
    "wide8,collapse=fill",
};

#define RAYS 200

/* The decoded triangles of a whole tree, in walk order. */
typedef struct decoded {
    float *v;       /* 9 per triangle */
    uint32_t *id;   /* as decode reports it */
    uint32_t *mesh; /* mapped to the mesh */
    size_t n, cap;
    size_t leaves, outside_raw; /* vertices outside a raw (unwidened) box: lossy codecs only */
    size_t outside_bounds;      /* vertices outside the accel's bounds: lossy codecs only */
    float bounds[6];
    size_t bad_box, bad_structure;
} decoded;

/* The mesh id of a decoded id, as bvh_accel.c's bvh_name_hit maps a hit. */
static uint32_t mesh_id_of(const bvh_shared *sh, uint32_t id) {
    if (id >= sh->triangles) return id; /* a codec with an id per triangle */
    return sh->mesh_ids ? sh->mesh_ids[id] : id;
}

/* Strip codecs: r such that decoded (A, B, C) is the mesh's (v_r, v_r+1, v_r+2). */
static uint32_t strip_rotation(const bvh_shared *sh, uint32_t id) {
    return sh->data[sizeof(strip_shared_head) + id / 4] >> (2 * (id % 4)) & 3;
}

static bool inside(const float box[6], const float *p) {
    for (int k = 0; k < 3; k++)
        if (!(p[k] >= box[k] && p[k] <= box[3 + k])) return false;
    return true;
}

/* Walks node; clip is the intersection of the widened boxes of its ancestors and itself. */
static void walk(const bvh_view *w, const bvh_child *node, const float clip_in[6], decoded *d, int depth) {
    float wide[6], clip[6];
    bvh_decoded_box(w->codec, w->shared, node->box, wide);
    for (int k = 0; k < 3; k++) clip[k] = fmaxf(clip_in[k], wide[k]), clip[3 + k] = fminf(clip_in[3 + k], wide[3 + k]);
    if (depth > BVH_MAX_DEPTH + 2) {
        d->bad_structure++;
        return;
    }
    if (node->count) {
        if (node->count > BVH_MAX_LEAF) {
            d->bad_structure++;
            return;
        }
        if (d->n + BVH_DECODE_MAX > d->cap) {
            d->cap = 2 * d->cap + BVH_DECODE_MAX;
            d->v = realloc(d->v, d->cap * 9 * sizeof(float));
            d->id = realloc(d->id, d->cap * sizeof(uint32_t));
            d->mesh = realloc(d->mesh, d->cap * sizeof(uint32_t));
        }
        const uint32_t k = w->codec->decode(w->blob + node->ref, node->count, w->shared, d->v + 9 * d->n, d->id + d->n);
        if (k > node->count) d->bad_structure++;
        for (uint32_t i = 0; i < k; i++) {
            const float *t = d->v + 9 * (d->n + i);
            for (int c = 0; c < 3; c++) {
                d->bad_box += !inside(clip, t + 3 * c);
                d->outside_raw += !inside(node->box, t + 3 * c);
                d->outside_bounds += !inside(d->bounds, t + 3 * c);
            }
            d->mesh[d->n + i] = mesh_id_of(w->shared, d->id[d->n + i]);
        }
        d->n += k;
        d->leaves++;
        return;
    }
    bvh_child kids[8];
    const uint32_t n = w->layout->children(w->blob, w->codec, node, kids);
    if (n == 0 || n > 8) d->bad_structure++;
    for (uint32_t i = 0; i < n && i < 8; i++) walk(w, &kids[i], clip, d, depth + 1);
}

static void decoded_free(decoded *d) { free(d->v), free(d->id), free(d->mesh); }

static bool is_degenerate(const prt_mesh *m, size_t t) {
    const uint32_t *i = m->triangles + 3 * t;
    if (i[0] == i[1] || i[1] == i[2] || i[0] == i[2]) return true;
    double e[2][3];
    for (int k = 0; k < 3; k++)
        e[0][k] = (double)m->vertices[3 * i[1] + k] - m->vertices[3 * i[0] + k],
        e[1][k] = (double)m->vertices[3 * i[2] + k] - m->vertices[3 * i[0] + k];
    const double c[3] = {e[0][1] * e[1][2] - e[0][2] * e[1][1], e[0][2] * e[1][0] - e[0][0] * e[1][2],
                         e[0][0] * e[1][1] - e[0][1] * e[1][0]};
    return c[0] == 0 && c[1] == 0 && c[2] == 0;
}

/* (a) and (b): every hit-able triangle once, vertices as the mesh's within err. bitpack-soa4
 * may drop a triangle whose first two vertices quantize to one point (zero area, never hit). */
static void check_triangles(const char *name, const prt_mesh *m, const bvh_view *w, const decoded *d, double err,
                            bool lossless) {
    uint32_t *seen = calloc(m->triangle_count, sizeof *seen);
    size_t bad_id = 0, bad_vertex = 0, twice = 0, missing = 0;
    double worst = 0;
    for (size_t i = 0; i < d->n; i++) {
        const uint32_t id = d->mesh[i];
        if (id >= m->triangle_count) {
            bad_id++;
            continue;
        }
        twice += seen[id]++ == 1;
        const uint32_t r = w->codec->strips ? strip_rotation(w->shared, d->id[i]) : 0;
        for (int c = 0; c < 3; c++) {
            const float *want = m->vertices + 3 * (size_t)m->triangles[3 * (size_t)id + (c + r) % 3],
                        *got = d->v + 9 * i + 3 * c;
            if (lossless) {
                bad_vertex += memcmp(want, got, 12) != 0;
            } else {
                double d2 = 0;
                for (int k = 0; k < 3; k++) d2 += ((double)got[k] - want[k]) * ((double)got[k] - want[k]);
                worst = fmax(worst, sqrt(d2));
                bad_vertex += !(sqrt(d2) <= err);
            }
        }
    }
    const bool may_drop = w->codec == &bvh_codecs[BVH_CODEC_bitpack_soa4];
    for (size_t t = 0; t < m->triangle_count; t++) {
        if (seen[t] || is_degenerate(m, t)) continue;
        const uint32_t *i = m->triangles + 3 * t;
        double d2 = 0;
        for (int k = 0; k < 3; k++)
            d2 += ((double)m->vertices[3 * i[1] + k] - m->vertices[3 * i[0] + k]) *
                  ((double)m->vertices[3 * i[1] + k] - m->vertices[3 * i[0] + k]);
        missing += !(may_drop && sqrt(d2) <= 2 * err);
    }
    CHECK_MSG(bad_id == 0 && twice == 0 && missing == 0 && bad_vertex == 0,
              "%s: %zu bad ids, %zu triangles twice, %zu missing, %zu vertices off (worst %g, error %g)", name, bad_id,
              twice, missing, bad_vertex, worst, err);
    free(seen);
}

/* (d): the nearest scalar hit over every decoded triangle against prt_intersect1, bit for
 * bit: t, the mesh id (ties: the smaller), u and v (strip codecs: rotated back). */
static void check_rays(const char *name, const prt_accel *a, const bvh_view *w, const decoded *d, const prt_ray *rays,
                       int count) {
    size_t wrong = 0;
    for (int i = 0; i < count; i++) {
        prt__rayx x;
        prt__rayx_init(&x, &rays[i]);
        float best = rays[i].tfar, bu = 0, bv = 0;
        uint32_t prim = PRT_INVALID, leaf_id = 0;
        for (size_t j = 0; j < d->n; j++) {
            const float *v = d->v + 9 * j;
            float t, u, vv;
            if (prt__tri_hit(&x, v, v + 3, v + 6, best, &t, &u, &vv) && (t < best || d->mesh[j] < prim))
                best = t, bu = u, bv = vv, prim = d->mesh[j], leaf_id = d->id[j];
        }
        if (prim != PRT_INVALID && w->codec->strips) bvh_strip_rotate_uv(strip_rotation(w->shared, leaf_id), &bu, &bv);
        prt_ray r = rays[i];
        prt_hit h;
        prt_intersect1(a, &r, &h);
        const bool ok =
            prim == PRT_INVALID ? h.prim == PRT_INVALID : h.prim == prim && h.t == best && h.u == bu && h.v == bv;
        if (!ok && wrong++ < 3)
            fprintf(stderr, "  %s: ray %d: decoded %u t %a u %a v %a, intersect1 %u t %a u %a v %a\n", name, i, prim,
                    best, bu, bv, h.prim, h.t, h.u, h.v);
    }
    CHECK_MSG(wrong == 0, "%s: %zu of %d rays differ", name, wrong, count);
}

static void decode_all(const prt_accel *a, bvh_view *w, decoded *d) {
    memset(d, 0, sizeof *d);
    CHECK(bvh_accel_view(a, w));
    if (!w->layout->root || !w->layout->children || !w->codec->decode) {
        d->bad_structure++;
        return;
    }
    memcpy(d->bounds, a->bounds, sizeof d->bounds);
    const bvh_child root = w->layout->root(w->blob, w->codec, d->bounds);
    const float all[6] = {-INFINITY, -INFINITY, -INFINITY, INFINITY, INFINITY, INFINITY};
    walk(w, &root, all, d, 1);
}

/* One spec over mesh m, as built and as loaded back; adds the vertices outside a raw box
 * and outside the accel's bounds to outside[0] and [1]. */
static void check_spec(const char *spec, const prt_mesh *m, const prt_ray *rays, size_t outside[2]) {
    prt_accel *a = NULL;
    prt_status s = prt_build(m, spec, NULL, &a);
    CHECK_MSG(s == PRT_OK, "%s: %s", spec, prt_last_error());
    if (s) return;
    prt_stats st;
    prt_accel_stats(a, &st);
    bvh_view w;
    decoded d;
    decode_all(a, &w, &d);
    const bool lossless = !w.codec->vertex_error && !w.codec->leaf_error;
    CHECK_MSG(d.bad_structure == 0 && d.bad_box == 0, "%s: %zu structural faults, %zu vertices outside a box", spec,
              d.bad_structure, d.bad_box);
    check_triangles(spec, m, &w, &d, st.vertex_error, lossless);
    check_rays(spec, a, &w, &d, rays, RAYS);

    /* Saved and loaded: the same triangles in the same walk order, the same hits. */
    const char *path = test_tmp_path("walk_view.prt");
    CHECK_OK(prt_accel_save(a, path));
    prt_accel *b = NULL;
    s = prt_accel_load(path, &b);
    CHECK_MSG(s == PRT_OK, "%s loaded: %s", spec, prt_last_error());
    remove(path);
    if (!s) {
        bvh_view wl;
        decoded dl;
        decode_all(b, &wl, &dl);
        CHECK_MSG(dl.n == d.n && dl.bad_structure == 0 && dl.bad_box == 0 && !memcmp(dl.v, d.v, 36 * d.n) &&
                      !memcmp(dl.mesh, d.mesh, 4 * d.n),
                  "%s loaded: %zu triangles (built: %zu), %zu faults, decoded differently", spec, dl.n, d.n,
                  dl.bad_structure);
        check_rays(spec, b, &wl, &dl, rays, RAYS / 4); /* the same triangles: the loaded kernels */
        decoded_free(&dl);
        prt_accel_free(b);
    }
    CHECK_MSG(d.leaves == st.leaves, "%s: %zu leaves walked, %zu in the tree", spec, d.leaves, st.leaves);
    if (lossless)
        CHECK_MSG(d.outside_raw == 0 && d.outside_bounds == 0, "%s: a lossless codec's vertex lies outside its raw box",
                  spec);
    outside[0] += d.outside_raw, outside[1] += d.outside_bounds;
    decoded_free(&d);
    prt_accel_free(a);
}

/* Every spec over m (named kind in messages). */
static void check_mesh(const char *kind, const prt_mesh *m) {
    prt_ray *rays = rays_random(m, RAYS, 11);
    for (int c = 0; c < BVH_CODEC_COUNT; c++) {
        size_t outside[2] = {0, 0};
        for (size_t l = 0; l < COUNT_OF(g_layouts); l++) {
            char spec[128];
            const char *comma = strchr(g_layouts[l], ',');
            if (comma)
                snprintf(spec, sizeof spec, "%.*s:%s%s", (int)(comma - g_layouts[l]), g_layouts[l], bvh_codecs[c].name,
                         comma);
            else snprintf(spec, sizeof spec, "%s:%s", g_layouts[l], bvh_codecs[c].name);
            check_spec(spec, m, rays, outside);
        }
        if (outside[0])
            printf("  %s %s: over the %zu trees, %zu decoded vertices outside their raw box (inside the widened one), "
                   "%zu outside the accel's bounds\n",
                   kind, bvh_codecs[c].name, COUNT_OF(g_layouts), outside[0], outside[1]);
    }
    free(rays);
}

static void check_generated(const char *kind, size_t triangles) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_generate(kind, triangles, 3, &m));
    if (!m) return;
    check_mesh(kind, m);
    prt_mesh_free(m);
}

TEST(test_walk_view_decodes_every_triangle_of_a_closed_sphere) { check_generated("sphere", 1000); }

TEST(test_walk_view_decodes_every_triangle_of_a_cad_mesh) { check_generated("cad", 1000); }

/* Six triangles: most layouts' root is then a leaf (aabb, aabb-compressed, skd), or an
 * inner node over one leaf (quad, quad-half, wide8). */
TEST(test_walk_view_decodes_a_tree_of_one_leaf) {
    prt_mesh *m = mesh_random_soup(6, 5);
    check_mesh("soup", m);
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_walk_view_decodes_every_triangle_of_a_closed_sphere);
    RUN(test_walk_view_decodes_every_triangle_of_a_cad_mesh);
    RUN(test_walk_view_decodes_a_tree_of_one_leaf);
    TEST_END();
}
