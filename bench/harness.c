/* Timing of one backend on one workload (docs/benchmark.md): the medians of repeated runs on one
 * thread and on all threads, and Rouwé's warm and cold figures for 1024 random rays. Rays are
 * converted to the backend's layout and reset outside the timed region. */
#include "bench.h"

#include "core/common.h"

#include <stdlib.h>
#include <string.h>

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

double bench_median(double *v, size_t n) {
    if (!n) return 0.0;
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double bench_min(const double *v, size_t n) {
    double m = n ? v[0] : 0.0;
    for (size_t i = 1; i < n; i++)
        if (v[i] < m) m = v[i];
    return m;
}

static int reps_of(const bench_options *o) { return o->reps < 5 ? 5 : o->reps; }

void bench_measure_random_1024(const bench_backend *b, const bench_rays *random, const bench_options *o,
                               double *warm_us, double *cold_us) {
    *warm_us = *cold_us = 0.0;
    /* The paper's batch: the first 1024 rays (fewer if the set is smaller). */
    bench_rays batch = *random;
    batch.count = random->count < 1024 ? random->count : 1024;
    batch.tile = 0;
    batch.pixel = NULL;
    if (!batch.count) return;
    bench_batch *bb = b->load(b->self, &batch);
    if (!bb) return;
    double scale = 1024.0 / (double)batch.count;

    /* Warm: one untimed pass loads the caches, then the minimum over repetitions, as
     * RayCastTest's PerfTimer reports next to the average. A batch takes ~0.1-1 ms, short
     * enough for a timer interrupt or a neighbour's burst to spoil single samples: 4x the
     * requested repetitions, and the minimum, make the figure reproducible. */
    int n = 4 * reps_of(o);
    double *t = malloc((size_t)n * sizeof *t);
    if (!t) {
        b->unload(b->self, bb);
        return;
    }
    b->reset(b->self, bb);
    b->single(b->self, bb, 0, batch.count);
    for (int i = 0; i < n; i++) {
        b->reset(b->self, bb);
        double t0 = prt__now();
        b->single(b->self, bb, 0, batch.count);
        t[i] = (prt__now() - t0) * 1e6 * scale;
    }
    *warm_us = bench_min(t, (size_t)n);

    /* Cold: caches flushed before every batch (see cache_flush.c), median of repetitions. */
    if (o->cold) {
        int nc = reps_of(o) < 10 ? 10 : reps_of(o);
        for (int i = 0; i < nc && i < n; i++) {
            b->reset(b->self, bb);
            bench_cache_flush(o->flush_bytes);
            double t0 = prt__now();
            b->single(b->self, bb, 0, batch.count);
            t[i] = (prt__now() - t0) * 1e6 * scale;
        }
        *cold_us = bench_median(t, (size_t)(nc < n ? nc : n));
    }
    free(t);
    b->unload(b->self, bb);
}

/* Median Mrays/s of `reps` runs of the whole batch on `threads` threads, after one untimed
 * warm-up run (first-touch page faults, thread pool start-up, lazy initialisation). */
static double time_stream(const bench_backend *b, bench_batch *bb, size_t count, int threads, int reps,
                          double *scratch) {
    b->reset(b->self, bb);
    b->stream(b->self, bb, threads);
    for (int i = 0; i < reps; i++) {
        b->reset(b->self, bb);
        double t0 = prt__now();
        b->stream(b->self, bb, threads);
        double dt = prt__now() - t0;
        scratch[i] = dt > 0 ? (double)count / dt * 1e-6 : 0.0;
    }
    return bench_median(scratch, (size_t)reps);
}

bool bench_measure_workload(const bench_backend *b, const bench_rays *rays, const bench_options *o, bench_figures *f,
                            prt_hit *hits, uint8_t *occluded) {
    memset(f, 0, sizeof *f);
    f->rays = rays->count;
    if (!rays->count) return true;
    int reps = reps_of(o);
    double *scratch = malloc((size_t)reps * sizeof *scratch);
    bench_batch *bb = scratch ? b->load(b->self, rays) : NULL;
    if (!bb) {
        free(scratch);
        return false;
    }
    f->mrays_1t = time_stream(b, bb, rays->count, 1, reps, scratch);
    int mt = prt__threads(o->threads);
    /* With one core the "all threads" figure is the one-thread figure: don't spend the time. */
    f->mrays_mt = mt > 1 ? time_stream(b, bb, rays->count, mt, reps, scratch) : f->mrays_1t;
    b->results(b->self, bb, hits, occluded);
    b->unload(b->self, bb);
    free(scratch);
    return true;
}

double bench_measure_random_cold_per_ray(const bench_backend *b, const bench_rays *random, size_t n,
                                         size_t flush_bytes) {
    bench_rays batch = *random;
    batch.count = random->count < n ? random->count : n;
    batch.tile = 0;
    batch.pixel = NULL;
    if (!batch.count) return 0.0;
    bench_batch *bb = b->load(b->self, &batch);
    if (!bb) return 0.0;
    /* Every ray starts from flushed caches; only the ray itself is inside the timer. */
    double sum = 0;
    for (size_t i = 0; i < batch.count; i++) {
        b->reset(b->self, bb);
        bench_cache_flush(flush_bytes);
        double t0 = prt__now();
        b->single(b->self, bb, i, 1);
        sum += prt__now() - t0;
    }
    b->unload(b->self, bb);
    return sum * 1e6 * 1024.0 / (double)batch.count;
}
