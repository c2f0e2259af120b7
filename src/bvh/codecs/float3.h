/* Float3 (Rouwé 2019, §3.1): each triangle as its three vertices in 9 floats, followed by
 * the 32-bit index of the triangle in the mesh (40 bytes). The simplest codec: one
 * scalar watertight test per triangle. */
#ifndef PRT_BVH_CODECS_FLOAT3_H
#define PRT_BVH_CODECS_FLOAT3_H

#include "bvh/codecs/codec.h"
#include "bvh/codecs/decode.h"
#include "geom/triangle.h"

#define FLOAT3_TRI_BYTES 40
enum { float3_block = 1, float3_align = 4, float3_seq_ids = 0 };

typedef struct float3_ray {
    char unused;
} float3_ray;

static inline size_t float3_leaf_bytes(uint32_t n) { return (size_t)n * FLOAT3_TRI_BYTES; }

static inline void float3_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    for (uint32_t i = 0; i < n; i++, dst += FLOAT3_TRI_BYTES) {
        const uint32_t *t = m->triangles + 3 * (size_t)ids[i];
        for (int v = 0; v < 3; v++) memcpy(dst + 12 * v, m->vertices + 3 * (size_t)t[v], 12);
        memcpy(dst + 36, &ids[i], 4);
    }
}

static inline void float3_ray_init(float3_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    (void)c, (void)r, (void)sh;
}
#define float3_shared_build NULL
#define float3_leaf_valid NULL

PRT_INLINE void float3_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const float3_ray *c,
                                 prt__hitx *h) {
    (void)c;
    for (uint32_t i = 0; i < n; i++, leaf += FLOAT3_TRI_BYTES) {
        float v[9], t, u, w;
        memcpy(v, leaf, sizeof v);
        uint32_t id;
        memcpy(&id, leaf + 36, 4);
        /* At equal t the smaller triangle id wins, in every codec, whatever the visit order. */
        if (prt__tri_hit(r, v, v + 3, v + 6, h->t, &t, &u, &w) && (t < h->t || id < h->prim))
            h->t = t, h->u = u, h->v = w, h->prim = id;
    }
}

PRT_INLINE bool float3_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const float3_ray *c, float tfar) {
    (void)c;
    for (uint32_t i = 0; i < n; i++, leaf += FLOAT3_TRI_BYTES) {
        float v[9], t, u, w;
        memcpy(v, leaf, sizeof v);
        if (prt__tri_hit(r, v, v + 3, v + 6, tfar, &t, &u, &w)) return true;
    }
    return false;
}

/* The triangles as stored, with their mesh ids (bvh_codec.decode). */
static inline uint32_t float3_decode(const uint8_t *leaf, uint32_t n, const bvh_shared *sh, float *v, uint32_t *ids) {
    (void)sh;
    for (uint32_t i = 0; i < n; i++, leaf += FLOAT3_TRI_BYTES) {
        memcpy(v + 9 * (size_t)i, leaf, 36);
        memcpy(ids + i, leaf + 36, 4);
    }
    return n;
}

#define float3_shared_remap NULL
#define float3_vertex_error NULL

#define float3_leaf_error NULL

#endif
