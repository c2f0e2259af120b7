/* The triangle codec interface (Rouwé 2019, §3). A codec encodes the triangles of one
 * leaf into a byte block and intersects rays with such a block. Kernels are static inline
 * functions named CODEC_<fn> in codecs/<name>.h so that each layout's traversal inlines
 * them (bvh/layouts/instantiate.inc); the table below holds what encoding and loading
 * need, where an indirect call costs nothing.
 *
 * Adding a codec: codecs/<id>.h and one line in BVH_TRIANGLE_CODECS below (or, for leaves
 * that are not runs of triangles, BVH_KIND_CODECS); CMakeLists.txt reads these lines (each
 * `    X(id, "` at the start of a line) and generates the header's include (codecs.h) and
 * its kernels' instantiation in every layout (layouts/instantiate.inc). A codec header defines
 * <name>_block, <name>_align, <name>_leaf_bytes, <name>_encode, <name>_ray (per-ray state),
 * <name>_ray_init(ray, rayx, shared), <name>_intersect, <name>_occluded,
 * <name>_shared_build / <name>_leaf_valid / <name>_shared_remap / <name>_vertex_error /
 * <name>_leaf_error as NULL-able macros or functions (codecs.h gives leaf_error a NULL
 * default for the codecs written before it), and <name>_seq_ids (0 or 1, see
 * bvh_codec.seq_ids). */
#ifndef PRT_BVH_CODECS_CODEC_H
#define PRT_BVH_CODECS_CODEC_H

#include "core/common.h"

/* X(id, name, description): every codec, in the order `packrt list` prints them. */
#define BVH_CODECS(X) BVH_TRIANGLE_CODECS(X) BVH_KIND_CODECS(X)

/* Codecs whose leaves are runs of triangles. */
#define BVH_TRIANGLE_CODECS(X)                                                                                         \
    X(float3, "float3", "Float3 (Rouwe 3.1): 9 floats and a 32-bit triangle id per triangle")                          \
    X(float3_soa4, "float3-soa4", "Float3SOA4 (Rouwe 3.2): blocks of 4 triangles in SOA form, SIMD test")              \
    X(float3_soa8, "float3-soa8", "Float3SOA8 (Rouwe 3.3): blocks of 8 triangles in SOA form, AVX test")               \
    X(idx32, "idx32", "Indexed32 (Rouwe 3.6): shared vertex buffer, three 32-bit indices and an id per triangle")      \
    X(idx32_soa4, "idx32-soa4",                                                                                        \
      "Indexed32SOA4 (Rouwe 3.7): shared vertex buffer, 32-bit indices of 4 triangles in SOA form")                    \
    X(idx8_bitpack_soa4, "idx8-bitpack-soa4",                                                                          \
      "Indexed8BitPackSOA4 (Rouwe 3.9): 21-bit packed vertices in leaf order, 8-bit local indices of 4 triangles, "    \
      "one id per leaf; lossy")                                                                                        \
    X(idx8_soa4, "idx8-soa4",                                                                                          \
      "Indexed8SOA4 (beyond Rouwe: 3.9 with float vertices): vertices in leaf order, 8-bit local indices of 4 "        \
      "triangles, one id per leaf; lossless")                                                                          \
    X(idx16, "idx16",                                                                                                  \
      "Indexed16 (Rouwe 3.6): shared vertex buffer, three 16-bit indices per triangle, one id per leaf")               \
    X(idx16_soa4, "idx16-soa4",                                                                                        \
      "Indexed16SOA4 (Rouwe 3.7): shared vertex buffer, 16-bit indices of 4 triangles in SOA form, one id per leaf")   \
    X(idx16_bitpack_soa4, "idx16-bitpack-soa4",                                                                        \
      "Indexed16BitPackSOA4 (Rouwe 3.8): 21-bit packed shared vertices, 16-bit indices of 4 triangles in SOA form, "   \
      "one id per leaf; lossy")                                                                                        \
    X(idx32_bitpack_soa4, "idx32-bitpack-soa4",                                                                        \
      "Indexed32BitPackSOA4 (Rouwe 3.8): 21-bit packed shared vertices, 32-bit indices of 4 triangles in SOA form, "   \
      "one id per leaf; lossy")                                                                                        \
    X(bitpack_soa4, "bitpack-soa4",                                                                                    \
      "BitPackSOA4 (Rouwe 3.5): 16-bit components of 4 triangles in SOA form over a float grid per block, one id per " \
      "leaf; lossy")                                                                                                   \
    X(bitpack, "bitpack",                                                                                              \
      "BitPack (Rouwe 3.4): three 21-bit packed vertices per triangle over a grid per leaf, one id per leaf; lossy")

/* Codecs whose leaves hold entries of a kind of their own (bvh/leaf_kind.h), which each
 * names as <id>_leaf_kind in its header. */
#define BVH_KIND_CODECS(X)                                                                                             \
    X(strip, "strip",                                                                                                  \
      "UncompressedStrip (Rouwe 3.10): strips of 12-byte vertices with the 3-bit context in their low bits, one id "   \
      "per leaf; lossy by one ulp")                                                                                    \
    X(strip_bitpack, "strip-bitpack",                                                                                  \
      "CompressedStrip (Rouwe 3.10): strips of 20-bit packed vertices and the 3-bit context in a u64, a grid and one " \
      "id per leaf; lossy")

typedef enum bvh_codec_id {
#define X(id, name, desc) BVH_CODEC_##id,
    BVH_CODECS(X)
#undef X
        BVH_CODEC_COUNT
} bvh_codec_id;

/* How many BVH_TRIANGLE_CODECS there are: they come first in bvh_codec_id, so a codec whose
 * id is below this holds runs of triangles (its decode gives what its test takes). */
enum {
    BVH_TRIANGLE_CODEC_COUNT = 0
#define X(id, name, desc) +1
    BVH_TRIANGLE_CODECS(X)
#undef X
};

/* Data a codec keeps for the whole tree (Indexed codecs: the vertex buffer), saved as its
 * own section and handed to every ray's kernels. size 0: none. */
typedef struct bvh_shared {
    const uint8_t *data;
    size_t size;
    /* Codecs with seq_ids: the number of triangles in the tree (every leaf's ids lie
     * below it; leaf_valid checks that), and the mesh triangle id of each, or NULL when
     * the tree was built with ids=none. Ties at equal t go to the smaller mesh id, so a
     * kernel compares bvh_tie_id(sh, id) rather than its own ids (bvh/codecs/nearest.h). */
    size_t triangles;
    const uint32_t *mesh_ids;
    /* Instead of mesh_ids, a compact map (lossygrid's id map): the mesh id of position id
     * below triangles. NULL for the BVH family. */
    uint32_t (*map_id)(const void *map, uint32_t id);
    const void *map;
    /* Codecs that store triangles as rotations of the mesh's (strip leaves): 2 bits per
     * leaf-order triangle, 4 a byte, low bits first, within data; NULL for the others
     * (bvh_rotate_uv). */
    const uint8_t *rotations;
    /* The state of a leaf_valid stand-in that visits leaves rather than checks them (the
     * BVH family measures leaf errors through the layout's validate walk); else NULL. */
    void *visit;
} bvh_shared;

/* The rotation of leaf-order triangle prim (sh->rotations not NULL). */
static inline uint32_t bvh_rotation(const bvh_shared *sh, uint32_t prim) {
    return sh->rotations[prim / 4] >> (2 * (prim % 4)) & 3;
}

/* u, v of a hit on a triangle stored as rotation r of the mesh's, (A, B, C) = (v_r, v_r+1,
 * v_r+2), as the mesh triangle's. */
static inline void bvh_rotate_uv(uint32_t r, float *u, float *v) {
    const float w = 1.0f - *u - *v, a = *u, b = *v;
    if (r == 1) *u = w, *v = a;
    else if (r == 2) *u = b, *v = w;
}

typedef struct bvh_codec {
    const char *name;
    const char *description;
    int block;    /* triangles tested together; leaves are padded to a multiple */
    size_t align; /* alignment of a leaf block in bytes */
    /* Bytes of a leaf of count triangles. Always affine in blocks:
     * leaf_bytes(n) == leaf_bytes(0) + ceil(n / block) * (leaf_bytes(block) - leaf_bytes(0)),
     * with both terms multiples of align, so a layout can recover a (block-padded) count from
     * a leaf's size (bvh_leaf_count_of) and need not store it. */
    size_t (*leaf_bytes)(uint32_t count);
    /* Write count triangles (ids into m) to dst, which has leaf_bytes(count) bytes. */
    void (*encode)(uint8_t *dst, const prt_mesh *m, const uint32_t *ids, uint32_t count);
    /* Build the shared data (prt__alloc'ed) for mesh m; NULL when the codec has none. */
    prt_status (*shared_build)(const prt_mesh *m, uint8_t **data, size_t *size);
    /* Loading: true when a leaf only references what exists (e.g. vertex indices inside
     * the shared buffer). NULL when a leaf cannot reference anything outside itself. */
    bool (*leaf_valid)(const uint8_t *leaf, uint32_t count, const bvh_shared *shared);
    /* True for codecs that keep one base id per leaf instead of an id per triangle: the
     * ids handed to encode() are then consecutive (ids[k] == ids[0] + k), because the tree
     * is built over the mesh's triangles permuted into leaf order, and the accel maps a
     * hit back to the mesh id through bvh_shared.mesh_ids (docs/design-changes.md). */
    bool seq_ids;
    /* Codecs whose leaves index a buffer laid out in leaf order (Indexed8's 8-bit windows,
     * Rouwé §3.9), instead of shared_build: build the shared data from m, whose triangles are
     * in leaf order (seq_ids) in a copy the codec may rewrite, replacing each vertex index by
     * the buffer position that encode() then stores; no leaf of the layout will hold more
     * than max_leaf triangles. NULL for the others. */
    prt_status (*shared_remap)(prt_mesh *m, uint32_t max_leaf, uint8_t **data, size_t *size);
    /* Lossy codecs: the largest distance between a vertex as decoded and the mesh's vertex,
     * kept in the shared data so it survives saving and loading. NULL: lossless. */
    double (*vertex_error)(const bvh_shared *shared);
    /* Lossy codecs without shared data (a grid per leaf or block): the largest distance
     * between a vertex of the leaf as decoded and its vertex in m, the mesh in leaf order
     * (seq_ids). The BVH family takes the maximum over every leaf of the encoded tree once
     * after building and keeps it in the META section. NULL for the others. */
    double (*leaf_error)(const uint8_t *leaf, uint32_t count, const prt_mesh *m);
    /* Codecs of BVH_KIND_CODECS: the kind of entries their leaves hold (Rouwé's strip
     * entries, bvh/leaf_kind.h), through which the BVH family rewrites the tree for them and
     * keeps their shared data; NULL for runs of triangles. strips: leaves != NULL (the
     * strip kinds are the only ones), for the walks that rotate triangles back. */
    const struct bvh_leaf_kind *leaves;
    bool strips;
    /* The triangles of a leaf of count entries (as the layout's kernels hand them to this
     * codec), exactly as its kernels test them: 9 floats each in v (the decoded vertices, in
     * the order the kernel's watertight test takes them) and in ids what the kernel reports as
     * hit.prim for each (leaf-order ids for seq_ids codecs, strip triangle numbers for strip
     * codecs); padding is skipped. Returns the number written, at most BVH_DECODE_MAX. For the
     * generic walks (bvh/walk.c), which answer point and all-hits queries. */
    uint32_t (*decode)(const uint8_t *leaf, uint32_t count, const bvh_shared *sh, float *v, uint32_t *ids);
    /* Codecs with a grid per leaf or block: the most steps a grid holds (2^bits - 1). The
     * BVH family then rounds the mesh to one lattice per tree before building
     * (codecs/lattice.h), so that shared vertices decode alike in every leaf. 0: none. */
    uint32_t lattice;
} bvh_codec;

/* Most triangles one leaf decodes to (bvh_codec.decode): every BVH codec decodes at most
 * one triangle per entry of the count it is handed, and no layout hands more than
 * BVH_MAX_LEAF (16, bvh.h; strip leaves hold at most 16 entries) to a validated leaf;
 * lossygrid's leaves (lossygrid/decode.c) hold up to 4 records of 32 triangles. */
#define BVH_DECODE_MAX 128

/* The (block-padded) count of a leaf of codec c that is `bytes` long, for layouts that
 * keep a leaf's size rather than its count (leaf sizes are affine in blocks, above). */
static inline uint32_t bvh_leaf_count_of(const bvh_codec *c, size_t bytes) {
    const size_t head = c->leaf_bytes(0), per = c->leaf_bytes((uint32_t)c->block) - head;
    return (uint32_t)((bytes - head) / per) * (uint32_t)c->block;
}

extern const bvh_codec bvh_codecs[BVH_CODEC_COUNT];

/* Codec id by name, or -1. */
int bvh_codec_find(const char *name);

#endif
