/* The benchmark harness behind `packrt bench` (docs/benchmark.md): deterministic ray workloads,
 * a backend interface that lets packrt and Embree be timed the same way on the same rays,
 * timing (warm, cold, one thread, all threads), hit-for-hit checks and the report.
 * Tests use the ray generators and the Embree wrapper as references; both stand alone. */
#ifndef PRT_BENCH_H
#define PRT_BENCH_H

#include "packrt.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---------------------------------------------------------------------------------
 * Workloads: deterministic ray sets (bench/workloads.c)
 * --------------------------------------------------------------------------------- */

typedef enum bench_workload {
    BENCH_RANDOM,  /* Rouwé's RayCastTest rays: incoherent, closest hit */
    BENCH_PRIMARY, /* pinhole camera, rays grouped in square tiles (packets), closest hit */
    BENCH_SHADOW,  /* from primary hits toward a point light, any hit */
    BENCH_DIFFUSE, /* cosine-weighted bounces from primary hits, closest hit, incoherent */
    BENCH_WORKLOAD_COUNT
} bench_workload;

/* "random", "primary", "shadow", "diffuse". */
const char *bench_workload_name(bench_workload w);
/* Parse one workload name; false when unknown. */
bool bench_workload_parse(const char *name, bench_workload *out);

/* Rays of one workload. Owns its arrays (free with bench_rays_free). */
typedef struct bench_rays {
    bench_workload kind;
    prt_ray *rays;
    size_t count;
    bool any_hit;           /* true: occlusion queries (shadow) */
    uint32_t width, height; /* primary: image size in pixels */
    uint32_t tile;          /* primary: rays stored tile by tile, tile x tile pixels (partial at
                               the right and bottom edges), row-major inside a tile; 0: no tiles */
    uint32_t *pixel;        /* shadow, diffuse: pixel (primary ray index) each ray comes from */
} bench_rays;

void bench_rays_free(bench_rays *r);

/* Tiles of a primary ray set, in storage order: tile i covers rays [first, first + count),
 * `width` pixels wide. A set without tiles is one tile holding every ray. */
size_t bench_rays_tile_count(const bench_rays *r);
void bench_rays_tile(const bench_rays *r, size_t i, size_t *first, uint32_t *count, uint32_t *width);
/* Position in storage order of pixel (x, y) of a tiled primary set. */
size_t bench_rays_pixel_index(const bench_rays *r, uint32_t x, uint32_t y);

/* Random rays (docs/benchmark.md, after RayCastTest): the bounds are enlarged by 10% of their size on
 * each side; R = half the enlarged diagonal; each ray starts uniformly on the sphere of radius R
 * around the bounds centre and points at a uniform point inside the sphere of radius R/4 around
 * the centre. dir is normalised, tnear = 0, tfar = +inf. Ray i depends only on (seed, i)
 * order: the first 1024 rays of any count are the same 1024 rays. */
prt_status bench_rays_random(const float lo[3], const float hi[3], size_t count, uint64_t seed, bench_rays *out);

/* A pinhole camera. */
typedef struct bench_camera {
    float eye[3], target[3], up[3];
    float fov_y_deg;
} bench_camera;

/* The default view of a box: from the front (+z) and a little above and to the right (+y, +x),
 * 40 degrees vertical field of view, far enough that the bounding sphere fills the view. */
void bench_camera_default(const float lo[3], const float hi[3], bench_camera *c);

/* Primary rays for a width x height image, stored in tiles of `tile` pixels (8 when 0) so a
 * tile is a coherent packet. dir is normalised, tnear = 0, tfar = +inf. */
prt_status bench_rays_primary(const bench_camera *c, uint32_t width, uint32_t height, uint32_t tile, bench_rays *out);

/* The default point light: above, in front of and to the left of the box, outside it. */
void bench_light_default(const float lo[3], const float hi[3], float light[3]);

/* Where secondary rays start by default: 1e-4 of the mesh diagonal off the surface, far
 * above float rounding of the hit point (~1e-7 relative) and far below a triangle's size on
 * the meshes we bench. A lossy representation whose surface lies farther than half the
 * offset from the mesh's can hit itself: `packrt bench --offset` says so and sets it. */
#define BENCH_SURFACE_OFFSET 1e-4

/* Shadow rays: for every primary ray that hit (hits[i] from any accel, prim indexing m), a ray
 * from the hit point (interpolated on triangle prim, moved along the geometric normal toward
 * the side the primary ray came from by `offset`, in mesh units) toward light; dir
 * normalised, tnear = 0, tfar = distance to the light. Misses make no shadow ray. */
prt_status bench_rays_shadow(const prt_mesh *m, const bench_rays *primary, const prt_hit *hits, const float light[3],
                             float offset, bench_rays *out);

/* Diffuse bounce rays: for every primary hit, a cosine-weighted direction about the geometric
 * normal (facing the primary ray's side), same offset origin, tnear = 0, tfar = +inf. The
 * direction of the ray from pixel p depends only on (seed, p). */
prt_status bench_rays_diffuse(const prt_mesh *m, const bench_rays *primary, const prt_hit *hits, uint64_t seed,
                              float offset, bench_rays *out);

/* ---------------------------------------------------------------------------------
 * Backends: what the harness times (packrt: bench/backend_packrt.c)
 * --------------------------------------------------------------------------------- */

/* A ray set copied into a backend's own layout once, so converting rays is never timed. */
typedef struct bench_batch bench_batch;

typedef struct bench_backend {
    const char *name;
    void *self;
    /* Copy rays into the backend's layout; NULL when out of memory. */
    bench_batch *(*load)(void *self, const bench_rays *rays);
    /* Restore the loaded rays (closest-hit queries shrink tfar). Not timed. */
    void (*reset)(void *self, bench_batch *b);
    /* Timed: rays [first, first + count) one at a time on the calling thread (intersect1 /
     * occluded1): RayCastTest's way of casting. */
    void (*single)(void *self, bench_batch *b, size_t first, size_t count);
    /* Timed: every ray, on `threads` threads (1: the calling thread only), as a stream, or
     * as one packet per tile when the set has tiles. */
    void (*stream)(void *self, bench_batch *b, int threads);
    /* Results of the last run over the whole batch: hits (closest) or occluded (any hit). */
    void (*results)(void *self, const bench_batch *b, prt_hit *hits, uint8_t *occluded);
    void (*unload)(void *self, bench_batch *b);
    /* Memory and build time. */
    void (*stats)(void *self, prt_stats *s);
} bench_backend;

/* A packrt accel under test. Specs with ids=none (compact codecs that keep no map to the
 * mesh's triangle ids) hit positions in the accel's own order; order then maps them back
 * (as a user who asked for ids=none does once), outside every timed region, so hits can
 * be checked against Embree's. */
typedef struct bench_accel {
    prt_accel *accel;
    uint32_t *order; /* NULL, or mesh triangle id of each accel position (malloc'ed) */
} bench_accel;

/* Build spec over m with `threads` build threads; on failure *out is empty and
 * prt_last_error() says why. */
prt_status bench_build(const prt_mesh *m, const char *spec, int threads, bench_accel *out);
void bench_accel_free(bench_accel *b);

/* b as a backend (b and its accel are borrowed). */
bench_backend bench_backend_packrt(const bench_accel *b, const char *name);

/* Convenience: closest hits of r's rays on accel b, naming mesh triangles (rays are
 * copied, r is unchanged). *hits is malloc'ed (free()). */
prt_status bench_trace_hits(const bench_accel *b, const bench_rays *r, prt_hit **hits);

/* ---------------------------------------------------------------------------------
 * Embree (bench/embree_backend.c; stubs returning PRT_ERROR_UNSUPPORTED without Embree)
 * --------------------------------------------------------------------------------- */

/* True when this build has Embree. */
bool bench_embree_available(void);

typedef struct bench_embree bench_embree;

typedef struct bench_embree_options {
    int threads;  /* build threads; 0: Embree's default (all cores) */
    bool robust;  /* RTC_SCENE_FLAG_ROBUST (watertight-ish, slower); off for the `embree` row */
    bool compact; /* RTC_SCENE_FLAG_COMPACT */
    int quality;  /* 0: Embree's default (medium), 1: low, 2: medium, 3: high */
} bench_embree_options;

/* An Embree device and scene holding mesh m as one triangle geometry. The scene uses shared
 * buffers owned by the wrapper (vertices padded to 16 bytes, indices copied), so m may be
 * freed afterwards. options may be NULL. PRT_ERROR_UNSUPPORTED without Embree. */
prt_status bench_embree_create(const prt_mesh *m, const bench_embree_options *options, bench_embree **out);
void bench_embree_free(bench_embree *e);

/* Same contract as prt_intersect1 / prt_occluded1 (hits converted to prt_hit: t, u, v, prim;
 * u and v use packrt's convention, which is Embree's). Thread-safe. */
void bench_embree_intersect(const bench_embree *e, prt_ray *r, prt_hit *h);
bool bench_embree_occluded(const bench_embree *e, const prt_ray *r);
/* Closest hits of n <= PRT_PACKET_MAX coherent rays in one rtcIntersect1M call with the
 * coherent flag (as the primary workload's tiles), same contract as prt_intersect_packet. */
void bench_embree_intersect_coherent(const bench_embree *e, prt_ray *rays, prt_hit *hits, uint32_t n);
/* Same contract as prt_intersect_stream / prt_occluded_stream (threads 0: all cores). */
void bench_embree_intersect_stream(const bench_embree *e, prt_ray *rays, prt_hit *hits, size_t n, int threads);
void bench_embree_occluded_stream(const bench_embree *e, const prt_ray *rays, uint8_t *occluded, size_t n, int threads);

/* Memory split (see docs/benchmark.md): bytes_tree = every byte Embree itself holds after the
 * build, counted by its memory monitor (BVH nodes and the triangle data it copies into leaves);
 * bytes_geometry = the shared buffers it reads (16 bytes per padded vertex + 12 per triangle);
 * bytes_other = 0. build_seconds = rtcCommitScene. */
void bench_embree_stats(const bench_embree *e, prt_stats *s);

/* Closest points through rtcPointQuery with a closest-point callback (Embree's tutorial's
 * way), answered as prt_closest_points answers, on the calling thread. */
void bench_embree_closest_points(const bench_embree *e, const float *points, size_t n, prt_closest *out);

/* e as a backend: single rays with rtcIntersect1 / rtcOccluded1, streams as chunks of
 * rtcIntersect1M / rtcOccluded1M (coherent flag for tiles) over OpenMP threads. */
bench_backend bench_backend_embree(bench_embree *e, const char *name);

/* Embree behind the prt_accel interface (bench/embree_accel.c), so code written against
 * prt_accel, the renderer first, traces the same rays through Embree: prt_intersect1 and
 * prt_occluded1 are rtcIntersect1 / rtcOccluded1, prt_intersect_packet is
 * bench_embree_intersect_coherent. Its bounds are those of m's non-degenerate triangles, as
 * packrt's accels report theirs, so default cameras frame both alike; spec "embree". It
 * holds its own copy of m (m may be freed); prt_accel_free releases it; it cannot be saved
 * (PRT_ERROR_UNSUPPORTED) or updated. PRT_ERROR_UNSUPPORTED without Embree. */
prt_status bench_embree_accel(const prt_mesh *m, const bench_embree_options *options, prt_accel **out);

/* ---------------------------------------------------------------------------------
 * Timing (bench/harness.c, bench/cache_flush.c)
 * --------------------------------------------------------------------------------- */

typedef struct bench_options {
    int reps;           /* repetitions per figure (median); at least 5 */
    int threads;        /* threads of the "mt" figures; 0: all cores */
    size_t flush_bytes; /* cache flush buffer; 0: twice the last-level cache, see cache_flush.c */
    bool cold;          /* measure the cold figure (flushes cost time) */
} bench_options;

/* Evict caches the way the cold figure needs (see cache_flush.c for what and why). */
void bench_cache_flush(size_t flush_bytes);
/* The flush buffer size that flush_bytes = 0 selects. */
size_t bench_cache_flush_default_bytes(void);

/* Median and minimum of n values (values is reordered: sorted, for the median). */
double bench_median(double *values, size_t n);
double bench_min(const double *values, size_t n);

/* Figures of one workload on one backend. 0 where not measured. */
typedef struct bench_figures {
    size_t rays;
    double mrays_1t; /* million rays per second, one thread, median */
    double mrays_mt; /* same on options.threads threads */
} bench_figures;

/* Rouwé's figures on the first 1024 rays of a random set (single-ray queries, one thread):
 * warm = minimum over repetitions after a warm-up pass, in µs per 1024 rays; cold = median
 * over repetitions with caches flushed before each batch, in µs per 1024 rays (divide by 1024
 * for the paper's µs per ray). */
void bench_measure_random_1024(const bench_backend *b, const bench_rays *random, const bench_options *o,
                               double *warm_us, double *cold_us);

/* Rouwé's FLUSH_CACHE_AFTER_EVERY_RAY figure: each of the first n random rays cast alone
 * after a cache flush of flush_bytes (0: the default), the times summed and scaled to µs
 * per 1024 rays. 0 when out of memory. */
double bench_measure_random_cold_per_ray(const bench_backend *b, const bench_rays *random, size_t n,
                                         size_t flush_bytes);

/* Mrays/s of a workload on one thread and on o->threads threads; hits / occluded (either may
 * be NULL, sized rays->count) receive the results for checking. False when out of memory. */
bool bench_measure_workload(const bench_backend *b, const bench_rays *rays, const bench_options *o, bench_figures *f,
                            prt_hit *hits, uint8_t *occluded);

/* ---------------------------------------------------------------------------------
 * Checks: do two backends agree on the benchmark rays? (bench/check.c)
 * --------------------------------------------------------------------------------- */

typedef struct bench_check {
    bool done;
    size_t rays;
    size_t hit_miss;     /* one hit, the other missed (or occluded flags differ) */
    size_t prim_differ;  /* both hit, different triangles (often a shared edge: fine when t agrees) */
    size_t t_differ;     /* both hit, |t - t_ref| > BENCH_CHECK_T_REL x scene diagonal */
    double max_dt_rel;   /* max |t - t_ref| / scene diagonal over rays both hit */
    bool lossy;          /* checked against a lossy representation's stated bound too */
    size_t beyond_bound; /* lossy: rays whose answer no surface within the bound explains */
} bench_check;

/* What a lossy representation's answers are checked with: the mesh the reference traced,
 * the rays as cast (indexing the answers), the representation's stated vertex error and a
 * tolerance for float rounding (BENCH_CHECK_T_REL of the diagonal). */
typedef struct bench_lossy {
    const prt_mesh *mesh;
    const prt_ray *rays;
    double vertex_error, tol;
} bench_lossy;

/* Whether `got` is a right answer of a lossy representation for ray r, given the exact
 * answer `want`, when every decoded triangle lies within err of its mesh triangle (plus
 * tol for float rounding): a reported hit lies within err + tol of the triangle it names,
 * and it is no farther than the decoded copy of want's triangle can be, unless the ray
 * passes so close to want's edges (within 2 (err + tol) / cos) that the copy may be
 * missed. A bound, not bit equality: what the tests and the benchmark check lossy
 * representations with. */
bool bench_lossy_acceptable(const prt_mesh *m, const prt_ray *r, const prt_hit *got, const prt_hit *want, double err,
                            double tol);

/* Relative t tolerance of a "t_differ" ray: RayCastTest's mismatch threshold (1e-5 of the
 * model size). */
#define BENCH_CHECK_T_REL 1e-5

/* True when a check shows a wrong backend rather than edge cases: more than 1 ray in 10^4
 * disagreeing on hit/miss or on t (for a lossy representation: beyond its stated bound).
 * Embree itself (float, not watertight) differs from an exact answer on a few rays per
 * million that graze edges or slivers. */
bool bench_check_bad(const bench_check *c);

/* lossy: NULL for a lossless representation (t within BENCH_CHECK_T_REL decides). */
void bench_check_hits(const prt_hit *hits, const prt_hit *ref, size_t n, double diagonal, const bench_lossy *lossy,
                      bench_check *c);
/* lossy: as for bench_check_hits; a disagreement then counts beyond the bound unless the
 * exact surface comes within the error of the ray's segment (blocked) or crosses it only
 * near an edge or an end (open). */
void bench_check_occluded(const uint8_t *occ, const uint8_t *ref, size_t n, const bench_lossy *lossy, bench_check *c);

/* ---------------------------------------------------------------------------------
 * One row per representation and the report (bench/report.c)
 * --------------------------------------------------------------------------------- */

typedef struct bench_row {
    char name[96];
    bool ok;
    char error[256];
    bool is_embree;
    size_t triangles;
    double build_s;
    double bytes_per_tri_tree, bytes_per_tri_geometry, bytes_per_tri_total;
    double vertex_error;            /* lossy representations: the stated bound, else 0 */
    char detail[256];               /* prt_stats.detail */
    double random_us_per_1024;      /* warm, one thread, minimum */
    double random_us_per_1024_cold; /* cold, one thread, median */
    bench_figures w[BENCH_WORKLOAD_COUNT];
    bench_check check[BENCH_WORKLOAD_COUNT];
    int rounds;    /* rounds the timings are medians of (fresh build each round) */
    double spread; /* largest (max - min) / median over rounds of any one-thread timing */
} bench_row;

/* A figure whose spread over rounds exceeds this is marked unreliable in the report. */
#define BENCH_SPREAD_MARK 0.10

/* The rounds of one representation as one row (bench/rounds.c): medians of the timings
 * over rounds[0..n), memory and checks of the first round (builds are deterministic), and
 * the spread. n >= 1; a round that failed makes the row fail with its error. */
void bench_rows_median(const bench_row *rounds, size_t n, bench_row *out);

/* What `packrt bench` runs without -r (bench/specs.c): every family, and every BVH
 * layout once, the fastest and the smallest codecs of wide8. NULL-terminated. */
extern const char *const bench_default_specs[];
/* What --calibrate measures without -r: the candidates of `auto` specs. NULL-terminated. */
extern const char *const bench_calibrate_specs[];

/* The cost table file of `auto` specs (bench/costs.c, docs/auto.md) as its lines: read
 * (a missing file is an empty table), a row set by spec, mesh kind and size, written atomically
 * (its directory created when missing). */
typedef struct bench_costs {
    char **lines;
    size_t count, cap;
} bench_costs;
void bench_costs_read(bench_costs *t, const char *path);
bool bench_costs_set(bench_costs *t, const char *spec, const char *kind, uint64_t triangles, const char *line);
prt_status bench_costs_write(const bench_costs *t, const char *path);
void bench_costs_free(bench_costs *t);

/* Fill a row's memory and build figures from stats. */
void bench_row_set_stats(bench_row *row, const prt_stats *s, size_t triangles);

typedef struct bench_report {
    const char *machine;   /* "CPU model, N cores" */
    const char *commit;    /* short hash or "unknown" */
    double load_average;   /* 1-minute load when the run started (other processes), -1: unknown */
    const char *mesh_path; /* file name or "gen:KIND:TRIS:SEED" */
    size_t triangles, vertices;
    const char *reference; /* name the checks compare against, NULL: none */
    bench_options options;
    int rounds;     /* rounds each row's timings are medians of */
    int threads_mt; /* resolved thread count of the mt figures */
    uint64_t seed;
    bool workload_on[BENCH_WORKLOAD_COUNT];
    size_t workload_rays[BENCH_WORKLOAD_COUNT];
    uint32_t width, height, tile; /* primary image, and its tiles' side */
    const bench_row *rows;
    size_t row_count;
} bench_report;

/* The table (one row per representation, ratios against the row named "embree"), the check
 * lines, and notes. */
void bench_report_text(FILE *f, const bench_report *r);
/* The JSON object of docs/benchmark.md. */
void bench_report_json(FILE *f, const bench_report *r);
/* The memory/speed trade-off as an SVG picture (bench/plot.c): every measured row as a point,
 * total bytes per triangle against warm time per ray (random workload, one thread), Embree
 * marked, the Pareto front joined and labelled. False (errno set) when writing fails. */
bool bench_plot_svg(FILE *f, const bench_report *r);

/* ---------------------------------------------------------------------------------
 * The Rouwé matrix (bench/matrix.c): `packrt bench MESH --matrix`
 * --------------------------------------------------------------------------------- */

typedef struct bench_matrix_options {
    int reps;               /* warm figure: minimum over 4 x reps batches; cold: median of reps */
    bool cold;              /* measure the cold figures */
    size_t flush_bytes;     /* per-batch flush buffer (0: default) */
    size_t cold_rays;       /* rays of the per-ray cold figure (0: skip it) */
    size_t flush_bytes_ray; /* per-ray flush buffer */
    uint64_t seed;
    bool vs_embree;
    const char *const *specs; /* representations of the main table; NULL: every registered one */
    size_t spec_count;
    const char *mesh_name, *machine, *commit;
    double load_average;
} bench_matrix_options;

/* Measure every representation (and Embree) on the first 1024 random rays, one thread,
 * and print Rouwé's tables (§3.11, §4.1-4.3, §6) as markdown to f. Returns 0, or 1 when a
 * representation failed for a reason other than a mesh it cannot encode. */
int bench_matrix(FILE *f, const prt_mesh *m, const bench_matrix_options *o);

/* "CPU model, N cores" from /proc/cpuinfo and the online core count. */
void bench_machine_string(char *buf, size_t size);
/* 1-minute load average from /proc/loadavg, -1 when unknown. */
double bench_load_average(void);

/* `packrt bench --queries` (bench/queries.c): closest points and containment on each spec
 * against Embree (rtcPointQuery; trimesh's re-casting containment), a Markdown report. */
typedef struct bench_queries_options {
    const char *const *specs;
    size_t spec_count;
    size_t points; /* per point set */
    int reps;
    uint64_t seed;
    bool vs_embree;
} bench_queries_options;
int bench_queries(FILE *f, const prt_mesh *m, const bench_queries_options *o);

#ifdef __cplusplus
}
#endif
#endif
