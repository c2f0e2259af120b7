/* QuadTreeHalfFloat (Rouwé 2019, §5.7): the QuadTree (§5.6) with its child boxes in half
 * floats, so a node is 64 bytes, one cache line; all nodes come before the leaves. Planes
 * are relative to the root box and rounded outward (quad_half.h says why and how). */
#include "bvh/layouts/quad_half.h"
#include "bvh/layouts/layout_debug.h"
#include "bvh/layouts/quad_plan.h"
#include "bvh/traverse.h"

/* Per-ray constants of the 4-wide decoded box test, and where the blob's parts start. */
typedef struct qh_ray {
    vf8 centre[3], scale[3], org[3], inv[3];
    vi4 neg[3]; /* all lanes -1 where the ray runs toward -inf: the hi plane is near */
    vf4 tnear;
    const uint8_t *nodes, *geometry;
} qh_ray;

static inline void qh_ray_init(qh_ray *w, const prt__rayx *r, const uint8_t *blob) {
    qh_header hd;
    memcpy(&hd, blob, sizeof hd);
    for (int k = 0; k < 3; k++) {
        w->centre[k] = vf8_set1(hd.centre[k]);
        w->scale[k] = vf8_set1(hd.scale[k]);
        w->org[k] = vf8_set1(r->org[k]);
        w->inv[k] = vf8_set1(r->inv[k]);
        const int32_t m = r->neg[k] ? -1 : 0;
        w->neg[k] = (vi4){m, m, m, m};
    }
    w->tnear = vf4_set1(r->tnear);
    w->nodes = blob + QH_HEADER_BYTES; /* node i at nodes + 64 i */
    w->geometry = blob + hd.geometry;
}

/* lo[4] and hi[4] of one axis as floats. */
static inline vf8 qh_load8(const uint16_t *h) {
#if defined(__F16C__)
    return (vf8)_mm256_cvtph_ps(_mm_loadu_si128((const __m128i *)h));
#else
    float f[8];
    qh_halves_to_floats(h, f);
    return vf8_load(f);
#endif
}

/* The robust slab test of geom/box.h on the four decoded child boxes: each plane is the
 * fmaf the encoder checked, then (plane - org) * inv as box.h computes it. */
static inline int qh_box_hit(const qh_node *n, const qh_ray *w, float tfar, vf4 *tentry) {
    vf4 tmin = w->tnear, tmax = vf4_set1(tfar);
    for (int k = 0; k < 3; k++) {
        const vf8 plane = vf8_fmadd(qh_load8(n->box + 8 * k), w->scale[k], w->centre[k]);
        const vf8 t = (plane - w->org[k]) * w->inv[k];
        vf4 lo, hi;
        memcpy(&lo, &t, sizeof lo);
        memcpy(&hi, (const char *)&t + sizeof lo, sizeof hi);
        tmin = vf4_max(vf4_select(w->neg[k], hi, lo), tmin); /* NaN in the first operand: tmin */
        tmax = vf4_min(vf4_select(w->neg[k], lo, hi), tmax);
    }
    tmax =
        vf4_select(tmax >= vf4_set1(0.0f), tmax * vf4_set1(PRT_BOX_FAR_SCALE), tmax * vf4_set1(PRT_BOX_FAR_SCALE_NEG));
    *tentry = tmin;
    return vi4_mask(tmin <= tmax);
}

#define LAYOUT_KERNELS "bvh/layouts/quad_half_kernels.inc"
#include "bvh/layouts/instantiate.inc"
#undef LAYOUT_KERNELS

/* --- encoding ----------------------------------------------------------------------- */

static size_t align_up(size_t x, size_t a) { return (x + a - 1) / a * a; }

/* Leaf blocks start at multiples of the codec's alignment and of 4 (offsets count words). */
static size_t leaf_align(const bvh_codec *c) {
    size_t a = c->align ? c->align : 1;
    while (a % 4) a *= 2;
    return a;
}

/* The half that decodes (fmaf(h, s, c)) to a plane at or below v (up: at or above). */
static uint16_t encode_plane(float v, float s, float c, bool up) {
    uint16_t h = qh_half_round((v - c) / s, up);
    if (up)
        while (qh_plane(h, s, c) < v) h = qh_half_next(h, true);
    else
        while (qh_plane(h, s, c) > v) h = qh_half_next(h, false);
    return h;
}

/* Centre and power-of-two scale of one axis: the root box maps into [-2^14, 2^14]. */
static void axis_frame(float lo, float hi, float *centre, float *scale) {
    *centre = 0.5f * lo + 0.5f * hi;
    const float half = fmaxf(hi - *centre, *centre - lo);
    int e = 0;
    if (half > 0) frexpf(half / 16384.0f, &e);
    *scale = ldexpf(1.0f, e < -100 ? -100 : e > 100 ? 100 : e);
}

static prt_status quad_half_encode(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bvh_blob *out) {
    memset(out, 0, sizeof *out);
    quad_plan *p = prt__alloc(prt__mul_size(t->node_count, sizeof *p));
    if (!p) return prt__fail(PRT_ERROR_NOMEM, "out of memory planning %zu nodes", t->node_count);
    const uint32_t count = bvh_quad_plan(t, p);
    const size_t la = leaf_align(c);
    const size_t nodes_end = QH_HEADER_BYTES + (size_t)count * QH_NODE_BYTES;
    const size_t geometry = align_up(nodes_end, la > 64 ? la : 64);
    size_t size = geometry;
    for (uint32_t q = 0; q < count; q++)
        for (int i = 0; i < p[q].count; i++) {
            const bvh_node *n = &t->nodes[p[q].bin[i]];
            if (n->count) size = align_up(size, la) + c->leaf_bytes(n->count);
        }
    if (count > QH_LEAF || (size - geometry) / 4 > QH_OFFSET_MASK) {
        prt__free(p);
        return prt__fail(
            PRT_ERROR_LIMIT,
            "quad-half layout: %zu bytes of leaves exceed the 512 MB its 27-bit word offsets address; use quad",
            size - geometry);
    }
    uint8_t *data = prt__calloc(1, size);
    if (!data) {
        prt__free(p);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for a %zu-byte tree", size);
    }
    qh_header hd;
    memset(&hd, 0, sizeof hd);
    const prt_aabb *root = &t->nodes[0].box;
    for (int k = 0; k < 3; k++) axis_frame(root->lo[k], root->hi[k], &hd.centre[k], &hd.scale[k]);
    hd.nodes = count;
    hd.geometry = geometry;
    memcpy(data, &hd, sizeof hd);
    size_t geo = geometry;
    for (uint32_t q = 0; q < count; q++) {
        qh_node node;
        for (int i = 0; i < 4; i++) {
            node.child[i] = 0;
            if (i >= p[q].count) {
                for (int k = 0; k < 3; k++)
                    node.box[8 * k + i] = QH_HALF_POS_INF, node.box[8 * k + 4 + i] = QH_HALF_NEG_INF;
                continue;
            }
            const bvh_node *n = &t->nodes[p[q].bin[i]];
            for (int k = 0; k < 3; k++) {
                node.box[8 * k + i] = encode_plane(n->box.lo[k], hd.scale[k], hd.centre[k], false);
                node.box[8 * k + 4 + i] = encode_plane(n->box.hi[k], hd.scale[k], hd.centre[k], true);
            }
            if (n->count) {
                geo = align_up(geo, la);
                c->encode(data + geo, m, t->prims + n->index, n->count);
                node.child[i] = QH_LEAF | (n->count - 1) << QH_COUNT_SHIFT | (uint32_t)((geo - geometry) / 4);
                geo += c->leaf_bytes(n->count);
            } else {
                node.child[i] = p[q].quad[i];
            }
        }
        memcpy(data + QH_HEADER_BYTES + (size_t)q * QH_NODE_BYTES, &node, sizeof node);
    }
    prt__free(p);
    out->data = data;
    out->size = size;
    out->bytes_tree = geometry;
    out->bytes_geometry = size - geometry;
    out->nodes = count;
    out->leaves = t->leaf_count;
    out->depth = t->depth; /* collapsing only shortens paths */
    return PRT_OK;
}

/* --- validation of a loaded blob ---------------------------------------------------- */

/* The header's frame finite (scales powers of two), every node referenced exactly once by
 * an earlier node, no NaN plane, empty slots with the empty box, every leaf inside the
 * geometry range, aligned and valid for the codec, depth bounded: traversal can then
 * neither leave the blob, loop, nor overflow its stack. */
static prt_status quad_half_validate(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh) {
    qh_header hd;
    if (b->size < QH_HEADER_BYTES) return prt__fail(PRT_ERROR_CORRUPT, "quad-half tree: shorter than its header");
    memcpy(&hd, b->data, sizeof hd);
    bool bad = hd.nodes == 0 || hd.nodes != b->nodes || hd.nodes >= QH_LEAF || hd.reserved ||
               hd.geometry < QH_HEADER_BYTES + (uint64_t)hd.nodes * QH_NODE_BYTES || hd.geometry != b->bytes_tree ||
               hd.geometry > b->size;
    for (int k = 0; k < 3; k++) {
        int e;
        bad |= !isfinite(hd.centre[k]) || !isfinite(hd.scale[k]) || !(hd.scale[k] > 0) ||
               frexpf(hd.scale[k], &e) != 0.5f || hd.scale[k] < 0x1p-100f;
    }
    if (bad) return prt__fail(PRT_ERROR_CORRUPT, "quad-half tree: header inconsistent with its size");
    uint8_t *depth = prt__calloc(hd.nodes, 1);
    if (!depth) return prt__fail(PRT_ERROR_NOMEM, "out of memory validating %u nodes", hd.nodes);
    prt_status s = PRT_OK;
    depth[0] = 1;
    const size_t geo_bytes = b->size - hd.geometry;
    for (size_t q = 0; q < hd.nodes && !s; q++) {
        if (!depth[q]) {
            s = prt__fail(PRT_ERROR_CORRUPT, "quad-half tree: node %zu is unreachable", q);
            break;
        }
        qh_node n;
        memcpy(&n, b->data + QH_HEADER_BYTES + q * QH_NODE_BYTES, sizeof n);
        for (int i = 0; i < 4 && !s; i++) {
            const uint32_t ref = n.child[i];
            bool nan = false, empty_box = true;
            for (int k = 0; k < 3; k++) {
                nan |= qh_half_is_nan(n.box[8 * k + i]) || qh_half_is_nan(n.box[8 * k + 4 + i]);
                empty_box &= n.box[8 * k + i] == QH_HALF_POS_INF && n.box[8 * k + 4 + i] == QH_HALF_NEG_INF;
            }
            if (nan || (ref == 0 && !empty_box)) {
                s = prt__fail(PRT_ERROR_CORRUPT, "quad-half tree: node %zu has a NaN box or an empty slot with a box",
                              q);
                break;
            }
            if (ref == 0) continue;
            if (ref & QH_LEAF) {
                const uint32_t k = qh_leaf_count(ref);
                const size_t off = 4 * (size_t)(ref & QH_OFFSET_MASK);
                if (k > BVH_MAX_LEAF || off > geo_bytes || geo_bytes - off < c->leaf_bytes(k) ||
                    (hd.geometry + off) % (c->align ? c->align : 1))
                    s = prt__fail(PRT_ERROR_CORRUPT, "quad-half tree: node %zu has a bad leaf reference", q);
                else if (c->leaf_valid && !c->leaf_valid(b->data + hd.geometry + off, k, sh))
                    s = prt__fail(PRT_ERROR_CORRUPT, "quad-half tree: node %zu has a leaf referencing outside the file",
                                  q);
                continue;
            }
            if (ref <= q || ref >= hd.nodes || depth[ref] || depth[q] >= BVH_MAX_DEPTH)
                s = prt__fail(PRT_ERROR_CORRUPT, "quad-half tree: node %zu has a bad child reference", q);
            else depth[ref] = (uint8_t)(depth[q] + 1);
        }
    }
    prt__free(depth);
    return s;
}

/* --- the generic walks' view (bvh_layout.root / children) -------------------------- */

/* The occupied slots of the node at byte offset node->ref, boxes decoded as the kernels do
 * (qh_plane); ref: a child node's byte offset, a leaf's block's. */
static uint32_t quad_half_children(const uint8_t *blob, const bvh_codec *c, const bvh_child *node, bvh_child out[8]) {
    (void)c;
    qh_header hd;
    memcpy(&hd, blob, sizeof hd);
    qh_node n;
    memcpy(&n, blob + node->ref, sizeof n);
    uint32_t count = 0;
    for (int i = 0; i < 4; i++) {
        const uint32_t ref = n.child[i];
        if (!ref) continue;
        bvh_child *o = &out[count++];
        for (int k = 0; k < 3; k++)
            o->box[k] = qh_plane(n.box[8 * k + i], hd.scale[k], hd.centre[k]),
            o->box[3 + k] = qh_plane(n.box[8 * k + 4 + i], hd.scale[k], hd.centre[k]);
        if (ref & QH_LEAF) o->ref = hd.geometry + 4 * (uint64_t)(ref & QH_OFFSET_MASK), o->count = qh_leaf_count(ref);
        else o->ref = QH_HEADER_BYTES + (uint64_t)QH_NODE_BYTES * ref, o->count = 0;
    }
    return count;
}

/* The root node, its box the union of its decoded child boxes. */
static bvh_child quad_half_root(const uint8_t *blob, const bvh_codec *c, const float bounds[6]) {
    (void)bounds;
    return bvh_child_inner_root(blob, c, QH_HEADER_BYTES, quad_half_children);
}

/* --- test walk (layout_debug.h) ------------------------------------------------------ */

static void debug_node(const bvh_blob *b, const qh_header *hd, uint32_t q, bvh_debug_leaf_fn leaf, void *user,
                       bvh_debug_boxes *out, prt_aabb *box) {
    qh_node n;
    memcpy(&n, b->data + QH_HEADER_BYTES + (size_t)q * QH_NODE_BYTES, sizeof n);
    for (int i = 0; i < 4; i++) {
        if (!n.child[i]) continue;
        prt_aabb child = prt_aabb_empty();
        if (n.child[i] & QH_LEAF) {
            const uint32_t k = qh_leaf_count(n.child[i]);
            leaf(user, b->data + hd->geometry + 4 * (size_t)(n.child[i] & QH_OFFSET_MASK), k, &child);
            out->triangles += k;
        } else {
            debug_node(b, hd, n.child[i], leaf, user, out, &child);
        }
        bool inside = true;
        for (int k = 0; k < 3; k++)
            inside &= qh_plane(n.box[8 * k + i], hd->scale[k], hd->centre[k]) <= child.lo[k] &&
                      qh_plane(n.box[8 * k + 4 + i], hd->scale[k], hd->centre[k]) >= child.hi[k];
        out->boxes++;
        out->violations += !inside;
        prt_aabb_grow(box, &child);
    }
}

void bvh_quad_half_debug_boxes(const bvh_blob *b, const bvh_codec *c, bvh_debug_leaf_fn leaf, void *user,
                               bvh_debug_boxes *out) {
    (void)c;
    qh_header hd;
    memcpy(&hd, b->data, sizeof hd);
    memset(out, 0, sizeof *out);
    prt_aabb all = prt_aabb_empty();
    debug_node(b, &hd, 0, leaf, user, out, &all);
}

const bvh_layout bvh_layout_quad_half = {
    "quad-half",
    "QuadTreeHalfFloat (Rouwe 5.7): 4-wide 64-byte nodes, half-float boxes relative to the root box, "
    "rounded outward",
    {[BVH_CODEC_float3] = 4,
     [BVH_CODEC_float3_soa4] = 8,
     [BVH_CODEC_float3_soa8] = 8,
     [BVH_CODEC_idx32] = 4,
     [BVH_CODEC_idx32_soa4] = 8},
    quad_half_encode,
    quad_half_validate,
    {(const bvh_kernels[BVH_CODEC_COUNT]){
#define X(id, nm, desc) \
    [BVH_CODEC_##id] = {.intersect1 = quad_half_intersect1_##id, .occluded1 = quad_half_occluded1_##id},
        BVH_CODECS(X)
#undef X
    }},
    quad_half_root,
    quad_half_children,
    NULL, /* point queries: the generic walk */
};
