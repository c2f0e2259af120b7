/* Mesh to vertex grids (Benthin et al., §3): triangle pairs merged into quads, quads grown
 * greedily into rectangular grids over the mesh's connectivity, grids cut into sub-grids of
 * at most 4x4 quads (5x5 vertices). Triangles that fit no grid are left loose. */
#ifndef PRT_LOSSYGRID_EXTRACT_H
#define PRT_LOSSYGRID_EXTRACT_H

#include "core/common.h"

#define LG_SUB 4 /* quads along a sub-grid side */

/* A sub-grid before compression. Grid vertex (i, j), i <= rx, j <= ry, is mesh vertex
 * v[5 j + i]. Cell (x, y) has corners C00 = (x, y), C10 = (x+1, y), C11 = (x+1, y+1),
 * C01 = (x, y+1), in the winding of the mesh, and two triangles: with diagonal bit
 * y * 4 + x clear (C00, C10, C11) and (C00, C11, C01), set (C00, C10, C01) and
 * (C10, C11, C01). Cell triangle k = 2 (y rx + x) + h is mesh triangle tri[k], whose
 * vertex 0 is the rot[k]-th vertex of the cell triangle (same winding, so the rest follow). */
typedef struct lg_source {
    uint32_t v[25];
    uint8_t rx, ry;
    uint16_t diag;
    uint32_t tri[32];
    uint8_t rot[32];
    uint32_t grid; /* the grid it was cut from, 0 .. grid_count - 1 */
} lg_source;

typedef struct lg_extraction {
    lg_source *subgrids;
    size_t subgrid_count;
    uint32_t *loose; /* hittable mesh triangles in no sub-grid */
    size_t loose_count;
    size_t grid_count;     /* grids that gave at least one sub-grid */
    size_t grid_triangles; /* triangles in sub-grids */
} lg_extraction;

/* Sub-grids of fewer quads go to exact records instead: a 2x2 sub-grid's 8 triangles over
 * 9 vertices fill one exact 128-byte record as well, losslessly and tested in one pass
 * rather than two rows (5 means at least 2x3; measured on the bunny: 14.0 B/tri against
 * 15.8 with 4 and 16.0 with 3). */
#define LG_MIN_QUADS 5

/* Extract grids from m; canon maps each vertex to its welded representative
 * (prt__mesh_weld), so duplicated vertices still connect. Degenerate triangles are
 * neither in a grid nor loose. */
prt_status lg_extract(const prt_mesh *m, const uint32_t *canon, lg_extraction *out);
void lg_extraction_free(lg_extraction *e);

#endif
