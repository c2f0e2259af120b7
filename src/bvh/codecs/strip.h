/* UncompressedStrip (Rouwé 2019, §3.10): a leaf is a u32 leaf-order id of its first
 * triangle, then per strip entry one vertex as 3 floats whose least significant bits carry
 * the entry's 3-bit context (bvh/strip_leaves.h), 12 bytes. Those bits are lost to the
 * vertex, so the BVH family clears them in every vertex before building (the tree's boxes
 * and neighbouring leaves then see the same, decoded vertex: no cracks) and states that
 * change, at most one unit in the last place, as the vertex error. */
#ifndef PRT_BVH_CODECS_STRIP_H
#define PRT_BVH_CODECS_STRIP_H

#include "bvh/codecs/codec.h"
#include "bvh/codecs/decode.h"
#include "bvh/codecs/nearest.h"
#include "bvh/strip_leaves.h"
#include "geom/triangle.h"

#include <math.h>

#define STRIP_F32_ENTRY_BYTES 12
#define STRIP_F32_HEAD_BYTES 4

/* The shared data of both strip codecs: this head, then 2 bits of rotation per leaf-order
 * triangle (bvh_strip_set.rotations). */
typedef struct strip_shared_head {
    float vertex_error; /* strip: what clearing the low bits moved a vertex; strip-bitpack: 0 (per leaf) */
    uint32_t triangles;
    uint32_t entries, strips; /* for statistics */
} strip_shared_head;

/* A float with its least significant bit cleared: how strip stores and decodes vertices. */
static inline float strip_clear_low_bit(float x) {
    uint32_t b;
    memcpy(&b, &x, 4);
    b &= ~1u;
    memcpy(&x, &b, 4);
    return x;
}

/* The entries ids[0 .. n) of the strip entry mesh m (bvh_strip_set: vertex, flags, triangle). */
static inline void strip_encode(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t n) {
    uint32_t id = PRT_INVALID;
    for (uint32_t i = 0; i < n && id == PRT_INVALID; i++) id = m->triangles[3 * (size_t)ids[i] + 2];
    memcpy(dst, &id, 4);
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t *e = m->triangles + 3 * (size_t)ids[i];
        for (int k = 0; k < 3; k++) {
            uint32_t b;
            memcpy(&b, m->vertices + 3 * (size_t)e[0] + k, 4);
            b = (b & ~1u) | (e[1] >> k & 1);
            memcpy(dst + STRIP_F32_HEAD_BYTES + STRIP_F32_ENTRY_BYTES * (size_t)i + 4 * (size_t)k, &b, 4);
        }
    }
}

PRT_INLINE uint32_t strip_entry(const uint8_t *leaf, uint32_t e, float v[3]) {
    uint32_t b[3];
    memcpy(b, leaf + STRIP_F32_HEAD_BYTES + STRIP_F32_ENTRY_BYTES * (size_t)e, sizeof b);
    const uint32_t f = (b[0] & 1) | (b[1] & 1) << 1 | (b[2] & 1) << 2;
    for (int k = 0; k < 3; k++) b[k] &= ~1u;
    memcpy(v, b, sizeof b);
    return f;
}

static inline bool strip_head_valid(const uint8_t *leaf) {
    (void)leaf;
    return true;
}

#define STRIP_FN(f) strip_##f
#define STRIP_ENTRY_BYTES STRIP_F32_ENTRY_BYTES
#define STRIP_HEAD_BYTES STRIP_F32_HEAD_BYTES
#include "bvh/codecs/strip_kernel.inc"
#undef STRIP_FN
#undef STRIP_ENTRY_BYTES
#undef STRIP_HEAD_BYTES

static inline double strip_vertex_error(const bvh_shared *sh) {
    strip_shared_head hd;
    if (sh->size < sizeof hd) return 0;
    memcpy(&hd, sh->data, sizeof hd);
    return hd.vertex_error;
}

#define strip_shared_build NULL
#define strip_shared_remap NULL
#define strip_leaf_error NULL

#endif
