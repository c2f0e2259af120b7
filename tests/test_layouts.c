/* Invariants of the node layouts of Rouwé §5.3-5.7 (quad-half, aabb-compressed,
 * aabb-pns, skd): every child box, decoded exactly as traversal decodes it, contains every vertex
 * of every triangle below that child whatever the coordinates' magnitude; half floats
 * round in the direction asked; meshes far from the origin or at tiny scale give exactly
 * the brute-force hits; AABBTreePNS reports the subtrees its offset bits cannot reach; the
 * node orders of §4.3 answer exactly as depth first and refuse trees that loop. */
#include "bvh/bvh.h"
#include "bvh/layouts/aabb_node.h"
#include "bvh/layouts/layout_debug.h"
#include "bvh/layouts/quad_half.h"
#include "core/rng.h"
#include "support/meshes.h"
#include "support/prims.h"
#include "support/reference.h"
#include "test.h"

/* --- half floats ---------------------------------------------------------------------- */

/* The exact value of a half given by sign, biased exponent and mantissa, computed from
 * the IEEE definition rather than from bits. */
static double half_value(int sign, int e, int m) {
    double v = e == 0 ? ldexp(m, -24) : ldexp(1024 + m, e - 25);
    return sign ? -v : v;
}

TEST(test_half_to_float_is_exact_for_every_finite_half) {
    size_t wrong = 0;
    for (uint32_t h = 0; h < 65536; h++) {
        int e = (h >> 10) & 31;
        if (e == 31) continue;
        wrong += (double)qh_half_to_float((uint16_t)h) != half_value(h >> 15, e, h & 0x3FF);
    }
    CHECK_MSG(wrong == 0, "%zu halves decode wrongly", wrong);
    CHECK(qh_half_to_float(QH_HALF_POS_INF) == INFINITY && qh_half_to_float(QH_HALF_NEG_INF) == -INFINITY);
    CHECK(isnan(qh_half_to_float(0x7E00)) && qh_half_is_nan(0x7E00) && !qh_half_is_nan(QH_HALF_POS_INF));
}

/* Hand-made values: exact ones stay, the others go to the neighbour on the asked side,
 * beyond the range to 65504 or infinity, below it to zero or the smallest subnormal. */
TEST(test_half_rounding_goes_in_the_asked_direction) {
    const struct {
        float x;
        double down, up;
    } cases[] = {
        {1.0f, 1.0, 1.0},
        {1.0f + 0x1p-11f, 1.0, 1.0 + 0x1p-10},
        {-1.0f - 0x1p-11f, -1.0 - 0x1p-10, -1.0},
        {0.1f, 0.0999755859375, 0.10003662109375},
        {-0.1f, -0.10003662109375, -0.0999755859375},
        {65504.0f, 65504.0, 65504.0},
        {65505.0f, 65504.0, INFINITY},
        {1e6f, 65504.0, INFINITY},
        {-1e6f, -INFINITY, -65504.0},
        {INFINITY, INFINITY, INFINITY},
        {-INFINITY, -INFINITY, -INFINITY},
        {0x1p-14f, 0x1p-14, 0x1p-14},                      /* smallest normal */
        {0x1p-14f + 0x1p-25f, 0x1p-14, 0x1p-14 + 0x1p-24}, /* between normals at the bottom */
        {3 * 0x1p-25f, 0x1p-24, 0x1p-23},                  /* between subnormals */
        {1e-8f, 0.0, 0x1p-24},                             /* below the smallest subnormal */
        {-1e-8f, -0x1p-24, 0.0},
        {0.0f, 0.0, 0.0},
        {2049.0f, 2048.0, 2050.0}, /* halves are 2 apart above 2048 */
    };
    for (size_t i = 0; i < COUNT_OF(cases); i++) {
        double down = qh_half_to_float(qh_half_round(cases[i].x, false));
        double up = qh_half_to_float(qh_half_round(cases[i].x, true));
        CHECK_MSG(down == cases[i].down && up == cases[i].up, "%a: down %a (want %a), up %a (want %a)", cases[i].x,
                  down, cases[i].down, up, cases[i].up);
    }
}

/* On random floats of every magnitude: down <= x <= up, and no half lies strictly
 * between (the next half past each is on the other side of x). */
TEST(test_half_rounding_is_tight_and_conservative_at_every_magnitude) {
    prt_rng rng = prt_rng_seed(5, 1);
    size_t bad = 0;
    for (int i = 0; i < 200000; i++) {
        float x = ldexpf(prt_rng_float(&rng) * 2 - 1, (int)(prt_rng_float(&rng) * 60) - 40);
        uint16_t d = qh_half_round(x, false), u = qh_half_round(x, true);
        float fd = qh_half_to_float(d), fu = qh_half_to_float(u);
        bad += !(fd <= x && fu >= x);
        bad += fd < x && !(qh_half_to_float(qh_half_next(d, true)) > x);
        bad += fu > x && !(qh_half_to_float(qh_half_next(u, false)) < x);
#if defined(__F16C__) /* the hardware's directed rounding agrees bit for bit */
        const __m128 v = _mm_set_ss(x);
        bad += (uint16_t)_mm_extract_epi16(_mm_cvtps_ph(v, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC), 0) != d;
        bad += (uint16_t)_mm_extract_epi16(_mm_cvtps_ph(v, _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC), 0) != u;
#endif
    }
    CHECK_MSG(bad == 0, "%zu roundings are not the neighbouring half on the asked side", bad);
}

/* --- conservative boxes --------------------------------------------------------------- */

/* float3 leaves hold 9 floats and an id (40 bytes each): the walk grows the box by them
 * and counts each triangle it meets. */
typedef struct leaves {
    uint8_t *seen; /* per mesh triangle */
} leaves;

static void float3_leaf_bounds(void *user, const uint8_t *leaf, uint32_t count, prt_aabb *box) {
    leaves *l = user;
    for (uint32_t t = 0; t < count; t++, leaf += 40) {
        float v[9];
        uint32_t id;
        memcpy(v, leaf, sizeof v);
        memcpy(&id, leaf + 36, 4);
        l->seen[id]++;
        for (int k = 0; k < 3; k++) prt_aabb_grow_point(box, v + 3 * k);
    }
}

typedef void (*debug_fn)(const bvh_blob *, const bvh_codec *, bvh_debug_leaf_fn, void *, bvh_debug_boxes *);

static const struct {
    const bvh_layout *layout;
    debug_fn walk;
} quantized[] = {
    {&bvh_layout_quad_half, bvh_quad_half_debug_boxes},
    {&bvh_layout_aabb_compressed, bvh_aabb_compressed_debug_boxes},
    {&bvh_layout_skd, bvh_skd_debug_boxes},
};

/* Builds layout:float3 over m with the given leaf size and checks every decoded box. */
static void check_conservative(const bvh_layout *layout, debug_fn walk, const prt_mesh *m, int leaf, const char *what) {
    bvh_prim *p = mesh_prims(m);
    bvh_build_params bp = {.split = BVH_SPLIT_SAH, .max_leaf = leaf, .block = 1, .threads = 1};
    bvh_tree tree;
    CHECK_OK(bvh_build(p, m->triangle_count, &bp, &tree));
    bvh_blob blob;
    const bvh_codec *c = &bvh_codecs[BVH_CODEC_float3];
    CHECK_OK(layout->encode(&tree, c, m, &blob));
    CHECK_OK(layout->validate(&blob, c, &(bvh_shared){0}));
    leaves l = {calloc(m->triangle_count, 1)};
    bvh_debug_boxes d;
    walk(&blob, c, float3_leaf_bounds, &l, &d);
    size_t once = 0;
    for (size_t t = 0; t < m->triangle_count; t++) once += l.seen[t] == 1;
    CHECK_MSG(d.violations == 0 && d.boxes > 0, "%s, %s, leaf %d: %zu of %zu decoded boxes cut into their subtree",
              layout->name, what, leaf, d.violations, d.boxes);
    CHECK_MSG(d.triangles == m->triangle_count && once == m->triangle_count,
              "%s, %s: %zu triangles stored, %zu of %zu once", layout->name, what, d.triangles, once,
              m->triangle_count);
    free(l.seen);
    prt__free(blob.data);
    bvh_tree_free(&tree);
    free(p);
}

TEST(test_quantized_child_boxes_contain_their_triangles) {
    prt_mesh *soup = mesh_random_soup(3000, 7), *same = mesh_same_centroid(200);
    prt_mesh *far = mesh_transformed(soup, 1.0f, 1e6f), *tiny = mesh_transformed(soup, 1e-4f, 0.0f);
    prt_mesh *tiny_far = mesh_transformed(soup, 1e-3f, -3e4f), *flat = mesh_transformed(soup, 1.0f, 0.0f);
    prt_mesh *huge = mesh_transformed(soup, 1e5f, 0.0f), *micro = mesh_transformed(soup, 1e-6f, 1e-6f);
    for (size_t i = 0; i < flat->vertex_count; i++) flat->vertices[3 * i + 2] = 0.25f; /* zero extent in z */
    const struct {
        const prt_mesh *m;
        const char *name;
    } cases[] = {{soup, "unit soup"},          {same, "same centroid"},           {far, "soup at 1e6"},
                 {tiny, "soup at 1e-4 scale"}, {tiny_far, "small soup far away"}, {flat, "flat soup"},
                 {huge, "soup at 1e5 scale"},  {micro, "soup at 1e-6 scale"}};
    for (size_t q = 0; q < COUNT_OF(quantized); q++)
        for (size_t c = 0; c < COUNT_OF(cases); c++)
            for (int leaf = 1; leaf <= 16; leaf *= 4)
                check_conservative(quantized[q].layout, quantized[q].walk, cases[c].m, leaf, cases[c].name);
    prt_mesh_free(soup), prt_mesh_free(same), prt_mesh_free(far), prt_mesh_free(tiny), prt_mesh_free(tiny_far),
        prt_mesh_free(flat), prt_mesh_free(huge), prt_mesh_free(micro);
}

/* --- hits at any magnitude ------------------------------------------------------------ */

/* Hits equal the double-precision brute force, away from edges, for the codecs of every
 * kernel family, on meshes whose magnitude stresses quantized boxes. */
TEST(test_far_and_tiny_meshes_hit_as_brute_force) {
    prt_mesh *soup = mesh_random_soup(2000, 11);
    prt_mesh *meshes[] = {mesh_transformed(soup, 1.0f, 1e6f), mesh_transformed(soup, 1e-4f, 0.0f),
                          mesh_transformed(soup, 1e-2f, -1e3f)};
    const char *layouts[] = {"quad-half", "aabb-compressed", "aabb-pns", "skd"};
    const char *codecs[] = {"float3", "float3-soa4", "float3-soa8", "idx32-soa4"};
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++) {
        prt_ray *rays = rays_random(meshes[mi], 2000, 3 + mi);
        prt_hit *want = malloc(2000 * sizeof *want);
        double *edge = malloc(2000 * sizeof *edge);
        for (size_t i = 0; i < 2000; i++) want[i] = ref_intersect(meshes[mi], &rays[i], &edge[i]);
        for (size_t li = 0; li < COUNT_OF(layouts); li++)
            for (size_t ci = 0; ci < COUNT_OF(codecs); ci++) {
                char spec[64];
                snprintf(spec, sizeof spec, "%s:%s", layouts[li], codecs[ci]);
                prt_accel *a = NULL;
                CHECK_OK(prt_build(meshes[mi], spec, NULL, &a));
                if (!a) continue;
                size_t wrong = 0, compared = 0;
                for (size_t i = 0; i < 2000; i++) {
                    if (want[i].prim != PRT_INVALID && edge[i] < 1e-4) continue; /* grazing an edge: either side */
                    prt_ray r = rays[i];
                    prt_hit got;
                    prt_intersect1(a, &r, &got);
                    compared++;
                    bool same_hit =
                        got.prim == want[i].prim || (got.prim != PRT_INVALID && want[i].prim != PRT_INVALID &&
                                                     fabsf(got.t - want[i].t) <= 1e-6f * fabsf(want[i].t));
                    wrong += !same_hit;
                    wrong += prt_occluded1(a, &rays[i]) != (want[i].prim != PRT_INVALID);
                }
                CHECK_MSG(wrong == 0 && compared > 500, "%s on mesh %zu: %zu of %zu rays differ", spec, mi, wrong,
                          compared);
                prt_accel_free(a);
            }
        free(rays), free(want), free(edge);
        prt_mesh_free(meshes[mi]);
    }
    prt_mesh_free(soup);
}

/* --- offsets that do not fit ---------------------------------------------------------- */

/* A codec whose leaves are 2 MB per triangle and hold nothing: trees far past 32 MB
 * without writing (or touching) their memory. */
static size_t huge_leaf_bytes(uint32_t n) { return (size_t)n << 21; }
static void huge_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    (void)dst, (void)m, (void)ids, (void)n;
}

/* AABBTreePNS keeps 23 offset bits beside its 8 PNS bits (32 MB): a larger subtree is a
 * PRT_ERROR_LIMIT that says so, where the AABBTree's 31 bits still fit. */
TEST(test_aabb_pns_reports_subtrees_beyond_its_offset_bits) {
    prt_mesh *m = mesh_random_soup(64, 3);
    bvh_prim *p = mesh_prims(m);
    bvh_build_params bp = {.split = BVH_SPLIT_SAH, .max_leaf = 1, .block = 1, .threads = 1};
    bvh_tree tree;
    CHECK_OK(bvh_build(p, m->triangle_count, &bp, &tree));
    const bvh_codec huge = {.name = "huge",
                            .description = "",
                            .block = 1,
                            .align = 4,
                            .leaf_bytes = huge_leaf_bytes,
                            .encode = huge_encode};
    bvh_blob blob;
    prt_status s = bvh_aabb_encode(&tree, &huge, m, AABB_PNS, &blob);
    CHECK_MSG(s == PRT_ERROR_LIMIT && strstr(prt_last_error(), "PNS") && strstr(prt_last_error(), "offset bits"),
              "aabb-pns over a 128 MB tree: %s: %s", prt_status_string(s), prt_last_error());
    CHECK_OK(bvh_aabb_encode(&tree, &huge, m, AABB_PLAIN, &blob));
    prt__free(blob.data);
    bvh_tree_free(&tree);
    free(p);
    prt_mesh_free(m);
}

/* --- node orders (§4.3) ---------------------------------------------------------------- */

/* The same tree in another order, traversed by the same box and triangle tests: the same
 * hits bit for bit, the same bytes, and a save and load that keeps the order. */
TEST(test_aabb_node_orders_answer_as_depth_first) {
    prt_mesh *meshes[] = {mesh_random_soup(3000, 41), mesh_grid(50)};
    const char *codecs[] = {"float3", "float3-soa8", "idx8-soa4", "bitpack-soa4", "strip"};
    const char *path = "packrt_test_orders.prt";
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++) {
        prt_ray *rays = rays_random(meshes[mi], 3000, 42);
        for (size_t ci = 0; ci < COUNT_OF(codecs); ci++) {
            char spec[96];
            snprintf(spec, sizeof spec, "aabb:%s", codecs[ci]);
            prt_accel *df;
            CHECK_OK(prt_build(meshes[mi], spec, NULL, &df));
            prt_stats sd;
            prt_accel_stats(df, &sd);
            for (int o = 1; o < BVH_ORDER_COUNT; o++) {
                snprintf(spec, sizeof spec, "aabb:%s,order=%s", codecs[ci], bvh_order_names[o]);
                prt_accel *a = NULL, *b = NULL;
                CHECK_OK(prt_build(meshes[mi], spec, NULL, &a));
                CHECK(a && strstr(prt_accel_spec(a), bvh_order_names[o]));
                if (a) CHECK_OK(prt_accel_save(a, path));
                if (a) CHECK_OK(prt_accel_load(path, &b));
                remove(path);
                prt_stats st;
                if (a) prt_accel_stats(a, &st);
                CHECK(a && st.bytes_tree == sd.bytes_tree && st.bytes_geometry == sd.bytes_geometry);
                size_t differ = 0;
                for (size_t i = 0; a && b && i < 3000; i++) {
                    prt_ray r0 = rays[i], r1 = rays[i], r2 = rays[i];
                    prt_hit h0, h1, h2;
                    prt_intersect1(df, &r0, &h0), prt_intersect1(a, &r1, &h1), prt_intersect1(b, &r2, &h2);
                    differ += memcmp(&h0, &h1, sizeof h0) != 0 || memcmp(&h0, &h2, sizeof h0) != 0;
                    differ += prt_occluded1(df, &rays[i]) != prt_occluded1(a, &rays[i]);
                }
                CHECK_MSG(differ == 0, "mesh %zu, %s: %zu rays differ from depth first", mi, spec, differ);
                prt_accel_free(a), prt_accel_free(b);
            }
            prt_accel_free(df);
        }
        free(rays);
    }
    prt_accel *a = NULL;
    CHECK(prt_build(meshes[0], "quad:float3,order=bf", NULL, &a) == PRT_ERROR_ARGUMENT && !a);
    CHECK(prt_build(meshes[0], "aabb:float3,order=veb", NULL, &a) == PRT_ERROR_ARGUMENT && !a);
    for (size_t mi = 0; mi < COUNT_OF(meshes); mi++) prt_mesh_free(meshes[mi]);
}

/* A breadth-first tree whose inner node points at itself, or at a node already reached,
 * would make traversal loop: the check refuses it. Three nodes, leaves last: a root and
 * two leaves that share one float3 triangle block after them. */
static uint32_t tl_leaf(size_t node, size_t block) {
    return AABB_LEAF | 1u << AABB_TL_COUNT_SHIFT | (uint32_t)((block - node) / 4);
}

TEST(test_aabb_node_orders_refuse_loops) {
    enum { N = AABB_NODE_BYTES, BLOCK = 3 * AABB_NODE_BYTES };
    uint8_t blob[3 * AABB_NODE_BYTES + 40] = {0};
    const float box[6] = {0, 0, 0, 1, 1, 1};
    for (int i = 0; i < 3; i++) memcpy(blob + i * N, box, sizeof box);
    const uint32_t children = N / 4, l1 = tl_leaf(N, BLOCK), l2 = tl_leaf(2 * N, BLOCK), self = 0;
    memcpy(blob + 24, &children, 4);
    memcpy(blob + N + 24, &l1, 4);
    memcpy(blob + 2 * N + 24, &l2, 4);
    const bvh_codec *c = &bvh_codecs[BVH_CODEC_float3];
    const bvh_shared sh = {0};
    bvh_blob b = {blob, sizeof blob, 3 * N, 40, 3, 2, 2};
    CHECK_OK(bvh_aabb_orders[3]->validate(&b, c, &sh));
    memcpy(blob + 24, &self, 4); /* the root's children: the root itself and the next node */
    CHECK(bvh_aabb_orders[3]->validate(&b, c, &sh) == PRT_ERROR_CORRUPT);
    memcpy(blob + 24, &children, 4);
    memcpy(blob + N + 24, &self, 4); /* the first child, now inner, has the root's offset 0: itself */
    CHECK(bvh_aabb_orders[3]->validate(&b, c, &sh) == PRT_ERROR_CORRUPT);
    memcpy(blob + N + 24, &l1, 4);
    const uint32_t past = tl_leaf(2 * N, BLOCK + 4); /* a block reaching past the blob */
    memcpy(blob + 2 * N + 24, &past, 4);
    CHECK(bvh_aabb_orders[3]->validate(&b, c, &sh) == PRT_ERROR_CORRUPT);
}

int main(void) {
    RUN(test_half_to_float_is_exact_for_every_finite_half);
    RUN(test_half_rounding_goes_in_the_asked_direction);
    RUN(test_half_rounding_is_tight_and_conservative_at_every_magnitude);
    RUN(test_quantized_child_boxes_contain_their_triangles);
    RUN(test_far_and_tiny_meshes_hit_as_brute_force);
    RUN(test_aabb_pns_reports_subtrees_beyond_its_offset_bits);
    RUN(test_aabb_node_orders_answer_as_depth_first);
    RUN(test_aabb_node_orders_refuse_loops);
    TEST_END();
}
