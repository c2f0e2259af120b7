#!/usr/bin/env python3
"""Turn `packrt bench --json` outputs into the Markdown tables of docs/results/.

Usage: results_md.py TITLE COMMAND RESULT.json... > out.md
Every figure comes from the JSON files; nothing is typed in by hand."""
import json
import sys


def fmt(x, digits=2):
    return "n/a" if x is None else f"{x:.{digits}f}"


def table(d):
    rows = d["results"]
    emb = next((r for r in rows if r["name"] == "embree"), None)
    out = []
    m = d["mesh"]
    out.append(f"### {m['path'].split('/')[-1]}: {m['triangles']:,} triangles, {m.get('vertices') or 0:,} vertices\n")
    out.append(f"Load average at start: {d.get('load_average')}; threads for mt: {d.get('threads')}; "
               f"repetitions: {d.get('reps')}; rays: {d.get('rays')}; primary image {d.get('size')}.\n")
    wl = [w for w in ("random", "primary", "shadow", "diffuse") if f"{w}_mrays_1t" in rows[0]]
    head = ["representation", "build s", "B/tri tree", "B/tri geom", "B/tri total", "random µs/1024 warm",
            "cold µs/ray"] + [f"{w} Mrays/s 1t / mt" for w in wl]
    if emb:
        head += ["time vs Embree", "memory vs Embree"]
    out.append("| " + " | ".join(head) + " |")
    out.append("|" + "---|" * len(head))
    for r in rows:
        cells = [f"`{r['name']}`", fmt(r["build_s"], 3), fmt(r["bytes_per_tri_tree"]), fmt(r["bytes_per_tri_geometry"]),
                 fmt(r["bytes_per_tri_total"]), fmt(r["random_us_per_1024"], 1), fmt(r.get("random_us_per_ray_cold"), 3)]
        cells += [f"{fmt(r.get(w + '_mrays_1t'))} / {fmt(r.get(w + '_mrays_mt'))}" for w in wl]
        if emb:
            cells.append(fmt(r["random_us_per_1024"] / emb["random_us_per_1024"]) + "x")
            cells.append(fmt(r["bytes_per_tri_total"] / emb["bytes_per_tri_total"]) + "x")
        out.append("| " + " | ".join(cells) + " |")
    checks = []
    for r in rows:
        if r["name"] == "embree":
            continue
        parts = [f"{w} {r.get(w + '_check_disagreements', 'n/a')}" for w in wl]
        checks.append(f"`{r['name']}`: " + ", ".join(parts))
    if emb:
        out.append("\nHit/miss disagreements with Embree on the same rays: " + "; ".join(checks) + ".\n")
    return "\n".join(out)


def main():
    title, command, files = sys.argv[1], sys.argv[2], sys.argv[3:]
    docs = [json.load(open(f)) for f in files]
    d0 = docs[0]
    print(f"# {title}\n")
    print(f"Machine: {d0['machine']}. Commit: `{d0['commit']}`. Made by:\n\n```\n{command}\n```\n")
    print("Columns (docs/benchmark.md): build wall-clock seconds; bytes per triangle that a query touches, "
          "tree + geometry = total; random µs per 1024 rays: warm, one thread, single-ray queries, minimum over "
          "repetitions; cold µs per ray: caches flushed before each batch of 1024, median (Rouwé's unit); "
          "Mrays/s: median, one thread / all threads; ratios: ours over Embree's from the same run "
          "(lower is better for both).\n")
    for d in docs:
        print(table(d))
        print()


main()
