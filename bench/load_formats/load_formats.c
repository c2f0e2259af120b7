/* Mesh load throughput per file format (docs/results/formats.md): each file loaded
 * `runs` times in turn (round robin, so machine load hits every format alike): median
 * wall time and median CPU time (user + system: what a shared, oversubscribed machine
 * measures more steadily), triangles per second and the ratio to the first file for
 * both, and the peak of packrt's allocations during a load. Not part of the build (bench/*.c only
 * is); compile with
 *   cc -O2 -Iinclude bench/load_formats/load_formats.c build/libpackrt.a \
 *      $(pkg-config --libs liblz4) -lmeshoptimizer -lz -lpng -lassimp -lm -fopenmp -lstdc++ -o
 * load_formats (drop -lassimp for a build without Assimp) usage: load_formats RUNS FILE... */
#include "packrt.h"

#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double clock_s(clockid_t c) {
    struct timespec ts;
    clock_gettime(c, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

int main(int argc, char **argv) {
    if (argc < 3) return fprintf(stderr, "usage: load_formats RUNS FILE...\n"), 2;
    int runs = atoi(argv[1]), nf = argc - 2;
    double *t = calloc((size_t)(runs * nf), sizeof *t), *cpu = calloc((size_t)(runs * nf), sizeof *cpu);
    size_t *peak = calloc((size_t)nf, sizeof *peak), *tris = calloc((size_t)nf, sizeof *tris);
    for (int r = 0; r < runs; r++)
        for (int f = 0; f < nf; f++) {
            prt_mesh *m;
            prt_memory_reset_peak();
            double t0 = clock_s(CLOCK_MONOTONIC), c0 = clock_s(CLOCK_PROCESS_CPUTIME_ID);
            if (prt_mesh_load(argv[2 + f], &m)) return fprintf(stderr, "%s\n", prt_last_error()), 1;
            t[f * runs + r] = clock_s(CLOCK_MONOTONIC) - t0;
            cpu[f * runs + r] = clock_s(CLOCK_PROCESS_CPUTIME_ID) - c0; /* user + system */
            size_t p;
            prt_memory_usage(NULL, &p);
            if (p > peak[f]) peak[f] = p;
            tris[f] = m->triangle_count;
            prt_mesh_free(m);
        }
    double base = 0, cbase = 0;
    for (int f = 0; f < nf; f++) {
        qsort(t + f * runs, (size_t)runs, sizeof *t, cmp);
        qsort(cpu + f * runs, (size_t)runs, sizeof *cpu, cmp);
        double med = t[f * runs + runs / 2], rate = (double)tris[f] / med;
        double cmed = cpu[f * runs + runs / 2], crate = (double)tris[f] / cmed;
        if (f == 0) base = rate, cbase = crate;
        printf("%-24s %9zu tris  wall median %.3f s (min %.3f, max %.3f) %6.1f Mtri/s %.2fx  "
               "cpu median %.3f s %6.1f Mtri/s %.2fx  peak %.0f MiB\n",
               argv[2 + f], tris[f], med, t[f * runs], t[f * runs + runs - 1], rate / 1e6, rate / base, cmed,
               crate / 1e6, crate / cbase, (double)peak[f] / 1048576.0);
    }
    return 0;
}
