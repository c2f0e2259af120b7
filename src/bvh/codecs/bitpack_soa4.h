/* BitPackSOA4 (Rouwé 2019, §3.5): blocks of four triangles with 16-bit vertex components
 * in SOA order (x of vertex 0 of the four, y, z, then vertex 1, vertex 2: 36 u16), then the
 * block's float scale xyz and offset xyz (24 bytes), a component decoded as
 * offset + q * scale with offset = the block's lower corner and scale the smallest power
 * of two with which its extent spans 65535 steps.
 * The leaf starts with a u32 leaf-order id of its first triangle (seq_ids) and its u32
 * triangle count (8 bytes, so that wide8's grain, the gcd of head and block, is 8 bytes and
 * a node's leaves fit its 255 grains): 8 + 96 bytes per block, no shared data. Padding
 * lanes hold 0xFFFF everywhere; a lane whose vertex 0
 * and vertex 1 are equal (padding, or a triangle quantized to zero area, which cannot be hit
 * either) is decoded as NaN. Lossy: the BVH family rounds the vertices to one lattice per
 * tree first (lattice.h), on which every block's grid is exact, so a vertex shared by two
 * blocks decodes to the same bits in both and the decoded mesh is as closed as the mesh.
 * The vertex error is measured at build time by decoding every leaf as encoded
 * (leaf_error) and kept in the META section. */
#ifndef PRT_BVH_CODECS_BITPACK_SOA4_H
#define PRT_BVH_CODECS_BITPACK_SOA4_H

#include "bvh/codecs/codec.h"
#include "bvh/codecs/decode.h"
#include "bvh/codecs/lattice.h"
#include "bvh/codecs/nearest.h"
#include "geom/triangle.h"

#include <math.h>

#define BSOA_HEAD_BYTES 8
#define BSOA_BLOCK_BYTES 96
#define BSOA_MASK 65535u
enum { bitpack_soa4_block = 4, bitpack_soa4_align = 4, bitpack_soa4_seq_ids = 1 };

typedef struct bitpack_soa4_ray {
    prt__rayx4t r4;
    const bvh_shared *sh;
} bitpack_soa4_ray;

static inline size_t bitpack_soa4_leaf_bytes(uint32_t n) {
    return BSOA_HEAD_BYTES + (size_t)((n + 3) / 4) * BSOA_BLOCK_BYTES;
}

/* One component as decoded: the same expression everywhere (kernel, error). */
static inline float bsoa_decode(float offset, float scale, uint32_t q) { return offset + (float)q * scale; }

/* ids are consecutive (seq_ids). */
static inline void bitpack_soa4_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    memcpy(dst, &ids[0], 4);
    memcpy(dst + 4, &n, 4);
    dst += BSOA_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, dst += BSOA_BLOCK_BYTES) {
        const uint32_t lanes = n - 4 * b < 4 ? n - 4 * b : 4;
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, scale[3];
        for (uint32_t l = 0; l < lanes; l++)
            for (int v = 0; v < 3; v++) {
                const float *p = m->vertices + 3 * (size_t)m->triangles[3 * (size_t)ids[4 * b + l] + (size_t)v];
                for (int k = 0; k < 3; k++) lo[k] = fminf(lo[k], p[k]), hi[k] = fmaxf(hi[k], p[k]);
            }
        for (int k = 0; k < 3; k++) scale[k] = bvh_lattice_step((double)hi[k] - lo[k], BSOA_MASK);
        uint16_t q[9][4];
        for (uint32_t l = 0; l < 4; l++)
            for (int c = 0; c < 9; c++) {
                if (l >= lanes) {
                    q[c][l] = 0xFFFF;
                    continue;
                }
                const int v = c / 3, k = c % 3;
                const float x =
                    m->vertices[3 * (size_t)m->triangles[3 * (size_t)ids[4 * b + l] + (size_t)v] + (size_t)k];
                const float r = scale[k] > 0 ? roundf((x - lo[k]) / scale[k]) : 0.0f;
                q[c][l] = (uint16_t)(r < 0 ? 0 : r > (float)BSOA_MASK ? BSOA_MASK : (uint32_t)r);
            }
        memcpy(dst, q, sizeof q);
        memcpy(dst + 72, scale, sizeof scale);
        memcpy(dst + 84, lo, sizeof lo);
    }
}

#define bitpack_soa4_shared_build NULL
#define bitpack_soa4_shared_remap NULL
#define bitpack_soa4_vertex_error NULL

/* The largest decoded-to-mesh vertex distance of the leaf's triangles (m: the mesh in
 * leaf order), padding lanes left out. */
static inline double bitpack_soa4_leaf_error(const uint8_t *leaf, uint32_t n, const prt_mesh *m) {
    uint32_t id0, count;
    memcpy(&id0, leaf, 4);
    memcpy(&count, leaf + 4, 4);
    (void)n;
    leaf += BSOA_HEAD_BYTES;
    double err2 = 0;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += BSOA_BLOCK_BYTES) {
        uint16_t q[9][4];
        float scale[3], offset[3];
        memcpy(q, leaf, sizeof q), memcpy(scale, leaf + 72, sizeof scale), memcpy(offset, leaf + 84, sizeof offset);
        for (uint32_t l = 0; l < 4; l++) {
            const size_t id = (size_t)id0 + 4 * b + l;
            if (4 * b + l >= count || id >= m->triangle_count) continue;
            for (int v = 0; v < 3; v++) {
                const float *p = m->vertices + 3 * (size_t)m->triangles[3 * id + (size_t)v];
                double d2 = 0;
                for (int k = 0; k < 3; k++) {
                    double d = (double)bsoa_decode(offset[k], scale[k], q[3 * v + k][l]) - (double)p[k];
                    d2 += d * d;
                }
                err2 = fmax(err2, d2);
            }
        }
    }
    return sqrt(err2);
}

/* The first id lies in the tree (ids of padding lanes may pass the end: never hit), the
 * count fits the block-padded size and every block's grid is finite; nothing else in a
 * leaf can reach outside it. */
static inline bool bitpack_soa4_leaf_valid(const uint8_t *leaf, uint32_t n, const bvh_shared *sh) {
    uint32_t id0, count;
    memcpy(&id0, leaf, 4);
    memcpy(&count, leaf + 4, 4);
    if (id0 >= sh->triangles || count > n || count + 4 <= n) return false;
    leaf += BSOA_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += BSOA_BLOCK_BYTES) {
        float g[6];
        memcpy(g, leaf + 72, sizeof g);
        for (int k = 0; k < 6; k++)
            if (!isfinite(g[k]) || (k < 3 && g[k] < 0)) return false;
    }
    return true;
}

static inline void bitpack_soa4_ray_init(bitpack_soa4_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    prt__rayx4t_init(&c->r4, r);
    c->sh = sh;
}

/* Decode a block into the SOA form the 4-wide kernel reads: four u16 widened to float,
 * times the scale plus the offset as bsoa_decode computes it (same bits). */
PRT_INLINE void bsoa_decode_block(const uint8_t *block, float p[36]) {
    uint64_t w[9];
    memcpy(w, block, sizeof w);
    float g[6];
    memcpy(g, block + 72, sizeof g);
    /* Lanes whose vertex 0 and vertex 1 are equal: padding or zero area, never hit. */
    const uint64_t d = (w[0] ^ w[3]) | (w[1] ^ w[4]) | (w[2] ^ w[5]);
    const vi4 pad = {-(int32_t)((d & 0xFFFF) == 0), -(int32_t)((d >> 16 & 0xFFFF) == 0),
                     -(int32_t)((d >> 32 & 0xFFFF) == 0), -(int32_t)((d >> 48) == 0)};
    const vf4 nan = vf4_set1(NAN);
    for (int c = 0; c < 9; c++) {
        const vi4 qi = {(int32_t)(w[c] & 0xFFFF), (int32_t)(w[c] >> 16 & 0xFFFF), (int32_t)(w[c] >> 32 & 0xFFFF),
                        (int32_t)(w[c] >> 48)};
        const vf4 x =
            vf4_select(pad, nan, vf4_set1(g[3 + c % 3]) + __builtin_convertvector(qi, vf4) * vf4_set1(g[c % 3]));
        memcpy(p + 4 * c, &x, sizeof x);
    }
}

PRT_INLINE void bitpack_soa4_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const bitpack_soa4_ray *c,
                                       prt__hitx *h) {
    uint32_t id0;
    memcpy(&id0, leaf, 4);
    leaf += BSOA_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += BSOA_BLOCK_BYTES) {
        float p[36];
        bsoa_decode_block(leaf, p);
        vf4 t, u, v;
        int mask = prt__tri4_hit(r, &c->r4, p, vf4_set1(h->t), &t, &u, &v);
        if (!mask) continue;
        bvh_take_block4_seq(h, t, u, v, mask, id0 + 4 * b, c->sh);
    }
}

PRT_INLINE bool bitpack_soa4_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const bitpack_soa4_ray *c,
                                      float tfar) {
    const vf4 tf = vf4_set1(tfar);
    leaf += BSOA_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += BSOA_BLOCK_BYTES) {
        float p[36];
        bsoa_decode_block(leaf, p);
        vf4 t, u, v;
        if (prt__tri4_hit(r, &c->r4, p, tf, &t, &u, &v)) return true;
    }
    return false;
}

/* The blocks as the kernel decodes them, with their leaf-order ids; padding lanes (and
 * lanes quantized to zero area, which never hit either) skipped (bvh_codec.decode). */
static inline uint32_t bitpack_soa4_decode(const uint8_t *leaf, uint32_t n, const bvh_shared *sh, float *v,
                                           uint32_t *ids) {
    (void)sh;
    uint32_t id0, k = 0;
    memcpy(&id0, leaf, 4);
    leaf += BSOA_HEAD_BYTES;
    for (uint32_t b = 0; b < (n + 3) / 4; b++, leaf += BSOA_BLOCK_BYTES) {
        float p[36];
        bsoa_decode_block(leaf, p);
        k = bvh_decode_soa(p, 4, 4, id0 + 4 * b, v, ids, k);
    }
    return k;
}

#endif
