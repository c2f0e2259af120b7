#!/usr/bin/env bash
# The main job: install what is missing, build packrt (Release), and benchmark every
# representation against Embree on a mesh. Without an argument the mesh is generated
# (`packrt gen`), so nothing outside the repository is needed.
# Usage: scripts/demo.sh [MESH] [extra packrt bench options]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)" --target packrt >/dev/null
exec build/packrt bench "$@"
