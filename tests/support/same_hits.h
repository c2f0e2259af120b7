/* Whether two meshes (the same triangles read from two file formats) answer rays alike. */
#ifndef PRT_TESTS_SAME_HITS_H
#define PRT_TESTS_SAME_HITS_H

#include "packrt.h"

/* Build `spec` over both meshes, cast n random rays (rays_random over a, seeded) through
 * prt_intersect1 and return how many hits differ in t, u, v or prim (bitwise); SIZE_MAX when
 * a build fails. */
size_t hits_differing(const prt_mesh *a, const prt_mesh *b, const char *spec, size_t n);

#endif
