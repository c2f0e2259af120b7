/* prt_mesh_save_ply: binary little-endian PLY (float x y z, list uchar int vertex_indices,
 * uchar red green blue on vertices and faces when the mesh has colours) streamed to disk in
 * large writes, so a 100M-triangle mesh needs one 8 MiB buffer. */
#include "mesh/source.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <unistd.h>

#define WRITE_BUFFER ((size_t)8 << 20)

typedef struct ply_out {
    const char *path;
    int fd;
    uint8_t *buf;
    size_t n;
    uint64_t written;
} ply_out;

static prt_status write_all(ply_out *o, const void *data, size_t size) {
    const uint8_t *p = data;
    while (size) {
        /* Linux writes at most ~2 GiB per call; ask for 1 GiB at a time. */
        ssize_t w = write(o->fd, p, PRT_MIN(size, (size_t)1 << 30));
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) {
            char eb[128];
            return prt__fail(PRT_ERROR_IO, "%s: write failed at byte %llu: %s", o->path,
                             (unsigned long long)o->written,
                             w < 0 ? strerror_r(errno, eb, sizeof eb) : "no progress");
        }
        p += w;
        size -= (size_t)w;
        o->written += (uint64_t)w;
    }
    return PRT_OK;
}

static prt_status flush(ply_out *o) {
    prt_status st = write_all(o, o->buf, o->n);
    o->n = 0;
    return st;
}

PRT_INLINE void put_u32le(uint8_t *p, uint32_t v) {
    p[0] = (uint8_t)v, p[1] = (uint8_t)(v >> 8), p[2] = (uint8_t)(v >> 16),
    p[3] = (uint8_t)(v >> 24);
}

static prt_status write_body(ply_out *o, const prt_mesh *m) {
    /* Indices above INT32_MAX do not fit the customary `int`: say `uint` then. */
    const char *itype = m->vertex_count > (size_t)INT32_MAX + 1 ? "uint" : "int";
    const char *rgb = "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    const uint8_t *vc = m->vertex_colors, *tc = m->triangle_colors;
    int h = snprintf(
        (char *)o->buf, WRITE_BUFFER,
        "ply\nformat binary_little_endian 1.0\ncomment written by packrt\nelement vertex %zu\n"
        "property float x\nproperty float y\nproperty float z\n%selement face %zu\n"
        "property list uchar %s vertex_indices\n%send_header\n",
        m->vertex_count, vc ? rgb : "", m->triangle_count, itype, tc ? rgb : "");
    o->n = (size_t)h;
    prt_status st = flush(o);
    if (st != PRT_OK) return st;
    const size_t nf = 3 * m->vertex_count;
    if (vc) { /* rows of 15 bytes: positions and colours interleaved */
        for (size_t i = 0; i < m->vertex_count && st == PRT_OK; i++) {
            uint8_t *p = o->buf + o->n;
            for (int k = 0; k < 3; k++) {
                uint32_t b;
                memcpy(&b, m->vertices + 3 * i + k, 4);
                put_u32le(p + 4 * k, b);
            }
            memcpy(p + 12, vc + 3 * i, 3);
            if ((o->n += 15) + 15 > WRITE_BUFFER) st = flush(o);
        }
        if (st == PRT_OK) st = flush(o);
    } else if (__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__) {
        st = write_all(o, m->vertices, nf * sizeof(float)); /* already the file's layout */
    } else {
        for (size_t i = 0; i < nf && st == PRT_OK; i++) {
            uint32_t b;
            memcpy(&b, m->vertices + i, 4);
            put_u32le(o->buf + o->n, b);
            if ((o->n += 4) + 4 > WRITE_BUFFER) st = flush(o);
        }
        if (st == PRT_OK) st = flush(o);
    }
    for (size_t t = 0; t < m->triangle_count && st == PRT_OK; t++) {
        uint8_t *p = o->buf + o->n;
        const uint32_t *i = m->triangles + 3 * t;
        p[0] = 3;
        put_u32le(p + 1, i[0]);
        put_u32le(p + 5, i[1]);
        put_u32le(p + 9, i[2]);
        size_t row = 13;
        if (tc) memcpy(p + 13, tc + 3 * t, 3), row = 16;
        if ((o->n += row) + 16 > WRITE_BUFFER) st = flush(o);
    }
    if (st == PRT_OK) st = flush(o);
    return st;
}

prt_status prt_mesh_save_ply(const prt_mesh *m, const char *path) {
    if (!path) return prt__fail(PRT_ERROR_ARGUMENT, "prt_mesh_save_ply: path is NULL");
    prt_status st = prt_mesh_validate(m);
    if (st != PRT_OK) {
        char detail[512];
        snprintf(detail, sizeof detail, "%s", prt_last_error());
        return prt__fail(st, "%s: refusing to save an invalid mesh: %s", path, detail);
    }
    ply_out o = {path, -1, NULL, 0, 0};
    o.buf = prt__alloc(WRITE_BUFFER);
    if (!o.buf) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for the write buffer", path);
    o.fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (o.fd < 0) {
        char eb[128];
        st = prt__fail(PRT_ERROR_IO, "%s: cannot create: %s", path,
                       strerror_r(errno, eb, sizeof eb));
    } else {
        st = write_body(&o, m);
        if (close(o.fd) != 0 && st == PRT_OK) {
            char eb[128];
            st = prt__fail(PRT_ERROR_IO, "%s: close failed: %s", path,
                           strerror_r(errno, eb, sizeof eb));
        }
        if (st != PRT_OK) unlink(path); /* no half-written mesh left behind */
    }
    prt__free(o.buf);
    return st;
}
