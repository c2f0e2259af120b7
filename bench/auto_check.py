#!/usr/bin/python3
"""What `auto` chooses against the best in its budget, measured in one run (docs/results/auto.md).

For a mesh: measures auto's candidates (and Embree) with `packrt bench --calibrate`, reads
what `packrt info --budget B` says auto would build for each budget, and prints a Markdown
table: auto's choice, its measured memory and time per ray, the fastest measured candidate
within the budget, and their ratio. Auto decides from the built-in cost table (PRT_COSTS is
pointed at nothing), so a mesh other than the ones the table was measured on tests how well
the table carries over.

With --all, every representation (`packrt bench -r all`, plus the cost table's specs with
options, such as ids=none, that `packrt list` does not name) is measured instead of auto's
candidates, so "best in budget" is the best packrt has, not the best auto could choose.

With --report FILE, the bench's JSON report is read from FILE when it exists (no bench is
run: a new cost table judged on the figures measured before) and written to it otherwise.

Usage: bench/auto_check.py PACKRT MESH [--all] [--budgets 8,12,16,24,48,0] [--rounds 3] [--report FILE] [bench options...]
"""
import json
import os
import re
import subprocess
import sys
import tempfile


def table_specs_with_options():
    """The built-in cost table's specs that carry options (`packrt list` names none of them)."""
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src", "api", "auto_costs.tsv")
    with open(path) as f:
        specs = [line.split("\t")[0] for line in f if line.strip() and not line.startswith("#")]
    return sorted({s for s in specs if "," in s})


def measure(packrt, mesh, which, rounds, extra, env):
    """The bench's JSON report on the candidates (which: None) or the given -r list."""
    with tempfile.TemporaryDirectory() as tmp:
        which = which or ["--calibrate", "--costs", os.path.join(tmp, "c.tsv")]
        out = subprocess.run([packrt, "bench", mesh] + which + ["--json",
                              "--workload", "random", "--no-cold", "--threads", "1", "--rounds", rounds] + extra,
                             env=env, capture_output=True, text=True)
    # Exit status 1 with a report: some rows could not be built (idx16 past 65,535 vertices).
    try:
        return json.loads(out.stdout)
    except json.JSONDecodeError:
        sys.exit(out.stderr)


def main():
    args = sys.argv[1:]
    if len(args) < 2:
        sys.exit(__doc__)
    packrt, mesh, rest = args[0], args[1], args[2:]
    budgets, rounds = [8, 12, 16, 24, 48, 0], "3"
    extra = []
    which = None
    saved = None
    i = 0
    while i < len(rest):
        if rest[i] == "--all":
            which = ["-r", "all"] + [a for spec in table_specs_with_options() for a in ("-r", spec)]
            i += 1
        elif rest[i] == "--budgets":
            budgets = [float(b) for b in rest[i + 1].split(",")]
            i += 2
        elif rest[i] == "--report":
            saved = rest[i + 1]
            i += 2
        elif rest[i] == "--rounds":
            rounds = rest[i + 1]
            i += 2
        else:
            extra.append(rest[i])
            i += 1
    env = dict(os.environ, PRT_COSTS="/nonexistent/packrt-costs.tsv")
    if saved and os.path.exists(saved):
        with open(saved) as f:
            report = json.load(f)
    else:
        report = measure(packrt, mesh, which, rounds, extra, env)
        if saved:
            with open(saved, "w") as f:
                json.dump(report, f)
    failed = [r["name"] for r in report["results"] if "error" in r]
    rows = {r["name"]: r for r in report["results"] if "error" not in r}
    tris = report["mesh"]["triangles"]
    print(f"{report['mesh']['path']}: {tris} triangles; {report['machine']}; load {report['load_average']}; "
          f"{report['rounds']} rounds" + (f"; could not build {', '.join(failed)}" if failed else ""))
    print()
    print("| budget B/tri | lossy | ids=none | auto chose | its B/tri | its µs/1024 | best in budget | its B/tri | its µs/1024 | auto / best |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    rows_out = []
    for lossy, order in ((False, False), (False, True), (True, False), (True, True)):
        # One call per combination: the estimates are made once for every budget.
        cmd = [packrt, "info", mesh, "--budget", ",".join(f"{b:g}" if b else "none" for b in budgets)]
        cmd += (["--lossy"] if lossy else []) + (["--order"] if order else [])
        info = subprocess.run(cmd, env=env, capture_output=True, text=True)
        choices = {}
        for m in re.finditer(r"^-r auto(?:,budget=([0-9.]+))?\S* would build (\S+)", info.stdout, re.M):
            choices[float(m.group(1)) if m.group(1) else 0.0] = m.group(2)
        for budget in budgets:
            chose = choices.get(float(budget))
            fits = [r for r in rows.values() if not r["name"].startswith("embree") and (lossy or "vertex_error" not in r)
                    and (order or "ids=none" not in r["name"])
                    and (not budget or r["bytes_per_tri_total"] <= budget) and r.get("random_us_per_1024")]
            best = min(fits, key=lambda r: r["random_us_per_1024"]) if fits else None
            a = rows.get(chose) if chose else None
            label = f"{budget:g}" if budget else "none"
            cells = [label, "yes" if lossy else "no", "yes" if order else "no"]
            if a:
                cells += [chose, f"{a['bytes_per_tri_total']:.1f}", f"{a['random_us_per_1024']:.0f}"]
            else:
                cells += [chose or "(nothing fits)", "-", "-"]
            if best:
                cells += [best["name"], f"{best['bytes_per_tri_total']:.1f}", f"{best['random_us_per_1024']:.0f}"]
            else:
                cells += ["(none fits)", "-", "-"]
            cells.append(f"{a['random_us_per_1024'] / best['random_us_per_1024']:.2f}" if a and best else "-")
            rows_out.append((budget, lossy, order, cells))
    for _, _, _, cells in sorted(rows_out, key=lambda x: (x[0] == 0, x[0], x[1], x[2])):
        print("| " + " | ".join(cells) + " |")
    e = rows.get("embree")
    if e:
        print(f"\nEmbree: {e['bytes_per_tri_total']:.1f} B/tri, {e['random_us_per_1024']:.0f} µs/1024 warm, one thread.")


if __name__ == "__main__":
    main()
