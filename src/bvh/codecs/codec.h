/* The triangle codec interface (Rouwé 2019, §3). A codec encodes the triangles of one
 * leaf into a byte block and intersects rays with such a block. Kernels are static inline
 * functions named CODEC_<fn> in codecs/<name>.h so that each layout's traversal inlines
 * them (bvh/layouts/instantiate.inc); the table below holds what encoding and loading
 * need, where an indirect call costs nothing.
 *
 * Adding a codec: codecs/<name>.h, one line in BVH_CODECS below, one include in
 * codecs/codecs.h and two lines in layouts/instantiate.inc. */
#ifndef PRT_BVH_CODECS_CODEC_H
#define PRT_BVH_CODECS_CODEC_H

#include "core/common.h"

/* X(id, name, description) */
#define BVH_CODECS(X)                                                                                 \
    X(float3, "float3", "Float3 (Rouwe 3.1): 9 floats and a 32-bit triangle id per triangle")       \
    X(float3_soa4, "float3-soa4", "Float3SOA4 (Rouwe 3.2): blocks of 4 triangles in SOA form, SIMD test") \
    X(float3_soa8, "float3-soa8", "Float3SOA8 (Rouwe 3.3): blocks of 8 triangles in SOA form, AVX test")

typedef enum bvh_codec_id {
#define X(id, name, desc) BVH_CODEC_##id,
    BVH_CODECS(X)
#undef X
    BVH_CODEC_COUNT
} bvh_codec_id;

typedef struct bvh_codec {
    const char *name;
    const char *description;
    int block;    /* triangles tested together; leaves are padded to a multiple */
    size_t align; /* alignment of a leaf block in bytes */
    size_t (*leaf_bytes)(uint32_t count);
    /* Write count triangles (ids into m) to dst, which has leaf_bytes(count) bytes. */
    void (*encode)(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t count);
} bvh_codec;

extern const bvh_codec bvh_codecs[BVH_CODEC_COUNT];

/* Codec id by name, or -1. */
int bvh_codec_find(const char *name);

#endif
