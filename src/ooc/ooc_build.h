/* The out-of-core builder's entry point (build.c): a producer pushes the triangles of a
 * mesh of any size (a prt_mesh, a PLY on disk, a generator) into the builder's sink. */
#ifndef PRT_OOC_BUILD_H
#define PRT_OOC_BUILD_H

#include "mesh/iso_bricks.h"
#include "ooc/ooc.h"

/* Calls sink(sink_user, ...) with every batch of the mesh, in order; returns the first
 * non-PRT_OK status of the sink or its own failure. */
typedef prt_status (*tri_producer_fn)(void *ctx, tri_sink_fn sink, void *sink_user);

typedef struct ooc_build_job {
    ooc_build_params params;
    const char *out_path;   /* the block file; NULL: build an image in memory */
    const char *tmp_prefix; /* temporary files are tmp_prefix.tmpN */
    uint64_t memory_budget; /* bytes the build may hold (0: 4 GiB) */
    uint64_t expected;      /* triangles, when known up front (0: unknown): a mesh that fits
                             * the budget is then held in memory, without temporary files */
    bool sift_generated;    /* ooc_build_generated: spool and sift the generator's stream as
                             * any other source's instead of splitting its bricks */
    void (*progress)(void *user, float fraction);
    void *progress_user;
} ooc_build_job;

/* A procedural source split by bricks instead of spooled (ooc_build_bricks): every
 * triangle of brick `id` lies in the brick's closed box, and a brick's triangles can be
 * regenerated at any time, bit for bit (mesh/iso_bricks.h). */
typedef struct ooc_brick_source {
    /* Hand every brick that holds triangles to fn, in the stream's order (brick i's first
     * triangle has the id that is the sum of the counts before it); memory_budget bounds
     * the bricks in flight. */
    prt_status (*census)(void *ctx, size_t memory_budget, gen_iso_bricks_fn fn, void *user);
    /* Brick id's triangles into soup (max_brick_tris * 9 floats); the count. Thread-safe. */
    uint32_t (*regen)(void *ctx, uint32_t id, float *soup);
    uint32_t max_brick_tris;
    void *ctx;
} ooc_brick_source;

/* Build the block file from bricks: one census pass records each brick's triangle count
 * and box; the upper levels split the set of bricks (a brick goes wherever one of its
 * triangles could); a node within the budget regenerates its bricks' triangles, keeps
 * those that touch its cell and is built in core. No temporary files; the same triangles
 * (ids, positions) as ooc_build over the source's stream. Writes out_path. */
prt_status ooc_build_bricks(const ooc_brick_source *src, const ooc_build_job *job, ooc_header *h);

/* Build the block file. h receives the header as written (spec is the caller's to fill
 * before: it is copied into the file). For a memory build *image receives the file image
 * (prt__free it). */
prt_status ooc_build(tri_producer_fn produce, void *produce_ctx, const ooc_build_job *job, ooc_header *h, void **image,
                     size_t *image_size);

/* Build from a prt_mesh (in memory when it fits the budget), or stream a mesh file or a
 * generated kind; out_path NULL builds an image in memory. */
prt_status ooc_build_mesh(const prt_mesh *m, ooc_build_job *job, ooc_header *h, void **image, size_t *image_size);
prt_status ooc_build_file(const char *mesh_path, ooc_build_job *job, ooc_header *h);
prt_status ooc_build_generated(const char *kind, uint64_t triangles, uint64_t seed, ooc_build_job *job, ooc_header *h);

/* The spec's options (leaf, cut) into params, with the canonical spec written back. */
prt_status ooc_parse_spec(prt_spec *spec, ooc_build_params *p);

#endif
