#!/usr/bin/env bash
# packrt-mpi against the threaded renderer on the same frames: for each view of
# bench/ooc_views.sh given, alternating ROUNDS times: packrt render with 2 threads, 1 rank of
# 2 threads, 2 ranks of 1 thread (static and dynamic super-tiles) and 1 rank of 1 thread; each
# converges (--lod 3) and then times REPS converged frames (median). Prints one line a run and
# the median a configuration; the images must be identical (cmp), else it stops.
# Usage: bench/mpi_ranks.sh FILE.ooc [VIEW...]   BUILD (default build) SIZE (512x384)
#   SHADE (gi: spp 2) REPS (5) ROUNDS (3). Views: default mid top bulb (default: mid bulb).
set -euo pipefail
cd "$(dirname "$0")/.."
file=$1; shift
[ $# -gt 0 ] && views=("$@") || views=(mid bulb)
build=${BUILD:-build} size=${SIZE:-512x384} shade=${SHADE:-gi} reps=${REPS:-5} rounds=${ROUNDS:-3}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_pml=ob1 OMPI_MCA_btl=self,vader OMPI_MCA_mtl=^ofi
declare -A cam=([default]="" [mid]="--camera 0.63,0.54,1.8,0,0,0,40" [top]="--camera 0.9,0.9,1.3,0,0.1,0,40"
  [bulb]="--camera 0.45,0.2,1.05,0.2,0.1,0.6,50")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
configs=(threads2 rank1x2 ranks2x1 ranks2x1dyn rank1x1)
run() { # run CONFIG VIEW -> prints the median converged frame time
  local c=$1 v=$2 common
  # shellcheck disable=SC2206 # the camera option is two words or none
  common=("$file" -o "$tmp/$c-$v.png" --lod 3 --size "$size" --cache 1G --frames 400 --shade "$shade" --spp 2
    --repeat "$reps" ${cam[$v]})
  case $c in
    threads2) "$build/packrt" render "${common[@]}" --threads 2 | grep -o 'median of [0-9]* converged frames [0-9.]*' | awk '{print $6}' ;;
    rank1x2) mpirun -np 1 --bind-to none "$build/packrt-mpi" "${common[@]}" --threads 2 | grep -o ': [0-9.]* s, [0-9.]* Mrays' | awk '{print $2}' ;;
    ranks2x1) mpirun -np 2 --bind-to none "$build/packrt-mpi" "${common[@]}" --threads 1 | grep -o ': [0-9.]* s, [0-9.]* Mrays' | awk '{print $2}' ;;
    ranks2x1dyn) mpirun -np 2 --bind-to none "$build/packrt-mpi" "${common[@]}" --threads 1 --balance dynamic | grep -o ': [0-9.]* s, [0-9.]* Mrays' | awk '{print $2}' ;;
    rank1x1) mpirun -np 1 --bind-to none "$build/packrt-mpi" "${common[@]}" --threads 1 | grep -o ': [0-9.]* s, [0-9.]* Mrays' | awk '{print $2}' ;;
  esac
}
declare -A all=()
for ((r = 1; r <= rounds; r++)); do
  for v in "${views[@]}"; do
    for c in "${configs[@]}"; do
      t=$(run "$c" "$v")
      all[$c-$v]="${all[$c-$v]:-} $t"
      echo "round $r $v $c: $t s ($(uptime | sed 's/.*load average: //'))"
      cmp -s "$tmp/threads2-$v.png" "$tmp/$c-$v.png" || { echo "mpi_ranks.sh: $c $v: image differs" >&2; exit 1; }
    done
  done
done
med() { tr ' ' '\n' | grep . | sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}'; }
for v in "${views[@]}"; do
  base=$(echo "${all[threads2-$v]}" | med)
  for c in "${configs[@]}"; do
    m=$(echo "${all[$c-$v]}" | med)
    printf '%-5s %-12s median %.3f s (%s), frame rate %.2fx packrt render --threads 2\n' "$v" "$c" "$m" "${all[$c-$v]# }" \
      "$(awk -v a="$base" -v b="$m" 'BEGIN { print a / b }')"
  done
done
