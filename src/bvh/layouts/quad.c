/* QuadTree (Rouwé 2019, §5.6): 4-wide nodes made by collapsing the binary tree, the four
 * child boxes in SOA form for one SIMD slab test. A node is 128 bytes (two cache lines):
 * 24 floats of boxes and four 64-bit child references. All nodes come first, depth first,
 * then all leaf blocks, so tree and geometry bytes are separate ranges of the blob.
 *
 * Child reference: 0 = empty slot; bit 63 set = leaf with the triangle count in bits
 * 56..62 and the byte offset of its block in bits 0..55; otherwise the byte offset of a
 * child node, always greater than its parent's (forward only, which validation uses). */
#include "bvh/layouts/quad_plan.h"
#include "bvh/traverse.h"

#include <math.h>

#define QUAD_LEAF (1ull << 63)
#define QUAD_OFFSET_MASK ((1ull << 56) - 1)
#define QUAD_STACK (3 * BVH_MAX_DEPTH + 4)

typedef struct quad_node {
    float box[24]; /* lo_x[4], hi_x[4], lo_y[4], hi_y[4], lo_z[4], hi_z[4] */
    uint64_t child[4];
} quad_node;

_Static_assert(sizeof(quad_node) == 128, "quad node is two cache lines");

static inline uint32_t quad_leaf_count(uint64_t ref) { return (uint32_t)((ref >> 56) & 0x7F); }

#define LAYOUT_KERNELS "bvh/layouts/quad_kernels.inc"
#include "bvh/layouts/instantiate.inc"
#undef LAYOUT_KERNELS

/* Binary children of a binary node, expanded (largest surface area first) up to four. */
static int collapse(const bvh_tree *t, uint32_t bin, uint32_t out[4]) {
    const bvh_node *n = &t->nodes[bin];
    if (n->count) {
        out[0] = bin;
        return 1;
    }
    int c = 2;
    out[0] = n->index, out[1] = n->index + 1;
    while (c < 4) {
        int best = -1;
        float area = -1;
        for (int i = 0; i < c; i++) {
            const bvh_node *k = &t->nodes[out[i]];
            float a = prt_aabb_half_area(&k->box);
            if (!k->count && a > area) area = a, best = i;
        }
        if (best < 0) break;
        uint32_t k = t->nodes[out[best]].index;
        out[best] = k;
        out[c++] = k + 1;
    }
    return c;
}

/* Depth-first numbering of the quad nodes (preorder: parents before children). */
static uint32_t plan(const bvh_tree *t, uint32_t bin, quad_plan *p, uint32_t *next) {
    uint32_t q = (*next)++;
    p[q].count = collapse(t, bin, p[q].bin);
    for (int i = 0; i < p[q].count; i++)
        if (!t->nodes[p[q].bin[i]].count) p[q].quad[i] = plan(t, p[q].bin[i], p, next);
    return q;
}

uint32_t bvh_quad_plan(const bvh_tree *t, quad_plan *p) {
    uint32_t count = 0;
    plan(t, 0, p, &count);
    return count;
}

static size_t align_up(size_t x, size_t a) { return (x + a - 1) / a * a; }

static prt_status quad_encode(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bvh_blob *out) {
    memset(out, 0, sizeof *out);
    quad_plan *p = prt__alloc(prt__mul_size(t->node_count, sizeof *p));
    if (!p) return prt__fail(PRT_ERROR_NOMEM, "out of memory planning %zu nodes", t->node_count);
    uint32_t count = bvh_quad_plan(t, p);
    size_t tree = (size_t)count * sizeof(quad_node), size = tree;
    for (uint32_t q = 0; q < count; q++)
        for (int i = 0; i < p[q].count; i++) {
            const bvh_node *n = &t->nodes[p[q].bin[i]];
            if (n->count) size = align_up(size, c->align) + c->leaf_bytes(n->count);
        }
    if (size > QUAD_OFFSET_MASK) {
        prt__free(p);
        return prt__fail(PRT_ERROR_LIMIT, "quad layout: %zu bytes exceed the 56-bit offsets", size);
    }
    uint8_t *data = prt__calloc(1, size);
    if (!data) {
        prt__free(p);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for a %zu-byte tree", size);
    }
    size_t geo = tree;
    uint32_t depth = 0;
    for (uint32_t q = 0; q < count; q++) {
        quad_node node;
        for (int i = 0; i < 4; i++) {
            const prt_aabb *b = i < p[q].count ? &t->nodes[p[q].bin[i]].box : NULL;
            for (int k = 0; k < 3; k++) {
                node.box[8 * k + i] = b ? b->lo[k] : INFINITY;
                node.box[8 * k + 4 + i] = b ? b->hi[k] : -INFINITY;
            }
            node.child[i] = 0;
            if (!b) continue;
            const bvh_node *n = &t->nodes[p[q].bin[i]];
            if (n->count) {
                geo = align_up(geo, c->align);
                c->encode(data + geo, m, t->prims + n->index, n->count);
                node.child[i] = QUAD_LEAF | ((uint64_t)n->count << 56) | geo;
                geo += c->leaf_bytes(n->count);
            } else {
                node.child[i] = (uint64_t)p[q].quad[i] * sizeof(quad_node);
            }
        }
        memcpy(data + (size_t)q * sizeof node, &node, sizeof node);
    }
    depth = t->depth; /* collapsing only shortens paths */
    prt__free(p);
    out->data = data;
    out->size = size;
    out->bytes_tree = tree;
    out->bytes_geometry = size - tree;
    out->nodes = count;
    out->leaves = t->leaf_count;
    out->depth = depth;
    return PRT_OK;
}

/* Every node referenced exactly once by an earlier node, every leaf inside the geometry
 * range, depth bounded: traversal can then neither leave the blob, loop, nor overflow
 * its stack. */
static prt_status quad_validate(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh) {
    size_t count = b->bytes_tree / sizeof(quad_node);
    if (count == 0 || b->bytes_tree % sizeof(quad_node) || b->bytes_tree > b->size || count != b->nodes)
        return prt__fail(PRT_ERROR_CORRUPT, "quad tree: node range inconsistent with its size");
    uint8_t *depth = prt__calloc(count, 1);
    if (!depth) return prt__fail(PRT_ERROR_NOMEM, "out of memory validating %zu nodes", count);
    prt_status s = PRT_OK;
    depth[0] = 1;
    for (size_t q = 0; q < count && !s; q++) {
        if (!depth[q]) s = prt__fail(PRT_ERROR_CORRUPT, "quad tree: node %zu is unreachable", q);
        const quad_node *n = (const quad_node *)(b->data + q * sizeof(quad_node));
        for (int i = 0; i < 4 && !s; i++) {
            uint64_t ref = n->child[i];
            /* No NaN anywhere: SIMD min/max pass NaNs on, which could make an empty slot's
             * box hit and send a ray to "node 0" again, forever (found by fuzz_prt). */
            bool nan = false;
            for (int k = 0; k < 6; k++) nan |= isnan(n->box[4 * k + i]);
            if (nan) {
                s = prt__fail(PRT_ERROR_CORRUPT, "quad tree: node %zu has a NaN box", q);
                continue;
            }
            if (ref == 0) {
                /* An empty slot must have the empty box on every axis. */
                for (int k = 0; k < 3; k++)
                    if (n->box[8 * k + i] != INFINITY || n->box[8 * k + 4 + i] != -INFINITY)
                        s = prt__fail(PRT_ERROR_CORRUPT, "quad tree: node %zu has an empty slot with a box", q);
                continue;
            }
            uint64_t off = ref & QUAD_OFFSET_MASK;
            if (ref & QUAD_LEAF) {
                uint32_t k = quad_leaf_count(ref);
                if (k == 0 || k > BVH_MAX_LEAF || off < b->bytes_tree || off % c->align || off > b->size ||
                    b->size - off < c->leaf_bytes(k))
                    s = prt__fail(PRT_ERROR_CORRUPT, "quad tree: node %zu has a bad leaf reference", q);
                else if (c->leaf_valid && !c->leaf_valid(b->data + off, k, sh))
                    s = prt__fail(PRT_ERROR_CORRUPT, "quad tree: node %zu has a leaf referencing outside the file", q);
                continue;
            }
            size_t child = off / sizeof(quad_node);
            if ((ref >> 56) || off % sizeof(quad_node) || child <= q || child >= count || depth[child] ||
                depth[q] >= BVH_MAX_DEPTH)
                s = prt__fail(PRT_ERROR_CORRUPT, "quad tree: node %zu has a bad child reference", q);
            else depth[child] = (uint8_t)(depth[q] + 1);
        }
    }
    prt__free(depth);
    return s;
}

/* --- the generic walks' view (bvh_layout.root / children) -------------------------- */

/* The occupied slots of the node at byte offset node->ref, with their stored boxes; ref: a
 * child node's byte offset, a leaf's block's. */
static uint32_t quad_children(const uint8_t *blob, const bvh_codec *c, const bvh_child *node, bvh_child out[8]) {
    (void)c;
    quad_node n;
    memcpy(&n, blob + node->ref, sizeof n);
    uint32_t count = 0;
    for (int i = 0; i < 4; i++) {
        const uint64_t ref = n.child[i];
        if (!ref) continue;
        bvh_child *o = &out[count++];
        for (int k = 0; k < 3; k++) o->box[k] = n.box[8 * k + i], o->box[3 + k] = n.box[8 * k + 4 + i];
        o->ref = ref & QUAD_OFFSET_MASK;
        o->count = ref & QUAD_LEAF ? quad_leaf_count(ref) : 0;
    }
    return count;
}

/* The root node (offset 0), its box the union of its child boxes. */
static bvh_child quad_root(const uint8_t *blob, const bvh_codec *c, const float bounds[6]) {
    (void)bounds;
    return bvh_child_inner_root(blob, c, 0, quad_children);
}

const bvh_layout bvh_layout_quad = {
    "quad",
    "QuadTree (Rouwe 5.6): 4-wide 128-byte nodes, SIMD box test, nearest child first",
    {[BVH_CODEC_float3] = 4,
     [BVH_CODEC_float3_soa4] = 8,
     [BVH_CODEC_float3_soa8] = 8,
     [BVH_CODEC_idx32] = 4,
     [BVH_CODEC_idx32_soa4] = 8},
    quad_encode,
    quad_validate,
    {(const bvh_kernels[BVH_CODEC_COUNT]){
#define X(id, nm, desc) [BVH_CODEC_##id] = {.intersect1 = quad_intersect1_##id, .occluded1 = quad_occluded1_##id},
        BVH_CODECS(X)
#undef X
    }},
    quad_root,
    quad_children,
    NULL, /* point queries: the generic walk */
};
