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
 * builders and generators allocate from worker threads. Blocks of 2 MiB and more are
 * asked for 2 MiB larger, so that they start on a 2 MiB boundary (transparent huge pages).
 * This is the library's one documented piece of global mutable state. */
void prt_set_allocator(void *(*alloc)(size_t size), void (*dealloc)(void *ptr));

/* Bytes currently allocated through packrt, and the peak since the last
 * prt_memory_reset_peak(). Either pointer may be NULL. Thread-safe. */
void prt_memory_usage(size_t *current, size_t *peak);
void prt_memory_reset_peak(void);

/* ---------------------------------------------------------------------------------
 * Meshes
 * --------------------------------------------------------------------------------- */

/* An indexed triangle mesh. Triangles index vertices; degenerate triangles (zero area,
 * repeated indices) are allowed: they are kept in the mesh and are never hit.
 *
 * Colours are optional and NULL when the mesh has none: 3 bytes (red, green, blue, 0-255,
 * sRGB-encoded as in image and mesh files) per vertex or per triangle. prt_render uses them
 * as the surface colour (per-vertex colours interpolated across each triangle; when a mesh
 * has both, the vertex colours). They are allocated with prt_mesh_add_colors (or by the
 * loaders) and freed by prt_mesh_free; prt_build ignores them. */
typedef struct prt_mesh {
    float *vertices;     /* 3 * vertex_count floats: x, y, z */
    uint32_t *triangles; /* 3 * triangle_count vertex indices */
    size_t vertex_count;
    size_t triangle_count;
    uint8_t *vertex_colors;   /* NULL, or 3 * vertex_count bytes: r, g, b */
    uint8_t *triangle_colors; /* NULL, or 3 * triangle_count bytes: r, g, b */
    uint16_t *materials;      /* NULL, or triangle_count material numbers (prt_hit.geom) */
} prt_mesh;

/* Allocate a mesh with uninitialised vertex and index arrays of the given sizes and no
 * colours. Free it with prt_mesh_free(). Returns PRT_ERROR_NOMEM or PRT_ERROR_ARGUMENT on
 * failure. */
prt_status prt_mesh_create(size_t vertex_count, size_t triangle_count, prt_mesh **out);

/* Give m uninitialised per-vertex and/or per-triangle colour arrays (sized by its current
 * counts), through packrt's allocator so prt_mesh_free releases them; an array m has
 * already is kept as it is. PRT_ERROR_ARGUMENT for a NULL m, PRT_ERROR_NOMEM (m unchanged). */
prt_status prt_mesh_add_colors(prt_mesh *m, bool per_vertex, bool per_triangle);

/* Give m a per-triangle material array (triangle_count entries, all 0), through packrt's
 * allocator so prt_mesh_free releases it; an array m has already is kept as it is.
 * Representations that store materials (raystrips,mat=u16) return the hit triangle's in
 * prt_hit.geom. PRT_ERROR_ARGUMENT for a NULL m, PRT_ERROR_NOMEM (m unchanged). */
prt_status prt_mesh_add_materials(prt_mesh *m);

/* Free a mesh from prt_mesh_create or prt_mesh_load, colours and materials included. NULL
 * is ignored. */
void prt_mesh_free(prt_mesh *m);

/* Load a mesh from a file: PLY (ASCII, binary little or big endian, any numeric vertex
 * type, polygons fan-triangulated) or OBJ (v/f, negative indices, polygons), each also
 * gzip-compressed (.ply.gz, .obj.gz). The format is chosen by content, not by name.
 * Colours are kept when the file has them: PLY vertex or face properties red, green, blue
 * (optionally alpha, read and dropped; also named diffuse_red, ...) of type uchar (0-255),
 * ushort (0-65535) or float/double (0-1, clamped); every triangle of a polygon takes the
 * face's colour. OBJ `v x y z r g b` (0-1, clamped) when every vertex has them. A colour
 * set missing a channel, a list or another type is PRT_ERROR_FORMAT.
 * Also STL (binary and ASCII; corners welded by exact position into shared vertices), OFF
 * (ASCII, [ST][C][N]OFF) and glTF 2.0 (.gltf with embedded or external buffers, .glb: the
 * default scene's triangle primitives with node transforms applied, every mesh instance
 * flattened into one mesh whose `materials` hold the instance's number, vertex colours
 * times base-colour factors in vertex_colors), each also gzip-compressed. The format is
 * recognised by magic bytes first and by the extension second (binary STL has no magic):
 * docs/formats-mesh.md.
 * The mesh is validated (see prt_mesh_validate). On failure *out is NULL and
 * prt_last_error() says what is wrong and where (file name, line or byte offset). */
prt_status prt_mesh_load(const char *path, prt_mesh **out);

/* Load from memory; name is used in error messages and for its extension only. Same rules
 * as prt_mesh_load, except that a .gltf's external buffer files are refused (data: URIs
 * and GLB's own buffer are read). */
prt_status prt_mesh_load_memory(const void *data, size_t size, const char *name, prt_mesh **out);

/* Write a binary little-endian PLY (float xyz, uchar/int triangle lists), with uchar red,
 * green, blue vertex and face properties for the colours m has. */
prt_status prt_mesh_save_ply(const prt_mesh *m, const char *path);

/* Write a binary STL: per triangle its unit normal (zero when degenerate), its three corner
 * positions and a zero attribute word. Colours and materials are not written. Reading it
 * back welds the corners by exact position, so a mesh without duplicate positions and
 * unused vertices round-trips to the same triangles (vertices renumbered in first-use
 * order). PRT_ERROR_ARGUMENT for a NULL path, the mesh's own status for an invalid mesh,
 * PRT_ERROR_LIMIT beyond 2^32-1 triangles, PRT_ERROR_IO when writing fails (the partial
 * file is removed). */
prt_status prt_mesh_save_stl(const prt_mesh *m, const char *path);

/* Write an ASCII OFF (COFF with "r g b 255" per vertex when m has vertex colours; "r g b"
 * after each face's indices when it has triangle colours; materials are dropped).
 * Coordinates are printed with 9 significant digits, so loading gives back the same
 * arrays. Errors as prt_mesh_save_stl. */
prt_status prt_mesh_save_off(const prt_mesh *m, const char *path);

/* Largest coordinate magnitude prt_build accepts (PRT_ERROR_LIMIT beyond). The watertight
 * ray/triangle test computes a product of three coordinate differences before dividing
 * (Woop et al.'s T = U az + V bz + W cz), which overflows single precision near 7e12: past
 * this limit (or for rays starting farther than about that), rays would miss triangles. */
#define PRT_MAX_COORDINATE 1e12f

/* Smallest bounding-box diagonal of a mesh prt_build accepts (PRT_ERROR_LIMIT below): for
 * meshes (and rays) much smaller, that product of three differences leaves the normal float
 * range (near 2e-13) and hit distances lose their precision, then hits are lost (1e-19). */
#define PRT_MIN_EXTENT 1e-10f

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
 * When several triangles are hit at exactly the same t, the smallest index wins, in every
 * representation. On a miss, prim = PRT_INVALID and t = +inf. geom: the hit triangle's
 * material (prt_mesh.materials) for representations that store materials
 * (raystrips,mat=u16), else 0. */
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
    /* For specs with ids=none (compact BVH codecs that store one id per leaf, lossygrid,
     * raystrips): the accel keeps no map back to mesh triangle ids and hits name triangles
     * by their position in the accel's own order; triangle_order[k] receives the mesh id
     * of position k, for k < prt_stats.triangles_built, so the caller can put its
     * per-triangle data in that order once and save the 4 bytes per triangle the map
     * would cost. Caller-allocated,
     * mesh triangle count entries; NULL otherwise. */
    uint32_t *triangle_order;
    /* Out-of-core builds ("ooc", prt_build_file): bytes of memory the build may hold, however
     * large the mesh (0: 4 GiB). Temporary files go next to the output file. */
    uint64_t memory_budget;
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
    /* Lossy representations: the largest distance between a vertex as the representation
     * decodes it and the mesh's vertex (mesh units), so every decoded triangle lies within
     * vertex_error of its original. 0 for lossless representations. */
    double vertex_error;
    /* Figures particular to the representation, one line for people (lossygrid: its grids
     * and error statistics); empty when it has none. */
    char detail[256];
} prt_stats;

/* Build an acceleration structure for mesh m (which is validated first) according to
 * spec: "structure[:codec][,key=value]...", e.g. "aabb:float3", "quad:float3-soa4,leaf=8".
 * Keys for BVH representations: split=sah|mean|longest|morton|fixed, leaf=1..16,
 * order=df|df-leaves-last|bf|bf-leaves-last (node order, Rouwé §4.3; aabb only), ids=mesh|none
 * (codecs that store one id per leaf: hits name mesh triangles through a 4-byte-per-triangle
 * map, or with none name positions in the accel's order, see triangle_order above),
 * collapse=sah|fill (wide8 only: fill charges each wide node a fixed cost in the SAH collapse,
 * for about 7% fewer, fuller nodes).
 * options may be NULL.
 * The build resets the peak of prt_memory_usage() to measure its own peak (reported in
 * prt_stats.build_peak_bytes; concurrent builds see each other's allocations).
 * A mesh that a representation cannot encode (too many vertices for 16-bit indices, offsets
 * past its bits) is PRT_ERROR_LIMIT with the reason in prt_last_error().
 * The accel does not keep a pointer to m. Free it with prt_accel_free(). */
prt_status prt_build(const prt_mesh *m, const char *spec, const prt_build_options *options, prt_accel **out);

/* "auto" specs choose for the caller (docs/auto.md): "auto,budget=B" (total bytes per
 * triangle), "auto,memory=N[K|M|G]" (total bytes for this mesh) or neither (no limit), with
 * ",workload=random|primary|shadow|diffuse" (default random) and ",lossy=yes" to allow
 * lossy representations (default no). The choice is the representation with the lowest
 * time per ray, relative to Embree's, for the mesh's kind (vertices shared or not) in a cost
 * table measured by `packrt bench --calibrate`, whose size, estimated by prt_estimate, fits
 * the budget; the built accel is checked against the budget and the next candidate built
 * when it does not fit, so prt_build("auto...") never returns an accel over its budget.
 * Specs with ids=none are candidates only when options->triangle_order is given. When
 * nothing fits: PRT_ERROR_LIMIT naming the smallest size possible. The cost table is the
 * one built into the library, with the rows of the file named by the environment variable
 * PRT_COSTS, else of ~/.cache/packrt/costs.tsv, taking precedence where present.
 * prt_accel_spec() of the result names the representation chosen. */

/* What auto would choose for m (without building it): the spec into spec_out (at least 96
 * bytes), and its estimated size when est is not NULL. */
typedef struct prt_size_estimate {
    size_t bytes_tree, bytes_geometry, bytes_other; /* for the whole mesh */
    double bytes_per_triangle;                      /* total over the mesh's triangles */
    size_t sample_triangles;                        /* triangles the estimate built; the mesh's: exact */
} prt_size_estimate;
prt_status prt_auto_choose(const prt_mesh *m, const char *auto_spec, const prt_build_options *options, char *spec_out,
                           size_t spec_size, prt_size_estimate *est);

/* The size spec would take on m, without building it over the whole mesh: representations
 * are built on a sample of at most 65536 triangles in four spatially compact patches and
 * scaled (docs/auto.md states the error measured per family); a mesh of at most 131072
 * triangles is built whole, and the figure is then exact. */
prt_status prt_estimate(const prt_mesh *m, const char *spec, prt_size_estimate *out);

/* Animated meshes: rebuild a in place for new positions of the same vertices (the
 * triangles stay those of the mesh a was built from; only their corners move). vertices
 * holds 3 * vertex_count floats of that mesh, each finite and within
 * +-PRT_MAX_COORDINATE (else PRT_ERROR_MESH or PRT_ERROR_LIMIT, a unchanged). "cgrid"
 * rebuilds its grid in pooled memory reused from call to call (built and loaded accels
 * alike); a BVH built with the spec option update=refit keeps its tree, refits it and
 * encodes it again into a new blob (its splits stay those of the first frame; a loaded one
 * keeps no tree). The others answer
 * PRT_ERROR_UNSUPPORTED: build them again from the moved mesh. prt_stats.build_seconds
 * then reports the update's time. Like building, it must not run concurrently with
 * queries on a. */
prt_status prt_accel_update(prt_accel *a, const float *vertices);

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

/* Closest hits for a packet of coherent rays (as prt_intersect1 for each ray). Rays past
 * PRT_PACKET_MAX are answered one by one. */
void prt_intersect_packet(const prt_accel *a, prt_packet *p);

/* Any hit for a packet of coherent rays, such as shadow rays from a pixel block's hit
 * points to one point light: occluded[i] = 1 when a triangle is hit with t in
 * [rays[i].tnear, rays[i].tfar], else 0, exactly as prt_occluded1 answers rays[i] (invalid
 * rays are 0). Reads p->rays, p->count and p->width (rows of width rays, as for
 * prt_intersect_packet); p->hits is not used and may be NULL. Rays past PRT_PACKET_MAX are
 * answered one by one. occluded: caller-owned, p->count entries. Representations without
 * packet traversal answer with prt_occluded1 per ray; "cgrid" traces frustums (Wald 2006
 * §4.6; docs/cgrid.md). */
void prt_occluded_packet(const prt_accel *a, const prt_packet *p, uint8_t *occluded);

/* Closest hits for n rays on `threads` threads (0: all cores). rays[i].tfar is shrunk as
 * by prt_intersect1. */
void prt_intersect_stream(const prt_accel *a, prt_ray *rays, prt_hit *hits, size_t n, int threads);

/* Any-hit for n rays; occluded[i] = 1 when ray i is blocked, else 0. */
void prt_occluded_stream(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, size_t n, int threads);

/* Closest hits (any hits) for n rays given as 6 floats each, origin xyz then direction
 * xyz (Open3D's and trimesh's layout: no prt_ray records to build), on threads, answered
 * as prt_intersect_stream (prt_occluded_stream) answers the same rays. tnear: NULL for 0,
 * else one value (tnear_stride 0) or one a ray (stride 1); tfar likewise, NULL for +inf. */
void prt_intersect_rays6(const prt_accel *a, const float *rays6, size_t n, const float *tnear, size_t tnear_stride,
                         const float *tfar, size_t tfar_stride, prt_hit *hits, int threads);
void prt_occluded_rays6(const prt_accel *a, const float *rays6, size_t n, const float *tnear, size_t tnear_stride,
                        const float *tfar, size_t tfar_stride, uint8_t *occluded, int threads);

/* Save to a .prt file (format: docs/formats.md). */
prt_status prt_accel_save(const prt_accel *a, const char *path);

/* Load a .prt file. The file is mapped and used in place where the layout allows; every
 * size, offset and checksum is checked: a corrupt, truncated or foreign file is
 * PRT_ERROR_CORRUPT, another .prt version or byte order or a representation this build does
 * not know is PRT_ERROR_UNSUPPORTED, an unreadable file PRT_ERROR_IO; never a crash. */
prt_status prt_accel_load(const char *path, prt_accel **out);

/* Same, from memory that the caller keeps alive and unchanged until prt_accel_free. */
prt_status prt_accel_load_memory(const void *data, size_t size, prt_accel **out);

/* ---------------------------------------------------------------------------------
 * Mesh queries beyond the closest hit (docs/queries.md): every crossing along a ray,
 * inside/outside, closest points and signed distance.
 *
 * They are answered by representations that can enumerate their triangles near a ray or a
 * point: every BVH layout and codec (lossy ones answer for the triangles they decode, within
 * prt_stats.vertex_error of the mesh's). The others return PRT_ERROR_UNSUPPORTED with a
 * message naming one that can. Every function here is thread-safe on a built or loaded
 * accel, like the ray queries; `threads` is 0 for all cores. prim values and barycentrics
 * are as in prt_hit (mesh triangle ids, u weighting vertex 1 and v vertex 2).
 * --------------------------------------------------------------------------------- */

/* Every crossing of the surface by r with t in [r->tnear, r->tfar], nearest first. A ray
 * through an edge or a vertex shared by several triangles counts the crossing once: ties on
 * an edge function are broken as if the ray were moved an infinitesimal step aside (the
 * same step for every triangle), so a ray entering a closed mesh through an edge or a
 * vertex has one crossing there, and one that grazes it zero or two. *count receives the
 * number of crossings; the nearest min(*count, max) are written to hits (NULL when max is
 * 0: count only), so *count > max says the list was truncated. Ties at equal t are in
 * order of prim. Errors: PRT_ERROR_ARGUMENT (NULL a, r or count, or hits NULL with max > 0),
 * PRT_ERROR_UNSUPPORTED (representation), PRT_ERROR_NOMEM. */
prt_status prt_intersect_all(const prt_accel *a, const prt_ray *r, prt_hit *hits, uint32_t max, uint32_t *count);

/* prt_intersect_all for n rays on threads. counts[i] receives ray i's crossing count. With
 * hits NULL only the counts are computed (offsets may be NULL); otherwise ray i writes its
 * nearest crossings to hits[offsets[i] .. offsets[i + 1]) (offsets: n + 1 ascending
 * entries, e.g. the prefix sums of a first, counting call) and counts[i] > offsets[i + 1] -
 * offsets[i] says it was truncated. */
prt_status prt_intersect_all_stream(const prt_accel *a, const prt_ray *rays, size_t n, uint32_t *counts,
                                    const uint64_t *offsets, prt_hit *hits, int threads);

/* The nearest point of the surface to a point, within max_distance (+inf: any). */
typedef struct prt_closest {
    float point[3]; /* the nearest surface point */
    float distance; /* its distance; +inf when no triangle lies within max_distance */
    float u, v;     /* its barycentrics on triangle prim */
    uint32_t prim;  /* the triangle (the smallest id among equally near ones); PRT_INVALID when none */
} prt_closest;

/* Closest points of n points (3 floats each) on threads. A point that is not finite gets
 * prim = PRT_INVALID and distance +inf. Errors: PRT_ERROR_ARGUMENT, PRT_ERROR_UNSUPPORTED. */
prt_status prt_closest_points(const prt_accel *a, const float *points, size_t n, float max_distance, prt_closest *out,
                              int threads);

/* Results of prt_contains (bits). */
#define PRT_INSIDE 1u /* the point is inside the mesh */
#define PRT_BY_WINDING                                                     \
    2u /* the crossing parities along the rays disagreed (an open or self- \
        * intersecting mesh), so the generalized winding number decided */

/* Inside/outside of n points on threads: the parity of the crossings along several ray
 * directions from each point, which is exact for closed meshes; when the directions
 * disagree, the generalized winding number (Jacobson et al. 2013, computed as
 * prt_winding_number_fast with beta 2) decides: inside when it is at least 0.5. result[i] is a combination of
 * PRT_INSIDE and PRT_BY_WINDING. A point that is not finite is outside. */
prt_status prt_contains(const prt_accel *a, const float *points, size_t n, uint8_t *result, int threads);

/* How prt_contains_by decides. */
typedef enum prt_contains_method {
    PRT_CONTAINS_AUTO = 0,   /* prt_contains: parity when the three directions agree, else the winding number */
    PRT_CONTAINS_PARITY = 1, /* the majority of the three parities, always (right for closed meshes) */
    PRT_CONTAINS_WINDING = 2 /* the fast winding number for every point (meshes with holes, self-
                              * intersections or inconsistent closure): inside when it is at least 0.5 */
} prt_contains_method;

/* prt_contains by method. The winding number here is the fast hierarchical one (Barill et
 * al. 2018, accuracy beta = 2: prt_winding_number_fast), on a tree built for the call over
 * the representation's triangles (O(n log n) time, at most about 240 bytes a triangle while the
 * call runs); result[i] has PRT_BY_WINDING set for the points it decided. Errors as prt_contains,
 * and PRT_ERROR_ARGUMENT for an unknown method, PRT_ERROR_NOMEM. */
prt_status prt_contains_by(const prt_accel *a, const float *points, size_t n, prt_contains_method method,
                           uint8_t *result, int threads);

/* Generalized winding number of the surface at n points (Jacobson et al. 2013: the sum of
 * the triangles' signed solid angles over 4 pi): 1 inside a closed outward-wound mesh, 0
 * outside, fractional near holes. */
prt_status prt_winding_number(const prt_accel *a, const float *points, size_t n, float *winding, int threads);

/* The generalized winding number by Barill et al. 2018's fast approximation ("Fast Winding
 * Numbers for Soups and Clouds"): a tree over the triangles (built for the call) whose
 * nodes keep their dipole and its first correction; a node whose centre is more than beta
 * times its radius from the point answers by that expansion, nearer ones by their
 * triangles' exact solid angles. beta = 2 is the paper's choice (docs/queries.md states the
 * error measured); beta <= 0 sums every triangle exactly. O(log n) a point far from the
 * surface. Points that are not finite get NaN. */
prt_status prt_winding_number_fast(const prt_accel *a, const float *points, size_t n, float beta, float *winding,
                                   int threads);

/* Signed distance of n points: the closest point's distance, negative inside (prt_contains'
 * answer), +inf (or -inf) when nothing lies within max_distance. */
prt_status prt_signed_distance(const prt_accel *a, const float *points, size_t n, float max_distance, float *distance,
                               int threads);

/* ---------------------------------------------------------------------------------
 * Out-of-core accels and levels of detail ("ooc": Áfra 2012; docs/ooc.md)
 *
 * An "ooc" accel is a block file: a kd-tree with LOD voxels in 64 KB LZ4-compressed
 * blocks, read on demand into a cache of fixed size, so a model far larger than memory
 * can be traced. prt_build(m, "ooc") builds one in memory; prt_build_file and
 * prt_build_generated stream a mesh of any size to a block file with bounded memory.
 * prt_accel_load and prt_accel_open open one. prt_intersect1 and the other exact queries
 * answer at full detail on every accel, waiting for the blocks they need; the LOD queries
 * below answer from what is loaded and stop at a voxel that is small enough.
 * --------------------------------------------------------------------------------- */

/* Build from a mesh file (any format prt_mesh_load reads) into out_path. For "ooc" the
 * mesh is streamed (never held whole: o->memory_budget bounds the build); for any other
 * spec this is prt_mesh_load, prt_build and prt_accel_save in one. */
prt_status prt_build_file(const char *mesh_path, const char *spec, const char *out_path, const prt_build_options *o);

/* Build a procedural mesh (prt_mesh_generate's kinds) into out_path; for "ooc" and the
 * kinds that can stream ("mandelbulb") the mesh is never held whole. */
prt_status prt_build_generated(const char *kind, uint64_t triangles, uint64_t seed, const char *spec,
                               const char *out_path, const prt_build_options *o);

typedef struct prt_open_options {
    uint64_t cache_bytes; /* ooc: decompressed block cache (0: 1 GiB, or the whole file if smaller) */
    int fetchers;         /* ooc: threads loading blocks for LOD queries (0: 4) */
} prt_open_options;

/* prt_accel_load with options (NULL: defaults); other representations ignore them. */
prt_status prt_accel_open(const char *path, const prt_open_options *o, prt_accel **out);

/* prim of a LOD hit on a voxel rather than a triangle. */
#define PRT_VOXEL_HIT 0xFFFFFFFEu

typedef struct prt_lod_hit {
    prt_hit hit; /* hit.prim: a triangle, PRT_VOXEL_HIT, or PRT_INVALID on a miss */
    /* Shading data from representations with LOD ("ooc"; zero from the others): a voxel's
     * normal, or the hit triangle's geometric normal (unit, as the mesh winds it), and the
     * voxel's or triangle's colour (linear, 0..1; meshes without colours are 0.74 grey). */
    float normal[3];
    float color[3];
    float voxel_radius; /* radius of the voxel's bounding sphere, 0 for triangles: offset
                         * secondary rays by its diameter to leave the voxel (§6.2) */
} prt_lod_hit;

/* Closest hit with levels of detail: a voxel of bounding radius R met at distance t stops
 * the ray when R <= t * error (Áfra eq. 2: for a camera, error = pixels of error / (h / 2 /
 * tan(fov_y / 2)) radius in pixels); and where a block is not loaded yet the ray stops
 * at the last voxel it passed and the block is requested (loaded by the fetcher threads,
 * used after the next prt_accel_frame). Returns true on a hit (r->tfar shrinks to it).
 * Other representations answer exactly (as prt_intersect1).
 * On an "ooc" accel whose cache is smaller than its file, exact queries on other threads
 * in the same frame evict nothing while a LOD query runs (they wait for a free slot), but
 * may evict published blocks between LOD queries, which then answer a voxel or a miss
 * where the block was: LOD frames converge best without exact queries beside them. */
bool prt_intersect_lod(const prt_accel *a, prt_ray *r, float error, prt_lod_hit *h);
/* prt_intersect_lod for n rays, traced as packets of 4x4 where the representation has them
 * ("ooc": 16 consecutive rays with the same direction signs walk the tree together, §6.1):
 * the same answers as one call per ray. */
void prt_intersect_lod_packet(const prt_accel *a, prt_ray *rays, prt_lod_hit *hits, uint32_t n, float error);
/* Any-hit with levels of detail: a voxel blocks the ray as a triangle does. */
bool prt_occluded_lod(const prt_accel *a, const prt_ray *r, float error);
/* prt_occluded_lod for n rays (occluded[i] 1 when ray i is blocked, else 0), traced as 4x4
 * shadow packets where the representation has them ("ooc", §6.1: 16 consecutive rays with
 * the same direction signs, e.g. from one light to a pixel block's hit points); the same
 * answers as one call per ray. */
void prt_occluded_lod_packet(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, uint32_t n, float error);

typedef struct prt_cache_info {
    uint64_t cache_bytes;                 /* the cache's size */
    uint64_t resident_bytes;              /* decompressed blocks held */
    uint64_t working_set_bytes;           /* blocks the last frame touched */
    uint32_t requested;                   /* blocks the last frame asked for and did not have */
    uint32_t pending;                     /* blocks being loaded */
    uint64_t blocks, blocks_loaded_total; /* in the file; loads since opening */
    uint64_t bytes_read_total;            /* compressed bytes read since opening */
    double decompress_seconds_total;
} prt_cache_info;

/* Between frames (Áfra §5.3): publish the blocks loaded since the last call, turn the
 * last frame's requests into loads (most requested first), evict the least recently used
 * blocks the last frame did not touch. Must not run concurrently with queries on a. info
 * may be NULL; zeros for representations without a cache. */
void prt_accel_frame(prt_accel *a, prt_cache_info *info);

/* PRT_ERROR_CORRUPT (with a message) when a query so far met a block that failed its
 * checks; queries treat such a block as empty rather than crash. PRT_OK otherwise and for
 * representations checked whole at load. */
prt_status prt_accel_check(const prt_accel *a);

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

/* Read or write a .points file (PRTPNTS1: the mesh queries' input, 3 floats a point). */
prt_status prt_points_read(const char *path, float **points, size_t *count);
prt_status prt_points_write(const char *path, const float *points, size_t count);

/* Free memory that packrt returned (ray and hit arrays). */
void prt_free(void *p);

/* ---------------------------------------------------------------------------------
 * Rendering (src/render/; shading modes, camera conventions, determinism: docs/render.md)
 * --------------------------------------------------------------------------------- */

/* A pinhole camera. World space is right-handed; the image's x runs along
 * cross(target - eye, up) (to the right), its y along up projected on the image plane
 * (upward on screen; row 0 of an image is the top). up need not be perpendicular to the
 * view direction but must not be parallel to it. */
typedef struct prt_camera {
    float eye[3];    /* centre of projection */
    float target[3]; /* the point seen at the centre of the image */
    float up[3];     /* world up, usually (0, 1, 0) */
    float fov_y_deg; /* vertical field of view in degrees, in (0, 180) */
} prt_camera;

/* The default framing of a box lo..hi: looking at its centre from the front (+z), a little
 * above and to the right (+x, +y), y up, 40 degrees vertical field of view, far enough that
 * the bounding sphere fills the image height. The same view as `packrt bench`'s primary
 * workload. */
void prt_camera_default(const float lo[3], const float hi[3], prt_camera *c);

/* Shading modes (docs/render.md). The surface colour (diffuse, shadows, gi) is the mesh's
 * vertex or triangle colour when prt_render has a mesh with colours, else grey. */
typedef enum prt_shade {
    PRT_SHADE_NORMAL,  /* geometric normal facing the ray, as colour 0.5 + 0.5 n */
    PRT_SHADE_DIFFUSE, /* Lambert with a light at the eye: no secondary rays */
    PRT_SHADE_SHADOWS, /* Lambert with a point light and hard shadows (one any-hit ray) */
    PRT_SHADE_AO,      /* ambient occlusion, uncoloured: a cosine-weighted any-hit ray per sample */
    PRT_SHADE_GI,      /* point light with shadows + one diffuse bounce (sky and light) */
    PRT_SHADE_COUNT
} prt_shade;

/* "normal", "diffuse", "shadows", "ao", "gi"; "?" past the end. */
const char *prt_shade_name(prt_shade s);

/* Parse one of the names above; PRT_ERROR_ARGUMENT (message lists the names) otherwise. */
prt_status prt_shade_parse(const char *name, prt_shade *out);

typedef struct prt_render_options {
    uint32_t width, height; /* image size in pixels; 0 for either: 640 x 480 */
    prt_shade shade;
    /* Samples per pixel; each is one camera ray (at the pixel centre when spp is 1, else
     * jittered inside the pixel) plus the secondary rays of the mode. 0: 1 for normal,
     * diffuse and shadows, 16 for ao and gi. */
    uint32_t spp;
    int threads;   /* 0: all cores. The image does not depend on it. */
    uint64_t seed; /* of every random choice (jitter, sample directions); 0 is a valid seed */
    /* gi: filter the indirect light with an edge-avoiding a-trous wavelet (Dammertz et
     * al. 2010), guided by normals and positions; direct light stays unfiltered. */
    bool denoise;
    /* Point light for shadows and gi; when use_light is false, a default above, in front
     * of and to the left of the scene bounds (as `packrt bench`'s shadow workload). */
    bool use_light;
    float light[3];
    /* ao: length of the occlusion rays; 0: 0.15 x the bounds diagonal. */
    float ao_radius;
    /* Called now and then with the fraction of pixels done (0..1), always from the thread
     * that called prt_render; NULL for none. */
    void (*progress)(void *user, float fraction);
    void *progress_user;
    /* Levels of detail (prt_intersect_lod; Áfra §6.2): camera and shadow rays accept a voxel
     * whose projection covers at most this many pixels, ao and gi rays one that subtends at
     * most 2 pi / spp steradians. 0: exact. With an out-of-core accel, blocks not loaded yet
     * show as the coarser voxel above them; call prt_accel_frame between renders to load
     * them (docs/ooc.md). */
    float lod_pixels;
} prt_render_options;

/* An 8-bit sRGB image: 3 bytes (r, g, b) per pixel, rows top to bottom, no padding.
 * A zero-initialised prt_image is an empty image; free one with prt_image_free. */
typedef struct prt_image {
    uint32_t width, height;
    uint8_t *rgb;
    /* Set by prt_render: rays cast (camera and secondary, normal-estimation rays included)
     * and wall-clock seconds of the render. */
    uint64_t rays;
    double seconds;
} prt_image;

/* Render accel a seen from camera c (NULL: prt_camera_default of the accel's bounds) into
 * *img. Pixels are rendered in 8x8 tiles spread over the threads; each tile's camera rays
 * go to prt_intersect_packet, so representations with packet traversal use it.
 *
 * m is the mesh a was built from, or NULL. Shading needs the geometric normal of each hit:
 * with m it is taken from triangle hit.prim of m (m->triangle_count must equal the accel's
 * triangle count, else PRT_ERROR_ARGUMENT); without m (a .prt file loaded alone) it is
 * estimated from two to four extra rays parallel to the hit ray, a small step beside it,
 * which costs rays and softens normals at creases and silhouettes (docs/render.md). The
 * mesh's colours, when it has them, colour the surfaces: vertex colours interpolated at the
 * hit's (u, v), else the triangle's colour (decoded from sRGB); without them, or without m,
 * surfaces are grey.
 *
 * The image is a pure function of (a's hits, m, c, options other than threads and
 * progress): the same call gives the same bytes on any number of threads.
 *
 * img may be empty or hold an earlier result, whose pixel buffer is reused when the size
 * matches (a viewer renders frame after frame without allocating). options may be NULL
 * (all defaults). On failure img is left empty. Errors: PRT_ERROR_ARGUMENT (NULL a or img,
 * bad size, fov or camera), PRT_ERROR_NOMEM. */
prt_status prt_render(const prt_accel *a, const prt_mesh *m, const prt_camera *c, const prt_render_options *options,
                      prt_image *img);

/* Write img as an 8-bit RGB PNG (libpng). PRT_ERROR_UNSUPPORTED when this build has no
 * libpng (use prt_image_save_ppm), PRT_ERROR_IO when the file cannot be written. */
prt_status prt_image_save_png(const prt_image *img, const char *path);

/* Write img as a binary PPM (P6); needs no library. */
prt_status prt_image_save_ppm(const prt_image *img, const char *path);

/* True when prt_image_save_png is available in this build. */
bool prt_image_png_supported(void);

/* Compare two images of the same size. *max_diff receives the largest absolute difference
 * of any channel of any pixel (0..255), *differing the number of pixels that differ,
 * *psnr_db the peak signal-to-noise ratio in dB over all channels (+inf when identical);
 * any output pointer may be NULL. When diff is not NULL it receives a new image showing
 * where they differ: black where equal, red scaled so that the largest difference is
 * full red. PRT_ERROR_ARGUMENT when the sizes differ. */
prt_status prt_image_compare(const prt_image *a, const prt_image *b, int *max_diff, size_t *differing, double *psnr_db,
                             prt_image *diff);

/* Free an image's pixels and reset it to empty. NULL is ignored. */
void prt_image_free(prt_image *img);

#ifdef __cplusplus
}
#endif
#endif /* PACKRT_H */
