/* In-core kd-tree construction (Áfra 2012 §4.1): binned SAH over the triangles' boxes
 * clipped to the cell, aggressive empty-space cutting first, a spatial-median split when
 * the SAH finds nothing better but the node is still over the leaf limit. Large subtrees
 * are built as parallel tasks, each into its own node array, grafted afterwards. */
#include "ooc/ooc.h"

#include "core/simd.h"

#include <float.h>
#include <math.h>

#define BINS 32
/* A step costs four triangle tests: the leaves grow to tens of triangles, so the tree
 * stays small (bunny: 32 B/tri raw with 1:1.5 it was 159, the speed within 10%). */
#define COST_TRAVERSE 4.0f
#define COST_INTERSECT 1.0f
#define TASK_MIN 65536 /* triangles below which a subtree is never a task of its own */

/* A triangle reference with its box clipped to the current cell: computed once at the
 * root, then only clipped at each split (one axis changes). */
typedef struct item {
    float b[6];
    uint32_t ref;
} item;

typedef struct ctx {
    const ooc_btri *tris;
    const ooc_build_params *p;
    size_t task_min; /* triangles below which a subtree is built on the current thread */
} ctx;

#define MINF(a, b) ((a) < (b) ? (a) : (b))
#define MAXF(a, b) ((a) > (b) ? (a) : (b))

static void tri_box(const ooc_btri *t, const float cell[6], float b[6]) {
    for (int k = 0; k < 3; k++) {
        float lo = MINF(MINF(t->v[k], t->v[3 + k]), t->v[6 + k]);
        float hi = MAXF(MAXF(t->v[k], t->v[3 + k]), t->v[6 + k]);
        b[k] = MAXF(lo, cell[k]);
        b[3 + k] = MINF(hi, cell[3 + k]);
    }
}

static float half_area(const float b[6]) {
    float dx = b[3] - b[0], dy = b[4] - b[1], dz = b[5] - b[2];
    return dx * dy + dy * dz + dz * dx;
}

static float volume(const float b[6]) { return (b[3] - b[0]) * (b[4] - b[1]) * (b[5] - b[2]); }

static prt_status push_node(ooc_tree *t, int32_t *idx) {
    if (t->count == t->cap) {
        size_t cap = t->cap ? 2 * t->cap : 64;
        ooc_bnode *n = prt__realloc(t->nodes, prt__mul_size(cap, sizeof *n));
        if (!n) return prt__fail(PRT_ERROR_NOMEM, "out of memory for kd-tree nodes");
        t->nodes = n, t->cap = cap;
    }
    if (t->count >= INT32_MAX) return prt__fail(PRT_ERROR_LIMIT, "kd-tree has more than 2^31 nodes");
    *idx = (int32_t)t->count++;
    memset(&t->nodes[*idx], 0, sizeof t->nodes[*idx]);
    t->nodes[*idx].child[0] = t->nodes[*idx].child[1] = -1;
    return PRT_OK;
}

static prt_status push_refs(ooc_tree *t, const uint32_t *refs, const item *items, size_t n, uint32_t *first) {
    if (t->nrefs + n > t->refcap) {
        size_t cap = PRT_MAX(t->refcap * 2, t->nrefs + n + 1024);
        uint32_t *r = prt__realloc(t->refs, prt__mul_size(cap, sizeof *r));
        if (!r) return prt__fail(PRT_ERROR_NOMEM, "out of memory for kd-tree leaf lists");
        t->refs = r, t->refcap = cap;
    }
    if (t->nrefs + n > UINT32_MAX) return prt__fail(PRT_ERROR_LIMIT, "kd-tree has more than 2^32 leaf references");
    if (refs) memcpy(t->refs + t->nrefs, refs, n * sizeof *refs);
    else
        for (size_t i = 0; i < n; i++) t->refs[t->nrefs + i] = items[i].ref;
    *first = (uint32_t)t->nrefs;
    t->nrefs += n;
    return PRT_OK;
}

/* What a node's split choice needs to know of its items: their bounds and, per axis, the
 * bins of their boxes' minima and maxima over the node's cell. The parent's sift fills it
 * for each child as it writes the child's items, so a node never rereads its items to
 * choose its split (one pass over the items per level, not five). */
typedef struct summary {
    float b[6];
    float lo[3], scale[3]; /* the cell's binning: bin = (x - lo) * scale */
    uint32_t mins[3][BINS], maxs[3][BINS];
} summary;

static void summary_init(summary *m, const float cell[6]) {
    memset(m, 0, sizeof *m);
    for (int k = 0; k < 3; k++) {
        float ext = cell[3 + k] - cell[k];
        m->b[k] = FLT_MAX, m->b[3 + k] = -FLT_MAX;
        m->lo[k] = cell[k];
        m->scale[k] = ext > 0.0f ? BINS / ext : 0.0f;
    }
}

/* A summary being gathered, in registers while items are added one by one: lanes 0-2 of
 * each vector are x, y, z (lane 3 is never used). */
typedef struct gather {
    vf4 lo, scale, bmin, bmax;
    uint32_t (*mins)[BINS], (*maxs)[BINS];
} gather;

static inline gather gather_begin(summary *m) {
    gather g;
    g.lo = (vf4){m->lo[0], m->lo[1], m->lo[2], 0.0f};
    g.scale = (vf4){m->scale[0], m->scale[1], m->scale[2], 0.0f};
    g.bmin = (vf4){m->b[0], m->b[1], m->b[2], 0.0f};
    g.bmax = (vf4){m->b[3], m->b[4], m->b[5], 0.0f};
    g.mins = m->mins, g.maxs = m->maxs;
    return g;
}

/* The bins of box bounds: clamped to [0, BINS - 1], 0 for NaN (max returns its second
 * operand then: a cell so thin that its scale overflowed), never an out-of-range
 * float-to-int conversion. */
static inline vi4 bins_of(const gather *g, vf4 x) {
    vf4 f = vf4_min(vf4_max((x - g->lo) * g->scale, vf4_set1(0.0f)), vf4_set1((float)(BINS - 1)));
    return __builtin_convertvector(f, vi4);
}

/* Add an item's box: its minima and maxima in lanes 0-2 of lo and hi. The caller passes
 * registers, not a box it has just written (a vector load of scalar stores stalls). */
static inline void gather_add(gather *g, vf4 lo, vf4 hi) {
    g->bmin = vf4_min(g->bmin, lo), g->bmax = vf4_max(g->bmax, hi);
    vi4 i = bins_of(g, lo), j = bins_of(g, hi);
    g->mins[0][i[0]]++, g->mins[1][i[1]]++, g->mins[2][i[2]]++;
    g->maxs[0][j[0]]++, g->maxs[1][j[1]]++, g->maxs[2][j[2]]++;
}

static inline void gather_end(const gather *g, summary *m) {
    for (int k = 0; k < 3; k++) m->b[k] = g->bmin[k], m->b[3 + k] = g->bmax[k];
}

/* out[i] = in[0] + ... + in[i] for the BINS (32) bins: a shift-and-add scan in each group
 * of eight lanes, each group then offset by the total of the ones before. */
static inline void prefix_sums(const uint32_t in[BINS], uint32_t out[BINS]) {
    _Static_assert(BINS == 32, "four groups of eight lanes");
    typedef uint32_t vu8 __attribute__((vector_size(32))); /* unsigned: counts reach n */
    const vu8 zero = {0, 0, 0, 0, 0, 0, 0, 0};
    uint32_t carry = 0;
    for (int g = 0; g < BINS; g += 8) {
        vu8 x;
        memcpy(&x, in + g, sizeof x);
        x += __builtin_shufflevector(zero, x, 0, 8, 9, 10, 11, 12, 13, 14);
        x += __builtin_shufflevector(zero, x, 0, 1, 8, 9, 10, 11, 12, 13);
        x += __builtin_shufflevector(zero, x, 0, 1, 2, 3, 8, 9, 10, 11);
        x += carry; /* broadcast */
        memcpy(out + g, &x, sizeof x);
        carry = x[7];
    }
}

/* Where to split: an empty-space cut when one leaves at least empty_cut of the cell's
 * volume empty, else the best SAH plane, else (over the leaf limit) the spatial median.
 * m summarises the n items over this cell. Returns false for a leaf. */
static bool choose_split(const ctx *c, const summary *m, size_t n, const float cell[6], int *axis_out, float *split_out,
                         int *empty_side) {
    *empty_side = -1;
    const float *b = m->b;
    const float vol = volume(cell);
    /* Empty-space cutting (§4.1): the largest empty slab at one of the six faces. */
    float best_empty = 0.0f;
    for (int k = 0; k < 3; k++) {
        float ext = cell[3 + k] - cell[k];
        if (!(ext > 0.0f)) continue;
        float lo_gap = (b[k] - cell[k]) / ext, hi_gap = (cell[3 + k] - b[3 + k]) / ext;
        if (lo_gap > best_empty) best_empty = lo_gap, *axis_out = k, *split_out = b[k], *empty_side = 0;
        if (hi_gap > best_empty) best_empty = hi_gap, *axis_out = k, *split_out = b[3 + k], *empty_side = 1;
    }
    if (vol > 0.0f && best_empty >= c->p->empty_cut) return true;
    *empty_side = -1;
    if (n <= 1) return false;

    /* Binned SAH over the clipped boxes: a box counts left when its minimum is below the
     * plane and right when its maximum is above it (both when it straddles). */
    const float area = half_area(cell);
    float best_cost = COST_INTERSECT * (float)n;
    int best_axis = -1;
    float best_split = 0.0f;
    for (int k = 0; k < 3; k++) {
        float lo = cell[k], ext = cell[3 + k] - cell[k];
        if (!(ext > 0.0f)) continue;
        /* Boundary i (1..31) has left of it the boxes whose minimum lies in bins below i
         * and right of it those whose maximum does not: prefix sums of the bins, taken
         * eight lanes at a time. Every boundary's cost then comes from one loop of plain
         * arithmetic that the compiler vectorises, and the cheapest from a vector minimum:
         * this runs once per node, and nodes are about a third as many as triangles. */
        uint32_t below_min[BINS], below_max[BINS];
        prefix_sums(m->mins[k], below_min), prefix_sums(m->maxs[k], below_max);
        float cost[BINS], pos[BINS];
        /* A box's half area is linear in its extent along k: d_k * (d_u + d_v) + d_u * d_v. */
        const float du = cell[3 + (k + 1) % 3] - cell[(k + 1) % 3], dv = cell[3 + (k + 2) % 3] - cell[(k + 2) % 3];
        const float side = du + dv, face = du * dv, hi = cell[3 + k];
        cost[0] = INFINITY, pos[0] = lo;
        for (int i = 1; i < BINS; i++) {
            const uint32_t nl = below_min[i - 1], nr = (uint32_t)n - below_max[i - 1];
            float s = lo + ext * (float)i / BINS;
            float al = (s - lo) * side + face, ar = (hi - s) * side + face;
            float sah = COST_TRAVERSE + COST_INTERSECT * (al * (float)nl + ar * (float)nr) / area;
            pos[i] = s;
            /* A plane that separates nothing never wins, nor does a NaN. */
            cost[i] = (nl < n || nr < n) && sah < INFINITY ? sah : INFINITY;
        }
        vf8 c8 =
            vf8_min(vf8_min(vf8_load(cost), vf8_load(cost + 8)), vf8_min(vf8_load(cost + 16), vf8_load(cost + 24)));
        const float least = vf8_hmin(c8);
        if (least < best_cost) { /* the first boundary at that cost, as a scan in order picks */
            int i = 1;
            while (cost[i] != least) i++;
            best_cost = least, best_axis = k, best_split = pos[i];
        }
    }
    if (best_axis >= 0) {
        *axis_out = best_axis, *split_out = best_split;
        return true;
    }
    if ((int)n <= c->p->leaf_max) return false;
    int k = 0;
    for (int j = 1; j < 3; j++)
        if (cell[3 + j] - cell[j] > cell[3 + k] - cell[k]) k = j;
    *axis_out = k, *split_out = 0.5f * (cell[k] + cell[3 + k]);
    return true;
}

static prt_status build_node(const ctx *c, ooc_tree *t, item *it, size_t n, const float cell[6], const summary *m,
                             uint32_t depth, int32_t *out);

/* A leaf of the items (node index in *out); the items are consumed (freed). */
static prt_status make_leaf(ooc_tree *t, item *it, size_t n, const float cell[6], int32_t *out) {
    prt_status s = push_node(t, out);
    if (!s) {
        ooc_bnode *nd = &t->nodes[*out];
        memcpy(nd->box, cell, sizeof nd->box);
        nd->count = (uint32_t)n;
        s = push_refs(t, NULL, it, n, &t->nodes[*out].first);
    }
    prt__free(it);
    return s;
}

/* Copy tree src under t (indices shifted); returns the root's new index. */
static prt_status graft(ooc_tree *t, const ooc_tree *src, int32_t *root) {
    *root = -1;
    if (!src->count) return PRT_OK;
    size_t base = t->count, rbase = t->nrefs;
    for (size_t i = 0; i < src->count; i++) {
        int32_t idx;
        prt_status s = push_node(t, &idx);
        if (s) return s;
        ooc_bnode nd = src->nodes[i];
        for (int k = 0; k < 2; k++)
            if (nd.child[k] >= 0) nd.child[k] += (int32_t)base;
        if (nd.child[0] < 0 && nd.child[1] < 0) nd.first += (uint32_t)rbase;
        t->nodes[idx] = nd;
    }
    uint32_t first;
    prt_status s = push_refs(t, src->refs, NULL, src->nrefs, &first);
    if (s) return s;
    t->depth = PRT_MAX(t->depth, src->depth);
    *root = (int32_t)base;
    return PRT_OK;
}

static prt_status build_node(const ctx *c, ooc_tree *t, item *refs, size_t n, const float cell[6], const summary *m,
                             uint32_t depth, int32_t *out) {
    *out = -1;
    if (n == 0) {
        prt__free(refs);
        return PRT_OK;
    }
    t->depth = PRT_MAX(t->depth, depth + 1);
    int axis = 0, empty = -1;
    float split = 0.0f;
    if (depth + 1 >= OOC_MAX_DEPTH || !choose_split(c, m, n, cell, &axis, &split, &empty))
        return make_leaf(t, refs, n, cell, out);

    /* Sift: a triangle goes to each side its clipped box reaches (a box touching the
     * plane goes to both, so hits on the plane are found from either side), except that
     * an empty-space cut leaves its empty side empty: rays in the plane visit both sides.
     * The left side (the only side of an empty-space cut) is written over refs, never
     * ahead of the item being read; the right side of a plain split to an array of its
     * own. Each side's summary is gathered on the way. */
    float box[2][6];
    memcpy(box[0], cell, sizeof box[0]), memcpy(box[1], cell, sizeof box[1]);
    box[0][3 + axis] = split, box[1][axis] = split;
    item *side[2] = {refs, NULL};
    size_t cnt[2] = {0, 0};
    if (empty == 0) side[1] = refs, side[0] = NULL;
    else if (empty < 0 && !(side[1] = prt__alloc(prt__mul_size(n, sizeof(item))))) {
        prt__free(refs);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory splitting a kd-tree node of %zu triangles", n);
    }
    summary sm[2]; /* on the stack: the tasks that read it end before this call does */
    summary_init(&sm[0], box[0]), summary_init(&sm[1], box[1]);
    gather g0 = gather_begin(&sm[0]), g1 = gather_begin(&sm[1]);
    size_t c0 = 0, c1 = 0;
    item *s0 = side[0], *s1 = side[1];
    /* The clipping as vectors: the split in lane `axis`, infinities elsewhere. */
    vf4 clip_hi = vf4_set1(INFINITY), clip_lo = vf4_set1(-INFINITY);
    clip_hi[axis] = split, clip_lo[axis] = split;
    /* An item moves as two overlapping 16-byte vectors, b[0..3] and b[3..5] + ref, clipped
     * in registers (min/max pick as MINF/MAXF do); a copy through a struct on the stack
     * stalled on store forwarding. Lane 3 of hi is the ref, kept bit for bit. */
    _Static_assert(sizeof(item) == 28 && offsetof(item, ref) == 24, "item: six floats, then the ref");
    const vi4 ref_lane = {0, 0, 0, -1};
    for (size_t i = 0; i < n; i++) {
        const float *b = refs[i].b;
        const float blo = b[axis], bhi = b[3 + axis];
        const vf4 lo = vf4_load(b), hi = vf4_load(b + 3);
        if (empty != 0 && blo <= split) {
            const vf4 h = vf4_min(hi, clip_hi), hr = vf4_select(ref_lane, hi, h);
            gather_add(&g0, lo, h);
            unsigned char *d = (unsigned char *)&s0[c0++]; /* the whole item's 28 bytes */
            memcpy(d, &lo, sizeof lo), memcpy(d + 3 * sizeof(float), &hr, sizeof hr);
        }
        if (empty != 1 && bhi >= split) {
            const vf4 l = vf4_max(lo, clip_lo);
            gather_add(&g1, l, hi);
            unsigned char *d = (unsigned char *)&s1[c1++];
            memcpy(d, &l, sizeof l), memcpy(d + 3 * sizeof(float), &hi, sizeof hi);
        }
    }
    gather_end(&g0, &sm[0]), gather_end(&g1, &sm[1]);
    cnt[0] = c0, cnt[1] = c1;
    /* A split that separates nothing (a pile of triangles through one point) ends here;
     * both sides then hold every item, the left one in refs unchanged but for a bound
     * clipped to the plane, so the leaf takes the right side's references (same order). */
    if (cnt[0] == n && cnt[1] == n) {
        prt__free(refs);
        return make_leaf(t, side[1], n, cell, out);
    }

    int32_t kid[2] = {-1, -1};
    prt_status st[2] = {PRT_OK, PRT_OK};
    if (n >= c->task_min) {
        /* Both halves as tasks, each into a tree of its own, grafted below. */
        ooc_tree sub[2];
        memset(sub, 0, sizeof sub);
        for (int k = 0; k < 2; k++) {
#pragma omp task default(none) shared(sub, st, side, cnt, box, kid, sm) firstprivate(k, c, depth)
            {
                int32_t r;
                st[k] = build_node(c, &sub[k], side[k], cnt[k], box[k], &sm[k], depth + 1, &r);
                (void)r;
            }
        }
#pragma omp taskwait
        prt_status s = st[0] ? st[0] : st[1];
        if (!s) s = push_node(t, out);
        for (int k = 0; k < 2 && !s; k++) s = graft(t, &sub[k], &kid[k]);
        ooc_tree_free(&sub[0]), ooc_tree_free(&sub[1]);
        if (s) return s;
    } else {
        prt_status s = push_node(t, out);
        if (s) {
            prt__free(side[0]), prt__free(side[1]);
            return s;
        }
        for (int k = 0; k < 2; k++) {
            if (!st[0]) st[k] = build_node(c, t, side[k], cnt[k], box[k], &sm[k], depth + 1, &kid[k]);
            else prt__free(side[k]);
        }
        if (st[0] || st[1]) return st[0] ? st[0] : st[1];
    }
    ooc_bnode *nd = &t->nodes[*out];
    memcpy(nd->box, cell, sizeof nd->box);
    nd->axis = (uint8_t)axis, nd->split = split;
    nd->child[0] = kid[0], nd->child[1] = kid[1];
    return PRT_OK;
}

prt_status ooc_kd_build(const ooc_btri *tris, size_t n, const float box[6], uint32_t root_depth,
                        const ooc_build_params *p, ooc_tree *out) {
    memset(out, 0, sizeof *out);
    if (n > UINT32_MAX) return prt__fail(PRT_ERROR_LIMIT, "an in-core kd subtree holds more than 2^32 triangles");
    int threads = prt__threads(p->threads);
    /* A task's subtree is copied into its parent's arrays when it is done, so tasks are
     * only as many as keep the threads busy (about 16 per thread), not one per node. */
    ctx c = {tris, p, threads > 1 ? PRT_MAX((size_t)TASK_MIN, n / (16 * (size_t)threads)) : SIZE_MAX};
    item *refs = prt__alloc(prt__mul_size(PRT_MAX(n, 1), sizeof *refs));
    if (!refs) return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu kd-tree references", n);
    summary *m = prt__alloc(sizeof *m);
    if (!m) {
        prt__free(refs);
        return prt__fail(PRT_ERROR_NOMEM, "out of memory for %zu kd-tree references", n);
    }
    summary_init(m, box);
    gather g = gather_begin(m);
    for (size_t i = 0; i < n; i++) {
        tri_box(&tris[i], box, refs[i].b);
        refs[i].ref = (uint32_t)i;
    }
    for (size_t i = 0; i < n; i++) gather_add(&g, vf4_load(refs[i].b), vf4_load(refs[i].b + 3));
    gather_end(&g, m);
    prt_status s = PRT_OK;
    int32_t root = -1;
#pragma omp parallel num_threads(threads) if (n >= c.task_min) default(none) \
    shared(s, c, refs, n, box, m, root_depth, out, root)
#pragma omp single
    s = build_node(&c, out, refs, n, box, m, root_depth, &root);
    prt__free(m);
    /* build_node pushes a node before its children, so the root is node 0. */
    if (s) ooc_tree_free(out);
    return s;
}

void ooc_tree_free(ooc_tree *t) {
    prt__free(t->nodes);
    prt__free(t->refs);
    memset(t, 0, sizeof *t);
}
