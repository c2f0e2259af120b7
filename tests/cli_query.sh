#!/usr/bin/env bash
# The mesh-query commands: packrt query (closest points, --signed, --contains, --winding),
# packrt cast --all and packrt sdf on a generated sphere around the origin, their files read
# back (docs/formats.md), and the exit codes of mistakes. Usage: cli_query.sh PACKRT SOURCE_DIR
set -u
packrt=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
. "$2/tests/support/cli_check.sh" # check, expect, finish
py() { python3 - "$@" || fail=$((fail + 1)); }

check gen_sphere 0 "$packrt" gen sphere --tris 20k -o "$dir/s.ply"
check build 0 "$packrt" build "$dir/s.ply" -r wide8:idx8-soa4 -o "$dir/s.prt"
# Text points: the centre, two inside, two outside, one far away.
printf '# x y z\n0 0 0\n0.5 0 0\n0,0.2,-0.3\n2 0 0\n0 -3 0\n10 10 10\n' >"$dir/p.txt"
check query_closest 0 "$packrt" query "$dir/s.prt" --points "$dir/p.txt" -o "$dir/d.dist"
check query_signed 0 "$packrt" query "$dir/s.ply" --points "$dir/p.txt" -o "$dir/s.dist" --signed
check query_contains 0 "$packrt" query "$dir/s.prt" --points "$dir/p.txt" -o "$dir/in.bin" --contains
check query_winding 0 "$packrt" query "$dir/s.prt" --points "$dir/p.txt" -o "$dir/w.bin" --winding
check query_contains_winding 0 "$packrt" query "$dir/s.prt" --points "$dir/p.txt" -o "$dir/inw.bin" --contains --method winding
check query_winding_fast 0 "$packrt" query "$dir/s.prt" --points "$dir/p.txt" -o "$dir/wf.bin" --winding --beta 2
check query_bad_method 2 "$packrt" query "$dir/s.prt" --points "$dir/p.txt" -o "$dir/x.bin" --contains --method vote
check query_bad_beta 2 "$packrt" query "$dir/s.prt" --points "$dir/p.txt" -o "$dir/x.bin" --winding --beta -1
check query_max_distance 0 "$packrt" query "$dir/s.prt" --points "$dir/p.txt" -o "$dir/m.dist" --max-distance 0.6
py "$dir" <<'PY'
import math, struct, sys
d = sys.argv[1]
pts = [(0, 0, 0), (0.5, 0, 0), (0, 0.2, -0.3), (2, 0, 0), (0, -3, 0), (10, 10, 10)]
inside = [True, True, True, False, False, False]
def records(path, magic, size):
    b = open(path, "rb").read()
    assert b[:8] == magic, (path, b[:8])
    n, = struct.unpack("<Q", b[8:16])
    assert len(b) == 16 + n * size and n == len(pts), (path, n, len(b))
    return [b[16 + i * size:16 + (i + 1) * size] for i in range(n)]
near = [math.dist(p, (0, 0, 0)) for p in pts]
for name, signed in (("d.dist", False), ("s.dist", True)):
    for p, r, ins, c in zip(pts, records(f"{d}/{name}", b"PRTDIST1", 28), inside, near):
        dist, prim, u, v, x, y, z = struct.unpack("<f I f f 3f", r)
        # The sphere's facets lie within a few % of the unit sphere; the point on them.
        want = abs(1 - c)
        assert abs(abs(dist) - want) < 0.03 * (1 + c), (name, p, dist, want)
        assert abs(math.dist((x, y, z), p) - abs(dist)) < 1e-4 * (1 + c), (name, p)
        assert prim != 0xFFFFFFFF and 0 <= u <= 1 and 0 <= v <= 1
        if signed: assert (dist < 0) == ins, (p, dist)
for r, ins in zip(records(f"{d}/in.bin", b"PRTINSD1", 1), inside):
    assert (r[0] & 1) == ins and not r[0] & 2, (r[0], ins)
for r, ins in zip(records(f"{d}/inw.bin", b"PRTINSD1", 1), inside):
    assert (r[0] & 1) == ins and r[0] & 2, (r[0], ins)  # decided by the winding number, and says so
for name, tol in (("w.bin", 1e-3), ("wf.bin", 1e-2)):
    for r, ins in zip(records(f"{d}/{name}", b"PRTWIND1", 4), inside):
        w, = struct.unpack("<f", r)
        assert abs(w - (1 if ins else 0)) < tol, (name, w)
for r, c in zip(records(f"{d}/m.dist", b"PRTDIST1", 28), near):
    dist, prim = struct.unpack("<f I", r[:8])
    assert (prim == 0xFFFFFFFF) == (abs(1 - c) > 0.62), (c, dist, prim)
print("ok   query files read back")
PY

# Every crossing: rays through the centre cross the sphere twice (from outside), once (from
# the centre); --max 1 keeps the nearest and still counts both.
python3 - "$dir/r.rays" <<'PY'
import math, struct, sys
rays = [(-3, 0.1, 0.05, 1, 0, 0), (0, 0, 0, 0.3, 0.5, -0.2), (0, 5, 0, 0, 1, 0), (1, 1, 1, 1, 1, 1)]
with open(sys.argv[1], "wb") as f:
    f.write(b"PRTRAYS1" + struct.pack("<Q", len(rays)))
    for o0, o1, o2, d0, d1, d2 in rays:
        f.write(struct.pack("<8f", o0, o1, o2, 0, d0, d1, d2, math.inf))
PY
check cast_all 0 "$packrt" cast "$dir/s.prt" --rays "$dir/r.rays" -o "$dir/x.bin" --all
check cast_all_max 0 "$packrt" cast "$dir/s.prt" --rays "$dir/r.rays" -o "$dir/x1.bin" --all --max 1
py "$dir" <<'PY'
import struct, sys
d = sys.argv[1]
for name, cap in (("x.bin", 99), ("x1.bin", 1)):
    b = open(f"{d}/{name}", "rb").read()
    assert b[:8] == b"PRTXING1"
    rays, recs = struct.unpack("<QQ", b[8:24])
    counts = struct.unpack(f"<{rays}I", b[24:24 + 4 * rays])
    assert counts == (2, 1, 0, 0), counts
    assert recs == sum(min(c, cap) for c in counts) and len(b) == 24 + 4 * rays + 16 * recs, (recs, len(b))
    ts = [struct.unpack("<f", b[24 + 4 * rays + 16 * k:28 + 4 * rays + 16 * k])[0] for k in range(recs)]
    assert ts[0] < 3 and (cap == 1 or (ts[1] > ts[0] and ts[1] > 3)), ts
print("ok   crossing files read back")
PY

check sdf 0 "$packrt" sdf "$dir/s.prt" --res 12 -o "$dir/f.raw"
py "$dir" <<'PY'
import json, math, struct, sys
d = sys.argv[1]
g = json.load(open(f"{d}/f.raw.json"))
nx, ny, nz = g["dims"]
vals = struct.unpack(f"<{nx * ny * nz}f", open(f"{d}/f.raw", "rb").read())
o, h = g["origin"], g["spacing"]
for k in range(nz):
    for j in range(ny):
        for i in range(nx):
            p = (o[0] + h * i, o[1] + h * j, o[2] + h * k)
            r = math.dist(p, (0, 0, 0))
            assert abs(vals[i + nx * (j + ny * k)] - (r - 1)) < 0.03 * (1 + r), (p, vals[i + nx * (j + ny * k)])
print("ok   sdf field matches the sphere's")
PY

# An out-of-core block file answers the same queries exactly (ooc/query.c): the same closest
# points, containment and crossings as the BVH file, byte for byte.
check build_ooc 0 "$packrt" build "$dir/s.ply" -r ooc -o "$dir/s.ooc"
check query_ooc_closest 0 "$packrt" query "$dir/s.ooc" --points "$dir/p.txt" -o "$dir/o.dist"
expect query_ooc_closest_as_bvh cmp -s "$dir/o.dist" "$dir/d.dist"
check query_ooc_contains 0 "$packrt" query "$dir/s.ooc" --points "$dir/p.txt" -o "$dir/oin.bin" --contains
expect query_ooc_contains_as_bvh cmp -s "$dir/oin.bin" "$dir/in.bin"
check cast_all_ooc 0 "$packrt" cast "$dir/s.ooc" --rays "$dir/r.rays" -o "$dir/ox.bin" --all
expect cast_all_ooc_as_bvh cmp -s "$dir/ox.bin" "$dir/x.bin"

# Mistakes: no points, a missing file, bad text, a representation without the queries.
check query_needs_points 2 "$packrt" query "$dir/s.prt" -o "$dir/z"
check query_missing_file 1 "$packrt" query "$dir/s.prt" --points "$dir/nope.points" -o "$dir/z"
printf '1 2\n' >"$dir/bad.txt"
check query_bad_text 1 "$packrt" query "$dir/s.prt" --points "$dir/bad.txt" -o "$dir/z"
grep -q "line 1" "$dir/err" || { fail=$((fail + 1)); echo "FAIL query_bad_text names the line"; }
check query_refused 1 "$packrt" query "$dir/s.ply" -r raystrips --points "$dir/p.txt" -o "$dir/z"
grep -q "wide8:idx8-soa4" "$dir/err" || { fail=$((fail + 1)); echo "FAIL query_refused names a representation that answers"; }
check cast_all_and_occluded 2 "$packrt" cast "$dir/s.prt" --rays "$dir/r.rays" -o "$dir/z" --all --occluded
check sdf_bad_res 2 "$packrt" sdf "$dir/s.prt" --res 1 -o "$dir/z"

finish
