#!/usr/bin/env bash
# Reproduces docs/results/render.md: frame times of `packrt render` at 1024x768 for every
# shading mode, on one and on all threads, for every representation on the bunny (when
# ../shared/data is there) and for two representations on a generated 10M-triangle mesh.
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

# One table: rows = representation x threads, columns = modes, cells = fps (ms per frame).
table() { # table MESH SPEC...
  local mesh=$1; shift
  printf '| representation | threads |'; for m in "${modes[@]}"; do printf ' %s |' "$m"; done; echo
  printf '|---|---:|'; for _ in "${modes[@]}"; do printf -- '---:|'; done; echo
  for spec in "$@"; do
    "$packrt" build "$mesh" -r "$spec" -o "$tmp/a.prt" >&2
    for t in 1 "$threads_all"; do
      printf '| `%s` | %s |' "$spec" "$t"
      for m in "${modes[@]}"; do
        # Median of 3 for the one-ray modes; sampled modes take long enough for one.
        reps=3; case $m in ao|gi) reps=1 ;; esac
        line=$("$packrt" render "$tmp/a.prt" --mesh "$mesh" -o "$tmp/img.png" --size $size --shade "$m" \
          --threads "$t" --repeat $reps)
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
echo "hits, ao 2 x 16, gi up to 4 x 16. Embree is not in these tables: the renderer traces"
echo "through prt_accel only; \`packrt bench\` compares the same primary, shadow and diffuse"
echo "rays with Embree (docs/results/)."
echo
if [ -f ../shared/data/bunny.ply ]; then
  echo "## Stanford bunny (69,451 triangles), every representation"
  echo
  mapfile -t specs < <("$packrt" list | cut -d' ' -f1)
  table ../shared/data/bunny.ply "${specs[@]}"
  echo
fi
"$packrt" gen mandelbulb --tris 10M --seed 1 -o "$tmp/mandelbulb_10M.ply" >&2
tris=$("$packrt" info "$tmp/mandelbulb_10M.ply" | awk '/^triangles/ {print $2}')
echo "## Mandelbulb, $tris triangles (\`packrt gen mandelbulb --tris 10M --seed 1\`)"
echo
table "$tmp/mandelbulb_10M.ply" aabb:float3 quad:float3-soa4
echo
echo "Load average at the end: $(cut -d' ' -f1 /proc/loadavg). With more runnable processes than"
echo "cores, the all-threads rows often gain nothing over one thread; where the machine was"
echo "quiet (e.g. \`quad:float3-soa8\` ao and gi) two threads halve the frame time."
