/* BVH representations (Rouwé 2019): a builder's generic tree encoded by a node layout
 * with a triangle codec into one blob, traversed by the layout's kernels. The family
 * answers to "layout:codec" spec names. */
#ifndef PRT_BVH_BVH_H
#define PRT_BVH_BVH_H

#include "bvh/codecs/codec.h"
#include "bvh/tree.h"
#include "core/isa.h"

/* An encoded tree: one allocation (or a slice of a mapped file) plus its accounting. */
typedef struct bvh_blob {
    uint8_t *data;
    size_t size;
    size_t bytes_tree, bytes_geometry;
    uint64_t nodes, leaves;
    uint32_t depth;
} bvh_blob;

typedef void (*bvh_intersect_fn)(const uint8_t *blob, const bvh_shared *sh, prt_ray *r, prt_hit *h);
typedef bool (*bvh_occluded_fn)(const uint8_t *blob, const bvh_shared *sh, const prt_ray *r);
/* Closest hits of n rays, invalid ones included (a miss), as intersect1 answers each. */
typedef void (*bvh_stream_fn)(const uint8_t *blob, const bvh_shared *sh, prt_ray *rays, prt_hit *hits, size_t n);

/* Closest hits (hits) or any hits (occluded, 1 or 0) of a packet of n <= PRT_PACKET_MAX
 * coherent rays, invalid ones included (a miss), as intersect1 / occluded1 answer each. */
typedef void (*bvh_packet_fn)(const uint8_t *blob, const bvh_shared *sh, prt_ray *rays, prt_hit *hits, uint32_t n);
typedef void (*bvh_occluded_packet_fn)(const uint8_t *blob, const bvh_shared *sh, const prt_ray *rays,
                                       uint8_t *occluded, uint32_t n);

/* A layout's kernels for one codec. */
typedef struct bvh_kernels {
    bvh_intersect_fn intersect1;
    bvh_occluded_fn occluded1;
    bvh_stream_fn stream; /* NULL: intersect1 per ray; unused where packet is set */
    /* NULL, or intersect1, occluded1 and stream specialised for one blob (its other members
     * unused), chosen once when it is built, loaded or refitted rather than at every query
     * (wide8: the folded or the decoded-plane box test, wide8_fold_suits); they answer as
     * the ones above do. */
    struct bvh_kernels (*for_blob)(const uint8_t *blob);
    bvh_packet_fn packet;                   /* NULL: intersect1 per ray; else also a stream's runs */
    bvh_occluded_packet_fn occluded_packet; /* NULL: occluded1 per ray */
} bvh_kernels;

/* A node as the generic walks see it (bvh/walk.c: closest points and all crossings): its
 * box as the layout's kernels decode it, and where it lies. The box holds every vertex of
 * the tree below (the mesh's; strip's with their low bits cleared), as the kernels' boxes
 * do; a lossy codec may decode vertices just outside it, so walks test bvh_decoded_box of
 * it. children() derives boxes from node->box in some layouts (aabb-compressed, skd): pass
 * it a bvh_child exactly as root() or children() returned it, and widen a copy. */
typedef struct bvh_child {
    float box[6];   /* lo xyz, hi xyz */
    uint64_t ref;   /* an inner node's byte offset in the blob; a leaf's: where its codec block starts */
    uint32_t count; /* 0: an inner node; else a leaf, the count its kernels hand the codec */
} bvh_child;

/* box widened so that it also holds the vertices below it as codec c decodes them (shared
 * data sh), so that it bounds what c's decode returns: unchanged for lossless codecs and
 * strip (the tree is built over its decoded vertices); by the vertex error in the shared
 * data for the shared-grid codecs (idx8/idx16/idx32-bitpack-soa4: a vertex on a box face
 * moves by up to half a grid step either way); by 2^-20 of its largest coordinate for the
 * codecs with a grid per leaf or block (bitpack, bitpack-soa4, strip-bitpack), whose
 * vertices decode inside that grid's box up to a few roundings. out may be box. bvh/child.c. */
void bvh_decoded_box(const bvh_codec *c, const bvh_shared *sh, const float box[6], float out[6]);

/* The root of layouts that keep no box for it (quad, quad-half, wide8): the inner node at
 * ref, its box the union of the boxes children() gives its children. bvh/child.c. */
bvh_child bvh_child_inner_root(const uint8_t *blob, const bvh_codec *c, uint64_t ref,
                               uint32_t (*children)(const uint8_t *, const bvh_codec *, const bvh_child *,
                                                    bvh_child[8]));

struct bvh_view;
struct prt__query;

typedef struct bvh_layout {
    const char *name;
    const char *description;
    int default_leaf[BVH_CODEC_COUNT]; /* leaf size when the spec gives none (0: bvh_accel.c's rule) */
    /* Encode t with codec c over mesh m into out (out->data from prt__alloc). */
    prt_status (*encode)(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bvh_blob *out);
    /* Check a loaded blob so traversal can never leave it or loop, and every leaf with the
     * codec's leaf_valid: PRT_ERROR_CORRUPT. */
    prt_status (*validate)(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh);
    /* The kernels of every codec, per instruction set (core/isa.h): [PRT__ISA_BASE] always;
     * NULL for a set the layout is not built for, which the base ones then serve. */
    const bvh_kernels *kernels[PRT__ISA_COUNT];
    /* The tree for the generic walks, which decode nodes rather than trace them: the root
     * (a leaf when the tree is one leaf), whose box may be taken from bounds (the accel's
     * lo xyz, hi xyz) where the blob keeps none; and the up to 8 children of an inner node,
     * returned in out with their count. Both only read a validated blob. Every layout takes
     * the root box from the blob (stored, or the union of the root's child boxes) and
     * ignores bounds. */
    bvh_child (*root)(const uint8_t *blob, const bvh_codec *c, const float bounds[6]);
    uint32_t (*children)(const uint8_t *blob, const bvh_codec *c, const bvh_child *node, bvh_child out[8]);
    /* The layout's own walk for point queries (api/query.h), handing q->leaf the triangles
     * bvh_walk would or fewer; false, having done nothing, for a codec it does not serve.
     * NULL: bvh_walk's generic walk answers them. */
    bool (*point_walk)(const struct bvh_view *w, struct prt__query *q);
} bvh_layout;

/* X(id, name) */
#define BVH_LAYOUTS(X)                    \
    X(aabb, "aabb")                       \
    X(aabb_split, "aabb-split")           \
    X(quad, "quad")                       \
    X(wide8, "wide8")                     \
    X(quad_half, "quad-half")             \
    X(aabb_compressed, "aabb-compressed") \
    X(aabb_pns, "aabb-pns")               \
    X(skd, "skd")

#define X(id, nm) extern const bvh_layout bvh_layout_##id;
BVH_LAYOUTS(X)
#undef X

/* wide8 with its collapse filling nodes (the spec's collapse=fill, wide8_pack_filled). */
extern const bvh_layout bvh_layout_wide8_filled;

/* AABBTree's node orders (Rouwé §4.3), the spec's order=: the layout object for each, the
 * first being bvh_layout_aabb itself (depth first, triangles behind their leaf). */
#define BVH_ORDER_COUNT 4
extern const bvh_layout *const bvh_aabb_orders[BVH_ORDER_COUNT];
extern const char *const bvh_order_names[BVH_ORDER_COUNT];

/* What the generic walks need of a BVH accel (bvh_accel.c). */
typedef struct bvh_view {
    const bvh_layout *layout;
    const bvh_codec *codec;
    const uint8_t *blob;
    const bvh_shared *shared;
} bvh_view;

/* The view of a BVH accel; false when a is another family's. */
struct prt_accel;
bool bvh_accel_view(const struct prt_accel *a, bvh_view *out);

/* The mesh queries' walk of a BVH (bvh/walk.c, api/query.h); bounds: the accel's. */
struct prt__query;
void bvh_walk(const bvh_view *w, const float bounds[6], struct prt__query *q);

/* n triangles as w's codec decoded them (v, ids) renamed as the mesh names them: strip
 * triangles rotated back to the mesh's vertex order, leaf-order ids mapped to mesh ids
 * (bvh/walk.c). Every walk hands the queries triangles so named. */
void bvh_walk_name(const bvh_view *w, float *v, uint32_t *ids, uint32_t n);

/* Hand q the leaf of count triangles at byte ref of w's blob, decoded and named. */
void bvh_walk_leaf(const bvh_view *w, uint64_t ref, uint32_t count, struct prt__query *q);

/* Leaf counts a loaded file may claim (the spec's leaf option is at most 16). */
#define BVH_MAX_LEAF 16

#endif
