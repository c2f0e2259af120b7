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

#endif
