#!/usr/bin/env bash
# The CLI as scripts outside the project call it: gen -> build -> cast -> info -> list,
# plus the exit codes of mistakes. Usage: cli_smoke.sh PACKRT SOURCE_DIR
set -u
packrt=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail=0 pass=0
check() { # check NAME EXPECTED_EXIT COMMAND...
  local name=$1 want=$2; shift 2
  "$@" >"$dir/out" 2>"$dir/err"; local got=$?
  if [ "$got" -eq "$want" ]; then pass=$((pass + 1)); echo "ok   $name"
  else fail=$((fail + 1)); echo "FAIL $name: exit $got, wanted $want"; cat "$dir/err"; fi
}

check gen_sphere 0 "$packrt" gen sphere --tris 20k -o "$dir/s.ply"
check build_quad 0 "$packrt" build "$dir/s.ply" -r quad:float3-soa4 -o "$dir/s.prt"
check info_prt 0 "$packrt" info "$dir/s.prt"
grep -q "quad:float3-soa4" "$dir/out" || { fail=$((fail + 1)); echo "FAIL info_prt names the representation"; }
check info_mesh 0 "$packrt" info "$dir/s.ply"
grep -q "closed" "$dir/out" || { fail=$((fail + 1)); echo "FAIL info_mesh sees the sphere closed"; }
check list 0 "$packrt" list
[ "$(cut -d' ' -f1 "$dir/out" | grep -c ':')" -ge 2 ] || { fail=$((fail + 1)); echo "FAIL list prints names"; }

# Rays from the centre outwards: every one must hit the closed sphere.
python3 - "$dir/in.rays" <<'PY' || { echo "FAIL python3 needed for the ray file"; exit 1; }
import math, struct, sys
n = 1000
with open(sys.argv[1], "wb") as f:
    f.write(b"PRTRAYS1" + struct.pack("<Q", n))
    for i in range(n):
        z = 1 - 2 * (i + 0.5) / n; r = math.sqrt(1 - z * z); a = i * 2.399963
        f.write(struct.pack("<8f", 0, 0, 0, 0, r * math.cos(a), r * math.sin(a), z, math.inf))
PY
check cast_prt 0 "$packrt" cast "$dir/s.prt" --rays "$dir/in.rays" -o "$dir/out.hits"
check cast_mesh 0 "$packrt" cast "$dir/s.ply" -r aabb:float3 --rays "$dir/in.rays" -o "$dir/mesh.hits"
check cast_occluded 0 "$packrt" cast "$dir/s.prt" --rays "$dir/in.rays" -o "$dir/occ.hits" --occluded
python3 - "$dir/out.hits" "$dir/mesh.hits" "$dir/occ.hits" <<'PY'
import struct, sys
def hits(p):
    d = open(p, "rb").read(); assert d[:8] == b"PRTHITS1"; n, = struct.unpack("<Q", d[8:16])
    return [struct.unpack("<fIff", d[16 + 16 * i: 32 + 16 * i]) for i in range(n)]
a, b, o = hits(sys.argv[1]), hits(sys.argv[2]), hits(sys.argv[3])
assert len(a) == 1000 and all(h[1] != 0xFFFFFFFF and 0.98 < h[0] < 1.001 for h in a), "every ray hits at t ~ 1"
assert all(abs(x[0] - y[0]) < 1e-5 for x, y in zip(a, b)), "both representations agree on t"
assert all(h[0] == 0 and h[1] == 0 for h in o), "occluded records are t=0, prim=0"
PY
if [ $? -eq 0 ]; then pass=$((pass + 1)); echo "ok   cast_results"; else fail=$((fail + 1)); echo "FAIL cast_results"; fi

check bench_json 0 "$packrt" bench "$dir/s.ply" -r quad:float3-soa4 --rays 2000 --reps 1 --size 32x32 --json
python3 -c "import json,sys; d=json.load(open('$dir/out')); r=d['results'][0]; assert r['name'].startswith('quad') and r['bytes_per_tri_total'] > 0" \
  && { pass=$((pass + 1)); echo "ok   bench_json_fields"; } || { fail=$((fail + 1)); echo "FAIL bench_json_fields"; }

# Rounds and the trade-off plot: two rows in two rounds, both drawn, the front joined.
check bench_plot 0 "$packrt" bench "$dir/s.ply" -r quad:float3-soa4 -r wide8:idx8-soa4 --rays 1000 --reps 1 \
  --rounds 2 --workload random --no-cold --vs none --plot "$dir/t.svg" --json
python3 -c "import json; d=json.load(open('$dir/out')); assert d['rounds'] == 2 and all('spread' in r for r in d['results'])" \
  && { pass=$((pass + 1)); echo "ok   bench_rounds_json"; } || { fail=$((fail + 1)); echo "FAIL bench_rounds_json"; }
grep -q "<polyline" "$dir/t.svg" && grep -q "wide8:idx8-soa4" "$dir/t.svg" && grep -q "</svg>" "$dir/t.svg" \
  && { pass=$((pass + 1)); echo "ok   bench_plot_svg"; } || { fail=$((fail + 1)); echo "FAIL bench_plot_svg"; }
check bench_plot_not_svg 2 "$packrt" bench "$dir/s.ply" --plot "$dir/t.png"
check bench_plot_unwritable 1 "$packrt" bench "$dir/s.ply" -r aabb:float3 --rays 200 --reps 1 --rounds 1 \
  --workload random --no-cold --vs none --plot "$dir/no/such/dir/t.svg"

# auto within a budget: the chosen spec is printed and fits; an impossible budget says the smallest.
check build_auto 0 "$packrt" build "$dir/s.ply" -r auto,budget=30 -o "$dir/auto.prt"
python3 - "$dir/err" <<'PY' && { pass=$((pass + 1)); echo "ok   build_auto_fits"; } || { fail=$((fail + 1)); echo "FAIL build_auto_fits"; cat "$dir/err"; }
import re, sys
line = open(sys.argv[1]).read()
m = re.search(r": (\S+), .* ([0-9.]+) B/tri", line)
assert m and not m.group(1).startswith("auto") and float(m.group(2)) <= 30, line
PY
check info_estimate 0 "$packrt" info "$dir/s.ply" --budget 30 --verify
grep -q "would build" "$dir/out" && grep -q "estimate" "$dir/out" \
  && { pass=$((pass + 1)); echo "ok   info_estimate_says_choice"; } || { fail=$((fail + 1)); echo "FAIL info_estimate_says_choice"; }
# Several budgets in one call: one choice line each, the impossible one says so (exit 1).
check info_budgets 1 "$packrt" info "$dir/s.ply" --budget 2,30,none
[ "$(grep -c "would build" "$dir/out")" = 2 ] && grep -q "auto,budget=2: .*nothing fits" "$dir/out" \
  && { pass=$((pass + 1)); echo "ok   info_budgets_one_line_each"; } || { fail=$((fail + 1)); echo "FAIL info_budgets_one_line_each"; }
check info_budgets_bad 2 "$packrt" info "$dir/s.ply" --budget 30,,8
check build_auto_too_small 1 "$packrt" build "$dir/s.ply" -r auto,budget=2 -o "$dir/auto2.prt"
grep -q "smallest" "$dir/err" || { fail=$((fail + 1)); echo "FAIL build_auto_too_small names the smallest"; }
check build_auto_bad 1 "$packrt" build "$dir/s.ply" -r auto,budget=lots -o "$dir/auto3.prt"

# --calibrate writes a row per spec, mesh kind and size: another size adds rows, the same
# size replaces them (needs Embree, which it measures against).
"$packrt" gen sphere --tris 2k -o "$dir/s2k.ply" >/dev/null 2>&1
calibrate() { "$packrt" bench "$1" -r wide8:idx8-soa4 --calibrate --costs "$dir/c.tsv" --rays 256 --rounds 1 \
  --no-cold --workload random --threads 1 >"$dir/out" 2>"$dir/err"; }
if calibrate "$dir/s.ply" && calibrate "$dir/s2k.ply" && calibrate "$dir/s.ply"; then
  python3 - "$dir/c.tsv" <<'PY' && { pass=$((pass + 1)); echo "ok   calibrate_rows_by_size"; } || { fail=$((fail + 1)); echo "FAIL calibrate_rows_by_size"; cat "$dir/c.tsv"; }
import sys
rows = [l.split("\t") for l in open(sys.argv[1]) if l.strip() and not l.startswith("#")]
sizes = sorted(int(r[2]) for r in rows if r[0] == "wide8:idx8-soa4" and r[1] == "shared")
assert len(sizes) == 2 and sizes[0] < 4000 and 15000 < sizes[1] < 25000, sizes
assert all(len(r) == 8 and float(r[4]) > 0 for r in rows), rows
PY
elif grep -q "has none" "$dir/err"; then echo "skip calibrate_rows_by_size: no Embree"
else fail=$((fail + 1)); echo "FAIL calibrate"; cat "$dir/err"; fi

# Mistakes: usage errors exit 2, failures exit 1 with a message, never a crash.
check no_command 2 "$packrt"
check unknown_command 2 "$packrt" frobnicate
# ids=none: the triangle order goes to --order, a permutation of the mesh's triangles.
check build_ids_none_needs_order 1 "$packrt" build "$dir/s.ply" -r wide8:idx8-soa4,ids=none -o "$dir/n.prt"
grep -q -- "--order" "$dir/err" || { fail=$((fail + 1)); echo "FAIL build_ids_none_needs_order names --order"; }
check build_ids_none_order 0 "$packrt" build "$dir/s.ply" -r wide8:idx8-soa4,ids=none -o "$dir/n.prt" --order "$dir/n.order"
python3 - "$dir/n.order" "$dir/s.ply" <<'PY' || { fail=$((fail + 1)); echo "FAIL build_ids_none_order writes a permutation"; }
import re, struct, sys
order = open(sys.argv[1], "rb").read()
faces = int(re.search(rb"element face (\d+)", open(sys.argv[2], "rb").read(4096)).group(1))
ids = struct.unpack("<%dI" % (len(order) // 4), order)
sys.exit(0 if len(order) == 4 * faces and sorted(ids) == list(range(faces)) else 1)
PY
check build_order_without_ids_none 2 "$packrt" build "$dir/s.ply" -r quad:float3 -o "$dir/q.prt" --order "$dir/q.order"
check build_missing_args 2 "$packrt" build "$dir/s.ply"
check build_bad_spec 1 "$packrt" build "$dir/s.ply" -r nosuch:thing -o "$dir/x.prt"
check cast_missing_rays 1 "$packrt" cast "$dir/s.prt" --rays "$dir/nonexistent.rays" -o "$dir/x.hits"
check info_missing_file 1 "$packrt" info "$dir/nonexistent.ply"
head -c 3000 "$dir/s.prt" >"$dir/trunc.prt"
check info_truncated_prt 1 "$packrt" info "$dir/trunc.prt"
check gen_unknown_kind 2 "$packrt" gen teapot -o "$dir/t.ply"

# The mandelbulb streams to disk (or only counts with --dry-run): same mesh either way.
check gen_mandelbulb_streamed 0 "$packrt" gen mandelbulb --tris 20k --memory 1M -o "$dir/b.ply"
written=$(grep -o '[0-9]* triangles' "$dir/out")
check info_streamed_mandelbulb 0 "$packrt" info "$dir/b.ply"
grep -q "closed" "$dir/out" || { fail=$((fail + 1)); echo "FAIL info sees the streamed mandelbulb closed"; }
check gen_mandelbulb_dry_run 0 "$packrt" gen mandelbulb --tris 20k --dry-run
[ -n "$written" ] && grep -q "$written streamed" "$dir/out" || { fail=$((fail + 1)); echo "FAIL dry run counts what gen writes"; }
check gen_dry_run_not_streamed_kind 2 "$packrt" gen sphere --dry-run
check gen_bad_memory 2 "$packrt" gen mandelbulb --memory lots -o "$dir/b.ply"

# Mesh formats of issue 33: gen writes STL and OFF; info reads them and says how many STL
# corners were welded; build accepts them; a bad STL is refused naming the file.
expect() { # expect NAME FILE PATTERN
  if grep -q -- "$3" "$2"; then pass=$((pass + 1)); echo "ok   $1"
  else fail=$((fail + 1)); echo "FAIL $1: no '$3' in"; cat "$2"; fi
}
check gen_stl 0 "$packrt" gen sphere --tris 2k -o "$dir/f.stl"
check gen_off 0 "$packrt" gen sphere --tris 2k -o "$dir/f.off"
check gen_mandelbulb_stl 0 "$packrt" gen mandelbulb --tris 5k -o "$dir/m.stl"
check info_stl 0 "$packrt" info "$dir/f.stl" -r aabb:idx32
# 2,028 triangles (the k=13 cube sphere, 12 k^2): 6084 corners; a closed genus-0 mesh has
# T/2 + 2 = 1016 vertices (Euler), so 5068 corners merge.
expect info_stl_welds "$dir/out" "welded       6084 corners into 1016 vertices (5068 merged)"
expect info_stl_closed "$dir/out" "closed"
check info_off 0 "$packrt" info "$dir/f.off" -r aabb:idx32
expect info_off_format "$dir/out" "format       OFF"
check info_glb 0 "$packrt" info "$2/tests/data/good/quad.glb" -r aabb:idx32
check build_stl 0 "$packrt" build "$dir/f.stl" -r aabb:idx32 -o "$dir/f.prt"
check build_ooc_off 0 "$packrt" build "$dir/f.off" -r ooc -o "$dir/fo.prt"
check info_bad_stl 1 "$packrt" info "$2/tests/data/bad/stl_lying_count_binary.stl"
expect bad_stl_message "$dir/err" "stl_lying_count_binary.stl: the header announces 5 triangles"

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
