/* Indexed8BitPackSOA4 (Rouwé 2019, §3.9): the smallest codec. One tree-wide buffer of
 * compressed vertices, a u64 each (21 bits per component over the mesh bounds, §3.4), laid
 * out in leaf order; per leaf the buffer position its indices count from and its first
 * triangle id (seq_ids), then per block of four triangles their 8-bit vertex indices in
 * SOA order (vertex 0 of the four, vertex 1, vertex 2): 8 + 12 bytes per block.
 *
 * The buffer and the leaf format are vertex_window.h's (greedy reuse in a 192-entry
 * window, so every leaf reaches its vertices with 8-bit indices). Lossy: every vertex lies
 * within the stated vertex error of its mesh vertex; a mesh vertex appended twice decodes
 * to the same bits both times, so neighbouring triangles stay watertight. Padding lanes
 * repeat one vertex three times: zero area, never hit (and turned to NaN when decoded). */
#ifndef PRT_BVH_CODECS_IDX8_BITPACK_SOA4_H
#define PRT_BVH_CODECS_IDX8_BITPACK_SOA4_H

#include "bvh/codecs/bitpack_vertices.h"
#include "bvh/codecs/codec.h"
#include "bvh/codecs/decode.h"
#include "bvh/codecs/nearest.h"
#include "bvh/codecs/vertex_window.h"
#include "geom/triangle.h"

#include <assert.h>
#include <math.h>

#define IDX8BP_HEAD_BYTES VW_HEAD_BYTES
#define IDX8BP_BLOCK_BYTES VW_BLOCK_BYTES
#define IDX8BP_BITS BPV_BITS
#define IDX8BP_MASK BPV_MASK
enum { idx8_bitpack_soa4_block = 4, idx8_bitpack_soa4_align = 4, idx8_bitpack_soa4_seq_ids = 1 };

/* Head of the shared buffer: bitpack_vertices.h's. */
typedef bpv_header idx8bp_header;

typedef bpv_ray idx8_bitpack_soa4_ray;

static inline size_t idx8_bitpack_soa4_leaf_bytes(uint32_t n) { return vw_leaf_bytes(n); }

/* m: triangles in leaf order, rewritten in place to buffer positions; the grid spans the
 * mesh's bounds, taken before the indices change meaning. */
static inline prt_status idx8_bitpack_soa4_shared_remap(prt_mesh *m, uint32_t max_leaf, uint8_t **data, size_t *size) {
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    uint32_t *source = NULL, len = 0;
    prt_status s = vw_build(m, "idx8-bitpack-soa4", max_leaf, &source, &len);
    if (!s) s = bpv_buffer_build_in(m, source, len, lo, hi, data, size);
    prt__free(source);
    return s;
}

/* ids are consecutive (seq_ids) and m's indices are buffer positions (shared_remap). */
static inline void idx8_bitpack_soa4_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    vw_encode(dst, m, ids, n);
}

#define idx8_bitpack_soa4_shared_build NULL

static inline double idx8_bitpack_soa4_vertex_error(const bvh_shared *sh) { return bpv_buffer_error(sh); }

/* The buffer is whole and every index of the leaf names an entry of it. */
static inline bool idx8_bitpack_soa4_leaf_valid(const uint8_t *leaf, uint32_t n, const bvh_shared *sh) {
    bpv_header hd;
    return bpv_buffer_valid(sh, &hd) && vw_leaf_valid(leaf, n, hd.count, sh);
}

/* --- traversal ------------------------------------------------------------------------ */

PRT_INLINE void idx8_bitpack_soa4_ray_init(idx8_bitpack_soa4_ray *c, const prt__rayx *r, const bvh_shared *sh) {
    bpv_ray_init(c, r, sh, 8);
}

/* The block at a and the next decoded into lanes 0-3 and 4-7 of the 8-wide test; for a
 * leaf's odd last block (`odd`) lanes 4-7 are padding. */
PRT_INLINE void idx8bp_gather8(const uint8_t *a, bool odd, const uint8_t *base, const idx8_bitpack_soa4_ray *c,
                               float p[72]) {
    const uint8_t *b = odd ? a : a + IDX8BP_BLOCK_BYTES;
    const vi8 off = odd ? vw_upper_half : (vi8){0};
    uint64_t w[3][8];
    for (int v = 0; v < 3; v++)
        for (int l = 0; l < 4; l++)
            memcpy(&w[v][l], base + 8 * (size_t)a[4 * v + l], 8),
                memcpy(&w[v][4 + l], base + 8 * (size_t)b[4 * v + l], 8);
    bpv_decode8((const uint64_t(*)[8])w, c->lo, c->step, c->comp, vw_padding8(a, b) | off, p);
}

PRT_INLINE void idx8_bitpack_soa4_intersect(const uint8_t *leaf, uint32_t n, const prt__rayx *r,
                                            const idx8_bitpack_soa4_ray *c, prt__hitx *h) {
    (void)r; /* the test reads the renamed axes (bpv_ray) */
    uint32_t first, id0;
    memcpy(&first, leaf, 4);
    memcpy(&id0, leaf + 4, 4);
    const uint8_t *base = c->vertices + 8 * (size_t)first;
    leaf += IDX8BP_HEAD_BYTES;
    /* Blocks two at a time in the 8-wide test (a leaf of up to 8 triangles: one test, no
     * loop), an odd last block with four padding lanes; the hit is taken as block after
     * block would take it (nearest, then the smallest id). */
    const uint32_t blocks = (n + 3) / 4;
    for (uint32_t b = 0; b < blocks; b += 2, leaf += 2 * IDX8BP_BLOCK_BYTES) {
        float p[72];
        idx8bp_gather8(leaf, b + 1 == blocks, base, c, p);
        vf8 t, u, v;
        int mask = prt__tri8_hit(&prt__rayx_renamed, &c->r8, p, vf8_set1(h->t), &t, &u, &v);
        if (mask) bvh_take_block8_seq(h, t, u, v, mask, id0 + 4 * b, c->sh);
    }
}

PRT_INLINE bool idx8_bitpack_soa4_occluded(const uint8_t *leaf, uint32_t n, const prt__rayx *r,
                                           const idx8_bitpack_soa4_ray *c, float tfar) {
    (void)r;
    uint32_t first;
    memcpy(&first, leaf, 4);
    const uint8_t *base = c->vertices + 8 * (size_t)first;
    leaf += IDX8BP_HEAD_BYTES;
    const uint32_t blocks = (n + 3) / 4;
    for (uint32_t b = 0; b < blocks; b += 2, leaf += 2 * IDX8BP_BLOCK_BYTES) {
        float p[72];
        idx8bp_gather8(leaf, b + 1 == blocks, base, c, p);
        vf8 t, u, v;
        if (prt__tri8_hit(&prt__rayx_renamed, &c->r8, p, vf8_set1(tfar), &t, &u, &v)) return true;
    }
    return false;
}

/* The blocks as the kernel decodes them (two at a time), axes not renamed, with their
 * leaf-order ids; padding lanes skipped (bvh_codec.decode). */
static inline uint32_t idx8_bitpack_soa4_decode(const uint8_t *leaf, uint32_t n, const bvh_shared *sh, float *v,
                                                uint32_t *ids) {
    idx8_bitpack_soa4_ray c;
    bpv_ray_world(&c, sh);
    uint32_t first, id0, k = 0;
    memcpy(&first, leaf, 4);
    memcpy(&id0, leaf + 4, 4);
    const uint8_t *base = c.vertices + 8 * (size_t)first;
    leaf += IDX8BP_HEAD_BYTES;
    const uint32_t blocks = (n + 3) / 4;
    for (uint32_t b = 0; b < blocks; b += 2, leaf += 2 * IDX8BP_BLOCK_BYTES) {
        float p[72];
        idx8bp_gather8(leaf, b + 1 == blocks, base, &c, p);
        k = bvh_decode_soa(p, 8, 8, id0 + 4 * b, v, ids, k);
    }
    return k;
}

#define idx8_bitpack_soa4_leaf_error NULL

#endif
