/* The representation interface (docs/extending.md): every representation fills one
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
    /* prt_occluded_stream's rays on one thread (invalid ones included: 0), as occluded1
     * answers them; NULL: occluded1 per ray. For representations that trace runs of
     * coherent rays (shadow rays in pixel order) together. */
    void (*occluded_stream)(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, size_t n);
    void (*stats)(const prt_accel *a, prt_stats *s); /* fills bytes, nodes, leaves, depth */
    prt_status (*save)(const prt_accel *a, prt_writer *w);
    /* Load from a checked container; sections point into memory that outlives the accel. */
    prt_status (*load)(prt_reader *r, prt_spec *spec, prt_accel **out);
    void (*destroy)(prt_accel *a);
    /* The mesh queries' walk (api/query.h): hand q->leaf the triangles of every part q does
     * not cull. NULL: the family answers no such query (prt_intersect_all and the others
     * say so). */
    void (*query)(const prt_accel *a, struct prt__query *q);
    /* What the family offers beyond the queries every family answers (below); NULL: none. */
    const struct prt_accel_caps *caps;
} prt_accel_ops;

/* Bytes of a file's start that a family's probe sees (fewer when the file is shorter). */
#define PRT_PROBE_BYTES 256

/* A named count of work (cells visited, triangle tests), for prt_accel_caps.counters. */
typedef struct prt_counter {
    const char *name;
    uint64_t value;
} prt_counter;
#define PRT_COUNTERS_MAX 16

/* Optional capabilities of a family, each found through the registry or the accel's ops
 * rather than by naming the family; a NULL member is a capability the family lacks, and
 * the API layer then answers as the comment says. */
struct prt__sample; /* api/estimate.h */

typedef struct prt_accel_caps {
    /* Own file format (instead of a .prt container, whose save/load the family then leaves
     * NULL). probe: true when these first bytes start such a file (prt_accel_load, _open and
     * _load_memory ask every family). open: an accel over the file in memory (mem, size;
     * fd < 0) or on disk (fd, size bytes; the accel owns fd on success, the caller closes it
     * on failure); name for messages; verify_crc=false skips checksums (fuzzing). save_file:
     * write the accel in that format. */
    bool (*probe)(const void *head, size_t n);
    prt_status (*open)(const void *mem, uint64_t size, int fd, const char *name, const prt_open_options *o,
                       bool verify_crc, prt_accel **out);
    prt_status (*save_file)(const prt_accel *a, const char *path);
    /* Streaming builds straight into a file, never holding the mesh (prt_build_file,
     * prt_build_generated); NULL: the mesh is loaded or generated, built, then saved. */
    prt_status (*build_file)(const char *mesh_path, prt_spec *spec, const char *out_path, const prt_build_options *o);
    prt_status (*build_generated)(const char *kind, uint64_t triangles, uint64_t seed, prt_spec *spec,
                                  const char *out_path, const prt_build_options *o);
    /* Level-of-detail queries (prt_intersect_lod, prt_occluded_lod); NULL: exact queries.
     * lod_packet (prt_intersect_lod_packet) and lod_occluded_packet (prt_occluded_lod_packet)
     * get rays already checked; NULL: one lod_query per ray. */
    bool (*lod_query)(const prt_accel *a, prt_ray *r, float error, bool any, prt_lod_hit *h);
    void (*lod_packet)(const prt_accel *a, prt_ray *rays, prt_lod_hit *h, uint32_t n, float error);
    void (*lod_occluded_packet)(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, uint32_t n, float error);
    /* A block cache with frames: the update between frames (prt_accel_frame; NULL: nothing
     * to do) and the failures its reads met so far (prt_accel_check; NULL: none possible). */
    void (*frame)(prt_accel *a, prt_cache_info *info);
    prt_status (*check)(const prt_accel *a);
    /* Refit: rebuild in place from new positions of the same vertices (prt_accel_update),
     * 3 floats per vertex of the mesh the accel was built from. NULL: it cannot update;
     * prt_accel_update says so. */
    prt_status (*update)(prt_accel *a, const float *vertices);
    /* Size before building (prt_estimate) where builds on the sample's patches miss (its
     * grid or its sub-grids depend on the whole mesh): smp->mesh is the whole mesh, and
     * prt__sample_build_estimate the patches' figure (api/estimate.h). NULL: that figure. */
    prt_status (*estimate)(const struct prt__sample *smp, const char *spec, int threads, prt_size_estimate *out);
    /* Work counters of the calling thread's queries since the last call (packrt animate
     * --counters): writes up to PRT_COUNTERS_MAX named totals to out, returns how many and
     * resets them. NULL: the family counts nothing. */
    size_t (*counters)(prt_counter *out);
} prt_accel_caps;

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

/* An occluded_stream op for families with packet traversal: the rays in runs of 64
 * consecutive ones, each traced as one packet through the family's occluded_packet (shadow
 * rays made in pixel order from tiles are coherent in such runs; docs/results/packets.md). */
void prt__occluded_stream_packets(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, size_t n);

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

/* An accel over a file in a family's own format (prt_accel_caps.open: mem and size, or fd
 * and size) when a family's probe knows its first bytes, head; *out stays NULL (PRT_OK)
 * when none does. */
prt_status prt__accel_open_own(const void *mem, uint64_t size, int fd, const void *head, size_t head_size,
                               const char *name, const prt_open_options *o, bool verify_crc, prt_accel **out);

/* Family that accepts spec, or NULL with an error message naming the valid ones. */
const prt_repr_family *prt__registry_find(const prt_spec *spec);

/* Family whose own file format starts with these bytes (prt_accel_caps.probe), or NULL. */
const prt_repr_family *prt__registry_probe(const void *head, size_t n);

/* The capabilities of the family that spec_text names, or NULL when it names none (or has
 * none): for callers that choose a path by capability (the CLI's streaming build). */
const prt_accel_caps *prt__registry_caps(const char *spec_text);

/* A capability member of a's family, or NULL when the family lacks it. */
#define PRT_CAP(a, member) ((a)->ops->caps ? (a)->ops->caps->member : NULL)

#endif
