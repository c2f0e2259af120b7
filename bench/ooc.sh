#!/usr/bin/env bash
# Afra 2012's Tables 5 and 6 and Figures 7 and 8 for packrt's out-of-core "ooc" on this
# machine, written to docs/results/ooc.md: Mandelbulbs streamed from the generator into
# block files (Table 6: size, compression, build time and memory), then rendered at
# 1024x768 with 3 pixels of error through a cache of CACHE bytes, frame after frame until
# nothing more is requested, and timed over REPS converged frames (Table 5: primary rays,
# + shadow rays, + two diffuse rays with their shadow rays; working set; time to the first
# image), against model size with and without LOD (Fig. 7) and against pixels of error on
# the largest model (Fig. 8).
# Usage: bench/ooc.sh [SIZES]   (default "10M 100M")
#   BUILD=dir (default build), DATA=dir for the block files (default $TMPDIR; they are
#   kept, and reused when KEEP=1), MEMORY=build budget (default 4G), CACHE (default 1G),
#   REPS=n converged frames (default 5), RESULTS=file (default docs/results/ooc.md; an
#   existing one is kept and the tables go to RESULTS.new unless FORCE=1)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${BUILD:-build}
sizes=${1:-"10M 100M"}
data=${DATA:-${TMPDIR:-/tmp}}
memory=${MEMORY:-4G}
cache=${CACHE:-1G}
reps=${REPS:-5}
results=${RESULTS:-docs/results/ooc.md}
# The results file also holds sections written by hand around the generated tables: a rerun
# writes its tables beside it (FILE.new, to merge by hand) rather than over it, unless FORCE=1.
if [ -e "$results" ] && [ "${FORCE:-0}" != 1 ]; then results="$results.new"; fi
mkdir -p "$data"
if [ ! -x "$build/packrt" ]; then
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$build" -j"$(nproc)" >/dev/null
fi
log=$(mktemp)
# The median frame time after convergence, or the last frame's time marked as not converged
# (the working set outgrew the cache, or --frames ran out first).
median() {
  (grep -o 'median of [0-9]* converged frames [0-9.]* s' "$1" || true) |
    awk '{ if ($3 > 0) print $6; else printf "%s (not converged after %d frames)", $6, n }' n="$(grep -c '^frame' "$1")"
}
trap 'rm -f "$log"' EXIT
t6=() t5=() f7=() f8=()
largest=""
for n in $sizes; do
  f="$data/bulb-$n.ooc"
  if [ "${KEEP:-0}" != 1 ] || [ ! -f "$f" ]; then
    echo "ooc.sh: building $f" >&2
    /usr/bin/time -v "$build/packrt" build --gen "mandelbulb:$n" -r ooc -o "$f" --memory "$memory" >"$log" 2>&1
  else
    "$build/packrt" info "$f" >"$log" 2>&1
  fi
  # From packrt build's report, or packrt info's for a kept file.
  tris=$( (grep -o '[0-9]* triangles' "$log" || grep -o 'triangles *[0-9]*' "$log" || true) | head -1 | tr -dc '0-9')
  built=$( (grep -o 'built in [0-9.]* s' "$log" || grep -o 'build [0-9.]* s' "$log" || true) | head -1 | grep -o '[0-9.]*' | head -1)
  bpt=$( (grep -o '[0-9.]* B/tri *(tree *[0-9.]*, geometry *[0-9.]*' "$log" || true) | head -1 | tr -s ' ')
  file=$( (grep -o 'block file [0-9.]* MB ([0-9]*% of [0-9.]* MB raw)' "$log" || true) | head -1)
  rss=$(awk '/Maximum resident/ {printf "%.0f", $6 / 1024}' "$log")
  peak="(kept file)"
  if [ -n "$rss" ]; then peak="$rss MB"; fi
  t6+=("| $n (${tris:-?}) | ${file:-?} | ${bpt:-?}) | ${built:-?} s | $peak |")
  # Table 5: the three ray mixes at 3 pixels of error.
  row="| $n"
  for mode in "diffuse 1" "shadows 1" "gi 2"; do
    set -- $mode
    "$build/packrt" render "$f" -o "$data/bulb-$n-$1.png" --lod 3 --shade "$1" --spp "$2" --size 1024x768 \
      --cache "$cache" --repeat "$reps" --frames 400 >"$log" 2>&1 || true
    med=$(median "$log")
    first=$( (grep -o 'first image [0-9.]* s' "$log" || true) | awk '{print $3}')
    conv=$( (grep -o 'converged after [0-9.]* s' "$log" || true) | awk '{print $3}')
    ws=$( (grep '^frame' "$log" || true) | tail -1 | (grep -o 'working set [0-9.]* MB' || true) | awk '{print $3}')
    case "$med" in
      *not*) fps="last frame $med" ;;
      *) fps="$(awk -v t="$med" 'BEGIN { printf "%.1f", 1 / t }') fps" ;;
    esac
    row+=" | $fps, $ws MB (first image $first s, converged $conv s)"
    if [ "$1" = diffuse ]; then pfps=$fps pws=$ws; fi
  done
  t5+=("$row |")
  # Fig. 7: primary rays with 3 pixels of error and at full detail (0.01 pixels: no voxel
  # is ever small enough to stop a ray before its triangles).
  "$build/packrt" render "$f" -o "$data/bulb-$n-full.png" --lod 0.01 --size 1024x768 --cache "$cache" \
    --repeat "$reps" --frames "${FULL_FRAMES:-60}" >"$log" 2>&1 || true
  full=$(median "$log")
  wsf=$( (grep '^frame' "$log" || true) | tail -1 | (grep -o 'working set [0-9.]* MB' || true) | awk '{print $3}')
  f7+=("| $n | $pfps, $pws MB | ${full:-?} s, $wsf MB |")
  largest=$f
done
# Fig. 8: the largest model against pixels of error.
for p in 0.5 1 2 3 5 10 20; do
  "$build/packrt" render "$largest" -o "$data/bulb-poe-$p.png" --lod "$p" --size 1024x768 --cache "$cache" \
    --repeat "$reps" --frames "${PoE_FRAMES:-120}" >"$log" 2>&1 || true
  med=$(median "$log")
  ws=$( (grep '^frame' "$log" || true) | tail -1 | (grep -o 'working set [0-9.]* MB' || true) | awk '{print $3}')
  f8+=("| $p | $med s | $ws MB |")
done

cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')
{
  echo "# Out-of-core kd-tree with LOD voxels: measurements"
  echo
  echo "\`bench/ooc.sh \"$sizes\"\` on $cpu, $(nproc) cores, commit $(git rev-parse --short HEAD), load average at"
  echo "the end $(cut -d' ' -f1 /proc/loadavg) (other processes share this machine: times are upper bounds)."
  echo "Mandelbulbs from \`packrt build --gen mandelbulb:N -r ooc --memory $memory\` (streamed: the mesh is never"
  echo "held whole); renders \`packrt render FILE --lod P --size 1024x768 --cache $cache --repeat $reps\` from the"
  echo "default framing, frames repeated with a cache update between them until no block is requested,"
  echo "then the median of $reps converged frames. All threads of this machine render; the fetchers are 4 threads."
  echo
  echo "## Table 6: block files"
  echo
  echo "| Mandelbulb (triangles) | file (LZ4 against raw) | raw bytes per triangle | build | build peak memory |"
  echo "|---|---|---|---:|---:|"
  printf '%s\n' "${t6[@]}"
  echo
  echo "## Table 5: frames per second and working set, 3 pixels of error"
  echo
  echo "| Mandelbulb | primary rays | primary + shadow rays | primary + 2 diffuse rays, each with a shadow ray (gi, spp 2) |"
  echo "|---|---|---|---|"
  printf '%s\n' "${t5[@]}"
  echo
  echo "## Figure 7: primary rays against model size, with and without LOD"
  echo
  echo "| Mandelbulb | 3 pixels of error (fps, working set) | full detail (frame time, working set) |"
  echo "|---|---|---|"
  printf '%s\n' "${f7[@]}"
  echo
  echo "## Figure 8: primary rays against pixels of error ($(basename "$largest"))"
  echo
  echo "| pixels of error | frame time | working set |"
  echo "|---:|---:|---:|"
  printf '%s\n' "${f8[@]}"
} >"$results"
echo "ooc.sh: wrote $results" >&2
