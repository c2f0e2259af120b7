/* The closest-hit rule every SIMD codec applies to a block of lanes. */
#ifndef PRT_BVH_CODECS_NEAREST_H
#define PRT_BVH_CODECS_NEAREST_H

#include "bvh/codecs/codec.h"
#include "core/simd.h"
#include "geom/ray.h"

/* Closest-hit update for a SIMD block: among the lanes in mask (all with t <= h->t), the
 * nearest, and at equal t the smallest triangle id, as in the scalar codecs; ids[lane]
 * are the lanes' triangle ids. Exact ties are rare, so the common path is one hmin. */
static inline void bvh_take_nearest(prt__hitx *h, const float *t, const float *u, const float *v, const uint32_t *ids,
                                    unsigned mask, float best) {
    uint32_t prim = PRT_INVALID;
    int lane = -1;
    for (unsigned m = mask; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        /* lane < 0: take the first tie even if its id is PRT_INVALID (a crafted file). */
        if (t[i] == best && (lane < 0 || ids[i] < prim)) prim = ids[i], lane = i;
    }
    if (lane < 0) return; /* cannot happen: best is the t of a lane in mask */
    if (best < h->t || prim < h->prim) h->t = t[lane], h->u = u[lane], h->v = v[lane], h->prim = prim;
}

/* The id that decides a tie at equal t for a seq_ids codec: the mesh id of leaf-order
 * triangle `id` (ids=none: the leaf-order id itself). Only evaluated on exact ties. */
static inline uint32_t bvh_tie_id(const bvh_shared *sh, uint32_t id) {
    if (id >= sh->triangles) return id;
    return sh->mesh_ids ? sh->mesh_ids[id] : sh->map_id ? sh->map_id(sh->map, id) : id;
}

/* bvh_take_nearest for seq_ids codecs: ids[lane] are leaf-order ids, and a tie at equal t
 * goes to the smaller mesh id (bvh_tie_id), as in every other codec. */
static inline void bvh_take_nearest_seq(prt__hitx *h, const float *t, const float *u, const float *v,
                                        const uint32_t *ids, unsigned mask, float best, const bvh_shared *sh) {
    int lane = -1;
    for (unsigned m = mask; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        if (t[i] == best && (lane < 0 || bvh_tie_id(sh, ids[i]) < bvh_tie_id(sh, ids[lane]))) lane = i;
    }
    if (lane < 0) return; /* cannot happen: best is the t of a lane in mask */
    if (best < h->t || h->prim == PRT_INVALID || bvh_tie_id(sh, ids[lane]) < bvh_tie_id(sh, h->prim)) {
        h->t = t[lane], h->u = u[lane], h->v = v[lane], h->prim = ids[lane];
        /* The hit is named through the map once the walk ends (bvh_accel.c): start
         * fetching its entry now, a cache miss on every random ray otherwise. */
        if (sh->mesh_ids && ids[lane] < sh->triangles) __builtin_prefetch(sh->mesh_ids + ids[lane]);
    }
}

/* A 4-lane block of a seq_ids codec whose lanes are leaf-order ids first .. first + 3: the
 * hit lanes in mask (t, u, v from the 4-wide triangle test) update h. */
static inline void bvh_take_block4_seq(prt__hitx *h, vf4 t, vf4 u, vf4 v, int mask, uint32_t first,
                                       const bvh_shared *sh) {
    const uint32_t ids[4] = {first, first + 1, first + 2, first + 3};
    /* The lanes read in place (a vector's elements may be read as floats): copies into
     * arrays cost the compiler dozens of moves per hit block. */
    bvh_take_nearest_seq(h, (const float *)&t, (const float *)&u, (const float *)&v, ids, (unsigned)mask, vf4_hmin(t),
                         sh);
}

/* The same for an 8-lane block: two consecutive 4-lane blocks, ids first .. first + 7. */
static inline void bvh_take_block8_seq(prt__hitx *h, vf8 t, vf8 u, vf8 v, int mask, uint32_t first,
                                       const bvh_shared *sh) {
    const uint32_t ids[8] = {first, first + 1, first + 2, first + 3, first + 4, first + 5, first + 6, first + 7};
    bvh_take_nearest_seq(h, (const float *)&t, (const float *)&u, (const float *)&v, ids, (unsigned)mask, vf8_hmin(t),
                         sh);
}

#endif
