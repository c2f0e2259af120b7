"""packrt.Scene: ray and mesh queries on numpy arrays, named after Open3D's RaycastingScene
(cast_rays, test_occlusions, count_intersections, ...) so that code can switch by its import.

Every query takes arrays of any leading shape (..., 6) for rays (origin, direction) or (..., 3)
for points, float32 (used in place) or float64 (converted once), and answers with arrays of
that leading shape. Calls into the library release the GIL (cffi does so around every C call)
and run on `threads` threads (0: all cores).
"""
import math
import threading

import numpy as np

from ._ffi import CONTAINS_METHODS, PRT_INSIDE, ffi, lib, library_path

#: primitive_ids and geometry_ids of a miss (PRT_INVALID).
INVALID_ID = 0xFFFFFFFF

#: The spec that spec=None builds: lossless, 8-bit local indices under 8-wide nodes, about a
#: fifth of Embree's memory (README). Replaced by the library's `auto` choice once it has one.
DEFAULT_SPEC = "wide8:idx8-soa4"

# prt_hit as numpy sees it: 20 bytes, the fields in the C order.
_HIT = np.dtype([("t", "<f4"), ("u", "<f4"), ("v", "<f4"), ("prim", "<u4"), ("geom", "<u4")])
assert _HIT.itemsize == ffi.sizeof("prt_hit") and ffi.sizeof("prt_ray") == 32
_CLOSEST = np.dtype([("point", "<f4", (3,)), ("distance", "<f4"), ("u", "<f4"), ("v", "<f4"), ("prim", "<u4")])
assert _CLOSEST.itemsize == ffi.sizeof("prt_closest")


class Error(Exception):
    """A failure reported by libpackrt (message from prt_last_error) or bad input caught here.
    `status` is the library's status name (prt_status_string: "invalid argument", "invalid mesh", ...)."""

    def __init__(self, status, message):
        super().__init__(f"{status}: {message}" if message else status)
        self.status = status


def _check(status):
    if status != 0:
        raise Error(ffi.string(lib.prt_status_string(status)).decode(), ffi.string(lib.prt_last_error()).decode())


def _fn(name):
    """A library function of the mesh queries (issue 28), or Error when this library lacks it."""
    try:
        return getattr(lib, name)
    except AttributeError:
        raise Error("unsupported", f"{library_path} has no {name} (a library from before the mesh queries)") from None


def has_mesh_queries():
    """True when the loaded library has the mesh queries (all crossings, closest points, containment)."""
    try:
        for name in ("prt_intersect_all_stream", "prt_closest_points", "prt_contains", "prt_signed_distance"):
            getattr(lib, name)
        return True
    except AttributeError:
        return False


def _threads(threads, nthreads):
    t = threads if nthreads is None else nthreads  # nthreads: Open3D's name
    if not isinstance(t, (int, np.integer)) or isinstance(t, bool) or t < 0:
        raise Error("invalid argument", f"threads must be an int >= 0 (0: all cores), not {t!r}")
    return int(t)


def _floats(a, last, what):
    """a as an array of shape (..., last) of a floating type, or Error."""
    a = np.asarray(a)
    if a.dtype.kind != "f":
        raise Error("invalid argument", f"{what} must be float32 or float64, not {a.dtype}")
    if a.ndim < 1 or a.shape[-1] != last:
        raise Error("invalid argument", f"{what} must have shape (..., {last}), not {a.shape}")
    return a


def _points(points, what="query_points"):
    """(..., 3) points as a contiguous float32 (n, 3) array (no copy when already so)."""
    p = _floats(points, 3, what)
    return np.ascontiguousarray(p.reshape(-1, 3), dtype=np.float32), p.shape[:-1]


# Rays as prt_ray records: 12 bytes of origin, tnear, 12 bytes of direction, tfar.
_RAY_PAIRS = np.dtype([("xyz", "V12"), ("t", "<f4")])
_V12 = np.dtype("V12")
_SCRATCH_MAX = 1 << 21  # rays: a per-thread buffer up to 64 MiB is kept between calls
_scratch = threading.local()


class _RayBuffer:
    """An (n, 8) float32 array of prt_ray records with views of its 12-byte origin and
    direction items and of its tnear/tfar pairs, made once per buffer."""

    def __init__(self, n):
        self.records = np.empty((n, 8), np.float32)
        pairs = self.records.view(_RAY_PAIRS).reshape(n, 2)
        self.xyz, self.t = pairs["xyz"], pairs["t"]


def _ray_buffer(n):
    """A _RayBuffer for at least n rays. The C stream shrinks tfar in place, so every call
    fills one; the calling thread's is reused (up to _SCRATCH_MAX rays) so that repeated
    calls pay neither the allocation nor the first touch of fresh pages."""
    if n > _SCRATCH_MAX:
        return _RayBuffer(n)
    buf = getattr(_scratch, "rays", None)
    if buf is None or len(buf.records) < n:
        buf = _scratch.rays = _RayBuffer(max(n, 1024))
    return buf


def _rays(rays, tnear, tfar):
    """(..., 6) rays as an (n, 8) float32 array of prt_ray records, and the leading shape.
    One vectorised copy of 12-byte origins and directions (numpy copies them as opaque items,
    faster than a strided copy of three floats)."""
    r = _floats(rays, 6, "rays")
    shape = r.shape[:-1]
    n = math.prod(shape)
    r = np.ascontiguousarray(r.reshape(n, 6), dtype=np.float32)
    buf = _ray_buffer(n)
    buf.xyz[:n] = r.view(_V12).reshape(n, 2)
    for col, value, name in ((0, tnear, "tnear"), (1, tfar, "tfar")):
        if np.ndim(value) == 0:
            buf.t[:n, col] = value
        else:
            try:
                buf.t[:n, col] = np.broadcast_to(np.asarray(value, np.float32), shape).reshape(n)
            except ValueError:
                raise Error("invalid argument", f"{name} of shape {np.shape(value)} does not fit rays {shape}") from None
    return buf.records[:n], shape


def _rays6(rays, tnear, tfar):
    """(..., 6) rays as the library's rays6 arguments, with no records made here: a
    contiguous float32 (n, 6) array (no copy when it is one already), tnear and tfar each as
    (pointer, stride) (stride 0: one value for every ray), and the leading shape."""
    r = _floats(rays, 6, "rays")
    shape = r.shape[:-1]
    n = math.prod(shape)
    r = np.ascontiguousarray(r.reshape(n, 6), dtype=np.float32)
    args = [ffi.from_buffer("float[]", r), n]  # from_buffer keeps its array alive
    for value, name in ((tnear, "tnear"), (tfar, "tfar")):
        if np.ndim(value) == 0:
            v = np.full(1, value, np.float32)
        else:
            try:
                v = np.ascontiguousarray(np.broadcast_to(np.asarray(value, np.float32), shape).reshape(n))
            except ValueError:
                raise Error("invalid argument", f"{name} of shape {np.shape(value)} does not fit rays {shape}") from None
        args += [ffi.from_buffer("float[]", v), 0 if np.ndim(value) == 0 else 1]
    return args, shape


def _triangle_normals(vertices, triangles):
    """Unit geometric normals (right-hand rule over the triangle's vertex order) of every
    triangle plus a last row of zeros for misses and degenerate triangles, float32."""
    v = vertices.astype(np.float64)[triangles]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        n = np.where(length > 0, n / length, 0.0)
    return np.concatenate([n, np.zeros((1, 3))]).astype(np.float32)


def _mesh_arrays(vertices, triangles):
    """Validated (V, 3) float32 vertices and (T, 3) uint32 triangles, contiguous."""
    v = np.asarray(vertices)
    t = np.asarray(triangles)
    if v.dtype.kind != "f" or v.ndim != 2 or v.shape[1] != 3:
        raise Error("invalid argument", f"vertices must be a (V, 3) float array, not {v.shape} {v.dtype}")
    if t.dtype.kind not in "iu" or t.ndim != 2 or t.shape[1] != 3:
        raise Error("invalid argument", f"triangles must be a (T, 3) integer array, not {t.shape} {t.dtype}")
    if t.size and (t.min() < 0 or t.max() >= len(v)):
        bad = int(np.flatnonzero((t < 0) | (t >= len(v)))[0])
        raise Error("invalid mesh", f"triangle {bad // 3} has vertex index {int(t.flat[bad])}, outside 0..{len(v) - 1}")
    return np.ascontiguousarray(v, dtype=np.float32), np.ascontiguousarray(t, dtype=np.uint32)


def _mesh_of(mesh):
    """(vertices, triangles) of an Open3D tensor or legacy TriangleMesh or a trimesh.Trimesh."""
    if hasattr(mesh, "vertex") and hasattr(mesh, "triangle"):  # open3d.t.geometry.TriangleMesh
        return mesh.vertex.positions.numpy(), mesh.triangle.indices.numpy()
    if hasattr(mesh, "faces"):  # trimesh
        return np.asarray(mesh.vertices), np.asarray(mesh.faces)
    if hasattr(mesh, "triangles"):  # open3d.geometry.TriangleMesh
        return np.asarray(mesh.vertices), np.asarray(mesh.triangles)
    raise Error("invalid argument", f"add_triangles takes (vertices, triangles) or a mesh, not {type(mesh).__name__}")


class Scene:
    """A triangle mesh built into a packrt representation, answering ray and point queries.

    Scene(vertices, triangles, spec=None, threads=0), or Scene(spec=None) and then
    add_triangles as Open3D's RaycastingScene: vertices (V, 3) float32/float64,
    triangles (T, 3) integers indexing them; spec any name of `packrt list` with options
    ("quad:float3-soa4,leaf=4", ...), None for DEFAULT_SPEC. The mesh is validated by the
    library: NaN or infinite vertices, indices out of range, no triangles and unknown specs
    raise packrt.Error with its message. Every query takes threads= (0: all cores) or
    Open3D's name for it, nthreads=.
    """

    INVALID_ID = INVALID_ID  # as Open3D's RaycastingScene.INVALID_ID

    def __repr__(self):
        if self._accel is None and not self._parts:
            return "packrt.Scene(no triangles)"
        tris = self.stats()["triangles"]
        return f"packrt.Scene(spec={self.spec!r}, triangles={tris}{'' if self.vertices is not None else ', no mesh'})"

    def __init__(self, vertices=None, triangles=None, spec=None, threads=0):
        self._spec_wanted, self._build_threads = spec, threads
        self._parts = []  # (vertices, triangles) of each add_triangles geometry
        self._offsets = None  # first triangle of each geometry, and the total, when several
        self._accel = None
        self.vertices = self.triangles = self._normals = None
        if vertices is None and triangles is None:
            return  # Open3D's way: Scene(), then add_triangles
        self._build(*_mesh_arrays(vertices, triangles))

    def add_triangles(self, vertices, triangles=None):
        """Add a mesh as a new geometry, as Open3D's add_triangles: (V, 3) vertices and (T, 3)
        triangles, or one mesh object (Open3D's tensor or legacy TriangleMesh, trimesh's
        Trimesh). Returns its geometry id (0, 1, ...), which hits report in geometry_ids,
        with primitive_ids counted within that geometry. The scene is built again, all
        geometries in one representation, at its next query; geometry ids are not saved."""
        if self._accel is not None and not self._parts:
            if self.vertices is None:
                raise Error("unsupported", "a scene loaded from a file without its mesh takes no more triangles")
            self._parts.append((self.vertices, self.triangles))  # what it was built from: geometry 0
        if triangles is None:
            vertices, triangles = _mesh_of(vertices)
        self._parts.append(_mesh_arrays(vertices, triangles))
        self._accel = None
        return len(self._parts) - 1

    @property
    def _a(self):
        """The accel, built first from the geometries added since the last build."""
        if self._accel is None:
            if not self._parts:
                raise Error("invalid argument", "the scene has no triangles yet (add_triangles)")
            first = np.cumsum([0] + [len(v) for v, _ in self._parts])
            vertices = np.concatenate([v for v, _ in self._parts])
            triangles = np.concatenate([t + np.uint32(f) for (_, t), f in zip(self._parts, first)])
            counts = [len(t) for _, t in self._parts]
            self._build(vertices, triangles)
            self._offsets = np.cumsum([0] + counts).astype(np.int64) if len(counts) > 1 else None
        return self._accel

    def _local_ids(self, prim):
        """(geometry_ids, primitive_ids within the geometry) of scene-wide triangle ids, with
        INVALID_ID kept; None for a scene of one geometry (the ids are already local)."""
        if self._offsets is None:
            return None
        miss = prim == INVALID_ID
        g = np.searchsorted(self._offsets, prim, side="right") - 1
        g[miss] = 0
        local = (prim - self._offsets[g]).astype(np.uint32)
        g = g.astype(np.uint32)
        g[miss] = INVALID_ID
        local[miss] = INVALID_ID
        return g, local

    def _build(self, v32, t32):
        pm = ffi.new("prt_mesh **")
        _check(lib.prt_mesh_create(len(v32), len(t32), pm))
        mesh = ffi.gc(pm[0], lib.prt_mesh_free)
        ffi.memmove(mesh.vertices, v32, v32.nbytes)
        ffi.memmove(mesh.triangles, t32, t32.nbytes)
        self._init_built(mesh, self._spec_wanted, self._build_threads, v32, t32)

    def _init_built(self, mesh, spec, threads, vertices, triangles):
        opts = ffi.new("prt_build_options *", {"threads": _threads(threads, None)})
        pa = ffi.new("prt_accel **")
        spec = DEFAULT_SPEC if spec is None else spec
        if not isinstance(spec, str):
            raise Error("invalid argument", f"spec must be a string or None, not {spec!r}")
        _check(lib.prt_build(mesh, spec.encode(), opts, pa))
        self._set_accel(pa[0], vertices, triangles)

    def _set_accel(self, accel, vertices=None, triangles=None):
        self._accel = ffi.gc(accel, lib.prt_accel_free)
        self._set_mesh(vertices, triangles)

    def _set_mesh(self, vertices, triangles):
        self.vertices, self.triangles = vertices, triangles
        # Normals come from the mesh; without one (a loaded file) or when hits name positions
        # in the accel's own order (ids=none) there are none.
        self._normals = None
        if vertices is not None and "ids=none" not in self.spec:
            self._normals = _triangle_normals(vertices, triangles)
            padded = np.zeros((len(self._normals), 4), np.float32)
            padded[:, :3] = self._normals
            self._normals16 = padded.view(np.complex128).reshape(-1)

    @classmethod
    def _from_mesh_ptr(cls, pm, spec, threads):
        mesh = ffi.gc(pm[0], lib.prt_mesh_free)
        v = np.frombuffer(ffi.buffer(mesh.vertices, 12 * mesh.vertex_count), np.float32).reshape(-1, 3).copy()
        t = np.frombuffer(ffi.buffer(mesh.triangles, 12 * mesh.triangle_count), np.uint32).reshape(-1, 3).copy()
        self = cls(spec=spec, threads=threads)
        self._init_built(mesh, spec, threads, v, t)
        return self

    @classmethod
    def from_file(cls, path, spec=None, threads=0):
        """Load a PLY or OBJ mesh (gzip too) with the library's reader and build it."""
        pm = ffi.new("prt_mesh **")
        _check(lib.prt_mesh_load(str(path).encode(), pm))
        return cls._from_mesh_ptr(pm, spec, threads)

    @classmethod
    def generate(cls, kind, triangles, seed=0, spec=None, threads=0):
        """Build one of the library's procedural meshes (`packrt gen`: sphere, terrain, ...)."""
        pm = ffi.new("prt_mesh **")
        _check(lib.prt_mesh_generate(kind.encode(), int(triangles), int(seed), pm))
        return cls._from_mesh_ptr(pm, spec, threads)

    @classmethod
    def load(cls, path, vertices=None, triangles=None):
        """Load a .prt file (mapped, no rebuild). Without the mesh it was built from
        (vertices, triangles), answers have primitive_normals None: a .prt file keeps no
        normals."""
        return cls.open(path, vertices=vertices, triangles=triangles)

    @classmethod
    def open(cls, path, cache_bytes=0, fetchers=0, vertices=None, triangles=None):
        """Scene.load with the options of out-of-core block files ("ooc"): cache_bytes of
        decompressed blocks (0: 1 GiB or the whole file) and fetcher threads (0: 4)."""
        o = ffi.new("prt_open_options *", {"cache_bytes": int(cache_bytes), "fetchers": int(fetchers)})
        pa = ffi.new("prt_accel **")
        _check(lib.prt_accel_open(str(path).encode(), o, pa))
        self = cls()
        self._set_accel(pa[0])
        self._spec_wanted = self.spec  # add_triangles builds again with the file's representation
        if vertices is not None:
            # The mesh only supplies normals: it must be the one the file was built from.
            v, t = np.asarray(vertices), np.asarray(triangles)
            if v.ndim != 2 or v.shape[1:] != (3,) or t.ndim != 2 or t.shape[1:] != (3,) or t.dtype.kind not in "iu":
                raise Error("invalid argument", f"vertices {v.shape} and triangles {t.shape} must be (V, 3) and (T, 3)")
            if len(t) != self.stats()["triangles"] or (t.size and (t.min() < 0 or t.max() >= len(v))):
                raise Error("invalid argument", f"{path} holds {self.stats()['triangles']} triangles: the mesh given "
                            f"({len(t)} triangles over {len(v)} vertices) is not the one it was built from")
            self._set_mesh(np.ascontiguousarray(v, np.float32), np.ascontiguousarray(t, np.uint32))
        return self

    @property
    def spec(self):
        """The canonical spec of the representation, every option spelled out."""
        return ffi.string(lib.prt_accel_spec(self._a)).decode()

    def save(self, path):
        """Write a .prt file (docs/formats.md) that Scene.load maps back without a rebuild."""
        _check(lib.prt_accel_save(self._a, str(path).encode()))

    def stats(self):
        """Memory and build figures: spec, triangles, bytes (tree, geometry, other) in all
        and per triangle, nodes, leaves, depth, build seconds, vertex error of lossy specs."""
        s = ffi.new("prt_stats *")
        lib.prt_accel_stats(self._a, s)
        tris = max(s.triangles, 1)
        total = s.bytes_tree + s.bytes_geometry + s.bytes_other
        return {
            "spec": self.spec,
            "triangles": s.triangles,
            "triangles_built": s.triangles_built,
            "bytes": total,
            "bytes_tree": s.bytes_tree,
            "bytes_geometry": s.bytes_geometry,
            "bytes_other": s.bytes_other,
            "bytes_per_triangle": total / tris,
            "bytes_per_triangle_tree": s.bytes_tree / tris,
            "bytes_per_triangle_geometry": s.bytes_geometry / tris,
            "nodes": s.nodes,
            "leaves": s.leaves,
            "depth": s.depth,
            "build_seconds": s.build_seconds,
            "vertex_error": s.vertex_error,
            "detail": ffi.string(s.detail).decode(),
        }

    def bounds(self):
        """(lo, hi): the bounds of the triangles the scene can hit."""
        lo, hi = ffi.new("float[3]"), ffi.new("float[3]")
        lib.prt_accel_bounds(self._a, lo, hi)
        return np.array(list(lo), np.float32), np.array(list(hi), np.float32)

    # ---- ray queries --------------------------------------------------------------------

    def cast_rays(self, rays, tnear=0.0, tfar=np.inf, threads=0, nthreads=None, normals=True):
        """Closest hits of rays (..., 6): origin, direction (any length; t in its units),
        accepted for t in [tnear, tfar] (scalars or arrays of the rays' leading shape).
        Returns a dict of arrays of the leading shape: t_hit (float32, inf on a miss),
        primitive_ids (uint32, INVALID_ID on a miss), primitive_uvs (..., 2) (u weights
        vertex 1, v vertex 2), primitive_normals (..., 3) (unit geometric normal, zeros on a
        miss; None for a scene loaded without its mesh), geometry_ids (0 on a hit, or the
        add_triangles geometry; INVALID_ID on a miss). t_hit, primitive_ids, primitive_uvs and geometry_ids are views of one
        buffer. normals=False leaves primitive_normals None and saves gathering them (a tenth
        of the call's time at 1M rays: docs/results/python.md)."""
        args, shape = _rays6(rays, tnear, tfar)
        n = args[1]
        hits = np.empty((n, 5), np.float32)
        lib.prt_intersect_rays6(self._a, *args, ffi.from_buffer("prt_hit[]", hits), _threads(threads, nthreads))
        words = hits.view(np.uint32)
        prim, geom = words[:, 3], words[:, 4]
        np.copyto(geom, INVALID_ID, where=prim == INVALID_ID)  # the library leaves geom 0 on a miss
        ans = {
            "t_hit": hits[:, 0].reshape(shape),
            "geometry_ids": geom.reshape(shape),
            "primitive_ids": prim.reshape(shape),
            "primitive_uvs": hits[:, 1:3].reshape(shape + (2,)),
            "primitive_normals": self._gather_normals(prim, shape) if normals else None,
        }
        local = self._local_ids(prim)
        if local is not None:  # several geometries: ids within each (new arrays)
            ans["geometry_ids"], ans["primitive_ids"] = (x.reshape(shape) for x in local)
        return ans

    def _gather_normals(self, prim, shape):
        """Unit normals of triangles prim (zeros for misses), or None without a mesh."""
        if self._normals is None:
            return None
        # The last row is zeros: misses (INVALID_ID, past the mesh) clip to it. Rows padded to
        # 16 bytes and taken as complex128 items, with intp indices, hit numpy's fast take
        # (7x faster than a (n, 3) float32 take with uint32 indices at 1M rays); the answer
        # is a (..., 3) view of the (..., 4) rows.
        rows = self._normals16.take(prim.astype(np.intp), mode="clip")
        return rows.view(np.float32).reshape(-1, 4)[:, :3].reshape(shape + (3,))

    def test_occlusions(self, rays, tnear=0.0, tfar=np.inf, threads=0, nthreads=None):
        """True for each ray of (..., 6) that hits anything with t in [tnear, tfar]."""
        args, shape = _rays6(rays, tnear, tfar)
        out = np.empty(args[1], np.uint8)
        lib.prt_occluded_rays6(self._a, *args, ffi.from_buffer("uint8_t[]", out), _threads(threads, nthreads))
        return out.view(np.bool_).reshape(shape)

    @staticmethod
    def create_rays_pinhole(*args, **kw):
        """Rays (height_px, width_px, 6) of a pinhole camera, as Open3D makes them, either
        create_rays_pinhole(fov_deg, center, eye, up, width_px, height_px) (fov_deg: the
        horizontal field of view) or create_rays_pinhole(intrinsic_matrix, extrinsic_matrix,
        width_px, height_px) (3x3 K, 4x4 world-to-camera). Pixel (x, y) looks through
        (x + 0.5, y + 0.5) and its direction has unit depth along the view axis, so t_hit is
        the depth (z distance) of the hit, not its distance. As in Open3D, image x runs along
        cross(up, center - eye) and image y along up, so with row 0 shown on top the picture
        is turned half a turn (np.rot90(image, 2) sets it upright; examples/depth.py does)."""
        return _pinhole(*args, **kw)

    # ---- mesh queries (library issue 28) ------------------------------------------------

    def _all_stream(self, buf, counts, offsets, hits, threads):
        f = _fn("prt_intersect_all_stream")
        _check(f(self._a, ffi.from_buffer("prt_ray[]", buf), len(buf), ffi.from_buffer("uint32_t[]", counts),
                 ffi.NULL if offsets is None else ffi.from_buffer("uint64_t[]", offsets),
                 ffi.NULL if hits is None else ffi.from_buffer("prt_hit[]", hits), threads))

    def count_intersections(self, rays, tnear=0.0, tfar=np.inf, threads=0, nthreads=None):
        """Number of surface crossings along each ray (int32, the rays' leading shape); a
        ray through a shared edge or vertex counts the crossing once."""
        buf, shape = _rays(rays, tnear, tfar)
        counts = np.empty(len(buf), np.uint32)
        self._all_stream(buf, counts, None, None, _threads(threads, nthreads))
        return counts.astype(np.int32).reshape(shape)

    def list_intersections(self, rays, tnear=0.0, tfar=np.inf, threads=0, nthreads=None):
        """Every crossing of every ray, nearest first, as Open3D lists them: ray_splits
        (n + 1, uint32; ray i's crossings are [ray_splits[i], ray_splits[i+1])), ray_ids
        (index of the ray in the flattened rays), t_hit, primitive_ids, primitive_uvs,
        geometry_ids."""
        buf, _ = _rays(rays, tnear, tfar)
        threads = _threads(threads, nthreads)
        n = len(buf)
        counts = np.empty(n, np.uint32)
        self._all_stream(buf, counts, None, None, threads)  # first pass: counts only
        offsets = np.zeros(n + 1, np.uint64)
        np.cumsum(counts, out=offsets[1:])
        total = int(offsets[-1])
        hits = np.empty(total, _HIT)
        counts2 = np.empty(n, np.uint32)
        self._all_stream(buf, counts2, offsets, hits, threads)
        ans = {
            "ray_splits": offsets.astype(np.uint32),
            "ray_ids": np.repeat(np.arange(n, dtype=np.uint32), counts),
            "t_hit": hits["t"].copy(),
            "primitive_ids": hits["prim"].copy(),
            "primitive_uvs": np.stack([hits["u"], hits["v"]], axis=-1),
            "geometry_ids": np.zeros(total, np.uint32),
        }
        local = self._local_ids(ans["primitive_ids"])
        if local is not None:
            ans["geometry_ids"], ans["primitive_ids"] = local
        return ans

    def compute_closest_points(self, query_points, threads=0, nthreads=None):
        """The nearest surface point to each of (..., 3) points: points (..., 3),
        primitive_ids, primitive_uvs (..., 2), primitive_normals (..., 3; None without the
        mesh), geometry_ids (0; INVALID_ID for a point that is not finite)."""
        p, shape = _points(query_points)
        out = self._closest(p, threads, nthreads)
        prim = out["prim"]
        ans = {
            "points": out["point"].reshape(shape + (3,)),
            "geometry_ids": np.where(prim == INVALID_ID, np.uint32(INVALID_ID), np.uint32(0)).reshape(shape),
            "primitive_ids": prim.reshape(shape),
            "primitive_uvs": np.stack([out["u"], out["v"]], axis=-1).reshape(shape + (2,)),
            "primitive_normals": self._gather_normals(prim, shape),
        }
        local = self._local_ids(prim)
        if local is not None:
            ans["geometry_ids"], ans["primitive_ids"] = (x.reshape(shape) for x in local)
        return ans

    def _closest(self, p, threads, nthreads):
        out = np.empty(len(p), _CLOSEST)
        _check(_fn("prt_closest_points")(self._a, ffi.from_buffer("float[]", p), len(p), math.inf,
                                         ffi.from_buffer("prt_closest[]", out), _threads(threads, nthreads)))
        return out

    def compute_distance(self, query_points, threads=0, nthreads=None):
        """Distance (float32) from each of (..., 3) points to the surface."""
        p, shape = _points(query_points)
        return self._closest(p, threads, nthreads)["distance"].reshape(shape)

    def compute_signed_distance(self, query_points, threads=0, nthreads=None, nsamples=None):
        """Distance to the surface, negative inside (as compute_occupancy decides). nsamples
        (Open3D's vote count) is accepted and ignored: the library decides containment."""
        p, shape = _points(query_points)
        out = np.empty(len(p), np.float32)
        _check(_fn("prt_signed_distance")(self._a, ffi.from_buffer("float[]", p), len(p), math.inf,
                                          ffi.from_buffer("float[]", out), _threads(threads, nthreads)))
        return out.reshape(shape)

    def _contains(self, query_points, threads, nthreads, method="auto"):
        if method not in CONTAINS_METHODS:
            raise Error("invalid argument", f"method must be one of {sorted(CONTAINS_METHODS)}, not {method!r}")
        p, shape = _points(query_points)
        out = np.empty(len(p), np.uint8)
        args = (ffi.from_buffer("float[]", p), len(p))
        if method == "auto":  # libraries from before prt_contains_by answer this one too
            _check(_fn("prt_contains")(self._a, *args, ffi.from_buffer("uint8_t[]", out), _threads(threads, nthreads)))
        else:
            _check(_fn("prt_contains_by")(self._a, *args, CONTAINS_METHODS[method], ffi.from_buffer("uint8_t[]", out),
                                          _threads(threads, nthreads)))
        return (out & PRT_INSIDE).astype(bool).reshape(shape)

    def compute_occupancy(self, query_points, threads=0, nthreads=None, nsamples=None, method="auto"):
        """1.0 inside the mesh, 0.0 outside (float32, as Open3D), for (..., 3) points. method
        (a packrt addition): "auto", crossing parity along several rays and the generalized
        winding number where they disagree; "parity", their majority; "winding", the fast
        winding number (Barill et al. 2018) for every point, for meshes with holes or
        self-intersections."""
        return self._contains(query_points, threads, nthreads, method).astype(np.float32)

    def compute_winding_number(self, query_points, threads=0, nthreads=None, beta=None):
        """Generalized winding number (Jacobson et al. 2013) at (..., 3) points: 1 inside a
        closed outward-wound mesh, 0 outside (a packrt addition). beta None: the exact sum
        over every triangle; a number (2: the paper's): Barill et al. 2018's fast
        approximation with that accuracy."""
        p, shape = _points(query_points)
        out = np.empty(len(p), np.float32)
        args = (self._a, ffi.from_buffer("float[]", p), len(p))
        if beta is None:
            _check(_fn("prt_winding_number")(*args, ffi.from_buffer("float[]", out), _threads(threads, nthreads)))
        else:
            _check(_fn("prt_winding_number_fast")(*args, float(beta), ffi.from_buffer("float[]", out),
                                                  _threads(threads, nthreads)))
        return out.reshape(shape)


def _pinhole(*args, **kw):
    names6 = ("fov_deg", "center", "eye", "up", "width_px", "height_px")
    names4 = ("intrinsic_matrix", "extrinsic_matrix", "width_px", "height_px")
    names = names6 if len(args) + len(kw) == 6 else names4
    if len(args) + len(kw) not in (4, 6):
        raise Error("invalid argument", "create_rays_pinhole takes (fov_deg, center, eye, up, width_px, height_px) "
                    "or (intrinsic_matrix, extrinsic_matrix, width_px, height_px)")
    a = dict(zip(names, args))
    a.update(kw)
    w, h = int(a["width_px"]), int(a["height_px"])
    if w <= 0 or h <= 0:
        raise Error("invalid argument", f"image size {w} x {h} must be positive")
    if names is names6:
        center, eye, up = (np.asarray(a[k], np.float64).reshape(3) for k in ("center", "eye", "up"))
        f = 0.5 * w / math.tan(0.5 * math.radians(float(a["fov_deg"])))
        k = np.array([[f, 0, 0.5 * w], [0, f, 0.5 * h], [0, 0, 1]])
        # World-to-camera rotation (rows: camera axes), as Open3D builds it from eye/center/up.
        r = np.empty((3, 3))
        with np.errstate(invalid="ignore", divide="ignore"):  # checked just below
            r[2] = (center - eye) / np.linalg.norm(center - eye)
            r[0] = np.cross(up / np.linalg.norm(up), r[2])
        if not np.isfinite(r[[0, 2]]).all() or np.linalg.norm(r[0]) < 1e-9:
            # Open3D answers NaN rays here (its issue 6471); say what is wrong instead.
            raise Error("invalid argument", f"camera eye {eye.tolist()}, center {center.tolist()} and up "
                        f"{up.tolist()}: eye must differ from center and up must not be parallel to the view")
        r[0] /= np.linalg.norm(r[0])
        r[1] = np.cross(r[2], r[0])
        ext = np.eye(4)
        ext[:3, :3], ext[:3, 3] = r, -r @ eye
    else:
        k = np.asarray(a["intrinsic_matrix"], np.float64).reshape(3, 3)
        ext = np.asarray(a["extrinsic_matrix"], np.float64).reshape(4, 4)
    rt = ext[:3, :3].T
    origin = -rt @ ext[:3, 3]
    m = (rt @ np.linalg.inv(k)).astype(np.float32)
    xs, ys = np.meshgrid(np.arange(w, dtype=np.float32) + 0.5, np.arange(h, dtype=np.float32) + 0.5)
    px = np.stack([xs, ys, np.ones_like(xs)], axis=-1)
    rays = np.empty((h, w, 6), np.float32)
    rays[..., :3] = origin.astype(np.float32)
    rays[..., 3:] = px @ m.T
    return rays
