/* Packing a binary BVH into wide8 nodes (wide8.h) over any kind of leaf: the SAH
 * collapse, the quantization of child boxes, and the check of a loaded blob. The BVH
 * family packs triangle codec leaves with it (wide8.c), lossygrid its sub-grids. */
#include "bvh/layouts/wide8.h"

#include <math.h>

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
    const wide8_leaves *lv;
    size_t grain; /* of the leaf sizes (write_blob) */
    int max_leaf;
    float node_fixed;        /* cost of a wide node besides its area's (wide8_pack_filled), root area 1 */
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
    *j_best = 1; /* even when every split costs infinity */
    for (int j = 1; j < slots; j++) {
        float x = c->cost[n->index][j - 1] + c->cost[n->index + 1][slots - j - 1];
        if (x < best) best = x, *j_best = (int8_t)j;
    }
    return best;
}

/* A box's half area relative to the root's, in double: costs stay finite for boxes whose
 * area would overflow a float (coordinates near PRT_MAX_COORDINATE). */
static float relative_area(const prt_aabb *b, double root) {
    double x = (double)b->hi[0] - b->lo[0], y = (double)b->hi[1] - b->lo[1], z = (double)b->hi[2] - b->lo[2];
    return (float)((x * y + y * z + z * x) / root);
}

static void collapse_costs(collapse *c) {
    const bvh_tree *t = c->t;
    const prt_aabb *rb = &t->nodes[0].box;
    double root = ((double)rb->hi[0] - rb->lo[0]) * ((double)rb->hi[1] - rb->lo[1]) +
                  ((double)rb->hi[1] - rb->lo[1]) * ((double)rb->hi[2] - rb->lo[2]) +
                  ((double)rb->hi[2] - rb->lo[2]) * ((double)rb->hi[0] - rb->lo[0]);
    if (!(root > 0) || !isfinite(root)) root = 1.0;
    for (size_t i = t->node_count; i-- > 0;) {
        const bvh_node *n = &t->nodes[i];
        const float area = relative_area(&n->box, root);
        float as_leaf = INFINITY, as_node = INFINITY;
        const uint32_t block = (uint32_t)c->lv->block;
        const bool fits = c->total[i] <= (uint32_t)c->max_leaf;
        if (fits) as_leaf = area * WIDE8_COST_BLOCK * (float)((c->total[i] + block - 1) / block);
        if (!n->count) as_node = area * WIDE8_COST_NODE + c->node_fixed + share(c, n, 8, &c->split[i]);
        /* Never a leaf past the leaf size, whatever the costs say (they tie at infinity). */
        c->leaf[i] = n->count || (fits && as_leaf <= as_node);
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
    uint32_t child; /* node index of the first inner child */
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
     * (possible only for large leaves and a small grain). */
    size_t grains = 0;
    for (int i = 0; i < n; i++) {
        if (!leaf[i]) continue;
        size_t g = c->lv->bytes(c->lv->ctx, c->total[kids[i]]) / c->grain;
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
static prt_status write_blob(const encoder *e, const wide8_leaves *c, bvh_blob *out) {
    const collapse *cl = e->c;
    const bvh_tree *t = cl->t;
    const size_t grain = cl->grain;
    const uint32_t count = e->next;
    const size_t tree = WIDE8_HEADER_BYTES + (size_t)count * WIDE8_NODE_BYTES;
    const size_t geometry = align_up(tree, c->align > 16 ? c->align : 16);
    size_t size = geometry, leaves = 0;
    for (uint32_t q = 0; q < count; q++)
        for (int i = e->plan[q].inner; i < e->plan[q].count; i++, leaves++)
            size += c->bytes(c->ctx, cl->total[e->plan[q].bin[i]]);
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
            c->encode(c->ctx, data + geo, t->prims + cl->first[bin], cl->total[bin]);
            size_t bytes = c->bytes(c->ctx, cl->total[bin]);
            geo += bytes, end += bytes / grain;
            if (end > 255) {
                prt__free(data);
                return prt__fail(
                    PRT_ERROR_LIMIT,
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

static prt_status pack(const bvh_tree *t, const wide8_leaves *c, float node_fixed, bvh_blob *out) {
    memset(out, 0, sizeof *out);
    const size_t nn = t->node_count;
    if (nn > (size_t)UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "wide8: %zu binary nodes exceed 32-bit node indices", nn);
    /* Leaves merge up to the largest leaf the builder made. */
    const uint32_t max_leaf = bvh_tree_max_leaf(t);
    const size_t head = c->bytes(c->ctx, 0), per = c->bytes(c->ctx, (uint32_t)c->block) - head;
    const size_t grain = wide8_grain(head, per);
    if (c->align % 4 || grain % 4 || grain > UINT32_MAX)
        return prt__fail(PRT_ERROR_LIMIT, "wide8: %s has leaf sizes that are not multiples of 4 bytes", c->name);
    collapse cl = {.t = t, .lv = c, .grain = grain, .max_leaf = (int)max_leaf, .node_fixed = node_fixed};
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
        s = write_blob(&e, c, out);
    }
    prt__free(cl.first), prt__free(cl.total), prt__free(cl.cost), prt__free(cl.pick), prt__free(cl.leaf),
        prt__free(cl.split), prt__free(e.plan);
    return s;
}

prt_status wide8_pack(const bvh_tree *t, const wide8_leaves *c, bvh_blob *out) { return pack(t, c, 0.0f, out); }

/* 0.001 of the root's area per node: enough to fill nodes where the SAH is indifferent
 * (bunny, leaf=8: 2099 -> 1952 nodes, depth 7); 1.0 packed more (1851) at depth 8-9. */
prt_status wide8_pack_filled(const bvh_tree *t, const wide8_leaves *c, bvh_blob *out) { return pack(t, c, 1e-3f, out); }

/* --- validation of a loaded blob ---------------------------------------------------- */

/* Every node referenced exactly once by an earlier node, slots in order (inner, leaves,
 * empty), every leaf a whole number of blocks inside the geometry range and valid, planes finite, depth bounded:
 * traversal can then neither leave the blob, loop, nor overflow its stack. */
prt_status wide8_check(const bvh_blob *b, const wide8_leaves *c) {
    wide8_header hd;
    if (b->size < WIDE8_HEADER_BYTES) return prt__fail(PRT_ERROR_CORRUPT, "wide8 tree: shorter than its header");
    memcpy(&hd, b->data, sizeof hd);
    const size_t head = c->bytes(c->ctx, 0), per = c->bytes(c->ctx, (uint32_t)c->block) - head;
    const size_t tree = WIDE8_HEADER_BYTES + (size_t)hd.nodes * WIDE8_NODE_BYTES;
    /* The grain wide8_pack chooses, which the kernels assume (a constant per codec). */
    if (hd.nodes == 0 || hd.nodes != b->nodes || hd.grain != wide8_grain(head, per) || hd.grain % 4 ||
        hd.geometry < tree || hd.geometry != b->bytes_tree || hd.geometry > b->size || hd.geometry % 16 ||
        hd.geometry % c->align)
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
            if (k == 0 || k > c->max_count || off > geo_bytes || geo_bytes - off < bytes ||
                (hd.geometry + off) % c->align ||
                (c->valid && !c->valid(c->ctx, b->data + hd.geometry + off, (uint32_t)k))) {
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
