"""python/examples/depth.py renders a readable PNG: the cube in the middle, background black."""
import os
import struct
import subprocess
import sys
import zlib

import numpy as np

import reference as R

EXAMPLE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples", "depth.py")


def read_png_gray(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, size = 8, b"", None
    while pos < len(data):
        n, tag = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        assert struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])[0] == zlib.crc32(tag + body) & 0xFFFFFFFF
        if tag == b"IHDR":
            size = struct.unpack(">II", body[:8])
        elif tag == b"IDAT":
            idat += body
        pos += 12 + n
    w, h = size
    rows = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, w + 1)
    assert (rows[:, 0] == 0).all()
    return rows[:, 1:]


def test_depth_example_writes_a_png_of_the_mesh(tmp_path):
    v, t = R.cube()
    R.write_ply(tmp_path / "c.ply", v, t)
    out = tmp_path / "d.png"
    run = subprocess.run([sys.executable, EXAMPLE, str(tmp_path / "c.ply"), "-o", str(out), "--size", "64x48"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    img = read_png_gray(out)
    assert img.shape == (48, 64)
    assert img[24, 32] > 0 and img[0, 0] == 0 and img.max() == 255
