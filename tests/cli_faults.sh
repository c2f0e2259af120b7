#!/usr/bin/env bash
# The CLI after faults (issue 31): an interrupted or cut block file is named as such by
# `packrt info`, `cast` and `render`; a full disk (a file size limit) ends `build`, `gen` and
# `render` with exit status 1 and a message naming the file, leaving the previous file.
# Usage: cli_faults.sh PACKRT SOURCE_DIR
set -u
packrt=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail=0 pass=0
check() { # check NAME EXPECTED_EXIT GREP_IN_STDERR COMMAND...
  local name=$1 want=$2 msg=$3; shift 3
  "$@" >"$dir/out" 2>"$dir/err"; local got=$?
  if [ "$got" -eq "$want" ] && { [ -z "$msg" ] || grep -q "$msg" "$dir/err"; }; then pass=$((pass + 1)); echo "ok   $name"
  else fail=$((fail + 1)); echo "FAIL $name: exit $got, wanted $want and '$msg' in:"; cat "$dir/err"; fi
}
same() { # same NAME FILE1 FILE2
  if cmp -s "$2" "$3"; then pass=$((pass + 1)); echo "ok   $1"; else fail=$((fail + 1)); echo "FAIL $1: $2 changed"; fi
}
none_left() { # none_left NAME: no temporary beside the outputs
  if ls "$dir" | grep -q '\.tmp\.'; then fail=$((fail + 1)); echo "FAIL $1: left $(ls "$dir" | grep '\.tmp\.')"
  else pass=$((pass + 1)); echo "ok   $1"; fi
}

check build_ooc 0 "" "$packrt" build --gen mandelbulb:40k -r ooc -o "$dir/k.ooc"
size=$(stat -c %s "$dir/k.ooc")
head -c $((size / 2)) "$dir/k.ooc" >"$dir/cut.ooc"
{ head -c 256 /dev/zero; tail -c +257 "$dir/k.ooc" | head -c $((size / 2)); } >"$dir/unfinished.ooc"
printf 'PRTRAYS1\1\0\0\0\0\0\0\0' >"$dir/one.rays"; head -c 32 /dev/zero >>"$dir/one.rays"
for f in cut unfinished; do
  check "info_$f" 1 "incomplete packrt block file" "$packrt" info "$dir/$f.ooc"
  check "cast_$f" 1 "incomplete packrt block file" "$packrt" cast "$dir/$f.ooc" --rays "$dir/one.rays" -o "$dir/h.hits"
  check "render_$f" 1 "incomplete packrt block file" "$packrt" render "$dir/$f.ooc" -o "$dir/r.png" --size 32x32
done

# A 32 KB file size limit; SIGXFSZ ignored, so writes fail with EFBIG.
cp "$dir/k.ooc" "$dir/prev.ooc"
check full_build_ooc 1 "k.ooc: write failed" bash -c "ulimit -f 32; trap '' XFSZ; exec '$packrt' build --gen mandelbulb:100k -r ooc -o '$dir/k.ooc'"
same full_build_ooc_keeps_previous "$dir/k.ooc" "$dir/prev.ooc"
check build_prt 0 "" "$packrt" build --gen sphere:2k -r aabb:float3 -o "$dir/s.prt"
cp "$dir/s.prt" "$dir/prev.prt"
check full_build_prt 1 "s.prt: write failed" bash -c "ulimit -f 32; trap '' XFSZ; exec '$packrt' build --gen sphere:100k -r aabb:float3 -o '$dir/s.prt'"
same full_build_prt_keeps_previous "$dir/s.prt" "$dir/prev.prt"
check full_gen 1 "m.ply" bash -c "ulimit -f 32; trap '' XFSZ; exec '$packrt' gen sphere --tris 100k -o '$dir/m.ply'"
check full_render 1 "r.ppm" bash -c "ulimit -f 32; trap '' XFSZ; exec '$packrt' render '$dir/s.prt' -o '$dir/r.ppm' --size 256x256"
none_left no_temporaries_left
[ -e "$dir/m.ply" ] && { fail=$((fail + 1)); echo "FAIL full_gen left a partial m.ply"; }

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
