/* The representation lists `packrt bench` runs when not given -r. */
#include "bench.h"

const char *const bench_default_specs[] = {
    /* wide8: the fastest float codec, the smallest lossless and the smallest lossy */
    "wide8:float3-soa8", "wide8:idx8-soa4", "wide8:idx8-bitpack-soa4,ids=none",
    /* every other BVH layout once, with the codec that suits it best */
    "quad:float3-soa4", "quad-half:float3-soa4", "aabb:float3", "aabb-split:float3-soa4", "aabb-pns:float3-soa4",
    "aabb-compressed:idx8-bitpack-soa4", "skd:idx8-soa4",
    /* the other families */
    "raystrips", "lossygrid", "cgrid", "ooc", NULL};

const char *const bench_calibrate_specs[] = {
    /* float codecs: the fastest */
    "wide8:float3-soa8", "wide8:float3-soa4", "quad:float3-soa4", "quad:float3-soa8", "quad-half:float3-soa4",
    /* lossless indexed codecs: between 13 and 30 bytes per triangle */
    "wide8:idx32-soa4", "wide8:idx16-soa4", "wide8:idx8-soa4", "wide8:idx8-soa4,ids=none", "raystrips", "skd:idx8-soa4",
    /* lossy: the smallest */
    "wide8:idx8-bitpack-soa4", "wide8:idx8-bitpack-soa4,ids=none", "wide8:idx8-bitpack-soa4,ids=none,leaf=12",
    "aabb-compressed:idx8-bitpack-soa4,ids=none", "lossygrid", NULL};
