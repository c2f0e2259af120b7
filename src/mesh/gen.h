/* The procedural generators behind prt_mesh_generate (gen.c checks arguments and
 * dispatches by kind; one file per kind). Each trusts its arguments: triangles >= 1. */
#ifndef PRT_MESH_GEN_H
#define PRT_MESH_GEN_H

#include "core/common.h"

prt_status gen_sphere(size_t triangles, uint64_t seed, prt_mesh **out);
prt_status gen_terrain(size_t triangles, uint64_t seed, prt_mesh **out);
prt_status gen_mandelbulb(size_t triangles, uint64_t seed, prt_mesh **out);
prt_status gen_cad(size_t triangles, uint64_t seed, prt_mesh **out);
prt_status gen_level(size_t triangles, uint64_t seed, prt_mesh **out);

prt_status gen_canyon(size_t triangles, uint64_t seed, prt_mesh **out);
prt_status gen_torus(size_t triangles, uint64_t seed, prt_mesh **out);

/* Animated kinds (gen_anim_*.c): the generator gives frame 0; the frame function writes
 * the vertices at time t in [0, 1] of that frame-0 mesh (same triangles, same seed). */
prt_status gen_twist(size_t triangles, uint64_t seed, prt_mesh **out);
void gen_twist_frame(const prt_mesh *base, float time, float *vertices);
prt_status gen_marbles(size_t triangles, uint64_t seed, prt_mesh **out);
void gen_marbles_frame(const prt_mesh *base, uint64_t seed, float time, float *vertices);

/* Grid surfaces (gen_grid.c): the two triangles of each of nu x nv cells over vertices
 * laid out row by row (nu + 1 a row, or nu when wrap_u; likewise rows), split along the
 * shorter diagonal; and a grid size near a triangle count at a given nu / nv. */
void gen_grid_triangles(prt_mesh *m, size_t nu, size_t nv, bool wrap_u, bool wrap_v);
void gen_grid_size(size_t triangles, double aspect, size_t *nu, size_t *nv);

#endif
