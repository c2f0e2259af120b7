/* AABBTreeSplitAxis (Rouwé 2019, §5.2): the AABBTree's 28-byte depth-first nodes, with
 * the split axis in two bits of an inner node's properties and the child lower along that
 * axis stored first, so each ray visits the child facing it first without testing boxes. */
#include "bvh/layouts/aabb_node.h"

#define LAYOUT_KERNELS "bvh/layouts/aabb_split_kernels.inc"
#include "bvh/layouts/instantiate.inc"
#undef LAYOUT_KERNELS

static prt_status aabb_split_encode(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bvh_blob *out) {
    return bvh_aabb_encode(t, c, m, AABB_SPLIT, out);
}

static prt_status aabb_split_validate(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh) {
    return bvh_aabb_validate(b, c, sh, AABB_SPLIT);
}

static bvh_child aabb_split_root(const uint8_t *blob, const bvh_codec *c, const float bounds[6]) {
    (void)bounds;
    return bvh_aabb_root(blob, c, false);
}

static uint32_t aabb_split_children(const uint8_t *blob, const bvh_codec *c, const bvh_child *node, bvh_child out[8]) {
    return bvh_aabb_children(blob, c, node, out, AABB_SPLIT, false, false);
}

const bvh_layout bvh_layout_aabb_split = {
    "aabb-split",
    "AABBTreeSplitAxis (Rouwe 5.2): AABBTree nodes with the split axis, children visited in ray order",
    {[BVH_CODEC_float3] = 8,
     [BVH_CODEC_float3_soa4] = 8,
     [BVH_CODEC_float3_soa8] = 8,
     [BVH_CODEC_idx32] = 8,
     [BVH_CODEC_idx32_soa4] = 8},
    aabb_split_encode,
    aabb_split_validate,
    {(const bvh_kernels[BVH_CODEC_COUNT]){
#define X(id, nm, desc) \
    [BVH_CODEC_##id] = {.intersect1 = aabb_split_intersect1_##id, .occluded1 = aabb_split_occluded1_##id},
        BVH_CODECS(X)
#undef X
    }},
    aabb_split_root,
    aabb_split_children,
    NULL, /* point queries: the generic walk */
};
