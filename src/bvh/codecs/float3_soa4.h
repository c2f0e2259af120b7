/* Float3SOA4 (Rouwé 2019, §3.2): blocks of four triangles, vertex components in SOA
 * order (x of vertex 0 for the 4 triangles, then y, ...), then the four 32-bit triangle
 * ids: 160 bytes per block. Padding lanes hold NaN vertices (never hit) and id
 * PRT_INVALID. Tested four at a time with the watertight SIMD kernel. */
#ifndef PRT_BVH_CODECS_FLOAT3_SOA4_H
#define PRT_BVH_CODECS_FLOAT3_SOA4_H

#include "geom/triangle.h"

#include <math.h>

#define FLOAT3_SOA4_BLOCK_BYTES 160
enum { float3_soa4_block = 4, float3_soa4_align = 16 };

typedef prt__rayx4t float3_soa4_ray;

static inline size_t float3_soa4_leaf_bytes(uint32_t n) { return (size_t)((n + 3) / 4) * FLOAT3_SOA4_BLOCK_BYTES; }

static inline void float3_soa4_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    for (uint32_t b = 0; b < (n + 3) / 4; b++, dst += FLOAT3_SOA4_BLOCK_BYTES) {
        float v[9][4];
        uint32_t id[4];
        for (uint32_t l = 0; l < 4; l++) {
            uint32_t i = 4 * b + l;
            if (i < n) {
                const uint32_t *t = m->triangles + 3 * (size_t)ids[i];
                for (int c = 0; c < 9; c++) v[c][l] = m->vertices[3 * (size_t)t[c / 3] + (size_t)(c % 3)];
                id[l] = ids[i];
            } else {
                for (int c = 0; c < 9; c++) v[c][l] = NAN;
                id[l] = PRT_INVALID;
            }
        }
        memcpy(dst, v, sizeof v);
        memcpy(dst + sizeof v, id, sizeof id);
    }
}

static inline void float3_soa4_ray_init(float3_soa4_ray *c, const prt__rayx *r) { prt__rayx4t_init(c, r); }

PRT_INLINE void float3_soa4_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r,
                                      const float3_soa4_ray *c, prt__hitx *h) {
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += FLOAT3_SOA4_BLOCK_BYTES) {
        vf4 t, u, v;
        int mask = prt__tri4_hit(r, c, (const float *)leaf, vf4_set1(h->t), &t, &u, &v);
        if (!mask) continue;
        float best = vf4_hmin(t);
        int lane = __builtin_ctz((unsigned)vi4_mask(t == vf4_set1(best)) & (unsigned)mask);
        h->t = best, h->u = u[lane], h->v = v[lane];
        memcpy(&h->prim, leaf + 144 + 4 * lane, 4);
    }
}

PRT_INLINE bool float3_soa4_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r,
                                     const float3_soa4_ray *c, float tfar) {
    const vf4 tf = vf4_set1(tfar);
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += FLOAT3_SOA4_BLOCK_BYTES) {
        vf4 t, u, v;
        if (prt__tri4_hit(r, c, (const float *)leaf, tf, &t, &u, &v)) return true;
    }
    return false;
}

#endif
