/* Float3SOA8 (Rouwé 2019, §3.3): blocks of eight triangles in SOA form, 320 bytes, tested
 * eight at a time with the watertight AVX kernel. */
#ifndef PRT_BVH_CODECS_FLOAT3_SOA8_H
#define PRT_BVH_CODECS_FLOAT3_SOA8_H

#include "bvh/codecs/codec.h"
#include "bvh/codecs/decode.h"
#include "bvh/codecs/nearest.h"
#include "geom/triangle.h"

#include <math.h>

#define SOA_W 8
#include "bvh/codecs/float3_soa.inc"
#undef SOA_W
#define float3_soa8_shared_build NULL
#define float3_soa8_leaf_valid NULL

#define float3_soa8_shared_remap NULL
#define float3_soa8_vertex_error NULL

#define float3_soa8_leaf_error NULL

#endif
