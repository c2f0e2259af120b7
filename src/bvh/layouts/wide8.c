/* Wide8: an 8-wide BVH with quantized child boxes in 80-byte nodes (after Ylitie et al.
 * 2017; beyond Rouwé's paper). The binary tree is collapsed to up to eight children per
 * node; child boxes are stored as 8-bit offsets on a per-node power-of-two grid, rounded
 * outward, so one node costs what Rouwé's QuadTreeHalfFloat costs for four children.
 * Node format and blob layout: wide8.h; packing: wide8_pack.c. */
#include "bvh/layouts/wide8_box.h"
#include "bvh/layouts/wide8_point.h"

#include <math.h>

/* --- the codec's leaves, for wide8_pack and wide8_check ---------------------------- */

typedef struct codec_leaves {
    const bvh_codec *c;
    const prt_mesh *m;
    const bvh_shared *sh;
} codec_leaves;

static size_t codec_bytes(const void *ctx, uint32_t count) { return ((const codec_leaves *)ctx)->c->leaf_bytes(count); }

static void codec_encode(const void *ctx, uint8_t *dst, const uint32_t *prims, uint32_t count) {
    const codec_leaves *x = ctx;
    x->c->encode(dst, x->m, prims, count);
}

static bool codec_valid(const void *ctx, const uint8_t *leaf, uint32_t count) {
    const codec_leaves *x = ctx;
    return !x->c->leaf_valid || x->c->leaf_valid(leaf, count, x->sh);
}

static wide8_leaves leaves_of(const codec_leaves *x) {
    return (wide8_leaves){x->c->name,  x->c->block,  x->c->align, BVH_MAX_LEAF,
                          codec_bytes, codec_encode, codec_valid, x};
}

static prt_status wide8_encode(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bvh_blob *out) {
    codec_leaves x = {c, m, NULL};
    wide8_leaves lv = leaves_of(&x);
    return wide8_pack(t, &lv, out);
}

static prt_status wide8_encode_filled(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bvh_blob *out) {
    codec_leaves x = {c, m, NULL};
    wide8_leaves lv = leaves_of(&x);
    return wide8_pack_filled(t, &lv, out);
}

static prt_status wide8_validate(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh) {
    codec_leaves x = {c, NULL, sh};
    wide8_leaves lv = leaves_of(&x);
    return wide8_check(b, &lv);
}

/* --- the generic walks' view (bvh_layout.root / children) -------------------------- */

/* Children of the node at byte offset node->ref: boxes decoded with the kernels' fma
 * (wide8_plane); an inner child's ref its node's byte offset, a leaf's its block's, with
 * the block-padded count wide8_child_ref hands the codec. */
static uint32_t wide8_children(const uint8_t *blob, const bvh_codec *c, const bvh_child *node, bvh_child out[8]) {
    wide8_header hd;
    memcpy(&hd, blob, sizeof hd);
    wide8_node n;
    memcpy(&n, blob + node->ref, sizeof n);
    const unsigned occupied = wide8_occupied(&n);
    uint32_t count = 0;
    for (int i = 0; i < 8; i++) {
        if (!(occupied >> i & 1)) continue;
        bvh_child *o = &out[count++];
        for (int k = 0; k < 3; k++) {
            const float s = wide8_scale(n.e[k]);
            o->box[k] = fmaf((float)n.q[2 * k][i], s, n.p[k]);
            o->box[3 + k] = fmaf((float)n.q[2 * k + 1][i], s, n.p[k]);
        }
        if (n.imask >> i & 1) {
            o->ref = WIDE8_HEADER_BYTES + (uint64_t)WIDE8_NODE_BYTES * (n.child + (uint32_t)i), o->count = 0;
        } else {
            const uint32_t start = i ? n.meta[i - 1] : 0, end = n.meta[i];
            o->ref = hd.geometry + 4 * (uint64_t)n.leaf + (uint64_t)start * hd.grain;
            o->count = bvh_leaf_count_of(c, (size_t)(end - start) * hd.grain);
        }
    }
    return count;
}

/* The root node, its box the union of its decoded child boxes. */
static bvh_child wide8_root(const uint8_t *blob, const bvh_codec *c, const float bounds[6]) {
    (void)bounds;
    return bvh_child_inner_root(blob, c, WIDE8_HEADER_BYTES, wide8_children);
}

/* The layout object, and the same with the filled collapse (collapse=fill): the blobs
 * differ in their trees only, so both share validation and kernels. */
#define WIDE8_LAYOUT(encode)                                                                                        \
    {                                                                                                               \
        "wide8",                                                                                                    \
            "8-wide BVH after Ylitie et al. 2017 (beyond Rouwe): 80-byte nodes, child boxes as 8-bit offsets on a " \
            "power-of-two grid, one 8-lane box test",                                                               \
            {[BVH_CODEC_float3] = 4,                                                                                \
             [BVH_CODEC_float3_soa4] = 8,                                                                           \
             [BVH_CODEC_float3_soa8] = 16,                                                                          \
             [BVH_CODEC_idx32] = 4,                                                                                 \
             [BVH_CODEC_idx32_soa4] = 8},                                                                           \
            encode, wide8_validate, {bvh_wide8_kernels, PRT_ISA_AVX512_OF(bvh_wide8_kernels)}, wide8_root,          \
            wide8_children, wide8_point_walk,                                                                       \
    }

const bvh_layout bvh_layout_wide8 = WIDE8_LAYOUT(wide8_encode);
const bvh_layout bvh_layout_wide8_filled = WIDE8_LAYOUT(wide8_encode_filled);
