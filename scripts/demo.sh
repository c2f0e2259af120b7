#!/usr/bin/env bash
# The main job: install what is missing, build packrt (Release), benchmark every
# representation against Embree on a mesh, then render that mesh to out/demo.png. Without
# an argument the mesh is generated (`packrt gen`), so nothing outside the repository is
# needed.
# Usage: scripts/demo.sh [MESH] [extra packrt bench options]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)" --target packrt >/dev/null
build/packrt bench "$@"

# A picture of what was measured: the same mesh (bench's default is the 1M mandelbulb).
mkdir -p out
if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then
  mesh=$1
else
  tris=1M prev=""
  for a in "$@"; do [ "$prev" = "--tris" ] && tris=$a; prev=$a; done
  mesh=out/demo-mesh.ply
  build/packrt gen mandelbulb --tris "$tris" -o "$mesh" >/dev/null
fi
build/packrt render "$mesh" -o out/demo.png --shade gi --denoise --size 1024x768
