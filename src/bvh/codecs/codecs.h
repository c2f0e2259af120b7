/* Every codec's kernels, for the layouts' traversal templates. */
#ifndef PRT_BVH_CODECS_CODECS_H
#define PRT_BVH_CODECS_CODECS_H

#include "bvh/codecs/codec.h"
#include "bvh/codecs/float3.h"
#include "bvh/codecs/float3_soa4.h"
#include "bvh/codecs/float3_soa8.h"
#include "bvh/codecs/idx32.h"
#include "bvh/codecs/idx32_soa4.h"
#include "bvh/codecs/idx8_bitpack_soa4.h"
#include "bvh/codecs/idx8_soa4.h"
#include "bvh/codecs/idx16.h"
#include "bvh/codecs/idx16_soa4.h"
#include "bvh/codecs/idx16_bitpack_soa4.h"
#include "bvh/codecs/idx32_bitpack_soa4.h"
#include "bvh/codecs/bitpack_soa4.h"
#include "bvh/codecs/bitpack.h"
#include "bvh/codecs/strip.h"
#include "bvh/codecs/strip_bitpack.h"

#endif
