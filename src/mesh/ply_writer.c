/* ply_writer: an indexed binary little-endian PLY streamed to disk in 8 MiB writes, for
 * meshes that are never whole in memory (gen_mandelbulb_save_ply). */
#include "mesh/ply_writer.h"
#include "io/atomic_file.h"

#include <stdio.h>

#define WRITE_BUFFER ((size_t)8 << 20)

struct ply_writer {
    char *path;
    prt__afile out; /* written beside the target, renamed in place by ply_writer_close */
    uint8_t *buf;
    size_t n;
    uint64_t written;              /* bytes */
    uint64_t nv, nt, vdone, tdone; /* announced and written */
    bool begun, vrgb, trgb, tmat;
    prt_status failed; /* the first error: later calls return it */
};

static prt_status write_all(ply_writer *w, const void *data, size_t size) {
    if (w->failed) return w->failed;
    prt_status st = prt__afile_write(&w->out, data, size);
    if (st) return w->failed = st;
    w->written += size;
    return PRT_OK;
}

static prt_status flush(ply_writer *w) {
    prt_status st = write_all(w, w->buf, w->n);
    w->n = 0;
    return st;
}

PRT_INLINE void put_u32le(uint8_t *p, uint32_t v) {
    p[0] = (uint8_t)v, p[1] = (uint8_t)(v >> 8), p[2] = (uint8_t)(v >> 16), p[3] = (uint8_t)(v >> 24);
}

prt_status ply_writer_open(const char *path, ply_writer **out) {
    *out = NULL;
    if (!path) return prt__fail(PRT_ERROR_ARGUMENT, "ply_writer_open: path is NULL");
    ply_writer *w = prt__calloc(1, sizeof *w);
    size_t len = strlen(path);
    if (w) w->path = prt__alloc(len + 1);
    if (w && w->path) w->buf = prt__alloc(WRITE_BUFFER);
    if (!w || !w->path || !w->buf) {
        if (w) prt__free(w->path);
        prt__free(w);
        return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for the write buffer", path);
    }
    memcpy(w->path, path, len + 1);
    prt_status st = prt__afile_open(&w->out, path);
    if (st) {
        prt__free(w->buf);
        prt__free(w->path);
        prt__free(w);
        return st;
    }
    *out = w;
    return PRT_OK;
}

prt_status ply_writer_begin(ply_writer *w, uint64_t vertices, uint64_t triangles, bool vertex_colors,
                            bool triangle_colors) {
    return ply_writer_begin_materials(w, vertices, triangles, vertex_colors, triangle_colors, false);
}

prt_status ply_writer_begin_materials(ply_writer *w, uint64_t vertices, uint64_t triangles, bool vertex_colors,
                                      bool triangle_colors, bool materials) {
    if (w->failed) return w->failed;
    if (w->begun) return w->failed = prt__fail(PRT_ERROR_ARGUMENT, "%s: header written twice", w->path);
    if (vertices > UINT32_MAX)
        return w->failed = prt__fail(PRT_ERROR_LIMIT, "%s: %llu vertices: packrt indexes vertices with 32 bits",
                                     w->path, (unsigned long long)vertices);
    /* Indices above INT32_MAX do not fit the customary `int`: say `uint` then. */
    const char *itype = vertices > (uint64_t)INT32_MAX + 1 ? "uint" : "int";
    const char *rgb = "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    w->n = (size_t)snprintf((char *)w->buf, WRITE_BUFFER,
                            "ply\nformat binary_little_endian 1.0\ncomment written by packrt\nelement vertex %llu\n"
                            "property float x\nproperty float y\nproperty float z\n%selement face %llu\n"
                            "property list uchar %s vertex_indices\n%s%send_header\n",
                            (unsigned long long)vertices, vertex_colors ? rgb : "", (unsigned long long)triangles,
                            itype, triangle_colors ? rgb : "", materials ? "property ushort material_index\n" : "");
    w->vrgb = vertex_colors, w->trgb = triangle_colors, w->tmat = materials;
    w->nv = vertices;
    w->nt = triangles;
    w->begun = true;
    return PRT_OK;
}

prt_status ply_writer_vertices(ply_writer *w, const float *xyz, const uint8_t *rgb, size_t count) {
    if (w->failed) return w->failed;
    if (!w->begun || w->tdone || count > w->nv - w->vdone || !rgb != !w->vrgb)
        return w->failed = prt__fail(PRT_ERROR_ARGUMENT,
                                     "%s: %zu vertices past the %llu announced (or after the "
                                     "triangles, or before the header, or colours not as announced)",
                                     w->path, count, (unsigned long long)w->nv);
    if (rgb) { /* rows of 15 bytes: position and colour interleaved */
        for (size_t i = 0; i < count; i++) {
            uint8_t *p = w->buf + w->n;
            for (int k = 0; k < 3; k++) {
                uint32_t b;
                memcpy(&b, xyz + 3 * i + k, 4);
                put_u32le(p + 4 * k, b);
            }
            memcpy(p + 12, rgb + 3 * i, 3);
            if ((w->n += 15) + 15 > WRITE_BUFFER) {
                prt_status st = flush(w);
                if (st) return st;
            }
        }
        w->vdone += count;
        return PRT_OK;
    }
    for (size_t i = 0; i < 3 * count;) {
        size_t k = PRT_MIN(3 * count - i, (WRITE_BUFFER - w->n) / 4);
        uint8_t *p = w->buf + w->n;
        if (__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__) {
            memcpy(p, xyz + i, 4 * k);
        } else {
            for (size_t j = 0; j < k; j++) {
                uint32_t b;
                memcpy(&b, xyz + i + j, 4);
                put_u32le(p + 4 * j, b);
            }
        }
        w->n += 4 * k;
        i += k;
        if (w->n + 4 > WRITE_BUFFER) {
            prt_status st = flush(w);
            if (st) return st;
        }
    }
    w->vdone += count;
    return PRT_OK;
}

prt_status ply_writer_triangles(ply_writer *w, const uint32_t *idx, const uint8_t *rgb, size_t count) {
    return ply_writer_faces(w, idx, rgb, NULL, count);
}

prt_status ply_writer_faces(ply_writer *w, const uint32_t *idx, const uint8_t *rgb, const uint16_t *mat, size_t count) {
    if (w->failed) return w->failed;
    if (!w->begun || w->vdone != w->nv || count > w->nt - w->tdone || !rgb != !w->trgb || !mat != !w->tmat)
        return w->failed = prt__fail(PRT_ERROR_ARGUMENT,
                                     "%s: %zu triangles past the %llu announced (or before all "
                                     "%llu vertices, or colours or materials not as announced)",
                                     w->path, count, (unsigned long long)w->nt, (unsigned long long)w->nv);
    for (size_t t = 0; t < count; t++) {
        const uint32_t *i = idx + 3 * t;
        if (i[0] >= w->nv || i[1] >= w->nv || i[2] >= w->nv)
            return w->failed = prt__fail(PRT_ERROR_ARGUMENT, "%s: triangle %llu references vertex %u of %llu", w->path,
                                         (unsigned long long)(w->tdone + t), PRT_MAX(i[0], PRT_MAX(i[1], i[2])),
                                         (unsigned long long)w->nv);
        if (w->n + 18 > WRITE_BUFFER) { /* room for the longest row (vertices may leave less) */
            prt_status st = flush(w);
            if (st) return st;
        }
        uint8_t *p = w->buf + w->n;
        p[0] = 3;
        put_u32le(p + 1, i[0]);
        put_u32le(p + 5, i[1]);
        put_u32le(p + 9, i[2]);
        size_t row = 13;
        if (rgb) memcpy(p + 13, rgb + 3 * t, 3), row = 16;
        if (mat) p[row] = (uint8_t)(mat[t] & 0xFF), p[row + 1] = (uint8_t)(mat[t] >> 8), row += 2;
        w->n += row;
    }
    w->tdone += count;
    return PRT_OK;
}

prt_status ply_writer_close(ply_writer *w, bool ok) {
    prt_status st = w->failed;
    if (ok && !st && (!w->begun || w->vdone != w->nv || w->tdone != w->nt))
        st = prt__fail(PRT_ERROR_ARGUMENT, "%s: closed after %llu of %llu vertices and %llu of %llu triangles", w->path,
                       (unsigned long long)w->vdone, (unsigned long long)w->nv, (unsigned long long)w->tdone,
                       (unsigned long long)w->nt);
    if (ok && !st) st = flush(w);
    /* No half-written mesh is left behind, and a previous file stays until this one is whole. */
    if (ok && !st) st = prt__afile_commit(&w->out);
    else prt__afile_abort(&w->out);
    prt__free(w->buf);
    prt__free(w->path);
    prt__free(w);
    return st;
}
