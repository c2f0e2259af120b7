/* The streaming Mandelbulb. gen_mandelbulb_stream: the same triangles as the in-memory
 * generator (compared as sorted sets of corner positions, so the expected set comes from
 * the indexed mesh, not from the stream's code), batches with consecutive ids, one order
 * whatever the thread count or memory budget, and a sink's error stopping it.
 * gen_mandelbulb_save_ply: the very bytes prt_mesh_save_ply writes of the in-memory mesh,
 * no temporary file left behind, no file at all on failure. */
#include "test.h"

#include "mesh/gen.h"

#include <dirent.h>
#include <omp.h>
#include <stdint.h>
#include <unistd.h>

/* A sink that keeps every triangle and checks the ids run on without gaps. */
typedef struct collected {
    float *tris;
    size_t n, cap, calls, max_batch;
    bool ids_ok;
    int stop_after; /* > 0: fail the call after this many */
} collected;

static prt_status collect(void *user, const float *tris, size_t count, uint64_t first_id) {
    collected *c = user;
    if (c->stop_after && c->calls == (size_t)c->stop_after) return prt__fail(PRT_ERROR_IO, "test sink: stop");
    c->calls++;
    if (first_id != c->n || count == 0) c->ids_ok = false;
    if (count > c->max_batch) c->max_batch = count;
    if (c->n + count > c->cap) {
        c->cap = 2 * (c->n + count);
        c->tris = realloc(c->tris, c->cap * 9 * sizeof(float));
    }
    memcpy(c->tris + 9 * c->n, tris, count * 9 * sizeof(float));
    c->n += count;
    return PRT_OK;
}

static int cmp_tri(const void *a, const void *b) { return memcmp(a, b, 9 * sizeof(float)); }

/* The mesh as 9 floats a triangle. */
static float *soup_of(const prt_mesh *m) {
    float *s = malloc(m->triangle_count * 9 * sizeof(float));
    for (size_t t = 0; t < m->triangle_count; t++)
        for (int k = 0; k < 3; k++)
            memcpy(s + 9 * t + 3 * k, m->vertices + 3 * (size_t)m->triangles[3 * t + k], 3 * sizeof(float));
    return s;
}

static void stream(size_t want, size_t budget, collected *c) {
    memset(c, 0, sizeof *c);
    c->ids_ok = true;
    uint64_t n = 0;
    CHECK_OK(gen_mandelbulb_stream(want, 1, budget, collect, c, &n));
    CHECK_MSG(n == c->n, "reported %llu, sink saw %zu", (unsigned long long)n, c->n);
    CHECK(c->ids_ok);
}

static void same_triangles_as_the_mesh(size_t want) {
    prt_mesh *m = NULL;
    CHECK_OK(prt_mesh_generate("mandelbulb", want, 1, &m));
    if (!m) return;
    collected c;
    stream(want, 0, &c);
    CHECK_MSG(c.n == m->triangle_count, "%zu streamed, %zu in the mesh", c.n, m->triangle_count);
    if (c.n == m->triangle_count) {
        float *s = soup_of(m);
        qsort(s, c.n, 9 * sizeof(float), cmp_tri);
        qsort(c.tris, c.n, 9 * sizeof(float), cmp_tri);
        CHECK_MSG(!memcmp(s, c.tris, c.n * 9 * sizeof(float)), "%zu triangles: the sets differ", c.n);
        free(s);
    }
    free(c.tris);
    prt_mesh_free(m);
}

TEST(test_mandelbulb_stream_gives_the_triangles_of_the_mesh) {
    same_triangles_as_the_mesh(1);      /* the smallest grid: calibration's correction */
    same_triangles_as_the_mesh(3000);   /* corrected once */
    same_triangles_as_the_mesh(150000); /* many groups, several flood-fill rounds */
}

TEST(test_mandelbulb_stream_order_is_the_same_for_any_threads_and_budget) {
    int threads = omp_get_max_threads();
    collected a, b, c;
    omp_set_num_threads(1);
    stream(100000, 0, &a);
    omp_set_num_threads(3);
    stream(100000, 0, &b);
    stream(100000, 1, &c); /* the smallest budget: groups of a few hundred bricks */
    omp_set_num_threads(threads);
    CHECK(a.n > 90000 && a.n == b.n && b.n == c.n);
    if (a.n == b.n && b.n == c.n) {
        CHECK(!memcmp(a.tris, b.tris, a.n * 9 * sizeof(float)));
        CHECK(!memcmp(b.tris, c.tris, a.n * 9 * sizeof(float)));
    }
    CHECK_MSG(a.calls > 1 && a.max_batch <= 65536, "%zu calls, largest %zu", a.calls, a.max_batch);
    free(a.tris);
    free(b.tris);
    free(c.tris);
}

TEST(test_mandelbulb_stream_stops_at_the_sinks_error) {
    collected c = {0};
    c.ids_ok = true;
    c.stop_after = 1;
    size_t before, after;
    prt_memory_usage(&before, NULL);
    prt_status st = gen_mandelbulb_stream(200000, 1, 0, collect, &c, NULL);
    CHECK_MSG(st == PRT_ERROR_IO, "%s", prt_status_string(st));
    CHECK(strstr(prt_last_error(), "test sink") != NULL);
    CHECK(c.calls == 1);
    prt_memory_usage(&after, NULL);
    CHECK_MSG(after == before, "%zu bytes left allocated", after - before);
    free(c.tris);
}

static unsigned char *read_all(const char *path, size_t *size) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *p = malloc(n > 0 ? (size_t)n : 1);
    *size = p ? fread(p, 1, (size_t)n, f) : 0;
    fclose(f);
    return p;
}

/* Directory entries whose name contains frag. */
static int entries_with(const char *dir, const char *frag) {
    DIR *d = opendir(dir);
    int n = 0;
    if (!d) return -1;
    for (struct dirent *e; (e = readdir(d));) n += strstr(e->d_name, frag) != NULL;
    closedir(d);
    return n;
}

TEST(test_mandelbulb_save_ply_writes_the_bytes_of_the_in_memory_mesh) {
    const char *streamed = PRT_BINARY_DIR "/test_gen_stream_bulb.ply",
               *saved = PRT_BINARY_DIR "/test_gen_stream_bulb_saved.ply";
    static const size_t want[] = {3000, 150000};
    for (size_t k = 0; k < COUNT_OF(want); k++) {
        prt_mesh *m = NULL;
        CHECK_OK(prt_mesh_generate("mandelbulb", want[k], 1, &m));
        if (!m) return;
        CHECK_OK(prt_mesh_save_ply(m, saved));
        uint64_t nt = 0, nv = 0;
        /* The smallest budget: the spill is written and read back in many groups. */
        CHECK_OK(gen_mandelbulb_save_ply(want[k], 1, 1, streamed, &nt, &nv));
        CHECK(nt == m->triangle_count && nv == m->vertex_count);
        size_t na = 0, nb = 0;
        unsigned char *a = read_all(streamed, &na), *b = read_all(saved, &nb);
        CHECK_MSG(a && b && na == nb && !memcmp(a, b, na), "%zu and %zu bytes differ", na, nb);
        free(a);
        free(b);
        prt_mesh *back = NULL;
        CHECK_OK(prt_mesh_load(streamed, &back));
        CHECK(back && back->triangle_count == m->triangle_count);
        prt_mesh_free(back);
        prt_mesh_free(m);
    }
    CHECK_MSG(entries_with(PRT_BINARY_DIR, ".spill-") == 0, "a temporary file was left");
    unlink(streamed);
    unlink(saved);
}

TEST(test_mandelbulb_save_ply_fails_cleanly) {
    size_t before, after;
    prt_memory_usage(&before, NULL);
    prt_status st = gen_mandelbulb_save_ply(1000, 1, 0, PRT_BINARY_DIR "/no/such/dir/b.ply", NULL, NULL);
    CHECK_MSG(st == PRT_ERROR_IO, "%s", prt_status_string(st));
    CHECK(strstr(prt_last_error(), "no/such/dir/b.ply") != NULL);
    const char *path = PRT_BINARY_DIR "/test_gen_stream_limit.ply";
    st = gen_mandelbulb_save_ply(GEN_MAX_TRIANGLES + 1, 1, 0, path, NULL, NULL);
    CHECK_MSG(st == PRT_ERROR_LIMIT, "%s", prt_status_string(st));
    CHECK(access(path, F_OK) != 0); /* no file left */
    CHECK(gen_mandelbulb_save_ply(0, 1, 0, path, NULL, NULL) == PRT_ERROR_ARGUMENT);
    CHECK(gen_mandelbulb_stream(0, 1, 0, collect, NULL, NULL) == PRT_ERROR_ARGUMENT);
    prt_memory_usage(&after, NULL);
    CHECK_MSG(after == before, "%zu bytes left allocated", after - before);
}

int main(void) {
    RUN(test_mandelbulb_stream_gives_the_triangles_of_the_mesh);
    RUN(test_mandelbulb_stream_order_is_the_same_for_any_threads_and_budget);
    RUN(test_mandelbulb_stream_stops_at_the_sinks_error);
    RUN(test_mandelbulb_save_ply_writes_the_bytes_of_the_in_memory_mesh);
    RUN(test_mandelbulb_save_ply_fails_cleanly);
    TEST_END();
}
