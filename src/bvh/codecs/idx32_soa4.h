/* Indexed32SOA4 (Rouwé 2019, §3.7): one shared vertex buffer (3 floats per vertex) and, per
 * block of four triangles, their 32-bit vertex indices in SOA order (vertex 0 of the four,
 * then vertex 1, then vertex 2) followed by the four 32-bit triangle ids: 64 bytes per four
 * triangles plus 12 bytes per mesh vertex. The block's vertices are gathered into SOA form
 * and tested with the same watertight kernel as Float3SOA4, so hits are bit-identical.
 * Padding lanes index an extra NaN vertex at the end of the buffer, which never hits. */
#ifndef PRT_BVH_CODECS_IDX32_SOA4_H
#define PRT_BVH_CODECS_IDX32_SOA4_H

#include "bvh/codecs/codec.h"
#include "bvh/codecs/decode.h"
#include "bvh/codecs/nearest.h"
#include "geom/triangle.h"

#include <math.h>

#define IDX32_SOA4_BLOCK_BYTES 64
enum { idx32_soa4_block = 4, idx32_soa4_align = 16, idx32_soa4_seq_ids = 0 };

typedef struct idx32_soa4_ray {
    prt__rayx4t r4;
    const float *vertices;
} idx32_soa4_ray;

static inline size_t idx32_soa4_leaf_bytes(uint32_t n) { return (size_t)((n + 3) / 4) * IDX32_SOA4_BLOCK_BYTES; }

/* Vertex count of the shared buffer, NaN padding vertex included. */
static inline size_t idx32_soa4_vertex_count(const prt_mesh *m) { return m->vertex_count + 1; }

static inline void idx32_soa4_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    const uint32_t pad = (uint32_t)m->vertex_count; /* the NaN vertex */
    for (uint32_t b = 0; b < (n + 3) / 4; b++, dst += IDX32_SOA4_BLOCK_BYTES) {
        uint32_t idx[3][4], id[4];
        for (uint32_t l = 0; l < 4; l++) {
            uint32_t i = 4 * b + l;
            for (int v = 0; v < 3; v++) idx[v][l] = i < n ? m->triangles[3 * (size_t)ids[i] + (size_t)v] : pad;
            id[l] = i < n ? ids[i] : PRT_INVALID;
        }
        memcpy(dst, idx, sizeof idx);
        memcpy(dst + sizeof idx, id, sizeof id);
    }
}

static inline prt_status idx32_soa4_shared_build(const prt_mesh *m, uint8_t **data, size_t *size) {
    size_t bytes = prt__mul_size(idx32_soa4_vertex_count(m), 3 * sizeof(float));
    float *v = bytes ? prt__alloc(bytes) : NULL;
    if (!v) return prt__fail(PRT_ERROR_NOMEM, "out of memory for a %zu-byte vertex buffer", bytes);
    memcpy(v, m->vertices, m->vertex_count * 3 * sizeof(float));
    v[3 * m->vertex_count] = v[3 * m->vertex_count + 1] = v[3 * m->vertex_count + 2] = NAN;
    *data = (uint8_t *)v;
    *size = bytes;
    return PRT_OK;
}

/* Every index must name a vertex of the shared buffer. */
static inline bool idx32_soa4_leaf_valid(const uint8_t *leaf, uint32_t n, const bvh_shared *sh) {
    size_t vertices = sh->size / (3 * sizeof(float));
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += IDX32_SOA4_BLOCK_BYTES) {
        uint32_t idx[12];
        memcpy(idx, leaf, sizeof idx);
        for (int i = 0; i < 12; i++)
            if (idx[i] >= vertices) return false;
    }
    return true;
}

static inline void idx32_soa4_ray_init(idx32_soa4_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    prt__rayx4t_init(&c->r4, r);
    c->vertices = (const float *)sh->data;
}

/* Gather a block's 12 vertices into the SOA form the SIMD kernel reads. */
PRT_INLINE void idx32_soa4_gather(const uint8_t *block, const float *vertices, float p[36]) {
    uint32_t idx[12];
    memcpy(idx, block, sizeof idx);
    for (int v = 0; v < 3; v++)
        for (int l = 0; l < 4; l++) {
            const float *q = vertices + 3 * (size_t)idx[4 * v + l];
            p[4 * (3 * v + 0) + l] = q[0];
            p[4 * (3 * v + 1) + l] = q[1];
            p[4 * (3 * v + 2) + l] = q[2];
        }
}

PRT_INLINE void idx32_soa4_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const idx32_soa4_ray *c,
                                     prt__hitx *h) {
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += IDX32_SOA4_BLOCK_BYTES) {
        float p[36];
        idx32_soa4_gather(leaf, c->vertices, p);
        vf4 t, u, v;
        int mask = prt__tri4_hit(r, &c->r4, p, vf4_set1(h->t), &t, &u, &v);
        if (!mask) continue;
        uint32_t ids[4];
        memcpy(ids, leaf + 48, sizeof ids);
        float tt[4], uu[4], vv[4];
        memcpy(tt, &t, sizeof tt), memcpy(uu, &u, sizeof uu), memcpy(vv, &v, sizeof vv);
        bvh_take_nearest(h, tt, uu, vv, ids, (unsigned)mask, vf4_hmin(t));
    }
}

PRT_INLINE bool idx32_soa4_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const idx32_soa4_ray *c,
                                    float tfar) {
    const vf4 tf = vf4_set1(tfar);
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += IDX32_SOA4_BLOCK_BYTES) {
        float p[36];
        idx32_soa4_gather(leaf, c->vertices, p);
        vf4 t, u, v;
        if (prt__tri4_hit(r, &c->r4, p, tf, &t, &u, &v)) return true;
    }
    return false;
}

/* The blocks as the kernel gathers them, with their mesh ids; padding lanes (the NaN
 * vertex) skipped (bvh_codec.decode). */
static inline uint32_t idx32_soa4_decode(const uint8_t *leaf, uint32_t n, const bvh_shared *sh, float *v,
                                         uint32_t *ids) {
    uint32_t k = 0;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += IDX32_SOA4_BLOCK_BYTES) {
        float p[36];
        idx32_soa4_gather(leaf, (const float *)sh->data, p);
        uint32_t id[4];
        memcpy(id, leaf + 48, sizeof id);
        k = bvh_decode_soa_ids(p, 4, id, v, ids, k);
    }
    return k;
}

#define idx32_soa4_shared_remap NULL
#define idx32_soa4_vertex_error NULL

#define idx32_soa4_leaf_error NULL

#endif
