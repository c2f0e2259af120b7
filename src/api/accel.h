/* The representation interface (DESIGN.md §3): every representation fills one
 * prt_accel_ops table and embeds struct prt_accel as its first member. The API layer
 * (api/accel.c) validates and dispatches; nothing above it knows which representation
 * it holds. */
#ifndef PRT_API_ACCEL_H
#define PRT_API_ACCEL_H

#include "core/common.h"
#include "core/spec.h"
#include "io/prt_file.h"

struct prt__query;

typedef struct prt_accel_ops {
    const char *name; /* family name, for messages */
    /* Build from a validated mesh; spec options not read are reported by the caller. */
    prt_status (*build)(const prt_mesh *m, prt_spec *spec, const prt_build_options *o, prt_accel **out);
    void (*intersect1)(const prt_accel *a, prt_ray *r, prt_hit *h);
    bool (*occluded1)(const prt_accel *a, const prt_ray *r);
    void (*intersect_packet)(const prt_accel *a, prt_packet *p); /* NULL: generic fallback */
    /* prt_intersect_stream's rays on one thread (invalid ones included: a miss, as
     * prt_intersect1 answers them), with the answers of intersect1; NULL: intersect1 per
     * ray. For representations that trace several incoherent rays at once. */
    void (*intersect_stream)(const prt_accel *a, prt_ray *rays, prt_hit *hits, size_t n);
    /* prt_occluded_packet for p->count <= PRT_PACKET_MAX rays (not yet checked for
     * validity); NULL: prt_occluded1 per ray. */
    void (*occluded_packet)(const prt_accel *a, const prt_packet *p, uint8_t *occluded);
    void (*stats)(const prt_accel *a, prt_stats *s);             /* fills bytes, nodes, leaves, depth */
    prt_status (*save)(const prt_accel *a, prt_writer *w);
    /* Load from a checked container; sections point into memory that outlives the accel. */
    prt_status (*load)(prt_reader *r, prt_spec *spec, prt_accel **out);
    void (*destroy)(prt_accel *a);
    /* Rebuild in place from new positions of the same vertices (prt_accel_update): the
     * array holds 3 floats per vertex of the mesh the accel was built from. NULL: the
     * representation cannot update; prt_accel_update says so. */
    prt_status (*update)(prt_accel *a, const float *vertices);
    /* Representations stored in a format of their own rather than a .prt container (ooc's
     * block file): write it to path. NULL: save() into a container. */
    prt_status (*save_file)(const prt_accel *a, const char *path);
    /* Level-of-detail queries (prt_intersect_lod, prt_occluded_lod); NULL: exact queries. */
    bool (*lod_query)(const prt_accel *a, prt_ray *r, float error, bool any, prt_lod_hit *h);
    /* prt_intersect_lod_packet (rays already checked); NULL: one lod_query per ray. */
    void (*lod_packet)(const prt_accel *a, prt_ray *rays, prt_lod_hit *h, uint32_t n, float error);
    /* prt_occluded_lod_packet (rays already checked); NULL: one any-hit lod_query per ray. */
    void (*lod_occluded_packet)(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, uint32_t n, float error);
    /* The cache update between frames (prt_accel_frame); NULL: nothing to do. */
    void (*frame)(prt_accel *a, prt_cache_info *info);
    /* Failures met by queries so far (prt_accel_check); NULL: none possible. */
    prt_status (*check)(const prt_accel *a);
    /* The mesh queries' walk (api/query.h): hand q->leaf the triangles of every part q does
     * not cull. NULL: the family answers no such query (prt_intersect_all and the others
     * say so). */
    void (*query)(const prt_accel *a, struct prt__query *q);
} prt_accel_ops;

struct prt_accel {
    const prt_accel_ops *ops;
    char spec[PRT_FILE_SPEC_BYTES]; /* canonical spec string */
    float bounds[6];                /* lo xyz, hi xyz of the built triangles */
    size_t triangles;               /* mesh triangles (degenerate included) */
    size_t triangles_built;         /* triangles that can be hit */
    double build_seconds;
    size_t build_peak_bytes;
    void *file_mapping; /* owned mapping (or aligned copy) of a loaded .prt file, or NULL */
    size_t file_mapping_size;
    bool file_mapping_is_copy; /* prt__free it rather than munmap */
};

/* prt_accel_update's check of new positions, for the representations' update ops: count
 * floats, each finite (else PRT_ERROR_MESH) and within +-PRT_MAX_COORDINATE (else
 * PRT_ERROR_LIMIT), the first bad one named. */
prt_status prt__check_update_vertices(const float *vertices, size_t count);

/* A registered representation family and the names it answers to. */
typedef struct prt_repr_family {
    const prt_accel_ops *ops;
    /* True when this family builds `spec` (structure and codec names). */
    bool (*accepts)(const prt_spec *spec);
    /* i-th full name and description of this family; false past the end. */
    bool (*name_at)(size_t i, const char **name, const char **description);
} prt_repr_family;

/* Open an accel over a .prt image in memory (64-byte aligned, kept alive by the caller).
 * verify_crc=false skips the checksums so fuzzing reaches the structural checks. */
prt_status prt__accel_open(const void *data, size_t size, bool verify_crc, prt_accel **out);

/* Family that accepts spec, or NULL with an error message naming the valid ones. */
const prt_repr_family *prt__registry_find(const prt_spec *spec);

#endif
