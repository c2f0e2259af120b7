#!/usr/bin/env bash
# Reproduces the tables of docs/results/cgrid.md: the coherent grid (Wald et al. 2006) on the
# BART scenes and packrt's animated generators, against packrt's BVHs and Embree, all
# rebuilt every frame, in the same run.
# Usage: bench/cgrid.sh [BUILD_DIR] > tables.md   (about 10 minutes on 2 cores)
# Every timing is a median over frames 1.. of one `packrt animate --bench` run (frame 0 holds
# the first build); each table names its command. OMP_WAIT_POLICY=passive: on a shared,
# oversubscribed machine spinning OpenMP barriers cost whole scheduler slices.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
packrt="$build/packrt"
data=../shared/data
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

scenes=()
for s in bart_robots bart_kitchen bart_museum5; do [ -d "$data/$s" ] && scenes+=("$data/$s"); done
scenes+=(twist marbles toys)
# Generated scenes: the twisting column at 100k triangles, 110 marbles (21k triangles; the
# paper's marbles were 8.8k, 110 of them), 119 walking toys on a floor (72k triangles, the
# size of BART robots).
gen_opts() { case "$1" in twist) echo "--tris 100k";; marbles) echo "--tris 21120";; toys) echo "--tris 72k";; *) echo "";; esac; }
name() { basename "$1"; }
bvh="quad:float3-soa4"
run() { # run OUT ARGS...: one animate run, JSON into OUT
  local out=$1; shift
  echo "animate $*" >&2
  "$packrt" animate "$@" --bench --json >"$out"
}

# A. Frames per second including the rebuild, 1024x1024 primary rays, 8x8 packets; the BVH
#    rebuilt (binned SAH, Morton) and refitted (built on frame 0, update=refit).
for s in "${scenes[@]}"; do
  for t in 1 2; do
    # shellcheck disable=SC2046
    run "$tmp/A_$(name "$s")_$t.json" "$s" $(gen_opts "$s") --threads "$t" --vs embree \
      -r cgrid -r "$bvh" -r "$bvh,split=morton" -r "$bvh,update=refit"
  done
done
# B. Table 1: ray-triangle tests and cells with and without mailboxing (MB) and frustum
#    culling (FC), 4x4 packets, no macrocells, one thread, 3 frames.
for s in "${scenes[@]}"; do
  # shellcheck disable=SC2046
  run "$tmp/B_$(name "$s").json" "$s" $(gen_opts "$s") --threads 1 --frames 3 --packet 4 --counters \
    -r "cgrid,macro=0,mailbox=off,cull=off" -r "cgrid,macro=0,mailbox=on,cull=off" -r "cgrid,macro=0"
done
# C. Tables 3 and 4: single-ray 3D-DDA against 4x4 and 8x8 packets, one thread, 3 frames.
for s in "${scenes[@]}"; do
  for p in 4 8; do
    # shellcheck disable=SC2046
    run "$tmp/C_$(name "$s")_$p.json" "$s" $(gen_opts "$s") --threads 1 --frames 3 --packet "$p" --counters \
      -r "cgrid,macro=0,packet=1" -r "cgrid,macro=0" -r "cgrid"
  done
done
# D. Figure 7 as a table: packet size against model size (the twisting column), one thread.
for n in 10k 100k 1M; do
  for p in 2 4 8 16; do
    run "$tmp/D_${n}_$p.json" twist --tris "$n" --frames 3 --threads 1 --packet "$p" --repeat 3 -r cgrid
  done
done
# E. Figure 6: lambda (cells per triangle), BART robots or the twist, one thread.
lam_scene=${scenes[0]}
lam_specs=()
for l in 1 2 4 6 8 12 16; do lam_specs+=(-r "cgrid,lambda=$l"); done
# shellcheck disable=SC2046
run "$tmp/E.json" "$lam_scene" $(gen_opts "$lam_scene") --threads 1 --frames 6 "${lam_specs[@]}"

# F. BART robots from a street inside the city (the default framing sees its outer walls).
if [ -d "$data/bart_robots" ]; then
  for t in 1 2; do
    run "$tmp/F_$t.json" "$data/bart_robots" --threads "$t" --vs embree --camera 0,60,200,0,0,-100,60 \
      -r cgrid -r cgrid,lambda=1
  done
fi

python3 - "$tmp" "$(uname -srm)" "$(nproc)" <<'PY'
import glob, json, os, sys
tmp, uname, nproc = sys.argv[1], sys.argv[2], sys.argv[3]
def load(p):
    return json.load(open(p))
def res(j, prefix):
    for r in j["results"]:
        if r["representation"].startswith(prefix):
            return r
    raise KeyError(prefix)
def scene_files(tag):
    return sorted(glob.glob(os.path.join(tmp, tag + "_*.json")))
print(f"Machine: {uname}, {nproc} cores. OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY','')}.\n")

print("### A. Frames per second including the rebuild (1024x1024 primary rays, 8x8 packets; Embree 4x4 in rtcIntersect16)\n")
print("Medians over frames 1..20 of one run. rebuild: prt_accel_update for cgrid, prt_build from scratch for the BVHs, "
      "rtcCommitScene (DYNAMIC, LOW) for Embree. build Mtri/s = triangles / rebuild time.\n")
print("With one thread the CPU time of that thread is given too (cpu columns): unlike the wall clock it does not "
      "count time the thread waited for a core held by another process. same prim: pixels whose primitive equals cgrid's.\n")
print("| scene | tris | threads | representation | rebuild ms | trace ms | total ms | fps | build Mtri/s | Embree's rebuild / this | total / Embree's | rebuild cpu ms | trace cpu ms | total cpu / Embree's | same prim % |")
print("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for f in scene_files("A"):
    j = load(f)
    em = res(j, "embree")
    tot_em = em["rebuild_ms"] + em["trace_ms"]
    cpu_em = em["rebuild_cpu_ms"] + em["trace_cpu_ms"]
    for r in j["results"]:
        tot = r["rebuild_ms"] + r["trace_ms"]
        cpu = r["rebuild_cpu_ms"] + r["trace_cpu_ms"]
        one = j["threads"] == 1
        c1 = f"{r['rebuild_cpu_ms']:.2f}" if one else ""
        c2 = f"{r['trace_cpu_ms']:.2f}" if one else ""
        c3 = f"{cpu / cpu_em:.2f}" if one else ""
        print(f"| {j['scene']} | {j['triangles']} | {j['threads']} | `{r['representation']}` | {r['rebuild_ms']:.2f} | "
              f"{r['trace_ms']:.2f} | {tot:.2f} | {r['fps']:.1f} | {r['build_mtris_per_s']:.1f} | "
              f"{em['rebuild_ms'] / r['rebuild_ms']:.2f} | {tot / tot_em:.2f} | "
              f"{c1} | {c2} | {c3} | {r['same_prim_percent']:.2f} |")
print()

print("### B. Table 1: ray-triangle tests per frame (millions), 4x4 packets, no macrocells, 1024x1024\n")
print("| scene | tris | -/- | MB/- | MB/FC | ratio -/- to MB/FC | cells -/- (M) | cells MB/FC (M) |")
print("|---|---:|---:|---:|---:|---:|---:|---:|")
for f in scene_files("B"):
    j = load(f)
    fr = j["frames"]
    a, b, c = j["results"]
    print(f"| {j['scene']} | {j['triangles']} | {a['tests']/fr/1e6:.3f} | {b['tests']/fr/1e6:.3f} | {c['tests']/fr/1e6:.3f} | "
          f"{a['tests']/max(c['tests'],1):.1f} | {a['cells']/fr/1e6:.3f} | {c['cells']/fr/1e6:.3f} |")
print()

print("### C. Tables 3 and 4: single-ray 3D-DDA against frustum packets (one thread, no macrocells unless said)\n")
print("fps from the tracing thread's CPU time (trace only, no rebuild); tests and cells per frame.\n")
print("| scene | tris | single-ray fps | 4x4 fps | 8x8 fps | 8x8, macrocells 6 fps | 8x8 / single | tests single (M) | tests 4x4 | tests 8x8 | cells single (M) | cells 4x4 | cells 8x8 | cells ratio 4x4 | cells ratio 8x8 |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
names = sorted({load(f)["scene"] for f in scene_files("C")})
for n in names:
    j4 = load(os.path.join(tmp, f"C_{n}_4.json")); j8 = load(os.path.join(tmp, f"C_{n}_8.json"))
    fr = j4["frames"]
    s1 = res(j4, "cgrid,lambda=6,macro=0,packet=1"); p4 = res(j4, "cgrid,lambda=6,macro=0,packet=0")
    p8 = res(j8, "cgrid,lambda=6,macro=0,packet=0"); m8 = res(j8, "cgrid,lambda=6,macro=6")
    fps = lambda r: 1000.0 / r["trace_cpu_ms"]
    M = lambda x: x / fr / 1e6
    print(f"| {n} | {j4['triangles']} | {fps(s1):.2f} | {fps(p4):.2f} | {fps(p8):.2f} | {fps(m8):.2f} | {fps(p8)/fps(s1):.1f} | "
          f"{M(s1['tests']):.3f} | {M(p4['tests']):.3f} | {M(p8['tests']):.3f} | {M(s1['cells']):.3f} | {M(p4['cells']):.3f} | "
          f"{M(p8['cells']):.3f} | {s1['cells']/max(p4['cells'],1):.1f} | {s1['cells']/max(p8['cells'],1):.1f} |")
print()

print("### D. Figure 7 as a table: trace ms per frame by packet size and model size (twist, one thread, 1024x1024, CPU time)\n")
print("| triangles | 2x2 | 4x4 | 8x8 | 16x16 |")
print("|---:|---:|---:|---:|---:|")
for n in ["10k", "100k", "1M"]:
    row = []
    tris = None
    for p in [2, 4, 8, 16]:
        j = load(os.path.join(tmp, f"D_{n}_{p}.json"))
        tris = j["triangles"]
        row.append(f"{j['results'][0]['trace_cpu_ms']:.1f}")
    print(f"| {tris} | " + " | ".join(row) + " |")
print()

print("### E. Figure 6: lambda (cells per triangle), one thread\n")
j = load(os.path.join(tmp, "E.json"))
print(f"Scene {j['scene']}, {j['triangles']} triangles, 8x8 packets, CPU time of the one thread.\n")
print("| lambda | rebuild ms | trace ms | total ms | total / best |")
print("|---:|---:|---:|---:|---:|")
best = min(r["rebuild_cpu_ms"] + r["trace_cpu_ms"] for r in j["results"])
for r in j["results"]:
    lam = r["representation"].split("lambda=")[1].split(",")[0]
    tot = r["rebuild_cpu_ms"] + r["trace_cpu_ms"]
    print(f"| {lam} | {r['rebuild_cpu_ms']:.2f} | {r['trace_cpu_ms']:.2f} | {tot:.2f} | {tot/best:.2f} |")

if os.path.exists(os.path.join(tmp, "F_1.json")):
    print("\n### F. BART robots from a street inside the city (`--camera 0,60,200,0,0,-100,60`)\n")
    print("| threads | representation | rebuild ms | trace ms | total ms | Embree's rebuild / this | total / Embree's | cpu total / Embree's |")
    print("|---:|---|---:|---:|---:|---:|---:|---:|")
    for t in (1, 2):
        j = load(os.path.join(tmp, f"F_{t}.json"))
        em = res(j, "embree")
        for r in j["results"]:
            tot = r["rebuild_ms"] + r["trace_ms"]
            cpu = (r["rebuild_cpu_ms"] + r["trace_cpu_ms"]) / (em["rebuild_cpu_ms"] + em["trace_cpu_ms"])
            cpu_s = f"{cpu:.2f}" if t == 1 else ""
            print(f"| {t} | `{r['representation']}` | {r['rebuild_ms']:.2f} | {r['trace_ms']:.2f} | {tot:.2f} | "
                  f"{em['rebuild_ms'] / r['rebuild_ms']:.2f} | {tot / (em['rebuild_ms'] + em['trace_ms']):.2f} | {cpu_s} |")
PY
