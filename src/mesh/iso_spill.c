/* gen_isosurface_indexed: the indexed mesh gen_isosurface builds, handed on vertices first
 * and triangles after without holding it. The flood fill's brick records go to a temporary
 * file as they come (breadth-first order); a table of (brick, offset) sorted by brick then
 * gives the mesh's order: a pass reads every brick's vertices, a second its triangles,
 * resolving each edge through the records of the bricks that own it, which lie at most a
 * layer of bricks ahead (a sliding window of record headers). */
#include "mesh/iso_brick.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#define B GEN_BRICK
#define IO_BUFFER ((size_t)4 << 20)
#define TRI_BATCH 65536 /* triangles a call to out->triangles */

/* A record on disk: this header, then nvert * 3 floats, then ntri * 3 uint16 slots. */
typedef struct disk_header {
    uint32_t id, nvert, ntri, pad;
    uint64_t owned[ISO_OWN_WORDS];
    uint16_t rank[ISO_OWN_WORDS];
} disk_header;

/* Where a brick's record lies, and its first vertex in the mesh. */
typedef struct entry {
    uint32_t id, nvert, ntri, vbase;
    uint64_t offset;
} entry;

typedef struct spill {
    const char *name; /* for messages */
    int fd;
    uint8_t *buf;
    size_t n;
    uint64_t size; /* bytes in the file, buffered ones included */
    entry *e;
    size_t ne, cap;
    uint64_t vertices;
} spill;

static prt_status io_error(const spill *s, const char *what, uint64_t at, ssize_t k) {
    char eb[128];
    return prt__fail(PRT_ERROR_IO, "%s: %s failed at byte %llu: %s", s->name, what, (unsigned long long)at,
                     k < 0 ? strerror_r(errno, eb, sizeof eb) : "short");
}

static prt_status spill_flush(spill *s) {
    uint64_t at = s->size - s->n;
    for (size_t done = 0; done < s->n;) {
        ssize_t k = pwrite(s->fd, s->buf + done, s->n - done, (off_t)(at + done));
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return io_error(s, "write to the temporary file", at + done, k);
        done += (size_t)k;
    }
    s->n = 0;
    return PRT_OK;
}

static prt_status spill_put(spill *s, const void *data, size_t bytes) {
    const uint8_t *p = data;
    while (bytes) {
        if (s->n == IO_BUFFER) {
            prt_status st = spill_flush(s);
            if (st) return st;
        }
        size_t k = PRT_MIN(bytes, IO_BUFFER - s->n);
        memcpy(s->buf + s->n, p, k);
        s->n += k;
        s->size += k;
        p += k;
        bytes -= k;
    }
    return PRT_OK;
}

static prt_status spill_read(const spill *s, void *data, size_t bytes, uint64_t at) {
    uint8_t *p = data;
    for (size_t done = 0; done < bytes;) {
        ssize_t k = pread(s->fd, p + done, bytes - done, (off_t)(at + done));
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return io_error(s, "read from the temporary file", at + done, k);
        done += (size_t)k;
    }
    return PRT_OK;
}

static prt_status spill_bricks(void *user, iso_brick_out *b, size_t n) {
    spill *s = user;
    for (size_t i = 0; i < n; i++) {
        const iso_brick *r = b[i].rec;
        if (!r) continue;
        if (s->ne == s->cap) {
            size_t cap = s->cap ? 2 * s->cap : 4096;
            entry *q = prt__realloc(s->e, cap * sizeof *q);
            if (!q) return prt__fail(PRT_ERROR_NOMEM, "out of memory for the brick table");
            s->e = q;
            s->cap = cap;
        }
        s->e[s->ne++] = (entry){r->id, r->nvert, r->ntri, 0, s->size};
        s->vertices += r->nvert;
        disk_header h;
        memset(&h, 0, sizeof h);
        h.id = r->id, h.nvert = r->nvert, h.ntri = r->ntri;
        memcpy(h.owned, r->owned, sizeof h.owned);
        memcpy(h.rank, r->rank, sizeof h.rank);
        prt_status st = spill_put(s, &h, sizeof h);
        if (!st) st = spill_put(s, r->vert, (size_t)r->nvert * 3 * sizeof(float));
        if (!st) st = spill_put(s, r->tri, (size_t)r->ntri * 3 * sizeof(uint16_t));
        if (st) return st;
    }
    return PRT_OK;
}

static int cmp_entry(const void *a, const void *b) {
    uint32_t x = ((const entry *)a)->id, y = ((const entry *)b)->id;
    return (x > y) - (x < y);
}

/* Position of brick id among entries [lo, n), or -1. */
static ptrdiff_t find_entry(const entry *e, size_t lo, size_t n, uint32_t id) {
    size_t hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (e[mid].id < id) lo = mid + 1;
        else hi = mid;
    }
    return lo < n && e[lo].id == id ? (ptrdiff_t)lo : -1;
}

/* Headers of the records at positions [first, end): a ring that grows when a window
 * holds more bricks than it has room for. */
typedef struct window {
    disk_header *h;
    size_t cap, first, end; /* cap a power of two */
} window;

static disk_header *window_at(window *w, size_t pos) { return &w->h[pos & (w->cap - 1)]; }

static prt_status window_push(window *w, const spill *s, size_t pos) {
    if (w->end - w->first == w->cap) {
        size_t cap = w->cap ? 2 * w->cap : 64;
        disk_header *h = prt__alloc(cap * sizeof *h);
        if (!h) return prt__fail(PRT_ERROR_NOMEM, "out of memory for the brick window");
        for (size_t p = w->first; p < w->end; p++) h[p & (cap - 1)] = *window_at(w, p);
        prt__free(w->h);
        w->h = h;
        w->cap = cap;
    }
    w->end = pos + 1;
    return spill_read(s, window_at(w, pos), sizeof(disk_header), s->e[pos].offset);
}

static prt_status emit_vertices(spill *s, const gen_iso_indexed_out *out) {
    float *v = prt__alloc(ISO_OWN_SLOTS * 3 * sizeof(float));
    if (!v) return prt__fail(PRT_ERROR_NOMEM, "out of memory reading the vertices back");
    prt_status st = PRT_OK;
    for (size_t i = 0; i < s->ne && !st; i++) {
        const entry *e = &s->e[i];
        st = spill_read(s, v, (size_t)e->nvert * 3 * sizeof(float), e->offset + sizeof(disk_header));
        if (!st && e->nvert) st = out->vertices(out->user, v, e->nvert);
    }
    prt__free(v);
    return st;
}

static prt_status emit_triangles(spill *s, uint32_t nb, const gen_iso_indexed_out *out) {
    window w = {NULL, 0, 0, 0};
    uint16_t *slots = prt__alloc(ISO_MAX_BRICK_TRIS * 3 * sizeof *slots);
    uint32_t *batch = prt__alloc(TRI_BATCH * 3 * sizeof *batch);
    size_t nbatch = 0;
    prt_status st = PRT_OK;
    if (!slots || !batch) st = prt__fail(PRT_ERROR_NOMEM, "out of memory reading triangles back");
    const uint64_t reach = (uint64_t)nb * nb + nb + 1; /* the farthest owner's id, ahead */
    for (size_t i = 0; i < s->ne && !st; i++) {
        const entry *e = &s->e[i];
        /* Slide the window: drop records behind, read those up to the farthest owner. */
        w.first = PRT_MAX(w.first, i);
        if (w.end < w.first) w.end = w.first;
        while (!st && w.end < s->ne && s->e[w.end].id <= e->id + reach) st = window_push(&w, s, w.end);
        if (st) break;
        st = spill_read(s, slots, (size_t)e->ntri * 3 * sizeof *slots,
                        e->offset + sizeof(disk_header) + (uint64_t)e->nvert * 3 * sizeof(float));
        if (st) break;
        ptrdiff_t own[8];
        uint32_t bx = e->id % nb, by = e->id / nb % nb, bz = e->id / nb / nb;
        for (int o = 0; o < 8; o++) {
            uint32_t x = bx + (o & 1), y = by + (o >> 1 & 1), z = bz + (o >> 2 & 1);
            own[o] = x < nb && y < nb && z < nb ? find_entry(s->e, i, w.end, (z * nb + y) * nb + x) : -1;
        }
        for (uint32_t j = 0; j < 3 * e->ntri; j++) {
            int o, slot;
            iso_edge_owner(slots[j], &o, &slot);
            const disk_header *h = own[o] < 0 ? NULL : window_at(&w, (size_t)own[o]);
            if (!h || !iso_owns(h->owned, slot)) {
                st = prt__fail(PRT_ERROR_MESH, "isosurface: a crossed edge has no vertex in its owning brick (bug)");
                break;
            }
            batch[3 * nbatch + j % 3] = s->e[own[o]].vbase + iso_owned_rank(h->owned, h->rank, slot);
            if (j % 3 == 2 && ++nbatch == TRI_BATCH) {
                st = out->triangles(out->user, batch, nbatch);
                nbatch = 0;
                if (st) break;
            }
        }
    }
    if (!st && nbatch) st = out->triangles(out->user, batch, nbatch);
    prt__free(w.h);
    prt__free(slots);
    prt__free(batch);
    return st;
}

/* A temporary file beside `near` (or in $TMPDIR, else /tmp), unlinked at once. */
static prt_status open_temp(const char *near, int *fd, char *name, size_t size) {
    if (near) snprintf(name, size, "%s.spill-XXXXXX", near);
    else {
        const char *dir = getenv("TMPDIR");
        snprintf(name, size, "%s/packrt-spill-XXXXXX", dir && *dir ? dir : "/tmp");
    }
    *fd = mkostemp(name, O_CLOEXEC);
    if (*fd < 0) {
        char eb[128];
        return prt__fail(PRT_ERROR_IO, "%s: cannot create a temporary file: %s", name,
                         strerror_r(errno, eb, sizeof eb));
    }
    unlink(name);
    return PRT_OK;
}

prt_status gen_isosurface_indexed(const gen_iso_params *p, size_t memory_budget, const char *temp_near,
                                  const gen_iso_indexed_out *out, uint64_t *vertices, uint64_t *triangles) {
    if (vertices) *vertices = 0;
    if (triangles) *triangles = 0;
    if (!out || !out->begin || !out->vertices || !out->triangles)
        return prt__fail(PRT_ERROR_ARGUMENT, "isosurface: incomplete output callbacks");
    char name[4096];
    spill s;
    memset(&s, 0, sizeof s);
    s.name = name;
    prt_status st = open_temp(temp_near, &s.fd, name, sizeof name);
    if (st) return st;
    s.buf = prt__alloc(IO_BUFFER);
    if (!s.buf) st = prt__fail(PRT_ERROR_NOMEM, "out of memory for the spill buffer");
    /* A group's worst case: every brick's record full (all edges crossed, all cells with
     * the most triangles). */
    const size_t brick_bytes =
        sizeof(iso_brick) + ISO_OWN_SLOTS * 3 * sizeof(float) + ISO_MAX_BRICK_TRIS * 3 * sizeof(uint16_t) + 64;
    size_t budget = PRT_MAX(memory_budget, GEN_ISO_MIN_BUDGET);
    size_t group = PRT_MAX((budget - 2 * IO_BUFFER) / brick_bytes, (size_t)16);
    uint64_t total = 0;
    if (!st) st = iso_flood(p, ISO_RECORDS, group, spill_bricks, &s, &total);
    if (!st) st = spill_flush(&s);
    if (!st && s.vertices >= UINT32_MAX)
        st = prt__fail(PRT_ERROR_LIMIT, "isosurface has %llu vertices: more than 32-bit indices hold",
                       (unsigned long long)s.vertices);
    if (!st) {
        qsort(s.e, s.ne, sizeof *s.e, cmp_entry);
        uint32_t v = 0;
        for (size_t i = 0; i < s.ne; i++) s.e[i].vbase = v, v += s.e[i].nvert;
        st = out->begin(out->user, s.vertices, total);
    }
    if (!st) st = emit_vertices(&s, out);
    if (!st) st = emit_triangles(&s, iso_bricks_per_side(p), out);
    close(s.fd);
    prt__free(s.buf);
    prt__free(s.e);
    if (!st && vertices) *vertices = s.vertices;
    if (!st && triangles) *triangles = total;
    return st;
}
