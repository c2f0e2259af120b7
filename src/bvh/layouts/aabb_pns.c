/* AABBTreePNS (Rouwé 2019, §5.3): the AABBTree's 28-byte depth-first nodes with eight
 * precomputed node-sorting bits in an inner node's properties, one per direction octant,
 * naming the child that rays of that octant visit first (Nah et al.'s precomputed node
 * sorting). The bits take offset bits: a subtree may span 32 MB at most. */
#include "bvh/layouts/aabb_node.h"

#define LAYOUT_KERNELS "bvh/layouts/aabb_pns_kernels.inc"
#include "bvh/layouts/instantiate.inc"
#undef LAYOUT_KERNELS

static prt_status aabb_pns_encode(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bvh_blob *out) {
    return bvh_aabb_encode(t, c, m, AABB_PNS, out);
}

static prt_status aabb_pns_validate(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh) {
    return bvh_aabb_validate(b, c, sh, AABB_PNS);
}

static bvh_child aabb_pns_root(const uint8_t *blob, const bvh_codec *c, const float bounds[6]) {
    (void)bounds;
    return bvh_aabb_root(blob, c, false);
}

static uint32_t aabb_pns_children(const uint8_t *blob, const bvh_codec *c, const bvh_child *node, bvh_child out[8]) {
    return bvh_aabb_children(blob, c, node, out, AABB_PNS, false, false);
}

const bvh_layout bvh_layout_aabb_pns = {
    "aabb-pns",
    "AABBTreePNS (Rouwe 5.3): AABBTree nodes with 8 precomputed node-sorting bits, children visited in the "
    "order stored for the ray's octant",
    {[BVH_CODEC_float3] = 8,
     [BVH_CODEC_float3_soa4] = 8,
     [BVH_CODEC_float3_soa8] = 8,
     [BVH_CODEC_idx32] = 8,
     [BVH_CODEC_idx32_soa4] = 8},
    aabb_pns_encode,
    aabb_pns_validate,
    {(const bvh_kernels[BVH_CODEC_COUNT]){
#define X(id, nm, desc) \
    [BVH_CODEC_##id] = {.intersect1 = aabb_pns_intersect1_##id, .occluded1 = aabb_pns_occluded1_##id},
        BVH_CODECS(X)
#undef X
    }},
    aabb_pns_root,
    aabb_pns_children,
    NULL, /* point queries: the generic walk */
};
