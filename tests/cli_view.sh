#!/usr/bin/env bash
# packrt-view headless: under Xvfb it opens its window, draws frames, saves a screenshot
# that shows the model (not a blank or uniform image) and exits on its own (--frames N).
# Skipped (77) when the viewer was not built (no SDL2) or no X display can be made.
# Usage: cli_view.sh PACKRT SOURCE_DIR   (packrt-view is looked for beside PACKRT)
set -u
packrt=$1
view="$(dirname "$packrt")/packrt-view"
[ -x "$view" ] || { echo "skip: packrt-view not built (SDL2 missing)"; exit 77; }
if command -v xvfb-run >/dev/null; then
  run=(xvfb-run -a -s "-screen 0 640x480x24")
elif [ -n "${DISPLAY:-}" ]; then
  run=()
else
  echo "skip: no xvfb-run and no DISPLAY"; exit 77
fi
# SDL and the X libraries keep allocations until exit that LeakSanitizer would report;
# the viewer's own code paths are covered by ASan and UBSan all the same.
export ASAN_OPTIONS="${ASAN_OPTIONS:-}:detect_leaks=0"
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail=0 pass=0
check() { # check NAME EXPECTED_EXIT COMMAND...
  local name=$1 want=$2; shift 2
  "$@" >"$dir/out" 2>"$dir/err"; local got=$?
  if [ "$got" -eq "$want" ]; then pass=$((pass + 1)); echo "ok   $name"
  else fail=$((fail + 1)); echo "FAIL $name: exit $got, wanted $want"; cat "$dir/err" "$dir/out"; fi
}
# not_blank FILE W H: a PNG of that size whose pixels are not one colour, with a twentieth of
# them lit (the model) and a twentieth dark (the backdrop). Decodes 8-bit RGB(A) PNG itself.
not_blank() { python3 - "$@" <<'PY'
import struct, sys, zlib
data = open(sys.argv[1], "rb").read()
assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
pos, idat, hdr = 8, b"", None
while pos < len(data):
    n, kind = struct.unpack(">I4s", data[pos:pos + 8]); body = data[pos + 8:pos + 8 + n]; pos += 12 + n
    if kind == b"IHDR": hdr = struct.unpack(">IIBBBBB", body)
    elif kind == b"IDAT": idat += body
w, h, depth, ctype, _, _, interlace = hdr
assert (w, h) == (int(sys.argv[2]), int(sys.argv[3])), f"size {w}x{h}"
assert depth == 8 and ctype in (2, 6) and interlace == 0, "unexpected PNG flavour"
bpp = 3 if ctype == 2 else 4
raw, stride, prev, rows = zlib.decompress(idat), w * bpp, bytearray(w * bpp), []
for y in range(h):
    f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
    for i in range(stride):
        a = line[i - bpp] if i >= bpp else 0; b = prev[i]; c = prev[i - bpp] if i >= bpp else 0
        if f == 1: line[i] = (line[i] + a) & 255
        elif f == 2: line[i] = (line[i] + b) & 255
        elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
        elif f == 4:
            p = a + b - c; pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
    rows.append(line); prev = line
lum = [sum(r[x * bpp:x * bpp + 3]) / 3 for r in rows for x in range(w)]
lit, dark = sum(v > 120 for v in lum), sum(v < 60 for v in lum)
assert len(set(lum)) > 20, "uniform image"
assert lit > len(lum) // 20 and dark > len(lum) // 20, f"lit {lit}, dark {dark} of {len(lum)}"
PY
}

check gen 0 "$packrt" gen sphere --tris 5k -o "$dir/s.ply"
check frames 0 "${run[@]}" "$view" "$dir/s.ply" --frames 3 --size 160x120 --shade shadows \
  --screenshot "$dir/shot.png" --screenshot-window "$dir/window.png"
if not_blank "$dir/shot.png" 160 120; then pass=$((pass + 1)); echo "ok   screenshot_shows_the_model"
else fail=$((fail + 1)); echo "FAIL screenshot_shows_the_model"; fi
if [ -s "$dir/window.png" ]; then pass=$((pass + 1)); echo "ok   window_capture_written"
else fail=$((fail + 1)); echo "FAIL window_capture_written"; fi
check build_prt 0 "$packrt" build "$dir/s.ply" -r aabb:float3 -o "$dir/s.prt"
check prt_alone 0 "${run[@]}" "$view" "$dir/s.prt" --frames 2 --size 64x48 --screenshot "$dir/prt.png"
check no_input 2 "$view"
check screenshot_without_frames 2 "$view" "$dir/s.ply" --screenshot "$dir/x.png"
check missing_file 1 "$view" "$dir/nonexistent.ply" --frames 1

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
