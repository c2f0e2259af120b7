/* The binary tree collapsed into 4-wide nodes (Rouwé 2019, §5.6: every other level
 * removed, the largest child opened first), shared by the QuadTree layouts (quad.c,
 * quad_half.c). */
#ifndef PRT_BVH_LAYOUTS_QUAD_PLAN_H
#define PRT_BVH_LAYOUTS_QUAD_PLAN_H

#include "bvh/tree.h"

typedef struct quad_plan {
    uint32_t bin[4];  /* binary node of each child */
    uint32_t quad[4]; /* quad node index of inner children */
    int count;
} quad_plan;

/* Numbers the quad nodes of t depth first (parents before children) into p, which has
 * room for t->node_count entries; returns how many there are. */
uint32_t bvh_quad_plan(const bvh_tree *t, quad_plan *p);

#endif
