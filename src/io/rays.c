/* .rays and .hits files (docs/formats.md): an 8-byte magic, a uint64 count, then fixed-size
 * little-endian records. */
#include "core/common.h"
#include "io/atomic_file.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <sys/stat.h>

#define RAYS_MAGIC "PRTRAYS1"
#define HITS_MAGIC "PRTHITS1"
#define HIT_RECORD 16

static prt_status read_array(const char *path, const char *magic, size_t record, void **out, size_t *count) {
    *out = NULL;
    *count = 0;
    FILE *f = fopen(path, "rb");
    if (!f) return prt__fail(PRT_ERROR_IO, "%s: %s", path, strerror(errno));
    char m[8];
    uint64_t n;
    struct stat st;
    prt_status s = PRT_OK;
    if (fread(m, 1, 8, f) != 8 || memcmp(m, magic, 8) != 0)
        s = prt__fail(PRT_ERROR_FORMAT, "%s: not a %.8s file (bad magic)", path, magic);
    else if (fread(&n, 8, 1, f) != 1) s = prt__fail(PRT_ERROR_FORMAT, "%s: truncated header", path);
    else if (fstat(fileno(f), &st) != 0 || (uint64_t)st.st_size < 16 || ((uint64_t)st.st_size - 16) / record < n ||
             ((uint64_t)st.st_size - 16) != n * record)
        s = prt__fail(PRT_ERROR_FORMAT, "%s: header says %llu records of %zu bytes, the file has %lld bytes of data",
                      path, (unsigned long long)n, record, (long long)st.st_size - 16);
    if (!s) {
        *out = prt__alloc(n ? (size_t)n * record : 1);
        if (!*out) s = prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for %llu records", path, (unsigned long long)n);
        else if (fread(*out, record, (size_t)n, f) != n) s = prt__fail(PRT_ERROR_IO, "%s: read failed", path);
    }
    fclose(f);
    if (s) {
        prt__free(*out);
        *out = NULL;
        return s;
    }
    *count = (size_t)n;
    return PRT_OK;
}

static prt_status write_array(const char *path, const char *magic, const void *data, size_t record, size_t count) {
    prt__afile a;
    prt_status s = prt__afile_open(&a, path);
    if (s) return s;
    uint64_t n = count;
    s = prt__afile_write(&a, magic, 8);
    if (!s) s = prt__afile_write(&a, &n, 8);
    if (!s) s = prt__afile_write(&a, data, prt__mul_size(record, count));
    if (s) prt__afile_abort(&a);
    return s ? s : prt__afile_commit(&a);
}

prt_status prt_rays_read(const char *path, prt_ray **rays, size_t *count) {
    _Static_assert(sizeof(prt_ray) == 32, "ray record is 8 floats");
    return read_array(path, RAYS_MAGIC, sizeof(prt_ray), (void **)rays, count);
}

prt_status prt_rays_write(const char *path, const prt_ray *rays, size_t count) {
    return write_array(path, RAYS_MAGIC, rays, sizeof(prt_ray), count);
}

/* Hit records on disk: t, prim, u, v (16 bytes), unlike prt_hit's in-memory order. */
prt_status prt_hits_read(const char *path, prt_hit **hits, size_t *count) {
    *hits = NULL;
    uint8_t *raw;
    prt_status s = read_array(path, HITS_MAGIC, HIT_RECORD, (void **)&raw, count);
    if (s) return s;
    *hits = prt__alloc(*count ? *count * sizeof(prt_hit) : 1);
    if (!*hits) {
        prt__free(raw);
        return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory", path);
    }
    for (size_t i = 0; i < *count; i++) {
        const uint8_t *r = raw + i * HIT_RECORD;
        prt_hit *h = &(*hits)[i];
        memcpy(&h->t, r, 4);
        memcpy(&h->prim, r + 4, 4);
        memcpy(&h->u, r + 8, 4);
        memcpy(&h->v, r + 12, 4);
        h->geom = 0;
    }
    prt__free(raw);
    return PRT_OK;
}

static prt_status write_records(const char *path, size_t count, void (*rec)(const void *, size_t, uint8_t *),
                                const void *ctx) {
    prt__afile a;
    prt_status s = prt__afile_open(&a, path);
    if (s) return s;
    uint64_t n = count;
    s = prt__afile_write(&a, HITS_MAGIC, 8);
    if (!s) s = prt__afile_write(&a, &n, 8);
    uint8_t buf[HIT_RECORD * 4096];
    for (size_t i = 0; i < count && !s; i += 4096) {
        size_t k = count - i < 4096 ? count - i : 4096;
        for (size_t j = 0; j < k; j++) rec(ctx, i + j, buf + j * HIT_RECORD);
        s = prt__afile_write(&a, buf, k * HIT_RECORD);
    }
    if (s) prt__afile_abort(&a);
    return s ? s : prt__afile_commit(&a);
}

static void hit_record(const void *ctx, size_t i, uint8_t *r) {
    const prt_hit *h = (const prt_hit *)ctx + i;
    memcpy(r, &h->t, 4);
    memcpy(r + 4, &h->prim, 4);
    memcpy(r + 8, &h->u, 4);
    memcpy(r + 12, &h->v, 4);
}

static void occluded_record(const void *ctx, size_t i, uint8_t *r) {
    bool occ = ((const uint8_t *)ctx)[i] != 0;
    float t = occ ? 0.0f : INFINITY, zero = 0.0f;
    uint32_t prim = occ ? 0 : PRT_INVALID;
    memcpy(r, &t, 4);
    memcpy(r + 4, &prim, 4);
    memcpy(r + 8, &zero, 4);
    memcpy(r + 12, &zero, 4);
}

prt_status prt_hits_write(const char *path, const prt_hit *hits, size_t count) {
    return write_records(path, count, hit_record, hits);
}

prt_status prt_hits_write_occluded(const char *path, const uint8_t *occluded, size_t count) {
    return write_records(path, count, occluded_record, occluded);
}

/* .points files (the mesh queries' input): PRTPNTS1, a count, then 3 float32 per point. */
#define POINTS_MAGIC "PRTPNTS1"

prt_status prt_points_read(const char *path, float **points, size_t *count) {
    return read_array(path, POINTS_MAGIC, 12, (void **)points, count);
}

prt_status prt_points_write(const char *path, const float *points, size_t count) {
    return write_array(path, POINTS_MAGIC, points, 12, count);
}
