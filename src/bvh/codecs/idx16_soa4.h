/* Indexed16SOA4 (Rouwé 2019, §3.7): idx32-soa4's shared vertex buffer (3 floats per mesh
 * vertex plus one NaN vertex) and, per block of four triangles, their 16-bit vertex indices
 * in SOA order (vertex 0 of the four, vertex 1, vertex 2): 24 bytes per block, after a u32
 * leaf-order id of the leaf's first triangle (seq_ids: lane l of block b is id + 4b + l).
 * Meshes of more than 65535 vertices do not fit (PRT_ERROR_LIMIT). Lossless: the gathered
 * floats are the mesh's and the kernel is float3-soa4's, so hits are bit-identical.
 *
 * One id per leaf rather than one per triangle (idx32-soa4's choice): 6 B/tri of leaf
 * instead of 10, and per triangle the 4-byte IDS entry is read only when a ray's final hit
 * is mapped back (or never, with ids=none). Bunny, wide8: 19.4 B/tri in all against
 * idx32-soa4's 25.2 at the same warm ray time within noise (docs/design-changes.md); a
 * per-triangle-id variant of this codec was not measured. */
#ifndef PRT_BVH_CODECS_IDX16_SOA4_H
#define PRT_BVH_CODECS_IDX16_SOA4_H

#include "bvh/codecs/codec.h"
#include "bvh/codecs/decode.h"
#include "bvh/codecs/idx32_soa4.h"
#include "bvh/codecs/nearest.h"
#include "geom/triangle.h"

#define IDX16_HEAD_BYTES 4
#define IDX16_SOA4_BLOCK_BYTES 24
/* Vertices a 16-bit index reaches, the NaN padding vertex included. */
#define IDX16_MAX_VERTICES 65536u
enum { idx16_soa4_block = 4, idx16_soa4_align = 4, idx16_soa4_seq_ids = 1 };

typedef struct idx16_soa4_ray {
    prt__rayx4t r4;
    const float *vertices;
    const bvh_shared *sh;
} idx16_soa4_ray;

static inline size_t idx16_soa4_leaf_bytes(uint32_t n) {
    return IDX16_HEAD_BYTES + (size_t)((n + 3) / 4) * IDX16_SOA4_BLOCK_BYTES;
}

/* ids are consecutive (seq_ids); padding lanes index the NaN vertex. */
static inline void idx16_soa4_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    const uint16_t pad = (uint16_t)m->vertex_count; /* the NaN vertex; shared_build checked the range */
    memcpy(dst, &ids[0], 4);
    dst += IDX16_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, dst += IDX16_SOA4_BLOCK_BYTES) {
        uint16_t idx[3][4];
        for (uint32_t l = 0; l < 4; l++) {
            uint32_t i = 4 * b + l;
            for (int v = 0; v < 3; v++)
                idx[v][l] = i < n ? (uint16_t)m->triangles[3 * (size_t)ids[i] + (size_t)v] : pad;
        }
        memcpy(dst, idx, sizeof idx);
    }
}

/* idx32-soa4's buffer, when 16-bit indices reach all of it. */
static inline prt_status idx16_buffer_build(const prt_mesh *m, uint8_t **data, size_t *size, const char *codec) {
    if (idx32_soa4_vertex_count(m) > IDX16_MAX_VERTICES)
        return prt__fail(PRT_ERROR_LIMIT,
                         "%s: %zu vertices do not fit 16-bit indices (at most %u, one kept for padding)", codec,
                         m->vertex_count, IDX16_MAX_VERTICES - 1);
    return idx32_soa4_shared_build(m, data, size);
}

static inline prt_status idx16_soa4_shared_build(const prt_mesh *m, uint8_t **data, size_t *size) {
    return idx16_buffer_build(m, data, size, "idx16-soa4");
}

/* The first id lies in the tree (ids of padding lanes may pass the end: never hit) and
 * every index names a vertex of the shared buffer. */
static inline bool idx16_soa4_leaf_valid(const uint8_t *leaf, uint32_t n, const bvh_shared *sh) {
    const size_t vertices = sh->size / (3 * sizeof(float));
    uint32_t id0;
    memcpy(&id0, leaf, 4);
    if (id0 >= sh->triangles) return false;
    leaf += IDX16_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += IDX16_SOA4_BLOCK_BYTES) {
        uint16_t idx[12];
        memcpy(idx, leaf, sizeof idx);
        for (int i = 0; i < 12; i++)
            if (idx[i] >= vertices) return false;
    }
    return true;
}

static inline void idx16_soa4_ray_init(idx16_soa4_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    prt__rayx4t_init(&c->r4, r);
    c->vertices = (const float *)sh->data;
    c->sh = sh;
}

/* Gather a block's 12 vertices into the SOA form the SIMD kernel reads. */
PRT_INLINE void idx16_soa4_gather(const uint8_t *block, const float *vertices, float p[36]) {
    uint16_t idx[12];
    memcpy(idx, block, sizeof idx);
    for (int v = 0; v < 3; v++)
        for (int l = 0; l < 4; l++) {
            const float *q = vertices + 3 * (size_t)idx[4 * v + l];
            p[4 * (3 * v + 0) + l] = q[0];
            p[4 * (3 * v + 1) + l] = q[1];
            p[4 * (3 * v + 2) + l] = q[2];
        }
}

PRT_INLINE void idx16_soa4_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const idx16_soa4_ray *c,
                                     prt__hitx *h) {
    uint32_t id0;
    memcpy(&id0, leaf, 4);
    leaf += IDX16_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += IDX16_SOA4_BLOCK_BYTES) {
        float p[36];
        idx16_soa4_gather(leaf, c->vertices, p);
        vf4 t, u, v;
        int mask = prt__tri4_hit(r, &c->r4, p, vf4_set1(h->t), &t, &u, &v);
        if (!mask) continue;
        bvh_take_block4_seq(h, t, u, v, mask, id0 + 4 * b, c->sh);
    }
}

PRT_INLINE bool idx16_soa4_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const idx16_soa4_ray *c,
                                    float tfar) {
    const vf4 tf = vf4_set1(tfar);
    leaf += IDX16_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += IDX16_SOA4_BLOCK_BYTES) {
        float p[36];
        idx16_soa4_gather(leaf, c->vertices, p);
        vf4 t, u, v;
        if (prt__tri4_hit(r, &c->r4, p, tf, &t, &u, &v)) return true;
    }
    return false;
}

/* The blocks as the kernel gathers them, with their leaf-order ids; padding lanes (the NaN
 * vertex) skipped (bvh_codec.decode). */
static inline uint32_t idx16_soa4_decode(const uint8_t *leaf, uint32_t n, const bvh_shared *sh, float *v,
                                         uint32_t *ids) {
    uint32_t id0, k = 0;
    memcpy(&id0, leaf, 4);
    leaf += IDX16_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += IDX16_SOA4_BLOCK_BYTES) {
        float p[36];
        idx16_soa4_gather(leaf, (const float *)sh->data, p);
        k = bvh_decode_soa(p, 4, 4, id0 + 4 * b, v, ids, k);
    }
    return k;
}

#define idx16_soa4_shared_remap NULL
#define idx16_soa4_vertex_error NULL

#define idx16_soa4_leaf_error NULL

#endif
