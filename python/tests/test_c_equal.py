"""Bit-for-bit equality with the C library and the answers under threads: cast_rays against
prt_intersect1 called ray by ray, against the `packrt cast` CLI through .rays/.hits files,
and against itself on one thread, many threads and concurrent Python threads."""
import faulthandler
import os
import shutil
import subprocess
import sys
import threading

import cffi
import numpy as np
import pytest

import packrt
import reference as R
from packrt._ffi import ffi, lib


def sphere_scene(spec=None):
    return packrt.Scene(*R.icosphere(3), spec=spec)


def test_cast_rays_equals_prt_intersect1_ray_by_ray():
    scene = sphere_scene()
    rays = R.random_rays(2000, seed=21)
    ans = scene.cast_rays(rays, tnear=0.1, tfar=4.0)
    r = ffi.new("prt_ray *")
    h = ffi.new("prt_hit *")
    for i in range(len(rays)):
        r.org = list(map(float, rays[i, :3]))
        r.dir = list(map(float, rays[i, 3:]))
        r.tnear, r.tfar = 0.1, 4.0
        lib.prt_intersect1(scene._accel, r, h)
        got = np.array([ans["t_hit"][i], *ans["primitive_uvs"][i]], np.float32)
        want = np.array([h.t, h.u, h.v], np.float32)
        assert got.tobytes() == want.tobytes(), i
        assert ans["primitive_ids"][i] == h.prim


def find_cli():
    path = os.environ.get("PACKRT_CLI") or os.path.join(os.path.dirname(__file__), "..", "..", "build", "packrt")
    return path if os.path.exists(path) else shutil.which("packrt")


def test_cast_rays_equals_the_cli_cast_bit_for_bit(tmp_path):
    cli = find_cli()
    if not cli:
        pytest.skip("no packrt CLI (set PACKRT_CLI)")
    scene = sphere_scene("wide8:float3-soa8")
    scene.save(tmp_path / "s.prt")
    rays = R.random_rays(5000, seed=22)
    rec = np.zeros((len(rays), 8), np.float32)
    rec[:, :3], rec[:, 4:7], rec[:, 7] = rays[:, :3], rays[:, 3:], np.inf
    (tmp_path / "in.rays").write_bytes(b"PRTRAYS1" + np.uint64(len(rays)).tobytes() + rec.tobytes())
    subprocess.run([cli, "cast", str(tmp_path / "s.prt"), "--rays", str(tmp_path / "in.rays"), "-o",
                    str(tmp_path / "out.hits")], check=True, capture_output=True)
    data = (tmp_path / "out.hits").read_bytes()
    assert data[:8] == b"PRTHITS1" and np.frombuffer(data[8:16], np.uint64)[0] == len(rays)
    hits = np.frombuffer(data[16:], np.dtype([("t", "<f4"), ("prim", "<u4"), ("u", "<f4"), ("v", "<f4")]))
    ans = scene.cast_rays(rays)
    assert ans["t_hit"].tobytes() == hits["t"].tobytes()
    assert ans["primitive_ids"].tobytes() == hits["prim"].tobytes()
    hit = hits["prim"] != packrt.INVALID_ID
    assert hit.sum() > 1000
    assert ans["primitive_uvs"][hit].tobytes() == np.stack([hits["u"], hits["v"]], -1)[hit].tobytes()


@pytest.mark.parametrize("threads", [2, 3, 0])
def test_threads_give_the_answers_of_one_thread(threads):
    scene = sphere_scene()
    rays = R.random_rays(20000, seed=23)  # many STREAM_CHUNKs of 256 rays
    one = scene.cast_rays(rays, threads=1)
    many = scene.cast_rays(rays, threads=threads)
    for k in one:
        assert one[k].tobytes() == many[k].tobytes()
    assert np.array_equal(scene.test_occlusions(rays, tfar=2.0, threads=1),
                          scene.test_occlusions(rays, tfar=2.0, threads=threads))


def test_concurrent_python_threads_get_the_serial_answers():
    scene = sphere_scene()
    batches = [R.random_rays(20000, seed=s) for s in range(4)]
    want = [scene.cast_rays(b, threads=1)["t_hit"] for b in batches]
    got = [None] * 4

    def work(i):
        got[i] = scene.cast_rays(batches[i], threads=1)["t_hit"]

    ts = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in ts:
        t.start()
    for t in ts:
        t.join(timeout=120)
    assert all(g is not None and g.tobytes() == w.tobytes() for g, w in zip(got, want))


def test_cffi_releases_the_gil_around_c_calls():
    # The packrt calls are ordinary cffi ABI-mode calls, and cffi releases the GIL around
    # every C call (cffi's reference, the conversion table's note since cffi 0.3: "C function
    # calls are done with the GIL released"; ABI and API modes alike). Checked here without
    # timing: a thread
    # blocks inside a C read() that only this thread's write can finish. Were the GIL held
    # during the call, this thread could never write and faulthandler would end the run.
    libc_ffi = cffi.FFI()
    libc_ffi.cdef("long read(int fd, void *buf, unsigned long n);")
    libc = libc_ffi.dlopen(None)
    rfd, wfd = os.pipe()
    buf = libc_ffi.new("char[1]")
    result = []
    entering = threading.Event()

    def reader():
        entering.set()
        result.append(libc.read(rfd, buf, 1))

    old = sys.getswitchinterval()
    sys.setswitchinterval(1.0)  # the reader keeps the GIL from set() into read() unless the call drops it
    faulthandler.dump_traceback_later(60, exit=True)
    try:
        t = threading.Thread(target=reader, daemon=True)
        t.start()
        entering.wait()
        os.write(wfd, b"x")
        t.join(timeout=30)
    finally:
        faulthandler.cancel_dump_traceback_later()
        sys.setswitchinterval(old)
        os.close(rfd)
        os.close(wfd)
    assert result == [1] and buf[0] == b"x"
