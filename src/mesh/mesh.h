/* Internal mesh helpers shared by loaders, generators and builders. */
#ifndef PRT_MESH_MESH_H
#define PRT_MESH_MESH_H

#include "core/common.h"

/* True when triangle (a, b, c) has exactly zero area: such triangles are never hit. */
bool prt__triangle_degenerate(const float *a, const float *b, const float *c);
/* Same for triangle t of m, also true for repeated indices. */
bool prt__mesh_triangle_degenerate(const prt_mesh *m, size_t t);

/* PRT_ERROR_LIMIT, with the message every builder gives, when the box lo..hi spans less
 * than PRT_MIN_EXTENT (its diagonal). */
prt_status prt__check_extent(const float lo[3], const float hi[3]);

/* canon[v] = the first vertex at v's exact position (-0 equal to +0), a new array of
 * vertex_count entries (prt__free it). */
prt_status prt__mesh_weld(const prt_mesh *m, uint32_t **canon);

#endif
