#!/usr/bin/env bash
# The main job: install what is missing, build packrt (Release), benchmark representations
# against Embree on a mesh, then render that mesh to out/demo.png. Without
# an argument the mesh is generated (`packrt gen`), so nothing outside the repository is
# needed.
# Usage: scripts/demo.sh [MESH] [extra packrt bench options]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)" --target packrt >/dev/null
# Without -r, bench runs one representation of every family and layout against Embree
# (`-r all` for every name of `packrt list`, `--matrix` for Rouwe's tables); the
# trade-off picture goes to out/tradeoff.svg.
mkdir -p out
build/packrt bench "$@" --plot out/tradeoff.svg

# A picture of what was measured: the same mesh (bench's default is the 1M mandelbulb).
if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then
  mesh=$1
else
  tris=1M prev=""
  for a in "$@"; do [ "$prev" = "--tris" ] && tris=$a; prev=$a; done
  mesh=out/demo-mesh.ply
  build/packrt gen mandelbulb --tris "$tris" -o "$mesh" >/dev/null
fi
build/packrt render "$mesh" -o out/demo.png --shade gi --denoise --size 1024x768
