#!/usr/bin/env bash
# Benthin et al.'s Tables 1-3 on this machine, written to docs/results/lossygrid.md: the
# displaced scenes (terrain as the Ground, canyon, torus) at each size and the real meshes of
# ../shared/data, lossygrid in its three encodings against Embree and packrt's triangle BVHs
# on the same rays (random, primary, diffuse), plus each encoding's error statistics.
# Usage: bench/lossygrid.sh [SIZES]   (default "1M 10M"; e.g. "1M 10M 40M")
#   BUILD=dir (default build), OUT=dir to keep the meshes and JSON (default a temp dir; JSON
#   files already there are reported too, so a 40M run can be added to a kept one),
#   REPS=n (default 5), KINDS="terrain canyon torus", REAL=0 to skip ../shared/data,
#   RESULTS=file (default docs/results/lossygrid.md; an existing one is kept and the tables go
#   to RESULTS.new unless FORCE=1), SPECS="spec ..." to bench only these
#   representations (default: the three encodings, ids=mesh and three triangle BVHs)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${BUILD:-build}
sizes=${1:-"1M 10M"}
out=${OUT:-$(mktemp -d)}
reps=${REPS:-5}
results=${RESULTS:-docs/results/lossygrid.md}
# The results file also holds sections written by hand around the generated tables: a rerun
# writes its tables beside it (FILE.new, to merge by hand) rather than over it, unless FORCE=1.
if [ -e "$results" ] && [ "${FORCE:-0}" != 1 ]; then results="$results.new"; fi
mkdir -p "$out"
if [ ! -x "$build/packrt" ]; then
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$build" -j"$(nproc)" >/dev/null
fi
specs=(-r lossygrid,ids=none -r lossygrid -r lossygrid,enc=oct,ids=none -r lossygrid,enc=exp,ids=none
       -r wide8:float3-soa8 -r quad:idx32-soa4 -r wide8:idx8-bitpack-soa4,ids=none)
if [ -n "${SPECS:-}" ]; then
  specs=()
  for s in $SPECS; do specs+=(-r "$s"); done
fi
meshes=()
for n in $sizes; do
  for k in ${KINDS:-terrain canyon torus}; do
    f="$out/$k-$n.ply"
    [ -f "$f" ] || "$build/packrt" gen "$k" --tris "$n" -o "$f" >/dev/null
    meshes+=("$f")
  done
done
if [ "${REAL:-1}" != 0 ]; then
  for m in ../shared/data/bunny.ply ../shared/data/bart_kitchen/kitchen_000.ply.gz ../shared/data/bart_robots/robots_000.ply.gz; do
    if [ -f "$m" ]; then meshes+=("$m"); fi
  done
fi
for m in "${meshes[@]}"; do
  j="$out/$(basename "$m" | sed 's/\..*//').json"
  echo "lossygrid.sh: $m" >&2
  "$build/packrt" bench "$m" "${specs[@]}" --workload random,primary,diffuse --reps "$reps" --json > "$j"
done
python3 bench/lossygrid_md.py "$out"/*.json > "$results"
echo "lossygrid.sh: wrote $results (JSON in $out)" >&2
