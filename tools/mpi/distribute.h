/* packrt-mpi's distributed frame (tools/mpi/distribute.c): the tiles of one render_frame dealt
 * to the ranks of MPI_COMM_WORLD in super-tiles, rendered there, and the pixels gathered to
 * rank 0. Only the thread that calls these calls MPI (MPI_THREAD_FUNNELED). */
#ifndef PRT_TOOLS_MPI_DISTRIBUTE_H
#define PRT_TOOLS_MPI_DISTRIBUTE_H

#include "render/render.h"

#include <stdbool.h>
#include <stdint.h>

typedef enum dist_balance {
    DIST_STATIC,  /* super-tile s to rank s mod N (OSPRay's static balancer) */
    DIST_DYNAMIC, /* rank 0 hands out super-tiles one at a time as ranks finish them */
} dist_balance;

typedef struct dist_config {
    int rank, ranks;
    dist_balance balance;
    long super; /* tiles a super-tile (consecutive tiles of the renderer's tile order) */
} dist_config;

/* What one frame did. Per-super-tile arrays (rank 0 only, super_count entries, owned by the
 * caller through dist_stats_free): who rendered it and in how many seconds. */
typedef struct dist_stats {
    long super_count;
    int *owner;
    double *seconds;           /* wall clock */
    double *cpu_seconds;       /* the rendering thread's CPU time (the cost, with --threads 1) */
    uint64_t bytes_gathered;   /* rank 0: payload bytes received from the other ranks */
    uint64_t bytes_own;        /* rank 0: its own tiles' payload (copied, not sent) */
    uint64_t rays;             /* rays cast by all ranks */
    double render_s, gather_s; /* rank 0: its rendering (and queue) time, then waiting for pixels */
} dist_stats;

/* Render frame f (after render_frame_begin on every rank with the same arguments) across the
 * ranks and finish it: on rank 0, f->img holds the frame exactly as prt_render would give it
 * (gi's filter and composition run after the gather, on rank 0); on the other ranks f->img is
 * scratch. f's buffers are freed. Collective. Returns PRT_OK or the status of
 * render_frame_end (the same on all ranks except for a failed allocation). */
prt_status dist_frame(render_frame *f, const dist_config *c, dist_stats *st);
void dist_stats_free(dist_stats *st);

#endif
