#!/usr/bin/env bash
# packrt-mpi (tools/mpi/) as users call it, on 3 ranks of an Open MPI job: the image of every
# shading mode tried (normal, ao, gi with its filter), static and dynamic tiles, equals
# `packrt render`'s byte for byte; an out-of-core file with levels of detail converges to the 1-rank image; a rank that
# cannot open the file, or is killed, ends the job (never a hang).
# Usage: cli_mpi.sh PACKRT SOURCE_DIR. Skipped (77) when packrt-mpi was not built (no MPI) or
# mpirun is missing.
set -u
packrt=$1
mpi=$(dirname "$packrt")/packrt-mpi
[ -x "$mpi" ] || { echo "skip: packrt-mpi not built (no MPI found at configure time)"; exit 77; }
command -v mpirun >/dev/null || { echo "skip: no mpirun (Debian openmpi-bin)"; exit 77; }
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
# As root (CI containers) Open MPI wants both variables.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# Open MPI keeps allocations to exit, which LeakSanitizer reports in a sanitized build;
# tests/lsan_mpi.supp names its libraries. For the stacks to reach them, its plugins stay
# loaded (else their frames are "<unknown module>") and LSan unwinds without frame pointers.
export OMPI_MCA_mca_base_component_disable_dlclose=1 PMIX_MCA_mca_base_component_disable_dlclose=1
export LSAN_OPTIONS="${LSAN_OPTIONS:+$LSAN_OPTIONS:}suppressions=$2/tests/lsan_mpi.supp:print_suppressions=0:fast_unwind_on_malloc=0"
# Ranks share 2 cores here (--oversubscribe), each with one thread; shared memory only, no
# probing for network hardware (the job takes 1-2 s to start, most of this test's time, so
# it starts few: each shading mode once, alternately with static and dynamic tiles).
export OMPI_MCA_pml=ob1 OMPI_MCA_btl=self,vader OMPI_MCA_mtl=^ofi
run3() { timeout 120 mpirun --oversubscribe -np 3 "$@"; }
# shellcheck source=support/cli_check.sh
. "$2/tests/support/cli_check.sh"

check gen 0 "$packrt" gen sphere --tris 3k -o "$dir/s.ply"
# 61x45: tiles cut at both edges; super-tiles of 3 tiles: every rank renders several.
opts=(--size 61x45 --spp 2)
# Two modes through the job (the gather is the same for every mode that writes 3 bytes a
# pixel; gi's float buffers come next), one with static and one with dynamic tiles: each job
# start costs 1-2.5 s, several times that under the sanitizers.
for mb in normal:static ao:dynamic; do
  mode=${mb%%:*} bal=${mb#*:}
  check "render_$mode" 0 "$packrt" render "$dir/s.ply" -o "$dir/r-$mode.ppm" --shade "$mode" "${opts[@]}"
  check "mpi3_${mode}_$bal" 0 run3 "$mpi" "$dir/s.ply" -o "$dir/m3-$mode.ppm" --shade "$mode" "${opts[@]}" \
    --threads 1 --balance $bal --super-tile 3
  expect "mpi3_${mode}_${bal}_equals_render" cmp -s "$dir/r-$mode.ppm" "$dir/m3-$mode.ppm"
done
# gi's filter runs on rank 0 after the float buffers are gathered.
check render_denoise 0 "$packrt" render "$dir/s.ply" -o "$dir/r-dn.ppm" --shade gi --denoise "${opts[@]}"
check mpi3_denoise 0 run3 "$mpi" "$dir/s.ply" -o "$dir/m3-dn.ppm" --shade gi --denoise "${opts[@]}" --threads 1 \
  --balance dynamic --super-tile 2
expect mpi3_denoise_equals_render cmp -s "$dir/r-dn.ppm" "$dir/m3-dn.ppm"
grep -q "gathered" "$dir/out" && { pass=$((pass + 1)); echo "ok   reports_bytes_gathered"; } \
  || { fail=$((fail + 1)); echo "FAIL reports_bytes_gathered"; cat "$dir/out"; }

# Levels of detail on an out-of-core file: each rank loads its own blocks between frames
# until no rank asks for one; the converged image is the 1-rank one.
check build_ooc 0 "$packrt" build --gen mandelbulb:40k -r ooc -o "$dir/k.ooc"
lod=(--lod 2 --size 48x40 --shade shadows --cache 64M)
check render_lod 0 "$packrt" render "$dir/k.ooc" -o "$dir/r-lod.ppm" "${lod[@]}"
check mpi3_lod 0 run3 "$mpi" "$dir/k.ooc" -o "$dir/m3-lod.ppm" "${lod[@]}" --threads 1
expect mpi3_lod_equals_render cmp -s "$dir/r-lod.ppm" "$dir/m3-lod.ppm"
grep -q "requested 0, loading 0" "$dir/out" && { pass=$((pass + 1)); echo "ok   lod_converged"; } \
  || { fail=$((fail + 1)); echo "FAIL lod_converged"; cat "$dir/out"; }

# Failures end the job with a message, never a hang (run3 gives up after 120 s: exit 124).
# Rank 1 alone cannot see the file (storage not shared with its node): rank 0 says so.
check missing_on_rank_1 1 run3 sh -c 'f=$1; [ "$OMPI_COMM_WORLD_RANK" = 1 ] && f=$2; exec "$0" "$f" -o "$3"' \
  "$mpi" "$dir/s.ply" "$dir/none.ply" "$dir/x.ppm"
grep -q "rank 1 of 3 failed to open" "$dir/err" && ! grep -q "rank [02] of 3 failed" "$dir/err" \
  && { pass=$((pass + 1)); echo "ok   missing_on_rank_1_named"; } \
  || { fail=$((fail + 1)); echo "FAIL missing_on_rank_1_named"; cat "$dir/err"; }
# Rank 1 killed before it starts: mpirun ends the others (exit 137: the signal's).
run3 sh -c '[ "$OMPI_COMM_WORLD_RANK" = 1 ] && kill -9 $$; exec "$0" "$1" -o "$2"' "$mpi" "$dir/s.ply" "$dir/x.ppm" \
  >"$dir/out" 2>&1; got=$?
[ "$got" -ne 0 ] && [ "$got" -ne 124 ] && { pass=$((pass + 1)); echo "ok   killed_rank_ends_job (exit $got)"; } \
  || { fail=$((fail + 1)); echo "FAIL killed_rank_ends_job: exit $got"; cat "$dir/out"; }
check bad_balance 2 timeout 60 mpirun -np 1 "$mpi" "$dir/s.ply" -o "$dir/x.ppm" --balance round

finish
