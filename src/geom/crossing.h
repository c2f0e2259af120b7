/* The crossing test of the all-hits and containment queries: Woop et al.'s watertight
 * ray/triangle test exactly as prt__tri_hit computes it (so t, u and v are its values bit
 * for bit), with one change: an edge function that is exactly zero, the ray passing through
 * an edge or a vertex, takes the sign it would have if the ray were moved by (e, e^2) in the
 * sheared plane, e infinitesimal ("simulation of simplicity", Edelsbrunner and Mücke 1990).
 * Two triangles sharing an edge see exactly negated edge functions and negated moves, so
 * exactly one of them owns a ray through that edge when the surface crosses the ray there,
 * and both or neither when it folds back (a graze): crossings along a ray through a closed
 * mesh are counted once each and their parity is exact. */
#ifndef PRT_GEOM_CROSSING_H
#define PRT_GEOM_CROSSING_H

#include "geom/triangle.h"

/* Sign of the edge function e of the edge from (x0, y0) to (x1, y1) at the moved origin:
 * e + ex (y1 - y0) + e^2 (x0 - x1). A float difference has the exact difference's sign. */
static inline float prt__sos_edge(float e, float x0, float y0, float x1, float y1) {
    if (e != 0.0f) return e;
    const float dy = y1 - y0, dx = x0 - x1;
    return dy != 0.0f ? dy : dx;
}

/* One triangle; on a crossing with t in [r->tnear, tfar] returns true and sets t, u, v
 * (u weights p1 and v p2, as prt_hit). */
static inline bool prt__tri_cross(const prt__rayx *r, const float *p0, const float *p1, const float *p2, float tfar,
                                  float *t_out, float *u_out, float *v_out) {
    const int kx = r->kx, ky = r->ky, kz = r->kz;
    const float az0 = p0[kz] - r->org[kz], bz0 = p1[kz] - r->org[kz], cz0 = p2[kz] - r->org[kz];
    const float ax = (p0[kx] - r->org[kx]) - r->sx * az0, ay = (p0[ky] - r->org[ky]) - r->sy * az0;
    const float bx = (p1[kx] - r->org[kx]) - r->sx * bz0, by = (p1[ky] - r->org[ky]) - r->sy * bz0;
    const float cx = (p2[kx] - r->org[kx]) - r->sx * cz0, cy = (p2[ky] - r->org[ky]) - r->sy * cz0;
    float u = cx * by - cy * bx;
    float v = ax * cy - ay * cx;
    float w = bx * ay - by * ax;
    if (PRT_UNLIKELY(u == 0.0f || v == 0.0f || w == 0.0f)) prt__tri_edges_double(ax, ay, bx, by, cx, cy, &u, &v, &w);
    /* u belongs to the edge b -> c, v to c -> a, w to a -> b. */
    const float su = prt__sos_edge(u, bx, by, cx, cy), sv = prt__sos_edge(v, cx, cy, ax, ay);
    const float sw = prt__sos_edge(w, ax, ay, bx, by);
    if ((su < 0.0f || sv < 0.0f || sw < 0.0f) && (su > 0.0f || sv > 0.0f || sw > 0.0f)) return false;
    if (su == 0.0f || sv == 0.0f || sw == 0.0f) return false; /* an edge of no length: seen edge-on */
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

#endif
