/* SKDTree (Rouwé 2019, §5.5; Ooi et al.'s spatial kd-tree): a binary node keeps one axis
 * and two planes, the left child's maximum and the right child's minimum along it, so a
 * child's region is its parent's cut by one half space. Traversal clips the ray's
 * [near, far] interval by the planes instead of testing boxes.
 *
 * Blob: a 32-byte header (the root box; traversal starts by clipping the ray to it), then
 * the tree depth first. A node starts with a u32: bits 30..31 the axis (3: a leaf), bits
 * 0..29 the triangle count of a leaf, or the offset of the right child from the node in
 * 4-byte words. An inner node continues with the two planes (floats) and its left child;
 * a leaf with its triangle block, at the codec's alignment. The right child starts where
 * the left child's subtree ends. Planes are the children's own box faces (exact floats):
 * the tree is lossless. */
#include "bvh/layouts/layout_debug.h"
#include "bvh/traverse.h"

#define SKD_HEADER_BYTES 32
#define SKD_INNER_BYTES 12
#define SKD_AXIS_SHIFT 30
#define SKD_LEAF 3u
#define SKD_PAYLOAD_MASK 0x3FFFFFFFu

typedef struct skd_header {
    float lo[3], hi[3]; /* the root box */
    uint32_t reserved[2];
} skd_header;

_Static_assert(sizeof(skd_header) == SKD_HEADER_BYTES, "skd header is 32 bytes");

static inline size_t skd_align_up(size_t x, size_t a) { return (x + a - 1) / a * a; }

static inline uint32_t skd_u32(const uint8_t *p) {
    uint32_t w;
    memcpy(&w, p, 4);
    return w;
}

static inline float skd_f32(const uint8_t *p) {
    float f;
    memcpy(&f, p, 4);
    return f;
}

/* Far distances grow by Ize's 2 gamma(3), as in geom/box.h, so clipping stays conservative. */
static inline float skd_far(float t) { return t * (t >= 0.0f ? PRT_BOX_FAR_SCALE : PRT_BOX_FAR_SCALE_NEG); }

/* The ray's interval inside the root box: false when it misses. NaN distances (an origin on
 * a plane the ray runs parallel to) constrain nothing, as in geom/box.h. */
static inline bool skd_root_clip(const prt__rayx *r, const uint8_t *blob, float tfar, float *tn, float *tf) {
    skd_header hd;
    memcpy(&hd, blob, sizeof hd);
    float a = r->tnear, b = tfar;
    for (int k = 0; k < 3; k++) {
        const float t0 = ((r->neg[k] ? hd.hi[k] : hd.lo[k]) - r->org[k]) * r->inv[k];
        const float t1 = ((r->neg[k] ? hd.lo[k] : hd.hi[k]) - r->org[k]) * r->inv[k];
        a = t0 > a ? t0 : a;
        b = t1 < b ? t1 : b;
    }
    *tn = a, *tf = skd_far(b);
    return a <= *tf;
}

/* The intervals of both children of an inner node (props, planes at p) given the node's
 * [tn, tf]: the left child's region is x[axis] <= left plane, the right's >= right plane. */
static inline void skd_clip(const prt__rayx *r, uint32_t props, const uint8_t *p, float tn, float tf, float *ln,
                            float *lf, float *rn, float *rf) {
    const int k = (int)(props >> SKD_AXIS_SHIFT);
    const float tl = (skd_f32(p) - r->org[k]) * r->inv[k], tr = (skd_f32(p + 4) - r->org[k]) * r->inv[k];
    const float fl = skd_far(tl), fr = skd_far(tr);
    if (r->neg[k]) { /* moving down: the left region is entered at tl, the right one left at tr */
        *ln = tl > tn ? tl : tn, *lf = tf;
        *rn = tn, *rf = fr < tf ? fr : tf;
    } else {
        *ln = tn, *lf = fl < tf ? fl : tf;
        *rn = tr > tn ? tr : tn, *rf = tf;
    }
}

#define LAYOUT_KERNELS "bvh/layouts/skd_kernels.inc"
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

/* The axis along which the two children overlap least for the parent's extent (a gap
 * counts negative), and whether the first (index) child must go right on it. */
static int choose_axis(const bvh_node *n, const bvh_node *a, const bvh_node *b, bool *swap) {
    int axis = 0;
    float best = INFINITY;
    for (int k = 0; k < 3; k++) {
        const bool s = (a->box.lo[k] + a->box.hi[k]) > (b->box.lo[k] + b->box.hi[k]);
        const bvh_node *l = s ? b : a, *r = s ? a : b;
        const float extent = n->box.hi[k] - n->box.lo[k];
        const float overlap = extent > 0 ? (l->box.hi[k] - r->box.lo[k]) / extent : INFINITY;
        if (overlap < best) best = overlap, axis = k, *swap = s;
    }
    if (best == INFINITY) *swap = false; /* a point-sized node: any axis does */
    return axis;
}

/* Writes binary node i at o; returns the end of its subtree, 0 when an offset overflows. */
static size_t write_node(encoder *e, uint32_t i, size_t o, uint32_t depth) {
    const bvh_node *n = &e->t->nodes[i];
    if (depth > e->depth) e->depth = depth;
    e->nodes++;
    if (n->count) {
        const size_t at = skd_align_up(o + 4, e->c->align), bytes = e->c->leaf_bytes(n->count);
        if (e->out) {
            const uint32_t props = SKD_LEAF << SKD_AXIS_SHIFT | n->count;
            memcpy(e->out + o, &props, 4);
            e->c->encode(e->out + at, e->m, e->t->prims + n->index, n->count);
        }
        e->geometry += bytes;
        return at + bytes;
    }
    bool swap = false;
    const int axis = choose_axis(n, &e->t->nodes[n->index], &e->t->nodes[n->index + 1], &swap);
    const uint32_t left = n->index + (swap ? 1 : 0), right = n->index + (swap ? 0 : 1);
    const size_t right_at = write_node(e, left, o + SKD_INNER_BYTES, depth + 1);
    if (!right_at || (right_at - o) / 4 > SKD_PAYLOAD_MASK) return 0;
    if (e->out) {
        const uint32_t props = (uint32_t)axis << SKD_AXIS_SHIFT | (uint32_t)((right_at - o) / 4);
        const float planes[2] = {e->t->nodes[left].box.hi[axis], e->t->nodes[right].box.lo[axis]};
        memcpy(e->out + o, &props, 4);
        memcpy(e->out + o + 4, planes, 8);
    }
    return write_node(e, right, right_at, depth + 1);
}

static prt_status skd_encode(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bvh_blob *out) {
    memset(out, 0, sizeof *out);
    if (c->align % 4)
        return prt__fail(PRT_ERROR_LIMIT, "skd: codec %s aligns leaves to %zu bytes; nodes need 4", c->name, c->align);
    encoder e = {t, c, m, NULL, 0, 0, 0};
    const size_t size = write_node(&e, 0, SKD_HEADER_BYTES, 1);
    if (!size) return prt__fail(PRT_ERROR_LIMIT, "skd: a subtree exceeds the 4 GB its 30-bit word offsets address");
    e = (encoder){t, c, m, prt__calloc(1, size), 0, 0, 0};
    if (!e.out) return prt__fail(PRT_ERROR_NOMEM, "out of memory for a %zu-byte tree", size);
    skd_header hd;
    memset(&hd, 0, sizeof hd);
    memcpy(hd.lo, t->nodes[0].box.lo, sizeof hd.lo);
    memcpy(hd.hi, t->nodes[0].box.hi, sizeof hd.hi);
    memcpy(e.out, &hd, sizeof hd);
    write_node(&e, 0, SKD_HEADER_BYTES, 1);
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

/* The subtree at o; its end, or 0 when it does not tile the blob as the encoder lays it
 * out (so traversal can neither leave the blob nor loop; depth bounds its stack). NaN
 * planes or root box faces are allowed: they constrain nothing. */
static size_t check_node(checker *k, size_t o, uint32_t depth) {
    if (depth > BVH_MAX_DEPTH || o > k->b->size || k->b->size - o < 4) return 0;
    k->nodes++;
    const uint32_t props = skd_u32(k->b->data + o), payload = props & SKD_PAYLOAD_MASK;
    if (props >> SKD_AXIS_SHIFT == SKD_LEAF) {
        const size_t at = skd_align_up(o + 4, k->c->align);
        if (payload == 0 || payload > BVH_MAX_LEAF || at > k->b->size || k->b->size - at < k->c->leaf_bytes(payload) ||
            (k->c->leaf_valid && !k->c->leaf_valid(k->b->data + at, payload, k->sh)))
            return 0;
        return at + k->c->leaf_bytes(payload);
    }
    if (k->b->size - o < SKD_INNER_BYTES) return 0;
    const size_t right = check_node(k, o + SKD_INNER_BYTES, depth + 1);
    if (!right || right != o + 4 * (size_t)payload) return 0;
    return check_node(k, right, depth + 1);
}

static prt_status skd_validate(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh) {
    skd_header hd;
    checker k = {b, c, sh, 0};
    if (b->size < SKD_HEADER_BYTES || c->align % 4)
        return prt__fail(PRT_ERROR_CORRUPT, "skd tree: shorter than its header");
    memcpy(&hd, b->data, sizeof hd);
    if (hd.reserved[0] || hd.reserved[1] || check_node(&k, SKD_HEADER_BYTES, 1) != b->size || k.nodes != b->nodes)
        return prt__fail(PRT_ERROR_CORRUPT, "skd tree: structure inconsistent with its size");
    return PRT_OK;
}

/* --- the generic walks' view (bvh_layout.root / children) -------------------------- */

/* The node at byte offset o with region box: an inner node's ref its offset, a leaf's its
 * block's, at the codec's alignment after the node's word. */
static bvh_child skd_child(const uint8_t *blob, const bvh_codec *c, size_t o, const float box[6]) {
    bvh_child ch;
    memcpy(ch.box, box, sizeof ch.box);
    const uint32_t props = skd_u32(blob + o);
    if (props >> SKD_AXIS_SHIFT == SKD_LEAF)
        ch.ref = skd_align_up(o + 4, c->align), ch.count = props & SKD_PAYLOAD_MASK;
    else ch.ref = o, ch.count = 0;
    return ch;
}

static bvh_child skd_root(const uint8_t *blob, const bvh_codec *c, const float bounds[6]) {
    (void)bounds;
    skd_header hd;
    memcpy(&hd, blob, sizeof hd);
    const float box[6] = {hd.lo[0], hd.lo[1], hd.lo[2], hd.hi[0], hd.hi[1], hd.hi[2]};
    return skd_child(blob, c, SKD_HEADER_BYTES, box);
}

/* Both children, their regions node->box cut by the node's planes (the left child's
 * maximum, the right child's minimum along its axis), as traversal clips the ray. */
static uint32_t skd_children(const uint8_t *blob, const bvh_codec *c, const bvh_child *node, bvh_child out[8]) {
    const size_t o = (size_t)node->ref;
    const uint32_t props = skd_u32(blob + o);
    const int k = (int)(props >> SKD_AXIS_SHIFT);
    float left[6], right[6];
    memcpy(left, node->box, sizeof left), memcpy(right, node->box, sizeof right);
    left[3 + k] = fminf(left[3 + k], skd_f32(blob + o + 4));
    right[k] = fmaxf(right[k], skd_f32(blob + o + 8));
    out[0] = skd_child(blob, c, o + SKD_INNER_BYTES, left);
    out[1] = skd_child(blob, c, o + 4 * (size_t)(props & SKD_PAYLOAD_MASK), right);
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

/* Grows box by the triangles below the node at o, whose region is lo/hi, and counts the
 * regions (the root box, and every child's half space) that cut into their subtree. */
static void debug_node(const debug_walk *w, size_t o, const float lo[3], const float hi[3], prt_aabb *box) {
    prt_aabb mine = prt_aabb_empty();
    const uint32_t props = skd_u32(w->b->data + o), payload = props & SKD_PAYLOAD_MASK;
    if (props >> SKD_AXIS_SHIFT == SKD_LEAF) {
        w->leaf(w->user, w->b->data + skd_align_up(o + 4, w->align), payload, &mine);
        w->out->triangles += payload;
    } else {
        const int k = (int)(props >> SKD_AXIS_SHIFT);
        float llo[3], lhi[3], rlo[3], rhi[3];
        memcpy(llo, lo, sizeof llo), memcpy(lhi, hi, sizeof lhi), memcpy(rlo, lo, sizeof rlo),
            memcpy(rhi, hi, sizeof rhi);
        lhi[k] = fminf(hi[k], skd_f32(w->b->data + o + 4));
        rlo[k] = fmaxf(lo[k], skd_f32(w->b->data + o + 8));
        debug_node(w, o + SKD_INNER_BYTES, llo, lhi, &mine);
        debug_node(w, o + 4 * (size_t)payload, rlo, rhi, &mine);
    }
    bool inside = true;
    for (int k = 0; k < 3; k++) inside &= lo[k] <= mine.lo[k] && hi[k] >= mine.hi[k];
    w->out->boxes++;
    w->out->violations += !inside;
    prt_aabb_grow(box, &mine);
}

void bvh_skd_debug_boxes(const bvh_blob *b, const bvh_codec *c, bvh_debug_leaf_fn leaf, void *user,
                         bvh_debug_boxes *out) {
    memset(out, 0, sizeof *out);
    skd_header hd;
    memcpy(&hd, b->data, sizeof hd);
    debug_walk w = {b, c->align, leaf, user, out};
    prt_aabb all = prt_aabb_empty();
    debug_node(&w, SKD_HEADER_BYTES, hd.lo, hd.hi, &all);
}

const bvh_layout bvh_layout_skd = {
    "skd",
    "SKDTree (Rouwe 5.5): binary nodes with a split axis and two planes (12 bytes), traversal clips the ray's "
    "interval instead of testing boxes",
    {[BVH_CODEC_float3] = 8,
     [BVH_CODEC_float3_soa4] = 8,
     [BVH_CODEC_float3_soa8] = 8,
     [BVH_CODEC_idx32] = 8,
     [BVH_CODEC_idx32_soa4] = 8},
    skd_encode,
    skd_validate,
    {(const bvh_kernels[BVH_CODEC_COUNT]){
#define X(id, nm, desc) [BVH_CODEC_##id] = {.intersect1 = skd_intersect1_##id, .occluded1 = skd_occluded1_##id},
        BVH_CODECS(X)
#undef X
    }},
    skd_root,
    skd_children,
    NULL, /* point queries: the generic walk */
};
