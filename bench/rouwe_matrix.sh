#!/usr/bin/env bash
# Reproduces the measured part of docs/results/rouwe-matrix.md: Rouwé's tables (every
# layout x codec, the splitter, leaf-size and node-order tables, Embree in the same run)
# on the Stanford bunny (when ../shared/data is there) and on a generated 2M-triangle
# game level standing in for the paper's 2.26M-triangle scene; then the configurations
# the targets name (ids=none, larger leaves). Each matrix runs RUNS times (default 3) and
# every cell of the main table is the median over the runs (bench/matrix_median.py): the
# machine is shared and one noisy run should not decide a row.
# Usage: bench/rouwe_matrix.sh [BUILD_DIR] > matrix.md   (about 20 minutes on 2 cores)
# RUNS=N changes the number of runs; KEEP=DIR keeps every run's raw output there.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
runs=${RUNS:-3}
packrt="$build/packrt"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
keep=${KEEP:-$tmp}
mkdir -p "$keep"
meshes=()
if [ -f ../shared/data/bunny.ply ]; then meshes+=(../shared/data/bunny.ply); fi
"$packrt" gen level --tris 2M --seed 1 -o "$tmp/level_2M.ply" >&2
meshes+=("$tmp/level_2M.ply")
selected=(-r wide8:float3-soa8 -r wide8:float3-soa4 -r quad:float3-soa4
          -r wide8:idx8-soa4 -r wide8:idx8-soa4,ids=none -r wide8:idx8-soa4,ids=none,leaf=16
          -r wide8:idx16-soa4,ids=none -r quad-half:idx8-soa4,ids=none
          -r wide8:idx8-bitpack-soa4,ids=none -r wide8:idx8-bitpack-soa4,ids=none,leaf=12
          -r aabb-compressed:idx8-bitpack-soa4,ids=none -r quad-half:idx8-bitpack-soa4,ids=none)
for m in "${meshes[@]}"; do
  name=$(basename "$m")
  gen=""
  [ "$name" = level_2M.ply ] && gen=" (mesh: \`packrt gen level --tris 2M --seed 1\`)"
  echo "## $name"
  echo
  echo "Command: \`packrt bench $name --matrix\`, $runs runs$gen"
  echo
  files=()
  for r in $(seq "$runs"); do
    echo "matrix: $m, run $r of $runs" >&2
    "$packrt" bench "$m" --matrix >"$keep/${name%.ply}_run$r.md"
    files+=("$keep/${name%.ply}_run$r.md")
  done
  python3 bench/matrix_median.py "${files[@]}"
  echo
  echo "### Selected configurations on $name"
  echo
  echo "Command: \`packrt bench $name --matrix --cold-rays 0 ${selected[*]}\`, $runs runs"
  echo
  files=()
  for r in $(seq "$runs"); do
    echo "matrix: $m, selected, run $r of $runs" >&2
    "$packrt" bench "$m" --matrix --cold-rays 0 "${selected[@]}" >"$keep/${name%.ply}_selected$r.md"
    files+=("$keep/${name%.ply}_selected$r.md")
  done
  python3 bench/matrix_median.py "${files[@]}" | sed -n '/^| representation/,/^$/p'
  echo
done
