/* Test-only walks over encoded trees whose boxes are quantized (quad-half,
 * aabb-compressed, skd): every child's box as traversal decodes it is compared with the
 * true bounds of the triangles below it. The layouts cannot read a codec's leaves, so the
 * caller grows a box by the triangles of one leaf. */
#ifndef PRT_BVH_LAYOUTS_LAYOUT_DEBUG_H
#define PRT_BVH_LAYOUTS_LAYOUT_DEBUG_H

#include "bvh/bvh.h"
#include "core/vec.h"

/* Grow box by every vertex of the count triangles of the leaf block at leaf. */
typedef void (*bvh_debug_leaf_fn)(void *user, const uint8_t *leaf, uint32_t count, prt_aabb *box);

typedef struct bvh_debug_boxes {
    size_t boxes;      /* decoded child boxes (or half spaces) compared */
    size_t violations; /* of them, those that cut into their subtree's true bounds */
    size_t triangles;  /* triangles reached (leaf counts summed) */
} bvh_debug_boxes;

void bvh_quad_half_debug_boxes(const bvh_blob *b, const bvh_codec *c, bvh_debug_leaf_fn leaf, void *user,
                               bvh_debug_boxes *out);
void bvh_aabb_compressed_debug_boxes(const bvh_blob *b, const bvh_codec *c, bvh_debug_leaf_fn leaf, void *user,
                                     bvh_debug_boxes *out);
void bvh_skd_debug_boxes(const bvh_blob *b, const bvh_codec *c, bvh_debug_leaf_fn leaf, void *user,
                         bvh_debug_boxes *out);

#endif
