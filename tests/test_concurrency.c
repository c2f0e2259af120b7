/* Concurrent queries (issue 31): several threads run single-ray, packet, stream and LOD
 * queries on one accel at once, each thread cycling through the kinds from a different
 * start so that every kind runs beside every other, and every answer is compared with the
 * single-threaded answers of the same accel, taken before. Accels: a BVH; an out-of-core
 * block file opened with the smallest cache (64 blocks, two fifths of the file), with
 * prt_accel_frame called between rounds while no query runs; a cgrid moved with
 * prt_accel_update between rounds. Built for ThreadSanitizer too (scripts/test.sh). */
#include "support/meshes.h"
#include "test.h"

#include <pthread.h>

#define THREADS 4
#define RAYS 1024
#define ROUNDS 3

typedef struct job {
    const prt_accel *a;
    const prt_ray *rays; /* RAYS rays */
    const prt_hit *want; /* single-threaded closest hits */
    bool lod_may_stop;   /* ooc: LOD queries may stop at a voxel (blocks not loaded yet) */
    int first_kind;
    size_t wrong[4]; /* answers that differ, per kind */
} job;

static bool same_hit(const prt_hit *a, const prt_hit *b) {
    return a->prim == b->prim && (a->prim == PRT_INVALID || a->t == b->t);
}

static void single(job *j, size_t lo, size_t hi) {
    for (size_t i = lo; i < hi; i++) {
        prt_ray r = j->rays[i];
        prt_hit h;
        prt_intersect1(j->a, &r, &h);
        j->wrong[0] += !same_hit(&h, &j->want[i]);
        j->wrong[0] += prt_occluded1(j->a, &j->rays[i]) != (j->want[i].prim != PRT_INVALID);
    }
}

static void packets(job *j, size_t lo, size_t hi) {
    prt_ray r[16];
    prt_hit h[16];
    uint8_t occ[16];
    for (size_t i = lo; i + 16 <= hi; i += 16) {
        memcpy(r, j->rays + i, sizeof r);
        prt_packet p = {r, h, 16, 4};
        prt_intersect_packet(j->a, &p);
        memcpy(r, j->rays + i, sizeof r);
        prt_occluded_packet(j->a, &p, occ);
        for (int k = 0; k < 16; k++) {
            j->wrong[1] += !same_hit(&h[k], &j->want[i + k]);
            j->wrong[1] += occ[k] != (j->want[i + k].prim != PRT_INVALID);
        }
    }
}

static void streams(job *j, size_t lo, size_t hi) {
    size_t n = hi - lo;
    prt_ray *r = malloc(n * sizeof *r);
    prt_hit *h = malloc(n * sizeof *h);
    uint8_t *occ = malloc(n);
    if (!r || !h || !occ) {
        j->wrong[2] += n;
    } else {
        memcpy(r, j->rays + lo, n * sizeof *r);
        prt_intersect_stream(j->a, r, h, n, 2);
        prt_occluded_stream(j->a, j->rays + lo, occ, n, 2);
        for (size_t i = 0; i < n; i++) {
            j->wrong[2] += !same_hit(&h[i], &j->want[lo + i]);
            j->wrong[2] += occ[i] != (j->want[lo + i].prim != PRT_INVALID);
        }
    }
    free(r), free(h), free(occ);
}

/* A LOD answer agrees when it is the exact hit, or (ooc) a voxel, which stands for the
 * surface inside it while its block is not published, or a miss: LOD queries answer from
 * the blocks published at the last prt_accel_frame, and the exact queries of the other
 * threads evict them from a cache this small (the root's too, and then no voxel was
 * passed). A triangle is never another than the exact one. */
static bool lod_ok(const job *j, const prt_lod_hit *h, size_t i) {
    if (j->lod_may_stop && (h->hit.prim == PRT_VOXEL_HIT || h->hit.prim == PRT_INVALID)) return true;
    return same_hit(&h->hit, &j->want[i]);
}

static void lods(job *j, size_t lo, size_t hi) {
    prt_ray r[16];
    prt_lod_hit h[16];
    for (size_t i = lo; i + 16 <= hi; i += 16) {
        for (int k = 0; k < 16; k++) {
            prt_ray one = j->rays[i + k];
            prt_lod_hit lh;
            prt_intersect_lod(j->a, &one, 0.0f, &lh);
            j->wrong[3] += !lod_ok(j, &lh, i + k);
            /* A missing exact hit means nothing blocks the ray, voxel or not. */
            if (j->want[i + k].prim == PRT_INVALID && !j->lod_may_stop)
                j->wrong[3] += prt_occluded_lod(j->a, &j->rays[i + k], 0.0f);
        }
        memcpy(r, j->rays + i, sizeof r);
        prt_intersect_lod_packet(j->a, r, h, 16, 0.0f);
        for (int k = 0; k < 16; k++) j->wrong[3] += !lod_ok(j, &h[k], i + k);
    }
}

/* LOD only, as render threads run between two cache updates: nothing is evicted or
 * published meanwhile, so every answer equals the single-threaded one of the same frame. */
static void *lod_worker(void *arg) {
    job *j = arg;
    prt_ray r[16];
    prt_lod_hit h[16];
    for (size_t i = 0; i + 16 <= RAYS; i += 16) {
        size_t at = (i + (size_t)j->first_kind * (RAYS / 4)) % RAYS;
        for (int k = 0; k < 16; k++) {
            prt_ray one = j->rays[at + k];
            prt_lod_hit lh;
            prt_intersect_lod(j->a, &one, 0.0f, &lh);
            j->wrong[3] += !same_hit(&lh.hit, &j->want[at + k]);
        }
        memcpy(r, j->rays + at, sizeof r);
        prt_intersect_lod_packet(j->a, r, h, 16, 0.0f);
        for (int k = 0; k < 16; k++) j->wrong[3] += !same_hit(&h[k].hit, &j->want[at + k]);
    }
    return NULL;
}

static void *worker(void *arg) {
    job *j = arg;
    /* Each thread walks the rays from its own quarter on, so threads touch different
     * blocks of an out-of-core accel at the same time. */
    for (int step = 0; step < 4; step++) {
        int kind = (j->first_kind + step) % 4;
        size_t lo = (size_t)((j->first_kind + step) % 4) * (RAYS / 4), hi = lo + RAYS / 4;
        if (kind == 0) single(j, lo, hi);
        else if (kind == 1) packets(j, lo, hi);
        else if (kind == 2) streams(j, lo, hi);
        else lods(j, lo, hi);
    }
    return NULL;
}

/* One round: THREADS threads at once; returns the wrong answers. */
static size_t round_of(const prt_accel *a, const prt_ray *rays, const prt_hit *want, bool lod_may_stop,
                       const char *what, int round, void *(*fn)(void *)) {
    job jobs[THREADS];
    pthread_t t[THREADS];
    for (int i = 0; i < THREADS; i++) {
        jobs[i] = (job){.a = a, .rays = rays, .want = want, .lod_may_stop = lod_may_stop, .first_kind = i};
        CHECK(pthread_create(&t[i], NULL, fn, &jobs[i]) == 0);
    }
    size_t wrong = 0;
    for (int i = 0; i < THREADS; i++) {
        pthread_join(t[i], NULL);
        static const char *kinds[4] = {"single", "packet", "stream", "lod"};
        for (int k = 0; k < 4; k++) {
            CHECK_MSG(jobs[i].wrong[k] == 0, "%s, round %d, thread %d: %zu wrong %s answers", what, round, i,
                      jobs[i].wrong[k], kinds[k]);
            wrong += jobs[i].wrong[k];
        }
    }
    return wrong;
}

/* The single-threaded answers: prt_intersect1, one ray after another. */
static prt_hit *reference(const prt_accel *a, const prt_ray *rays) {
    prt_hit *h = malloc(RAYS * sizeof *h);
    for (size_t i = 0; h && i < RAYS; i++) {
        prt_ray r = rays[i];
        prt_intersect1(a, &r, &h[i]);
    }
    return h;
}

static size_t hits_of(const prt_hit *h) {
    size_t n = 0;
    for (size_t i = 0; i < RAYS; i++) n += h[i].prim != PRT_INVALID;
    return n;
}

/* A generated mesh and spec built over it; NULL (the mesh freed) on failure. */
static prt_accel *built(const char *kind, size_t tris, const char *spec, prt_mesh **m) {
    *m = NULL;
    prt_accel *a = NULL;
    CHECK_OK(prt_mesh_generate(kind, tris, 4, m));
    if (*m) CHECK_OK(prt_build(*m, spec, NULL, &a));
    if (!a) prt_mesh_free(*m), *m = NULL;
    return a;
}

TEST(test_threads_share_a_bvh) {
    prt_mesh *m;
    prt_accel *a = built("mandelbulb", 30000, "quad:float3-soa4", &m);
    if (!a) return;
    prt_ray *rays = rays_random(m, RAYS, 5);
    prt_hit *want = reference(a, rays);
    CHECK(hits_of(want) > RAYS / 4);
    for (int r = 0; r < ROUNDS; r++) round_of(a, rays, want, false, "bvh", r, worker);
    free(rays), free(want);
    prt_accel_free(a);
    prt_mesh_free(m);
}

TEST(test_threads_share_an_ooc_accel_whose_cache_evicts) {
    const char *path = test_tmp_path("concurrency.ooc");
    prt_build_options bo = {.threads = 2};
    CHECK_OK(prt_build_generated("mandelbulb", 250000, 6, "ooc", path, &bo));
    prt_open_options oo = {.cache_bytes = 1, .fetchers = 2}; /* the minimum: 64 blocks of 64 KB */
    prt_accel *a = NULL;
    CHECK_OK(prt_accel_open(path, &oo, &a));
    if (!a) return;
    prt_stats st;
    prt_accel_stats(a, &st);
    /* About 160 blocks raw: the cache holds two fifths of the file. */
    CHECK_MSG(st.bytes_tree + st.bytes_geometry > 2 * 64u * 65536u,
              "the file (%zu bytes raw) must be over twice the cache", st.bytes_tree + st.bytes_geometry);
    float lo[3], hi[3];
    prt_accel_bounds(a, lo, hi);
    /* Rays from around the bounds through them (rays_random needs a mesh: a box stands in). */
    prt_mesh *box;
    CHECK_OK(prt_mesh_create(2, 1, &box));
    memcpy(box->vertices, lo, sizeof lo), memcpy(box->vertices + 3, hi, sizeof hi);
    box->triangles[0] = 0, box->triangles[1] = 1, box->triangles[2] = 1;
    prt_ray *rays = rays_random(box, RAYS, 9);
    prt_mesh_free(box);
    prt_hit *want = reference(a, rays);
    CHECK(hits_of(want) > RAYS / 8);
    prt_cache_info ci = {0};
    for (int r = 0; r < ROUNDS + 2; r++) {
        round_of(a, rays, want, true, "ooc", r, worker);
        prt_accel_frame(a, &ci); /* no query runs now: publish loads, evict */
    }
    /* Frames of LOD queries only: the threads agree with one thread in the same frame. */
    for (int r = 0; r < ROUNDS; r++) {
        prt_hit *lod = malloc(RAYS * sizeof *lod);
        for (size_t i = 0; lod && i < RAYS; i++) {
            prt_ray one = rays[i];
            prt_lod_hit lh;
            prt_intersect_lod(a, &one, 0.0f, &lh);
            lod[i] = lh.hit;
        }
        if (lod) round_of(a, rays, lod, false, "ooc lod frame", r, lod_worker);
        free(lod);
        prt_accel_frame(a, &ci);
    }
    CHECK_MSG(ci.blocks_loaded_total > 64, "only %llu block loads: the cache did not evict",
              (unsigned long long)ci.blocks_loaded_total);
    CHECK_OK(prt_accel_check(a));
    free(rays), free(want);
    prt_accel_free(a);
    remove(path);
}

TEST(test_threads_share_a_cgrid_updated_between_frames) {
    prt_mesh *m;
    prt_accel *a = built("sphere", 20000, "cgrid", &m);
    if (!a) return;
    prt_ray *rays = rays_random(m, RAYS, 3);
    float *v = malloc(3 * m->vertex_count * sizeof *v);
    for (int r = 0; r < ROUNDS; r++) {
        /* Frame r: the sphere squashed and moved a little more. */
        for (size_t i = 0; i < m->vertex_count; i++)
            for (int k = 0; k < 3; k++)
                v[3 * i + k] = m->vertices[3 * i + k] * (k == 1 ? 1.0f - 0.1f * (float)r : 1.0f) + 0.02f * (float)r;
        CHECK_OK(prt_accel_update(a, v));
        prt_hit *want = reference(a, rays);
        CHECK(hits_of(want) > RAYS / 8);
        round_of(a, rays, want, false, "cgrid", r, worker);
        free(want);
    }
    free(v), free(rays);
    prt_accel_free(a);
    prt_mesh_free(m);
}

int main(void) {
    RUN(test_threads_share_a_bvh);
    RUN(test_threads_share_an_ooc_accel_whose_cache_evicts);
    RUN(test_threads_share_a_cgrid_updated_between_frames);
    TEST_END();
}
