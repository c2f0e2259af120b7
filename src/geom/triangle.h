/* Watertight ray/triangle intersection (Woop, Benthin, Wald, "Watertight Ray/Triangle
 * Intersection", JCGT 2013), one triangle and four at once. Vertices are translated to
 * the ray origin, sheared so the ray runs along +z, and the 2D edge functions U, V, W
 * decide the hit; an edge shared by two triangles yields exactly negated edge functions
 * in both (no FMA: see CMakeLists.txt), so no ray slips between them. When an edge
 * function is exactly zero it is recomputed in double (§3.2). Zero-area triangles never
 * hit (det == 0); builders drop exactly degenerate ones up front. Both versions give
 * bit-identical results for the same triangle. */
#ifndef PRT_GEOM_TRIANGLE_H
#define PRT_GEOM_TRIANGLE_H

#include "core/simd.h"
#include "geom/ray.h"

/* Edge functions recomputed in double: the products of floats are exact there, so the
 * sign of a near-zero edge function is decided correctly. */
static inline void prt__tri_edges_double(float ax, float ay, float bx, float by, float cx, float cy,
                                         float *u, float *v, float *w) {
    *u = (float)((double)cx * (double)by - (double)cy * (double)bx);
    *v = (float)((double)ax * (double)cy - (double)ay * (double)cx);
    *w = (float)((double)bx * (double)ay - (double)by * (double)ax);
}

/* One triangle. On a hit with t in [tnear, tfar] returns true and sets t, u, v. */
static inline bool prt__tri_hit(const prt__rayx *r, const float *p0, const float *p1, const float *p2,
                                float tfar, float *t_out, float *u_out, float *v_out) {
    const int kx = r->kx, ky = r->ky, kz = r->kz;
    const float az0 = p0[kz] - r->org[kz], bz0 = p1[kz] - r->org[kz], cz0 = p2[kz] - r->org[kz];
    const float ax = (p0[kx] - r->org[kx]) - r->sx * az0, ay = (p0[ky] - r->org[ky]) - r->sy * az0;
    const float bx = (p1[kx] - r->org[kx]) - r->sx * bz0, by = (p1[ky] - r->org[ky]) - r->sy * bz0;
    const float cx = (p2[kx] - r->org[kx]) - r->sx * cz0, cy = (p2[ky] - r->org[ky]) - r->sy * cz0;
    float u = cx * by - cy * bx;
    float v = ax * cy - ay * cx;
    float w = bx * ay - by * ax;
    if (PRT_UNLIKELY(u == 0.0f || v == 0.0f || w == 0.0f)) prt__tri_edges_double(ax, ay, bx, by, cx, cy, &u, &v, &w);
    if ((u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f)) return false;
    const float det = u + v + w;
    if (det == 0.0f) return false;
    const float T = u * (r->sz * az0) + v * (r->sz * bz0) + w * (r->sz * cz0);
    const float t = T / det;
    if (!(t >= r->tnear && t <= tfar)) return false;
    *t_out = t;
    *u_out = v / det;
    *v_out = w / det;
    return true;
}

/* Four triangles in SOA form: p[c] for c = 0..8 holds component c%3 of vertex c/3 for the
 * four lanes. Padding lanes hold NaN vertices, which never hit. Returns the mask of lanes
 * hit within [tnear, tfar]; when non-zero, t (+inf in lanes not hit), u and v are set. */
typedef struct prt__rayx4t {
    vf4 org[3], sx, sy, sz;
    vf4 tnear;
} prt__rayx4t;

static inline void prt__rayx4t_init(prt__rayx4t *x, const prt__rayx *r) {
    for (int k = 0; k < 3; k++) x->org[k] = vf4_set1(r->org[k]);
    x->sx = vf4_set1(r->sx), x->sy = vf4_set1(r->sy), x->sz = vf4_set1(r->sz);
    x->tnear = vf4_set1(r->tnear);
}

PRT_NOINLINE static void prt__tri4_fix_edges(vi4 zero, const vf4 *ax, const vf4 *ay, const vf4 *bx,
                                             const vf4 *by, const vf4 *cx, const vf4 *cy, vf4 *u, vf4 *v,
                                             vf4 *w) {
    for (int i = 0; i < 4; i++)
        if (zero[i]) {
            float uu, vv, ww;
            prt__tri_edges_double((*ax)[i], (*ay)[i], (*bx)[i], (*by)[i], (*cx)[i], (*cy)[i], &uu, &vv, &ww);
            (*u)[i] = uu, (*v)[i] = vv, (*w)[i] = ww;
        }
}

static inline int prt__tri4_hit(const prt__rayx *r, const prt__rayx4t *r4, const float *p, vf4 tfar,
                                vf4 *t_out, vf4 *u_out, vf4 *v_out) {
    const int kx = r->kx, ky = r->ky, kz = r->kz;
    const vf4 az0 = vf4_load(p + 4 * (0 + kz)) - r4->org[kz];
    const vf4 bz0 = vf4_load(p + 4 * (3 + kz)) - r4->org[kz];
    const vf4 cz0 = vf4_load(p + 4 * (6 + kz)) - r4->org[kz];
    const vf4 ax = (vf4_load(p + 4 * (0 + kx)) - r4->org[kx]) - r4->sx * az0;
    const vf4 ay = (vf4_load(p + 4 * (0 + ky)) - r4->org[ky]) - r4->sy * az0;
    const vf4 bx = (vf4_load(p + 4 * (3 + kx)) - r4->org[kx]) - r4->sx * bz0;
    const vf4 by = (vf4_load(p + 4 * (3 + ky)) - r4->org[ky]) - r4->sy * bz0;
    const vf4 cx = (vf4_load(p + 4 * (6 + kx)) - r4->org[kx]) - r4->sx * cz0;
    const vf4 cy = (vf4_load(p + 4 * (6 + ky)) - r4->org[ky]) - r4->sy * cz0;
    vf4 u = cx * by - cy * bx;
    vf4 v = ax * cy - ay * cx;
    vf4 w = bx * ay - by * ax;
    const vf4 zero = vf4_set1(0.0f);
    const vi4 any_zero = (u == zero) | (v == zero) | (w == zero);
    if (PRT_UNLIKELY(vi4_mask(any_zero))) prt__tri4_fix_edges(any_zero, &ax, &ay, &bx, &by, &cx, &cy, &u, &v, &w);
    const vi4 mixed = ((u < zero) | (v < zero) | (w < zero)) & ((u > zero) | (v > zero) | (w > zero));
    const vf4 det = u + v + w;
    const vf4 T = u * (r4->sz * az0) + v * (r4->sz * bz0) + w * (r4->sz * cz0);
    const vf4 t = T / det;
    const vi4 ok = ~mixed & (det != zero) & (t >= r4->tnear) & (t <= tfar);
    int mask = vi4_mask(ok);
    if (mask) {
        *t_out = vf4_select(ok, t, vf4_set1(INFINITY));
        *u_out = v / det;
        *v_out = w / det;
    }
    return mask;
}

#endif
