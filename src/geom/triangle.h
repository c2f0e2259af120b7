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

#include "core/simd16.h"
#include "geom/ray.h"

/* Edge functions recomputed in double: the products of floats are exact there, so the
 * sign of a near-zero edge function is decided correctly. */
static inline void prt__tri_edges_double(float ax, float ay, float bx, float by, float cx, float cy, float *u, float *v,
                                         float *w) {
    *u = (float)((double)cx * (double)by - (double)cy * (double)bx);
    *v = (float)((double)ax * (double)cy - (double)ay * (double)cx);
    *w = (float)((double)bx * (double)ay - (double)by * (double)ax);
}

/* Sign of the edge function e of the edge from (x0, y0) to (x1, y1) with the ray moved by
 * (eps, eps^2) in the sheared plane (geom/crossing.h): e + eps (y1 - y0) + eps^2 (x0 - x1). A
 * float difference has the sign of the exact one. */
static inline float prt__sos_edge(float e, float x0, float y0, float x1, float y1) {
    if (e != 0.0f) return e;
    const float dy = y1 - y0, dx = x0 - x1;
    return dy != 0.0f ? dy : dx;
}

/* One triangle. On a hit with t in [tnear, tfar] returns true and sets t, u, v. crossing
 * (a constant at every call, so the branch folds away): edge functions that are exactly
 * zero take the sign of a moved ray (prt__sos_edge), so that a ray through an edge or a
 * vertex belongs to one triangle of a crossing surface (geom/crossing.h); otherwise zero
 * counts as inside for every triangle (watertight, and hits there twice). */
static inline bool prt__tri_test(const prt__rayx *r, const float *p0, const float *p1, const float *p2, float tfar,
                                 float *t_out, float *u_out, float *v_out, bool crossing) {
    const int kx = r->kx, ky = r->ky, kz = r->kz;
    const float az0 = p0[kz] - r->org[kz], bz0 = p1[kz] - r->org[kz], cz0 = p2[kz] - r->org[kz];
    const float ax = (p0[kx] - r->org[kx]) - r->sx * az0, ay = (p0[ky] - r->org[ky]) - r->sy * az0;
    const float bx = (p1[kx] - r->org[kx]) - r->sx * bz0, by = (p1[ky] - r->org[ky]) - r->sy * bz0;
    const float cx = (p2[kx] - r->org[kx]) - r->sx * cz0, cy = (p2[ky] - r->org[ky]) - r->sy * cz0;
    float u = cx * by - cy * bx;
    float v = ax * cy - ay * cx;
    float w = bx * ay - by * ax;
    if (PRT_UNLIKELY(u == 0.0f || v == 0.0f || w == 0.0f)) prt__tri_edges_double(ax, ay, bx, by, cx, cy, &u, &v, &w);
    float su = u, sv = v, sw = w;
    if (crossing) { /* u belongs to the edge b -> c, v to c -> a, w to a -> b */
        su = prt__sos_edge(u, bx, by, cx, cy), sv = prt__sos_edge(v, cx, cy, ax, ay),
        sw = prt__sos_edge(w, ax, ay, bx, by);
        if (su == 0.0f || sv == 0.0f || sw == 0.0f) return false; /* an edge of no length: seen edge-on */
    }
    if ((su < 0.0f || sv < 0.0f || sw < 0.0f) && (su > 0.0f || sv > 0.0f || sw > 0.0f)) return false;
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

static inline bool prt__tri_hit(const prt__rayx *r, const float *p0, const float *p1, const float *p2, float tfar,
                                float *t_out, float *u_out, float *v_out) {
    return prt__tri_test(r, p0, p1, p2, tfar, t_out, u_out, v_out, false);
}

/* The axes of a ray whose triangle vertices were renamed kx, ky, kz -> 0, 1, 2 as they
 * were loaded (prt__rayx4t_init_renamed): what such codecs pass to prt__tri4_hit. */
static const prt__rayx prt__rayx_renamed = {.kx = 0, .ky = 1, .kz = 2};

/* N triangles at once (N = 4 and 8, from geom/triangle_simd.inc): prt__rayx4t /
 * prt__tri4_hit and prt__rayx8t / prt__tri8_hit; N = 16 where vf16 is native (AVX-512), for
 * the test over 16 rays (geom/triangle_rays.h). */
#define TRI_W 4
#include "geom/triangle_simd.inc"
#undef TRI_W
#define TRI_W 8
#include "geom/triangle_simd.inc"
#undef TRI_W
#if PRT_SIMD16_NATIVE
#define TRI_W 16
#include "geom/triangle_simd.inc"
#undef TRI_W
#endif

#endif
