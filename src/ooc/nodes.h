/* Readers of the block file's node and triangle records (ooc.h, docs/formats-ooc.md),
 * shared by the ray walk (traverse.c) and the mesh queries' walk (query.c): one decoder of
 * each record. Every read is checked against its block's size; a failed check answers
 * false (or NULL), and counting it as a failure is the caller's. */
#ifndef PRT_OOC_NODES_H
#define PRT_OOC_NODES_H

#include "ooc/ooc_accel.h"

#include <stddef.h>

/* True when block b exists, is of this kind and holds bytes (else a corrupt reference). */
static inline bool ooc_block_is(const ooc_cache *c, uint32_t b, uint32_t kind) {
    return b < c->nblocks && c->table[b].kind == kind && c->table[b].raw != 0;
}

/* An inner node's split axis and plane (w0, w1 its two words): false for a corrupt axis or
 * a path deeper than any the builder writes. */
static inline bool ooc_inner_plane(uint32_t w0, uint32_t w1, int depth, int *axis, float *split) {
    *axis = (int)(w0 & 3);
    memcpy(split, &w1, 4);
    return *axis != 3 && depth < OOC_MAX_DEPTH;
}

/* An inner node's children: offsets from base (the node itself, or the start of the child
 * block after a LOD node) and which of the two exist. */
static inline void ooc_inner_children(uint32_t w0, uint32_t base, uint32_t kid[2], bool has[2]) {
    kid[0] = base + (w0 & 0xFFFC), kid[1] = kid[0] + 4 * ((w0 >> 18) & 0x7FF);
    has[0] = (w0 & OOC_LEFT) != 0, has[1] = (w0 & OOC_RIGHT) != 0;
}

/* A LOD node at off of block blk (size bytes): its voxel's radius, the block of its
 * children and where its voxel starts (not checked: it may lie past the block). False
 * when the node does not fit the block. */
static inline bool ooc_lod_node(const uint8_t *blk, uint32_t size, uint32_t off, float *radius, uint32_t *child_block,
                                uint32_t *vox_off) {
    if (off + 16 > size) return false;
    uint32_t w3;
    memcpy(radius, blk + off + 8, 4);
    memcpy(&w3, blk + off + 12, 4);
    *vox_off = off + 4 * (w3 >> 26);
    *child_block = w3 & ((1u << 26) - 1);
    return true;
}

/* A leaf's view of its triangle block: its list of n triangle indices, and the block's
 * triangle records (ntri) and vertices (nvert). */
typedef struct ooc_leaf {
    const uint8_t *list, *tris, *verts;
    uint32_t n, ntri, nvert;
} ooc_leaf;

/* The leaf w0 (its first word) in triangle block p of size bytes, whose section offsets
 * the cache checked when it loaded the block. A count over 255 is stored as the list's
 * first entry. False when the list does not fit the block's list section. */
static inline bool ooc_leaf_open(const uint8_t *p, uint32_t size, uint32_t w0, ooc_leaf *l) {
    uint16_t sec[2];
    memcpy(sec, p, 4);
    uint32_t list = w0 & 0xFFFF, n = (w0 >> 16) & 0xFF;
    l->ntri = (uint32_t)(sec[1] - sec[0]) / sizeof(ooc_tri), l->nvert = (size - sec[1]) / 12;
    l->tris = p + sec[0], l->verts = p + sec[1];
    if (n == 0) {
        uint16_t n16 = 0;
        if (list + 2 <= sec[0]) memcpy(&n16, p + list, 2);
        n = n16, list += 2;
    }
    l->list = p + list, l->n = n;
    return list + 2 * n <= sec[0];
}

/* The record of the leaf's j-th triangle (j < l->n), its vertices' 12 bytes at vert[0..2]:
 * NULL for an index past the block's triangles or vertices. */
static inline const uint8_t *ooc_leaf_tri(const ooc_leaf *l, uint32_t j, const uint8_t *vert[3]) {
    uint16_t ti, v[3];
    memcpy(&ti, l->list + 2 * j, 2);
    if (ti >= l->ntri) return NULL;
    const uint8_t *tp = l->tris + (size_t)ti * sizeof(ooc_tri);
    memcpy(v, tp, sizeof v);
    if (v[0] >= l->nvert || v[1] >= l->nvert || v[2] >= l->nvert) return NULL;
    for (int k = 0; k < 3; k++) vert[k] = l->verts + 12u * v[k];
    return tp;
}

/* Ask for the leaf's triangle records at once: each is a load that depends on the list, and
 * their vertices on them; asked together they arrive together. */
static inline void ooc_leaf_prefetch(const ooc_leaf *l) {
    for (uint32_t j = 0; j < l->n; j++) {
        uint16_t ti;
        memcpy(&ti, l->list + 2 * j, 2);
        if (ti < l->ntri) __builtin_prefetch(l->tris + (size_t)ti * sizeof(ooc_tri));
    }
}

#endif
