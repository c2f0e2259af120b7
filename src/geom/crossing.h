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

/* One triangle; on a crossing with t in [r->tnear, tfar] returns true and sets t, u, v
 * (u weights p1 and v p2, as prt_hit): prt__tri_hit's test with the tie rule above. */
static inline bool prt__tri_cross(const prt__rayx *r, const float *p0, const float *p1, const float *p2, float tfar,
                                  float *t_out, float *u_out, float *v_out) {
    return prt__tri_test(r, p0, p1, p2, tfar, t_out, u_out, v_out, true);
}

#endif
