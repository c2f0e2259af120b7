#!/usr/bin/env python3
"""Merge several `packrt bench --matrix` outputs for one mesh into one: every numeric cell
of every table becomes the median over the runs (per row and column, so one noisy run on a
shared machine does not decide a cell), the vs-Embree ratios are recomputed from the
medians, and the main table is sorted again by warm time. The text around the tables is
the first run's. Usage: matrix_median.py RUN.md RUN.md ... > merged.md"""
import re
import statistics
import sys


def tables(lines):
    """[(first line index, last + 1)] of every markdown table."""
    out, i = [], 0
    while i < len(lines):
        if lines[i].startswith("|"):
            j = i
            while j < len(lines) and lines[j].startswith("|"):
                j += 1
            out.append((i, j))
            i = j
        else:
            i += 1
    return out


def cells(line):
    return [c.strip() for c in line.strip().strip("|").split("|")]


def num(cell):
    try:
        return float(cell.rstrip("x"))
    except ValueError:
        return None


def decimals(cell):
    m = re.match(r"^-?\d+\.(\d+)$", cell)
    return len(m.group(1)) if m else 0


runs = [open(p).read().splitlines() for p in sys.argv[1:]]
base = runs[0]
spans = [tables(r) for r in runs]
out, pos, embree = [], 0, None
for t, (a, b) in enumerate(spans[0]):
    out.extend(base[pos:a])
    pos = b
    head = cells(base[a])
    rows = {}
    for r, sp in zip(runs, spans):
        if t >= len(sp):
            continue
        for line in r[sp[t][0] + 2:sp[t][1]]:
            c = cells(line)
            rows.setdefault(c[0], []).append(c[1:])
    merged = []
    for line in base[a + 2:b]:
        c = cells(line)
        name, first = c[0], c[1:]
        cols = []
        for j, cell in enumerate(first):
            vals = [num(v[j]) for v in rows[name] if j < len(v) and num(v[j]) is not None]
            if j + 1 >= len(head) or num(cell) is None or head[j + 1] in ("vs Embree", "vertex error") or not vals:
                cols.append(cell)
            else:
                cols.append(("%." + str(decimals(cell)) + "f") % statistics.median(vals))
        merged.append([name] + cols)
    if head[0] == "representation":
        for m in merged:
            if m[0] == "embree":
                embree = {h: num(v) for h, v in zip(head, m)}
        for m in merged:  # ratios from the medians, against the main table's Embree
            if len(m) != len(head):
                continue  # "cannot be built" rows span the table in one cell
            for j, h in enumerate(head):
                if h == "vs Embree" and embree:
                    ref = head[j - 1] if head[j - 1] in ("warm µs/1024", "total B/tri") else "total B/tri"
                    x, e = num(m[head.index(ref)]), embree.get(ref)
                    if x is not None and e:
                        m[j] = "%.2fx" % (x / e)
        if "warm µs/1024" in head and any(m[0] == "embree" for m in merged):
            w = head.index("warm µs/1024")
            merged.sort(key=lambda m: num(m[w]) if len(m) > w and num(m[w]) is not None else 1e30)
    out.append(base[a])
    out.append(base[a + 1])
    out.extend("| " + " | ".join(m) + " |" for m in merged)
out.extend(base[pos:])
text = "\n".join(out)
text = text.replace("### Every representation, fastest first",
                    "### Every representation, fastest first (each cell the median of %d runs)" % len(runs), 1)
print(text)
