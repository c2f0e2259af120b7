"""Brute-force references in double precision for the Python tests: every ray against every
triangle (Moller-Trumbore), every point against every triangle (Ericson's closest point),
solid angles for the winding number (Van Oosterom & Strackee). Independent of the library.
Also the small test meshes: a cube, an icosphere and a triangle soup, made here in numpy."""
import numpy as np

# A ray whose hit lies within this barycentric margin of an edge (or whose miss passes this
# close) is ambiguous between float32 and float64 and is left out of exact comparisons.
MARGIN = 1e-4


def cube(half=1.0):
    """Closed cube [-half, half]^3, 8 vertices, 12 outward-wound triangles."""
    v = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)], np.float64)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    t = []
    for a, b, c, d in quads:
        t += [(a, b, c), (a, c, d)]
    t = np.array(t, np.int64)
    # Wind each triangle outward: its normal points away from the centre.
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    flip = (n * v[t].mean(axis=1)).sum(axis=1) < 0
    t[flip] = t[flip][:, ::-1]
    return v, t


def write_ply(path, v, t):
    """An ASCII PLY of a mesh, for the loaders."""
    head = ["ply", "format ascii 1.0", f"element vertex {len(v)}", "property float x", "property float y",
            "property float z", f"element face {len(t)}", "property list uchar int vertex_indices", "end_header"]
    lines = head + [" ".join(map(str, p)) for p in v] + ["3 " + " ".join(map(str, f)) for f in t]
    open(path, "w").write("\n".join(lines) + "\n")


def icosphere(subdivisions=2, radius=1.0):
    """Closed sphere of 20 * 4^subdivisions outward-wound triangles."""
    p = (1 + 5 ** 0.5) / 2
    v = [(-1, p, 0), (1, p, 0), (-1, -p, 0), (1, -p, 0), (0, -1, p), (0, 1, p), (0, -1, -p), (0, 1, -p),
         (p, 0, -1), (p, 0, 1), (-p, 0, -1), (-p, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    v = [np.array(x, np.float64) / np.linalg.norm(x) for x in v]
    for _ in range(subdivisions):
        mid = {}

        def midpoint(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                m = v[a] + v[b]
                v.append(m / np.linalg.norm(m))
                mid[key] = len(v) - 1
            return mid[key]

        f2 = []
        for a, b, c in f:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            f2 += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = f2
    return np.array(v) * radius, np.array(f, np.int64)


def soup(n=150, seed=1):
    """n random, unconnected, intersecting triangles in [-1, 1]^3."""
    rng = np.random.default_rng(seed)
    centre = rng.uniform(-1, 1, (n, 1, 3))
    v = (centre + rng.normal(0, 0.3, (n, 3, 3))).reshape(-1, 3)
    return v, np.arange(3 * n).reshape(n, 3)


def random_rays(n, seed=2, spread=1.5):
    """Rays from a shell around the origin towards points near it, (n, 6) float32."""
    rng = np.random.default_rng(seed)
    o = rng.normal(size=(n, 3))
    o = 3.5 * o / np.linalg.norm(o, axis=1, keepdims=True)
    target = rng.uniform(-spread, spread, (n, 3))
    return np.concatenate([o, target - o], axis=1).astype(np.float32)


def ray_triangle(rays, v, t):
    """(t, u, v, b) arrays (n_rays, n_tris) of every ray's plane hit with every triangle,
    b the smallest barycentric (negative outside the triangle); t NaN where parallel."""
    r = rays.astype(np.float64)
    o, d = r[:, None, :3], r[:, None, 3:6]
    p0, p1, p2 = (v[t[:, k]][None] for k in range(3))
    e1, e2 = p1 - p0, p2 - p0
    pv = np.cross(d, e2)
    det = (e1 * pv).sum(-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o - p0
        u = (s * pv).sum(-1) * inv
        q = np.cross(s, e1)
        w = (d * q).sum(-1) * inv
        tt = (e2 * q).sum(-1) * inv
    tt = np.where(np.abs(det) > 1e-12, tt, np.nan)
    b = np.minimum(np.minimum(u, w), 1 - u - w)
    return tt, u, w, b


def closest_hits(rays, v, t, tnear=0.0, tfar=np.inf):
    """Per ray: (t, prim, u, v, ambiguous), prim -1 on a miss; ambiguous where a triangle's
    edge or either end of the interval passes within MARGIN of deciding otherwise."""
    tt, u, w, b = ray_triangle(rays, v, t)
    tnear = np.broadcast_to(np.asarray(tnear, np.float64), (len(rays),))[:, None]
    tfar = np.broadcast_to(np.asarray(tfar, np.float64), (len(rays),))[:, None]
    inside_t = (tt >= tnear) & (tt <= tfar)
    hit = inside_t & (b >= 0)
    tm = np.where(hit, tt, np.inf)
    prim = np.argmin(tm, axis=1)
    best = tm[np.arange(len(rays)), prim]
    miss = ~np.isfinite(best)
    near_edge = (np.abs(b) < MARGIN) & (tt >= tnear - 1e-4) & (tt <= tfar + 1e-4)
    scale = np.maximum(1.0, np.abs(tt))
    near_end = (b >= -MARGIN) & ((np.abs(tt - tnear) < 1e-4 * scale) | (np.abs(tt - tfar) < 1e-4 * scale))
    srt = np.sort(tm, axis=1)
    with np.errstate(invalid="ignore"):  # inf - inf on misses: not close
        close_second = (srt.shape[1] > 1) & (np.abs(srt[:, 1] - srt[:, 0]) < 1e-4 * np.maximum(1, np.abs(srt[:, 0])))
    amb = near_edge.any(axis=1) | near_end.any(axis=1) | (close_second & ~miss)
    rows = np.arange(len(rays))
    return (np.where(miss, np.inf, best), np.where(miss, -1, prim), u[rows, prim], w[rows, prim], amb)


def all_hits(rays, v, t, tnear=0.0, tfar=np.inf):
    """Per ray: the sorted t and prims of every crossing, and whether it is ambiguous."""
    tt, _, _, b = ray_triangle(rays, v, t)
    out = []
    for i in range(len(rays)):
        ok = (b[i] >= 0) & (tt[i] >= tnear) & (tt[i] <= tfar)
        idx = np.flatnonzero(ok)
        order = np.lexsort((idx, tt[i][idx]))
        amb = bool(((np.abs(b[i]) < MARGIN) & np.isfinite(tt[i]) & (tt[i] > tnear - 1e-4)).any())
        out.append((tt[i][idx][order], idx[order], amb))
    return out


def point_triangle(points, v, t):
    """(nearest points (n, T, 3), distances (n, T)) of every point to every triangle."""
    p = points.astype(np.float64)[:, None, :]
    a, b, c = (v[t[:, k]][None] for k in range(3))
    q = _closest_on_triangle(p, a, b, c)
    return q, np.linalg.norm(q - p, axis=-1)


def closest_points(points, v, t):
    """(points (n, 3), distance (n,), prim (n,), second-nearest distance) by brute force."""
    q, dist = point_triangle(points, v, t)
    prim = np.argmin(dist, axis=1)
    rows = np.arange(len(points))
    srt = np.sort(dist, axis=1)
    second = srt[:, 1] if dist.shape[1] > 1 else np.full(len(points), np.inf)
    return q[rows, prim], dist[rows, prim], prim, second


def _closest_on_triangle(p, a, b, c):
    """Ericson, Real-Time Collision Detection 5.1.5, vectorised: every region at once."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    bp = p - b
    d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    cp = p - c
    d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = 1.0 / (va + vb + vc)
        face = a + ab * (vb * denom)[..., None] + ac * (vc * denom)[..., None]
        e_ab = a + ab * (d1 / (d1 - d3))[..., None]
        e_ac = a + ac * (d2 / (d2 - d6))[..., None]
        e_bc = b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))[..., None]
    out = face
    cases = [  # Ericson's tests from last to first: earlier ones overwrite later ones
        ((va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), e_bc),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), e_ac),
        ((d6 >= 0) & (d5 <= d6), np.broadcast_to(c, face.shape)),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), e_ab),
        ((d3 >= 0) & (d4 <= d3), np.broadcast_to(b, face.shape)),
        ((d1 <= 0) & (d2 <= 0), np.broadcast_to(a, face.shape)),
    ]
    for cond, value in cases:
        out = np.where(cond[..., None], value, out)
    return out


def winding_numbers(points, v, t):
    """Generalized winding number: sum of signed solid angles / 4 pi."""
    p = points.astype(np.float64)[:, None, :]
    a, b, c = (v[t[:, k]][None] - p for k in range(3))
    la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
    num = (a * np.cross(b, c)).sum(-1)
    den = la * lb * lc + (a * b).sum(-1) * lc + (b * c).sum(-1) * la + (c * a).sum(-1) * lb
    return (2 * np.arctan2(num, den)).sum(axis=1) / (4 * np.pi)
