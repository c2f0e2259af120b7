/* Indexed32 (Rouwé 2019, §3.6): the classic indexed triangle list. One shared vertex buffer
 * (3 floats per vertex, the same as idx32-soa4's) and per triangle its three 32-bit vertex
 * indices and its 32-bit triangle id: 16 bytes per triangle plus 12 per vertex, tested one
 * triangle at a time with the scalar watertight kernel. */
#ifndef PRT_BVH_CODECS_IDX32_H
#define PRT_BVH_CODECS_IDX32_H

#include "bvh/codecs/codec.h"
#include "bvh/codecs/decode.h"
#include "bvh/codecs/idx32_soa4.h"
#include "geom/triangle.h"

#define IDX32_TRI_BYTES 16
enum { idx32_block = 1, idx32_align = 4, idx32_seq_ids = 0 };

typedef struct idx32_ray {
    const float *vertices;
} idx32_ray;

static inline size_t idx32_leaf_bytes(uint32_t n) { return (size_t)n * IDX32_TRI_BYTES; }

static inline void idx32_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    for (uint32_t i = 0; i < n; i++, dst += IDX32_TRI_BYTES) {
        memcpy(dst, m->triangles + 3 * (size_t)ids[i], 12);
        memcpy(dst + 12, &ids[i], 4);
    }
}

/* The vertex buffer is idx32-soa4's (mesh vertices plus one NaN vertex). */
#define idx32_shared_build idx32_soa4_shared_build

static inline bool idx32_leaf_valid(const uint8_t *leaf, uint32_t n, const bvh_shared *sh) {
    size_t vertices = sh->size / (3 * sizeof(float));
    for (uint32_t i = 0; i < n; i++, leaf += IDX32_TRI_BYTES) {
        uint32_t idx[3];
        memcpy(idx, leaf, sizeof idx);
        if (idx[0] >= vertices || idx[1] >= vertices || idx[2] >= vertices) return false;
    }
    return true;
}

static inline void idx32_ray_init(idx32_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    (void)r;
    c->vertices = (const float *)sh->data;
}

PRT_INLINE void idx32_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const idx32_ray *c, prt__hitx *h) {
    for (uint32_t i = 0; i < n; i++, leaf += IDX32_TRI_BYTES) {
        uint32_t idx[4];
        memcpy(idx, leaf, sizeof idx);
        float t, u, w;
        /* At equal t the smaller triangle id wins, as in every codec. */
        if (prt__tri_hit(r, c->vertices + 3 * (size_t)idx[0], c->vertices + 3 * (size_t)idx[1],
                         c->vertices + 3 * (size_t)idx[2], h->t, &t, &u, &w) &&
            (t < h->t || idx[3] < h->prim))
            h->t = t, h->u = u, h->v = w, h->prim = idx[3];
    }
}

PRT_INLINE bool idx32_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const idx32_ray *c, float tfar) {
    for (uint32_t i = 0; i < n; i++, leaf += IDX32_TRI_BYTES) {
        uint32_t idx[3];
        memcpy(idx, leaf, sizeof idx);
        float t, u, w;
        if (prt__tri_hit(r, c->vertices + 3 * (size_t)idx[0], c->vertices + 3 * (size_t)idx[1],
                         c->vertices + 3 * (size_t)idx[2], tfar, &t, &u, &w))
            return true;
    }
    return false;
}

/* The triangles' vertices from the shared buffer, with their mesh ids (bvh_codec.decode). */
static inline uint32_t idx32_decode(const uint8_t *leaf, uint32_t n, const bvh_shared *sh, float *v, uint32_t *ids) {
    const float *vertices = (const float *)sh->data;
    for (uint32_t i = 0; i < n; i++, leaf += IDX32_TRI_BYTES) {
        uint32_t idx[4];
        memcpy(idx, leaf, sizeof idx);
        for (int c = 0; c < 3; c++) memcpy(v + 9 * (size_t)i + 3 * c, vertices + 3 * (size_t)idx[c], 12);
        ids[i] = idx[3];
    }
    return n;
}

#define idx32_shared_remap NULL
#define idx32_vertex_error NULL

#define idx32_leaf_error NULL

#endif
