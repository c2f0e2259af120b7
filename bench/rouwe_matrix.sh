#!/usr/bin/env bash
# Reproduces the measured part of docs/results/rouwe-matrix.md: Rouwé's tables (every
# layout x codec, the splitter, leaf-size and node-order tables, Embree in the same run)
# on the Stanford bunny (when ../shared/data is there) and on a generated 2M-triangle
# game level standing in for the paper's 2.26M-triangle scene.
# Usage: bench/rouwe_matrix.sh [BUILD_DIR] > matrix.md   (about 10 minutes on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
packrt="$build/packrt"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
meshes=()
if [ -f ../shared/data/bunny.ply ]; then meshes+=(../shared/data/bunny.ply); fi
"$packrt" gen level --tris 2M --seed 1 -o "$tmp/level_2M.ply" >&2
meshes+=("$tmp/level_2M.ply")
for m in "${meshes[@]}"; do
  echo "matrix: $m" >&2
  echo "## $(basename "$m")"
  echo
  echo "Command: \`packrt bench $(basename "$m") --matrix\`$([ "$(basename "$m")" = level_2M.ply ] && echo " (mesh: \`packrt gen level --tris 2M --seed 1\`)")"
  echo
  "$packrt" bench "$m" --matrix
  echo
done
