/* One quantization lattice per tree for the codecs with a grid per leaf or block
 * (bitpack, bitpack-soa4, strip-bitpack; issue 31). A leaf or block takes as its grid its
 * lower corner and the smallest power of two step with which its span fits mask steps
 * (bvh_lattice_step). Before encoding, the BVH family rounds every coordinate to a multiple
 * of a power of two no finer than the step of any leaf or block holding it: per vertex
 * (bvh_lattice_snap_tree, bitpack and bitpack-soa4) or, where the leaves are made later
 * (strip-bitpack), the cell with which the mesh bounds span mask - 1 steps
 * (bvh_lattice_snap). Each coordinate of a leaf is then lo + q * step for an integer
 * q <= mask, and the decode lo + (float)q * step is exact (every term and the sum are
 * floats: no rounding, whatever the kernel's order or fusing). A vertex shared by several
 * leaves thus decodes to the same float bit for bit in each, and the decoded mesh is as
 * closed as the mesh. The cost: a vertex errs up to half a step of the coarsest grid
 * holding it per component, where a grid per leaf erred half a step of its own grid
 * (docs/results/reliability.md measures both). */
#ifndef PRT_BVH_CODECS_LATTICE_H
#define PRT_BVH_CODECS_LATTICE_H

#include "core/common.h"

#include <math.h>

#define BVH_LATTICE_NONE (-1000) /* bvh_lattice_exp of an empty span: no constraint */

/* The smallest e >= -149 (2^-149: the smallest float) with span <= steps * 2^e;
 * BVH_LATTICE_NONE when span is 0. Powers of two scale exactly: the comparisons are exact. */
static inline int bvh_lattice_exp(double span, uint32_t steps) {
    if (!(span > 0)) return BVH_LATTICE_NONE;
    int e;
    frexp(span / steps, &e); /* span / steps < 2^e, up to the division's rounding */
    while (e > -149 && span <= steps * ldexp(1.0, e - 1)) e--;
    while (span > steps * ldexp(1.0, e)) e++;
    return e < -149 ? -149 : e;
}

/* The grid step of a leaf or block that spans `span`: 2^bvh_lattice_exp, 0 for no span. */
static inline float bvh_lattice_step(double span, uint32_t steps) {
    const int e = bvh_lattice_exp(span, steps);
    return e == BVH_LATTICE_NONE ? 0.0f : ldexpf(1.0f, e);
}

/* x rounded to a multiple of 2^e. Exact in double (a float over a power of two); rounding
 * to float again keeps a multiple: a value a float cannot hold lies where floats are spaced
 * wider than 2^e. */
static inline float bvh_lattice_round(float x, int e) {
    return e == BVH_LATTICE_NONE || !isfinite(x) ? x : (float)(nearbyint(ldexp(x, -e)) * ldexp(1.0, e));
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
    int e[3];
    for (int k = 0; k < 3; k++)
        e[k] = hi[k] > lo[k] ? bvh_lattice_exp((double)hi[k] - lo[k], mask - 1) : BVH_LATTICE_NONE;
    for (size_t v = 0; v < m->vertex_count; v++)
        for (int k = 0; k < 3; k++) out[3 * v + (size_t)k] = bvh_lattice_round(in[3 * v + (size_t)k], e[k]);
}

/* The same as fine as each vertex allows (bvh/lattice_tree.c): for a codec with a grid per
 * `unit` triangles of a leaf (0: per leaf) over tree t, whose t->prims index m's triangles,
 * every vertex rounded to the coarsest lattice that a run a layout may make a grid of and
 * that holds it needs, so that every such run encodes exactly (in and out may not be the
 * same). PRT_ERROR_NOMEM when out of memory. */
struct bvh_tree;
prt_status bvh_lattice_snap_tree(const struct bvh_tree *t, const prt_mesh *m, const float *in, uint32_t mask,
                                 uint32_t unit, float *out);

#endif
