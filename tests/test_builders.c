/* Builders: every splitter and leaf size yields a tree that references every hittable
 * triangle exactly once, respects the leaf size, nests children inside parents and stays
 * within the traversal depth limit. */
#include "bvh/tree.h"
#include "support/meshes.h"
#include "support/prims.h"
#include "test.h"

/* Returns the number of violations found in the subtree of node i. */
static int check_node(const bvh_tree *t, const bvh_node *parent, uint32_t i, int max_leaf, uint8_t *seen,
                      const bvh_prim *orig) {
    const bvh_node *n = &t->nodes[i];
    int bad = 0;
    if (parent && !prt_aabb_contains(&parent->box, &n->box)) bad++;
    if (n->count) {
        if ((int)n->count > max_leaf) bad++;
        for (uint32_t k = 0; k < n->count; k++) {
            uint32_t id = t->prims[n->index + k];
            if (seen[id]++) bad++;
            prt_aabb pb = {{orig[id].lo[0], orig[id].lo[1], orig[id].lo[2]},
                           {orig[id].hi[0], orig[id].hi[1], orig[id].hi[2]}};
            if (!prt_aabb_contains(&n->box, &pb)) bad++;
        }
        return bad;
    }
    if (n->index + 1 >= t->node_count) return bad + 1;
    return bad + check_node(t, n, n->index, max_leaf, seen, orig) +
           check_node(t, n, n->index + 1, max_leaf, seen, orig);
}

static void check_all_splitters(const prt_mesh *m) {
    static const int leaves[] = {1, 2, 4, 8, 16};
    bvh_prim *orig = mesh_prims(m);
    for (int s = 0; s < BVH_SPLIT_COUNT; s++)
        for (size_t l = 0; l < PRT_ARRAY_SIZE(leaves); l++)
            for (int block = 1; block <= 4; block += 3) {
                bvh_prim *p = mesh_prims(m);
                bvh_build_params bp = {.split = (bvh_split)s, .max_leaf = leaves[l], .block = block};
                bvh_tree t;
                prt_status st = bvh_build(p, m->triangle_count, &bp, &t);
                CHECK_OK(st);
                if (st) continue;
                uint8_t *seen = calloc(m->triangle_count, 1);
                int bad = check_node(&t, NULL, 0, leaves[l], seen, orig);
                size_t missing = 0;
                for (size_t i = 0; i < m->triangle_count; i++) missing += seen[i] != 1;
                CHECK_MSG(bad == 0 && missing == 0, "split=%s leaf=%d block=%d: %d violations, %zu ids not seen once",
                          bvh_split_names[s], leaves[l], block, bad, missing);
                CHECK_MSG(t.depth <= BVH_MAX_DEPTH, "depth %u", t.depth);
                CHECK(t.prim_count == m->triangle_count);
                free(seen);
                bvh_tree_free(&t);
                free(p);
            }
    free(orig);
}

TEST(test_every_splitter_and_leaf_size_references_each_triangle_once) {
    prt_mesh *m = mesh_random_soup(3000, 11);
    check_all_splitters(m);
    prt_mesh_free(m);
}

TEST(test_identical_centroids_still_respect_leaf_size) {
    prt_mesh *m = mesh_same_centroid(500);
    check_all_splitters(m);
    prt_mesh_free(m);
}

TEST(test_single_triangle_tree_is_one_leaf) {
    prt_mesh *m = mesh_random_soup(1, 3);
    bvh_prim *p = mesh_prims(m);
    bvh_build_params bp = {.split = BVH_SPLIT_SAH, .max_leaf = 8, .block = 1};
    bvh_tree t;
    CHECK_OK(bvh_build(p, 1, &bp, &t));
    CHECK(t.node_count == 1 && t.nodes[0].count == 1 && t.prims[0] == 0 && t.depth == 1);
    bvh_tree_free(&t);
    free(p);
    prt_mesh_free(m);
}

TEST(test_sah_tree_is_shallower_than_linear) {
    prt_mesh *m = mesh_random_soup(20000, 5);
    bvh_prim *p = mesh_prims(m);
    bvh_build_params bp = {.split = BVH_SPLIT_SAH, .max_leaf = 4, .block = 1};
    bvh_tree t;
    CHECK_OK(bvh_build(p, m->triangle_count, &bp, &t));
    /* log2(20000/4) is about 12; a sane SAH tree over a uniform soup stays near that. */
    CHECK_MSG(t.depth < 40, "depth %u", t.depth);
    bvh_tree_free(&t);
    free(p);
    prt_mesh_free(m);
}

/* Rouwé §4.1's point of the fixed splitter: leaves hold whole groups of the block size
 * (4 for one-at-a-time codecs), all but at most one leaf, so SOA blocks need no padding. */
TEST(test_fixed_splitter_fills_whole_blocks) {
    prt_mesh *m = mesh_random_soup(5001, 17);
    static const int blocks[] = {1, 4, 8};
    static const int leaves[] = {4, 8, 16};
    for (size_t bi = 0; bi < PRT_ARRAY_SIZE(blocks); bi++)
        for (size_t li = 0; li < PRT_ARRAY_SIZE(leaves); li++) {
            const int g = PRT_MIN(blocks[bi] > 1 ? blocks[bi] : 4, leaves[li]);
            bvh_prim *p = mesh_prims(m);
            bvh_build_params bp = {.split = BVH_SPLIT_FIXED, .max_leaf = leaves[li], .block = blocks[bi]};
            bvh_tree t;
            CHECK_OK(bvh_build(p, m->triangle_count, &bp, &t));
            size_t partial = 0, leaf_count = 0;
            for (size_t i = 0; i < t.node_count; i++)
                if (t.nodes[i].count) leaf_count++, partial += t.nodes[i].count % (uint32_t)g != 0;
            CHECK_MSG(partial <= 1, "block %d leaf %d: %zu of %zu leaves hold a partial group of %d", blocks[bi],
                      leaves[li], partial, leaf_count, g);
            bvh_tree_free(&t);
            free(p);
        }
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_every_splitter_and_leaf_size_references_each_triangle_once);
    RUN(test_identical_centroids_still_respect_leaf_size);
    RUN(test_single_triangle_tree_is_one_leaf);
    RUN(test_sah_tree_is_shallower_than_linear);
    RUN(test_fixed_splitter_fills_whole_blocks);
    TEST_END();
}
