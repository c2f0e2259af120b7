#!/usr/bin/python3
"""Frames per second of packrt-mpi on N nodes, from per-tile times measured on one machine.

Each node runs one rank of T threads (this host: 2 cores). A frame costs
  max over ranks (the rank's tiles, rendered as packrt-mpi renders them)
  + the gather (bytes from the other ranks into rank 0's link) + the frame's collectives.
The per-tile times (`packrt-mpi --threads 1 --super-tile 1 --tile-times F`, one rank: each
8x8 tile's seconds in the renderer's tile order) fix each view's cost map; with --anchor the map
is scaled so that one node's modelled frame equals a measured frame of a bigger model (the
355M Mandelbulb's times in docs/results/ooc.md), i.e. the model assumes the bigger model's cost
is spread over the tiles as the measured one's is. ANCHOR: one node's frame at the modelled
size (after --scale).

Inside a rank: a super-tile's tiles go to T threads greedily in order (OpenMP dynamic), each
tile stretched by 1/E (E: the measured efficiency of T threads against one; they share caches
and memory) and the super-tile ends at the last thread (the loop's barrier).
Static: super-tile s to rank s mod N. Dynamic: each super-tile, in order, to the rank free first
(rank 0's answer latency hidden by the worker's second queued super-tile: not modelled).
Gather: (N-1)/N of W x H x B bytes into rank 0's link (B = 3, or 52-64 with gi's filter), plus
one latency per rank; collectives (barrier, allreduces): 4 log2(N) latencies.
Not modelled: block loads (a converged view loads none; a moving camera loads on every rank what
its tiles need), rank 0's PNG writing, network contention beyond rank 0's link.

Usage: mpi_model.py VIEW=TILES[@ANCHOR_SECONDS] ... [--threads 2] [--eff E] [--gbps 10]
                    [--latency-us 20] [--bytes-per-pixel 3] [--nodes 1,2,4,...] [--scale K] [--super N]
                    [--width 1024 --height 768: the measured tile maps' image]
       mpi_model.py --check MAP RUN: each rank's CPU seconds in RUN (a multi-rank --tile-times
                    file, --threads 1) against the replay of MAP (one rank) over its tiles
--scale K: the image K x K times the pixels (each tile split into K*K tiles of 1/K^2 its time).
"""
import math
import sys


def read_tiles(path):
    """Per-tile seconds in tile order (files written with --super-tile 1)."""
    t = {}
    for line in open(path):
        if line.startswith("#") or not line.strip():
            continue
        f = line.split()
        if int(f[2]) != 1:
            sys.exit(f"mpi_model.py: {path}: written with super-tiles of {f[2]} tiles; use --super-tile 1")
        # The rendering thread's CPU seconds: the tile's cost on a loaded machine too.
        t[int(f[1])] = float(f[5] if len(f) > 5 else f[4])
    return [t[i] for i in range(len(t))]


def super_time(tiles, threads, eff):
    """One super-tile on `threads` threads: greedy in order, ends at the last thread."""
    if threads == 1:
        return sum(tiles) / eff
    free = [0.0] * threads
    for t in tiles:
        i = free.index(min(free))
        free[i] += t / eff
    return max(free)


def super_size(ntiles, ranks, fixed=0):
    """packrt-mpi's default: up to 64 tiles, fewer so that each rank gets at least 16."""
    if fixed:
        return fixed
    return max(1, min(64, ntiles // (16 * ranks)))


SUPER = 0  # --super N: every frame in super-tiles of N tiles (0: packrt-mpi's default)


def render_time(tiles, ranks, threads, eff, balance, fixed=0):
    fixed = fixed or SUPER
    s = super_size(len(tiles), ranks, fixed)
    supers = [super_time(tiles[i:i + s], threads, eff) for i in range(0, len(tiles), s)]
    busy = [0.0] * ranks
    if balance == "static":
        for k, t in enumerate(supers):
            busy[k % ranks] += t
    else:
        for t in supers:
            i = busy.index(min(busy))
            busy[i] += t
    return max(busy), sum(busy) / ranks


def frame_time(tiles, ranks, threads, eff, balance, pixels, bpp, gbps, lat):
    r, mean = render_time(tiles, ranks, threads, eff, balance)
    gather = (ranks - 1) / ranks * pixels * bpp / (gbps * 1e9 / 8) + (ranks - 1) * lat
    sync = 4 * math.log2(ranks) * lat if ranks > 1 else 0.0
    return r + gather + sync, r, mean, gather


def check(map_path, run_path):
    """The replay against a run: each rank's CPU seconds in RUN (a multi-rank --tile-times file)
    against the sum of MAP's per-tile seconds (one rank, --super-tile 1) over the same tiles."""
    tiles = read_tiles(map_path)
    measured, predicted = {}, {}
    for line in open(run_path):
        if line.startswith("#") or not line.strip():
            continue
        f = line.split()
        first, n, rank, cpu = int(f[1]), int(f[2]), int(f[3]), float(f[5])
        measured[rank] = measured.get(rank, 0.0) + cpu
        predicted[rank] = predicted.get(rank, 0.0) + sum(tiles[first:first + n])
    ranks = sorted(measured)
    for r in ranks:
        print(f"{run_path}: rank {r}: measured {measured[r]:.3f} s CPU, replayed {predicted[r]:.3f} s "
              f"({measured[r] / predicted[r]:.2f}x)")
    imb = lambda d: max(d.values()) / (sum(d.values()) / len(d))
    print(f"{run_path}: imbalance (slowest rank / mean): measured {imb(measured):.3f}, replayed {imb(predicted):.3f}; "
          f"total CPU measured {sum(measured.values()):.3f} s, one-rank map {sum(tiles):.3f} s")


def main(argv):
    opts = {"threads": 2, "eff": 0.9, "gbps": 10.0, "latency-us": 20.0, "bytes-per-pixel": 3.0,
            "nodes": "1,2,4,8,16,32,64", "scale": 1, "width": 1024, "height": 768}
    views, i = [], 0
    if argv and argv[0] == "--check":
        check(argv[1], argv[2])
        return
    while i < len(argv):
        a = argv[i]
        if a.startswith("--"):
            opts[a[2:]] = argv[i + 1]
            i += 2
            continue
        name, spec = a.split("=", 1)
        path, _, anchor = spec.partition("@")
        views.append((name, read_tiles(path), float(anchor) if anchor else None))
        i += 1
    threads, eff = int(opts["threads"]), float(opts["eff"])
    gbps, lat, bpp = float(opts["gbps"]), float(opts["latency-us"]) * 1e-6, float(opts["bytes-per-pixel"])
    k = int(opts["scale"])
    global SUPER
    SUPER = int(opts.get("super", 0))
    nodes = [int(n) for n in str(opts["nodes"]).split(",")]
    pixels = int(opts["width"]) * int(opts["height"]) * k * k
    print(f"# {threads} threads a node at efficiency {eff}, {gbps} Gb/s into rank 0, {lat * 1e6:.0f} us latency, "
          f"{bpp:g} B a pixel gathered, {pixels} pixels")
    table = {}
    for name, tiles, anchor in views:
        if k > 1:
            tiles = [t / (k * k) for t in tiles for _ in range(k * k)]
        one, _, _, _ = frame_time(tiles, 1, threads, eff, "static", pixels, bpp, gbps, lat)
        scale = anchor / one if anchor else 1.0
        tiles = [t * scale for t in tiles]
        print(f"# {name}: {len(tiles)} tiles, one node {one * scale:.3f} s"
              + (f" (anchored: measured tile map x {scale:.2f})" if anchor else ""))
        for bal in ("static", "dynamic"):
            base = frame_time(tiles, 1, threads, eff, bal, pixels, bpp, gbps, lat)[0]
            for n in nodes:
                f, r, mean, g = frame_time(tiles, n, threads, eff, bal, pixels, bpp, gbps, lat)
                table.setdefault((bal, n), []).append((name, f, r, mean, g, base / (n * f)))
    print("| balance | nodes | mean of the views' fps | " + " | ".join(
        f"{v[0]}: fps, eff., imbalance, gather ms" for v in views) + " |")
    print("|---|---:|---:|" + "---|" * len(views))
    for (bal, n), rows in table.items():
        fps = sum(1 / f for _, f, _, _, _, _ in rows) / len(rows)
        cells = " | ".join(f"{1 / f:.1f}, {e:.2f}, {r / mean:.2f}, {g * 1e3:.1f}" for _, f, r, mean, g, e in rows)
        print(f"| {bal} | {n} | {fps:.1f} | {cells} |")


if __name__ == "__main__":
    main(sys.argv[1:])
