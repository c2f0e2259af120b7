/*
 * packrt - compact ray-tracing representations for large and animated triangle meshes.
 *
 * One header, C11. Every public name starts with prt_ / PRT_.
 *
 * Data flows one way: a mesh (prt_mesh) is built into an acceleration structure
 * (prt_accel) according to a representation spec string ("aabb:float3",
 * "quad:float3-soa4,leaf=4,split=sah", ...); the accel answers ray queries and can be
 * saved to a .prt file that later loads in place (mmap, no rebuild).
 *
 * Errors: functions that can fail return prt_status. prt_status_string() names the
 * status and prt_last_error() returns a human-readable message with the detail (file
 * name, byte offset, offending value). The message is kept per thread.
 *
 * Threads: a built or loaded prt_accel is immutable; any number of threads may query it
 * at once. Building, saving and destroying are not to be run concurrently with queries
 * on the same accel.
 */
#ifndef PACKRT_H
#define PACKRT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define PRT_VERSION_MAJOR 0
#define PRT_VERSION_MINOR 1

/* prim value of a miss, and vertex index sentinel. */
#define PRT_INVALID 0xFFFFFFFFu

/* ---------------------------------------------------------------------------------
 * Status and errors
 * --------------------------------------------------------------------------------- */

typedef enum prt_status {
    PRT_OK = 0,
    PRT_ERROR_ARGUMENT,    /* a caller passed something invalid (NULL, bad spec string, ...) */
    PRT_ERROR_IO,          /* the operating system refused (open, read, write, mmap) */
    PRT_ERROR_FORMAT,      /* a file is malformed: bad header, truncated, lying counts */
    PRT_ERROR_MESH,        /* mesh content is invalid: NaN/Inf vertex, index out of range, empty */
    PRT_ERROR_CORRUPT,     /* a .prt file fails its checks: checksum, offsets, foreign magic */
    PRT_ERROR_UNSUPPORTED, /* valid request this build or representation cannot serve */
    PRT_ERROR_NOMEM,       /* an allocation failed */
    PRT_ERROR_LIMIT        /* the input exceeds a representation's limit (offset bits, counts) */
} prt_status;

/* Short constant name of a status ("ok", "format error", ...). Never NULL. */
const char *prt_status_string(prt_status s);

/* Detail of the last failure on the calling thread, or "" if none. The string stays
 * valid until the next packrt call on this thread that fails. */
const char *prt_last_error(void);

/* ---------------------------------------------------------------------------------
 * Memory
 * --------------------------------------------------------------------------------- */

/* Replace the allocator used for every allocation packrt makes (default: malloc/free).
 * Call before any other packrt function; passing NULL for both restores the default.
 * alloc must return memory aligned to at least 16 bytes or NULL, and must be thread-safe:
 * builders and generators allocate from worker threads. This is the library's one
 * documented piece of global mutable state. */
void prt_set_allocator(void *(*alloc)(size_t size), void (*dealloc)(void *ptr));

/* Bytes currently allocated through packrt, and the peak since the last
 * prt_memory_reset_peak(). Either pointer may be NULL. Thread-safe. */
void prt_memory_usage(size_t *current, size_t *peak);
void prt_memory_reset_peak(void);

/* ---------------------------------------------------------------------------------
 * Meshes
 * --------------------------------------------------------------------------------- */

/* An indexed triangle mesh. Triangles index vertices; degenerate triangles (zero area,
 * repeated indices) are allowed: they are kept in the mesh and are never hit. */
typedef struct prt_mesh {
    float *vertices;       /* 3 * vertex_count floats: x, y, z */
    uint32_t *triangles;   /* 3 * triangle_count vertex indices */
    size_t vertex_count;
    size_t triangle_count;
} prt_mesh;

/* Allocate a mesh with uninitialised vertex and index arrays of the given sizes.
 * Free it with prt_mesh_free(). Returns PRT_ERROR_NOMEM or PRT_ERROR_ARGUMENT on failure. */
prt_status prt_mesh_create(size_t vertex_count, size_t triangle_count, prt_mesh **out);

/* Free a mesh from prt_mesh_create or prt_mesh_load. NULL is ignored. */
void prt_mesh_free(prt_mesh *m);

/* Load a mesh from a file: PLY (ASCII, binary little or big endian, any numeric vertex
 * type, polygons fan-triangulated) or OBJ (v/f, negative indices, polygons), each also
 * gzip-compressed (.ply.gz, .obj.gz). The format is chosen by content, not by name.
 * The mesh is validated (see prt_mesh_validate). On failure *out is NULL and
 * prt_last_error() says what is wrong and where (file name, line or byte offset). */
prt_status prt_mesh_load(const char *path, prt_mesh **out);

/* Load from memory; name is used in error messages only. Same rules as prt_mesh_load. */
prt_status prt_mesh_load_memory(const void *data, size_t size, const char *name, prt_mesh **out);

/* Write a binary little-endian PLY (float xyz, uchar/int triangle lists). */
prt_status prt_mesh_save_ply(const prt_mesh *m, const char *path);

/* Check a mesh: at least one triangle, every vertex finite, every index < vertex_count.
 * Returns PRT_ERROR_MESH with the first offending element in prt_last_error(). */
prt_status prt_mesh_validate(const prt_mesh *m);

/* Axis-aligned bounds of the referenced vertices: lo[3], hi[3]. */
void prt_mesh_bounds(const prt_mesh *m, float lo[3], float hi[3]);

/* Number of triangles that can never be hit: repeated indices or exactly zero area. */
size_t prt_mesh_count_degenerate(const prt_mesh *m);

/* Procedural meshes, deterministic for a given kind, triangle budget and seed. The
 * result has approximately `triangles` triangles (exact count depends on the kind).
 * kind: "sphere" (closed cube sphere, 12k^2 triangles), "terrain" (noise height field),
 * "mandelbulb" (closed marching-cubes isosurface), "cad" (many separate boxes and
 * cylinders, poor connectivity). See prt_gen_kinds() and docs/generators.md. */
prt_status prt_mesh_generate(const char *kind, size_t triangles, uint64_t seed, prt_mesh **out);

/* Space-separated list of the kinds prt_mesh_generate accepts. */
const char *prt_gen_kinds(void);

/* ---------------------------------------------------------------------------------
 * Rays and hits
 * --------------------------------------------------------------------------------- */

/* A ray; hits are accepted for t in [tnear, tfar]. dir need not be normalised. 32 bytes. */
typedef struct prt_ray {
    float org[3], tnear;
    float dir[3], tfar;
} prt_ray;

/* A hit: point = (1-u-v)*v0 + u*v1 + v*v2 of triangle `prim` (its index in the mesh).
 * On a miss, prim = PRT_INVALID and t = +inf. geom is reserved (0). */
typedef struct prt_hit {
    float t, u, v;
    uint32_t prim;
    uint32_t geom;
} prt_hit;

/* A packet of coherent rays, e.g. a 2x2, 4x4 or 8x8 pixel block (width x count/width).
 * The caller owns both arrays; hits[i] answers rays[i]. count <= PRT_PACKET_MAX. */
#define PRT_PACKET_MAX 256
typedef struct prt_packet {
    prt_ray *rays;
    prt_hit *hits;
    uint32_t count;
    uint32_t width;
} prt_packet;

/* ---------------------------------------------------------------------------------
 * Acceleration structures
 * --------------------------------------------------------------------------------- */

typedef struct prt_accel prt_accel;

typedef struct prt_build_options {
    int threads; /* 0: all cores */
    /* Called now and then with the fraction of the build done (0..1), always from the
     * thread that called prt_build; NULL for none. The CLI draws its progress bar with it. */
    void (*progress)(void *user, float fraction);
    void *progress_user;
} prt_build_options;

/* Memory of an accel, split as in Rouwé's and Benthin's tables. Every byte that a query
 * touches is counted: tree = hierarchy nodes, geometry = leaf payload (triangles,
 * vertices, indices, primitive ids), other = anything else held (headers). */
typedef struct prt_stats {
    size_t triangles;       /* mesh triangles, degenerate included */
    size_t triangles_built; /* triangles that can be hit */
    size_t bytes_tree;
    size_t bytes_geometry;
    size_t bytes_other;
    size_t nodes;
    size_t leaves;
    uint32_t depth;
    double build_seconds;
    size_t build_peak_bytes; /* peak packrt allocation during the build, mesh excluded */
} prt_stats;

/* Build an acceleration structure for mesh m (which is validated first) according to
 * spec: "structure[:codec][,key=value]...", e.g. "aabb:float3", "quad:float3-soa4,leaf=8".
 * Keys for BVH representations: split=sah|mean|longest|morton|fixed, leaf=1..16,
 * order=df|df-last|bf|bf-last (node order, Rouwé §4.3). options may be NULL.
 * The accel does not keep a pointer to m. Free it with prt_accel_free(). */
prt_status prt_build(const prt_mesh *m, const char *spec, const prt_build_options *options,
                     prt_accel **out);

/* Free an accel (built or loaded). NULL is ignored. */
void prt_accel_free(prt_accel *a);

/* The canonical spec string of an accel (with every option spelled out). */
const char *prt_accel_spec(const prt_accel *a);

/* Bounds of the triangles the accel can hit: lo[3], hi[3]. */
void prt_accel_bounds(const prt_accel *a, float lo[3], float hi[3]);

/* Memory and build statistics. */
void prt_accel_stats(const prt_accel *a, prt_stats *s);

/* Closest hit along r. On a hit, h receives it and r->tfar is shrunk to h->t; on a miss
 * h->prim = PRT_INVALID, h->t = +inf and r is unchanged. */
void prt_intersect1(const prt_accel *a, prt_ray *r, prt_hit *h);

/* True when any triangle is hit with t in [r->tnear, r->tfar]. */
bool prt_occluded1(const prt_accel *a, const prt_ray *r);

/* Closest hits for a packet of coherent rays (as prt_intersect1 for each ray). */
void prt_intersect_packet(const prt_accel *a, prt_packet *p);

/* Closest hits for n rays on `threads` threads (0: all cores). rays[i].tfar is shrunk as
 * by prt_intersect1. */
void prt_intersect_stream(const prt_accel *a, prt_ray *rays, prt_hit *hits, size_t n, int threads);

/* Any-hit for n rays; occluded[i] = 1 when ray i is blocked, else 0. */
void prt_occluded_stream(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, size_t n,
                         int threads);

/* Save to a .prt file (format: docs/formats.md). */
prt_status prt_accel_save(const prt_accel *a, const char *path);

/* Load a .prt file. The file is mapped and used in place where the layout allows; every
 * size, offset and checksum is checked: a corrupt, truncated or foreign file is
 * PRT_ERROR_CORRUPT (or PRT_ERROR_FORMAT), never a crash. */
prt_status prt_accel_load(const char *path, prt_accel **out);

/* Same, from memory that the caller keeps alive and unchanged until prt_accel_free. */
prt_status prt_accel_load_memory(const void *data, size_t size, prt_accel **out);

/* ---------------------------------------------------------------------------------
 * Representations
 * --------------------------------------------------------------------------------- */

/* Number of registered representation names, and the i-th name and its one-line
 * description (NULL past the end). These are what `packrt list` prints. */
size_t prt_repr_count(void);
const char *prt_repr_name(size_t i);
const char *prt_repr_description(size_t i);

/* ---------------------------------------------------------------------------------
 * Ray and hit files (.rays, .hits: docs/formats.md)
 * --------------------------------------------------------------------------------- */

/* Read a .rays file into a new array (free with prt_free). */
prt_status prt_rays_read(const char *path, prt_ray **rays, size_t *count);
prt_status prt_rays_write(const char *path, const prt_ray *rays, size_t count);

/* Read or write a .hits file. */
prt_status prt_hits_read(const char *path, prt_hit **hits, size_t *count);
prt_status prt_hits_write(const char *path, const prt_hit *hits, size_t count);

/* Write a .hits file for any-hit results: occluded -> t = 0, prim = 0; else t = +inf,
 * prim = PRT_INVALID. */
prt_status prt_hits_write_occluded(const char *path, const uint8_t *occluded, size_t count);

/* Free memory that packrt returned (ray and hit arrays). */
void prt_free(void *p);

#ifdef __cplusplus
}
#endif
#endif /* PACKRT_H */
