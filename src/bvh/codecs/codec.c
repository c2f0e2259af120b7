/* The codec table: what encoding and loading need from each codec. */
#include "bvh/bvh.h"
#include "bvh/codecs/codecs.h"

#define X(id, nm, desc)                                                                              \
    static void id##_encode_fn(uint8_t *d, const prt_mesh *m, const uint32_t *ids, uint32_t n) {     \
        id##_encode(d, m, ids, n);                                                                   \
    }
BVH_CODECS(X)
#undef X

/* The codecs with a grid per leaf or block, and their steps (bvh_codec.lattice). */
#define BVH_LATTICE(c) ((c) == BVH_CODEC_bitpack ? BPV_MASK : (c) == BVH_CODEC_bitpack_soa4 ? BSOA_MASK \
                        : (c) == BVH_CODEC_strip_bitpack ? STRIP_BITPACK_MASK : 0u)

const bvh_codec bvh_codecs[BVH_CODEC_COUNT] = {
#define X(id, nm, desc)                                                                              \
    [BVH_CODEC_##id] = {nm, desc, id##_block, id##_align, id##_leaf_bytes, id##_encode_fn, id##_shared_build,        \
                        id##_leaf_valid, id##_seq_ids, id##_shared_remap, id##_vertex_error, id##_leaf_error,         \
                        BVH_CODEC_##id == BVH_CODEC_strip || BVH_CODEC_##id == BVH_CODEC_strip_bitpack, id##_decode, \
                        BVH_LATTICE(BVH_CODEC_##id)},
    BVH_CODECS(X)
#undef X
};

_Static_assert(BVH_DECODE_MAX >= BVH_MAX_LEAF, "a leaf decodes to at most BVH_MAX_LEAF triangles");

int bvh_codec_find(const char *name) {
    for (int i = 0; i < BVH_CODEC_COUNT; i++)
        if (!strcmp(bvh_codecs[i].name, name)) return i;
    return -1;
}
