/* Builder input made inside tests: one bvh_prim per triangle of a mesh (internal API). */
#ifndef PRT_TESTS_PRIMS_H
#define PRT_TESTS_PRIMS_H

#include "bvh/tree.h"

/* The box and id of every triangle of m (free()). */
bvh_prim *mesh_prims(const prt_mesh *m);

#endif
