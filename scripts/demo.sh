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
# All 108 representations would take the better part of an hour here; without -r, bench
# the fastest and the smallest BVHs of each kind and the other four families
# (`packrt bench --matrix` or -r all for the rest).
picks=()
case " $* " in
  *" -r "*) ;;
  *) for s in quad:float3-soa4 wide8:float3-soa8 quad-half:float3-soa4 wide8:idx8-soa4 wide8:idx32-soa4 \
              wide8:idx8-bitpack-soa4 aabb-compressed:idx8-bitpack-soa4 aabb:float3 raystrips lossygrid cgrid ooc; do
       picks+=(-r "$s")
     done ;;
esac
build/packrt bench "$@" "${picks[@]}"

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
