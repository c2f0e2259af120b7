/* Indexed16 (Rouwé 2019, §3.6): idx32's shared vertex buffer (3 floats per mesh vertex plus
 * one NaN vertex) and per triangle three 16-bit vertex indices, tested one triangle at a
 * time with the scalar watertight kernel; a u32 leaf-order id of the leaf's first triangle
 * heads the leaf (seq_ids, as idx16-soa4: 6 B/tri instead of 10). Triangles are stored in
 * pairs (12 bytes, block 2) so that leaf sizes stay multiples of 4 bytes, which the layouts
 * need; a leaf of odd count ends with a padding triangle on the NaN vertex, never hit.
 * Meshes of more than 65535 vertices do not fit (PRT_ERROR_LIMIT). Lossless. */
#ifndef PRT_BVH_CODECS_IDX16_H
#define PRT_BVH_CODECS_IDX16_H

#include "bvh/codecs/codec.h"
#include "bvh/codecs/decode.h"
#include "bvh/codecs/idx16_soa4.h"
#include "bvh/codecs/nearest.h"
#include "geom/triangle.h"

#define IDX16_TRI_BYTES 6
enum { idx16_block = 2, idx16_align = 4, idx16_seq_ids = 1 };

typedef struct idx16_ray {
    const float *vertices;
    const bvh_shared *sh;
} idx16_ray;

static inline size_t idx16_leaf_bytes(uint32_t n) {
    return IDX16_HEAD_BYTES + (size_t)((n + 1) / 2) * 2 * IDX16_TRI_BYTES;
}

static inline void idx16_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    const uint16_t pad = (uint16_t)m->vertex_count; /* the NaN vertex */
    memcpy(dst, &ids[0], 4);
    dst += IDX16_HEAD_BYTES;
    for (uint32_t i = 0; i < (n + 1) / 2 * 2; i++, dst += IDX16_TRI_BYTES) {
        uint16_t idx[3];
        for (int v = 0; v < 3; v++) idx[v] = i < n ? (uint16_t)m->triangles[3 * (size_t)ids[i] + (size_t)v] : pad;
        memcpy(dst, idx, sizeof idx);
    }
}

static inline prt_status idx16_shared_build(const prt_mesh *m, uint8_t **data, size_t *size) {
    return idx16_buffer_build(m, data, size, "idx16");
}

static inline bool idx16_leaf_valid(const uint8_t *leaf, uint32_t n, const bvh_shared *sh) {
    const size_t vertices = sh->size / (3 * sizeof(float));
    uint32_t id0;
    memcpy(&id0, leaf, 4);
    if (id0 >= sh->triangles) return false;
    leaf += IDX16_HEAD_BYTES;
    for (uint32_t i = 0; i < 3 * ((n + 1) / 2 * 2); i++) {
        uint16_t idx;
        memcpy(&idx, leaf + 2 * (size_t)i, 2);
        if (idx >= vertices) return false;
    }
    return true;
}

static inline void idx16_ray_init(idx16_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    (void)r;
    c->vertices = (const float *)sh->data;
    c->sh = sh;
}

PRT_INLINE void idx16_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const idx16_ray *c, prt__hitx *h) {
    uint32_t id0;
    memcpy(&id0, leaf, 4);
    leaf += IDX16_HEAD_BYTES;
    for (uint32_t i = 0; i < n; i++, leaf += IDX16_TRI_BYTES) {
        uint16_t idx[3];
        memcpy(idx, leaf, sizeof idx);
        float t, u, w;
        /* At equal t the smaller mesh id wins, as in every codec (bvh_tie_id). */
        if (prt__tri_hit(r, c->vertices + 3 * (size_t)idx[0], c->vertices + 3 * (size_t)idx[1],
                         c->vertices + 3 * (size_t)idx[2], h->t, &t, &u, &w) &&
            (t < h->t || bvh_tie_id(c->sh, id0 + i) < bvh_tie_id(c->sh, h->prim)))
            h->t = t, h->u = u, h->v = w, h->prim = id0 + i;
    }
}

PRT_INLINE bool idx16_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const idx16_ray *c, float tfar) {
    leaf += IDX16_HEAD_BYTES;
    for (uint32_t i = 0; i < n; i++, leaf += IDX16_TRI_BYTES) {
        uint16_t idx[3];
        memcpy(idx, leaf, sizeof idx);
        float t, u, w;
        if (prt__tri_hit(r, c->vertices + 3 * (size_t)idx[0], c->vertices + 3 * (size_t)idx[1],
                         c->vertices + 3 * (size_t)idx[2], tfar, &t, &u, &w))
            return true;
    }
    return false;
}

/* The triangles' vertices from the shared buffer, with their leaf-order ids; the padding
 * triangle (on the NaN vertex) skipped (bvh_codec.decode). */
static inline uint32_t idx16_decode(const uint8_t *leaf, uint32_t n, const bvh_shared *sh, float *v, uint32_t *ids) {
    const float *vertices = (const float *)sh->data;
    uint32_t id0, k = 0;
    memcpy(&id0, leaf, 4);
    leaf += IDX16_HEAD_BYTES;
    for (uint32_t i = 0; i < n; i++, leaf += IDX16_TRI_BYTES) {
        uint16_t idx[3];
        memcpy(idx, leaf, sizeof idx);
        float p[9];
        for (int c = 0; c < 3; c++) memcpy(p + 3 * c, vertices + 3 * (size_t)idx[c], 12);
        k = bvh_decode_soa(p, 1, 1, id0 + i, v, ids, k);
    }
    return k;
}

#define idx16_shared_remap NULL
#define idx16_vertex_error NULL

#define idx16_leaf_error NULL

#endif
