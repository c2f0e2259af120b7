/* The codec table: what encoding and loading need from each codec. */
#include "bvh/bvh.h"
#include "bvh/codecs/codecs.h"

#define X(id, nm, desc)                                                                          \
    static void id##_encode_fn(uint8_t *d, const prt_mesh *m, const uint32_t *ids, uint32_t n) { \
        id##_encode(d, m, ids, n);                                                               \
    }
BVH_CODECS(X)
#undef X

/* The codecs with a grid per leaf or block, and their steps (bvh_codec.lattice). */
#define BVH_LATTICE(c)                                     \
    ((c) == BVH_CODEC_bitpack         ? BPV_MASK           \
     : (c) == BVH_CODEC_bitpack_soa4  ? BSOA_MASK          \
     : (c) == BVH_CODEC_strip_bitpack ? STRIP_BITPACK_MASK \
                                      : 0u)

/* The fields every codec header defines. */
#define CODEC_FIELDS(id, nm, desc)                                                                            \
    .name = nm, .description = desc, .block = id##_block, .align = id##_align, .leaf_bytes = id##_leaf_bytes, \
    .encode = id##_encode_fn, .shared_build = id##_shared_build, .leaf_valid = id##_leaf_valid,               \
    .seq_ids = id##_seq_ids, .shared_remap = id##_shared_remap, .vertex_error = id##_vertex_error,            \
    .leaf_error = id##_leaf_error, .decode = id##_decode, .lattice = BVH_LATTICE(BVH_CODEC_##id)

const bvh_codec bvh_codecs[BVH_CODEC_COUNT] = {
#define X(id, nm, desc) [BVH_CODEC_##id] = {CODEC_FIELDS(id, nm, desc)},
    BVH_TRIANGLE_CODECS(X)
#undef X
#define X(id, nm, desc) [BVH_CODEC_##id] = {CODEC_FIELDS(id, nm, desc), .leaves = &id##_leaf_kind, .strips = true},
        BVH_KIND_CODECS(X)
#undef X
};

_Static_assert(BVH_DECODE_MAX >= BVH_MAX_LEAF, "a leaf decodes to at most BVH_MAX_LEAF triangles");

int bvh_codec_find(const char *name) {
    for (int i = 0; i < BVH_CODEC_COUNT; i++)
        if (!strcmp(bvh_codecs[i].name, name)) return i;
    return -1;
}
