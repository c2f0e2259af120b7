#!/usr/bin/env python3
"""Benthin et al.'s Tables 1-3 from `packrt bench --json` files (bench/lossygrid.sh).

Usage: lossygrid_md.py RUN.json... > docs/results/lossygrid.md
Every ratio compares rows of one JSON file, i.e. figures measured in the same process on
the same rays. The grid statistics come from each lossygrid row's "detail" (prt_stats)."""
import json
import os
import re
import sys

OURS = "lossygrid,ids=none"
ENCODINGS = [("fix", "lossygrid,ids=none"), ("oct", "lossygrid,enc=oct,ids=none"), ("exp", "lossygrid,enc=exp,ids=none")]
TRIANGLE_BVHS = ["wide8:float3-soa8", "quad:idx32-soa4", "wide8:idx8-bitpack-soa4,ids=none"]

DETAIL = re.compile(r"(?P<sub>\d+) sub-grids hold (?P<share>[\d.]+)% of the triangles, (?P<per>[\d.]+) per sub-grid; "
                    r"vertex error max (?P<max>[\d.e+-]+), RMS (?P<rms>[\d.e+-]+)"
                    r"(; per sub-grid / its diagonal: avg (?P<ravg>[\d.e+-]+)%, max (?P<rmax>[\d.e+-]+)%; (?P<grids>\d+) grids)?"
                    r"(; shared corners would save (?P<share_save>[\d.e+-]+) B/tri)?")


def rows(run):
    return {r["name"]: r for r in run["results"] if "error" not in r}


def mesh_name(run):
    p = run["mesh"]["path"]
    return os.path.basename(p).split(".")[0]


def fmt(x, digits=2):
    return "-" if x is None else f"{x:.{digits}f}"


def ratio(a, b):
    return None if not a or not b else a / b


def main(paths):
    runs = [json.load(open(p)) for p in paths]
    order = {"terrain": 0, "canyon": 1, "torus": 2}
    def key(run):  # displaced scenes by size then kind, the real meshes after them
        name = mesh_name(run)
        kind, _, size = name.partition("-")
        return (0, run["mesh"]["triangles"], order.get(kind, 9)) if kind in order else (1, 0, name)
    runs.sort(key=key)
    if not runs:
        sys.exit("lossygrid_md.py: no JSON files")
    first = runs[0]
    out = []
    w = out.append
    w("# Lossy compressed grids: Benthin et al.'s tables on this machine\n")
    w(f"Machine: {first['machine']}; commit {first['commit']}; `bench/lossygrid.sh` "
      f"(`packrt bench MESH -r ... --workload random,primary,diffuse --reps {first['reps']} --json`, "
      "then `bench/lossygrid_md.py`). Every ratio is between figures of one run on the same rays; "
      "the machine has 2 cores and is shared, so single runs are noisy (load average at the start of each "
      "run is listed). `lossygrid` rows are `ids=none` unless named otherwise: like the paper, no per-triangle "
      "id map (the caller receives the triangle order once); the map costs 4 B/tri more.\n")
    w("Meshes: `terrain` is the paper's Ground (a height field), `canyon` and `torus` its other two scenes, "
      "all from `packrt gen`; `bunny`, `kitchen_000`, `robots_000` are real meshes from `../shared/data`.\n")

    w("## Table 1: memory\n")
    w("| mesh | triangles | sub-grids | in grids | tri/sub-grid | tree B/tri | geometry B/tri | total B/tri | total MB "
      "| ids=mesh B/tri | Embree B/tri | reduction vs Embree | vs quad:idx32-soa4 | vs wide8:idx8-bitpack-soa4 "
      "| §9 shared corners would save | load |")
    w("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for run in runs:
        r = rows(run)
        g = r.get(OURS)
        if not g:
            continue
        d = DETAIL.search(g.get("detail", "")) if g.get("detail") else None
        tri = run["mesh"]["triangles"]
        e = r.get("embree")
        idx = r.get("quad:idx32-soa4")
        small = r.get("wide8:idx8-bitpack-soa4,ids=none")
        withids = r.get("lossygrid")
        w(f"| {mesh_name(run)} | {tri:,} | {d['sub'] if d else '-'} | {d['share'] + '%' if d else '-'} | "
          f"{d['per'] if d else '-'} | {fmt(g['bytes_per_tri_tree'])} | {fmt(g['bytes_per_tri_geometry'])} | "
          f"**{fmt(g['bytes_per_tri_total'])}** | {fmt(g['bytes_per_tri_total'] * tri / 1e6, 1)} | "
          f"{fmt(withids['bytes_per_tri_total']) if withids else '-'} | {fmt(e['bytes_per_tri_total']) if e else '-'} | "
          f"{fmt(ratio(e and e['bytes_per_tri_total'], g['bytes_per_tri_total']), 1)}x | "
          f"{fmt(ratio(idx and idx['bytes_per_tri_total'], g['bytes_per_tri_total']), 1)}x | "
          f"{fmt(ratio(small and small['bytes_per_tri_total'], g['bytes_per_tri_total']), 1)}x | "
          f"{d['share_save'] + ' B/tri' if d and d['share_save'] else '-'} | {run.get('load_average', -1):.1f} |")
    w("")

    w("## Table 2: speed relative to Embree (same rays, one thread; > 1 is faster than Embree)\n")
    w("Columns: Mrays/s of the 64k-ray random workload, of 1024x1024 primary rays and of diffuse bounce rays "
      "over Embree's in the same run (Embree traces primary rays in packets of 16; lossygrid in packets of 16 since commit 0930803, the triangle BVHs single rays), and "
      "Embree's time over ours for the warm 1024-ray batch (minimum) and the cold one (caches flushed first). "
      "Last-level cache misses (the paper's figures in brackets) are not reported: `perf stat` has no hardware "
      "counters on this machine.\n")
    names = [n for _, n in ENCODINGS] + TRIANGLE_BVHS
    w("| mesh | representation | B/tri | random | primary | diffuse | warm 1024 | cold 1024 |")
    w("|---|---|---:|---:|---:|---:|---:|---:|")
    for run in runs:
        r = rows(run)
        e = r.get("embree")
        if not e:
            continue
        for n in names:
            x = r.get(n)
            if not x:
                continue
            cells = [ratio(x.get(f"{wl}_mrays_1t"), e.get(f"{wl}_mrays_1t")) for wl in ("random", "primary", "diffuse")]
            cells += [ratio(e.get("random_us_per_1024"), x.get("random_us_per_1024")),
                      ratio(e.get("random_us_per_1024_cold"), x.get("random_us_per_1024_cold"))]
            label = f"**{n}**" if n == OURS else n
            w(f"| {mesh_name(run)} | {label} | {fmt(x['bytes_per_tri_total'])} | " + " | ".join(fmt(c) for c in cells) + " |")
    w("")

    w("## Table 3: error of each displacement encoding\n")
    w("The largest and RMS distance of a decoded sub-grid vertex from the mesh's (scene units), and per "
      "sub-grid the largest error over the sub-grid's box diagonal, averaged and maximal over the sub-grids "
      "(the paper's Diag(%)). `oct` and `exp` are the paper's two encodings (§4.1), `fix` ours (the default).\n")
    w("| mesh | encoding | max | RMS | per sub-grid avg | per sub-grid max |")
    w("|---|---|---:|---:|---:|---:|")
    for run in runs:
        r = rows(run)
        for enc, n in ENCODINGS:
            x = r.get(n)
            d = DETAIL.search(x["detail"]) if x and x.get("detail") else None
            if not d:
                continue
            w(f"| {mesh_name(run)} | {enc} | {float(d['max']):.3g} | {float(d['rms']):.3g} | "
              f"{d['ravg'] or '-'}% | {d['rmax'] or '-'}% |")
    w("")
    print("\n".join(out))


if __name__ == "__main__":
    main(sys.argv[1:])
