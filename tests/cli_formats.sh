#!/usr/bin/env bash
# The CLI on the mesh formats of issue 33: gen writes STL and OFF, info reads them (and
# says how many STL corners were welded), build accepts them, and a bad STL is refused
# naming the file. Usage: cli_formats.sh PACKRT SOURCE_DIR
set -u
packrt=$1 src=$2
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail=0 pass=0
check() { # check NAME EXPECTED_EXIT COMMAND...
  local name=$1 want=$2; shift 2
  "$@" >"$dir/out" 2>"$dir/err"; local got=$?
  if [ "$got" -eq "$want" ]; then pass=$((pass + 1)); echo "ok   $name"
  else fail=$((fail + 1)); echo "FAIL $name: exit $got, wanted $want"; cat "$dir/err"; fi
}
expect() { # expect NAME FILE PATTERN
  if grep -q -- "$3" "$2"; then pass=$((pass + 1)); echo "ok   $1"
  else fail=$((fail + 1)); echo "FAIL $1: no '$3' in"; cat "$2"; fi
}

check gen_stl 0 "$packrt" gen sphere --tris 2k -o "$dir/s.stl"
check gen_off 0 "$packrt" gen sphere --tris 2k -o "$dir/s.off"
check gen_mandelbulb_stl 0 "$packrt" gen mandelbulb --tris 5k -o "$dir/m.stl"
check info_stl 0 "$packrt" info "$dir/s.stl" -r aabb:idx32
# 2,028 triangles (the k=13 cube sphere, 12 k^2): 6084 corners; a closed genus-0 mesh has
# T/2 + 2 = 1016 vertices (Euler), so 5068 corners merge.
expect info_stl_welds "$dir/out" "welded       6084 corners into 1016 vertices (5068 merged)"
expect info_stl_closed "$dir/out" "closed"
check info_off 0 "$packrt" info "$dir/s.off" -r aabb:idx32
expect info_off_format "$dir/out" "format       OFF"
check info_glb 0 "$packrt" info "$src/tests/data/good/quad.glb" -r aabb:idx32
check build_stl 0 "$packrt" build "$dir/s.stl" -r aabb:idx32 -o "$dir/s.prt"
check build_ooc_off 0 "$packrt" build "$dir/s.off" -r ooc -o "$dir/o.prt"
check info_bad_stl 1 "$packrt" info "$src/tests/data/bad/stl_lying_count_binary.stl"
expect bad_stl_message "$dir/err" "stl_lying_count_binary.stl: the header announces 5 triangles"

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
