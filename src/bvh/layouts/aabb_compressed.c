/* AABBTreeCompressed (Rouwé 2019, §5.4): the smallest tree. A 12-byte node keeps its two
 * children's boxes as 7-bit steps in from its own box with one side bit per component;
 * traversal carries each node's decoded box on its stack. Format: aabb_compressed.h. */
#include "bvh/layouts/aabb_compressed.h"
#include "bvh/layouts/layout_debug.h"
#include "bvh/traverse.h"

static inline size_t ac_align_up(size_t x, size_t a) { return (x + a - 1) / a * a; }

static inline uint32_t ac_word(const uint8_t *p) {
    uint32_t w;
    memcpy(&w, p, 4);
    return w;
}

#define LAYOUT_KERNELS "bvh/layouts/aabb_compressed_kernels.inc"
#include "bvh/layouts/instantiate.inc"
#undef LAYOUT_KERNELS

/* --- encoding ----------------------------------------------------------------------- */

typedef struct encoder {
    const bvh_tree *t;
    const bvh_codec *c;
    const prt_mesh *m;
    uint8_t *out; /* NULL: measuring only */
    size_t geometry, nodes;
    uint32_t depth;
} encoder;

/* The largest q whose min plane stays at or below v (q = 0, the parent's plane, always does). */
static uint32_t quantize_min(float lo, float hi, float v) {
    const float step = ac_step(lo, hi);
    float x = step > 0 ? floorf((v - lo) / step) : 0;
    uint32_t q = x > 127 ? 127 : x > 0 ? (uint32_t)x : 0;
    while (q > 0 && ac_min_plane(lo, step, q) > v) q--;
    while (q < 127 && ac_min_plane(lo, step, q + 1) <= v) q++;
    return q;
}

/* The largest q whose max plane stays at or above v. */
static uint32_t quantize_max(float lo, float hi, float v) {
    const float step = ac_step(lo, hi);
    float x = step > 0 ? floorf((hi - v) / step) : 0;
    uint32_t q = x > 127 ? 127 : x > 0 ? (uint32_t)x : 0;
    while (q > 0 && ac_max_plane(hi, step, q) < v) q--;
    while (q < 127 && ac_max_plane(hi, step, q + 1) >= v) q++;
    return q;
}

static size_t place(encoder *e, uint32_t i, size_t o, const float lo[3], const float hi[3], uint32_t depth);

/* Writes inner node i (decoded box lo/hi) at o; returns the end of its subtree, 0 when an
 * offset does not fit in 32 bits. */
static size_t write_node(encoder *e, uint32_t i, size_t o, const float lo[3], const float hi[3], uint32_t depth) {
    const bvh_node *n = &e->t->nodes[i], *a = &e->t->nodes[n->index], *b = &e->t->nodes[n->index + 1];
    uint32_t wmin = a->count << AC_COUNT_SHIFT, wmax = b->count << AC_COUNT_SHIFT;
    for (int k = 0; k < 3; k++) {
        /* The child whose plane lies further in takes the changed value; the other keeps the parent's. */
        const uint32_t smin = b->box.lo[k] > a->box.lo[k], smax = b->box.hi[k] < a->box.hi[k];
        wmin |= quantize_min(lo[k], hi[k], (smin ? b : a)->box.lo[k]) << (7 * k) | smin << (AC_SIDE_SHIFT + k);
        wmax |= quantize_max(lo[k], hi[k], (smax ? b : a)->box.hi[k]) << (7 * k) | smax << (AC_SIDE_SHIFT + k);
    }
    float llo[3], lhi[3], rlo[3], rhi[3];
    ac_unpack(lo, hi, wmin, wmax, llo, lhi, rlo, rhi);
    e->nodes++;
    const size_t left_end = place(e, n->index, o + AC_NODE_BYTES, llo, lhi, depth + 1);
    if (!left_end) return 0;
    const size_t right = b->count ? ac_align_up(left_end, e->c->align) : left_end;
    if (right > UINT32_MAX) return 0;
    if (e->out) {
        const uint32_t w[3] = {wmin, wmax, (uint32_t)right};
        memcpy(e->out + o, w, sizeof w);
    }
    return place(e, n->index + 1, right, rlo, rhi, depth + 1);
}

/* Places binary node i (a leaf at the codec's alignment, or an inner node) at o or after. */
static size_t place(encoder *e, uint32_t i, size_t o, const float lo[3], const float hi[3], uint32_t depth) {
    const bvh_node *n = &e->t->nodes[i];
    if (depth > e->depth) e->depth = depth;
    if (!n->count) return write_node(e, i, o, lo, hi, depth);
    o = ac_align_up(o, e->c->align);
    if (e->out) e->c->encode(e->out + o, e->m, e->t->prims + n->index, n->count);
    e->geometry += e->c->leaf_bytes(n->count);
    return o + e->c->leaf_bytes(n->count);
}

static prt_status aabb_compressed_encode(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bvh_blob *out) {
    memset(out, 0, sizeof *out);
    const bvh_node *root = &t->nodes[0];
    for (int k = 0; k < 3; k++)
        if (!(root->box.hi[k] - root->box.lo[k] <= FLT_MAX / 2))
            return prt__fail(PRT_ERROR_LIMIT, "aabb-compressed: the mesh's extent (axis %d) overflows a float's range",
                             k);
    encoder e = {t, c, m, NULL, 0, 0, 0};
    const size_t size = place(&e, 0, AC_HEADER_BYTES, root->box.lo, root->box.hi, 1);
    if (!size || size > UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT,
                         "aabb-compressed: the tree exceeds the 4 GB its 32-bit child offsets address");
    e = (encoder){t, c, m, prt__calloc(1, size), 0, 0, 0};
    if (!e.out) return prt__fail(PRT_ERROR_NOMEM, "out of memory for a %zu-byte tree", size);
    ac_header hd = {{root->box.lo[0], root->box.lo[1], root->box.lo[2]},
                    {root->box.hi[0], root->box.hi[1], root->box.hi[2]},
                    root->count,
                    0};
    memcpy(e.out, &hd, sizeof hd);
    place(&e, 0, AC_HEADER_BYTES, root->box.lo, root->box.hi, 1);
    out->data = e.out;
    out->size = size;
    out->bytes_geometry = e.geometry;
    out->bytes_tree = size - e.geometry; /* header, nodes and alignment padding */
    out->nodes = e.nodes;
    out->leaves = t->leaf_count;
    out->depth = e.depth;
    return PRT_OK;
}

/* --- validation of a loaded blob ---------------------------------------------------- */

typedef struct checker {
    const bvh_blob *b;
    const bvh_codec *c;
    const bvh_shared *sh;
    uint64_t nodes;
} checker;

static size_t check_child(checker *k, size_t o, uint32_t count, uint32_t depth);

/* The subtree of the node at o; its end offset, or 0 when it does not tile the blob as the
 * encoder lays it out (so the walk is linear, and traversal can neither leave nor loop). */
static size_t check_node(checker *k, size_t o, uint32_t depth) {
    if (depth > BVH_MAX_DEPTH || o > k->b->size || k->b->size - o < AC_NODE_BYTES) return 0;
    k->nodes++;
    const uint32_t wmin = ac_word(k->b->data + o), wmax = ac_word(k->b->data + o + 4),
                   right = ac_word(k->b->data + o + 8);
    const uint32_t nl = wmin >> AC_COUNT_SHIFT, nr = wmax >> AC_COUNT_SHIFT;
    const size_t left_end =
        check_child(k, nl ? ac_align_up(o + AC_NODE_BYTES, k->c->align) : o + AC_NODE_BYTES, nl, depth + 1);
    if (!left_end || right != (nr ? ac_align_up(left_end, k->c->align) : left_end)) return 0;
    return check_child(k, right, nr, depth + 1);
}

static size_t check_child(checker *k, size_t o, uint32_t count, uint32_t depth) {
    if (!count) return check_node(k, o, depth);
    const size_t bytes = k->c->leaf_bytes(count);
    if (count > BVH_MAX_LEAF || o > k->b->size || k->b->size - o < bytes ||
        (k->c->leaf_valid && !k->c->leaf_valid(k->b->data + o, count, k->sh)))
        return 0;
    return o + bytes;
}

/* A finite root box with room to spare (decoded child boxes stay within a rounding of
 * their parent's, so no box becomes infinite or NaN), and the walk above. */
static prt_status aabb_compressed_validate(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh) {
    ac_header hd;
    if (b->size < AC_HEADER_BYTES) return prt__fail(PRT_ERROR_CORRUPT, "aabb-compressed tree: shorter than its header");
    memcpy(&hd, b->data, sizeof hd);
    bool bad = hd.reserved != 0 || hd.root_count > BVH_MAX_LEAF;
    for (int k = 0; k < 3; k++) bad |= !(fabsf(hd.lo[k]) <= 1e37f && fabsf(hd.hi[k]) <= 1e37f); /* false for NaN too */
    checker ck = {b, c, sh, 0};
    if (bad ||
        check_child(&ck, hd.root_count ? ac_align_up(AC_HEADER_BYTES, c->align) : AC_HEADER_BYTES, hd.root_count, 1) !=
            b->size ||
        ck.nodes != b->nodes)
        return prt__fail(PRT_ERROR_CORRUPT, "aabb-compressed tree: structure inconsistent with its size");
    return PRT_OK;
}

/* --- the generic walks' view (bvh_layout.root / children) -------------------------- */

/* A child at byte offset o of count triangles (0: an inner node) with its decoded box. */
static bvh_child ac_child(size_t o, uint32_t count, const float lo[3], const float hi[3]) {
    bvh_child ch = {.ref = o, .count = count};
    memcpy(ch.box, lo, 12), memcpy(ch.box + 3, hi, 12);
    return ch;
}

/* The root from the header; ref: an inner node's byte offset, a leaf's block's. */
static bvh_child aabb_compressed_root(const uint8_t *blob, const bvh_codec *c, const float bounds[6]) {
    (void)bounds;
    ac_header hd;
    memcpy(&hd, blob, sizeof hd);
    return ac_child(hd.root_count ? ac_align_up(AC_HEADER_BYTES, c->align) : AC_HEADER_BYTES, hd.root_count, hd.lo,
                    hd.hi);
}

/* Both children, their boxes decoded from node->box as traversal decodes them. */
static uint32_t aabb_compressed_children(const uint8_t *blob, const bvh_codec *c, const bvh_child *node,
                                         bvh_child out[8]) {
    const size_t o = (size_t)node->ref;
    const uint32_t wmin = ac_word(blob + o), wmax = ac_word(blob + o + 4), right = ac_word(blob + o + 8);
    const uint32_t nl = wmin >> AC_COUNT_SHIFT, nr = wmax >> AC_COUNT_SHIFT;
    float llo[3], lhi[3], rlo[3], rhi[3];
    ac_unpack(node->box, node->box + 3, wmin, wmax, llo, lhi, rlo, rhi);
    out[0] = ac_child(nl ? ac_align_up(o + AC_NODE_BYTES, c->align) : o + AC_NODE_BYTES, nl, llo, lhi);
    out[1] = ac_child(right, nr, rlo, rhi);
    return 2;
}

/* --- test walk (layout_debug.h) ------------------------------------------------------ */

typedef struct debug_walk {
    const bvh_blob *b;
    size_t align;
    bvh_debug_leaf_fn leaf;
    void *user;
    bvh_debug_boxes *out;
} debug_walk;

/* Grows box by the triangles of the child at o (count > 0: a leaf) and counts decoded
 * boxes below it that cut into their subtree. */
static void debug_child(const debug_walk *w, size_t o, uint32_t count, const float lo[3], const float hi[3],
                        prt_aabb *box) {
    prt_aabb mine = prt_aabb_empty();
    if (count) {
        w->leaf(w->user, w->b->data + o, count, &mine);
        w->out->triangles += count;
    } else {
        const uint32_t wmin = ac_word(w->b->data + o), wmax = ac_word(w->b->data + o + 4),
                       right = ac_word(w->b->data + o + 8);
        float llo[3], lhi[3], rlo[3], rhi[3];
        ac_unpack(lo, hi, wmin, wmax, llo, lhi, rlo, rhi);
        const uint32_t nl = wmin >> AC_COUNT_SHIFT;
        debug_child(w, nl ? ac_align_up(o + AC_NODE_BYTES, w->align) : o + AC_NODE_BYTES, nl, llo, lhi, &mine);
        debug_child(w, right, wmax >> AC_COUNT_SHIFT, rlo, rhi, &mine);
    }
    bool inside = true;
    for (int k = 0; k < 3; k++) inside &= lo[k] <= mine.lo[k] && hi[k] >= mine.hi[k];
    w->out->boxes++;
    w->out->violations += !inside;
    prt_aabb_grow(box, &mine);
}

void bvh_aabb_compressed_debug_boxes(const bvh_blob *b, const bvh_codec *c, bvh_debug_leaf_fn leaf, void *user,
                                     bvh_debug_boxes *out) {
    memset(out, 0, sizeof *out);
    ac_header hd;
    memcpy(&hd, b->data, sizeof hd);
    debug_walk w = {b, c->align, leaf, user, out};
    prt_aabb all = prt_aabb_empty();
    debug_child(&w, hd.root_count ? ac_align_up(AC_HEADER_BYTES, c->align) : AC_HEADER_BYTES, hd.root_count, hd.lo,
                hd.hi, &all);
}

const bvh_layout bvh_layout_aabb_compressed = {
    "aabb-compressed",
    "AABBTreeCompressed (Rouwe 5.4): 12-byte binary nodes, child boxes as 7-bit steps in from the parent's "
    "box, rounded outward",
    {[BVH_CODEC_float3] = 8,
     [BVH_CODEC_float3_soa4] = 8,
     [BVH_CODEC_float3_soa8] = 8,
     [BVH_CODEC_idx32] = 8,
     [BVH_CODEC_idx32_soa4] = 8},
    aabb_compressed_encode,
    aabb_compressed_validate,
    {(const bvh_kernels[BVH_CODEC_COUNT]){
#define X(id, nm, desc) \
    [BVH_CODEC_##id] = {.intersect1 = aabb_compressed_intersect1_##id, .occluded1 = aabb_compressed_occluded1_##id},
        BVH_CODECS(X)
#undef X
    }},
    aabb_compressed_root,
    aabb_compressed_children,
    NULL, /* point queries: the generic walk */
};
