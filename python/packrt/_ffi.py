"""The C declarations the package uses (copied from include/packrt.h) and the loading of
libpackrt.so in cffi's ABI mode: no compiler at install, the library is opened at import.

Where the library is looked for, first found wins:
  1. the environment variable PACKRT_LIBRARY (a path to libpackrt.so);
  2. the build tree: <repository>/build/libpackrt.so, next to this package's python/ folder;
  3. the installed layout of `cmake --install`: <prefix>/lib/libpackrt.so, with this package
     in <prefix>/lib/python3/dist-packages/packrt;
  4. the system's library path (ctypes.util.find_library("packrt")).
"""
import ctypes.util
import os

import cffi

ffi = cffi.FFI()
ffi.cdef(
    """
typedef enum prt_status {
    PRT_OK = 0, PRT_ERROR_ARGUMENT, PRT_ERROR_IO, PRT_ERROR_FORMAT, PRT_ERROR_MESH,
    PRT_ERROR_CORRUPT, PRT_ERROR_UNSUPPORTED, PRT_ERROR_NOMEM, PRT_ERROR_LIMIT
} prt_status;
const char *prt_status_string(prt_status s);
const char *prt_last_error(void);

typedef struct prt_mesh {
    float *vertices; uint32_t *triangles; size_t vertex_count; size_t triangle_count;
    uint8_t *vertex_colors; uint8_t *triangle_colors; uint16_t *materials;
} prt_mesh;
prt_status prt_mesh_create(size_t vertex_count, size_t triangle_count, prt_mesh **out);
void prt_mesh_free(prt_mesh *m);
prt_status prt_mesh_load(const char *path, prt_mesh **out);
prt_status prt_mesh_generate(const char *kind, size_t triangles, uint64_t seed, prt_mesh **out);

typedef struct prt_ray { float org[3], tnear; float dir[3], tfar; } prt_ray;
typedef struct prt_hit { float t, u, v; uint32_t prim; uint32_t geom; } prt_hit;

typedef struct prt_accel prt_accel;
typedef struct prt_build_options {
    int threads; void (*progress)(void *user, float fraction); void *progress_user;
    uint32_t *triangle_order; uint64_t memory_budget;
} prt_build_options;
typedef struct prt_stats {
    size_t triangles; size_t triangles_built;
    size_t bytes_tree; size_t bytes_geometry; size_t bytes_other;
    size_t nodes; size_t leaves; uint32_t depth;
    double build_seconds; size_t build_peak_bytes; double vertex_error;
    char detail[256];
} prt_stats;
prt_status prt_build(const prt_mesh *m, const char *spec, const prt_build_options *options,
                     prt_accel **out);
void prt_accel_free(prt_accel *a);
const char *prt_accel_spec(const prt_accel *a);
void prt_accel_bounds(const prt_accel *a, float lo[3], float hi[3]);
void prt_accel_stats(const prt_accel *a, prt_stats *s);
void prt_intersect1(const prt_accel *a, prt_ray *r, prt_hit *h);
void prt_intersect_stream(const prt_accel *a, prt_ray *rays, prt_hit *hits, size_t n, int threads);
void prt_occluded_stream(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, size_t n,
                         int threads);
void prt_intersect_rays6(const prt_accel *a, const float *rays6, size_t n, const float *tnear, size_t tnear_stride,
                         const float *tfar, size_t tfar_stride, prt_hit *hits, int threads);
void prt_occluded_rays6(const prt_accel *a, const float *rays6, size_t n, const float *tnear, size_t tnear_stride,
                        const float *tfar, size_t tfar_stride, uint8_t *occluded, int threads);
prt_status prt_accel_save(const prt_accel *a, const char *path);
prt_status prt_accel_load(const char *path, prt_accel **out);
typedef struct prt_open_options { uint64_t cache_bytes; int fetchers; } prt_open_options;
prt_status prt_accel_open(const char *path, const prt_open_options *o, prt_accel **out);

/* Mesh queries (issue 28): missing from libraries built before it; the package checks. */
prt_status prt_intersect_all_stream(const prt_accel *a, const prt_ray *rays, size_t n, uint32_t *counts,
                                    const uint64_t *offsets, prt_hit *hits, int threads);
typedef struct prt_closest { float point[3]; float distance; float u, v; uint32_t prim; } prt_closest;
prt_status prt_closest_points(const prt_accel *a, const float *points, size_t n, float max_distance,
                              prt_closest *out, int threads);
prt_status prt_contains(const prt_accel *a, const float *points, size_t n, uint8_t *result, int threads);
prt_status prt_winding_number(const prt_accel *a, const float *points, size_t n, float *winding,
                              int threads);
prt_status prt_signed_distance(const prt_accel *a, const float *points, size_t n, float max_distance,
                               float *distance, int threads);
prt_status prt_contains_by(const prt_accel *a, const float *points, size_t n, int method, uint8_t *result,
                           int threads);
prt_status prt_winding_number_fast(const prt_accel *a, const float *points, size_t n, float beta, float *winding,
                                   int threads);
"""
)

#: Bits of prt_contains' answers (include/packrt.h).
PRT_INSIDE = 1
PRT_BY_WINDING = 2
#: prt_contains_method values, by name (include/packrt.h).
CONTAINS_METHODS = {"auto": 0, "parity": 1, "winding": 2}


def _candidates():
    env = os.environ.get("PACKRT_LIBRARY")
    if env:
        # An explicit choice: use it or fail, never fall back to another copy silently.
        return [env]
    here = os.path.dirname(os.path.abspath(__file__))
    paths = [
        os.path.join(here, "..", "..", "build", "libpackrt.so"),  # <repo>/python/packrt
        os.path.join(here, "..", "..", "..", "libpackrt.so"),  # <prefix>/lib/python3/dist-packages/packrt
    ]
    paths = [os.path.normpath(p) for p in paths if os.path.exists(p)]
    found = ctypes.util.find_library("packrt")
    if found:
        paths.append(found)
    return paths


def _open():
    tried = _candidates()
    errors = []
    for path in tried:
        try:
            return ffi.dlopen(path), path
        except OSError as e:
            errors.append(f"{path}: {e}")
    raise ImportError(
        "packrt: cannot load libpackrt.so (set PACKRT_LIBRARY to its path, build it with "
        "`cmake --build build --target packrt_shared`, or `cmake --install`); "
        + ("tried " + "; ".join(errors) if errors else "found none")
    )


lib, library_path = _open()
