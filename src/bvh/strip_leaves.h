/* Rouwé's strip codecs (§3.10) under every node layout. A strip leaf's size depends on how
 * its triangles chain, not on their number, while every layout sizes a leaf from its count
 * (codec.h). So the tree is rewritten before encoding: each leaf's triangles are chained
 * into strips, and the leaf then holds strip *entries* (one vertex and its 3-bit context
 * each) instead of triangles; a strip codec's leaf is affine in entries. A leaf whose
 * entries exceed BVH_MAX_LEAF is split into a small subtree (docs/design-changes.md). */
#ifndef PRT_BVH_STRIP_LEAVES_H
#define PRT_BVH_STRIP_LEAVES_H

#include "bvh/bvh.h"

/* The 3-bit context of an entry (Rouwé §3.10). START_V1 and START_V2 begin a strip; any
 * other value continues it with triangle (A, B, C): C the entry's vertex, A vertex (f & 3)
 * of the previous triangle, B the one after A, or with STRIP_B_PLUS_2 the one after that
 * (wrapping V3 + 1 = V1). The first triangle of a strip is (V1, V2, C): flags 0. */
enum { STRIP_START_V1 = 3, STRIP_START_V2 = 7, STRIP_B_PLUS_2 = 4 };

/* Entries a leaf may hold: the count layouts store and validate. */
#define STRIP_MAX_ENTRIES BVH_MAX_LEAF

/* The entries of the rewritten tree, in the order of its prims. */
typedef struct bvh_strip_set {
    uint32_t *entries; /* 3 per entry: vertex index, flags, leaf-order triangle it completes or PRT_INVALID */
    size_t count;
    size_t strips;
    /* 2 bits per leaf-order triangle (4 a byte, low bits first): r such that the strip's
     * triangle (A, B, C) is the mesh's (v_r, v_r+1, v_r+2), to return u, v in mesh order. */
    uint8_t *rotations;
} bvh_strip_set;

/* Chain the triangles of every leaf of t into strips. t's prims are leaf-order triangles
 * of m (prims[i] == i, permute_to_leaf_order); within each leaf the triangles are
 * renumbered in strip order: m's rows become (A, B, C) as the strip decodes them and ids
 * (mesh id per leaf-order triangle, or NULL) follows. Afterwards t's leaves hold ranges of
 * out->entries and t->prims indexes those. Vertices are matched by position, so meshes
 * with split vertices still chain. */
prt_status bvh_strip_leaves(bvh_tree *t, prt_mesh *m, uint32_t *ids, bvh_strip_set *out);

void bvh_strip_set_free(bvh_strip_set *s);

/* u, v of a hit on the strip triangle (A, B, C) as the mesh triangle's, for rotation r. */
static inline void bvh_strip_rotate_uv(uint32_t r, float *u, float *v) { bvh_rotate_uv(r, u, v); }

/* The leaf kinds of the strip codecs (bvh/leaf_kind.h): strip stores vertices without their
 * lowest bit, so its kind clears it in every vertex before building; strip-bitpack's
 * packs each leaf's vertices itself. */
struct bvh_leaf_kind;
extern const struct bvh_leaf_kind strip_leaf_kind, strip_bitpack_leaf_kind;

#endif
