/* The wide8 layout's traversal kernels (wide8_kernels.inc, wide8_packet.inc) for every codec, in one table:
 * this file is compiled once per instruction set (core/isa.h, CMakeLists.txt), its table
 * named bvh_wide8_kernels, bvh_wide8_kernels_avx512, ... */
#include "bvh/layouts/wide8_packet.h"
#include "bvh/traverse.h"
#include "core/isa.h"

#define LAYOUT_KERNELS "bvh/layouts/wide8_packet.inc" /* includes wide8_kernels.inc */
#include "bvh/layouts/instantiate.inc"
#undef LAYOUT_KERNELS

#define WIDE8_KERNELS(id, nm, desc)                                                     \
    [BVH_CODEC_##id] = {wide8_intersect1_##id, wide8_occluded1_##id, wide8_stream_##id, \
                        wide8_for_blob_##id,   wide8_packet_##id,    wide8_occluded_packet_##id},
const bvh_kernels PRT_ISA_NAME(bvh_wide8_kernels)[BVH_CODEC_COUNT] = {BVH_CODECS(WIDE8_KERNELS)};
