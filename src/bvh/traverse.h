/* Pieces every BVH traversal kernel shares. */
#ifndef PRT_BVH_TRAVERSE_H
#define PRT_BVH_TRAVERSE_H

#include "bvh/bvh.h"
#include "bvh/codecs/codecs.h"
#include "bvh/layouts/kernel_names.h"
#include "geom/box.h"

#include <math.h>

/* Copy a kernel's hit record out; on a hit also shrink the ray (prt_intersect1's contract). */
static inline void bvh_finish_hit(prt_ray *ray, prt_hit *hit, const prt__hitx *h) {
    if (h->prim == PRT_INVALID) {
        *hit = prt__miss();
        return;
    }
    hit->t = h->t, hit->u = h->u, hit->v = h->v, hit->prim = h->prim, hit->geom = 0;
    ray->tfar = h->t;
}

#endif
