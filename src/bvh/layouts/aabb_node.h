/* The 28-byte node of Rouwé's AABBTree family (§5.1, §5.2): box min, box max, properties.
 * Shared by layouts/aabb.c (encoder, validator, AABBTree kernels) and layouts/aabb_split.c. */
#ifndef PRT_BVH_LAYOUTS_AABB_NODE_H
#define PRT_BVH_LAYOUTS_AABB_NODE_H

#include "bvh/traverse.h"

#define AABB_NODE_BYTES 28
#define AABB_LEAF 0x80000000u
/* AABBTreeSplitAxis inner nodes: split axis in bits 29..30, offset in bits 0..28. */
#define AABB_SPLIT_AXIS_SHIFT 29
#define AABB_SPLIT_OFFSET_MASK 0x1FFFFFFFu
/* AABBTreePNS inner nodes: bit o of bits 23..30 set when the second child comes first for
 * rays of direction octant o (x, y, z sign bits as bits 2, 1, 0); offset in bits 0..22. */
#define AABB_PNS_SHIFT 23
#define AABB_PNS_OFFSET_MASK 0x7FFFFFu

/* Leaves of the node orders with triangles last (aabb_order.c): count in bits 26..30,
 * the offset to the triangle block in 4-byte words in bits 0..25. */
#define AABB_TL_COUNT_SHIFT 26
#define AABB_TL_OFFSET_MASK ((1u << AABB_TL_COUNT_SHIFT) - 1)

/* The three variants that share the node and its depth-first order. */
typedef enum aabb_variant {
    AABB_PLAIN, /* AABBTree: offset in bits 0..30 */
    AABB_SPLIT, /* AABBTreeSplitAxis */
    AABB_PNS,   /* AABBTreePNS */
} aabb_variant;

/* Offset bits of an inner node's properties in variant v. */
static inline uint32_t aabb_offset_mask(aabb_variant v) {
    return v == AABB_SPLIT ? AABB_SPLIT_OFFSET_MASK : v == AABB_PNS ? AABB_PNS_OFFSET_MASK : ~AABB_LEAF;
}

static inline uint32_t aabb_props(const uint8_t *node) {
    uint32_t p;
    memcpy(&p, node + 24, 4);
    return p;
}

static inline float aabb_box_hit(const prt__rayx *r, const uint8_t *node, float tfar) {
    float b[6];
    memcpy(b, node, sizeof b);
    return prt__box_hit(r, b, b + 3, tfar);
}

/* The generic walks' view of the 28-byte nodes in every variant and node order (bf: an
 * inner node's children side by side where its properties point; tl: leaves point to
 * their triangle block behind all nodes; aabb_order.c): a node's ref is its byte offset,
 * a leaf's the offset of its triangle block, with the count its properties hold. */
bvh_child bvh_aabb_root(const uint8_t *blob, const bvh_codec *c, bool tl);
uint32_t bvh_aabb_children(const uint8_t *blob, const bvh_codec *c, const bvh_child *node, bvh_child out[8],
                           aabb_variant v, bool bf, bool tl);

/* Depth-first encoding and its structural check, for every variant. */
prt_status bvh_aabb_encode(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, aabb_variant v, bvh_blob *out);
prt_status bvh_aabb_validate(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh, aabb_variant v);

#endif
