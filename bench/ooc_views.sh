#!/usr/bin/env bash
# Afra 2012's Table 5 the way the paper measured it: the average over four representative
# views (its caption), here for one block file at 1024x768 and 3 pixels of error, for each
# of the table's three ray mixes: primary rays (`--shade diffuse`, one ray a pixel),
# primary + shadow rays (`--shade shadows`), and primary + 2 diffuse rays, each with a
# shadow ray (`--shade gi --spp 2`). The views, fixed before any was measured:
#   default  the whole model (prt_camera_default's framing)
#   mid      the same direction from 1.9 units: the model fills and overflows the frame
#   top      close over the top, every pixel on fine detail (the slowest view we know)
#   bulb     into a bulb from close by
# Each view is rendered frame after frame with a cache update between frames until nothing
# more is requested, then timed over REPS converged frames (median). Prints one line a view
# and, per mix, the averages: the paper's (mean of the views' fps) and the time-weighted one
# (frames over total time, what a user flying through all four would see), plus the slowest
# view and the largest working set.
# Usage: bench/ooc_views.sh FILE.ooc   BUILD=dir (default build) CACHE (default 1G)
#   REPS (default 5) ROUNDS=n (default 1: each view n times, alternating views)
#   MODES (default "diffuse": primary rays only; "diffuse shadows gi" gives all of Table 5)
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -eq 1 ] || { echo "usage: bench/ooc_views.sh FILE.ooc" >&2; exit 2; }
file=$1
build=${BUILD:-build}
cache=${CACHE:-1G}
reps=${REPS:-5}
rounds=${ROUNDS:-1}
[ -f "$file" ] || { echo "ooc_views.sh: $file: no such file" >&2; exit 1; }
modes=${MODES:-diffuse}
names=(default mid top bulb)
cams=("" "--camera 0.63,0.54,1.8,0,0,0,40" "--camera 0.9,0.9,1.3,0,0.1,0,40" "--camera 0.45,0.2,1.05,0.2,0.1,0.6,50")
log=$(mktemp)
img=$(mktemp --suffix=.png)
trap 'rm -f "$log" "$img"' EXIT
for mode in $modes; do
  case $mode in
    diffuse) shade=(--shade diffuse) mix="primary rays" ;;
    shadows) shade=(--shade shadows) mix="primary + shadow rays" ;;
    gi) shade=(--shade gi --spp 2) mix="primary + 2 diffuse rays, each with a shadow ray" ;;
    *) echo "ooc_views.sh: MODES: diffuse, shadows or gi, not $mode" >&2; exit 2 ;;
  esac
  declare -A times=() sets=()
  for ((r = 0; r < rounds; r++)); do
    for i in "${!names[@]}"; do
      # shellcheck disable=SC2086 # the camera option is two words or none
      "$build/packrt" render "$file" -o "$img" --lod 3 --size 1024x768 --cache "$cache" --frames 400 \
        --repeat "$reps" "${shade[@]}" ${cams[$i]} >"$log" 2>&1
      t=$(grep -o 'median of [0-9]* converged frames [0-9.]* s' "$log" | awk '{print $6}')
      if [ -z "$t" ]; then
        echo "ooc_views.sh: ${names[$i]} ($mode) did not converge (working set over the cache?):" >&2
        tail -3 "$log" >&2
        exit 1
      fi
      ws=$(grep '^frame' "$log" | tail -1 | grep -o 'working set [0-9.]* MB' | awk '{print $3}')
      times[${names[$i]}]="${times[${names[$i]}]:-} $t"
      sets[${names[$i]}]=$ws
      printf '%-8s %-7s round %d: %s s (%.1f fps), working set %s MB\n' "${names[$i]}" "$mode" $((r + 1)) "$t" \
        "$(awk -v t="$t" 'BEGIN { print 1 / t }')" "$ws"
    done
  done
  # Per view the median over rounds; then the averages.
  for v in "${names[@]}"; do
    # shellcheck disable=SC2086 # one time a word
    m=$(printf '%s\n' ${times[$v]} | sort -g | awk '{ a[NR] = $1 } END { print NR % 2 ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2 }')
    echo "$v $m ${sets[$v]}"
  done | awk -v mode="$mode" -v mix="$mix" '{
      printf "%-8s %-7s median %.3f s  %5.1f fps  working set %s MB\n", $1, mode, $2, 1 / $2, $3
      fps += 1 / $2; tot += $2; k++; if (k == 1 || 1 / $2 < slow) { slow = 1 / $2; sv = $1 }
      if ($3 > wmax) wmax = $3
    } END {
      printf "Table 5, %s (mean of the %d views fps): %.1f fps; time-weighted: %.1f fps; slowest: %s %.1f fps; largest working set %.0f MB\n",
        mix, k, fps / k, k / tot, sv, slow, wmax
    }'
done
