#!/usr/bin/env bash
# packrt animate as users call it: a generated animation rendered to one PNG per frame, a
# frame directory (frames written by packrt gen and moved by hand, same faces), --bench with
# a representation that updates (cgrid) beside one rebuilt every frame (a BVH), --json,
# Embree when this build has it, and the exit codes of mistakes.
# Usage: cli_animate.sh PACKRT SOURCE_DIR
set -u
packrt=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
. "$2/tests/support/cli_check.sh" # check, expect, finish

"$packrt" animate --help | grep -q "prt_accel_update" || { echo "FAIL help"; exit 1; }
check twist_frames 0 "$packrt" animate twist --tris 3k --frames 3 --size 32x24 -o "$dir/tw"
n=$(ls "$dir/tw" | grep -c '^frame_00[0-2]\.p[np][gm]$')
expect three_frame_images [ "$n" -eq 3 ]
check marbles_bench 0 "$packrt" animate marbles --tris 2k --frames 3 --size 32x32 --bench -r cgrid -r aabb:float3 --packet 4
expect bench_prints_medians grep -q "medians over frames 1..2" "$dir/out"
expect bvh_agrees_with_cgrid awk '/^aabb:float3/ && $NF == "100.000" {ok=1} END {exit !ok}' "$dir/out"
check toys_bench 0 "$packrt" animate toys --tris 3k --frames 3 --size 32x32 --bench -r cgrid -r aabb:float3 --packet 8
expect toys_bvh_agrees_with_cgrid awk '/^aabb:float3/ && $NF == "100.000" {ok=1} END {exit !ok}' "$dir/out"
# Frames on disk: two copies of one mesh, the second moved; a third with other faces.
check gen 0 "$packrt" gen sphere --tris 2k -o "$dir/s.ply"
mkdir -p "$dir/seq"
cp "$dir/s.ply" "$dir/seq/a_000.ply"
python3 - "$dir/s.ply" "$dir/seq/a_001.ply" <<'PY'
import struct, sys
d = open(sys.argv[1], "rb").read()
end = d.index(b"end_header\n") + len(b"end_header\n")
head = d[:end].decode()
nv = int(head.split("element vertex ")[1].split()[0])
v = list(struct.unpack("<%df" % (3 * nv), d[end:end + 12 * nv]))
v = [x + 0.25 if i % 3 == 0 else x for i, x in enumerate(v)]
open(sys.argv[2], "wb").write(d[:end] + struct.pack("<%df" % (3 * nv), *v) + d[end + 12 * nv:])
PY
check dir_json 0 "$packrt" animate "$dir/seq" --bench --json --size 16x16 --threads 1 --counters
expect json_parses python3 -c "import json,sys; j=json.load(open('$dir/out')); r=j['results'][0]; sys.exit(not (j['frames']==2 and r['updates'] and r['cells']>0))"
check gen_other 0 "$packrt" gen sphere --tris 500 -o "$dir/seq/a_002.ply"
check dir_faces_differ 1 "$packrt" animate "$dir/seq" --bench --size 16x16
grep -q "faces differ" "$dir/err" && pass=$((pass + 1)) || { fail=$((fail + 1)); echo "FAIL faces_differ_message"; }
if "$packrt" bench --help 2>/dev/null | grep -q embree && "$packrt" animate twist --tris 1k --frames 2 --size 16x16 --bench --vs embree >"$dir/out" 2>"$dir/err"; then
  expect embree_row grep -q "^embree,dynamic,low,packet16" "$dir/out"
fi
check no_scene 2 "$packrt" animate
check nothing_to_do 2 "$packrt" animate twist
check bad_scene 2 "$packrt" animate teapot --bench
check bad_packet 2 "$packrt" animate twist --bench --packet 3
check bad_spec 1 "$packrt" animate twist --bench --tris 1k --frames 2 --size 8x8 -r nosuch

finish
