/* The wide8 layout's own walk for point queries (wide8_point.c, its bvh_layout.point_walk):
 * eight child boxes' distances at once rather than the generic walk's one by one. */
#ifndef PRT_BVH_LAYOUTS_WIDE8_POINT_H
#define PRT_BVH_LAYOUTS_WIDE8_POINT_H

#include "bvh/bvh.h"

struct prt__query;

/* Answer point query q (api/query.h: PRT__QUERY_POINT) on w as bvh_walk would, handing
 * q->leaf the same triangles or fewer (only those whose box lies within the radius); false,
 * having done nothing, when w's codec is lossy (the generic walk widens lossy boxes). */
bool wide8_point_walk(const bvh_view *w, struct prt__query *q);

#endif
