/* The Ray-Strip kernels of single rays, streams and packets (traverse.c): the
 * edge test of a group of up to 8 consecutive strip triangles (§5.2) and the traversal of
 * one strip's implicit s-kd tree (§5.1, Algorithm 1).
 *
 * Edge tests: every strip vertex is moved into the ray's sheared frame once (Woop, Benthin,
 * Wald 2013: the ray runs along +z through the origin), and the 2D edge function of an edge
 * PQ, W(P, Q) = Px Qy - Py Qx, is the ray's Plücker side product with the edge's line in
 * that frame. A strip has two kinds of edges: sides (j, j + 1), each shared by triangles
 * j - 1 and j, and diagonals (j, j + 2); 8 triangles take 9 sides and 8 diagonals, each
 * computed once, eight at a time. W is exactly antisymmetric (W(Q, P) = -W(P, Q) bit for
 * bit, no FMA) and a zero is recomputed in double, so its sign is exact: an edge gets the
 * same answer in every triangle and every strip that has it, and no ray slips through a
 * shared edge or vertex. Triangle j of a strip (vertices j, j + 1, j + 2, winding
 * alternating) is hit when its three edge functions, -side(j + 1), diag(j), -side(j), have
 * one sign; these are the weights of vertices j, j + 1, j + 2 (all negated on odd j, which
 * the division by their sum undoes). Triangles with a repeated vertex (a strip's turns)
 * get a zero and two opposite values: never hit. */
#ifndef PRT_STRIPS_KERNEL_H
#define PRT_STRIPS_KERNEL_H

#include "bvh/layouts/wide8_box.h"
#include "core/simd.h"
#include "geom/box.h"
#include "geom/triangle.h"
#include "strips/strips.h"

#include <math.h>

/* Far distances grow by Ize's 2 gamma(3), as in geom/box.h, so clipping stays conservative. */
static inline float rs_far(float t) { return t * (t >= 0.0f ? PRT_BOX_FAR_SCALE : PRT_BOX_FAR_SCALE_NEG); }

/* A hit inside a strip: the record, the strip triangle, the weights of its three strip
 * vertices. */
typedef struct rs_best {
    float t, b[3];
    const uint32_t *rec;
    uint32_t tri, id;
} rs_best;

/* Edge functions of a side or diagonal recomputed in double where they came out zero. */
PRT_NOINLINE static void rs_fix_zero_edges(int zero, float *e, const float *X, const float *Y, int step) {
    for (; zero; zero &= zero - 1) {
        int j = __builtin_ctz((unsigned)zero);
        e[j] = (float)((double)X[j] * (double)Y[j + step] - (double)Y[j] * (double)X[j + step]);
    }
}

/* rs_group4 (count <= 3) and rs_group8 (count <= 8) from strips/group.inc. */
#define RG_W 4
#include "strips/group.inc"
#undef RG_W
#define RG_W 8
#include "strips/group.inc"
#undef RG_W

/* Triangles [first, first + count) of strip s (count <= 8)
 * against ray r within [tnear, tfar]. any: return at the first hit (mask only). Otherwise
 * the nearest hit goes to *best (ties to the smallest id) and the mask of hits is returned. */
static inline int rs_group(const prt__rayx *r, const float *vertices, const rs_strip *s, uint32_t count, float tfar,
                           bool any, uint32_t first, const uint32_t *rec, rs_best *best) {
    return count <= 3 ? rs_group4(r, vertices, s, count, tfar, any, first, rec, best)
                      : rs_group8(r, vertices, s, count, tfar, any, first, rec, best);
}

/* Strip traversal state. */
typedef struct rs_visit {
    uint32_t node, first, count;
    float dmin, dmax;
} rs_visit;

/* The two planes of s-kd node `node` on axis k of strip s (g: the grid of the top-level
 * node holding the strip, read for q16 only). */
static inline void rs_planes(const rs_accel *a, const rs_strip *s, uint32_t node, int k, const rs_grid *g, float *p1,
                             float *p2) {
    if (a->fmt.q16) {
        uint16_t q[2];
        memcpy(q, (const uint16_t *)s->splits + 2 * node, sizeof q);
        *p1 = rs_q16_plane(q[0], g, k), *p2 = rs_q16_plane(q[1], g, k);
    } else {
        float f[2];
        memcpy(f, (const float *)s->splits + 2 * node, sizeof f);
        *p1 = f[0], *p2 = f[1];
    }
}

/* The strip of the leaf entry at e. */
static inline rs_strip rs_strip_of(const rs_accel *a, const uint32_t *e) {
    rs_strip s = rs_strip_at(e + a->fmt.no_ids, &a->fmt);
    if (a->fmt.no_ids) s.base = e[0];
    return s;
}

/* The hit's mesh triangle (or position, ids=none), barycentrics in the mesh triangle's
 * vertex order and material, from the strip triangle's id. */
static inline void rs_finish(const rs_accel *a, const rs_best *b, prt_ray *ray, prt_hit *hit) {
    if (!b->rec) {
        *hit = prt__miss();
        return;
    }
    hit->geom = 0;
    const uint32_t code = b->id & ((1u << RS_ID_SHIFT) - 1);
    hit->t = b->t, hit->prim = b->id >> RS_ID_SHIFT;
    hit->u = b->b[rs_perm[code][0]], hit->v = b->b[rs_perm[code][1]];
    if (a->fmt.mat) {
        const rs_strip s = rs_strip_at(b->rec, &a->fmt);
        hit->geom = s.mat[rs_live_index(&s, b->tri)];
    }
    ray->tfar = b->t;
}

/* The strip of the leaf entry at e, on grid g (read for q16 only), entered over
 * [dmin, dmax]. any: true at the first hit. Otherwise best->t shrinks with
 * every nearer hit; returns whether one was found. Algorithm 1 with the reverse flag;
 * lg = log2(leaf). */
static inline bool rs_strip_trace(const rs_accel *a, const prt__rayx *r, const uint32_t *e, const rs_grid *g,
                                  float dmin, float dmax, bool any, rs_best *best) {
    const uint32_t leaf = a->fmt.leaf, lg = (uint32_t)__builtin_ctz(leaf);
    const rs_strip s = rs_strip_of(a, e);
    const uint32_t *rec = e + a->fmt.no_ids;
    rs_visit stack[24];
    int top = 0;
    bool found = false;
    uint32_t node = 0, first = 0, count = s.n;
    for (;;) {
        while (count > leaf) {
            const uint32_t groups = (count + leaf - 1) >> lg, left_groups = (groups + 1) >> 1;
            const uint32_t nl = left_groups << lg;
            const uint32_t fl = s.flags[node];
            const int k = (int)(fl & 3u);
            float p1, p2;
            rs_planes(a, &s, node, k, g, &p1, &p2);
            /* lower half: x <= p1, upper half: x >= p2; the near one is the lower when the ray
             * runs up the axis. NaN distances (origin on a plane the ray runs along) clip
             * nothing. */
            const float tl = (p1 - r->org[k]) * r->inv[k], tu = (p2 - r->org[k]) * r->inv[k];
            const bool up = !r->neg[k];
            const float near_end = rs_far(up ? tl : tu), far_start = up ? tu : tl;
            const float near_hi = near_end < dmax ? near_end : dmax;
            const float far_lo = far_start > dmin ? far_start : dmin;
            const bool near_lower = up, lower_left = !(fl & RS_FLAG_REVERSE);
            const bool near_left = near_lower == lower_left;
            const bool near_ok = dmin <= near_hi, far_ok = far_lo <= dmax;
            const uint32_t ln = node + 1, rn = node + left_groups, lf = first, rf = first + nl, lc = nl,
                           rc = count - nl;
            if (near_ok) {
                if (far_ok)
                    stack[top++] =
                        near_left ? (rs_visit){rn, rf, rc, far_lo, dmax} : (rs_visit){ln, lf, lc, far_lo, dmax};
                if (near_left) node = ln, first = lf, count = lc;
                else node = rn, first = rf, count = rc;
                dmax = near_hi;
            } else if (far_ok) {
                if (near_left) node = rn, first = rf, count = rc;
                else node = ln, first = lf, count = lc;
                dmin = far_lo;
            } else {
                goto pop;
            }
        }
        if (rs_group(r, a->vertices, &s, count, best->t, any, first, rec, best)) {
            if (any) return true;
            found = true;
        }
    pop:
        /* Culls against the hit so far take the node test's slack (wide8_far_widen1): an
         * entry distance can round above the t of a hit inside its cell, which without it
         * dropped a nearer hit (or an equal t's smaller id) depending on the visiting order
         * (rays aimed at vertices), so packets and single rays disagreed. */
        for (;;) {
            if (top == 0) return found;
            --top;
            if (any || stack[top].dmin <= wide8_far_widen1(best->t)) break;
        }
        node = stack[top].node, first = stack[top].first, count = stack[top].count;
        dmin = stack[top].dmin, dmax = stack[top].dmax;
        if (!any && wide8_far_widen1(best->t) < dmax) dmax = wide8_far_widen1(best->t);
    }
}

#endif
