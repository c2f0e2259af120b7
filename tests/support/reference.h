/* Test oracle: brute-force closest and any hit in double precision over every triangle. */
#ifndef PRT_TESTS_REFERENCE_H
#define PRT_TESTS_REFERENCE_H

#include "packrt.h"

#include <stdbool.h>

/* Closest hit with t in [tnear, tfar]; also returns in *edge_dist the smallest barycentric
 * coordinate of the hit (how far from an edge it is, 0..1/3) so tests can skip ambiguous
 * rays that graze edges. Misses: prim = PRT_INVALID, t = +inf. */
prt_hit ref_intersect(const prt_mesh *m, const prt_ray *r, double *edge_dist);

/* Any hit with t in [tnear, tfar], ignoring hits closer than edge_eps to an edge when
 * edge_eps > 0 (returns -1 when only such ambiguous hits exist). */
int ref_occluded(const prt_mesh *m, const prt_ray *r, double edge_eps);

/* Whether triangle prim is hit by r (any t), and where: for telling a tie between
 * coplanar overlapping triangles (both answers right) from a wrong primitive. */
bool ref_hits_triangle(const prt_mesh *m, const prt_ray *r, uint32_t prim, double *t);

/* Path of a file in ../shared/data, or NULL (and a message) when the folder is absent. */
const char *ref_shared_path(const char *name);

/* bench_lossy_acceptable (bench/check.c): the one definition of a lossy representation's
 * right answer, shared by the tests and `packrt bench`. */
bool ref_lossy_acceptable(const prt_mesh *m, const prt_ray *r, const prt_hit *got, const prt_hit *want, double err,
                          double tol);

/* Bounds diagonal of a mesh. */
double ref_diagonal(const prt_mesh *m);

#endif
