/* Internals of the sparse marching cubes shared by isosurface.c (bricks, flood fill, the
 * in-memory mesh, the triangle stream) and iso_spill.c (the indexed surface written through
 * a temporary file): the brick record, the flood fill driver and edge resolution. */
#ifndef PRT_MESH_ISO_BRICK_H
#define PRT_MESH_ISO_BRICK_H

#include "mesh/isosurface.h"
#include "mesh/marching_cubes.h"

#define ISO_S (GEN_BRICK + 1)                                 /* samples per brick side */
#define ISO_OWN_SLOTS (3 * GEN_BRICK * GEN_BRICK * GEN_BRICK) /* edges a brick owns */
#define ISO_OWN_WORDS ((ISO_OWN_SLOTS + 63) / 64)
#define ISO_MAX_BRICK_TRIS (GEN_BRICK * GEN_BRICK * GEN_BRICK * GEN_MC_MAX_TRIS)

/* The extracted piece of one brick. It owns the grid edges whose lower end lies in its
 * half-open box [0, B)^3 and stores the vertices of those that the surface crosses, in
 * slot order (slot = ((axis * B + z) * B + y) * B + x); its triangles name edges by
 * "extended slot" (axis * S^3 + (z * S + y) * S + x with x, y, z in 0..B), which may belong
 * to the +x/+y/+z neighbours. */
typedef struct iso_brick {
    uint32_t id, nvert, ntri;
    uint64_t owned[ISO_OWN_WORDS];
    uint16_t rank[ISO_OWN_WORDS]; /* owned crossings in the words before this one */
    float *vert;
    uint16_t *tri;
} iso_brick;

/* What the flood fill makes of each brick it visits. */
typedef enum iso_mode {
    ISO_COUNT,   /* triangle counts only */
    ISO_RECORDS, /* an iso_brick record (one allocation: prt__free(rec)) */
    ISO_SOUP     /* the triangles' corner positions, 9 floats a triangle (prt__free(soup)) */
} iso_mode;

typedef struct iso_brick_out {
    uint32_t id, ntri;
    iso_brick *rec; /* ISO_RECORDS, NULL for a brick without triangles */
    float *soup;    /* ISO_SOUP, NULL for a brick without triangles */
} iso_brick_out;

/* Receives the visited bricks group by group, in the flood fill's order: breadth-first
 * rounds, the bricks of a round in the order they were found (seeds in octree order), the
 * same whatever the thread count. It may take rec / soup (setting them NULL); what is left
 * is freed after the call. Anything but PRT_OK stops the flood fill with that status. */
typedef prt_status (*iso_brick_fn)(void *user, iso_brick_out *bricks, size_t n);

/* Flood fill the surface of p from the seeds, extracting at most `group` bricks at a time
 * (0: a whole round at once) and handing each group to fn. *triangles: the total. */
prt_status iso_flood(const gen_iso_params *p, iso_mode mode, size_t group, iso_brick_fn fn, void *user,
                     uint64_t *triangles);

/* Bricks per side of p's grid. */
PRT_INLINE uint32_t iso_bricks_per_side(const gen_iso_params *p) { return (p->resolution + GEN_BRICK - 1) / GEN_BRICK; }

/* Split extended slot e: which of the owners (o = dx | dy << 1 | dz << 2: the brick itself
 * or a +x/+y/+z neighbour) owns the edge, and its slot there. */
PRT_INLINE void iso_edge_owner(int e, int *o, int *slot) {
    const int b = GEN_BRICK, s = ISO_S;
    int x = e % s, y = e / s % s, z = e / (s * s) % s, a = e / (s * s * s);
    *o = (x == b) | (y == b) << 1 | (z == b) << 2;
    *slot = ((a * b + (z & (b - 1))) * b + (y & (b - 1))) * b + (x & (b - 1));
}

PRT_INLINE bool iso_owns(const uint64_t *owned, int slot) { return owned[slot >> 6] >> (slot & 63) & 1; }

/* Index of an owned slot among the brick's vertices. */
PRT_INLINE uint32_t iso_owned_rank(const uint64_t *owned, const uint16_t *rank, int slot) {
    int w = slot >> 6;
    uint64_t below = owned[w] & ((1ull << (slot & 63)) - 1);
    return rank[w] + (uint32_t)__builtin_popcountll(below);
}

#endif
