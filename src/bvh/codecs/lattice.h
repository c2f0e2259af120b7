/* One quantization lattice per tree for the codecs with a grid per leaf or block
 * (bitpack, bitpack-soa4, strip-bitpack; issue 31). Before the tree is built, every
 * coordinate is rounded to a multiple of a power of two `cell` per axis, the smallest with
 * which the mesh bounds span at most mask - 1 cells (bvh_lattice_snap); the tree and every
 * leaf then see these vertices. A leaf or block takes as its grid its lower corner and the
 * smallest power of two step with which its span fits mask steps (bvh_lattice_step): never
 * above the cell, so each of its coordinates is lo + q * step for an integer q <= mask, and
 * the decode lo + (float)q * step is exact (every term and the sum are floats: no rounding).
 * A vertex shared by several leaves thus decodes to the same float bit for bit in each, and
 * the decoded mesh is as closed as the mesh. The cost: at most half a cell per component,
 * a cell below 2 * span / (mask - 1), where a grid per leaf erred half a leaf step. */
#ifndef PRT_BVH_CODECS_LATTICE_H
#define PRT_BVH_CODECS_LATTICE_H

#include "core/common.h"

#include <math.h>

/* The smallest power of two s >= 2^-149 (the smallest float) with span <= steps * s, as a
 * float; 0 when span is 0. Powers of two scale exactly, so the comparisons are exact. */
static inline float bvh_lattice_step(double span, uint32_t steps) {
    if (!(span > 0)) return 0.0f;
    int e;
    frexp(span / steps, &e); /* span / steps < 2^e, up to the division's rounding */
    while (e > -149 && span <= steps * ldexp(1.0, e - 1)) e--;
    while (span > steps * ldexp(1.0, e)) e++;
    return ldexpf(1.0f, e < -149 ? -149 : e);
}

/* out: the vertices `in` (of m's triangles; m->vertices is not read, and out may be it)
 * rounded to the tree's lattice: per axis multiples of the step with which the bounds of
 * the triangles' vertices span mask - 1 steps, so that any leaf spans at most mask of them
 * (the bounds grow by at most half a step each side). A coordinate already a multiple
 * (a step below its float spacing) stays as it is. */
static inline void bvh_lattice_snap(const prt_mesh *m, const float *in, uint32_t mask, float *out) {
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < 3 * m->triangle_count; i++)
        for (int k = 0; k < 3; k++) {
            const float x = in[3 * (size_t)m->triangles[i] + (size_t)k];
            lo[k] = fminf(lo[k], x), hi[k] = fmaxf(hi[k], x);
        }
    double cell[3];
    for (int k = 0; k < 3; k++) cell[k] = hi[k] > lo[k] ? (double)bvh_lattice_step((double)hi[k] - lo[k], mask - 1) : 0.0;
    for (size_t v = 0; v < m->vertex_count; v++)
        for (int k = 0; k < 3; k++) {
            const float x = in[3 * v + (size_t)k];
            /* Exact in double (a float over a power of two); rounding to float again keeps a
             * multiple of the cell: a value a float cannot hold lies where floats are
             * spaced wider than the cell. */
            out[3 * v + (size_t)k] = cell[k] > 0 && isfinite(x) ? (float)(nearbyint(x / cell[k]) * cell[k]) : x;
        }
}

#endif
