#!/usr/bin/env bash
# A/B of lossygrid's traversal kernels in one process: src/lossygrid/traverse.c (with the
# record.h it includes) as of REV against the working tree's, both compiled into one
# program with their entry points renamed, tracing the same blob (built by BUILD's library)
# and the same rays, alternating rep by rep on the thread's CPU time. On a shared machine
# the ratio of two medians taken in separate processes moved by 0.65-0.92 between runs of
# the same code; the median of per-rep ratios here stays within about 2% (A/A runs), since
# both sides see the same load, frequency and caches. Prints the speed-up (> 1: the tree is
# faster) and how many hits differ (bit for bit). The tree's side takes src/lossygrid only
# (onto REV's other sources), so another module's uncommitted edits do not leak into it.
# Kernels only: a change to the build or the record format needs bench/lossygrid_cpu.sh.
# Usage: bench/lossygrid_inproc.sh MESH [REV] [REPS] [WORKLOAD]   (HEAD, 21, diffuse|random)
#   BUILD=dir (default build): the library the program links for everything else
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: bench/lossygrid_inproc.sh MESH [REV] [REPS] [WORKLOAD]" >&2; exit 2; }
cd "$(dirname "$0")/.."
build=${BUILD:-build}
rev=${2:-HEAD}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/base" "$tmp/tree"
git archive "$rev" src include | tar -x -C "$tmp/base"
git archive "$rev" src include | tar -x -C "$tmp/tree"
cp src/lossygrid/* "$tmp/tree/src/lossygrid/"
cat > "$tmp/ab.c" <<'EOF'
#include "bench.h"
#include "core/common.h"
#include "lossygrid/lossygrid.h"
#include "packrt.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
typedef void stream_fn(const uint8_t *blob, const bvh_shared *sh, prt_ray *rays, prt_hit *hits, size_t n);
stream_fn base_lg_trace_stream, tree_lg_trace_stream;
int main(int argc, char **argv) {
    int reps = atoi(argv[2]);
    if (reps < 1 || reps > 256) reps = 21;
    const char *work = argv[3];
    prt_mesh *m;
    if (prt_mesh_load(argv[1], &m)) return fprintf(stderr, "%s\n", prt_last_error()), 1;
    float lo[3], hi[3];
    prt_mesh_bounds(m, lo, hi);
    bench_embree *e;
    if (bench_embree_create(m, NULL, &e)) return fprintf(stderr, "no Embree\n"), 1;
    bench_camera c;
    bench_camera_default(lo, hi, &c);
    bench_rays primary, r;
    bench_rays_primary(&c, 1024, 1024, 8, &primary);
    prt_hit *hits = malloc(primary.count * sizeof *hits);
    prt_ray *w = malloc(primary.count * sizeof *w);
    memcpy(w, primary.rays, primary.count * sizeof *w);
    for (size_t i = 0; i < primary.count; i++) bench_embree_intersect(e, &w[i], &hits[i]);
    if (!strcmp(work, "random")) bench_rays_random(lo, hi, 65536, 1, &r);
    else bench_rays_diffuse(m, &primary, hits, 1, BENCH_SURFACE_OFFSET, &r);
    lg_build_params p = {LG_ENC_FIX, 1, 0};
    bvh_blob blob;
    uint32_t *order = NULL;
    lg_build_report rep;
    if (lg_build_blob(m, &p, &blob, &order, &rep)) return fprintf(stderr, "%s\n", prt_last_error()), 1;
    bvh_shared sh = {.triangles = rep.triangles}; /* ids=none */
    const size_t n = r.count;
    prt_ray *rw = malloc(n * sizeof *rw);
    prt_hit *h[2] = {malloc(n * sizeof(prt_hit)), malloc(n * sizeof(prt_hit))};
    stream_fn *f[2] = {base_lg_trace_stream, tree_lg_trace_stream};
    static double t[2][256], ratio[256];
    for (int k = 0; k < reps; k++)
        for (int s = 0; s < 2; s++) {
            memcpy(rw, r.rays, n * sizeof *rw);
            const double t0 = prt__thread_seconds();
            f[s](blob.data, &sh, rw, h[s], n);
            t[s][k] = prt__thread_seconds() - t0;
        }
    size_t differ = 0;
    for (size_t i = 0; i < n; i++) differ += memcmp(&h[0][i], &h[1][i], sizeof(prt_hit)) != 0;
    for (int k = 0; k < reps; k++) ratio[k] = t[0][k] / t[1][k];
    const double speedup = bench_median(ratio, (size_t)reps); /* ratio is sorted now: its quartiles */
    const double base = bench_median(t[0], (size_t)reps), tree = bench_median(t[1], (size_t)reps);
    printf("%s\t%s\t%zu rays\tbase %.3f Mrays/s\ttree %.3f Mrays/s\tspeed-up %.3f (quartiles %.3f-%.3f)\t%zu hits differ\n",
           argv[1], work, n, (double)n / base / 1e6, (double)n / tree / 1e6, speedup, ratio[reps / 4],
           ratio[3 * reps / 4], differ);
    return differ != 0;
}
EOF
flags=$(sed -n 's/^C_FLAGS = //p' "$build/CMakeFiles/packrt_obj.dir/flags.make")
for side in base tree; do
    ren=""
    for f in lg_trace_stream lg_trace1 lg_trace_any lg_trace1_template lg_trace_packet lg_occlude_packet; do
        ren+=" -D$f=${side}_$f"
    done
    # shellcheck disable=SC2086
    cc $flags $ren -I"$tmp/$side/include" -I"$tmp/$side/src" -c "$tmp/$side/src/lossygrid/traverse.c" -o "$tmp/$side.o"
done
libs=(-lembree3 -lz -lmeshoptimizer -llz4 -lm -fopenmp -lpthread)
if grep -q "PRT_HAVE_PNG\|PNG_LIBRARY" "$build/CMakeCache.txt" 2>/dev/null; then libs+=(-lpng); fi
cc -O2 -std=c11 -D_GNU_SOURCE -Iinclude -Ibench -Isrc "$tmp/ab.c" "$tmp/base.o" "$tmp/tree.o" "$build/libpackrt_bench.a" \
    "$build/libpackrt.a" "${libs[@]}" -o "$tmp/ab"
"$tmp/ab" "$1" "${3:-21}" "${4:-diffuse}"
