#!/usr/bin/env bash
# One representation against Embree timed on the thread's CPU time rather than the wall
# clock, for a shared machine where other processes take the cores away in the middle of a
# timing: the bench's own backends (bench/backend_packrt.c, bench/embree_backend.c: packets
# per 8x8 tile for primary rays, single rays for random and diffuse), the same rays as
# `packrt bench` (seed 1: 64k random, 1024x1024 primary, diffuse bounces from Embree's
# primary hits), one thread, the two alternating rep by rep; prints the median of each and
# the ratio (> 1: faster than Embree). Compiled here against BUILD's static libraries.
# Usage: bench/lossygrid_cpu.sh MESH [SPEC] [REPS]   (default lossygrid,ids=none, 7)
#   BUILD=dir (default build), WORKLOADS="random primary diffuse"
set -euo pipefail
cd "$(dirname "$0")/.."
build=${BUILD:-build}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat > "$tmp/cpu.c" <<'EOF'
#include "bench.h"
#include "core/common.h"
#include "packrt.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
int main(int argc, char **argv) {
    const char *spec = argv[2];
    const int reps = atoi(argv[3]);
    prt_mesh *m;
    if (prt_mesh_load(argv[1], &m)) return fprintf(stderr, "%s\n", prt_last_error()), 1;
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    bench_accel a;
    bench_embree *e;
    if (bench_build(m, spec, 1, &a)) return fprintf(stderr, "%s\n", prt_last_error()), 1;
    if (bench_embree_create(m, NULL, &e)) return fprintf(stderr, "no Embree\n"), 1;
    bench_backend be[2] = {bench_backend_packrt(&a, spec), bench_backend_embree(e, "embree")};
    bench_camera c;
    bench_camera_default(lo, hi, &c);
    bench_rays primary;
    bench_rays_primary(&c, 1024, 1024, 8, &primary);
    prt_hit *hits = malloc(primary.count * sizeof *hits);
    prt_ray *work = malloc(primary.count * sizeof *work);
    memcpy(work, primary.rays, primary.count * sizeof *work);
    for (size_t i = 0; i < primary.count; i++) bench_embree_intersect(e, &work[i], &hits[i]);
    for (int w = 4; w < argc; w++) {
        bench_rays r = primary;
        if (!strcmp(argv[w], "random")) bench_rays_random(lo, hi, 65536, 1, &r);
        else if (!strcmp(argv[w], "diffuse")) bench_rays_diffuse(m, &primary, hits, 1, BENCH_SURFACE_OFFSET, &r);
        bench_batch *b[2] = {be[0].load(be[0].self, &r), be[1].load(be[1].self, &r)};
        double t[2][64];
        for (int rep = 0; rep < reps && rep < 64; rep++)
            for (int k = 0; k < 2; k++) {
                be[k].reset(be[k].self, b[k]);
                const double t0 = prt__thread_seconds();
                be[k].stream(be[k].self, b[k], 1);
                t[k][rep] = prt__thread_seconds() - t0;
            }
        const double ours = bench_median(t[0], (size_t)reps), theirs = bench_median(t[1], (size_t)reps);
        printf("%s\t%s\t%s\t%zu rays\t%.3f Mrays/s\tembree %.3f Mrays/s\tratio %.3f\n", argv[1], spec, argv[w], r.count,
               (double)r.count / ours / 1e6, (double)r.count / theirs / 1e6, theirs / ours);
        for (int k = 0; k < 2; k++) be[k].unload(be[k].self, b[k]);
    }
    return 0;
}
EOF
libs=(-lembree3 -lz -lmeshoptimizer -llz4 -lm -fopenmp -lpthread)
if grep -q "PRT_HAVE_PNG\|PNG_LIBRARY" "$build/CMakeCache.txt" 2>/dev/null; then libs+=(-lpng); fi
cc -O2 -std=c11 -D_GNU_SOURCE -Iinclude -Ibench -Isrc "$tmp/cpu.c" "$build/libpackrt_bench.a" "$build/libpackrt.a" "${libs[@]}" -o "$tmp/cpu"
# shellcheck disable=SC2086
"$tmp/cpu" "$1" "${2:-lossygrid,ids=none}" "${3:-7}" ${WORKLOADS:-random primary diffuse}
