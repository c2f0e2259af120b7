/* Small meshes made inside tests, independent of the generators under test elsewhere. */
#ifndef PRT_TESTS_MESHES_H
#define PRT_TESTS_MESHES_H

#include "packrt.h"

/* n random triangles of random size inside the unit cube (seeded). */
prt_mesh *mesh_random_soup(size_t n, uint64_t seed);

/* n triangles that all share one centroid (worst case for splitters). */
prt_mesh *mesh_same_centroid(size_t n);

/* An n x n grid of quads in the xz plane (a gentle wave in y), two triangles each, vertices
 * shared: a connected mesh of half a vertex per triangle. */
prt_mesh *mesh_grid(uint32_t n);

/* The closed surface of the cube [0, n]^3, each face cut into n x n unit squares of two
 * triangles, wound outward, vertices at integer positions shared between faces (unused
 * duplicates stay in the vertex array): rays with integer origins and directions pass
 * exactly through its edges and vertices. */
prt_mesh *mesh_grid_cube(uint32_t n);

/* A copy of m with every vertex scaled then moved: v * scale + offset. */
prt_mesh *mesh_transformed(const prt_mesh *m, float scale, float offset);

/* m with every triangle given its own three vertices: nothing shared by index. */
prt_mesh *mesh_unwelded(const prt_mesh *m);

/* Random rays: origins on a sphere around the mesh, aimed inside it (Rouwé's workload). */
prt_ray *rays_random(const prt_mesh *m, size_t n, uint64_t seed);

#endif
