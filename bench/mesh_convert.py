#!/usr/bin/env python3
"""Convert a binary PLY as packrt writes it (float x y z, list uchar int vertex_indices, no
colours) to binary STL, OFF or GLB, for the format load benchmarks (docs/results/formats.md).
Usage: bench/mesh_convert.py in.ply out.stl|out.off|out.glb   (needs numpy)"""
import json
import struct
import sys

import numpy as np


def read_ply(path):
    with open(path, "rb") as f:
        head = b""
        while not head.endswith(b"end_header\n"):
            head += f.readline()
        lines = head.decode().split("\n")
        nv = nf = 0
        for ln in lines:
            if ln.startswith("element vertex"):
                nv = int(ln.split()[2])
            if ln.startswith("element face"):
                nf = int(ln.split()[2])
        if "property uchar red" in head.decode() or "material_index" in head.decode():
            sys.exit("only plain float x y z / uchar int lists are converted")
        v = np.fromfile(f, dtype="<f4", count=3 * nv).reshape(nv, 3)
        fd = np.fromfile(f, dtype=np.dtype([("n", "u1"), ("i", "<i4", (3,))]), count=nf)
        if (fd["n"] != 3).any():
            sys.exit("only triangles are converted")
        return v, fd["i"].astype("<u4")


def write_stl(path, v, t):
    rec = np.zeros(len(t), dtype=np.dtype([("n", "<f4", (3,)), ("c", "<f4", (9,)), ("a", "<u2")]))
    c = v[t]  # (T, 3, 3)
    n = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    rec["n"] = np.where(ln > 0, n / np.where(ln > 0, ln, 1), 0)
    rec["c"] = c.reshape(len(t), 9)
    with open(path, "wb") as f:
        f.write(b"binary STL from bench/mesh_convert.py".ljust(80, b" "))
        f.write(struct.pack("<I", len(t)))
        rec.tofile(f)


def write_off(path, v, t):
    with open(path, "w") as f:
        f.write("OFF\n%d %d 0\n" % (len(v), len(t)))
        np.savetxt(f, v, fmt="%.9g")
        np.savetxt(f, np.hstack([np.full((len(t), 1), 3, dtype=np.int64), t.astype(np.int64)]), fmt="%d")


def write_glb(path, v, t):
    vb, ib = v.astype("<f4").tobytes(), t.astype("<u4").tobytes()
    gltf = {
        "asset": {"version": "2.0", "generator": "packrt bench/mesh_convert.py"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(vb) + len(ib)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(vb)},
                        {"buffer": 0, "byteOffset": len(vb), "byteLength": len(ib)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(v), "type": "VEC3",
                       "min": v.min(0).tolist(), "max": v.max(0).tolist()},
                      {"bufferView": 1, "componentType": 5125, "count": t.size, "type": "SCALAR"}],
    }
    js = json.dumps(gltf).encode()
    js += b" " * (-len(js) % 4)
    binary = vb + ib
    binary += b"\0" * (-len(binary) % 4)
    with open(path, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(binary)))
        f.write(struct.pack("<II", len(js), 0x4E4F534A) + js)
        f.write(struct.pack("<II", len(binary), 0x004E4942) + binary)


if __name__ == "__main__":
    v, t = read_ply(sys.argv[1])
    out = sys.argv[2]
    {"stl": write_stl, "off": write_off, "glb": write_glb}[out.rsplit(".", 1)[1].lower()](out, v, t)
