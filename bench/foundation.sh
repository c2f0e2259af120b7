#!/usr/bin/env bash
# Reproduces docs/results/foundation.md: every representation and Embree on the bunny (when
# ../shared/data is there) and on generated 1M and 10M triangle meshes.
# Usage: bench/foundation.sh [BUILD_DIR] > docs/results/foundation.md   (takes ~10 minutes)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
packrt="$build/packrt"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
meshes=()
if [ -f ../shared/data/bunny.ply ]; then meshes+=(../shared/data/bunny.ply); fi
"$packrt" gen mandelbulb --tris 1M --seed 1 -o "$tmp/mandelbulb_1M.ply" >&2
"$packrt" gen mandelbulb --tris 10M --seed 1 -o "$tmp/mandelbulb_10M.ply" >&2
meshes+=("$tmp/mandelbulb_1M.ply" "$tmp/mandelbulb_10M.ply")
jsons=()
for m in "${meshes[@]}"; do
  name=$(basename "$m" .ply)
  echo "bench: $m" >&2
  "$packrt" bench "$m" --json >"$tmp/$name.json"
  jsons+=("$tmp/$name.json")
done
python3 bench/results_md.py "Foundation: aabb and quad BVHs against Embree" \
  "bench/foundation.sh  # packrt gen mandelbulb --tris 1M|10M --seed 1; packrt bench MESH --json" "${jsons[@]}"
