/* Marching cubes (Lorensen & Cline 1987): the case table, derived at run time from a
 * face-walking rule rather than typed in, and the cell/edge numbering the extractors share. */
#ifndef PRT_MESH_MARCHING_CUBES_H
#define PRT_MESH_MARCHING_CUBES_H

#include <stdint.h>

/* Cell corner c sits at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1) from the cell origin.
 * Edge e runs along axis e >> 2 from the corner whose other two coordinates are
 * (e & 1, (e >> 1) & 1), taken in increasing axis order: x edges vary (y, z), y edges
 * vary (x, z), z edges vary (x, y). So an edge is named by its axis and its origin
 * offset, which is how extractors turn it into a global grid edge. */
#define GEN_MC_MAX_TRIS 5

typedef struct gen_mc_table {
    uint8_t count[256];                      /* triangles for each inside-corner mask */
    uint8_t edges[256][3 * GEN_MC_MAX_TRIS]; /* edge ids, three per triangle */
} gen_mc_table;

/* Origin offset (o[0..2] in {0, 1}) and axis of edge e. */
static inline int gen_mc_edge_axis(int e) { return e >> 2; }
static inline void gen_mc_edge_origin(int e, int o[3]) {
    int a = e >> 2, u = a == 0 ? 1 : 0, v = a == 2 ? 1 : 2;
    o[a] = 0;
    o[u] = e & 1;
    o[v] = (e >> 1) & 1;
}

/* Fill t. Case mask bit c is set when corner c is inside (field < 0). Triangles wind
 * counter-clockwise seen from outside, so their normals point from inside to outside.
 * Ambiguous faces always separate the inside corners; since the rule depends only on the
 * four corner signs of the face, the two cells sharing a face agree and the surface has
 * no cracks. */
void gen_mc_table_build(gen_mc_table *t);

/* Where the surface crosses an edge whose end values are f0 < 0 <= f1 or the reverse:
 * the linear-interpolation parameter, kept off the end points so that no triangle
 * collapses onto a grid sample (which would make zero-area triangles). */
static inline float gen_mc_crossing(float f0, float f1) {
    float t = f0 / (f0 - f1);
    const float lo = 1.0f / 256, hi = 255.0f / 256;
    return t < lo ? lo : (t > hi ? hi : t);
}

#endif
