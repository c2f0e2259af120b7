/* AABBTree (Rouwé 2019, §5.1): 28-byte nodes (box min, box max, properties) written depth
 * first. A leaf's triangle block follows its node; an inner node's first child follows it
 * and its properties hold the distance to the second child in 4-byte words. */
#include "bvh/layouts/aabb_node.h"

#define LAYOUT_KERNELS "bvh/layouts/aabb_kernels.inc"
#include "bvh/layouts/instantiate.inc"
#undef LAYOUT_KERNELS

typedef struct encoder {
    const bvh_tree *t;
    const bvh_codec *c;
    const prt_mesh *m;
    uint8_t *out;
    size_t size;
    aabb_variant v;
} encoder;

/* The axis along which two sibling boxes' centres differ most, and whether the first
 * (index) child lies above the second on it. */
static int split_axis_of(const bvh_node *a, const bvh_node *b, bool *swap) {
    int axis = 0;
    float best = -1;
    for (int k = 0; k < 3; k++) {
        float d = (a->box.lo[k] + a->box.hi[k]) - (b->box.lo[k] + b->box.hi[k]);
        if (fabsf(d) > best) best = fabsf(d), axis = k;
    }
    *swap = (a->box.lo[axis] + a->box.hi[axis]) > (b->box.lo[axis] + b->box.hi[axis]);
    return axis;
}

/* AABBTreePNS (Rouwé §5.3, precomputed node sorting): for each of the eight direction
 * octants (x, y, z sign bits as bits 2, 1, 0), whether rays of that octant should visit
 * the second child first: the children's centres are compared along 27 directions spread
 * over the octant and the majority decides (on the bunny, 2% fewer instructions per ray
 * than AABBTreeSplitAxis's one axis per node). */
static uint32_t pns_bits(const bvh_node *a, const bvh_node *b) {
    static const float w[3] = {0.2f, 0.5f, 1.0f};
    float c[3];
    for (int k = 0; k < 3; k++) c[k] = (b->box.lo[k] + b->box.hi[k]) - (a->box.lo[k] + a->box.hi[k]);
    uint32_t bits = 0;
    for (uint32_t o = 0; o < 8; o++) {
        const float s[3] = {o & 4 ? -c[0] : c[0], o & 2 ? -c[1] : c[1], o & 1 ? -c[2] : c[2]};
        int votes = 0;
        for (int i = 0; i < 27; i++) votes += w[i % 3] * s[0] + w[i / 3 % 3] * s[1] + w[i / 9] * s[2] < 0 ? 1 : -1;
        bits |= (uint32_t)(votes > 0) << o;
    }
    return bits;
}

/* Bytes of the whole encoded tree: every node plus every leaf's triangle block. */
static size_t encoded_bytes(const bvh_tree *t, const bvh_codec *c) {
    size_t bytes = 0;
    for (size_t i = 0; i < t->node_count; i++)
        bytes += AABB_NODE_BYTES + (t->nodes[i].count ? c->leaf_bytes(t->nodes[i].count) : 0);
    return bytes;
}

/* Writes node i at offset o, returns the offset past its subtree (0 on offset overflow). */
static size_t write_node(encoder *e, uint32_t i, size_t o) {
    const bvh_node *n = &e->t->nodes[i];
    memcpy(e->out + o, n->box.lo, 12);
    memcpy(e->out + o + 12, n->box.hi, 12);
    uint32_t props;
    size_t end;
    if (n->count) {
        props = AABB_LEAF | n->count;
        e->c->encode(e->out + o + AABB_NODE_BYTES, e->m, e->t->prims + n->index, n->count);
        end = o + AABB_NODE_BYTES + e->c->leaf_bytes(n->count);
    } else {
        uint32_t first = n->index, second = n->index + 1, axis_bits = 0;
        if (e->v == AABB_SPLIT) {
            bool swap;
            int axis = split_axis_of(&e->t->nodes[first], &e->t->nodes[second], &swap);
            if (swap) first = n->index + 1, second = n->index;
            axis_bits = (uint32_t)axis << AABB_SPLIT_AXIS_SHIFT;
        } else if (e->v == AABB_PNS) {
            axis_bits = pns_bits(&e->t->nodes[first], &e->t->nodes[second]) << AABB_PNS_SHIFT;
        }
        size_t right = write_node(e, first, o + AABB_NODE_BYTES);
        if (!right || (right - o) / 4 > aabb_offset_mask(e->v)) return 0;
        props = (uint32_t)((right - o) / 4) | axis_bits;
        end = write_node(e, second, right);
        if (!end) return 0;
    }
    memcpy(e->out + o + 24, &props, 4);
    return end;
}

prt_status bvh_aabb_encode(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, aabb_variant v, bvh_blob *out) {
    memset(out, 0, sizeof *out);
    encoder e = {t, c, m, NULL, encoded_bytes(t, c), v};
    e.out = prt__alloc(e.size);
    if (!e.out) return prt__fail(PRT_ERROR_NOMEM, "out of memory for a %zu-byte tree", e.size);
    if (write_node(&e, 0, 0) != e.size) {
        prt__free(e.out);
        if (v == AABB_PNS)
            return prt__fail(
                PRT_ERROR_LIMIT,
                "aabb-pns: a subtree exceeds the 32 MB that the 23 offset bits left beside the 8 PNS bits "
                "address (Rouwe's AABBTreePNS ran out of offset bits on his large scene too); use aabb or quad");
        return prt__fail(PRT_ERROR_LIMIT, "aabb layouts: a subtree exceeds the child offset bits (%s); use quad",
                         v == AABB_SPLIT ? "2 GB" : "8 GB");
    }
    out->data = e.out;
    out->size = e.size;
    out->nodes = t->node_count;
    out->leaves = t->leaf_count;
    out->depth = t->depth;
    out->bytes_tree = t->node_count * AABB_NODE_BYTES;
    out->bytes_geometry = e.size - out->bytes_tree;
    return PRT_OK;
}

/* Walks the tree checking that it tiles the blob exactly: every second child starts where
 * the first child's subtree ends, so the walk is linear and traversal can never leave the
 * blob or loop. Returns the end offset, or 0 on corruption. */
static size_t check_node(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh, aabb_variant v, size_t o,
                         uint32_t depth, uint64_t *nodes) {
    if (depth > BVH_MAX_DEPTH || o > b->size || b->size - o < AABB_NODE_BYTES) return 0;
    ++*nodes;
    uint32_t props = aabb_props(b->data + o);
    if (props & AABB_LEAF) {
        uint32_t n = props & ~AABB_LEAF;
        if (n == 0 || n > BVH_MAX_LEAF) return 0;
        size_t bytes = c->leaf_bytes(n);
        if (b->size - o - AABB_NODE_BYTES < bytes) return 0;
        if (c->leaf_valid && !c->leaf_valid(b->data + o + AABB_NODE_BYTES, n, sh)) return 0;
        return o + AABB_NODE_BYTES + bytes;
    }
    if (v == AABB_SPLIT && ((props >> AABB_SPLIT_AXIS_SHIFT) & 3) == 3) return 0;
    uint32_t offset = props & aabb_offset_mask(v);
    size_t right = check_node(b, c, sh, v, o + AABB_NODE_BYTES, depth + 1, nodes);
    if (!right || right != o + 4 * (size_t)offset) return 0;
    return check_node(b, c, sh, v, right, depth + 1, nodes);
}

prt_status bvh_aabb_validate(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh, aabb_variant v) {
    uint64_t nodes = 0;
    if (check_node(b, c, sh, v, 0, 1, &nodes) != b->size || nodes != b->nodes)
        return prt__fail(PRT_ERROR_CORRUPT, "aabb tree structure is inconsistent with its size");
    return PRT_OK;
}

/* --- the generic walks' view (bvh_layout.root / children) -------------------------- */

/* The node at byte offset o: its stored box; a leaf's block follows it, or with tl lies
 * where its properties point. */
static bvh_child aabb_child_at(const uint8_t *blob, size_t o, bool tl) {
    bvh_child ch;
    memcpy(ch.box, blob + o, sizeof ch.box);
    const uint32_t props = aabb_props(blob + o);
    if (!(props & AABB_LEAF)) {
        ch.ref = o, ch.count = 0;
    } else if (tl) {
        ch.ref = o + 4 * (size_t)(props & AABB_TL_OFFSET_MASK), ch.count = (props & ~AABB_LEAF) >> AABB_TL_COUNT_SHIFT;
    } else {
        ch.ref = o + AABB_NODE_BYTES, ch.count = props & ~AABB_LEAF;
    }
    return ch;
}

bvh_child bvh_aabb_root(const uint8_t *blob, const bvh_codec *c, bool tl) {
    (void)c;
    return aabb_child_at(blob, 0, tl);
}

/* Where the kernels find an inner node's children (aabb_kernels.inc, aabb_order_kernels.inc). */
uint32_t bvh_aabb_children(const uint8_t *blob, const bvh_codec *c, const bvh_child *node, bvh_child out[8],
                           aabb_variant v, bool bf, bool tl) {
    const size_t o = (size_t)node->ref;
    const uint32_t props = aabb_props(blob + o);
    size_t left = o + AABB_NODE_BYTES, right = o + 4 * (size_t)(props & aabb_offset_mask(v));
    if (bf) {
        left = right, right = left + AABB_NODE_BYTES;
        const uint32_t lp = aabb_props(blob + left);
        if (!tl && (lp & AABB_LEAF)) right += c->leaf_bytes(lp & ~AABB_LEAF);
    }
    out[0] = aabb_child_at(blob, left, tl);
    out[1] = aabb_child_at(blob, right, tl);
    return 2;
}

static bvh_child aabb_root(const uint8_t *blob, const bvh_codec *c, const float bounds[6]) {
    (void)bounds;
    return bvh_aabb_root(blob, c, false);
}

static uint32_t aabb_children(const uint8_t *blob, const bvh_codec *c, const bvh_child *node, bvh_child out[8]) {
    return bvh_aabb_children(blob, c, node, out, AABB_PLAIN, false, false);
}

static prt_status aabb_encode(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bvh_blob *out) {
    return bvh_aabb_encode(t, c, m, AABB_PLAIN, out);
}

static prt_status aabb_validate(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh) {
    return bvh_aabb_validate(b, c, sh, AABB_PLAIN);
}

const bvh_layout bvh_layout_aabb = {
    "aabb",
    "AABBTree (Rouwe 5.1): 28-byte binary nodes, depth first, triangles after their leaf",
    {[BVH_CODEC_float3] = 8,
     [BVH_CODEC_float3_soa4] = 8,
     [BVH_CODEC_float3_soa8] = 8,
     [BVH_CODEC_idx32] = 8,
     [BVH_CODEC_idx32_soa4] = 8},
    aabb_encode,
    aabb_validate,
    {(const bvh_kernels[BVH_CODEC_COUNT]){
#define X(id, nm, desc) [BVH_CODEC_##id] = {.intersect1 = aabb_intersect1_##id, .occluded1 = aabb_occluded1_##id},
        BVH_CODECS(X)
#undef X
    }},
    aabb_root,
    aabb_children,
    NULL, /* point queries: the generic walk */
};
