/* Single-ray closest and any hit over Ray-Strips: the wide8 top level (bvh/layouts/wide8.h;
 * nearest child first, the others on a stack with their entry and exit distances), then at
 * a leaf each strip entry's own s-kd traversal and edge tests (strips/kernel.h). */
#include "strips/kernel.h"

/* A stack entry: node `node` itself (slot < 0) or the leaf in its slot `slot`, entered
 * over [tn, tf]. */
typedef struct rs_entry {
    uint32_t node;
    int32_t slot;
    float tn, tf;
} rs_entry;

/* Start fetching child i of node q (inner node or leaf), visited soon. */
static inline rs_entry rs_child(const rs_accel *a, const wide8_node *n, uint32_t q, int i, float tn, float tf) {
    if (n->imask >> i & 1) {
        const uint32_t c = n->child + (uint32_t)i;
        const char *p = (const char *)&a->nodes[c];
        __builtin_prefetch(p), __builtin_prefetch(p + WIDE8_NODE_BYTES - 1);
        return (rs_entry){c, -1, tn, tf};
    }
    const char *p = (const char *)(a->geometry + n->leaf + (size_t)(i ? n->meta[i - 1] : 0) * RS_UNIT_WORDS);
    __builtin_prefetch(p), __builtin_prefetch(p + 64);
    return (rs_entry){q, i, tn, tf};
}

/* The strips of the leaf in slot `slot` of node n, entered over [tn, tf]; out of line, so
 * that the node loop of trace keeps its ray constants in registers (inlined, the edge
 * tests' vectors made the compiler spill them around every node, as lossygrid found). */
PRT_NOINLINE static bool rs_leaf(const rs_accel *a, const prt__rayx *r, const wide8_node *n, int slot, float tn,
                                 float tf, bool any, rs_best *best) {
    size_t e, end;
    rs_leaf_range(n, slot, &e, &end);
    const rs_grid g = a->fmt.q16 ? rs_grid_of(n) : (rs_grid){{0, 0, 0}, {0, 0, 0}};
    bool hit = false;
    for (; e < end; e += rs_entry_size(a->geometry + e, &a->fmt)) {
        if (rs_strip_trace(a, r, a->geometry + e, &g, tn, tf < best->t ? tf : best->t, any, best)) {
            if (any) return true;
            hit = true;
        }
    }
    return hit;
}

/* After a node test that hit the children of mask (non-zero) at [tmin, tmax]: the child
 * to visit next, the nearest (ties: the lower slot); the others pushed far to near. */
PRT_INLINE rs_entry rs_descend(const rs_accel *a, const wide8_node *n, uint32_t node, unsigned mask, vf8 tmin, vf8 tmax,
                               rs_entry *stack, int *top) {
    float tt[8], te[8];
    memcpy(tt, &tmin, sizeof tt), memcpy(te, &tmax, sizeof te);
    const int i0 = __builtin_ctz(mask);
    if (!(mask & (mask - 1))) return rs_child(a, n, node, i0, tt[i0], te[i0]); /* the common case: one child hit */
    const unsigned rest = mask & (mask - 1);
    if (!(rest & (rest - 1))) {
        const int i1 = __builtin_ctz(rest);
        /* Two: the farther pushed (ties: the higher slot), one comparison. */
        const bool swap = tt[i1] < tt[i0];
        const int nearer = swap ? i1 : i0, farther = swap ? i0 : i1;
        stack[(*top)++] = rs_child(a, n, node, farther, tt[farther], te[farther]);
        return rs_child(a, n, node, nearer, tt[nearer], te[nearer]);
    }
    const unsigned more = rest & (rest - 1);
    if (!(more & (more - 1))) {
        /* Three: a stable network of three compare-swaps (ties by slot). */
        int x = i0, y = __builtin_ctz(rest), z = __builtin_ctz(more), w;
        if (tt[y] < tt[x]) w = x, x = y, y = w;
        if (tt[z] < tt[y]) w = y, y = z, z = w;
        if (tt[y] < tt[x]) w = x, x = y, y = w;
        stack[(*top)++] = rs_child(a, n, node, z, tt[z], te[z]);
        stack[(*top)++] = rs_child(a, n, node, y, tt[y], te[y]);
        return rs_child(a, n, node, x, tt[x], te[x]);
    }
    /* More: placed on the stack far to near by their rank (ties by slot), the nearest
     * visited next. */
    const int c = __builtin_popcount(mask);
    for (unsigned m = mask; m; m &= m - 1) {
        const int i = __builtin_ctz(m);
        const vf8 ti = vf8_set1(tt[i]);
        const unsigned before = (unsigned)vi8_mask(tmin < ti) | ((unsigned)vi8_mask(tmin == ti) & ((1u << i) - 1));
        stack[*top + c - 1 - __builtin_popcount(before & mask)] = rs_child(a, n, node, i, tt[i], te[i]);
    }
    *top += c - 1;
    return stack[*top];
}

/* The next stacked entry entered before the best hit at t, its exit cut to t: false when
 * none is left. */
PRT_INLINE bool rs_pop(const rs_entry *stack, int *top, float t, rs_entry *cur) {
    for (;;) {
        if (*top == 0) return false;
        --*top;
        if (stack[*top].tn <= t) break;
    }
    *cur = stack[*top];
    if (cur->tf > t) cur->tf = t;
    return true;
}

/* Shared by both queries: any stops at the first hit. */
static inline bool trace(const rs_accel *a, const prt__rayx *r, bool any, rs_best *best) {
    wide8_nfray c;
    wide8_nfray_init(&c, r, a->blob);
    rs_entry stack[RS_STACK];
    int top = 0;
    rs_entry cur = {0, -1, r->tnear, best->t};
    for (;;) {
        const wide8_node *n = &a->nodes[cur.node];
        if (cur.slot < 0) {
            vf8 tmin, tmax;
            unsigned mask = wide8_nf_hit(n, &c, best->t, &tmin, &tmax);
            if (mask) {
                cur = rs_descend(a, n, cur.node, mask, tmin, tmax, stack, &top);
                continue;
            }
        } else {
            if (rs_leaf(a, r, n, cur.slot, cur.tn, cur.tf, any, best) && any) return true;
        }
        if (!rs_pop(stack, &top, best->t, &cur)) return best->rec != NULL;
    }
}

/* --- streams of single rays, closest hit ------------------------------------------------ */

/* One ray of rs_intersect_stream in flight: trace's state. */
typedef struct rs_lane {
    prt__rayx r;
    wide8_nfray c;
    rs_best best;
    rs_entry cur;
    int top;
    unsigned mask; /* the current node's test, from the first half of a round */
    bool staged;   /* the current leaf's vertices are being fetched (rs_leaf_fetch) */
    vf8 tmin, tmax;
    size_t i; /* the ray's place in the stream */
    rs_entry stack[RS_STACK];
} rs_lane;

/* Start lane l on the next valid ray of rays[*next .. n) (an invalid one gets the miss
 * prt_intersect1 gives it); false when none is left. */
static bool rs_lane_start(const rs_accel *a, rs_lane *l, prt_ray *rays, prt_hit *hits, size_t n, size_t *next) {
    for (; *next < n; ++*next) {
        const prt_ray *ray = &rays[*next];
        if (!prt__ray_valid(ray)) {
            hits[*next] = prt__miss();
            continue;
        }
        prt__rayx_init(&l->r, ray);
        wide8_nfray_init(&l->c, &l->r, a->blob);
        l->best = (rs_best){ray->tfar, {0, 0, 0}, NULL, 0, 0};
        l->cur = (rs_entry){0, -1, l->r.tnear, l->best.t};
        l->top = 0;
        l->staged = false;
        l->i = (*next)++;
        return true;
    }
    return false;
}

/* Start fetching the vertices of the strips of the leaf in slot `slot` of node n (their
 * records were fetched when the leaf was pushed or chosen). */
static inline void rs_leaf_fetch(const rs_accel *a, const wide8_node *n, int slot) {
    size_t e, end;
    rs_leaf_range(n, slot, &e, &end);
    for (; e < end; e += rs_entry_size(a->geometry + e, &a->fmt)) {
        const uint32_t *rec = a->geometry + e + a->fmt.no_ids;
        const uint32_t *ix = rec + rs_tree_words(rec[0] & 0xFFFFu, &a->fmt);
        const uint32_t nv = (rec[0] & 0xFFFFu) + 2;
        for (uint32_t j = 0; j < nv; j++) __builtin_prefetch(a->vertices + 3 * (size_t)ix[j]);
    }
}

/* trace (closest hit) for n rays, RS_LANES at a time in rounds: every lane's node test
 * first (no branch between lanes, so their dependent load and test chains overlap), then
 * each lane acts on its own, as lossygrid's and wide8's streams do. Each ray takes trace's
 * steps with trace's operations: the same answers, bit for bit. */
#define RS_LANES 6
void rs_intersect_stream(const prt_accel *acc, prt_ray *rays, prt_hit *hits, size_t n) {
    const rs_accel *a = (const rs_accel *)acc;
    rs_lane lanes[RS_LANES];
    size_t next = 0;
    unsigned on = 0;
    for (int i = 0; i < RS_LANES; i++)
        if (rs_lane_start(a, &lanes[i], rays, hits, n, &next)) on |= 1u << i;
    while (on) {
        for (int i = 0; i < RS_LANES; i++) {
            rs_lane *l = &lanes[i];
            if (on >> i & 1 && l->cur.slot < 0)
                l->mask = wide8_nf_hit(&a->nodes[l->cur.node], &l->c, l->best.t, &l->tmin, &l->tmax);
        }
        for (int i = 0; i < RS_LANES; i++) {
            rs_lane *l = &lanes[i];
            if (!(on >> i & 1)) continue;
            const wide8_node *nd = &a->nodes[l->cur.node];
            if (l->cur.slot < 0) {
                if (l->mask) {
                    l->cur = rs_descend(a, nd, l->cur.node, l->mask, l->tmin, l->tmax, l->stack, &l->top);
                    continue;
                }
            } else {
                /* A leaf waits one round for its vertices while the other lanes work. */
                if (!l->staged) {
                    rs_leaf_fetch(a, nd, l->cur.slot);
                    l->staged = true;
                    continue;
                }
                l->staged = false;
                rs_leaf(a, &l->r, nd, l->cur.slot, l->cur.tn, l->cur.tf, false, &l->best);
            }
            if (rs_pop(l->stack, &l->top, l->best.t, &l->cur)) continue;
            rs_finish(a, &l->best, &rays[l->i], &hits[l->i]);
            if (!rs_lane_start(a, l, rays, hits, n, &next)) on &= ~(1u << i);
        }
    }
}

void rs_intersect1(const prt_accel *acc, prt_ray *ray, prt_hit *hit) {
    const rs_accel *a = (const rs_accel *)acc;
    prt__rayx r;
    prt__rayx_init(&r, ray);
    rs_best best = {ray->tfar, {0, 0, 0}, NULL, 0, 0};
    trace(a, &r, false, &best);
    rs_finish(a, &best, ray, hit);
}

bool rs_occluded1(const prt_accel *acc, const prt_ray *ray) {
    const rs_accel *a = (const rs_accel *)acc;
    prt__rayx r;
    prt__rayx_init(&r, ray);
    rs_best best = {ray->tfar, {0, 0, 0}, NULL, 0, 0};
    return trace(a, &r, true, &best);
}
