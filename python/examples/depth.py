#!/usr/bin/env python3
"""Render the depth image of a mesh to an 8-bit grayscale PNG (near = bright, background
black) with packrt's Open3D-style API.

    /usr/bin/python3 python/examples/depth.py [MESH.ply|.obj] [-o depth.png] [--size 640x480]

Without a mesh it renders a generated terrain (packrt gen's "terrain"). The PNG is written
with the standard library's zlib, no imaging package needed.
"""
import argparse
import os
import struct
import sys
import zlib

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))  # python/ in a checkout
import packrt  # noqa: E402


def write_png_gray(path, img):
    """An 8-bit grayscale PNG of a (h, w) uint8 array: signature, IHDR, one IDAT, IEND."""
    h, w = img.shape

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    rows = np.concatenate([np.zeros((h, 1), np.uint8), img], axis=1)  # filter type 0 per row
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(rows.tobytes(), 6)) + chunk(b"IEND", b""))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mesh", nargs="?", help="PLY or OBJ file (default: a generated terrain)")
    ap.add_argument("-o", "--output", default="depth.png")
    ap.add_argument("--size", default="640x480", help="WIDTHxHEIGHT")
    ap.add_argument("--spec", default=None, help="packrt representation (default: packrt.DEFAULT_SPEC)")
    args = ap.parse_args()
    w, h = (int(x) for x in args.size.lower().split("x"))

    try:
        scene = (packrt.Scene.from_file(args.mesh, spec=args.spec) if args.mesh
                 else packrt.Scene.generate("terrain", 200_000, spec=args.spec))
    except packrt.Error as e:
        sys.exit(f"depth.py: {e}")
    lo, hi = (b.astype(np.float64) for b in scene.bounds())
    center, diag = (lo + hi) / 2, np.linalg.norm(hi - lo)
    eye = center + diag * np.array([0.35, 0.45, 0.9])  # in front (+z), above and to the right
    # Open3D's pinhole rays: unit depth along the view axis, so t_hit is the z distance. Its
    # image x runs along cross(up, view) and y along up: half a turn from the usual picture.
    rays = packrt.Scene.create_rays_pinhole(50.0, center, eye, [0, 1, 0], w, h)
    ans = scene.cast_rays(rays)
    depth = np.rot90(ans["t_hit"], 2)

    hit = np.isfinite(depth)
    img = np.zeros((h, w), np.uint8)
    if hit.any():
        near, far = depth[hit].min(), depth[hit].max()
        img[hit] = (255 - 200 * (depth[hit] - near) / max(far - near, 1e-12)).astype(np.uint8)
    write_png_gray(args.output, img)
    st = scene.stats()
    print(f"{args.output}: {w}x{h}, {hit.mean():.0%} of pixels hit; {st['spec']}, {st['triangles']} triangles, "
          f"{st['bytes_per_triangle']:.1f} B/tri")


if __name__ == "__main__":
    main()
