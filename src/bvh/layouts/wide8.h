/* The 8-wide node with quantized child boxes (after Ylitie, Karras, Laine, "Efficient
 * Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs", HPG 2017, §3.1), shared
 * by the encoder (wide8.c) and its traversal kernels (wide8_kernels.inc).
 *
 * Blob: a 16-byte header, the nodes (80 bytes each, node 0 the root; the inner children of
 * a node are consecutive, in slot order), then every leaf block (the leaves of a node are
 * consecutive, in slot order), so tree and geometry bytes are separate ranges. */
#ifndef PRT_BVH_LAYOUTS_WIDE8_H
#define PRT_BVH_LAYOUTS_WIDE8_H

#include "bvh/bvh.h"

/* Slot i of a node holds child i's box: plane = p + q * 2^(e - 127), computed as one
 * fmaf (the encoder checks the rounded result, so the box is conservative bit for bit).
 * Slots run inner children first, then leaves, then empty ones. A leaf slot's meta is the
 * end of its block, counted in grains from the node's first leaf; its start is the end of
 * the slot before (0 for an inner slot or slot 0). Inner and empty slots have meta 0. */
typedef struct wide8_node {
    float p[3];      /* origin of the quantization grid: the node's box minimum */
    uint8_t e[3];    /* per-axis scale exponent, biased like a float's */
    uint8_t imask;   /* bit i: slot i is an inner node */
    uint32_t child;  /* node index of the first inner child */
    uint32_t leaf;   /* offset of the first leaf from the geometry start, in 4-byte words */
    uint8_t meta[8]; /* leaf slots: end of the block in grains */
    uint8_t q[6][8]; /* lo_x, hi_x, lo_y, hi_y, lo_z, hi_z of the 8 slots */
} wide8_node;

_Static_assert(sizeof(wide8_node) == 80, "wide8 node is 80 bytes");

/* Blob header. grain divides every leaf size of the codec (gcd of its per-leaf header and
 * per-block bytes), so 8 bits of meta address a node's leaves. */
typedef struct wide8_header {
    uint32_t grain;
    uint32_t nodes;
    uint64_t geometry; /* byte offset of the first leaf block, aligned for the codec */
} wide8_header;

_Static_assert(sizeof(wide8_header) == 16, "wide8 header is 16 bytes");

#define WIDE8_HEADER_BYTES 16
#define WIDE8_NODE_BYTES 80
#define WIDE8_LEAF (1ull << 63)
#define WIDE8_OFFSET_MASK ((1ull << 56) - 1)
#define WIDE8_STACK (7 * BVH_MAX_DEPTH + 8)

/* The grain of leaf sizes head + k * per (wide8_header): gcd(head, per), or per when head
 * is 0. Constant per codec, so the kernels fold it. */
static inline size_t wide8_grain(size_t head, size_t per) {
    size_t a = head, b = per;
    while (b) {
        const size_t r = a % b;
        a = b, b = r;
    }
    return head ? a : per;
}

/* The scale 2^(e - 127) of an exponent byte in [1, 254]. */
static inline float wide8_scale(uint8_t e) {
    uint32_t bits = (uint32_t)e << 23;
    float s;
    memcpy(&s, &bits, 4);
    return s;
}

/* The leaves wide8_pack writes under its nodes: their sizes, always affine in blocks
 * (bytes(n) == bytes(0) + ceil(n / block) * (bytes(block) - bytes(0)), both terms
 * multiples of 4, codec.h), so a node stores where each leaf ends and never its count. */
typedef struct wide8_leaves {
    const char *name;   /* for messages */
    int block;          /* primitives tested together: a leaf costs ceil(n / block) */
    size_t align;       /* alignment of a leaf in the blob */
    uint32_t max_count; /* the largest leaf a loaded blob may claim */
    size_t (*bytes)(const void *ctx, uint32_t count);
    /* Write the leaf of prims[0 .. count) (ids of the tree's primitives) to dst. */
    void (*encode)(const void *ctx, uint8_t *dst, const uint32_t *prims, uint32_t count);
    /* Loading: whether a leaf of count primitives only references what exists; NULL: any. */
    bool (*valid)(const void *ctx, const uint8_t *leaf, uint32_t count);
    const void *ctx;
} wide8_leaves;

/* The traversal kernels of every codec (wide8_kernels.c), once per instruction set. */
extern const bvh_kernels bvh_wide8_kernels[BVH_CODEC_COUNT];
#ifdef PRT_HAVE_ISA_AVX512
extern const bvh_kernels bvh_wide8_kernels_avx512[BVH_CODEC_COUNT];
#endif

/* Collapse binary tree t into wide8 nodes by the SAH (Ylitie et al. 2017, §3.2), leaves
 * merged up to the largest leaf of t, and write nodes and leaves into out. */
prt_status wide8_pack(const bvh_tree *t, const wide8_leaves *leaves, bvh_blob *out);

/* wide8_pack with a fixed cost per wide node on top of the SAH's (the spec's
 * collapse=fill): the collapse then prefers fewer, fuller nodes, a smaller tree for a
 * little more traversal (bunny, leaves of 8-12: 7% fewer nodes, 0.11-0.18 B/tri). */
prt_status wide8_pack_filled(const bvh_tree *t, const wide8_leaves *leaves, bvh_blob *out);

/* Check a loaded blob: every node reached once, every leaf inside the geometry range and
 * valid, so traversal can neither leave the blob, loop, nor overflow its stack. */
prt_status wide8_check(const bvh_blob *b, const wide8_leaves *leaves);

#endif
