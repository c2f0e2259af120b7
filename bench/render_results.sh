#!/usr/bin/env bash
# Reproduces docs/results/render.md: frame times of `packrt render` at 1024x768 for every
# shading mode, on one and on all threads, for every representation on the bunny (when
# ../shared/data is there) and for two representations on a generated 10M-triangle mesh,
# each table led by Embree tracing the same frames (`-r embree`, when the build has it).
# Each representation is built once (.prt) and rendered with --mesh for exact normals.
# Usage: bench/render_results.sh [BUILD_DIR] > docs/results/render.md
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
packrt="$build/packrt"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
size=1024x768
threads_all=$(nproc)
modes=(normal diffuse shadows ao gi)
# "embree" when this build can render through Embree, else nothing.
embree=
if "$packrt" gen sphere --tris 2k -o "$tmp/probe.ply" >/dev/null 2>&1 &&
  "$packrt" render "$tmp/probe.ply" -r embree -o "$tmp/probe.ppm" --size 8x8 >/dev/null 2>&1; then
  embree=embree
fi

# One table: rows = representation x threads, columns = modes, cells = fps (ms per frame).
table() { # table MESH SPEC...
  local mesh=$1; shift
  printf '| representation | threads |'; for m in "${modes[@]}"; do printf ' %s |' "$m"; done; echo
  printf '|---|---:|'; for _ in "${modes[@]}"; do printf -- '---:|'; done; echo
  for spec in "$@"; do
    # Embree renders from the mesh (it has no .prt form); the rest from their .prt files.
    if [ "$spec" = embree ]; then
      input=("$mesh" -r embree)
    else
      if ! "$packrt" build "$mesh" -r "$spec" -o "$tmp/a.prt" >&2; then
        printf '| `%s` | | build failed (see the log) |\n' "$spec"
        continue
      fi
      input=("$tmp/a.prt" --mesh "$mesh")
    fi
    for t in 1 "$threads_all"; do
      printf '| `%s` | %s |' "$spec" "$t"
      for m in "${modes[@]}"; do
        # Median of 3 for the one-ray modes; sampled modes take long enough for one.
        reps=3; case $m in ao|gi) reps=1 ;; esac
        if ! line=$("$packrt" render "${input[@]}" -o "$tmp/img.png" --size $size --shade "$m" \
          --threads "$t" --repeat $reps); then
          printf ' failed |'
          continue
        fi
        s=$(sed -E 's/.*: ([0-9.]+) s, ([0-9.]+) Mrays.*/\1/' <<<"$line")
        mr=$(sed -E 's/.*: ([0-9.]+) s, ([0-9.]+) Mrays.*/\2/' <<<"$line")
        awk -v s="$s" -v mr="$mr" 'BEGIN { printf " %.2f fps (%.0f ms, %s Mrays/s) |", 1 / s, 1000 * s, mr }'
        echo "render: $spec $t $m $line" >&2
      done
      echo
    done
  done
}

echo "# Renderer frame times"
echo
echo "\`bench/render_results.sh\` on $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores,"
echo "commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown), load average at the start $(cut -d' ' -f1 /proc/loadavg)"
echo "(other processes share this machine: the figures are upper bounds on frame time)."
echo "Each cell: \`packrt render FILE.prt --mesh MESH --size $size --shade MODE --threads T\`,"
echo "median of 3 renders for normal, diffuse and shadows, one render for ao and gi (16 samples"
echo "per pixel, gi without the filter). Rays per pixel: normal and diffuse 1, shadows 1 + lit"
echo "hits, ao 2 x 16, gi up to 4 x 16."
if [ "$embree" = embree ]; then
  echo "The \`embree\` rows render the same frames through Embree 3 (\`packrt render MESH -r embree\`:"
  echo "Embree behind the prt_accel interface, bench/embree_accel.c): the same camera rays as 8x8"
  echo "coherent packets (rtcIntersect1M, as \`packrt bench\`'s primary workload) and the same"
  echo "shadow, occlusion and bounce rays one by one (rtcIntersect1, rtcOccluded1), shaded by the"
  echo "same code, so the difference between rows is the ray tracing alone."
else
  echo "This build has no Embree, so the tables have no Embree row."
fi
echo
if [ -f ../shared/data/bunny.ply ]; then
  echo "## Stanford bunny (69,451 triangles), every representation"
  echo
  mapfile -t specs < <("$packrt" list | cut -d' ' -f1)
  table ../shared/data/bunny.ply $embree "${specs[@]}"
  echo
fi
"$packrt" gen mandelbulb --tris 10M --seed 1 -o "$tmp/mandelbulb_10M.ply" >&2
# The face count from the header (every face a triangle): `packrt info` would build every
# representation of the 10M mesh.
tris=$(head -c 4096 "$tmp/mandelbulb_10M.ply" | grep -a -m1 '^element face' | awk '{print $3}')
echo "## Mandelbulb, $tris triangles (\`packrt gen mandelbulb --tris 10M --seed 1\`)"
echo
table "$tmp/mandelbulb_10M.ply" $embree aabb:float3 quad:float3-soa4 wide8:float3-soa8
echo
echo "Load average at the end: $(cut -d' ' -f1 /proc/loadavg). With more runnable processes than"
echo "cores, the all-threads rows can gain nothing over one thread."
