/* 2x2 ray packets over Ray-Strips (Lauterbach et al. 2007, §5.3): four rays traverse the
 * top-level BVH and a strip's s-kd tree together (one SIMD lane per ray, a subtree is
 * entered when any ray's interval reaches it); when fewer than RS_PACKET_MIN rays are
 * active at a strip they leave the packet and trace it one by one with the single-ray
 * kernels. Triangles are always tested ray by ray with the single-ray group test (SIMD
 * over the strip's edges), so every ray gets exactly the hit prt_intersect1 gives it: the
 * nearest (t, smallest id) does not depend on the visiting order. */
#include "strips/kernel.h"

/* Fewer active rays than this at a strip: single-ray traversal for each. */
#define RS_PACKET_MIN 2

typedef struct rs_pk {
    prt__rayx r[4];
    vf4 org[3], inv[3], tnear;
    rs_best best[4];
} rs_pk;

static inline vf4 far4(vf4 t) {
    return vf4_select(t >= vf4_set1(0.0f), t * vf4_set1(PRT_BOX_FAR_SCALE), t * vf4_set1(PRT_BOX_FAR_SCALE_NEG));
}

static inline vf4 best_t(const rs_pk *p) { return (vf4){p->best[0].t, p->best[1].t, p->best[2].t, p->best[3].t}; }

/* Child slot i of node n against the four rays: the mask of rays (within active) that hit
 * it, and their intervals. */
static inline int box_rays(const rs_pk *p, const rs_node *n, int i, int active, vf4 *tn, vf4 *tf) {
    vf4 tmin = p->tnear, tmax = best_t(p);
    for (int k = 0; k < 3; k++) {
        const vf4 lo = vf4_set1(n->box[8 * k + i]), hi = vf4_set1(n->box[8 * k + 4 + i]);
        const vf4 t0 = (lo - p->org[k]) * p->inv[k], t1 = (hi - p->org[k]) * p->inv[k];
        const vi4 neg = p->inv[k] < vf4_set1(0.0f);
        tmin = vf4_max(vf4_select(neg, t1, t0), tmin); /* NaN: keeps tmin, as geom/box.h */
        tmax = vf4_min(vf4_select(neg, t0, t1), tmax);
    }
    tmax = far4(tmax);
    *tn = tmin, *tf = tmax;
    return vi4_mask(tmin <= tmax) & active;
}

typedef struct pk_visit {
    uint32_t node, first, count;
    int mask;
    vf4 dmin, dmax;
} pk_visit;

/* The strip at rec (box lo/hi) for the rays in mask, over their intervals [dmin, dmax]. */
static void strip_packet(const rs_accel *a, rs_pk *p, const uint32_t *rec, const float *lo, const float *hi, int mask,
                         vf4 dmin, vf4 dmax) {
    const uint32_t leaf = a->leaf, lg = (uint32_t)__builtin_ctz(leaf);
    const rs_strip s = rs_strip_at(rec, leaf, a->q16);
    pk_visit stack[24];
    int top = 0;
    uint32_t node = 0, first = 0, count = s.n;
    for (;;) {
        while (count > leaf) {
            const uint32_t groups = (count + leaf - 1) >> lg, left_groups = (groups + 1) >> 1, nl = left_groups << lg;
            const uint32_t fl = s.flags[node];
            const int k = (int)(fl & 3u);
            float p1, p2;
            if (a->q16) {
                uint16_t q[2];
                memcpy(q, (const uint16_t *)s.splits + 2 * node, sizeof q);
                const float step = rs_q16_step(lo[k], hi[k]);
                p1 = rs_q16_plane(q[0], lo[k], hi[k], step), p2 = rs_q16_plane(q[1], lo[k], hi[k], step);
            } else {
                float f[2];
                memcpy(f, (const float *)s.splits + 2 * node, sizeof f);
                p1 = f[0], p2 = f[1];
            }
            const vf4 tl = (vf4_set1(p1) - p->org[k]) * p->inv[k], tu = (vf4_set1(p2) - p->org[k]) * p->inv[k];
            const vi4 up = p->inv[k] >= vf4_set1(0.0f);
            /* lower half x <= p1, upper half x >= p2, per ray by its direction on the axis. */
            const vf4 lower_lo = vf4_select(up, dmin, vf4_max(tl, dmin)), lower_hi = vf4_select(up, vf4_min(far4(tl), dmax), dmax);
            const vf4 upper_lo = vf4_select(up, vf4_max(tu, dmin), dmin), upper_hi = vf4_select(up, dmax, vf4_min(far4(tu), dmax));
            const int lm = vi4_mask(lower_lo <= lower_hi) & mask, um = vi4_mask(upper_lo <= upper_hi) & mask;
            const bool lower_left = !(fl & RS_FLAG_REVERSE);
            const pk_visit left = {node + 1, first, nl, 0, dmin, dmax}, right = {node + left_groups, first + nl, count - nl, 0, dmin, dmax};
            pk_visit lower = lower_left ? left : right, upper = lower_left ? right : left;
            lower.mask = lm, lower.dmin = lower_lo, lower.dmax = lower_hi;
            upper.mask = um, upper.dmin = upper_lo, upper.dmax = upper_hi;
            /* Near first for the first active ray. */
            const bool lower_near = up[__builtin_ctz((unsigned)mask)] != 0;
            const pk_visit *nearv = lower_near ? &lower : &upper, *farv = lower_near ? &upper : &lower;
            pk_visit next;
            if (nearv->mask) {
                if (farv->mask) stack[top++] = *farv;
                next = *nearv;
            } else if (farv->mask) {
                next = *farv;
            } else {
                goto pop;
            }
            node = next.node, first = next.first, count = next.count, mask = next.mask, dmin = next.dmin, dmax = next.dmax;
        }
        for (int m = mask; m; m &= m - 1) {
            const int j = __builtin_ctz((unsigned)m);
            rs_group(&p->r[j], a->vertices, &s, count, p->best[j].t, false, first, rec, &p->best[j]);
        }
    pop:
        for (;;) {
            if (top == 0) return;
            --top;
            mask = stack[top].mask & vi4_mask(stack[top].dmin <= best_t(p));
            if (mask) break;
        }
        node = stack[top].node, first = stack[top].first, count = stack[top].count;
        dmin = stack[top].dmin, dmax = vf4_min(stack[top].dmax, best_t(p));
    }
}

typedef struct pk_entry {
    uint32_t ref, slot;
    int mask;
    float key;
} pk_entry;

static void trace4(const rs_accel *a, rs_pk *p, int active) {
    pk_entry stack[RS_STACK];
    int top = 0;
    uint32_t ref = 0, slot = 0;
    for (;;) {
        if (!(ref & RS_LEAF)) {
            const rs_node *n = &a->nodes[ref];
            pk_entry e[4];
            int c = 0;
            const int lead = __builtin_ctz((unsigned)active);
            for (int i = 0; i < 4; i++) {
                if (n->child[i] == RS_EMPTY) continue;
                vf4 tn, tf;
                const int m = box_rays(p, n, i, active, &tn, &tf);
                if (!m) continue;
                /* Order by the entry of the packet's first active ray (or of any ray that hits). */
                const pk_entry x = {n->child[i], ref * 4 + (uint32_t)i, m, tn[(m >> lead) & 1 ? lead : __builtin_ctz((unsigned)m)]};
                int j = c++;
                while (j > 0 && e[j - 1].key < x.key) e[j] = e[j - 1], j--;
                e[j] = x;
            }
            if (c) {
                for (int i = 0; i < c - 1; i++) stack[top++] = e[i];
                ref = e[c - 1].ref, slot = e[c - 1].slot, active = e[c - 1].mask;
                continue;
            }
        } else {
            const rs_node *n = &a->nodes[slot >> 2];
            const int i = (int)(slot & 3);
            vf4 tn, tf;
            const int m = box_rays(p, n, i, active, &tn, &tf);
            float lo[3], hi[3];
            for (int k = 0; k < 3; k++) lo[k] = n->box[8 * k + i], hi[k] = n->box[8 * k + 4 + i];
            const uint32_t *rec = a->strips + (ref & ~RS_LEAF);
            if (__builtin_popcount((unsigned)m) < RS_PACKET_MIN) {
                for (int mm = m; mm; mm &= mm - 1) {
                    const int j = __builtin_ctz((unsigned)mm);
                    rs_strip_trace(a, &p->r[j], rec, lo, hi, tn[j], tf[j], false, &p->best[j]);
                }
            } else if (m) {
                strip_packet(a, p, rec, lo, hi, m, tn, tf);
            }
        }
        if (top == 0) return;
        --top;
        ref = stack[top].ref, slot = stack[top].slot, active = stack[top].mask;
    }
}

static void finish(const rs_best *b, prt_ray *ray, prt_hit *hit) {
    hit->geom = 0;
    if (!b->rec) {
        hit->t = INFINITY, hit->u = 0, hit->v = 0, hit->prim = PRT_INVALID;
        return;
    }
    const uint32_t code = b->id & ((1u << RS_ID_SHIFT) - 1);
    hit->t = b->t, hit->prim = b->id >> RS_ID_SHIFT;
    hit->u = b->b[rs_perm[code][0]], hit->v = b->b[rs_perm[code][1]];
    ray->tfar = b->t;
}

/* Up to four rays (ray i of the packet at idx[i]) as one SIMD packet. */
static void packet4(const rs_accel *a, prt_packet *pk, const uint32_t *idx, int n) {
    rs_pk p;
    int active = 0;
    for (int j = 0; j < 4; j++) {
        const prt_ray *ray = j < n ? &pk->rays[idx[j]] : NULL;
        const bool ok = ray && prt__ray_valid(ray);
        if (ok) prt__rayx_init(&p.r[j], ray), active |= 1 << j;
        else memset(&p.r[j], 0, sizeof p.r[j]);
        p.best[j] = (rs_best){ok ? ray->tfar : -INFINITY, {0, 0, 0}, NULL, 0, 0};
    }
    for (int k = 0; k < 3; k++) {
        p.org[k] = (vf4){p.r[0].org[k], p.r[1].org[k], p.r[2].org[k], p.r[3].org[k]};
        p.inv[k] = (vf4){p.r[0].inv[k], p.r[1].inv[k], p.r[2].inv[k], p.r[3].inv[k]};
    }
    p.tnear = (vf4){p.r[0].tnear, p.r[1].tnear, p.r[2].tnear, p.r[3].tnear};
    if (active) trace4(a, &p, active);
    for (int j = 0; j < n; j++) {
        if (active >> j & 1) finish(&p.best[j], &pk->rays[idx[j]], &pk->hits[idx[j]]);
        else pk->hits[idx[j]] = (prt_hit){INFINITY, 0, 0, PRT_INVALID, 0};
    }
}

void rs_intersect_packet(const prt_accel *acc, prt_packet *p) {
    const rs_accel *a = (const rs_accel *)acc;
    const uint32_t n = p->count < PRT_PACKET_MAX ? p->count : PRT_PACKET_MAX, w = p->width;
    uint32_t idx[4];
    if (w >= 2 && w % 2 == 0 && n % (2 * w) == 0) { /* 2x2 pixel blocks */
        for (uint32_t y = 0; y < n / w; y += 2)
            for (uint32_t x = 0; x < w; x += 2) {
                idx[0] = y * w + x, idx[1] = idx[0] + 1, idx[2] = idx[0] + w, idx[3] = idx[2] + 1;
                packet4(a, p, idx, 4);
            }
        return;
    }
    for (uint32_t i = 0; i < n; i += 4) {
        const int c = n - i < 4 ? (int)(n - i) : 4;
        for (int j = 0; j < c; j++) idx[j] = i + (uint32_t)j;
        packet4(a, p, idx, c);
    }
}
