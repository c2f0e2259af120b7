/* mesh_arrays in streaming mode: the triangles a parser collects are resolved to corner
 * positions and handed to a tri_sink whenever a batch fills, in file order, ids counting
 * on; vertices stay whole (faces may name any of them) on the heap while they fit the
 * memory budget, else in an unlinked temporary file mapped shared, which the kernel pages
 * to disk and back, so the heap stays bounded whatever the vertex count. */
#include "mesh/stream_arrays.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <unistd.h>

struct mesh_stream {
    tri_sink_fn sink;
    void *user;
    size_t budget;      /* bytes for vertices on the heap and triangles held back */
    uint64_t next_id;   /* stream id of the next triangle handed on */
    float *batch;       /* MESH_STREAM_BATCH triangles of 9 floats */
    size_t scanned;     /* held triangles whose indices are in max_index */
    uint32_t max_index; /* largest index among them */
    int fd;             /* the vertex file, or -1 while vertices are on the heap */
    size_t mapped;      /* bytes mapped */
    char path[4096];    /* for messages */
};

prt_status mesh_stream_begin(mesh_arrays *a, size_t memory_budget, tri_sink_fn sink, void *user) {
    struct mesh_stream *m = prt__calloc(1, sizeof *m);
    if (m) m->batch = prt__alloc((size_t)MESH_STREAM_BATCH * 9 * sizeof(float));
    if (!m || !m->batch) {
        if (m) prt__free(m);
        return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for the triangle batch", a->name);
    }
    m->sink = sink;
    m->user = user;
    m->budget = memory_budget ? memory_budget : MESH_STREAM_DEFAULT_BUDGET;
    m->fd = -1;
    a->stream = m;
    return PRT_OK;
}

/* Bytes a vertex costs on the heap (its colour too, when the parser keeps colours). */
static size_t vertex_bytes(const mesh_arrays *a) { return 3 * sizeof(float) + (a->want_vc ? 3 : 0); }

static size_t heap_vertex_budget(const struct mesh_stream *m) {
    return m->budget > MESH_STREAM_OVERHEAD ? m->budget - MESH_STREAM_OVERHEAD : 0;
}

/* Map (or grow the mapping of) the vertex file to cap vertices. */
static prt_status map_vertices(mesh_arrays *a, size_t cap) {
    struct mesh_stream *m = a->stream;
    size_t bytes = prt__mul_size(cap, 3 * sizeof(float));
    char eb[128];
    if (bytes == SIZE_MAX || ftruncate(m->fd, (off_t)bytes) != 0)
        return prt__fail(PRT_ERROR_IO, "%s: cannot make the temporary vertex file %s %zu bytes: %s", a->name, m->path,
                         bytes, strerror_r(errno, eb, sizeof eb));
    void *p = m->mapped ? mremap(a->v, m->mapped, bytes, MREMAP_MAYMOVE)
                        : mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, m->fd, 0);
    if (p == MAP_FAILED)
        return prt__fail(PRT_ERROR_NOMEM, "%s: cannot map %zu bytes of the temporary vertex file %s: %s", a->name,
                         bytes, m->path, strerror_r(errno, eb, sizeof eb));
    a->v = p;
    a->vcap = cap;
    m->mapped = bytes;
    return PRT_OK;
}

/* Move the vertices from the heap to a new temporary file of cap vertices. */
static prt_status spill_vertices(mesh_arrays *a, size_t cap) {
    struct mesh_stream *m = a->stream;
    const char *dir = getenv("TMPDIR");
    snprintf(m->path, sizeof m->path, "%s/packrt-vertices-XXXXXX", dir && *dir ? dir : "/tmp");
    m->fd = mkostemp(m->path, O_CLOEXEC);
    if (m->fd < 0) {
        char eb[128];
        return prt__fail(PRT_ERROR_IO,
                         "%s: %zu vertices do not fit the memory budget (%zu bytes) and no "
                         "temporary file for them can be made (%s: %s); set TMPDIR or raise the "
                         "budget",
                         a->name, cap, m->budget, m->path, strerror_r(errno, eb, sizeof eb));
    }
    unlink(m->path); /* gone from the directory; the space returns when it is closed */
    float *heap = a->v;
    prt_status st = map_vertices(a, cap);
    if (st != PRT_OK) {
        a->v = heap;
        return st;
    }
    if (a->nv) memcpy(a->v, heap, a->nv * 3 * sizeof(float));
    prt__free(heap);
    return PRT_OK;
}

prt_status mesh_stream_vertex_room(mesh_arrays *a, size_t need, size_t expect) {
    struct mesh_stream *m = a->stream;
    if (need <= a->vcap) return PRT_OK;
    /* The capacity grow() in load.c would pick. */
    size_t cap = PRT_MAX(need, PRT_MAX(a->vcap * 2, (size_t)1024));
    if (expect >= need && cap > expect) cap = expect;
    if (m->fd < 0 && prt__mul_size(cap, vertex_bytes(a)) <= heap_vertex_budget(m))
        return PRT_OK; /* on the heap: grow() does it */
    return m->fd < 0 ? spill_vertices(a, cap) : map_vertices(a, cap);
}

/* Hand the held triangles to the sink, or keep holding them while some index names a
 * vertex not read yet (a PLY whose faces come before its vertices). */
static prt_status flush(mesh_arrays *a, bool *held) {
    struct mesh_stream *m = a->stream;
    for (size_t i = 3 * m->scanned; i < 3 * a->nt; i++) m->max_index = PRT_MAX(m->max_index, a->t[i]);
    m->scanned = a->nt;
    *held = a->nt && m->max_index >= a->nv;
    if (*held) return PRT_OK;
    for (size_t t0 = 0; t0 < a->nt; t0 += MESH_STREAM_BATCH) {
        size_t n = PRT_MIN(a->nt - t0, (size_t)MESH_STREAM_BATCH);
        for (size_t t = 0; t < n; t++)
            for (int k = 0; k < 3; k++)
                memcpy(m->batch + 9 * t + 3 * k, a->v + 3 * (size_t)a->t[3 * (t0 + t) + k], 3 * sizeof(float));
        prt_status st = m->sink(m->user, m->batch, n, m->next_id);
        m->next_id += n;
        if (st != PRT_OK) return st;
    }
    a->nt = 0;
    m->scanned = 0;
    m->max_index = 0;
    return PRT_OK;
}

prt_status mesh_stream_triangle_room(mesh_arrays *a, size_t extra) {
    struct mesh_stream *m = a->stream;
    if (!a->nt || a->nt + extra <= MESH_STREAM_BATCH) return PRT_OK;
    bool held;
    prt_status st = flush(a, &held);
    if (st != PRT_OK || !held) return st;
    /* Faces before vertices: all of them are held until the vertices come, within a
     * quarter of the budget. */
    if (prt__mul_size(a->nt + extra, 3 * sizeof(uint32_t)) > m->budget / 4)
        return prt__fail(PRT_ERROR_UNSUPPORTED,
                         "%s: the faces come before the vertices, and holding them until the "
                         "vertices are read would take more than a quarter of the memory budget "
                         "(%zu bytes); raise the budget, load the file whole, or write the vertex "
                         "element first",
                         a->name, m->budget);
    return PRT_OK;
}

prt_status mesh_stream_end(mesh_arrays *a, uint64_t *triangles) {
    bool held;
    prt_status st = flush(a, &held);
    if (st == PRT_OK && held) /* the parser checked every index against the vertices */
        st = prt__fail(PRT_ERROR_MESH, "%s: a face names vertex %u of %zu (bug)", a->name, a->stream->max_index, a->nv);
    if (st == PRT_OK && triangles) *triangles = a->stream->next_id;
    return st;
}

void mesh_stream_release(mesh_arrays *a) {
    struct mesh_stream *m = a->stream;
    if (m) {
        if (m->fd >= 0) {
            if (m->mapped) munmap(a->v, m->mapped);
            a->v = NULL; /* not the heap's */
            close(m->fd);
        }
        prt__free(m->batch);
        prt__free(m);
        a->stream = NULL;
    }
    mesh_arrays_free(a);
}
