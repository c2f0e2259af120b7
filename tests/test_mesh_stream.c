/* Mesh files as triangle streams (mesh_ply_stream): exactly the triangles, order and ids
 * of prt_mesh_load on every good file and on generated meshes written in each format
 * (expected values from the generator's arrays), vertices moved off the heap when the
 * budget is small, faces before vertices held within the budget, every broken file
 * failing with a message naming it, truncations failing cleanly, a sink's error stopping
 * the reading. */
#include "test.h"

#include "mesh/ply_stream.h"

#include <dirent.h>
#include <stdarg.h>
#include <stdint.h>
#include <zlib.h>

#define GOOD PRT_SOURCE_DIR "/tests/data/good"
#define BAD PRT_SOURCE_DIR "/tests/data/bad"

typedef struct collected {
    float *tris;
    size_t n, cap, calls;
    bool ids_ok;
    int stop_after; /* > 0: fail the call after this many */
} collected;

static prt_status collect(void *user, const float *tris, size_t count, uint64_t first_id) {
    collected *c = user;
    if (c->stop_after && c->calls == (size_t)c->stop_after) return prt__fail(PRT_ERROR_IO, "test sink: stop");
    c->calls++;
    if (first_id != c->n || count == 0) c->ids_ok = false;
    if (c->n + count > c->cap) {
        c->cap = 2 * (c->n + count);
        c->tris = realloc(c->tris, c->cap * 9 * sizeof(float));
    }
    memcpy(c->tris + 9 * c->n, tris, count * 9 * sizeof(float));
    c->n += count;
    return PRT_OK;
}

static size_t allocated(void) {
    size_t n;
    prt_memory_usage(&n, NULL);
    return n;
}

/* The mesh's triangles as 9 floats each, in order. */
static float *soup_of(const prt_mesh *m) {
    float *s = malloc(m->triangle_count * 9 * sizeof(float) + 1);
    for (size_t t = 0; t < m->triangle_count; t++)
        for (int k = 0; k < 3; k++)
            memcpy(s + 9 * t + 3 * k, m->vertices + 3 * (size_t)m->triangles[3 * t + k], 3 * sizeof(float));
    return s;
}

/* Stream a file (data == NULL) or a buffer; the status, the triangles in *c. */
static prt_status stream(const char *path, const void *data, size_t size, size_t budget, collected *c) {
    memset(c, 0, sizeof *c);
    c->ids_ok = true;
    uint64_t n = UINT64_MAX;
    prt_status st = data ? mesh_ply_stream_memory(data, size, path, budget, collect, c, &n)
                         : mesh_ply_stream(path, budget, collect, c, &n);
    CHECK_MSG(st != PRT_OK || n == c->n, "reported %llu, sink saw %zu", (unsigned long long)n, c->n);
    CHECK(c->ids_ok);
    return st;
}

/* The stream of path (or data) with this budget is exactly `expected`. */
static void check_stream_budget(const char *path, const void *data, size_t size, const float *expected, size_t count,
                                size_t budget) {
    size_t before = allocated();
    collected c;
    prt_status st = stream(path, data, size, budget, &c);
    CHECK_MSG(st == PRT_OK, "%s, budget %zu: %s: %s", path, budget, prt_status_string(st), prt_last_error());
    CHECK_MSG(c.n == count && (!count || !memcmp(c.tris, expected, count * 9 * sizeof(float))),
              "%s, budget %zu: %zu triangles streamed, %zu expected, or they differ", path, budget, c.n, count);
    CHECK(allocated() == before);
    free(c.tris);
}

/* The same with the default budget and with every vertex in the temporary file. */
static void check_stream(const char *path, const void *data, size_t size, const float *expected, size_t count) {
    check_stream_budget(path, data, size, expected, count, 0);
    check_stream_budget(path, data, size, expected, count, 1);
}

static bool is_mesh_file(const char *name) { return strstr(name, ".ply") || strstr(name, ".obj"); }

TEST(test_stream_gives_the_triangles_of_prt_mesh_load_on_every_good_file) {
    DIR *d = opendir(GOOD);
    CHECK(d != NULL);
    if (!d) return;
    int files = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (!is_mesh_file(e->d_name)) continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", GOOD, e->d_name);
        prt_mesh *m = NULL;
        CHECK_OK(prt_mesh_load(path, &m));
        if (!m) continue;
        float *s = soup_of(m);
        check_stream(path, NULL, 0, s, m->triangle_count);
        free(s);
        prt_mesh_free(m);
        files++;
    }
    closedir(d);
    CHECK_MSG(files >= 15, "only %d mesh files in %s", files, GOOD);
}

/* A growable text or byte buffer. */
typedef struct buf {
    char *p;
    size_t n, cap;
} buf;

static void put(buf *b, const void *data, size_t n) {
    if (b->n + n > b->cap) {
        b->cap = 2 * (b->n + n) + 4096;
        b->p = realloc(b->p, b->cap);
    }
    memcpy(b->p + b->n, data, n);
    b->n += n;
}

static void putf(buf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void putf(buf *b, const char *fmt, ...) {
    char line[256];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    put(b, line, (size_t)n);
}

static void put_be32(buf *b, uint32_t v) {
    uint8_t q[4] = {(uint8_t)(v >> 24), (uint8_t)(v >> 16), (uint8_t)(v >> 8), (uint8_t)v};
    put(b, q, 4);
}

enum { W_ASCII, W_BE_FACES_FIRST, W_BE };

/* m written by hand in the ascii or binary big-endian flavour (vertices as doubles), the
 * faces first if asked. */
static buf write_ply(const prt_mesh *m, int kind) {
    buf b = {0};
    bool ascii = kind == W_ASCII, faces_first = kind == W_BE_FACES_FIRST;
    putf(&b, "ply\nformat %s 1.0\n", ascii ? "ascii" : "binary_big_endian");
    const char *vh = "element vertex %zu\nproperty double x\nproperty double y\nproperty double z\n",
               *fh = "element face %zu\nproperty list uchar uint vertex_indices\n";
    if (faces_first) putf(&b, fh, m->triangle_count);
    putf(&b, vh, m->vertex_count);
    if (!faces_first) putf(&b, fh, m->triangle_count);
    putf(&b, "end_header\n");
    for (int part = 0; part < 2; part++) {
        if ((part == 0) != faces_first) {
            for (size_t i = 0; i < 3 * m->vertex_count; i++) {
                if (ascii) {
                    putf(&b, "%.9g%c", (double)m->vertices[i], i % 3 == 2 ? '\n' : ' ');
                } else {
                    double d = m->vertices[i];
                    uint64_t u;
                    memcpy(&u, &d, 8);
                    put_be32(&b, (uint32_t)(u >> 32));
                    put_be32(&b, (uint32_t)u);
                }
            }
        } else {
            for (size_t t = 0; t < m->triangle_count; t++) {
                const uint32_t *i = m->triangles + 3 * t;
                if (ascii) {
                    putf(&b, "3 %u %u %u\n", i[0], i[1], i[2]);
                } else {
                    put(&b, "\3", 1);
                    for (int k = 0; k < 3; k++) put_be32(&b, i[k]);
                }
            }
        }
    }
    return b;
}

static buf gzip_of(const buf *in) {
    buf out = {0};
    out.cap = compressBound(in->n) + 64;
    out.p = malloc(out.cap);
    z_stream z;
    memset(&z, 0, sizeof z);
    deflateInit2(&z, 1, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);
    z.next_in = (Bytef *)in->p;
    z.avail_in = (uInt)in->n;
    z.next_out = (Bytef *)out.p;
    z.avail_out = (uInt)out.cap;
    deflate(&z, Z_FINISH);
    out.n = z.total_out;
    deflateEnd(&z);
    return out;
}

TEST(test_stream_of_a_generated_mesh_in_every_format) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_generate("mandelbulb", 100000, 1, &m));
    if (!m) return;
    float *s = soup_of(m);
    const char *path = PRT_BINARY_DIR "/test_mesh_stream_bulb.ply";
    CHECK_OK(prt_mesh_save_ply(m, path));
    check_stream(path, NULL, 0, s, m->triangle_count); /* binary little-endian, from disk */
    buf ascii = write_ply(m, W_ASCII), be = write_ply(m, W_BE), gz = gzip_of(&be);
    check_stream("bulb ascii", ascii.p, ascii.n, s, m->triangle_count);
    check_stream("bulb big-endian", be.p, be.n, s, m->triangle_count);
    check_stream("bulb big-endian gzip", gz.p, gz.n, s, m->triangle_count);
    collected c;
    CHECK_OK(stream(path, NULL, 0, 0, &c));
    CHECK_MSG(c.calls >= 3, "%zu batches for %zu triangles", c.calls, c.n);
    free(c.tris);
    free(ascii.p);
    free(be.p);
    free(gz.p);
    free(s);
    remove(path);
    prt_mesh_free(m);
}

TEST(test_faces_before_vertices_are_held_within_a_quarter_of_the_budget) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_generate("sphere", 100000, 1, &m));
    if (!m) return;
    float *s = soup_of(m);
    buf b = write_ply(m, W_BE_FACES_FIRST);
    check_stream_budget("faces first", b.p, b.n, s, m->triangle_count, 0);
    /* 1 MiB budget: the faces need 1.2 MB held; refused, naming why. */
    collected c;
    size_t before = allocated();
    prt_status st = stream("faces first", b.p, b.n, (size_t)1 << 20, &c);
    CHECK_MSG(st == PRT_ERROR_UNSUPPORTED, "%s", prt_status_string(st));
    CHECK(strstr(prt_last_error(), "faces first") && strstr(prt_last_error(), "before the vertices"));
    CHECK(c.n == 0);
    CHECK(allocated() == before);
    free(c.tris);
    free(b.p);
    free(s);
    prt_mesh_free(m);
}

/* With a small budget the vertices leave the heap: the peak of packrt's allocations falls
 * by most of the vertex array (1M vertices, 12 MB) against the default budget. */
TEST(test_small_budget_keeps_the_vertices_off_the_heap) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_generate("terrain", 2000000, 1, &m));
    if (!m) return;
    const char *path = PRT_BINARY_DIR "/test_mesh_stream_terrain.ply";
    CHECK_OK(prt_mesh_save_ply(m, path));
    size_t vbytes = m->vertex_count * 12, peak[2];
    size_t budgets[2] = {0, 4u << 20};
    for (int i = 0; i < 2; i++) {
        size_t base = allocated();
        prt_memory_reset_peak();
        collected c;
        CHECK_OK(stream(path, NULL, 0, budgets[i], &c));
        CHECK(c.n == m->triangle_count);
        prt_memory_usage(NULL, &peak[i]);
        peak[i] -= base;
        free(c.tris);
    }
    printf("     peak heap: %zu bytes with the default budget, %zu with 4 MiB (%zu of vertices)\n", peak[0], peak[1],
           vbytes);
    CHECK_MSG(peak[0] > vbytes && peak[1] + vbytes * 8 / 10 < peak[0], "peaks %zu and %zu", peak[0], peak[1]);
    remove(path);
    prt_mesh_free(m);
}

TEST(test_every_bad_file_fails_naming_the_file) {
    DIR *d = opendir(BAD);
    CHECK(d != NULL);
    if (!d) return;
    int files = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (e->d_name[0] == '.' || strstr(e->d_name, ".prt")) continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", BAD, e->d_name);
        size_t before = allocated();
        collected c;
        prt_status st = stream(path, NULL, 0, 0, &c);
        CHECK_MSG(st != PRT_OK, "%s streamed", e->d_name);
        CHECK_MSG(strstr(prt_last_error(), path) != NULL, "%s: message '%s'", e->d_name, prt_last_error());
        /* The same status as prt_mesh_load. */
        prt_mesh *m = NULL;
        prt_status ls = prt_mesh_load(path, &m);
        CHECK_MSG(ls == st, "%s: load says %s, stream %s", e->d_name, prt_status_string(ls), prt_status_string(st));
        prt_mesh_free(m);
        CHECK_MSG(allocated() == before, "%s: %zu bytes leaked", e->d_name, allocated() - before);
        free(c.tris);
        files++;
    }
    closedir(d);
    CHECK_MSG(files >= 40, "only %d files in %s", files, BAD);
}

TEST(test_truncated_files_fail_cleanly_at_every_cut) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_generate("sphere", 20000, 1, &m));
    if (!m) return;
    buf le = {0}, be = write_ply(m, W_BE), ascii = write_ply(m, W_ASCII);
    const char *path = PRT_BINARY_DIR "/test_mesh_stream_cut.ply";
    CHECK_OK(prt_mesh_save_ply(m, path));
    FILE *f = fopen(path, "rb");
    if (f) {
        char chunk[65536];
        for (size_t k; (k = fread(chunk, 1, sizeof chunk, f));) put(&le, chunk, k);
        fclose(f);
    }
    buf *files[3] = {&le, &be, &ascii};
    for (int k = 0; k < 3; k++)
        for (int cut = 0; cut < 40; cut++) {
            /* Cuts in the header, the vertices and the faces; the whole minus a byte last. */
            size_t n = cut == 39 ? files[k]->n - 1 : files[k]->n * (size_t)cut / 39 + cut % 7;
            if (n >= files[k]->n) continue;
            size_t before = allocated();
            collected c;
            prt_status st = stream("cut.ply", files[k]->p, n, cut % 2, &c);
            CHECK_MSG(st == PRT_OK || strstr(prt_last_error(), "cut.ply"), "message: %s", prt_last_error());
            /* The outcome of prt_mesh_load; binary files can only fail (an ascii file cut
             * inside its last number, or before its last newline, is still a mesh). */
            prt_mesh *l = NULL;
            prt_status ls = prt_mesh_load_memory(files[k]->p, n, "cut.ply", &l);
            CHECK_MSG(st == ls && (k == 2 || st != PRT_OK), "file %d cut at %zu of %zu: %s, load %s", k, n, files[k]->n,
                      prt_status_string(st), prt_status_string(ls));
            if (l && st == PRT_OK) {
                float *s = soup_of(l);
                CHECK(c.n == l->triangle_count && !memcmp(s, c.tris, c.n * 9 * sizeof(float)));
                free(s);
            }
            prt_mesh_free(l);
            CHECK(c.n <= m->triangle_count);
            CHECK(allocated() == before);
            free(c.tris);
        }
    remove(path);
    free(le.p);
    free(be.p);
    free(ascii.p);
    prt_mesh_free(m);
}

TEST(test_sink_error_stops_the_reading) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_generate("sphere", 200000, 1, &m));
    if (!m) return;
    const char *path = PRT_BINARY_DIR "/test_mesh_stream_stop.ply";
    CHECK_OK(prt_mesh_save_ply(m, path));
    collected c;
    memset(&c, 0, sizeof c);
    c.stop_after = 2;
    size_t before = allocated();
    prt_status st = mesh_ply_stream(path, 0, collect, &c, NULL);
    CHECK_MSG(st == PRT_ERROR_IO && strstr(prt_last_error(), "test sink"), "%s: %s", prt_status_string(st),
              prt_last_error());
    CHECK(c.calls == 2);
    CHECK(allocated() == before);
    CHECK(mesh_ply_stream(path, 0, NULL, NULL, NULL) == PRT_ERROR_ARGUMENT);
    CHECK(mesh_ply_stream(PRT_BINARY_DIR "/no/such.ply", 0, collect, &c, NULL) == PRT_ERROR_IO);
    free(c.tris);
    remove(path);
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_stream_gives_the_triangles_of_prt_mesh_load_on_every_good_file);
    RUN(test_stream_of_a_generated_mesh_in_every_format);
    RUN(test_faces_before_vertices_are_held_within_a_quarter_of_the_budget);
    RUN(test_small_budget_keeps_the_vertices_off_the_heap);
    RUN(test_every_bad_file_fails_naming_the_file);
    RUN(test_truncated_files_fail_cleanly_at_every_cut);
    RUN(test_sink_error_stops_the_reading);
    TEST_END();
}
