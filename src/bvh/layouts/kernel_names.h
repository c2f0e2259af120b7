/* Token pasting for the traversal templates: CODEC_FN(intersect) -> float3_intersect,
 * KERNEL_FN(aabb, intersect1) -> aabb_intersect1_float3. */
#ifndef PRT_BVH_LAYOUTS_KERNEL_NAMES_H
#define PRT_BVH_LAYOUTS_KERNEL_NAMES_H
#define PRT_CAT2_(a, b) a##_##b
#define PRT_CAT2(a, b) PRT_CAT2_(a, b)
#define CODEC_FN(f) PRT_CAT2(CODEC, f)
#define KERNEL_FN(layout, f) PRT_CAT2(PRT_CAT2(layout, f), CODEC)
#endif
