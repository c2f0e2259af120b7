#!/usr/bin/env python3
"""Before/after table from repeated bench/lossygrid.sh runs (one JSON per mesh per run).

Usage: bench/lossygrid_ab.py [--spec SPEC] LABEL=DIR[,DIR...] ...
Each DIR holds the JSON files of one run (OUT= of bench/lossygrid.sh). For every mesh and
workload it prints, per label, the median over the runs of SPEC's rate over Embree's in the
same process (random, primary, diffuse: Mrays/s; warm and cold: Embree's time over ours) and
the range, as a markdown table, with the load averages the runs started at.
"""
import json
import os
import statistics
import sys

COLUMNS = [("random", "random_mrays_1t", False), ("primary", "primary_mrays_1t", False),
           ("diffuse", "diffuse_mrays_1t", False), ("warm 1024", "random_us_per_1024", True),
           ("cold 1024", "random_us_per_1024_cold", True)]


def ratios(path, spec):
    d = json.load(open(path))
    rows = {r["name"]: r for r in d["results"]}
    ours, ref = rows.get(spec), rows.get("embree")
    if not ours or not ref:
        return None, None
    out = {}
    for col, key, inverse in COLUMNS:
        a, b = ours.get(key), ref.get(key)
        if a and b:
            out[col] = b / a if inverse else a / b
    mesh = os.path.splitext(os.path.basename(path))[0]
    return mesh, (out, d.get("load_average"))


def main(argv):
    spec = "lossygrid,ids=none"
    if len(argv) > 2 and argv[1] == "--spec":
        spec, argv = argv[2], [argv[0]] + argv[3:]
    labels, data, loads = [], {}, {}
    for arg in argv[1:]:
        label, dirs = arg.split("=", 1)
        labels.append(label)
        for d in dirs.split(","):
            for f in sorted(os.listdir(d)):
                if not f.endswith(".json"):
                    continue
                mesh, got = ratios(os.path.join(d, f), spec)
                if not mesh:
                    continue
                for col, v in got[0].items():
                    data.setdefault((mesh, col), {}).setdefault(label, []).append(v)
                if got[1] is not None:
                    loads.setdefault(label, []).append(got[1])
    print("| mesh | workload | " + " | ".join(f"{l} (median, range)" for l in labels) + " |")
    print("|---|---|" + "---:|" * len(labels))
    for (mesh, col) in sorted(data, key=lambda k: (k[0], [c[0] for c in COLUMNS].index(k[1]))):
        cells = []
        for l in labels:
            v = data[(mesh, col)].get(l)
            cells.append(f"**{statistics.median(v):.2f}** ({min(v):.2f}-{max(v):.2f}, {len(v)} runs)" if v else "-")
        print(f"| {mesh} | {col} | " + " | ".join(cells) + " |")
    for l in labels:
        if loads.get(l):
            la = [x if isinstance(x, (int, float)) else x[0] for x in loads[l]]
            print(f"\n{l}: load average at the start of the runs {min(la):.1f}-{max(la):.1f}", end="")
    print()


if __name__ == "__main__":
    main(sys.argv)
