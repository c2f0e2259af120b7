/* The out-of-core kd-tree with LOD voxels (Áfra 2012; docs/ooc.md, docs/formats-ooc.md):
 * the block file's records, the build tree, and the pieces that build, lay out, cache and
 * traverse it. Everything is little-endian, as the file is. */
#ifndef PRT_OOC_H
#define PRT_OOC_H

#include "api/accel.h"
#include "mesh/tri_stream.h"

#include <stdatomic.h>

/* --- The block file ------------------------------------------------------------------ */

#define OOC_MAGIC "PRTOOC1\n"
#define OOC_VERSION 1u
#define OOC_BLOCK 65536u                   /* raw (decompressed) block size, §4 */
#define OOC_HEADER_BYTES 256u              /* followed by the blocks; the block table is at the end */
#define OOC_MAX_BLOCKS (1u << 26)          /* block ids are 26 bits in LOD nodes: 4 TiB of blocks */
#define OOC_MAX_DEPTH 96                   /* kd depth limit (build and traversal stack) */
#define OOC_MAX_LEAF 255                   /* triangles a leaf can name (8-bit count, Table 4) */
#define OOC_LEVELS (OOC_MAX_DEPTH / 3 + 2) /* treelet levels */
#define OOC_TREELET_MAX 256                /* bytes: 7 nodes of at most 16 bytes and 4 voxels of 24 */

enum { OOC_BLOCK_NODES = 1, OOC_BLOCK_TRIS = 2 };

typedef struct ooc_header {
    char magic[8];
    uint32_t version;
    uint32_t block_size; /* OOC_BLOCK */
    uint32_t block_count;
    uint32_t root_block; /* the root treelet: block and byte offset */
    uint32_t root_offset;
    uint32_t depth;        /* kd-tree depth */
    uint64_t table_offset; /* file offset of block_count ooc_block_entry */
    uint64_t triangles, triangles_built;
    uint64_t raw_bytes[2]; /* decompressed bytes of node blocks and triangle blocks */
    uint64_t nodes, leaves, lod_nodes, voxel_samples;
    float bounds[6];
    double build_seconds;
    char spec[64];
    uint32_t table_crc;  /* crc32 of the block table */
    uint32_t header_crc; /* crc32 of this header up to here */
    uint8_t reserved[256 - 208];
} ooc_header;

typedef struct ooc_block_entry {
    uint64_t offset; /* file offset of the LZ4 data */
    uint32_t size;   /* compressed bytes; == raw when stored uncompressed */
    uint32_t raw;    /* decompressed bytes, <= OOC_BLOCK */
    uint32_t crc;    /* crc32 of the stored bytes */
    uint32_t kind;   /* OOC_BLOCK_NODES or OOC_BLOCK_TRIS */
} ooc_block_entry;

/* --- Node records (Tables 2-4, with the changes of docs/formats-ooc.md) ---------------
 * word 0 of an inner node: bits 0-1 split axis, 2-15 left child offset (bytes, a multiple
 * of 4: from this node in a basic node, from the start of the child block in a LOD node),
 * 16 left present, 17 right present, 18-28 (right - left offset) / 4, 29 LOD node, 31
 * inner (1). word 1: split position. LOD nodes add word 2: radius of the voxel's bounding
 * sphere, word 3: bits 0-25 child block, 26-31 voxel offset from this node / 4.
 * A leaf: word 0 bits 0-15 triangle list offset in its block, 16-23 count, 31 = 0;
 * word 1 the triangle block. */
#define OOC_INNER (1u << 31)
#define OOC_LOD (1u << 29)
#define OOC_LEFT (1u << 16)
#define OOC_RIGHT (1u << 17)

/* Triangle blocks (§4.6): a list section of u16 offsets, then 12-byte triangles (three
 * u16 vertex offsets, a 15-bit colour, and the mesh id), then 12-byte vertices. */
typedef struct ooc_tri {
    uint16_t v[3];
    uint16_t color; /* 5:5:5 RGB as Table 1 */
    uint32_t prim;
} ooc_tri;

/* Voxel samples (Table 1): 5:5:5 colour, normal on the cube (sign, axis, u, v), bit 31 set
 * on a 1-sample voxel. A 6-sample voxel stores -x, +x, -y, +y, -z, +z. */
uint32_t ooc_sample_pack(const float n[3], const float rgb[3], bool single);
void ooc_sample_unpack(uint32_t s, float n[3], float rgb[3]);
/* ooc_q31[j] = q / 31 for the 6-bit two's complement q of j (j for a 5-bit colour
 * channel), bit for bit the division. */
extern const float ooc_q31[64];

/* --- The build tree ------------------------------------------------------------------- */

/* What a node looks like from each of its six sides (-x, +x, -y, +y, -z, +z): the mean
 * normal (facing that side) and colour of what is seen, and the fraction of the side
 * covered. Leaves rasterise their triangles at one sample; inner nodes composite their
 * children front to back (docs/ooc.md). */
typedef struct ooc_look {
    float n[6][3];
    float rgb[6][3];
    float cover[6];
} ooc_look;

typedef struct ooc_bnode {
    float box[6];     /* the kd cell */
    int32_t child[2]; /* build node index, -1 when empty; both -1 for a leaf */
    uint8_t axis;
    float split;
    uint32_t first, count; /* leaf: range in the build's reference array */
} ooc_bnode;

/* A triangle as the builders hold it. */
typedef struct ooc_btri {
    float v[9];
    uint32_t prim;
    uint16_t color;
} ooc_btri;

typedef struct ooc_build_params {
    int leaf_max;    /* SAH leaves up to this many triangles (128, §4.1) */
    float empty_cut; /* empty-space cutting volume threshold (0.15) */
    int threads;
    int lz4hc; /* blocks' LZ4HC level 1-12; 0: the default (4); -1: plain LZ4 */
} ooc_build_params;

/* Build an in-core kd-tree over tris (cell = box) with SAH, empty-space cutting and the
 * leaf rules of §4.1. nodes[0] is the root. Refs index tris. */
typedef struct ooc_tree {
    ooc_bnode *nodes;
    size_t count, cap;
    uint32_t *refs;
    size_t nrefs, refcap;
    uint32_t depth;
} ooc_tree;

prt_status ooc_kd_build(const ooc_btri *tris, size_t n, const float box[6], uint32_t root_depth,
                        const ooc_build_params *p, ooc_tree *out);
void ooc_tree_free(ooc_tree *t);

/* Looks: one leaf's from its triangles; a node's from its children (split on axis). */
void ooc_look_leaf(ooc_look *l, const float box[6], const ooc_btri *tris, const uint32_t *refs, size_t n);
void ooc_look_compose(ooc_look *l, const float box[6], int axis, const ooc_look *lo, const float *lo_box,
                      const ooc_look *hi, const float *hi_box);
/* The voxel record of a look: 1 sample when the six agree within tolerance, else 6. */
int ooc_look_voxel(const ooc_look *l, uint32_t out[6]);

/* --- Writing blocks ------------------------------------------------------------------- */

/* The block writer: open node and triangle blocks filled as treelets and leaves arrive,
 * LZ4-compressed and appended to the output (a file or memory) when full. */
typedef struct ooc_writer ooc_writer;

/* A treelet laid out but not yet placed in a block: its parent LOD node places it beside
 * its sibling, since both children of a LOD node live in one block (§4.5). */
typedef struct ooc_pending {
    uint8_t bytes[OOC_TREELET_MAX];
    uint32_t size;
} ooc_pending;

/* The part of the tree above the next treelet boundary, while it is being assembled
 * bottom-up: inner nodes, leaves already written to triangle blocks (their 8-byte
 * record), and subtrees below the boundary already laid out as pending treelets. */
enum { OOC_F_INNER, OOC_F_LEAF, OOC_F_EXT };
typedef struct ooc_fnode {
    uint8_t kind;
    uint8_t axis;
    int8_t child[2]; /* fragment node index, -1 empty */
    float split;
    uint32_t rec[2]; /* a leaf's record */
    int ext;         /* OOC_F_EXT: index into frag->pend */
    float box[6];
    ooc_look look;
} ooc_fnode;

#define OOC_FRAG_NODES 15 /* 7 nodes of one treelet above 8 roots of the next */
typedef struct ooc_frag {
    ooc_fnode node[OOC_FRAG_NODES];
    int count; /* 0: an empty subtree; else node[0] is the root */
    ooc_pending pend[8];
    int npend;
} ooc_frag;

prt_status ooc_writer_open(ooc_writer **w, const char *path /* NULL: memory */);
/* The compression of the blocks written from now on: LZ4HC level 1-12, 0 the default
 * (4), -1 plain LZ4 (ooc_build_params.lz4hc). */
void ooc_writer_set_level(ooc_writer *w, int lz4hc);
/* A leaf of n triangles (refs into tris) in cell box at kd depth `depth`: written to the
 * open triangle block (a treelet of its own at a treelet root level). */
prt_status ooc_writer_leaf(ooc_writer *w, uint32_t depth, const ooc_btri *tris, const uint32_t *refs, uint32_t n,
                           const float box[6], ooc_frag *out);
/* An inner node at kd depth `depth` over two fragments (either may be empty): when depth
 * is a treelet root level (a multiple of 3) the treelet is laid out and the result is a
 * single pending subtree. */
prt_status ooc_writer_inner(ooc_writer *w, uint32_t depth, const float box[6], int axis, float split,
                            const ooc_frag *lo, const ooc_frag *hi, ooc_frag *out);
/* Lay out a whole in-core build tree whose root is at kd depth `depth`. */
prt_status ooc_writer_tree(ooc_writer *w, const ooc_tree *t, const ooc_btri *tris, uint32_t depth, ooc_frag *out);
/* Place the root and finish: header and block table written; for a memory writer the
 * image (64-byte aligned, prt__free it) goes to *image. info supplies the header fields the
 * writer does not know (bounds, counts, spec). */
prt_status ooc_writer_finish(ooc_writer *w, const ooc_frag *root, ooc_header *info, void **image, size_t *image_size);
void ooc_writer_free(ooc_writer *w);
/* CPU seconds spent compressing blocks so far. */
double ooc_writer_compress_seconds(const ooc_writer *w);

#endif
