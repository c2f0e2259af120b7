#!/usr/bin/env bash
# packrt render as users call it: every shading mode, .prt input with and without --mesh,
# --compare, the same bytes on 1 and 2 threads, and the exit codes of mistakes.
# Usage: cli_render.sh PACKRT SOURCE_DIR
set -u
packrt=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
. "$2/tests/support/cli_check.sh" # check, expect, finish
# PNG signature and IHDR size: png_size FILE W H
png_size() { python3 - "$@" <<'PY'
import struct, sys
d = open(sys.argv[1], "rb").read(32)
w, h = struct.unpack(">II", d[16:24])
sys.exit(0 if d[:8] == b"\x89PNG\r\n\x1a\n" and (w, h) == (int(sys.argv[2]), int(sys.argv[3])) else 1)
PY
}

ext=png
"$packrt" render --help | grep -q "compare" || { echo "FAIL help"; exit 1; }
check gen 0 "$packrt" gen sphere --tris 5k -o "$dir/s.ply"
# A build without libpng refuses .png with a clear message; test the PPM path then.
"$packrt" render "$dir/s.ply" -o "$dir/probe.png" --size 8x8 >/dev/null 2>"$dir/err" || {
  grep -q "libpng" "$dir/err" && ext=ppm; }
for mode in normal diffuse shadows ao gi; do
  check "render_$mode" 0 "$packrt" render "$dir/s.ply" -o "$dir/$mode.$ext" --shade "$mode" --size 48x32 --spp 2
done
[ "$ext" = png ] && expect png_header_and_size png_size "$dir/gi.png" 48 32
check render_denoise 0 "$packrt" render "$dir/s.ply" -o "$dir/d.$ext" --shade gi --denoise --size 48x32 --spp 2
check threads_1 0 "$packrt" render "$dir/s.ply" -o "$dir/t1.$ext" --shade ao --size 40x30 --spp 3 --threads 1
check threads_2 0 "$packrt" render "$dir/s.ply" -o "$dir/t2.$ext" --shade ao --size 40x30 --spp 3 --threads 2
expect same_bytes_any_threads cmp -s "$dir/t1.$ext" "$dir/t2.$ext"
check camera 0 "$packrt" render "$dir/s.ply" -o "$dir/c.ppm" --camera 0,0,5,0,0,0,30 --size 16x16
check ppm 0 test "$(head -c 2 "$dir/c.ppm")" = P6

check build_prt 0 "$packrt" build "$dir/s.ply" -r aabb:float3 -o "$dir/s.prt"
check prt_alone 0 "$packrt" render "$dir/s.prt" -o "$dir/p.$ext" --shade normal --size 32x24
grep -q "normals are estimated" "$dir/err" && { pass=$((pass + 1)); echo "ok   prt_alone_says_normals_are_estimated"; } \
  || { fail=$((fail + 1)); echo "FAIL prt_alone_says_normals_are_estimated"; }
check prt_with_mesh 0 "$packrt" render "$dir/s.prt" --mesh "$dir/s.ply" -o "$dir/pm.$ext" --shade normal --size 32x24
check mesh_direct 0 "$packrt" render "$dir/s.ply" -r aabb:float3 -o "$dir/m.$ext" --shade normal --size 32x24
expect prt_with_mesh_equals_mesh cmp -s "$dir/pm.$ext" "$dir/m.$ext"

check compare 0 "$packrt" render "$dir/s.ply" --compare aabb:float3,quad:float3-soa4,leaf=4 -o "$dir/cmp.$ext" \
  --shade shadows --size 48x32
grep -q "identical" "$dir/out" && { pass=$((pass + 1)); echo "ok   compare_lossless_identical"; } \
  || { fail=$((fail + 1)); echo "FAIL compare_lossless_identical"; cat "$dir/out"; }
expect compare_files test -s "$dir/cmp-aabb_float3.$ext" -a -s "$dir/cmp-quad_float3-soa4_leaf_4.$ext" -a -s "$dir/cmp-diff.$ext"

# A coloured mesh renders in its colours: the face-coloured quad seen head on shows its
# orange-brown face (200, 100, 50) and its near-black one (7, 8, 9) over the grey backdrop.
check colours 0 "$packrt" render "$2/tests/data/good/face_colors_ascii.ply" -o "$dir/col.ppm" --size 32x32 \
  --camera 1,0,8,1,0,2.4,30
expect colours_show python3 - "$dir/col.ppm" <<'PY'
import sys
d = open(sys.argv[1], "rb").read()
px = d[len(b"P6\n32 32\n255\n"):]
rgb = [tuple(px[i:i + 3]) for i in range(0, len(px), 3)]
lit = [p for p in rgb if p[0] > 80]          # the backdrop is darker, bluish grey
dark = [p for p in rgb if max(p) < 20]        # the second face
sys.exit(0 if len(lit) > 60 and len(dark) > 30 and all(r > g + 20 and g > b + 10 for r, g, b in lit) else 1)
PY

check info_colours 0 "$packrt" info "$2/tests/data/good/face_colors_ascii.ply" -r aabb:float3
grep -q "^colours *per triangle" "$dir/out" && { pass=$((pass + 1)); echo "ok   info_names_the_colours"; } \
  || { fail=$((fail + 1)); echo "FAIL info_names_the_colours"; cat "$dir/out"; }

# -r embree: the same frames traced by Embree (when this build has it).
if "$packrt" render "$dir/s.ply" -r embree -o "$dir/e.$ext" --size 8x8 >/dev/null 2>"$dir/err"; then
  check embree_render 0 "$packrt" render "$dir/s.ply" -r embree -o "$dir/e.$ext" --shade shadows --size 48x32
  grep -q "^embree " "$dir/out" && { pass=$((pass + 1)); echo "ok   embree_named_in_report"; } \
    || { fail=$((fail + 1)); echo "FAIL embree_named_in_report"; cat "$dir/out"; }
  check embree_compare 0 "$packrt" render "$dir/s.ply" --compare embree,aabb:float3 -o "$dir/ec.$ext" \
    --shade ao --spp 2 --size 48x32
  grep -Eq "identical|PSNR [4-9][0-9]" "$dir/out" && { pass=$((pass + 1)); echo "ok   embree_same_image"; } \
    || { fail=$((fail + 1)); echo "FAIL embree_same_image"; cat "$dir/out"; }
  check embree_prt 2 "$packrt" render "$dir/s.prt" -r embree -o "$dir/x.$ext"
else
  grep -q "no Embree" "$dir/err" && echo "ok   embree (skipped: this build has no Embree)" \
    || { fail=$((fail + 1)); echo "FAIL embree_render"; cat "$dir/err"; }
fi

check bad_shade 2 "$packrt" render "$dir/s.ply" -o "$dir/x.$ext" --shade phong
check no_output 2 "$packrt" render "$dir/s.ply"
check bad_size 2 "$packrt" render "$dir/s.ply" -o "$dir/x.$ext" --size 12
check bad_camera 2 "$packrt" render "$dir/s.ply" -o "$dir/x.$ext" --camera 1,2,3
check eye_is_target 1 "$packrt" render "$dir/s.ply" -o "$dir/x.$ext" --camera 1,1,1,1,1,1
check compare_one_spec 2 "$packrt" render "$dir/s.ply" -o "$dir/x.$ext" --compare aabb:float3
check compare_prt 2 "$packrt" render "$dir/s.prt" -o "$dir/x.$ext" --compare aabb:float3,quad:float3
check missing_file 1 "$packrt" render "$dir/nonexistent.ply" -o "$dir/x.$ext"
check unwritable 1 "$packrt" render "$dir/s.ply" -o "$dir/no/such/dir/x.$ext" --size 8x8

finish
