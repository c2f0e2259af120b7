/* Wald's precomputed projection triangle test (Wald 2004, §7.1; the test the coherent grid
 * paper used, §3 of Wald et al. 2006): per triangle 48 bytes rebuilt every frame, the plane
 * as k-projected coefficients and the two barycentric edge equations in the projection
 * plane. Not watertight (a ray through a shared edge can miss both triangles), so cgrid
 * keeps the watertight test by default and offers this one as tri=wald, for measuring.
 * The scalar and 8-ray forms do the same operations in the same order (packets give the
 * single rays' bits; -ffp-contract=off). */
#ifndef PRT_CGRID_WALD_TRI_H
#define PRT_CGRID_WALD_TRI_H

#include "core/simd.h"

#include <math.h>
#include <stdint.h>

typedef struct cg_wald {
    float n_u, n_v, n_d;         /* plane: p_k + n_u p_u + n_v p_v = n_d */
    uint32_t k;                  /* projection axis: the normal's largest component */
    float b_nu, b_nv, b_d, pad0; /* barycentric of vertex B: b_nu h_u + b_nv h_v + b_d */
    float c_nu, c_nv, c_d, pad1; /* barycentric of vertex C */
} cg_wald;
_Static_assert(sizeof(cg_wald) == 48, "Wald's triangle record is 48 bytes");

/* Precompute from vertices A, B, C (9 floats). A zero-area or NaN triangle gets NaN
 * coefficients, which no comparison accepts. */
static inline void cg_wald_setup(const float *p, cg_wald *w) {
    const float e1[3] = {p[3] - p[0], p[4] - p[1], p[5] - p[2]}, e2[3] = {p[6] - p[0], p[7] - p[1], p[8] - p[2]};
    const float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    const float ax = fabsf(n[0]), ay = fabsf(n[1]), az = fabsf(n[2]);
    const uint32_t k = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2), u = (k + 1) % 3, v = (k + 2) % 3;
    const float ink = n[k] != 0.0f ? 1.0f / n[k] : NAN;
    w->k = k;
    w->n_u = n[u] * ink, w->n_v = n[v] * ink;
    w->n_d = (n[0] * p[0] + n[1] * p[1] + n[2] * p[2]) * ink;
    const float det = e1[u] * e2[v] - e1[v] * e2[u], id = det != 0.0f ? 1.0f / det : NAN;
    w->b_nu = e2[v] * id, w->b_nv = -e2[u] * id, w->b_d = (p[v] * e2[u] - p[u] * e2[v]) * id;
    w->c_nu = -e1[v] * id, w->c_nv = e1[u] * id, w->c_d = (p[u] * e1[v] - p[v] * e1[u]) * id;
    w->pad0 = w->pad1 = 0;
}

/* Hit with t in [tnear, tfar]: t, and u, v the weights of B and C. */
static inline bool cg_wald_hit(const cg_wald *w, const float *org, const float *dir, float tnear, float tfar,
                               float *t_out, float *u_out, float *v_out) {
    const uint32_t k = w->k, u = (k + 1) % 3, v = (k + 2) % 3;
    const float nd = 1.0f / (dir[k] + w->n_u * dir[u] + w->n_v * dir[v]);
    const float f = (w->n_d - org[k] - w->n_u * org[u] - w->n_v * org[v]) * nd;
    if (!(f >= tnear && f <= tfar)) return false;
    const float hu = org[u] + f * dir[u], hv = org[v] + f * dir[v];
    const float lambda = hu * w->b_nu + hv * w->b_nv + w->b_d;
    const float mue = hu * w->c_nu + hv * w->c_nv + w->c_d;
    if (!(lambda >= 0.0f && mue >= 0.0f && lambda + mue <= 1.0f)) return false;
    *t_out = f, *u_out = lambda, *v_out = mue;
    return true;
}

/* The same for 8 rays (SOA org, dir, tnear, tfar): mask of lanes hit. */
static inline int cg_wald_hit8(const cg_wald *w, const vf8 org[3], const vf8 dir[3], vf8 tnear, vf8 tfar, vf8 *t_out,
                               vf8 *u_out, vf8 *v_out) {
    const uint32_t k = w->k, u = (k + 1) % 3, v = (k + 2) % 3;
    const vf8 nu = vf8_set1(w->n_u), nv = vf8_set1(w->n_v);
    const vf8 nd = vf8_set1(1.0f) / (dir[k] + nu * dir[u] + nv * dir[v]);
    const vf8 f = (vf8_set1(w->n_d) - org[k] - nu * org[u] - nv * org[v]) * nd;
    const vi8 in_t = (f >= tnear) & (f <= tfar);
    if (!vi8_mask(in_t)) return 0;
    const vf8 hu = org[u] + f * dir[u], hv = org[v] + f * dir[v];
    const vf8 lambda = hu * vf8_set1(w->b_nu) + hv * vf8_set1(w->b_nv) + vf8_set1(w->b_d);
    const vf8 mue = hu * vf8_set1(w->c_nu) + hv * vf8_set1(w->c_nv) + vf8_set1(w->c_d);
    const vf8 zero = vf8_set1(0.0f);
    const int mask = vi8_mask(in_t & (lambda >= zero) & (mue >= zero) & (lambda + mue <= vf8_set1(1.0f)));
    if (mask) *t_out = f, *u_out = lambda, *v_out = mue;
    return mask;
}

#endif
