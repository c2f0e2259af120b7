/* What the lossygrid files share: building the blob of wide8 nodes over 128-byte records,
 * checking a loaded one, and the traversal entry points. */
#ifndef PRT_LOSSYGRID_LOSSYGRID_H
#define PRT_LOSSYGRID_LOSSYGRID_H

#include "bvh/bvh.h"
#include "lossygrid/displacement.h"

#define LG_MAX_LEAF 4 /* records per leaf */

typedef struct lg_build_params {
    int enc;  /* LG_ENC_OCT or LG_ENC_EXP */
    int leaf; /* records per leaf, 1..LG_MAX_LEAF */
    int threads;
} lg_build_params;

/* What a build measured, for stats and the results tables (Benthin's Tables 1 and 3). */
typedef struct lg_build_report {
    size_t triangles; /* hittable triangles = accel positions */
    size_t grids, subgrids, grid_triangles;
    size_t tri_records, loose_triangles;
    double vertex_error;                 /* largest distance of a decoded grid vertex from the mesh's */
    double rms_error;                    /* over every sub-grid vertex */
    double rel_error_avg, rel_error_max; /* per sub-grid: its largest error / its box diagonal */
    size_t distinct_corners;             /* mesh vertices that are some sub-grid's corner (§9's sharing) */
    float bounds[6];
} lg_build_report;

/* Build the records and the wide8 blob over them. *order: on entry the caller's array for
 * the position-to-mesh-id map (ids=none) or NULL to have one allocated; on return the map. */
prt_status lg_build_blob(const prt_mesh *m, const lg_build_params *p, bvh_blob *blob, uint32_t **order,
                         lg_build_report *report);

/* How many records lg_build_blob would make of m (sub-grids and clusters of the other
 * triangles), without encoding them (prt_estimate). */
prt_status lg_count_records(const prt_mesh *m, int threads, size_t *records);

/* Check a loaded blob: nodes as wide8_check does, every record well formed and naming
 * positions below sh->triangles. */
prt_status lg_blob_check(const bvh_blob *b, const bvh_shared *sh);

/* Closest and any hit (traverse.c); hits name accel positions. */
void lg_trace1(const uint8_t *blob, const bvh_shared *sh, prt_ray *r, prt_hit *h);

/* The triangles of a leaf of count records, in the mesh's vertex order, with their accel
 * positions (bvh_codec.decode's contract, lossygrid/decode.c): for the mesh queries. */
uint32_t lg_record_triangles(const uint8_t *leaf, uint32_t count, const bvh_shared *sh, float *v, uint32_t *ids);
bool lg_trace_any(const uint8_t *blob, const bvh_shared *sh, const prt_ray *r);
/* lg_trace1 for n rays (invalid ones a miss), four walks interleaved by the wide8
 * walk's stream; every answer is lg_trace1's bit for bit. */
void lg_trace_stream(const uint8_t *blob, const bvh_shared *sh, prt_ray *rays, prt_hit *hits, size_t n);

/* Closest hits of n <= PRT_PACKET_MAX coherent rays traced together (wide8_packet.inc:
 * slices of one octant, each wide8 node's child boxes decoded once for a slice and each
 * record once for the rays that reach it; invalid rays miss); every answer is lg_trace1's
 * bit for bit (the same box and triangle operations for each ray, and ties at equal t go
 * to the smaller id whatever the visit order). */
void lg_trace_packet(const uint8_t *blob, const bvh_shared *sh, prt_ray *rays, prt_hit *hits, uint32_t n);

/* Any hit for n <= PRT_PACKET_MAX rays traced together (shadow rays of a tile), as
 * lg_trace_packet; occluded[i] is lg_trace_any's answer for ray i (0 for an invalid ray). */
void lg_occlude_packet(const uint8_t *blob, const bvh_shared *sh, const prt_ray *rays, uint8_t *occluded, uint32_t n);

#endif
