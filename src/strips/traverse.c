/* Single-ray closest and any hit over Ray-Strips: the 4-wide top-level BVH (nearest child
 * first, the others on a stack with their entry and exit distances), then at a leaf the
 * strip's own s-kd traversal and edge tests (strips/kernel.h). */
#include "strips/kernel.h"

typedef struct rs_entry {
    uint32_t ref, slot; /* slot: node * 4 + child, where the child's box is */
    float tn, tf;
} rs_entry;

static inline void child_box(const rs_accel *a, uint32_t slot, float lo[3], float hi[3]) {
    const rs_node *n = &a->nodes[slot >> 2];
    for (int k = 0; k < 3; k++) lo[k] = n->box[8 * k + (slot & 3)], hi[k] = n->box[8 * k + 4 + (slot & 3)];
}

/* Shared by both queries: any stops at the first hit. */
static inline bool trace(const rs_accel *a, const prt__rayx *r, bool any, rs_best *best) {
    prt__rayx4 r4;
    prt__rayx4_init(&r4, r);
    rs_entry stack[RS_STACK];
    int top = 0;
    uint32_t ref = 0, slot = 0;
    float tn = r->tnear, tf = best->t;
    for (;;) {
        if (!(ref & RS_LEAF)) {
            const rs_node *n = &a->nodes[ref];
            vf4 en, ex;
            int mask = rs_box4(&r4, n->box, best->t, &en, &ex);
            if (mask) {
                /* Order the hit children far to near; push all but the nearest. */
                rs_entry e[4];
                int c = 0;
                for (; mask; mask &= mask - 1) {
                    const int i = __builtin_ctz((unsigned)mask);
                    const rs_entry x = {n->child[i], ref * 4 + (uint32_t)i, en[i], ex[i]};
                    /* Memory latency dominates on large meshes: start every child's load now. */
                    if (x.ref & RS_LEAF) __builtin_prefetch(a->strips + (x.ref & ~RS_LEAF));
                    else __builtin_prefetch(&a->nodes[x.ref]), __builtin_prefetch((const char *)&a->nodes[x.ref] + 64);
                    int j = c++;
                    while (j > 0 && e[j - 1].tn < x.tn) e[j] = e[j - 1], j--;
                    e[j] = x;
                }
                for (int i = 0; i < c - 1; i++) stack[top++] = e[i];
                ref = e[c - 1].ref, slot = e[c - 1].slot, tn = e[c - 1].tn, tf = e[c - 1].tf;
                continue;
            }
        } else {
            float lo[3], hi[3];
            if (a->fmt.q16) child_box(a, slot, lo, hi);
            if (rs_strip_trace(a, r, a->strips + (ref & ~RS_LEAF), slot, lo, hi, tn, tf, any, best) && any) return true;
        }
        for (;;) {
            if (top == 0) return best->rec != NULL;
            --top;
            if (stack[top].tn <= best->t) break;
        }
        ref = stack[top].ref, slot = stack[top].slot, tn = stack[top].tn, tf = stack[top].tf;
        if (tf > best->t) tf = best->t;
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
