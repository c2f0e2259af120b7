/* The generic binary BVH that every builder produces and every node layout encodes
 * (the pattern of Rouwé's AABBTreeBuilder -> AABBTreeToBuffer). */
#ifndef PRT_BVH_TREE_H
#define PRT_BVH_TREE_H

#include "core/common.h"
#include "core/vec.h"

/* Trees are never deeper than this: builders switch to median splits (which halve the
 * count) long before, so traversal stacks of this size cannot overflow. */
#define BVH_MAX_DEPTH 96

/* count == 0: inner node, children at nodes[index] and nodes[index + 1].
 * count > 0: leaf holding prims[index .. index + count). */
typedef struct bvh_node {
    prt_aabb box;
    uint32_t index;
    uint32_t count;
} bvh_node;

typedef struct bvh_tree {
    bvh_node *nodes; /* nodes[0] is the root */
    size_t node_count;
    uint32_t *prims; /* primitive ids in leaf order */
    size_t prim_count;
    uint32_t depth; /* levels, the root alone is 1 */
    size_t leaf_count;
} bvh_tree;

/* Builder input record: a primitive's box and id, permuted in place by the builders.
 * 32 bytes so partitioning moves whole cache-friendly records. */
typedef struct bvh_prim {
    float lo[3];
    uint32_t id;
    float hi[3];
    uint32_t pad;
} bvh_prim;

typedef enum bvh_split {
    BVH_SPLIT_SAH,     /* binned SAH, Wald 2007 */
    BVH_SPLIT_MEAN,    /* mean of centroids on the axis of largest deviation (Rouwé §4.1) */
    BVH_SPLIT_LONGEST, /* centre of the centroid bounds on the longest axis */
    BVH_SPLIT_MORTON,  /* highest differing Morton bit (Lauterbach et al. 2009) */
    BVH_SPLIT_FIXED,   /* SAH over groups of `block` primitives (Rouwé §4.1 Fixed Leaf Size) */
    BVH_SPLIT_COUNT
} bvh_split;

extern const char *const bvh_split_names[BVH_SPLIT_COUNT];

#define BVH_SAH_MAX_BINS 128

typedef struct bvh_build_params {
    bvh_split split;
    int max_leaf; /* 1..16 primitives per leaf */
    int block;    /* primitives tested together by the codec: leaf cost is ceil(n / block) */
    int bins;     /* SAH bins per axis, at most BVH_SAH_MAX_BINS; 0: Wald's 32 */
    int threads;  /* 0: all cores */
    /* Progress callback (fraction 0..1 of primitives placed in leaves), or NULL. */
    void (*progress)(void *user, float fraction);
    void *progress_user;
    float progress_scale; /* the builder reports fraction * progress_scale */
} bvh_build_params;

/* A prim's box and id (pad cleared). */
void bvh_prim_set(bvh_prim *p, const prt_aabb *box, uint32_t id);

/* The boxes of m's triangles (ids[0 .. count) of them, or all when ids is NULL) into a new
 * array (prt__free it), leaving out exactly degenerate ones: they can never be hit. *n:
 * the prims written. */
prt_status bvh_triangle_prims(const prt_mesh *m, const uint32_t *ids, size_t count, bvh_prim **out, size_t *n);

/* As bvh_triangle_prims over all of m, but keeping the flat triangles (only those naming a
 * vertex twice are left out): a refitted tree (update=refit) keeps its triangles for every
 * frame, and a flat one may open up when its vertices move. */
prt_status bvh_triangle_prims_movable(const prt_mesh *m, bvh_prim **out, size_t *n);

/* Recompute every node's box from the triangles of m (whose indices tree->prims are)
 * bottom-up, keeping the topology: children always follow their parent in nodes[]. */
void bvh_tree_refit(bvh_tree *tree, const prt_mesh *m);

/* Build over n prims (permuted in place). On success *out owns its arrays. */
prt_status bvh_build(bvh_prim *prims, size_t n, const bvh_build_params *p, bvh_tree *out);
void bvh_tree_free(bvh_tree *t);
/* The most primitives any leaf of t holds (at least 1). */
uint32_t bvh_tree_max_leaf(const bvh_tree *t);

/* --- shared by the builder files ------------------------------------------------- */

typedef struct bvh_builder bvh_builder;

/* Partition prims[0..n) into [0, *mid) and [*mid, n). Return false to make a leaf (only
 * allowed when n <= max_leaf; the driver falls back to a median split otherwise). */
typedef bool (*bvh_split_fn)(bvh_builder *b, bvh_prim *prims, size_t n, const prt_aabb *box, const prt_aabb *cbox,
                             size_t *mid);

struct bvh_builder {
    bvh_build_params params;
    bvh_split_fn split;
    bvh_prim *base;       /* start of the whole prim array */
    const uint32_t *keys; /* per-position sort keys (Morton codes) or NULL */
    bvh_node *nodes;
    size_t node_capacity;
    _Atomic size_t node_next;
    _Atomic uint32_t depth; /* maximum */
    _Atomic size_t placed;  /* primitives in finished leaves, for progress */
    size_t total;
    size_t next_report; /* read and written by the calling thread only */
};

static inline float bvh_centroid(const bvh_prim *p, int k) { return 0.5f * (p->lo[k] + p->hi[k]); }

/* Run the recursive driver with `split` over prims; used by bvh_build's dispatch. */
prt_status bvh_build_with(bvh_builder *b, bvh_prim *prims, size_t n, bvh_tree *out);

/* Split functions, one per builder file. */
bool bvh_split_sah(bvh_builder *b, bvh_prim *prims, size_t n, const prt_aabb *box, const prt_aabb *cbox, size_t *mid);
bool bvh_split_mean(bvh_builder *b, bvh_prim *prims, size_t n, const prt_aabb *box, const prt_aabb *cbox, size_t *mid);
bool bvh_split_longest(bvh_builder *b, bvh_prim *prims, size_t n, const prt_aabb *box, const prt_aabb *cbox,
                       size_t *mid);
bool bvh_split_morton(bvh_builder *b, bvh_prim *prims, size_t n, const prt_aabb *box, const prt_aabb *cbox,
                      size_t *mid);

/* The binned SAH split, also naming the axis it partitioned along (centroids of
 * prims[0..mid) lie below those of prims[mid..n) on it). */
bool bvh_split_sah_axis(bvh_builder *b, bvh_prim *prims, size_t n, const prt_aabb *box, const prt_aabb *cbox,
                        size_t *mid, int *axis);

/* Sort prims by the Morton code of their centroid; returns the codes (prt__free them). */
uint32_t *bvh_morton_sort(bvh_prim *prims, size_t n, const prt_aabb *cbox, int threads);

/* Fixed leaf size: binned SAH with every split rounded to a multiple of the block
 * (builders/fixed_leaf.c). */
prt_status bvh_build_fixed(bvh_builder *b, bvh_prim *prims, size_t n, bvh_tree *out);

/* Partition by predicate "centroid[axis] < pos"; returns the split index. */
size_t bvh_partition(bvh_prim *prims, size_t n, int axis, float pos);

#endif
