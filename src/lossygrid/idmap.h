/* The map from accel positions to mesh triangles (ids=mesh) in about 2.1 bytes a triangle
 * instead of 4: positions come in blocks of 32, each with a base id and a 16-bit delta per
 * position. Positions follow the records, and a record's triangles are neighbours in most
 * meshes' order, so a block's ids nearly always span fewer than 65536; a block that does
 * not ("wide") keeps its 32 ids in full. Section IDMP (docs/formats.md): u32 blocks, u32
 * wide blocks, 8 reserved bytes, u32 base per block (bit 31 set: the index of its wide
 * block), u16 delta per position of every block, u32 32 ids per wide block. */
#ifndef PRT_LOSSYGRID_IDMAP_H
#define PRT_LOSSYGRID_IDMAP_H

#include "core/common.h"

#define LG_IDMAP_WIDE 0x80000000u

typedef struct lg_idmap {
    const uint32_t *base;
    const uint16_t *delta;
    const uint32_t *wide;
    uint32_t blocks, wide_blocks;
} lg_idmap;

static inline uint32_t lg_idmap_get(const lg_idmap *m, uint32_t p) {
    const uint32_t b = m->base[p >> 5];
    return b & LG_IDMAP_WIDE ? m->wide[32 * (size_t)(b & ~LG_IDMAP_WIDE) + (p & 31)] : b + m->delta[p];
}

/* The bvh_shared.map_id of a lossygrid accel. */
uint32_t lg_idmap_lookup(const void *map, uint32_t p);

/* Encode ids[0 .. n) into a new section image (prt__free it). */
prt_status lg_idmap_build(const uint32_t *ids, size_t n, uint8_t **data, size_t *size);

/* Check a section image of n positions and point a map into it. */
prt_status lg_idmap_open(const void *data, size_t size, size_t n, lg_idmap *out);

#endif
