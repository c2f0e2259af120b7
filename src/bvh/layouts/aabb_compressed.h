/* AABBTreeCompressed (Rouwé 2019, §5.4): node format and the child-box decoding shared by
 * the encoder (aabb_compressed.c), its kernels (aabb_compressed_kernels.inc) and the tests.
 *
 * Blob: a 32-byte header (root box, root triangle count), then the tree depth first: an
 * inner node (12 bytes) is followed by its left child; a leaf's triangle block follows its
 * parent node (or the header), at the codec's alignment. The right child starts where the
 * left child's subtree ends (aligned when it is a leaf), and the node keeps its offset.
 *
 * Node words 0 (left) and 1 (right): bits 0..20 three 7-bit components q (x, y, z), bits
 * 21..23 one side bit per component, bits 24..31 the triangle count of that child (0: an
 * inner node). Word 0 holds the minima, word 1 the maxima; a side bit says which child
 * (0: left, 1: right) has the changed plane, the other keeps the parent's:
 *     changed min = parent.min + q * step, changed max = parent.max - q * step,
 *     step = (parent.max - parent.min) / 127,
 * so q = 0 is the parent's plane exactly. The encoder rounds every plane outward and checks
 * it with these very operations on the parent box as traversal decodes it, so a decoded box
 * always contains its child's true box. Word 2: the right child's byte offset in the blob. */
#ifndef PRT_BVH_LAYOUTS_AABB_COMPRESSED_H
#define PRT_BVH_LAYOUTS_AABB_COMPRESSED_H

#include "core/common.h"

#define AC_HEADER_BYTES 32
#define AC_NODE_BYTES 12
#define AC_SIDE_SHIFT 21
#define AC_COUNT_SHIFT 24

typedef struct ac_header {
    float lo[3], hi[3];  /* the root box */
    uint32_t root_count; /* > 0: the root is a leaf of that many triangles */
    uint32_t reserved;   /* 0 */
} ac_header;

_Static_assert(sizeof(ac_header) == AC_HEADER_BYTES, "aabb-compressed header is 32 bytes");

/* A product, not a division: decoding runs on every node visit, and the encoder checks
 * planes with this very function, so the rounding of 1/127 costs nothing in correctness. */
static inline float ac_step(float lo, float hi) { return (hi - lo) * (1.0f / 127.0f); }
static inline float ac_min_plane(float lo, float step, uint32_t q) { return lo + (float)q * step; }
static inline float ac_max_plane(float hi, float step, uint32_t q) { return hi - (float)q * step; }

/* The two child boxes of a node whose own (decoded) box is lo/hi. */
static inline void ac_unpack(const float lo[3], const float hi[3], uint32_t wmin, uint32_t wmax, float llo[3],
                             float lhi[3], float rlo[3], float rhi[3]) {
    for (int k = 0; k < 3; k++) {
        const float step = ac_step(lo[k], hi[k]);
        const float mn = ac_min_plane(lo[k], step, (wmin >> (7 * k)) & 127);
        const float mx = ac_max_plane(hi[k], step, (wmax >> (7 * k)) & 127);
        const bool smin = (wmin >> (AC_SIDE_SHIFT + k)) & 1, smax = (wmax >> (AC_SIDE_SHIFT + k)) & 1;
        llo[k] = smin ? lo[k] : mn, rlo[k] = smin ? mn : lo[k];
        lhi[k] = smax ? hi[k] : mx, rhi[k] = smax ? mx : hi[k];
    }
}

#endif
