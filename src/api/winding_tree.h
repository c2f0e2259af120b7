/* The fast generalized winding number (Barill, Dickson, Schmidt, Levin, Jacobson, "Fast
 * Winding Numbers for Soups and Clouds", SIGGRAPH 2018): a tree over the triangles, each
 * node keeping the first two terms of the far-field (dipole) expansion of its triangles'
 * solid angles; a node at least beta times its radius away answers by its expansion, a
 * nearer one by its children, a leaf by the exact sum (geom/closest.h). api/winding_tree.c. */
#ifndef PRT_API_WINDING_TREE_H
#define PRT_API_WINDING_TREE_H

#include "core/common.h"

typedef struct prt__wtree prt__wtree;

struct prt_accel;

/* The tree of the triangles a hands the queries' walk (a checked by prt__query_check),
 * built by the project's BVH builder (bvh/tree.h) on `threads` threads (0: all cores):
 * PRT_ERROR_NOMEM, else PRT_OK with *out to free with prt__wtree_free. */
prt_status prt__wtree_build(const struct prt_accel *a, int threads, prt__wtree **out);
void prt__wtree_free(prt__wtree *t);

/* The winding number at p (sum of solid angles over 4 pi) with accuracy beta (Barill et
 * al.: 2); beta <= 0 sums every triangle exactly. */
double prt__wtree_winding(const prt__wtree *t, const double p[3], double beta);

#endif
