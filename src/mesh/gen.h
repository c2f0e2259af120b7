/* The procedural generators behind prt_mesh_generate (gen.c checks arguments and
 * dispatches by kind; one file per kind). Each trusts its arguments: triangles >= 1. */
#ifndef PRT_MESH_GEN_H
#define PRT_MESH_GEN_H

#include "core/common.h"
#include "mesh/tri_stream.h"

/* Above this the triangles' 32-bit ids (prt_hit.prim) and the machine's memory run out
 * long before any generator's own limit; a request this large is a typo. */
#define GEN_MAX_TRIANGLES ((size_t)1 << 31)

prt_status gen_sphere(size_t triangles, uint64_t seed, prt_mesh **out);
prt_status gen_terrain(size_t triangles, uint64_t seed, prt_mesh **out);
prt_status gen_mandelbulb(size_t triangles, uint64_t seed, prt_mesh **out);
prt_status gen_cad(size_t triangles, uint64_t seed, prt_mesh **out);
prt_status gen_level(size_t triangles, uint64_t seed, prt_mesh **out);

/* The Mandelbulb without building a mesh (gen_mandelbulb.c), for meshes larger than memory.
 * Both check triangles (1 to GEN_MAX_TRIANGLES: PRT_ERROR_ARGUMENT, PRT_ERROR_LIMIT).
 * Stream: the triangles gen_mandelbulb gives for the same request (bit-identical positions,
 * in the extraction's order rather than the mesh's, the same for any thread count), handed
 * to sink in batches as the surface is extracted; memory_budget bounds the triangles in
 * flight (isosurface.h: gen_isosurface_stream). *triangle_count (may be NULL): the total.
 * Requests up to 16M are first counted once at the calibrated grid, as gen_mandelbulb
 * checks them; larger ones cost one extraction plus the calibration. */
prt_status gen_mandelbulb_stream(size_t triangles, uint64_t seed, size_t memory_budget, tri_sink_fn sink, void *user,
                                 uint64_t *triangle_count);

/* Write the mesh gen_mandelbulb gives (the same file as prt_mesh_save_ply would write of
 * it) to path as binary PLY, holding neither it nor its triangles: the extraction spills to
 * a temporary file beside path (isosurface.h: gen_isosurface_indexed). The file is removed
 * on failure. *triangle_count, *vertex_count (may be NULL): what was written. */
prt_status gen_mandelbulb_save_ply(size_t triangles, uint64_t seed, size_t memory_budget, const char *path,
                                   uint64_t *triangle_count, uint64_t *vertex_count);

prt_status gen_canyon(size_t triangles, uint64_t seed, prt_mesh **out);
prt_status gen_torus(size_t triangles, uint64_t seed, prt_mesh **out);

/* Animated kinds (gen_anim_*.c): the generator gives frame 0; the frame function writes
 * the vertices at time t in [0, 1] of that frame-0 mesh (same triangles, same seed). */
prt_status gen_twist(size_t triangles, uint64_t seed, prt_mesh **out);
void gen_twist_frame(const prt_mesh *base, float time, float *vertices);
prt_status gen_marbles(size_t triangles, uint64_t seed, prt_mesh **out);
void gen_marbles_frame(const prt_mesh *base, uint64_t seed, float time, float *vertices);
prt_status gen_toys(size_t triangles, uint64_t seed, prt_mesh **out);
void gen_toys_frame(const prt_mesh *base, uint64_t seed, float time, float *vertices);

/* Grid surfaces (gen_grid.c): the two triangles of each of nu x nv cells over vertices
 * laid out row by row (nu + 1 a row, or nu when wrap_u; likewise rows), split along the
 * shorter diagonal; and a grid size near a triangle count at a given nu / nv. */
void gen_grid_triangles(prt_mesh *m, size_t nu, size_t nv, bool wrap_u, bool wrap_v);
void gen_grid_size(size_t triangles, double aspect, size_t *nu, size_t *nv);

#endif
