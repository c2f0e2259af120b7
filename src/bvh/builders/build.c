/* The builder driver shared by every splitter: recursion, node allocation, leaf rules,
 * depth limit and OpenMP tasks for large subtrees. A splitter only partitions. */
#include "bvh/tree.h"
#include "core/simd.h"

#include <omp.h>
#include <stdatomic.h>

const char *const bvh_split_names[BVH_SPLIT_COUNT] = {"sah", "mean", "longest", "morton", "fixed"};

/* Below this depth the driver stops trusting the splitter and halves the count, so depth
 * is bounded by this plus log2(n). */
#define MEDIAN_FROM_DEPTH 64
#define TASK_MIN_PRIMS 8192

static void bounds_of(const bvh_prim *p, size_t n, prt_aabb *box, prt_aabb *cbox) {
    vf4 lo = vf4_set1(FLT_MAX), hi = vf4_set1(-FLT_MAX), clo = lo, chi = hi;
    for (size_t i = 0; i < n; i++) {
        vf4 a = vf4_load(p[i].lo), b = vf4_load(p[i].hi);
        a[3] = b[3] = 0.0f; /* lane 3 holds the id's bits: often a denormal, which is slow */
        vf4 c = (a + b) * vf4_set1(0.5f);
        lo = vf4_min(lo, a), hi = vf4_max(hi, b);
        clo = vf4_min(clo, c), chi = vf4_max(chi, c);
    }
    for (int k = 0; k < 3; k++) {
        box->lo[k] = lo[k], box->hi[k] = hi[k];
        cbox->lo[k] = clo[k], cbox->hi[k] = chi[k];
    }
}

static void swap_prims(bvh_prim *a, bvh_prim *b) {
    bvh_prim t = *a;
    *a = *b;
    *b = t;
}

/* Quickselect with a three-way partition: afterwards p[k] has the k-th smallest centroid
 * on axis, smaller ones before it, larger after. Equal keys (the common degenerate case)
 * end the loop at once. */
static void select_nth(bvh_prim *p, size_t n, size_t k, int axis) {
    size_t lo = 0, hi = n;
    while (hi - lo > 1) {
        float a = bvh_centroid(&p[lo], axis), b = bvh_centroid(&p[lo + (hi - lo) / 2], axis),
              c = bvh_centroid(&p[hi - 1], axis);
        float pivot = prt_maxf(prt_minf(a, b), prt_minf(prt_maxf(a, b), c));
        size_t lt = lo, i = lo, gt = hi;
        while (i < gt) {
            float x = bvh_centroid(&p[i], axis);
            if (x < pivot) swap_prims(&p[lt++], &p[i++]);
            else if (x > pivot) swap_prims(&p[i], &p[--gt]);
            else i++;
        }
        if (k < lt) hi = lt;
        else if (k >= gt) lo = gt;
        else return;
    }
}

/* Median split by count on the longest centroid axis: always makes progress, so it is the
 * fallback when a splitter finds nothing and the guard against very deep trees. */
static size_t median_split(const bvh_builder *b, bvh_prim *p, size_t n, const prt_aabb *cbox) {
    if (b->keys) return n / 2; /* Morton: already sorted, and the keys follow positions */
    int axis = 0;
    float ext = -1;
    for (int k = 0; k < 3; k++)
        if (cbox->hi[k] - cbox->lo[k] > ext) ext = cbox->hi[k] - cbox->lo[k], axis = k;
    select_nth(p, n, n / 2, axis);
    return n / 2;
}

static void build_node(bvh_builder *b, size_t node, bvh_prim *p, size_t n, uint32_t depth) {
    prt_aabb box, cbox;
    bounds_of(p, n, &box, &cbox);
    bvh_node *nd = &b->nodes[node];
    nd->box = box;

    uint32_t d = atomic_load(&b->depth);
    while (depth > d && !atomic_compare_exchange_weak(&b->depth, &d, depth)) {}

    size_t mid = 0;
    bool split;
    if (n <= 1) split = false;
    else if (depth >= MEDIAN_FROM_DEPTH) {
        split = n > (size_t)b->params.max_leaf;
        if (split) mid = median_split(b, p, n, &cbox);
    } else {
        split = b->split(b, p, n, &box, &cbox, &mid);
        if (split && (mid == 0 || mid >= n)) split = false; /* splitter found nothing */
        if (!split && n > (size_t)b->params.max_leaf) {
            split = true;
            mid = median_split(b, p, n, &cbox);
        }
    }
    if (!split) {
        nd->index = (uint32_t)(p - b->base);
        nd->count = (uint32_t)n;
        size_t placed = atomic_fetch_add(&b->placed, n) + n;
        /* Only the calling thread (OpenMP thread 0 of the build team) reports. */
        if (b->params.progress && placed >= b->next_report && omp_get_thread_num() == 0) {
            b->next_report = placed + b->total / 100;
            b->params.progress(b->params.progress_user, b->params.progress_scale * (float)placed / (float)b->total);
        }
        return;
    }
    size_t c = atomic_fetch_add(&b->node_next, 2);
    nd->index = (uint32_t)c;
    nd->count = 0;
    if (n >= TASK_MIN_PRIMS) {
#pragma omp task default(shared) firstprivate(b, c, p, mid, depth)
        build_node(b, c, p, mid, depth + 1);
        build_node(b, c + 1, p + mid, n - mid, depth + 1);
#pragma omp taskwait
    } else {
        build_node(b, c, p, mid, depth + 1);
        build_node(b, c + 1, p + mid, n - mid, depth + 1);
    }
}

prt_status bvh_build_with(bvh_builder *b, bvh_prim *prims, size_t n, bvh_tree *out) {
    memset(out, 0, sizeof *out);
    b->base = prims;
    b->node_capacity = 2 * n - 1;
    b->nodes = prt__alloc(prt__mul_size(b->node_capacity, sizeof(bvh_node)));
    if (!b->nodes) return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu BVH nodes", b->node_capacity);
    atomic_store(&b->node_next, 1);
    atomic_store(&b->depth, 0);
    atomic_store(&b->placed, 0);
    b->total = n;
    b->next_report = 0;
    int threads = prt__threads(b->params.threads);
#pragma omp parallel num_threads(threads)
#pragma omp single
    build_node(b, 0, prims, n, 1);

    out->node_count = atomic_load(&b->node_next);
    out->nodes = prt__realloc(b->nodes, out->node_count * sizeof(bvh_node));
    if (!out->nodes) out->nodes = b->nodes;
    out->prim_count = n;
    out->prims = prt__alloc(prt__mul_size(n, sizeof(uint32_t)));
    if (!out->prims) {
        bvh_tree_free(out);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu primitive ids", n);
    }
    for (size_t i = 0; i < n; i++) out->prims[i] = prims[i].id;
    out->depth = atomic_load(&b->depth);
    for (size_t i = 0; i < out->node_count; i++) out->leaf_count += out->nodes[i].count > 0;
    return PRT_OK;
}

prt_status bvh_build(bvh_prim *prims, size_t n, const bvh_build_params *p, bvh_tree *out) {
    memset(out, 0, sizeof *out);
    if (n == 0) return prt__fail(PRT_ERROR_MESH, "no triangle can be hit (all are degenerate)");
    if (n >= UINT32_MAX / 2) return prt__fail(PRT_ERROR_LIMIT, "%zu primitives: the builders index with 32 bits", n);
    if (p->max_leaf < 1 || p->max_leaf > 16 || p->block < 1)
        return prt__fail(PRT_ERROR_ARGUMENT, "leaf size %d outside 1..16", p->max_leaf);
    bvh_builder b = {.params = *p};
    switch (p->split) {
    case BVH_SPLIT_SAH: b.split = bvh_split_sah; break;
    case BVH_SPLIT_MEAN: b.split = bvh_split_mean; break;
    case BVH_SPLIT_LONGEST: b.split = bvh_split_longest; break;
    case BVH_SPLIT_MORTON: {
        prt_aabb box, cbox;
        bounds_of(prims, n, &box, &cbox);
        uint32_t *codes = bvh_morton_sort(prims, n, &cbox, p->threads);
        if (!codes) return prt__fail(PRT_ERROR_NOMEM, "out of memory for Morton codes");
        b.keys = codes;
        b.split = bvh_split_morton;
        prt_status s = bvh_build_with(&b, prims, n, out);
        prt__free(codes);
        return s;
    }
    case BVH_SPLIT_FIXED: return bvh_build_fixed(&b, prims, n, out);
    default: return prt__fail(PRT_ERROR_ARGUMENT, "unknown splitter %d", (int)p->split);
    }
    return bvh_build_with(&b, prims, n, out);
}

void bvh_tree_free(bvh_tree *t) {
    prt__free(t->nodes);
    prt__free(t->prims);
    memset(t, 0, sizeof *t);
}

uint32_t bvh_tree_max_leaf(const bvh_tree *t) {
    uint32_t m = 1;
    for (size_t i = 0; i < t->node_count; i++) m = PRT_MAX(m, t->nodes[i].count);
    return m;
}

size_t bvh_partition(bvh_prim *p, size_t n, int axis, float pos) {
    size_t i = 0, j = n;
    while (i < j) {
        if (bvh_centroid(&p[i], axis) < pos) i++;
        else {
            j--;
            bvh_prim t = p[i];
            p[i] = p[j];
            p[j] = t;
        }
    }
    return i;
}
