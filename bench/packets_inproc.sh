#!/usr/bin/env bash
# packrt's packet and stream rates against Embree's in one process (docs/results/packets.md,
# steps 4 and 5): the bench's rays (1024x1024 camera in 8x8 tiles, its light, its diffuse
# seed, 65,536 random rays; AO: the diffuse rays with tfar 5% of the diagonal), each
# workload timed alternately with Embree rep by rep on the thread's CPU time. Prints the
# median of the per-rep ratios packrt rate / Embree rate (> 1: packrt faster):
#   primary  prt_intersect_packet per tile   vs rtcIntersect1M, coherent flag
#   shadow   prt_occluded_stream             vs rtcOccluded1M
#   diffuse, random  prt_intersect_stream    vs rtcIntersect1M
#   ao       prt_occluded_stream             vs rtcOccluded1M
# On a shared machine two processes' medians moved by up to 2x between runs; the per-rep
# ratio sees the same load on both sides. One thread; links BUILD's library (default build).
# Usage: bench/packets_inproc.sh MESH [SPEC] [REPS]   (wide8:float3-soa8, 7)
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: bench/packets_inproc.sh MESH [SPEC] [REPS]" >&2; exit 2; }
cd "$(dirname "$0")/.."
build=${BUILD:-build}
[ -f "$build/libpackrt_bench.a" ] || { echo "packets_inproc: build $build first (needs Embree)" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat > "$tmp/ab.c" <<'CEOF'
#include "bench.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

enum { PACKETS, OCCLUDED, STREAM, MAX_REPS = 64 };

static double cpu_now(void) {
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int by_value(const void *a, const void *b) {
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* The median over reps of (Embree's time / packrt's time) on the rays of set. */
static double ratio(prt_accel *a, bench_embree *e, const bench_rays *set, int mode, int reps) {
    const size_t n = set->count;
    prt_ray *r = malloc(n * sizeof *r);
    prt_hit *h = malloc(n * sizeof *h);
    uint8_t *o = malloc(n);
    bench_backend eb = bench_backend_embree(e, "embree");
    bench_batch *bb = eb.load(eb.self, set);
    if (!r || !h || !o || !bb) fprintf(stderr, "packets_inproc: out of memory\n"), exit(1);
    double q[MAX_REPS];
    for (int k = 0; k < reps; k++) {
        memcpy(r, set->rays, n * sizeof *r);
        double t0 = cpu_now();
        if (mode == PACKETS)
            for (size_t i = 0; i < n; i += 64) {
                prt_packet p = {r + i, h + i, n - i < 64 ? (uint32_t)(n - i) : 64, 8};
                prt_intersect_packet(a, &p);
            }
        else if (mode == OCCLUDED) prt_occluded_stream(a, r, o, n, 1);
        else prt_intersect_stream(a, r, h, n, 1);
        const double ours = cpu_now() - t0;
        eb.reset(eb.self, bb);
        t0 = cpu_now();
        eb.stream(eb.self, bb, 1);
        q[k] = (cpu_now() - t0) / ours;
    }
    qsort(q, (size_t)reps, sizeof *q, by_value);
    eb.unload(eb.self, bb);
    free(r), free(h), free(o);
    return q[reps / 2];
}

int main(int argc, char **argv) {
    (void)argc;
    const int reps = atoi(argv[3]) < 1 ? 1 : atoi(argv[3]) > MAX_REPS ? MAX_REPS : atoi(argv[3]);
    prt_mesh *m;
    prt_accel *a;
    bench_embree *e;
    if (prt_mesh_load(argv[1], &m) || prt_build(m, argv[2], NULL, &a) || bench_embree_create(m, NULL, &e))
        return fprintf(stderr, "packets_inproc: %s\n", prt_last_error()), 1;
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    double d = 0;
    for (int k = 0; k < 3; k++) d += (double)(hi[k] - lo[k]) * (hi[k] - lo[k]);
    const float offset = (float)(BENCH_SURFACE_OFFSET * sqrt(d));
    bench_camera cam;
    bench_camera_default(lo, hi, &cam);
    bench_rays prim, sh, df, rnd;
    if (bench_rays_primary(&cam, 1024, 1024, 8, &prim)) return 1;
    prt_ray *r = malloc(prim.count * sizeof *r);
    prt_hit *h = malloc(prim.count * sizeof *h);
    if (!r || !h) return 1;
    memcpy(r, prim.rays, prim.count * sizeof *r);
    prt_intersect_stream(a, r, h, prim.count, 1);
    float light[3];
    bench_light_default(lo, hi, light);
    if (bench_rays_shadow(m, &prim, h, light, offset, &sh) || bench_rays_diffuse(m, &prim, h, 1, offset, &df) ||
        bench_rays_random(lo, hi, 65536, 1, &rnd))
        return 1;
    bench_rays ao = df;
    prt_ray *aor = malloc(df.count * sizeof *aor);
    if (!aor) return 1;
    for (size_t i = 0; i < df.count; i++) aor[i] = df.rays[i], aor[i].tfar = (float)(0.05 * sqrt(d));
    ao.rays = aor, ao.any_hit = true, ao.kind = BENCH_SHADOW;
    printf("%s %s primary %.3f shadow %.3f diffuse %.3f random %.3f ao %.3f\n", argv[1], argv[2],
           ratio(a, e, &prim, PACKETS, reps), ratio(a, e, &sh, OCCLUDED, reps), ratio(a, e, &df, STREAM, reps),
           ratio(a, e, &rnd, STREAM, reps), ratio(a, e, &ao, OCCLUDED, reps));
    return 0;
}
CEOF
libs=(-lembree3 -lassimp -lz -lmeshoptimizer -llz4 -lm -fopenmp -lpthread)
if grep -q "PRT_HAVE_PNG\|PNG_LIBRARY" "$build/CMakeCache.txt" 2>/dev/null; then libs+=(-lpng); fi
cc -O2 -std=gnu11 -Iinclude -Ibench -Isrc "$tmp/ab.c" "$build/libpackrt_bench.a" "$build/libpackrt.a" "${libs[@]}" \
  -o "$tmp/ab"
"$tmp/ab" "$1" "${2:-wide8:float3-soa8}" "${3:-7}"
