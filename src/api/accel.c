/* The API layer: validates arguments and rays, times builds, dispatches to the
 * representation's ops, and provides the generic packet and stream paths. */
#include "api/accel.h"
#include "api/auto.h"
#include "geom/ray.h"
#include "mesh/mesh.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>

prt_status prt_build(const prt_mesh *m, const char *spec_text, const prt_build_options *o, prt_accel **out) {
    if (!out) return prt__fail(PRT_ERROR_ARGUMENT, "prt_build: out is NULL");
    *out = NULL;
    prt_status s = prt_mesh_validate(m);
    if (s) return s;
    /* Beyond this, the triangle test's numerator overflows (PRT_MAX_COORDINATE). */
    for (size_t i = 0; i < 3 * m->vertex_count; i++)
        if (fabsf(m->vertices[i]) > PRT_MAX_COORDINATE)
            return prt__fail(PRT_ERROR_LIMIT,
                             "vertex %zu has a coordinate of magnitude %g; packrt builds meshes within +-%g", i / 3,
                             (double)m->vertices[i], (double)PRT_MAX_COORDINATE);
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    if ((s = prt__check_extent(lo, hi))) return s;
    prt_spec spec;
    if ((s = prt__spec_parse(spec_text, &spec))) return s;
    if (!strcmp(spec.structure, "auto")) return prt__build_auto(m, spec_text, o, out);
    const prt_repr_family *f = prt__registry_find(&spec);
    if (!f) return PRT_ERROR_ARGUMENT;

    size_t mem0, peak;
    prt_memory_usage(&mem0, NULL);
    prt_memory_reset_peak();
    double t0 = prt__now();
    prt_accel *a = NULL;
    if ((s = f->ops->build(m, &spec, o, &a))) return s;
    a->build_seconds = prt__now() - t0;
    if (o && o->progress) o->progress(o->progress_user, 1.0f);
    prt_memory_usage(NULL, &peak);
    a->build_peak_bytes = peak > mem0 ? peak - mem0 : 0;
    a->triangles = m->triangle_count;
    prt__spec_format(&spec, a->spec, sizeof a->spec);
    *out = a;
    return PRT_OK;
}

void prt__unmap(void *p, size_t size); /* io/prt_file.c */

void prt_accel_free(prt_accel *a) {
    if (!a) return;
    void *map = a->file_mapping;
    size_t size = a->file_mapping_size;
    bool copy = a->file_mapping_is_copy;
    a->ops->destroy(a);
    if (map && copy) prt__free(map);
    else if (map) prt__unmap(map, size);
}

prt_status prt__check_update_vertices(const float *vertices, size_t count) {
    /* Blocks of 1024 coordinates checked without a branch (the loop vectorizes), then the
     * first bad one of a failing block found for the message. */
    size_t i = count;
    for (size_t b = 0; b < count && i == count; b += 1024) {
        const size_t e = PRT_MIN(count, b + 1024);
        int bad = 0;
        for (size_t j = b; j < e; j++) bad |= !(fabsf(vertices[j]) <= PRT_MAX_COORDINATE);
        if (bad)
            for (i = b; fabsf(vertices[i]) <= PRT_MAX_COORDINATE;) i++;
    }
    if (i < count)
        return prt__fail(isfinite(vertices[i]) ? PRT_ERROR_LIMIT : PRT_ERROR_MESH,
                         "prt_accel_update: vertex %zu has coordinate %g (finite, within +-%g expected)", i / 3,
                         (double)vertices[i], (double)PRT_MAX_COORDINATE);
    return PRT_OK;
}

prt_status prt_accel_update(prt_accel *a, const float *vertices) {
    if (!a || !vertices) return prt__fail(PRT_ERROR_ARGUMENT, "prt_accel_update: NULL argument");
    if (!PRT_CAP(a, update))
        return prt__fail(
            PRT_ERROR_UNSUPPORTED,
            "prt_accel_update: representation '%s' cannot be updated in place; build it again from the moved mesh",
            a->spec);
    double t0 = prt__now();
    prt_status s = a->ops->caps->update(a, vertices);
    if (!s) a->build_seconds = prt__now() - t0;
    return s;
}

const char *prt_accel_spec(const prt_accel *a) { return a->spec; }

void prt_accel_bounds(const prt_accel *a, float lo[3], float hi[3]) {
    memcpy(lo, a->bounds, 3 * sizeof(float));
    memcpy(hi, a->bounds + 3, 3 * sizeof(float));
}

void prt_accel_stats(const prt_accel *a, prt_stats *s) {
    memset(s, 0, sizeof *s);
    a->ops->stats(a, s);
    s->triangles = a->triangles;
    s->triangles_built = a->triangles_built;
    s->build_seconds = a->build_seconds;
    s->build_peak_bytes = a->build_peak_bytes;
}

void prt_intersect1(const prt_accel *a, prt_ray *r, prt_hit *h) {
    if (PRT_UNLIKELY(!prt__ray_valid(r))) {
        *h = prt__miss();
        return;
    }
    a->ops->intersect1(a, r, h);
}

bool prt_occluded1(const prt_accel *a, const prt_ray *r) {
    if (PRT_UNLIKELY(!prt__ray_valid(r))) return false;
    return a->ops->occluded1(a, r);
}

/* Both packet queries hand a family at most PRT_PACKET_MAX rays and answer the rest one by
 * one, so no family's packet walk needs its own cap. */
void prt_intersect_packet(const prt_accel *a, prt_packet *p) {
    uint32_t n = p->count < PRT_PACKET_MAX ? p->count : PRT_PACKET_MAX;
    if (a->ops->intersect_packet && n) {
        prt_packet q = *p;
        q.count = n;
        a->ops->intersect_packet(a, &q);
    } else {
        n = 0;
    }
    for (uint32_t i = n; i < p->count; i++) prt_intersect1(a, &p->rays[i], &p->hits[i]);
}

void prt_occluded_packet(const prt_accel *a, const prt_packet *p, uint8_t *occluded) {
    uint32_t n = p->count < PRT_PACKET_MAX ? p->count : PRT_PACKET_MAX;
    if (a->ops->occluded_packet && n) {
        prt_packet q = *p;
        q.count = n;
        a->ops->occluded_packet(a, &q, occluded);
    } else {
        n = 0;
    }
    for (uint32_t i = n; i < p->count; i++) occluded[i] = prt_occluded1(a, &p->rays[i]);
}

/* Chunks of 256 rays: big enough to amortise scheduling, small enough to balance. */
#define STREAM_CHUNK 256

/* Rays [0, n) of a stream on this thread. */
static void intersect_run(const prt_accel *a, prt_ray *rays, prt_hit *hits, size_t n) {
    if (a->ops->intersect_stream) a->ops->intersect_stream(a, rays, hits, n);
    else
        for (size_t i = 0; i < n; i++) prt_intersect1(a, &rays[i], &hits[i]);
}

void prt_intersect_stream(const prt_accel *a, prt_ray *rays, prt_hit *hits, size_t n, int threads) {
    int t = prt__threads(threads);
    if (t == 1 || n <= STREAM_CHUNK) {
        intersect_run(a, rays, hits, n);
        return;
    }
#pragma omp parallel for num_threads(t) schedule(dynamic, 1)
    for (size_t c = 0; c < (n + STREAM_CHUNK - 1) / STREAM_CHUNK; c++) {
        const size_t first = c * STREAM_CHUNK;
        intersect_run(a, rays + first, hits + first, n - first < STREAM_CHUNK ? n - first : STREAM_CHUNK);
    }
}

#define STREAM_PACKET 64
void prt__occluded_stream_packets(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, size_t n) {
    for (size_t first = 0; first < n; first += STREAM_PACKET) {
        const uint32_t k = (uint32_t)(n - first < STREAM_PACKET ? n - first : STREAM_PACKET);
        a->ops->occluded_packet(a, &(prt_packet){(prt_ray *)rays + first, NULL, k, k}, occluded + first);
    }
}

/* Any hits of rays [0, n) of a stream on this thread. */
static void occluded_run(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, size_t n) {
    if (a->ops->occluded_stream) a->ops->occluded_stream(a, rays, occluded, n);
    else
        for (size_t i = 0; i < n; i++) occluded[i] = prt_occluded1(a, &rays[i]);
}

void prt_occluded_stream(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, size_t n, int threads) {
    int t = prt__threads(threads);
    if (t == 1 || n <= STREAM_CHUNK) {
        occluded_run(a, rays, occluded, n);
        return;
    }
#pragma omp parallel for num_threads(t) schedule(dynamic, 1)
    for (size_t c = 0; c < (n + STREAM_CHUNK - 1) / STREAM_CHUNK; c++) {
        const size_t first = c * STREAM_CHUNK;
        occluded_run(a, rays + first, occluded + first, n - first < STREAM_CHUNK ? n - first : STREAM_CHUNK);
    }
}

/* Rays [first, first + count) of a (n, 6) array as records: tnear and tfar from their
 * arrays (stride 1), one value (stride 0) or the defaults (NULL). */
static void rays6_records(const float *rays6, const float *tnear, size_t tnear_stride, const float *tfar,
                          size_t tfar_stride, size_t first, size_t count, prt_ray *out) {
    for (size_t i = 0; i < count; i++) {
        const float *r = rays6 + 6 * (first + i);
        out[i] = (prt_ray){{r[0], r[1], r[2]},
                           tnear ? tnear[(first + i) * tnear_stride] : 0.0f,
                           {r[3], r[4], r[5]},
                           tfar ? tfar[(first + i) * tfar_stride] : INFINITY};
    }
}

/* prt_intersect_rays6 (hits) and prt_occluded_rays6 (occluded): each chunk's records are
 * made on the thread that traces them, where they stay in cache. */
static void rays6_stream(const prt_accel *a, const float *rays6, size_t n, const float *tnear, size_t tnear_stride,
                         const float *tfar, size_t tfar_stride, prt_hit *hits, uint8_t *occluded, int threads) {
#pragma omp parallel for num_threads(prt__threads(threads)) schedule(dynamic, 1) if (n > STREAM_CHUNK)
    for (size_t c = 0; c < (n + STREAM_CHUNK - 1) / STREAM_CHUNK; c++) {
        prt_ray rays[STREAM_CHUNK];
        const size_t first = c * STREAM_CHUNK, count = n - first < STREAM_CHUNK ? n - first : STREAM_CHUNK;
        rays6_records(rays6, tnear, tnear_stride, tfar, tfar_stride, first, count, rays);
        if (hits) intersect_run(a, rays, hits + first, count);
        else
            for (size_t i = 0; i < count; i++) occluded[first + i] = prt_occluded1(a, &rays[i]);
    }
}

void prt_intersect_rays6(const prt_accel *a, const float *rays6, size_t n, const float *tnear, size_t tnear_stride,
                         const float *tfar, size_t tfar_stride, prt_hit *hits, int threads) {
    rays6_stream(a, rays6, n, tnear, tnear_stride, tfar, tfar_stride, hits, NULL, threads);
}

void prt_occluded_rays6(const prt_accel *a, const float *rays6, size_t n, const float *tnear, size_t tnear_stride,
                        const float *tfar, size_t tfar_stride, uint8_t *occluded, int threads) {
    rays6_stream(a, rays6, n, tnear, tnear_stride, tfar, tfar_stride, NULL, occluded, threads);
}

/* --- Levels of detail and caches ---------------------------------------------------- */

bool prt_intersect_lod(const prt_accel *a, prt_ray *r, float error, prt_lod_hit *h) {
    memset(h, 0, sizeof *h);
    if (PRT_UNLIKELY(!prt__ray_valid(r))) {
        h->hit = prt__miss();
        return false;
    }
    if (PRT_CAP(a, lod_query)) return a->ops->caps->lod_query(a, r, error, false, h);
    a->ops->intersect1(a, r, &h->hit);
    return h->hit.prim != PRT_INVALID;
}

void prt_intersect_lod_packet(const prt_accel *a, prt_ray *rays, prt_lod_hit *hits, uint32_t n, float error) {
    bool valid = true;
    for (uint32_t i = 0; i < n && valid; i++) valid = prt__ray_valid(&rays[i]);
    if (valid && PRT_CAP(a, lod_packet)) {
        a->ops->caps->lod_packet(a, rays, hits, n, error);
        return;
    }
    for (uint32_t i = 0; i < n; i++) prt_intersect_lod(a, &rays[i], error, &hits[i]);
}

bool prt_occluded_lod(const prt_accel *a, const prt_ray *r, float error) {
    if (PRT_UNLIKELY(!prt__ray_valid(r))) return false;
    if (PRT_CAP(a, lod_query)) {
        prt_ray copy = *r;
        prt_lod_hit h;
        return a->ops->caps->lod_query(a, &copy, error, true, &h);
    }
    return a->ops->occluded1(a, r);
}

void prt_occluded_lod_packet(const prt_accel *a, const prt_ray *rays, uint8_t *occluded, uint32_t n, float error) {
    bool valid = true;
    for (uint32_t i = 0; i < n && valid; i++) valid = prt__ray_valid(&rays[i]);
    if (valid && PRT_CAP(a, lod_occluded_packet)) {
        a->ops->caps->lod_occluded_packet(a, rays, occluded, n, error);
        return;
    }
    for (uint32_t i = 0; i < n; i++) occluded[i] = prt_occluded_lod(a, &rays[i], error);
}

void prt_accel_frame(prt_accel *a, prt_cache_info *info) {
    if (info) memset(info, 0, sizeof *info);
    if (a && PRT_CAP(a, frame)) a->ops->caps->frame(a, info);
}

prt_status prt_accel_check(const prt_accel *a) {
    if (!a) return prt__fail(PRT_ERROR_ARGUMENT, "prt_accel_check: NULL accel");
    return PRT_CAP(a, check) ? a->ops->caps->check(a) : PRT_OK;
}

/* --- .prt files ---------------------------------------------------------------------- */

static prt_status fill_sections(const void *ctx, prt_writer *w) {
    const prt_accel *a = ctx;
    return a->ops->save(a, w);
}

prt_status prt_accel_save(const prt_accel *a, const char *path) {
    if (!a || !path) return prt__fail(PRT_ERROR_ARGUMENT, "prt_accel_save: NULL argument");
    if (PRT_CAP(a, save_file)) return a->ops->caps->save_file(a, path);
    prt_file_info info = {{0}, {0}, a->triangles, a->triangles_built, a->build_seconds};
    snprintf(info.spec, sizeof info.spec, "%s", a->spec);
    memcpy(info.bounds, a->bounds, sizeof info.bounds);
    return prt__file_save(path, &info, fill_sections, a);
}

prt_status prt__accel_open_own(const void *mem, uint64_t size, int fd, const void *head, size_t head_size,
                               const char *name, const prt_open_options *o, bool verify_crc, prt_accel **out) {
    *out = NULL;
    const prt_repr_family *f = prt__registry_probe(head, head_size);
    return f ? f->ops->caps->open(mem, size, fd, name, o, verify_crc, out) : PRT_OK;
}

/* A checked container's accel, loaded by the family its spec names. */
static prt_status open_container(const void *data, size_t size, bool verify_crc, prt_accel **out) {
    prt_file_info info;
    prt_reader r;
    prt_status s = prt__file_open(data, size, verify_crc, &info, &r);
    if (s) return s;
    prt_spec spec;
    if (prt__spec_parse(info.spec, &spec))
        return prt__fail(PRT_ERROR_CORRUPT, "the file's representation spec '%.64s' is malformed", info.spec);
    const prt_repr_family *f = prt__registry_find(&spec);
    if (!f)
        return prt__fail(PRT_ERROR_UNSUPPORTED, "the file holds representation '%.64s', unknown to this packrt",
                         info.spec);
    if (!f->ops->load)
        return prt__fail(PRT_ERROR_CORRUPT,
                         "a .prt container names representation '%.64s', which is stored in a format of its own",
                         info.spec);
    prt_accel *a = NULL;
    if ((s = f->ops->load(&r, &spec, &a))) return s;
    memcpy(a->spec, info.spec, sizeof a->spec);
    memcpy(a->bounds, info.bounds, sizeof a->bounds);
    a->triangles = info.triangles;
    a->triangles_built = info.triangles_built;
    a->build_seconds = info.build_seconds;
    *out = a;
    return PRT_OK;
}

prt_status prt__accel_open(const void *data, size_t size, bool verify_crc, prt_accel **out) {
    prt_status s = prt__accel_open_own(data, size, -1, data, size, "file in memory", NULL, verify_crc, out);
    if (s || *out) return s;
    return open_container(data, size, verify_crc, out);
}

prt_status prt_accel_load_memory(const void *data, size_t size, prt_accel **out) {
    if (!data || !out) return prt__fail(PRT_ERROR_ARGUMENT, "prt_accel_load_memory: NULL argument");
    /* A family's own format is read where it lies; containers need 64-byte alignment. */
    prt_status s = prt__accel_open_own(data, size, -1, data, size, "file in memory", NULL, true, out);
    if (s || *out) return s;
    if ((uintptr_t)data % 64 == 0) return open_container(data, size, true, out);
    /* Layouts read their nodes in place and need the container's 64-byte alignment. */
    void *copy = prt__alloc(size);
    if (!copy) return prt__fail(PRT_ERROR_NOMEM, "out of memory copying a %zu-byte .prt image", size);
    memcpy(copy, data, size);
    s = open_container(copy, size, true, out);
    if (s) {
        prt__free(copy);
        return s;
    }
    (*out)->file_mapping = copy;
    (*out)->file_mapping_size = size;
    (*out)->file_mapping_is_copy = true;
    return PRT_OK;
}
