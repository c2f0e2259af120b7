#!/usr/bin/env bash
# Reproduces docs/results/raystrips.md: the tables of Lauterbach et al. 2007 (Ray-Strips) on
# this machine. Ray-Strips variants, packrt's BVH representations and Embree in one
# `packrt bench` run per mesh (random and primary rays), plus `packrt build` + `packrt info`
# of each Ray-Strips variant for the strip counts.
# Meshes: the bunny and one frame of each BART scene (when ../shared/data is there), a
# generated connected, scan-like surface (mandelbulb isosurface) and a CAD-like one with
# poor connectivity (cad: unwelded faces), of each size in SIZES (default "1M"; the
# results file also has SIZES=10M SHARED=0, run separately).
# SWEEP=0 skips the chunk-threshold table (random rays on the first generated mesh).
# SHARED=bunny: of the shared meshes only the bunny.
# Usage: [SIZES="1M 10M"] [SHARED=0|bunny] [SWEEP=0] [REPS=5] bench/raystrips.sh [BUILD_DIR] > out.md
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
packrt="$build/packrt"
reps=${REPS:-5}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
keep=${KEEP:-}  # a folder to keep the JSON outputs in

meshes=()
if [ "${SHARED:-1}" = 1 ] && [ -f ../shared/data/bunny.ply ]; then
  meshes+=(../shared/data/bunny.ply ../shared/data/bart_kitchen/kitchen_000.ply.gz
           ../shared/data/bart_robots/robots_000.ply.gz ../shared/data/bart_museum5/museum5_000.ply.gz)
elif [ "${SHARED:-1}" = bunny ] && [ -f ../shared/data/bunny.ply ]; then
  meshes+=(../shared/data/bunny.ply)
fi
sizes=${SIZES:-1M}
for n in $sizes; do
  "$packrt" gen mandelbulb --tris "$n" --seed 1 -o "$tmp/mandelbulb_$n.ply" >&2
  "$packrt" gen cad --tris "$n" --seed 1 -o "$tmp/cad_$n.ply" >&2
  meshes+=("$tmp/mandelbulb_$n.ply" "$tmp/cad_$n.ply")
done

# Ray-Strips: the default (our stripifier, 16-triangle chunks, 8-triangle leaves, 16-bit
# planes) with 4x4 packets, 2x2 packets and single rays only (packet=none: primary rays
# then go one by one), without ids (ids=none) and with 16-bit materials (mat=u16; generated meshes have none, so all 0,
# which costs the same), the same with meshoptimizer's strips, and the paper's own settings
# (2-triangle leaves, float planes, meshoptimizer standing in for Stripe). Then the fastest
# BVH representations and a small indexed one.
strips=("raystrips" "raystrips,packet=2x2" "raystrips,packet=none" "raystrips,ids=none,packet=none"
        "raystrips,mat=u16,packet=none" "raystrips,strip=meshopt,packet=none"
        "raystrips,leaf=2,split=f32,strip=meshopt" "raystrips,leaf=2,split=f32,strip=meshopt,packet=none")
others=("wide8:float3-soa8" "quad:float3-soa4" "wide8:idx32-soa4")
args=()
for s in "${strips[@]}" "${others[@]}"; do args+=(-r "$s"); done

for m in "${meshes[@]}"; do
  name=$(basename "$m"); name=${name%.gz}; name=${name%.ply}
  echo "bench: $m" >&2
  "$packrt" bench "$m" "${args[@]}" --workload random,primary --no-cold --reps "$reps" --json >"$tmp/$name.json"
  for s in $(printf '%s\n' "${strips[@]}" | sed 's/,packet=[a-z0-9]*//; s/,ids=none//; s/,mat=u16//' | sort -u); do
    "$packrt" build "$m" -r "$s" -o "$tmp/$name.prt" >/dev/null 2>&1
    echo "$s $("$packrt" info "$tmp/$name.prt" | grep -o 'leaves [0-9]*' | cut -d' ' -f2)" >>"$tmp/$name.strips"
  done
  echo "$tmp/$name" >>"$tmp/list"
  if [ -n "$keep" ]; then mkdir -p "$keep" && cp "$tmp/$name.json" "$tmp/$name.strips" "$keep/"; fi
done

# The chunk threshold trades memory for speed (longer strips, larger strip boxes): random
# rays only, on the first generated mesh.
sweep=()
for c in 8 12 16 24 32 64 128 256; do sweep+=(-r "raystrips,chunk=$c"); done
if [ "${SWEEP:-1}" = 1 ]; then
  "$packrt" bench "$tmp/mandelbulb_${sizes%% *}.ply" "${sweep[@]}" -r raystrips,strip=meshopt -r wide8:float3-soa8 \
    --workload random --no-cold --reps "$reps" --json >"$tmp/sweep.json"
fi

python3 - "$tmp/list" "$(uptime)" "$tmp/sweep.json" <<'PY'
import json, sys

names = [l.strip() for l in open(sys.argv[1])]
print("# Ray-Strips (Lauterbach et al. 2007) on this machine\n")
first = json.load(open(names[0] + ".json"))
print(f"Machine: {first['machine']}. Commit: `{first['commit']}`. Load at the end: `{sys.argv[2].strip()}`.\n")
print("Made by `bench/raystrips.sh build` (`packrt bench MESH -r ... --workload random,primary --no-cold "
      "--json`, one run per mesh with every row and Embree on the same rays; `packrt build` + `packrt info` "
      "for the strip counts). Other builds and benchmarks shared the 2 cores during the run: compare rows "
      "within one table (same run), not across tables.\n")
print("Rows: `raystrips` is the default, `chunk=16,leaf=8,split=q16,strip=rt,packet=4x4` (our stripifier, "
      "16-triangle chunks, 8-triangle implicit leaves, 16-bit planes, 4x4 packets); `strip=meshopt` swaps in meshoptimizer's stripifier; "
      "`leaf=2,split=f32,strip=meshopt` is the paper's configuration (meshoptimizer standing in for Stripe). "
      "`packet=none` rows answer primary rays one by one (single-ray rate, 1x1); `packet=2x2` rows trace them "
      "in 2x2 packets, the others in 4x4 packets. `ids=none` rows store no triangle ids (hits are mapped back "
      "outside the timed region); `mat=u16` rows store a 16-bit material per triangle.\n")
print("Memory as the paper's Table 1: *minimal* = 14 B/tri (3 indices and a material) + 12 B per vertex + a "
      "BVH of 2n-1 nodes of 32 B; *optimized* = 48 B/tri + the same BVH. The reduction is Ray-Strips' total "
      "against *minimal* (the target: at least 75%). Times: random = Rouwé's random rays, µs per 1024, warm, "
      "one thread (minimum of 5 batches of 1024, so an interrupted batch does not count), and Mrays/s one "
      "thread (median over 64k rays); primary = 1024x1024 pinhole camera, Mrays/s one thread (median). "
      "The ratios are time per ray over Embree's and over `wide8:float3-soa8`'s from the same run, from "
      "the one-thread medians (lower is better).\n")

def fmt(x, d=2):
    return "n/a" if x is None else f"{x:.{d}f}"

for base in names:
    d = json.load(open(base + ".json"))
    strips = {}
    try:
        for line in open(base + ".strips"):
            k, v = line.split()
            strips[k] = int(v)
    except FileNotFoundError:
        pass
    m = d["mesh"]
    T, V = m["triangles"], m.get("vertices") or 0
    rows = d["results"]
    by = {r["name"]: r for r in rows}
    emb, w8 = by.get("embree"), by.get("wide8:float3-soa8")
    minimal = 14 * T + 12 * V + 32 * (2 * T - 1)
    optimized = 48 * T + 32 * (2 * T - 1)
    print(f"## {m['path'].split('/')[-1]}: {T:,} triangles, {V:,} vertices\n")
    print(f"Minimal indexed list + BVH: {minimal / T:.1f} B/tri ({minimal / 2**20:.1f} MB; geometry "
          f"{(14 * T + 12 * V) / T:.1f}, BVH 64.0); optimized 48 B/tri + BVH: {optimized / T:.1f} B/tri "
          f"({optimized / 2**20:.1f} MB). Load average at the start of the run: {d.get('load_average')}.\n")
    print("| representation | build s | strips | tris/strip | B/tri hierarchy | B/tri geometry | B/tri total | MB total "
          "| vs minimal | random µs/1024 | random Mrays/s | primary Mrays/s | random vs Embree | random vs wide8 "
          "| primary vs Embree | primary vs wide8 |")
    print("|" + "---|" * 16)
    for r in rows:
        n = r["name"]
        key = n.replace(",packet=none", "").replace(",packet=4x4", "").replace(",packet=2x2", "").replace(",ids=none", "").replace(",mat=u16", "")
        ns = strips.get(key)
        total = r["bytes_per_tri_total"]
        cells = [f"`{n}`", fmt(r["build_s"], 3), str(ns) if ns else "", fmt(T / ns, 1) if ns else "",
                 fmt(r["bytes_per_tri_tree"]), fmt(r["bytes_per_tri_geometry"]), fmt(total),
                 fmt(total * T / 2**20, 1), f"{100 * (total * T / minimal - 1):+.0f}%",
                 fmt(r["random_us_per_1024"], 1), fmt(r.get("random_mrays_1t")), fmt(r.get("primary_mrays_1t"))]
        for ref in (emb, w8):
            ok = ref and r.get("random_mrays_1t") and ref.get("random_mrays_1t")
            cells.append(fmt(ref["random_mrays_1t"] / r["random_mrays_1t"]) + "x" if ok else "")
        for ref in (emb, w8):
            ok = ref and r.get("primary_mrays_1t") and ref.get("primary_mrays_1t")
            cells.append(fmt(ref["primary_mrays_1t"] / r["primary_mrays_1t"]) + "x" if ok else "")
        print("| " + " | ".join(cells) + " |")
    dis = [f"`{r['name']}` {r.get('random_check_disagreements', 'n/a')}/{r.get('primary_check_disagreements', 'n/a')}"
           for r in rows if r["name"] != "embree"]
    print("\nHit/miss disagreements with Embree (random/primary): " + "; ".join(dis) + ".\n")

try:
    d = json.load(open(sys.argv[3]))
except FileNotFoundError:
    sys.exit(0)
m = d["mesh"]
print(f"## Chunk threshold: {m['path'].split('/')[-1]}, random rays only\n")
print("| representation | B/tri hierarchy | B/tri geometry | B/tri total | vs minimal | random µs/1024 | random Mrays/s "
      "| vs Embree | vs wide8 |")
print("|" + "---|" * 9)
by = {r["name"]: r for r in d["results"]}
T, V = m["triangles"], m.get("vertices") or 0
minimal = 14 * T + 12 * V + 32 * (2 * T - 1)
for r in d["results"]:
    e, w = by.get("embree"), by.get("wide8:float3-soa8")
    print(f"| `{r['name']}` | {fmt(r['bytes_per_tri_tree'])} | {fmt(r['bytes_per_tri_geometry'])} | "
          f"{fmt(r['bytes_per_tri_total'])} | {100 * (r['bytes_per_tri_total'] * T / minimal - 1):+.0f}% | "
          f"{fmt(r['random_us_per_1024'], 1)} | {fmt(r['random_mrays_1t'])} | "
          f"{fmt(e['random_mrays_1t'] / r['random_mrays_1t'])}x | {fmt(w['random_mrays_1t'] / r['random_mrays_1t'])}x |")
print()
PY
