/* Sparse marching cubes: extract the zero set of a field that can bound its distance to the
 * surface from outside, visiting only bricks near the surface (for gen_mandelbulb.c). */
#ifndef PRT_MESH_ISOSURFACE_H
#define PRT_MESH_ISOSURFACE_H

#include "core/common.h"

/* Cells per brick edge: the unit of culling, of parallel work and of vertex ownership. */
#define GEN_BRICK 8

/* Field samples at n world points (x[i], y[i], z[i]) into out[i]. Negative: inside (the
 * magnitude means nothing). Zero or positive: outside, and the value estimates the
 * distance to the surface, so a block whose centre is farther than its half-diagonal can
 * be skipped. Batches let the field use SIMD; a point's value must not depend on the
 * batch it comes in, since grid points shared by bricks are sampled once per brick. */
typedef void (*gen_field_fn)(const void *ctx, size_t n, const double *x, const double *y,
                             const double *z, double *out);

typedef struct gen_iso_params {
    gen_field_fn field;
    const void *ctx;
    double lo[3];        /* minimum corner of the cubic domain */
    double cell;         /* grid spacing: any positive value, so the size of the result can be
                          * tuned continuously */
    uint32_t resolution; /* cells per side, 2 to GEN_ISO_MAX_RES: the domain is
                          * [lo, lo + resolution * cell]^3 */
} gen_iso_params;

#define GEN_ISO_MAX_RES 8192u

/* Extract the surface on a resolution^3 grid. Samples on the domain's faces are taken as
 * outside, so every surface is closed. Surfaces are found from the outside: the bricks near
 * the surface seed a flood fill that follows the surface across brick faces, so every
 * component that comes near the outside region is complete; pockets sealed inside are
 * skipped. Vertices are shared per grid edge; the result is the same for any thread count.
 * out == NULL counts triangles only (into *triangles) without storing anything. */
prt_status gen_isosurface(const gen_iso_params *p, prt_mesh **out, size_t *triangles);

#endif
