/* Rounds: one process's warm figure can differ 2-4x from the next process's on a shared
 * machine (page placement, huge pages, neighbours), so `packrt bench` measures every row in
 * alternating rounds, each with a fresh build, and reports medians with their spread. */
#include "bench.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

/* Median of the n values at base + i * stride (doubles inside rows); 0 stays "not measured"
 * only when every round says 0. Adds (max - min) / median to *spread when larger. */
static double median_of(const bench_row *rounds, size_t n, size_t offset, double *spread) {
    double v[64];
    size_t k = 0;
    for (size_t i = 0; i < n && k < 64; i++) {
        double x;
        memcpy(&x, (const char *)&rounds[i] + offset, sizeof x);
        if (x > 0 && isfinite(x)) v[k++] = x;
    }
    if (!k) return 0;
    double lo = bench_min(v, k), m = bench_median(v, k), hi = v[k - 1]; /* v is sorted now */
    if (spread && m > 0 && (hi - lo) / m > *spread) *spread = (hi - lo) / m;
    return m;
}

void bench_rows_median(const bench_row *rounds, size_t n, bench_row *out) {
    *out = rounds[0];
    out->rounds = (int)n;
    out->spread = 0;
    for (size_t i = 0; i < n; i++)
        if (!rounds[i].ok) {
            *out = rounds[i];
            return;
        }
    /* The one-thread timings decide the spread; the all-threads ones and the build time
     * wait on the scheduler and would mark every row on a shared machine. */
    out->random_us_per_1024 = median_of(rounds, n, offsetof(bench_row, random_us_per_1024), &out->spread);
    out->random_us_per_1024_cold = median_of(rounds, n, offsetof(bench_row, random_us_per_1024_cold), &out->spread);
    out->build_s = median_of(rounds, n, offsetof(bench_row, build_s), NULL);
    for (int w = 0; w < BENCH_WORKLOAD_COUNT; w++) {
        size_t at = offsetof(bench_row, w) + (size_t)w * sizeof(bench_figures);
        out->w[w].mrays_1t = median_of(rounds, n, at + offsetof(bench_figures, mrays_1t), &out->spread);
        out->w[w].mrays_mt = median_of(rounds, n, at + offsetof(bench_figures, mrays_mt), NULL);
    }
}
