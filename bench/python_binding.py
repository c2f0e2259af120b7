#!/usr/bin/env python3
"""The cost of the Python binding: rays per second through packrt.Scene.cast_rays against the
same rays through prt_intersect_stream called directly (cffi, preallocated prt_ray/prt_hit
arrays, only the C call timed; "C fresh": the same call writing into a newly allocated hit
array, as cast_rays must), at 1K, 64K and 1M rays, interleaved in one process; median of
--runs. Results: docs/results/python.md.

    PACKRT_LIBRARY=build/libpackrt.so /usr/bin/python3 bench/python_binding.py [--runs 9]

With the CLI (--cli, default build/packrt) it then runs `packrt bench` on the same mesh and
spec (random workload, streams) for the C stream's rate against Embree's in the same run.
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
import packrt  # noqa: E402
from packrt._ffi import ffi, lib  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--kind", default="terrain")
    ap.add_argument("--tris", type=int, default=200_000)
    ap.add_argument("--spec", default=None)
    ap.add_argument("--runs", type=int, default=9)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--cli", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "build", "packrt"))
    args = ap.parse_args()
    tmp = tempfile.mkdtemp()
    ply = os.path.join(tmp, "mesh.ply")
    if os.path.exists(args.cli):  # the same mesh for the CLI bench below
        subprocess.run([args.cli, "gen", args.kind, "--tris", str(args.tris), "-o", ply], check=True,
                       capture_output=True)
        scene = packrt.Scene.from_file(ply, spec=args.spec)
    else:
        scene = packrt.Scene.generate(args.kind, args.tris, spec=args.spec)
    lo, hi = (b.astype(np.float64) for b in scene.bounds())
    center, diag = (lo + hi) / 2, np.linalg.norm(hi - lo)
    eye = center + diag * np.array([0.35, 0.45, 0.9])
    st = scene.stats()
    print(f"library {packrt.library_path}; {args.kind} {st['triangles']} triangles, {st['spec']}, "
          f"median of {args.runs}")
    # Wall clock: 1K rays on one thread (the binding's own cost, without waking OpenMP's
    # team), then 1K, 64K and 1M rays of the same view on --threads. Then the calling
    # thread's CPU time (time.thread_time) with every call on that one thread: other
    # processes taking the cores do not count in it, so it holds on a loaded machine.
    print("wall clock")
    table(scene, center, eye, args.runs, time.perf_counter,
          ((32, 1), (32, args.threads), (256, args.threads), (1024, args.threads)))
    print("CPU time of the calling thread, one thread")
    table(scene, center, eye, args.runs, time.thread_time, ((32, 1), (256, 1), (1024, 1)))

    if os.path.exists(ply):
        print(f"\n{args.cli} bench (same mesh and spec; its random workload goes through prt_intersect_stream):")
        out = subprocess.run([args.cli, "bench", ply, "-r", st["spec"], "--workload", "random", "--no-cold",
                              "--threads", str(args.threads)], check=True, capture_output=True, text=True).stdout
        print(out)
        os.remove(ply)
    os.rmdir(tmp)



def table(scene, center, eye, runs, clock, configs):
    print(f"{'rays':>8} {'thr':>3} {'C Mrays/s':>10} {'Py Mrays/s':>10} {'Py/C':>6} {'C us':>9} {'Py us':>9} "
          f"{'overhead us':>11} {'no-normals':>10} {'overhead us':>12} {'C fresh':>10}")
    for side, threads in configs:
        rays6 = packrt.Scene.create_rays_pinhole(50.0, center, eye, [0, 1, 0], side, side).reshape(-1, 6)
        n = len(rays6)
        pristine = np.zeros((n, 8), np.float32)
        pristine[:, :3], pristine[:, 4:7], pristine[:, 7] = rays6[:, :3], rays6[:, 3:], np.inf
        work = pristine.copy()
        hits = np.empty((n, 5), np.float32)
        c_rays, c_hits = ffi.from_buffer("prt_ray[]", work), ffi.from_buffer("prt_hit[]", hits)
        tc, tf, tp, tl = [], [], [], []
        for _ in range(runs):
            np.copyto(work, pristine)  # the stream shrinks tfar: fresh rays, outside the clock
            t0 = clock()
            lib.prt_intersect_stream(scene._accel, c_rays, c_hits, n, threads)
            tc.append(clock() - t0)
            np.copyto(work, pristine)  # again, into a fresh hit array as cast_rays must return one
            t0 = clock()
            fresh = np.empty((n, 5), np.float32)
            lib.prt_intersect_stream(scene._accel, c_rays, ffi.from_buffer("prt_hit[]", fresh), n, threads)
            tf.append(clock() - t0)
            del fresh
            t0 = clock()
            ans = scene.cast_rays(rays6, threads=threads)
            tp.append(clock() - t0)
            t0 = clock()
            scene.cast_rays(rays6, threads=threads, normals=False)
            tl.append(clock() - t0)
        assert ans["t_hit"].tobytes() == hits[:, 0].tobytes()  # the same answers, bit for bit
        c, f, p, q = np.median(tc), np.median(tf), np.median(tp), np.median(tl)
        print(f"{n:>8} {threads or os.cpu_count():>3} {n / c / 1e6:>10.2f} {n / p / 1e6:>10.2f} {c / p:>6.3f} "
              f"{c * 1e6:>9.1f} {p * 1e6:>9.1f} {(p - c) * 1e6:>11.1f} {c / q:>10.3f} {(q - c) * 1e6:>12.1f} "
              f"{c / f:>10.3f}")


if __name__ == "__main__":
    main()
