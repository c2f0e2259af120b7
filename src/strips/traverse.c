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
PRT_NOINLINE static bool rs_leaf(const rs_accel *a, const prt__rayx *r, const wide8_node *n, int slot, float tn, float tf,
                                 bool any, rs_best *best) {
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

/* Shared by both queries: any stops at the first hit. */
static inline bool trace(const rs_accel *a, const prt__rayx *r, bool any, rs_best *best) {
    rs_nray c;
    rs_nray_init(&c, r, a->blob);
    rs_entry stack[RS_STACK];
    int top = 0;
    rs_entry cur = {0, -1, r->tnear, best->t};
    for (;;) {
        const wide8_node *n = &a->nodes[cur.node];
        if (cur.slot < 0) {
            vf8 tmin, tmax;
            unsigned mask = rs_node_hit(n, &c, best->t, &tmin, &tmax);
            if (mask) {
                float tt[8], te[8];
                memcpy(tt, &tmin, sizeof tt), memcpy(te, &tmax, sizeof te);
                const int i0 = __builtin_ctz(mask);
                if (!(mask & (mask - 1))) { /* the common case: one child hit */
                    cur = rs_child(a, n, cur.node, i0, tt[i0], te[i0]);
                    continue;
                }
                const unsigned rest = mask & (mask - 1);
                if (!(rest & (rest - 1))) {
                    const int i1 = __builtin_ctz(rest);
                    /* Two: the farther pushed (ties: the higher slot), one comparison. */
                    const bool swap = tt[i1] < tt[i0];
                    const int nearer = swap ? i1 : i0, farther = swap ? i0 : i1;
                    stack[top++] = rs_child(a, n, cur.node, farther, tt[farther], te[farther]);
                    cur = rs_child(a, n, cur.node, nearer, tt[nearer], te[nearer]);
                    continue;
                }
                const unsigned more = rest & (rest - 1);
                if (!(more & (more - 1))) {
                    /* Three: a stable network of three compare-swaps (ties by slot). */
                    int x = i0, y = __builtin_ctz(rest), z = __builtin_ctz(more), w;
                    if (tt[y] < tt[x]) w = x, x = y, y = w;
                    if (tt[z] < tt[y]) w = y, y = z, z = w;
                    if (tt[y] < tt[x]) w = x, x = y, y = w;
                    stack[top++] = rs_child(a, n, cur.node, z, tt[z], te[z]);
                    stack[top++] = rs_child(a, n, cur.node, y, tt[y], te[y]);
                    cur = rs_child(a, n, cur.node, x, tt[x], te[x]);
                    continue;
                }
                /* More: placed on the stack far to near by their rank (ties by slot), the
                 * nearest visited next. */
                const int c = __builtin_popcount(mask);
                for (unsigned m = mask; m; m &= m - 1) {
                    const int i = __builtin_ctz(m);
                    const vf8 ti = vf8_set1(tt[i]);
                    const unsigned before = (unsigned)vi8_mask(tmin < ti) | ((unsigned)vi8_mask(tmin == ti) & ((1u << i) - 1));
                    stack[top + c - 1 - __builtin_popcount(before & mask)] = rs_child(a, n, cur.node, i, tt[i], te[i]);
                }
                top += c - 1;
                cur = stack[top];
                continue;
            }
        } else {
            if (rs_leaf(a, r, n, cur.slot, cur.tn, cur.tf, any, best) && any) return true;
        }
        for (;;) {
            if (top == 0) return best->rec != NULL;
            --top;
            if (stack[top].tn <= best->t) break;
        }
        cur = stack[top];
        if (cur.tf > best->t) cur.tf = best->t;
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
