/* BitPack (Rouwé 2019, §3.4): per triangle its three vertices as u64 BitPack words
 * (bitpack_vertices.h: 21 bits per component), tested one triangle at a time with the scalar
 * watertight kernel. The paper quantizes relative to the box of the tree node holding the
 * leaf; our layouts do not hand a node's box to the codec (and several store it quantized
 * or not at all), so the leaf stores its own: lo xyz, the lower corner of its triangles,
 * and step xyz, the smallest power of two with which their extent spans 2^21 - 1 steps.
 * Leaf: u32 leaf-order id of its first triangle (seq_ids), the 24-byte grid, then 24 bytes
 * per triangle. Lossy: the BVH family rounds the vertices to one lattice per tree first
 * (lattice.h), on which every leaf's grid is exact, so a vertex shared by two leaves
 * decodes to the same bits in both (no cracks); the vertex error is measured at build time
 * by decoding every leaf (leaf_error) and kept in META. */
#ifndef PRT_BVH_CODECS_BITPACK_H
#define PRT_BVH_CODECS_BITPACK_H

#include "bvh/codecs/bitpack_vertices.h"
#include "bvh/codecs/codec.h"
#include "bvh/codecs/lattice.h"
#include "bvh/codecs/nearest.h"
#include "geom/triangle.h"

#define BITPACK_HEAD_BYTES 28
#define BITPACK_TRI_BYTES 24
enum { bitpack_block = 1, bitpack_align = 4, bitpack_seq_ids = 1 };

typedef struct bitpack_ray {
    const bvh_shared *sh;
} bitpack_ray;

static inline size_t bitpack_leaf_bytes(uint32_t n) { return BITPACK_HEAD_BYTES + (size_t)n * BITPACK_TRI_BYTES; }

/* ids are consecutive (seq_ids). */
static inline void bitpack_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, grid[6];
    for (uint32_t i = 0; i < n; i++)
        for (int v = 0; v < 3; v++) {
            const float *p = m->vertices + 3 * (size_t)m->triangles[3 * (size_t)ids[i] + (size_t)v];
            for (int k = 0; k < 3; k++) lo[k] = fminf(lo[k], p[k]), hi[k] = fmaxf(hi[k], p[k]);
        }
    for (int k = 0; k < 3; k++) grid[k] = lo[k], grid[3 + k] = bvh_lattice_step((double)hi[k] - lo[k], BPV_MASK);
    memcpy(dst, &ids[0], 4);
    memcpy(dst + 4, grid, sizeof grid);
    dst += BITPACK_HEAD_BYTES;
    for (uint32_t i = 0; i < n; i++)
        for (int v = 0; v < 3; v++, dst += 8) {
            double d2;
            uint64_t w =
                bpv_pack(m->vertices + 3 * (size_t)m->triangles[3 * (size_t)ids[i] + (size_t)v], grid, grid + 3, &d2);
            memcpy(dst, &w, 8);
        }
}

#define bitpack_shared_build NULL
#define bitpack_shared_remap NULL
#define bitpack_vertex_error NULL

/* The 9 decoded coordinates of triangle i of the leaf. */
PRT_INLINE void bitpack_triangle(const uint8_t *leaf, uint32_t i, float p[9]) {
    float g[6];
    memcpy(g, leaf + 4, sizeof g);
    uint64_t w[3];
    memcpy(w, leaf + BITPACK_HEAD_BYTES + (size_t)i * BITPACK_TRI_BYTES, sizeof w);
    for (int v = 0; v < 3; v++)
        for (int k = 0; k < 3; k++)
            p[3 * v + k] = bpv_decode(g[k], g[3 + k], (uint32_t)(w[v] >> (BPV_BITS * k)) & BPV_MASK);
}

/* The largest decoded-to-mesh vertex distance of the leaf's triangles (m in leaf order). */
static inline double bitpack_leaf_error(const uint8_t *leaf, uint32_t n, const prt_mesh *m) {
    uint32_t id0;
    memcpy(&id0, leaf, 4);
    double err2 = 0;
    for (uint32_t i = 0; i < n && (size_t)id0 + i < m->triangle_count; i++) {
        float p[9];
        bitpack_triangle(leaf, i, p);
        for (int v = 0; v < 3; v++) {
            const float *q = m->vertices + 3 * (size_t)m->triangles[3 * ((size_t)id0 + i) + (size_t)v];
            double d2 = 0;
            for (int k = 0; k < 3; k++) d2 += ((double)p[3 * v + k] - q[k]) * ((double)p[3 * v + k] - q[k]);
            err2 = fmax(err2, d2);
        }
    }
    return sqrt(err2);
}

/* The first id lies in the tree and the grid is finite. */
static inline bool bitpack_leaf_valid(const uint8_t *leaf, uint32_t n, const bvh_shared *sh) {
    uint32_t id0;
    memcpy(&id0, leaf, 4);
    float g[6];
    memcpy(g, leaf + 4, sizeof g);
    for (int k = 0; k < 6; k++)
        if (!isfinite(g[k]) || (k >= 3 && g[k] < 0)) return false;
    return id0 < sh->triangles && n > 0;
}

static inline void bitpack_ray_init(bitpack_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    (void)r;
    c->sh = sh;
}

PRT_INLINE void bitpack_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const bitpack_ray *c,
                                  prt__hitx *h) {
    uint32_t id0;
    memcpy(&id0, leaf, 4);
    for (uint32_t i = 0; i < n; i++) {
        float p[9], t, u, w;
        bitpack_triangle(leaf, i, p);
        /* At equal t the smaller mesh id wins, as in every codec (bvh_tie_id). */
        if (prt__tri_hit(r, p, p + 3, p + 6, h->t, &t, &u, &w) &&
            (t < h->t || bvh_tie_id(c->sh, id0 + i) < bvh_tie_id(c->sh, h->prim)))
            h->t = t, h->u = u, h->v = w, h->prim = id0 + i;
    }
}

PRT_INLINE bool bitpack_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r, const bitpack_ray *c,
                                 float tfar) {
    (void)c;
    for (uint32_t i = 0; i < n; i++) {
        float p[9], t, u, w;
        bitpack_triangle(leaf, i, p);
        if (prt__tri_hit(r, p, p + 3, p + 6, tfar, &t, &u, &w)) return true;
    }
    return false;
}

/* The triangles as the kernel decodes them, with their leaf-order ids (bvh_codec.decode). */
static inline uint32_t bitpack_decode(const uint8_t *leaf, uint32_t n, const bvh_shared *sh, float *v, uint32_t *ids) {
    (void)sh;
    uint32_t id0;
    memcpy(&id0, leaf, 4);
    for (uint32_t i = 0; i < n; i++) {
        bitpack_triangle(leaf, i, v + 9 * (size_t)i);
        ids[i] = id0 + i;
    }
    return n;
}

#endif
