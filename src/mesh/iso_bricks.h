/* The bricks of a sparse marching-cubes surface as a procedural source (isosurface.c,
 * gen_mandelbulb.c): a census of the bricks that hold surface, in the triangle stream's
 * order, and any one brick's triangles regenerated on demand. Every triangle lies in its
 * brick's closed box, so an out-of-core builder can split bricks instead of spooling
 * triangles (src/ooc/build.c, docs/ooc.md). */
#ifndef PRT_MESH_ISO_BRICKS_H
#define PRT_MESH_ISO_BRICKS_H

#include "mesh/isosurface.h"

/* Triangles a brick can hold: every cell of GEN_BRICK^3 at marching cubes' maximum of 5. */
#define GEN_ISO_MAX_BRICK_TRIS (GEN_BRICK * GEN_BRICK * GEN_BRICK * 5)

/* One brick that holds surface: its id ((bz * nb + by) * nb + bx, nb bricks a side) and its
 * triangles' corners (9 floats a triangle), valid during the call. */
typedef struct gen_iso_brick {
    uint32_t id, ntri;
    const float *soup;
} gen_iso_brick;

/* Receives the bricks that hold surface group by group, in the order of
 * gen_isosurface_stream's triangles: brick i's first triangle has stream id equal to the
 * sum of ntri before it. Anything but PRT_OK stops the census with that status. */
typedef prt_status (*gen_iso_bricks_fn)(void *user, const gen_iso_brick *bricks, size_t n);

/* The census: the flood fill of gen_isosurface_stream (same grid, same order, same memory
 * rules), handing on each brick with its triangles instead of a flat stream. */
prt_status gen_isosurface_bricks(const gen_iso_params *p, size_t memory_budget, gen_iso_bricks_fn fn, void *user,
                                 uint64_t *triangles);

/* One brick's triangles regenerated from its own samples: the same corners, bit for bit and
 * in the same order, as the stream hands on for it. soup holds GEN_ISO_MAX_BRICK_TRIS * 9
 * floats; returns the count. Safe to call from many threads at once. */
typedef struct gen_iso_regen gen_iso_regen;
prt_status gen_iso_regen_open(const gen_iso_params *p, gen_iso_regen **out);
uint32_t gen_iso_regen_brick(const gen_iso_regen *r, uint32_t id, float *soup);
void gen_iso_regen_free(gen_iso_regen *r);

/* The grid gen_mandelbulb_stream extracts for a request of `triangles` (calibrated as it
 * does: the same checks and errors). */
prt_status gen_mandelbulb_grid(size_t triangles, gen_iso_params *p);

#endif
