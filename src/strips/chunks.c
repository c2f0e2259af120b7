/* The high level of Ray-Strips (Lauterbach et al. 2007, §3.3.1, §4.2): a SAH BVH over the
 * mesh's triangles, cut where a subtree holds at most the chunk threshold, gives the
 * chunks of spatially close (and, on connected meshes, connected) triangles that are
 * stripified one by one. */
#include "mesh/mesh.h"
#include "strips/strips.h"

typedef struct cutter {
    const bvh_tree *t;
    uint32_t max_chunk;
    uint32_t *first;
    size_t count;
} cutter;

/* The prims range of binary node i (subtrees are contiguous in leaf order); records the
 * ranges of the highest subtrees within the threshold as chunks. */
static void cut(cutter *c, uint32_t i, size_t *lo, size_t *hi) {
    const bvh_node *n = &c->t->nodes[i];
    if (n->count) {
        *lo = n->index, *hi = (size_t)n->index + n->count;
    } else {
        size_t l0, l1, r0, r1;
        size_t mark = c->count;
        cut(c, n->index, &l0, &l1);
        cut(c, n->index + 1, &r0, &r1);
        *lo = l0 < r0 ? l0 : r0, *hi = l1 > r1 ? l1 : r1;
        if (*hi - *lo > c->max_chunk) return;
        c->count = mark; /* the children's chunks merge into this node's */
    }
    if (*hi - *lo <= c->max_chunk) c->first[c->count++] = (uint32_t)*lo;
}

prt_status rs_chunks(const prt_mesh *m, uint32_t max_chunk, int threads, uint32_t **tris, size_t *tri_count,
                     uint32_t **first, size_t *chunk_count) {
    *tris = NULL, *first = NULL, *tri_count = 0, *chunk_count = 0;
    bvh_prim *prims;
    size_t n;
    prt_status s = bvh_triangle_prims(m, NULL, 0, &prims, &n);
    if (s) return s;
    bvh_build_params p = {
        .split = BVH_SPLIT_SAH, .max_leaf = max_chunk < 16 ? (int)max_chunk : 16, .block = 1, .threads = threads};
    bvh_tree tree;
    s = bvh_build(prims, n, &p, &tree);
    prt__free(prims);
    if (s) return s;
    cutter c = {&tree, max_chunk, prt__alloc(prt__mul_size(n + 1, sizeof(uint32_t))), 0};
    if (!c.first) {
        bvh_tree_free(&tree);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for chunks");
    }
    size_t lo, hi;
    cut(&c, 0, &lo, &hi);
    c.first[c.count] = (uint32_t)n;
    *tris = tree.prims; /* leaf order: chunks are consecutive runs of it */
    tree.prims = NULL;
    bvh_tree_free(&tree);
    *tri_count = n;
    *first = c.first;
    *chunk_count = c.count;
    return PRT_OK;
}
