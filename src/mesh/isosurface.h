/* Sparse marching cubes: extract the zero set of a field that can bound its distance to the
 * surface from outside, visiting only bricks near the surface (for gen_mandelbulb.c). */
#ifndef PRT_MESH_ISOSURFACE_H
#define PRT_MESH_ISOSURFACE_H

#include "core/common.h"
#include "mesh/tri_stream.h"

/* Cells per brick edge: the unit of culling, of parallel work and of vertex ownership. */
#define GEN_BRICK 8

/* Field samples at n world points (x[i], y[i], z[i]) into out[i]. Negative: inside (the
 * magnitude means nothing). Zero or positive: outside, and the value estimates the
 * distance to the surface, so a block whose centre is farther than its half-diagonal can
 * be skipped. Batches let the field use SIMD; a point's value must not depend on the
 * batch it comes in, since grid points shared by bricks are sampled once per brick. */
typedef void (*gen_field_fn)(const void *ctx, size_t n, const double *x, const double *y, const double *z, double *out);

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

/* Budgets below this are raised to it (a few hundred bricks in flight). */
#define GEN_ISO_MIN_BUDGET ((size_t)16 << 20)

/* The same triangles as gen_isosurface (each corner computed from the same two samples as
 * the mesh's vertex, so the positions are bit-identical), handed to sink in batches without
 * building a mesh. Order: bricks in the flood fill's order (breadth-first rounds from the
 * seeds), each brick's triangles as in the mesh; the same for any thread count. Bricks are
 * extracted in groups whose worst case fits memory_budget (at least GEN_ISO_MIN_BUDGET);
 * the flood fill's bitmap of visited bricks (resolution^3 / 4096 bits, 128 MiB at the
 * largest grid) and its frontier (4 bytes a brick) come on top. *triangles (may be NULL):
 * the total. A sink status other than PRT_OK stops the extraction and is returned. */
/* An indexed surface handed on in the order a file needs: the counts, every vertex (3 floats
 * each), then every triangle (3 vertex indices each), in batches. */
typedef struct gen_iso_indexed_out {
    prt_status (*begin)(void *user, uint64_t vertices, uint64_t triangles);
    prt_status (*vertices)(void *user, const float *xyz, size_t count);
    prt_status (*triangles)(void *user, const uint32_t *indices, size_t count);
    void *user;
} gen_iso_indexed_out;

/* The mesh gen_isosurface builds (the same vertices and triangles in the same order) handed
 * to out without holding it (iso_spill.c): the bricks' pieces go to a temporary file beside
 * temp_near ("temp_near.spill-XXXXXX", removed from the directory at once; NULL: $TMPDIR or
 * /tmp), about 14 bytes a triangle, then are read back in the mesh's order. Memory: bricks
 * in flight within memory_budget (at least GEN_ISO_MIN_BUDGET), 24 bytes a brick that holds
 * surface (about 1/6 byte a triangle) and gen_isosurface_stream's bitmap and frontier.
 * *vertices, *triangles (may be NULL): the counts. Callback errors are returned as is. */
prt_status gen_isosurface_indexed(const gen_iso_params *p, size_t memory_budget, const char *temp_near,
                                  const gen_iso_indexed_out *out, uint64_t *vertices, uint64_t *triangles);

prt_status gen_isosurface_stream(const gen_iso_params *p, size_t memory_budget, tri_sink_fn sink, void *user,
                                 uint64_t *triangles);

#endif
