/* Float3SOA4 (Rouwé 2019, §3.2): blocks of four triangles in SOA form, 160 bytes, tested
 * four at a time with the watertight SSE kernel. */
#ifndef PRT_BVH_CODECS_FLOAT3_SOA4_H
#define PRT_BVH_CODECS_FLOAT3_SOA4_H

#include "bvh/codecs/codec.h"
#include "bvh/codecs/decode.h"
#include "bvh/codecs/nearest.h"
#include "geom/triangle.h"

#include <math.h>

#define SOA_W 4
#include "bvh/codecs/float3_soa.inc"
#undef SOA_W
#define float3_soa4_shared_build NULL
#define float3_soa4_leaf_valid NULL

#define float3_soa4_shared_remap NULL
#define float3_soa4_vertex_error NULL

#define float3_soa4_leaf_error NULL

#endif
