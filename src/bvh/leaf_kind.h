/* Leaves that hold something other than a run of triangles (Rouwé's strips, §3.10): the
 * small interface through which the BVH family (bvh_accel.c) builds, loads and describes
 * them, so it holds no case for any one kind. A codec names its kind in codec.h's
 * BVH_KIND_CODECS list as <id>_leaf_kind; the strip codecs' kinds are bvh/strip_leaves.c. */
#ifndef PRT_BVH_LEAF_KIND_H
#define PRT_BVH_LEAF_KIND_H

#include "bvh/bvh.h"

typedef struct bvh_leaf_kind {
    const char *name; /* what the leaves hold, for messages: "strip entries" */
    /* Entries tested together: the builder's block and the default leaf size. */
    int block;
    /* The vertices the codec stores exactly, in a copy of m (the caller prt__frees
     * out->vertices; the triangles stay m's), and the largest distance that moved a
     * vertex; the tree is built over them. NULL: m as it is. */
    prt_status (*prepare)(const prt_mesh *m, prt_mesh *out, float *error);
    /* Rewrite the tree's leaves (over lm, the mesh in leaf order; ids: the mesh id of each
     * leaf-order triangle, or NULL; both follow any renumbering) into entries, encode them
     * with layout l and codec c into blob, and make sh's data (prt__alloc'ed; sh->triangles
     * is set) with its rotations. error: what prepare moved a vertex. The tree keeps no
     * triangles afterwards, so these leaves cannot be refitted. */
    prt_status (*encode)(const bvh_layout *l, const bvh_codec *c, bvh_tree *tree, prt_mesh *lm, uint32_t *ids,
                         float error, bvh_blob *blob, bvh_shared *sh);
    /* Loading: check sh's data (from a file) for sh->triangles leaf-order triangles and
     * point sh->rotations into it; PRT_ERROR_CORRUPT when it is inconsistent. */
    prt_status (*load_shared)(bvh_shared *sh);
    /* A line for prt_stats.detail. */
    void (*detail)(const bvh_shared *sh, char *text, size_t size);
} bvh_leaf_kind;

#endif
