/* Indexed16BitPackSOA4 (Rouwé 2019, §3.8): 16-bit SOA indices of 4 triangles over one
 * u64 BitPack vertex per mesh vertex; see idx_bitpack_soa4.inc. Lossy. */
#ifndef PRT_BVH_CODECS_IDX16_BITPACK_SOA4_H
#define PRT_BVH_CODECS_IDX16_BITPACK_SOA4_H

#include "bvh/codecs/bitpack_vertices.h"
#include "bvh/codecs/codec.h"
#include "bvh/codecs/decode.h"
#include "bvh/codecs/nearest.h"
#include "geom/triangle.h"

#define IBP_BITS 16
#include "bvh/codecs/idx_bitpack_soa4.inc"
#undef IBP_BITS

#define idx16_bitpack_soa4_shared_remap NULL

#define idx16_bitpack_soa4_leaf_error NULL

#endif
