/* Coherent grid traversal (Wald, Ize, Kensler, Knoll, Parker 2006): a uniform grid of
 * cubic cells rebuilt from scratch every frame (build.c), one coarser level of macrocells
 * (build.c), a single-ray 3D-DDA (dda.c), slice-by-slice frustum packets with mailboxing
 * and frustum culling (frustum.c), and the prt_accel glue with save/load (cgrid_accel.c).
 * docs/cgrid.md describes the design. */
#ifndef PRT_CGRID_CGRID_H
#define PRT_CGRID_CGRID_H

#include "api/accel.h"
#include "geom/ray.h"

/* Triangles are inserted into every cell their bounding box, grown by this many cells on
 * each side, overlaps: points within it of a cell boundary belong to both cells, which
 * covers the rounding of the traversal's plane distances (docs/cgrid.md, robustness). */
#define CG_INSERT_MARGIN 4e-3f
/* Traversal overlap boxes are grown by this many cells before truncation. */
#define CG_TRAVERSE_MARGIN 1e-3f
/* The build refuses grids beyond this many cells (the resolution is lowered instead). */
#define CG_MAX_CELLS (1u << 26)
#define CG_MAX_RES 4096u
/* Triangles per build thread at least (build.c). */
#define CG_BUILD_GRAIN 32768u

/* min / max that compile to one instruction (fminf / fmaxf are library calls unless NaNs
 * are ruled out by flags); a NaN in a gives b. */
static inline float cg_min(float a, float b) { return a < b ? a : b; }
static inline float cg_max(float a, float b) { return a > b ? a : b; }

/* One frame's grid. Arrays are owned by the accel's pool (built or updated) or point into
 * a loaded file. */
typedef struct cg_grid {
    float lo[3];      /* world position of the grid corner */
    float cell;       /* edge of a cubic cell (world units) */
    float inv_cell;   /* grid coordinate of p: (p - lo) * inv_cell */
    uint32_t res[3];  /* cells per axis */
    uint32_t macro;   /* M: a macrocell is M x M x M cells; 0 for none */
    uint32_t mres[3]; /* macrocells per axis */
    size_t ncells, nrefs, nmacro;
    const uint32_t *cell_start; /* ncells + 1: refs of cell c are refs[cell_start[c] .. cell_start[c+1]) */
    const uint32_t *refs;       /* mesh triangle ids */
    const uint8_t *mflags;      /* nmacro: 1 when any cell below is occupied */
    const float *tris;          /* 9 floats per mesh triangle: v0, v1, v2 */
    const struct cg_wald *wald; /* tri=wald: Wald's precomputed test data per triangle, else NULL */
} cg_grid;

/* Query options (spec keys). */
typedef struct cg_options {
    int lambda;  /* cells per triangle */
    int macro;   /* macrocell size M, 0 for none */
    int packet;  /* 0: trace the caller's packets as given; 1: single rays; N: N x N sub-packets */
    int mailbox; /* per-packet mailboxing */
    int cull;    /* per-packet frustum culling of triangles */
    int tri;     /* 0: the watertight test; 1: Wald's precomputed projection test (wald_tri.h) */
    int spread;  /* shadow packets whose hit points spread over more cells are split (§4.6); 0: never */
} cg_options;

typedef struct cg_file_header {
    float lo[3], cell, inv_cell;
    uint32_t res[3], macro, reserved0;
    uint64_t ncells, nrefs, ntris, nverts;
    uint32_t reserved[2];
} cg_file_header; /* the CGHD section */

/* Pooled buffers reused from frame to frame: they only grow. */
typedef struct cg_pool {
    uint32_t *cell_start;
    uint32_t *refs;
    uint8_t *mflags;
    float *tris;
    uint16_t *ranges; /* build scratch: each triangle's cell range */
    void *scratch;    /* build scratch: per-thread bounds and z-slice counts (build.c) */
    struct cg_wald *wald;
    size_t cap_wald;
    size_t cap_cells, cap_refs, cap_macro, cap_tris, cap_ranges, cap_scratch;
} cg_pool;

typedef struct cg_accel {
    prt_accel base;
    cg_grid g;
    cg_options opt;
    cg_pool pool;
    const uint32_t *indices; /* 3 per triangle: what update() rebuilds from */
    uint32_t *indices_owned;
    size_t ntris, nverts;
    int threads;
    struct cg_file_header header; /* what save() writes, kept until the file is written */
} cg_accel;

/* Counters for the paper's Tables 1, 3 and 4, per calling thread (a query never touches
 * another thread's): cells visited, ray-triangle tests, packets traced, rays traced by
 * the single-ray DDA. */
typedef struct cg_counters {
    uint64_t cells, tests, packets, dda_rays, culled, mailboxed, slices, macro_skips;
} cg_counters;
extern _Thread_local cg_counters prt__cg_counters;

/* Macrocell flags of c->g (cells already in place) into the pool. */
prt_status cg_macro_flags(cg_accel *c, int threads);

/* tri=wald: Wald's test data of c->g.tris into the pool (g->wald); else nothing. */
prt_status cg_wald_rebuild(cg_accel *c, int threads);

/* Rebuild c->g from vertex positions (c->indices, c->ntris, c->nverts set) into the pool. */
prt_status cg_rebuild(cg_accel *c, const float *vertices, int threads);

/* The grid cg_rebuild would make of m (resolution, macrocells, reference count) and the
 * triangles it would insert, without storing one reference: its passes A and B, on one
 * thread (prt_estimate). */
prt_status cg_count(const prt_mesh *m, int lambda, uint32_t macro, cg_grid *g, size_t *built);

/* Bytes of a grid over ntris triangles (wald: with Wald's test data), as prt_stats counts them. */
static inline void cg_bytes(const cg_grid *g, size_t ntris, bool wald, prt_stats *s) {
    s->bytes_tree = 4 * (g->ncells + 1) + g->nmacro;
    s->bytes_geometry = 4 * g->nrefs + 36 * ntris + (wald ? 48 * ntris : 0);
    s->bytes_other = 12 * ntris + sizeof(cg_accel);
}

/* Single-ray DDA (Amanatides-Woo). */
void cg_intersect1(const prt_accel *a, prt_ray *r, prt_hit *h);
bool cg_occluded1(const prt_accel *a, const prt_ray *r);
/* Closest hit of one valid ray by DDA; hit.t = tfar, prim = PRT_INVALID on entry. */
void cg_dda_closest(const cg_grid *g, const prt_ray *r, prt__hitx *hit);

/* Frustum packet traversal (prt_accel_ops.intersect_packet). */
void cg_intersect_packet(const prt_accel *a, prt_packet *p);
/* Shadow packets, any hit per ray (prt_accel_ops.occluded_packet; shadow.c). */
void cg_occluded_packet(const prt_accel *a, const prt_packet *p, uint8_t *occluded);

/* Stats and counters for tools (bench, tests): reset and read the calling thread's. */
void prt__cgrid_counters_reset(void);
cg_counters prt__cgrid_counters_get(void);

#endif
