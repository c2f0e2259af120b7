/* AABBTree node orders (Rouwé 2019, §4.3): the same 28-byte nodes stored depth first or
 * breadth first, with each leaf's triangles behind it or behind all nodes. Depth first
 * with triangles behind their leaf is layouts/aabb.c; this file encodes, checks and
 * traverses the other three (aabb_order_kernels.inc), chosen by the spec's order=. */
#include "bvh/layouts/aabb_node.h"

#define LAYOUT_KERNELS "bvh/layouts/aabb_order_kernels.inc"
#define AABB_BF 0
#define AABB_TL 1
#define AABB_ORDER_NAME aabb_df_tl
#include "bvh/layouts/instantiate.inc"
#undef AABB_BF
#undef AABB_TL
#undef AABB_ORDER_NAME
#define AABB_BF 1
#define AABB_TL 0
#define AABB_ORDER_NAME aabb_bf
#include "bvh/layouts/instantiate.inc"
#undef AABB_BF
#undef AABB_TL
#undef AABB_ORDER_NAME
#define AABB_BF 1
#define AABB_TL 1
#define AABB_ORDER_NAME aabb_bf_tl
#include "bvh/layouts/instantiate.inc"
#undef AABB_BF
#undef AABB_TL
#undef AABB_ORDER_NAME
#undef LAYOUT_KERNELS

static bool is_leaf(const bvh_node *n) { return n->count != 0; }

/* Node i's position in the blob is pos[i]; with tl its triangle block is at tri[i]. */
static prt_status encode_order(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bool bf, bool tl,
                               bvh_blob *out) {
    memset(out, 0, sizeof *out);
    const size_t n = t->node_count;
    uint32_t *seq = prt__alloc(prt__mul_size(n, sizeof *seq)), *stack = prt__alloc(prt__mul_size(n, sizeof *stack));
    size_t *pos = prt__alloc(prt__mul_size(n, 2 * sizeof *pos));
    uint8_t *data = NULL;
    prt_status s = PRT_OK;
    if (!seq || !stack || !pos) {
        s = prt__fail(PRT_ERROR_NOMEM, "out of memory ordering %zu nodes", n);
        goto out;
    }
    size_t *tri = pos + n, k = 0;
    if (bf) { /* both children of a node are queued together, so siblings sit side by side */
        seq[k++] = 0;
        for (size_t i = 0; i < k; i++)
            if (!is_leaf(&t->nodes[seq[i]])) seq[k++] = t->nodes[seq[i]].index, seq[k++] = t->nodes[seq[i]].index + 1;
    } else { /* preorder: the first child follows its parent */
        size_t top = 0;
        stack[top++] = 0;
        while (top) {
            const uint32_t i = stack[--top];
            seq[k++] = i;
            if (!is_leaf(&t->nodes[i])) stack[top++] = t->nodes[i].index + 1, stack[top++] = t->nodes[i].index;
        }
    }
    size_t at = 0;
    for (size_t i = 0; i < n; i++) {
        const bvh_node *nd = &t->nodes[seq[i]];
        pos[seq[i]] = at;
        at += AABB_NODE_BYTES + (!tl && is_leaf(nd) ? c->leaf_bytes(nd->count) : 0);
    }
    for (size_t i = 0; tl && i < n; i++)
        if (is_leaf(&t->nodes[seq[i]])) tri[seq[i]] = at, at += c->leaf_bytes(t->nodes[seq[i]].count);
    data = prt__alloc(at ? at : 1);
    if (!data) {
        s = prt__fail(PRT_ERROR_NOMEM, "out of memory for a %zu-byte tree", at);
        goto out;
    }
    for (size_t i = 0; i < n; i++) {
        const bvh_node *nd = &t->nodes[i];
        uint8_t *o = data + pos[i];
        memcpy(o, nd->box.lo, 12);
        memcpy(o + 12, nd->box.hi, 12);
        uint32_t props;
        if (is_leaf(nd)) {
            const size_t words = tl ? (tri[i] - pos[i]) / 4 : 0;
            if (words > AABB_TL_OFFSET_MASK || nd->count > (~AABB_LEAF >> AABB_TL_COUNT_SHIFT)) {
                s = prt__fail(PRT_ERROR_LIMIT, "aabb with leaves last: a triangle block lies past the 256 MB its 26 "
                                               "offset bits address; use order=df");
                goto out;
            }
            props = AABB_LEAF | (tl ? nd->count << AABB_TL_COUNT_SHIFT | (uint32_t)words : nd->count);
            c->encode(tl ? data + tri[i] : o + AABB_NODE_BYTES, m, t->prims + nd->index, nd->count);
        } else {
            const size_t words = (pos[bf ? nd->index : nd->index + 1] - pos[i]) / 4;
            if (words > ~AABB_LEAF) {
                s = prt__fail(PRT_ERROR_LIMIT, "aabb layouts: a child lies past the 8 GB the offset bits address");
                goto out;
            }
            props = (uint32_t)words;
        }
        memcpy(o + 24, &props, 4);
    }
    out->data = data, data = NULL;
    out->size = at;
    out->nodes = n;
    out->leaves = t->leaf_count;
    out->depth = t->depth;
    out->bytes_tree = n * AABB_NODE_BYTES;
    out->bytes_geometry = at - out->bytes_tree;
out:
    prt__free(seq), prt__free(stack), prt__free(pos), prt__free(data);
    return s;
}

typedef struct checker {
    const bvh_blob *b;
    const bvh_codec *c;
    const bvh_shared *sh;
    bool bf, tl;
    uint8_t *seen; /* a bit per 4-byte word where a node starts */
    uint64_t nodes;
} checker;

/* Every node inside the blob and reached once (so traversal cannot loop or leave it), the
 * depth bounded, every leaf's block inside the blob and valid for the codec. */
static bool check_node(checker *k, size_t o, uint32_t depth) {
    const size_t size = k->b->size;
    if (depth > BVH_MAX_DEPTH || o % 4 || o > size || size - o < AABB_NODE_BYTES) return false;
    if (k->seen[o / 32] >> (o / 4 % 8) & 1) return false;
    k->seen[o / 32] |= (uint8_t)(1u << (o / 4 % 8));
    k->nodes++;
    const uint8_t *node = k->b->data + o;
    const uint32_t props = aabb_props(node);
    if (props & AABB_LEAF) {
        const uint32_t count = k->tl ? (props & ~AABB_LEAF) >> AABB_TL_COUNT_SHIFT : props & ~AABB_LEAF;
        const size_t at = k->tl ? o + 4 * (size_t)(props & AABB_TL_OFFSET_MASK) : o + AABB_NODE_BYTES;
        if (count == 0 || count > BVH_MAX_LEAF || at > size || size - at < k->c->leaf_bytes(count)) return false;
        return !k->c->leaf_valid || k->c->leaf_valid(k->b->data + at, count, k->sh);
    }
    size_t left = o + AABB_NODE_BYTES, right = o + 4 * (size_t)props;
    if (k->bf) {
        left = right;
        if (left > size || size - left < AABB_NODE_BYTES) return false;
        const uint32_t lp = aabb_props(k->b->data + left);
        right = left + AABB_NODE_BYTES;
        if (!k->tl && (lp & AABB_LEAF)) {
            const uint32_t lc = lp & ~AABB_LEAF;
            if (lc == 0 || lc > BVH_MAX_LEAF) return false;
            right += k->c->leaf_bytes(lc);
        }
    }
    return check_node(k, left, depth + 1) && check_node(k, right, depth + 1);
}

static prt_status validate_order(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh, bool bf, bool tl) {
    checker k = {b, c, sh, bf, tl, prt__calloc(b->size / 32 + 1, 1), 0};
    if (!k.seen) return prt__fail(PRT_ERROR_NOMEM, "out of memory checking a %zu-byte tree", b->size);
    const bool ok = check_node(&k, 0, 1) && k.nodes == b->nodes;
    prt__free(k.seen);
    return ok ? PRT_OK : prt__fail(PRT_ERROR_CORRUPT, "aabb tree structure is inconsistent with its size");
}

#define ORDER_FNS(name, bf, tl)                                                                                \
    static prt_status name##_encode(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bvh_blob *out) { \
        return encode_order(t, c, m, bf, tl, out);                                                             \
    }                                                                                                          \
    static prt_status name##_validate(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh) {           \
        return validate_order(b, c, sh, bf, tl);                                                               \
    }                                                                                                          \
    static bvh_child name##_root(const uint8_t *blob, const bvh_codec *c, const float bounds[6]) {             \
        (void)bounds;                                                                                          \
        return bvh_aabb_root(blob, c, tl);                                                                     \
    }                                                                                                          \
    static uint32_t name##_children(const uint8_t *blob, const bvh_codec *c, const bvh_child *node,            \
                                    bvh_child out[8]) {                                                        \
        return bvh_aabb_children(blob, c, node, out, AABB_PLAIN, bf, tl);                                      \
    }
ORDER_FNS(aabb_df_tl, false, true)
ORDER_FNS(aabb_bf, true, false)
ORDER_FNS(aabb_bf_tl, true, true)
#undef ORDER_FNS

#define DEFAULT_LEAVES                                                                                           \
    {                                                                                                            \
        [BVH_CODEC_float3] = 8, [BVH_CODEC_float3_soa4] = 8, [BVH_CODEC_float3_soa8] = 8, [BVH_CODEC_idx32] = 8, \
        [BVH_CODEC_idx32_soa4] = 8                                                                               \
    }

static const bvh_layout aabb_df_tl = {
    "aabb",
    "AABBTree (Rouwe 5.1) depth first, triangle blocks behind all nodes (4.3)",
    DEFAULT_LEAVES,
    aabb_df_tl_encode,
    aabb_df_tl_validate,
    {(const bvh_kernels[BVH_CODEC_COUNT]){
#define X(id, nm, desc) \
    [BVH_CODEC_##id] = {.intersect1 = aabb_df_tl_intersect1_##id, .occluded1 = aabb_df_tl_occluded1_##id},
        BVH_CODECS(X)
#undef X
    }},
    aabb_df_tl_root,
    aabb_df_tl_children,
    NULL, /* point queries: the generic walk */
};

static const bvh_layout aabb_bf = {
    "aabb",
    "AABBTree (Rouwe 5.1) breadth first, each leaf's triangles behind it (4.3)",
    DEFAULT_LEAVES,
    aabb_bf_encode,
    aabb_bf_validate,
    {(const bvh_kernels[BVH_CODEC_COUNT]){
#define X(id, nm, desc) [BVH_CODEC_##id] = {.intersect1 = aabb_bf_intersect1_##id, .occluded1 = aabb_bf_occluded1_##id},
        BVH_CODECS(X)
#undef X
    }},
    aabb_bf_root,
    aabb_bf_children,
    NULL, /* point queries: the generic walk */
};

static const bvh_layout aabb_bf_tl = {
    "aabb",
    "AABBTree (Rouwe 5.1) breadth first, triangle blocks behind all nodes (4.3)",
    DEFAULT_LEAVES,
    aabb_bf_tl_encode,
    aabb_bf_tl_validate,
    {(const bvh_kernels[BVH_CODEC_COUNT]){
#define X(id, nm, desc) \
    [BVH_CODEC_##id] = {.intersect1 = aabb_bf_tl_intersect1_##id, .occluded1 = aabb_bf_tl_occluded1_##id},
        BVH_CODECS(X)
#undef X
    }},
    aabb_bf_tl_root,
    aabb_bf_tl_children,
    NULL, /* point queries: the generic walk */
};

const bvh_layout *const bvh_aabb_orders[BVH_ORDER_COUNT] = {&bvh_layout_aabb, &aabb_df_tl, &aabb_bf, &aabb_bf_tl};
const char *const bvh_order_names[BVH_ORDER_COUNT] = {"df", "df-leaves-last", "bf", "bf-leaves-last"};
