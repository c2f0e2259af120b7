/* Wide8: an 8-wide BVH with quantized child boxes in 80-byte nodes (after Ylitie et al.
 * 2017; beyond Rouwé's paper). The binary tree is collapsed to up to eight children per
 * node; child boxes are stored as 8-bit offsets on a per-node power-of-two grid, rounded
 * outward, so one node costs what Rouwé's QuadTreeHalfFloat costs for four children.
 * Node format and blob layout: wide8.h. */
#include "bvh/layouts/wide8.h"
#include "bvh/traverse.h"

#include <math.h>

/* Per-ray constants of the 8-lane box test, and the blob's header fields. */
typedef struct wide8_ray {
    vf8 org[3], inv[3];
    float tnear;
    int near[3], far[3]; /* row of q holding the near and far plane on each axis */
    uint64_t geometry;
    uint32_t grain;
} wide8_ray;

static inline void wide8_ray_init(wide8_ray *w, const prt__rayx *r, const uint8_t *blob) {
    for (int k = 0; k < 3; k++) {
        w->org[k] = vf8_set1(r->org[k]);
        w->inv[k] = vf8_set1(r->inv[k]);
        w->near[k] = 2 * k + r->neg[k];
        w->far[k] = 2 * k + 1 - r->neg[k];
    }
    w->tnear = r->tnear;
    wide8_header hd;
    memcpy(&hd, blob, sizeof hd);
    w->geometry = hd.geometry;
    w->grain = hd.grain;
}

/* Bit mask of the occupied slots: inner ones and leaves (non-zero meta). */
static inline unsigned wide8_occupied(const wide8_node *n) {
#if defined(__SSE4_1__)
    __m128i meta = _mm_loadl_epi64((const __m128i *)n->meta);
    unsigned zero = (unsigned)_mm_movemask_epi8(_mm_cmpeq_epi8(meta, _mm_setzero_si128())) & 0xFF;
    return n->imask | (~zero & 0xFF);
#else
    unsigned m = n->imask;
    for (int i = 0; i < 8; i++) m |= (unsigned)(n->meta[i] != 0) << i;
    return m;
#endif
}

/* The per-axis scales 2^(e - 127) of a node: its three exponent bytes moved into the
 * exponent field of three lanes at once, then broadcast. */
static inline void wide8_scales(const wide8_node *n, vf8 s[3]) {
#if defined(__AVX2__)
    int32_t bytes;
    memcpy(&bytes, n->e, 4); /* e[0..2] and imask, whose lane is ignored */
    const __m256 e = _mm256_castps128_ps256(_mm_castsi128_ps(_mm_slli_epi32(_mm_cvtepu8_epi32(_mm_cvtsi32_si128(bytes)), 23)));
    s[0] = (vf8)_mm256_permutevar8x32_ps(e, _mm256_set1_epi32(0));
    s[1] = (vf8)_mm256_permutevar8x32_ps(e, _mm256_set1_epi32(1));
    s[2] = (vf8)_mm256_permutevar8x32_ps(e, _mm256_set1_epi32(2));
#else
    for (int k = 0; k < 3; k++) s[k] = vf8_set1(wide8_scale(n->e[k]));
#endif
}

/* The robust slab test of geom/box.h on the eight decoded child boxes. The far distance
 * grows by 2^-21 of its magnitude (one fma on |tmax|), more than the 2 gamma(3) that
 * makes the test conservative (Ize 2013), as box.h's two-sided scaling does. */
static inline unsigned wide8_box_hit(const wide8_node *n, const wide8_ray *w, float tfar, vf8 *tentry) {
    vf8 tmin = vf8_set1(w->tnear), tmax = vf8_set1(tfar), s[3];
    wide8_scales(n, s);
    for (int k = 0; k < 3; k++) {
        const vf8 p = vf8_set1(n->p[k]);
        const vf8 near = vf8_fmadd(vf8_from_u8(n->q[w->near[k]]), s[k], p);
        const vf8 far = vf8_fmadd(vf8_from_u8(n->q[w->far[k]]), s[k], p);
        tmin = vf8_max((near - w->org[k]) * w->inv[k], tmin); /* NaN in the first operand: tmin */
        tmax = vf8_min((far - w->org[k]) * w->inv[k], tmax);
    }
    const vi8 magnitude = (vi8)tmax & (vi8){0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF, 0x7FFFFFFF};
    tmax = vf8_fmadd((vf8)magnitude, vf8_set1(0x1p-21f), tmax);
    *tentry = tmin;
    return (unsigned)vi8_mask(tmin <= tmax) & wide8_occupied(n);
}

#define LAYOUT_KERNELS "bvh/layouts/wide8_kernels.inc"
#include "bvh/layouts/instantiate.inc"
#undef LAYOUT_KERNELS

/* --- encoding ----------------------------------------------------------------------- */

/* Collapsing the binary tree into 8-wide nodes by the surface area heuristic (Ylitie et
 * al. 2017, §3.2): for every binary node n and slot budget i, cost[n][i] is the cheapest
 * way to hand n's subtree to a parent in at most i slots, as one leaf (n's triangles
 * merged, up to the leaf size), one wide node, or n's two children sharing the budget.
 * Costs are SAH: surface area times one node test, or times the leaf's blocks. */
#define WIDE8_COST_NODE 1.0f
#define WIDE8_COST_BLOCK 1.0f

typedef struct collapse {
    const bvh_tree *t;
    const bvh_codec *codec;
    size_t grain; /* of the codec's leaf sizes (write_blob) */
    int max_leaf;
    uint32_t *first, *total; /* per binary node: its triangles t->prims[first .. first + total) */
    float (*cost)[8];        /* cost[n][i - 1]: at most i slots */
    int8_t (*pick)[8];       /* 0: as one slot (see leaf); j > 0: j slots to the first child */
    uint8_t *leaf;           /* one slot: as a leaf (1) or as a wide node (0) */
    int8_t *split;           /* as a wide node: slots of its first child */
} collapse;

/* Subtree triangle ranges, children before parents (builders number children after
 * their parent). False when a subtree's triangles are not one run of t->prims. */
static bool subtree_ranges(collapse *c) {
    const bvh_tree *t = c->t;
    for (size_t i = t->node_count; i-- > 0;) {
        const bvh_node *n = &t->nodes[i];
        if (n->count) {
            c->first[i] = n->index, c->total[i] = n->count;
            continue;
        }
        uint32_t a = n->index, b = n->index + 1;
        if (a <= i || b >= t->node_count) return false;
        uint32_t lo = PRT_MIN(c->first[a], c->first[b]);
        if ((size_t)c->total[a] + c->total[b] > UINT32_MAX ||
            PRT_MAX(c->first[a] + c->total[a], c->first[b] + c->total[b]) - lo != c->total[a] + c->total[b])
            return false;
        c->first[i] = lo, c->total[i] = c->total[a] + c->total[b];
    }
    return true;
}

/* Best split of `slots` slots between the two children of inner node n. */
static float share(const collapse *c, const bvh_node *n, int slots, int8_t *j_best) {
    float best = INFINITY;
    for (int j = 1; j < slots; j++) {
        float x = c->cost[n->index][j - 1] + c->cost[n->index + 1][slots - j - 1];
        if (x < best) best = x, *j_best = (int8_t)j;
    }
    return best;
}

static void collapse_costs(collapse *c) {
    const bvh_tree *t = c->t;
    for (size_t i = t->node_count; i-- > 0;) {
        const bvh_node *n = &t->nodes[i];
        const float area = prt_aabb_half_area(&n->box);
        float as_leaf = INFINITY, as_node = INFINITY;
        const uint32_t block = (uint32_t)c->codec->block;
        if (c->total[i] <= (uint32_t)c->max_leaf)
            as_leaf = area * WIDE8_COST_BLOCK * (float)((c->total[i] + block - 1) / block);
        if (!n->count) as_node = area * WIDE8_COST_NODE + share(c, n, 8, &c->split[i]);
        c->leaf[i] = as_leaf <= as_node;
        const float one = PRT_MIN(as_leaf, as_node);
        for (int slots = 1; slots <= 8; slots++) {
            c->cost[i][slots - 1] = one, c->pick[i][slots - 1] = 0;
            int8_t j = 0;
            float x = n->count || slots == 1 ? INFINITY : share(c, n, slots, &j);
            if (x < one) c->cost[i][slots - 1] = x, c->pick[i][slots - 1] = j;
        }
    }
}

/* The slots (binary node, as a leaf or not) that subtree n fills with a budget of i. */
static void gather(const collapse *c, uint32_t n, int slots, uint32_t *bin, uint8_t *leaf, int *count) {
    int j = c->pick[n][slots - 1];
    if (j) {
        gather(c, c->t->nodes[n].index, j, bin, leaf, count);
        gather(c, c->t->nodes[n].index + 1, slots - j, bin, leaf, count);
        return;
    }
    bin[*count] = n, leaf[*count] = c->leaf[n], ++*count;
}

typedef struct wide8_plan {
    uint32_t bin[8]; /* binary node of each slot: inner children first, then leaves */
    int count, inner;
    uint32_t child;  /* node index of the first inner child */
} wide8_plan;

typedef struct encoder {
    const collapse *c;
    wide8_plan *plan;
    uint32_t next; /* next free node index */
    uint32_t depth;
} encoder;

/* Plan node q for binary node bin (its children's slots, or bin itself as the one leaf of
 * a root that is a leaf): the inner children get consecutive indices, then each is
 * planned in turn (depth first over sibling blocks). */
static void plan_node(encoder *e, uint32_t q, uint32_t bin, uint32_t depth) {
    const collapse *c = e->c;
    wide8_plan *p = &e->plan[q];
    uint32_t kids[8];
    uint8_t leaf[8];
    int n = 0;
    if (c->leaf[bin]) kids[0] = bin, leaf[0] = 1, n = 1;
    else {
        int j = c->split[bin];
        gather(c, c->t->nodes[bin].index, j, kids, leaf, &n);
        gather(c, c->t->nodes[bin].index + 1, 8 - j, kids, leaf, &n);
    }
    /* A node addresses 255 grains of leaves: a leaf past that gets a node of its own
     * (possible only for codecs with large leaves and a small grain). */
    size_t grains = 0;
    for (int i = 0; i < n; i++) {
        if (!leaf[i]) continue;
        size_t g = c->codec->leaf_bytes(c->total[kids[i]]) / c->grain;
        if (grains + g > 255 && !(n == 1 && bin == kids[i])) leaf[i] = 0;
        else grains += g;
    }
    int inner = 0;
    for (int i = 0; i < n; i++)
        if (!leaf[i]) p->bin[inner++] = kids[i];
    int slot = inner;
    for (int i = 0; i < n; i++)
        if (leaf[i]) p->bin[slot++] = kids[i];
    p->count = n, p->inner = inner;
    p->child = e->next;
    e->next += (uint32_t)inner;
    if (depth > e->depth) e->depth = depth;
    for (int i = 0; i < inner; i++) plan_node(e, p->child + (uint32_t)i, p->bin[i], depth + 1);
}

static size_t gcd_size(size_t a, size_t b) {
    while (b) {
        size_t r = a % b;
        a = b, b = r;
    }
    return a;
}

static size_t align_up(size_t x, size_t a) { return (x + a - 1) / a * a; }

/* Quantize the child boxes of one axis on the grid p + q * s: the smallest power-of-two
 * s that spans the node, then each plane rounded outward and checked with the very fmaf
 * the kernel computes. Returns the exponent byte. */
static uint8_t quantize_axis(const prt_aabb *const *boxes, int count, int k, float lo, float hi, uint8_t qlo[8],
                             uint8_t qhi[8]) {
    int x;
    frexpf((hi - lo) / 255.0f, &x);
    if (x < -126) x = -126;
    float s = ldexpf(1.0f, x);
    while (fmaf(255.0f, s, lo) < hi) s *= 2.0f, x++; /* hi - lo was rounded down */
    for (int i = 0; i < count; i++) {
        float blo = boxes[i]->lo[k], bhi = boxes[i]->hi[k];
        float a = floorf((blo - lo) / s), b = ceilf((bhi - lo) / s);
        int ql = a < 0 ? 0 : a > 255 ? 255 : (int)a;
        int qh = b < 0 ? 0 : b > 255 ? 255 : (int)b;
        while (ql > 0 && fmaf((float)ql, s, lo) > blo) ql--;
        while (qh < 255 && fmaf((float)qh, s, lo) < bhi) qh++;
        qlo[i] = (uint8_t)ql, qhi[i] = (uint8_t)qh;
    }
    for (int i = count; i < 8; i++) qlo[i] = 1, qhi[i] = 0; /* empty: never read (masked) */
    return (uint8_t)(x + 127);
}

/* Write the planned nodes and their leaves into a new blob. */
static prt_status write_blob(const encoder *e, const bvh_codec *c, const prt_mesh *m, bvh_blob *out) {
    const collapse *cl = e->c;
    const bvh_tree *t = cl->t;
    const size_t grain = cl->grain;
    const uint32_t count = e->next;
    const size_t tree = WIDE8_HEADER_BYTES + (size_t)count * WIDE8_NODE_BYTES;
    const size_t geometry = align_up(tree, c->align > 16 ? c->align : 16);
    size_t size = geometry, leaves = 0;
    for (uint32_t q = 0; q < count; q++)
        for (int i = e->plan[q].inner; i < e->plan[q].count; i++, leaves++)
            size += c->leaf_bytes(cl->total[e->plan[q].bin[i]]);
    if ((size - geometry) / 4 > UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "wide8: %zu bytes of leaves exceed the 16 GB of 32-bit word offsets",
                         size - geometry);
    uint8_t *data = prt__calloc(1, size);
    if (!data) return prt__fail(PRT_ERROR_NOMEM, "out of memory for a %zu-byte tree", size);
    wide8_header hd = {(uint32_t)grain, count, geometry};
    memcpy(data, &hd, sizeof hd);
    size_t geo = geometry;
    for (uint32_t q = 0; q < count; q++) {
        const wide8_plan *p = &e->plan[q];
        const prt_aabb *boxes[8];
        prt_aabb box = prt_aabb_empty();
        for (int i = 0; i < p->count; i++) {
            boxes[i] = &t->nodes[p->bin[i]].box;
            for (int k = 0; k < 3; k++) {
                box.lo[k] = fminf(box.lo[k], boxes[i]->lo[k]);
                box.hi[k] = fmaxf(box.hi[k], boxes[i]->hi[k]);
            }
        }
        wide8_node node;
        memset(&node, 0, sizeof node);
        for (int k = 0; k < 3; k++) {
            node.p[k] = box.lo[k];
            node.e[k] = quantize_axis(boxes, p->count, k, box.lo[k], box.hi[k], node.q[2 * k], node.q[2 * k + 1]);
        }
        node.imask = (uint8_t)((1u << p->inner) - 1);
        node.child = p->inner ? p->child : 0;
        node.leaf = (uint32_t)((geo - geometry) / 4);
        size_t end = 0;
        for (int i = p->inner; i < p->count; i++) {
            const uint32_t bin = p->bin[i];
            c->encode(data + geo, m, t->prims + cl->first[bin], cl->total[bin]);
            size_t bytes = c->leaf_bytes(cl->total[bin]);
            geo += bytes, end += bytes / grain;
            if (end > 255) {
                prt__free(data);
                return prt__fail(PRT_ERROR_LIMIT,
                                 "wide8: the leaves of one node exceed 255 grains of %zu bytes; use a smaller leaf size", grain);
            }
            node.meta[i] = (uint8_t)end;
        }
        memcpy(data + WIDE8_HEADER_BYTES + (size_t)q * WIDE8_NODE_BYTES, &node, sizeof node);
    }
    out->data = data;
    out->size = size;
    out->bytes_tree = geometry;
    out->bytes_geometry = size - geometry;
    out->nodes = count;
    out->leaves = leaves;
    out->depth = e->depth;
    return PRT_OK;
}

static prt_status wide8_encode(const bvh_tree *t, const bvh_codec *c, const prt_mesh *m, bvh_blob *out) {
    memset(out, 0, sizeof *out);
    const size_t nn = t->node_count;
    if (nn > (size_t)UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "wide8: %zu binary nodes exceed 32-bit node indices", nn);
    /* Leaves merge up to the largest leaf the builder made, which the spec's leaf size bounds. */
    uint32_t max_leaf = 1;
    for (size_t i = 0; i < nn; i++) max_leaf = PRT_MAX(max_leaf, t->nodes[i].count);
    const size_t head = c->leaf_bytes(0), per = c->leaf_bytes((uint32_t)c->block) - head;
    const size_t grain = head ? gcd_size(head, per) : per;
    if (c->align % 4 || grain % 4 || grain > UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "wide8: codec %s has leaf sizes that are not multiples of 4 bytes", c->name);
    collapse cl = {.t = t, .codec = c, .grain = grain, .max_leaf = (int)max_leaf};
    cl.first = prt__alloc(prt__mul_size(nn, sizeof *cl.first));
    cl.total = prt__alloc(prt__mul_size(nn, sizeof *cl.total));
    cl.cost = prt__alloc(prt__mul_size(nn, sizeof *cl.cost));
    cl.pick = prt__alloc(prt__mul_size(nn, sizeof *cl.pick));
    cl.leaf = prt__alloc(nn);
    cl.split = prt__alloc(nn);
    encoder e = {&cl, prt__alloc(prt__mul_size(nn, sizeof(wide8_plan))), 1, 1};
    prt_status s = PRT_OK;
    if (!cl.first || !cl.total || !cl.cost || !cl.pick || !cl.leaf || !cl.split || !e.plan)
        s = prt__fail(PRT_ERROR_NOMEM, "out of memory planning %zu nodes", nn);
    else if (!subtree_ranges(&cl))
        s = prt__fail(PRT_ERROR_ARGUMENT, "wide8: a subtree's triangles are not contiguous in the builder's order");
    if (!s) {
        collapse_costs(&cl);
        plan_node(&e, 0, 0, 1);
        s = write_blob(&e, c, m, out);
    }
    prt__free(cl.first), prt__free(cl.total), prt__free(cl.cost), prt__free(cl.pick), prt__free(cl.leaf),
        prt__free(cl.split), prt__free(e.plan);
    return s;
}

/* --- validation of a loaded blob ---------------------------------------------------- */

/* Every node referenced exactly once by an earlier node, slots in order (inner, leaves,
 * empty), every leaf a whole number of codec blocks inside the geometry range and valid
 * for the codec, planes finite, depth bounded: traversal can then neither leave the blob,
 * loop, nor overflow its stack. */
static prt_status wide8_validate(const bvh_blob *b, const bvh_codec *c, const bvh_shared *sh) {
    wide8_header hd;
    if (b->size < WIDE8_HEADER_BYTES) return prt__fail(PRT_ERROR_CORRUPT, "wide8 tree: shorter than its header");
    memcpy(&hd, b->data, sizeof hd);
    const size_t head = c->leaf_bytes(0), per = c->leaf_bytes((uint32_t)c->block) - head;
    const size_t tree = WIDE8_HEADER_BYTES + (size_t)hd.nodes * WIDE8_NODE_BYTES;
    if (hd.nodes == 0 || hd.nodes != b->nodes || hd.grain == 0 || hd.grain % 4 || hd.geometry < tree ||
        hd.geometry != b->bytes_tree || hd.geometry > b->size || hd.geometry % 16 || hd.geometry % c->align)
        return prt__fail(PRT_ERROR_CORRUPT, "wide8 tree: header inconsistent with its size");
    uint8_t *depth = prt__calloc(hd.nodes, 1);
    if (!depth) return prt__fail(PRT_ERROR_NOMEM, "out of memory validating %u nodes", hd.nodes);
    prt_status s = PRT_OK;
    depth[0] = 1;
    const size_t geo_bytes = b->size - hd.geometry;
    for (size_t q = 0; q < hd.nodes && !s; q++) {
        wide8_node n;
        memcpy(&n, b->data + WIDE8_HEADER_BYTES + q * WIDE8_NODE_BYTES, sizeof n);
        if (!depth[q]) {
            s = prt__fail(PRT_ERROR_CORRUPT, "wide8 tree: node %zu is unreachable", q);
            break;
        }
        bool bad = false;
        for (int k = 0; k < 3; k++) bad |= !isfinite(n.p[k]) || n.e[k] == 0 || n.e[k] == 255;
        /* Slots: inner ones first (meta 0), then leaves (meta rising), then empty (meta 0). */
        int inner = __builtin_popcount(n.imask);
        bad |= n.imask != (1u << inner) - 1;
        int i = inner;
        uint32_t prev = 0;
        for (int j = 0; j < inner; j++) bad |= n.meta[j] != 0;
        for (; i < 8 && n.meta[i]; i++) {
            size_t bytes = (size_t)(n.meta[i] - prev) * hd.grain;
            if (n.meta[i] <= prev || bytes < head || (bytes - head) % per) {
                bad = true;
                break;
            }
            size_t k = (bytes - head) / per * (size_t)c->block;
            size_t off = 4 * (size_t)n.leaf + (size_t)prev * hd.grain;
            if (k == 0 || k > BVH_MAX_LEAF || off > geo_bytes || geo_bytes - off < bytes ||
                (hd.geometry + off) % c->align ||
                (c->leaf_valid && !c->leaf_valid(b->data + hd.geometry + off, (uint32_t)k, sh))) {
                bad = true;
                break;
            }
            prev = n.meta[i];
        }
        for (; i < 8; i++) bad |= n.meta[i] != 0;
        bad |= inner == 0 && n.meta[0] == 0; /* no child at all */
        if (bad) {
            s = prt__fail(PRT_ERROR_CORRUPT, "wide8 tree: node %zu has a bad slot", q);
            break;
        }
        if (!inner) continue;
        if (n.child <= q || (size_t)n.child + (size_t)inner > hd.nodes || depth[q] >= BVH_MAX_DEPTH) {
            s = prt__fail(PRT_ERROR_CORRUPT, "wide8 tree: node %zu has a bad child reference", q);
            break;
        }
        for (int j = 0; j < inner && !s; j++) {
            if (depth[n.child + (size_t)j])
                s = prt__fail(PRT_ERROR_CORRUPT, "wide8 tree: node %u is referenced twice", n.child + j);
            depth[n.child + (size_t)j] = (uint8_t)(depth[q] + 1);
        }
    }
    prt__free(depth);
    return s;
}

const bvh_layout bvh_layout_wide8 = {
    "wide8",
    "8-wide BVH after Ylitie et al. 2017 (beyond Rouwe): 80-byte nodes, child boxes as 8-bit offsets on a "
    "power-of-two grid, one 8-lane box test",
    {[BVH_CODEC_float3] = 4, [BVH_CODEC_float3_soa4] = 8, [BVH_CODEC_float3_soa8] = 16, [BVH_CODEC_idx32] = 4,
     [BVH_CODEC_idx32_soa4] = 8},
    wide8_encode,
    wide8_validate,
    {
#define X(id, nm, desc) [BVH_CODEC_##id] = {wide8_intersect1_##id, wide8_occluded1_##id},
        BVH_CODECS(X)
#undef X
    },
};
