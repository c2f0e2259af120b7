"""packrt.Scene's ray queries against the double-precision brute force (reference.py), on a
cube, an icosphere and a triangle soup: hits, misses, shapes, dtypes, t intervals, files."""
import types

import numpy as np
import pytest

import packrt
import reference as R

MESHES = {"cube": R.cube(), "icosphere": R.icosphere(2), "soup": R.soup()}
SPECS = [None, "aabb:float3", "quad:float3-soa4", "wide8:float3-soa8"]


def unit_normals(v, t):
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def check_against_reference(ans, rays, v, t, tnear=0.0, tfar=np.inf):
    rt, rprim, ru, rv, amb = R.closest_hits(rays, v, t, tnear, tfar)
    ok = ~amb
    assert ok.mean() > 0.9, "too many ambiguous rays for the test to mean anything"
    hit = ok & (rprim >= 0)
    miss = ok & (rprim < 0)
    assert hit.sum() > 10 and miss.sum() > 10
    prim = ans["primitive_ids"]
    assert np.array_equal(prim[hit], rprim[hit])
    np.testing.assert_allclose(ans["t_hit"][hit], rt[hit], rtol=2e-5, atol=1e-6)
    np.testing.assert_allclose(ans["primitive_uvs"][hit], np.stack([ru, rv], -1)[hit], atol=2e-4)
    np.testing.assert_allclose(ans["primitive_normals"][hit], unit_normals(v, t)[rprim[hit]], atol=1e-5)
    assert (ans["geometry_ids"][hit] == 0).all()
    assert np.isinf(ans["t_hit"][miss]).all() and (ans["t_hit"][miss] > 0).all()
    assert packrt.Scene.INVALID_ID == packrt.INVALID_ID == 0xFFFFFFFF
    assert (prim[miss] == packrt.INVALID_ID).all() and (ans["geometry_ids"][miss] == packrt.INVALID_ID).all()
    assert (ans["primitive_normals"][miss] == 0).all()


@pytest.mark.parametrize("name", MESHES)
@pytest.mark.parametrize("spec", SPECS)
def test_cast_rays_matches_brute_force(name, spec):
    v, t = MESHES[name]
    rays = R.random_rays(3000)
    ans = packrt.Scene(v, t, spec=spec).cast_rays(rays)
    assert ans["t_hit"].dtype == np.float32 and ans["primitive_ids"].dtype == np.uint32
    assert ans["primitive_uvs"].shape == (3000, 2) and ans["primitive_normals"].shape == (3000, 3)
    check_against_reference(ans, rays, v, t)
    lean = packrt.Scene(v, t, spec=spec).cast_rays(rays, normals=False)
    assert lean["primitive_normals"] is None
    assert all(np.array_equal(lean[k], ans[k]) for k in ("t_hit", "primitive_ids", "primitive_uvs", "geometry_ids"))


@pytest.mark.parametrize("name", MESHES)
def test_test_occlusions_matches_brute_force(name):
    v, t = MESHES[name]
    rays = R.random_rays(3000, seed=5)
    tfar = np.random.default_rng(3).uniform(0.2, 1.2, 3000).astype(np.float32)
    occ = packrt.Scene(v, t).test_occlusions(rays, tfar=tfar)
    assert occ.dtype == np.bool_ and occ.shape == (3000,)
    rt, _, _, _, amb = R.closest_hits(rays, v, t, 0.0, tfar)
    assert (~amb).mean() > 0.9
    assert np.array_equal(occ[~amb], np.isfinite(rt)[~amb])
    assert occ[~amb].any() and not occ[~amb].all()


def test_tnear_tfar_scalars_and_arrays_select_the_interval():
    v, t = R.icosphere(2)
    rays = R.random_rays(2000, seed=7)
    rng = np.random.default_rng(8)
    tnear = rng.uniform(0.0, 0.6, 2000).astype(np.float32)
    scene = packrt.Scene(v, t)
    check_against_reference(scene.cast_rays(rays, tnear=tnear, tfar=1.5), rays, v, t, tnear, 1.5)
    check_against_reference(scene.cast_rays(rays, tnear=0.5), rays, v, t, 0.5, np.inf)


@pytest.mark.parametrize("shape", [(), (7,), (5, 4), (2, 3, 4)])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_any_leading_shape_and_float_dtype_give_the_same_answers(shape, dtype):
    v, t = R.cube()
    scene = packrt.Scene(v, t)
    n = int(np.prod(shape))
    flat = R.random_rays(max(n, 1), seed=11)[:n] if shape else R.random_rays(1, seed=11)
    rays = flat.reshape(shape + (6,)).astype(dtype)
    ans = scene.cast_rays(rays)
    want = scene.cast_rays(flat)
    for k, a in ans.items():
        extra = want[k].shape[1:]
        assert a.shape == shape + extra
        assert np.array_equal(a.reshape((-1,) + extra), want[k])
    assert scene.test_occlusions(rays).shape == shape


def test_float64_input_is_rounded_once_to_float32():
    v, t = R.icosphere(2)
    scene = packrt.Scene(v.astype(np.float64), t)
    rays64 = R.random_rays(500, seed=3).astype(np.float64) + 1e-9
    a = scene.cast_rays(rays64)
    b = scene.cast_rays(rays64.astype(np.float32))
    assert all(np.array_equal(a[k], b[k]) for k in a)


def test_non_contiguous_and_fortran_rays_are_read_correctly():
    v, t = R.icosphere(2)
    scene = packrt.Scene(v, t)
    rays = R.random_rays(1000, seed=4)
    want = scene.cast_rays(rays[::2].copy())
    for r in (rays[::2], np.asfortranarray(rays[::2])):
        got = scene.cast_rays(r)
        assert all(np.array_equal(got[k], want[k]) for k in got)
    wide = np.zeros((500, 9), np.float32)
    wide[:, 1:7] = rays[::2]
    got = scene.cast_rays(wide[:, 1:7])
    assert all(np.array_equal(got[k], want[k]) for k in got)


def test_empty_ray_arrays_give_empty_answers():
    scene = packrt.Scene(*R.cube())
    ans = scene.cast_rays(np.zeros((0, 6), np.float32))
    assert ans["t_hit"].shape == (0,) and ans["primitive_uvs"].shape == (0, 2)
    assert scene.test_occlusions(np.zeros((0, 3, 6))).shape == (0, 3)


@pytest.mark.parametrize("bad, match", [
    (dict(vertices=np.zeros((3, 2))), "vertices"),
    (dict(vertices=np.zeros((3, 3), np.int32)), "vertices"),
    (dict(triangles=np.zeros((1, 3), np.float32)), "triangles"),
    (dict(triangles=np.zeros((3,), np.int64)), "triangles"),
    (dict(triangles=np.array([[0, 1, 3]])), "3"),
    (dict(triangles=np.array([[0, -1, 2]])), "-1"),
    (dict(triangles=np.array([[0, 1, 2 + 2 ** 32]])), "4294967298"),
    (dict(vertices=np.array([[0, 0, 0], [1, 0, np.nan], [0, 1, 0]])), "nan"),
    (dict(vertices=np.array([[0, 0, 0], [1, 0, np.inf], [0, 1, 0]])), "inf"),
    (dict(triangles=np.zeros((0, 3), np.int64)), ""),
    (dict(spec="no-such-thing"), "no-such-thing"),
    (dict(spec="aabb:float3,leaf=99"), "leaf"),
])
def test_bad_meshes_and_specs_raise_packrt_error_with_the_reason(bad, match):
    args = dict(vertices=np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), triangles=np.array([[0, 1, 2]]))
    args.update(bad)
    with pytest.raises(packrt.Error, match=match) as e:
        packrt.Scene(**args)
    assert e.value.status


@pytest.mark.parametrize("call", [
    lambda s: s.cast_rays(np.zeros((4, 5), np.float32)),
    lambda s: s.cast_rays(np.zeros((4, 6), np.int32)),
    lambda s: s.cast_rays(np.zeros(6, np.complex64)),
    lambda s: s.cast_rays(np.zeros((4, 6)), tfar=np.ones(3)),
    lambda s: s.cast_rays(np.zeros((4, 6)), threads=-1),
    lambda s: s.test_occlusions(np.zeros((4, 7))),
    lambda s: packrt.Scene.load("/nonexistent/file.prt"),
    lambda s: packrt.Scene.create_rays_pinhole(60, [0, 0, 0], [0, 0, 0], [0, 1, 0], 4, 4),
    lambda s: packrt.Scene.create_rays_pinhole(60, [0, 0, 0], [0, 1, 0], [0, 1, 0], 4, 4),
    lambda s: packrt.Scene.create_rays_pinhole(60, [0, 0, 0], [0, 0, 1], [0, 1, 0], 0, 4),
])
def test_bad_queries_raise_packrt_error(call):
    with pytest.raises(packrt.Error):
        call(packrt.Scene(*R.cube()))


def test_save_load_and_open_answer_as_the_built_scene(tmp_path):
    v, t = R.icosphere(2)
    scene = packrt.Scene(v, t, spec="quad:float3-soa4")
    scene.save(tmp_path / "s.prt")
    rays = R.random_rays(1000)
    want = scene.cast_rays(rays)
    loaded = packrt.Scene.load(tmp_path / "s.prt")
    assert loaded.spec == scene.spec
    got = loaded.cast_rays(rays)
    assert got["primitive_normals"] is None  # a .prt file keeps no mesh
    for k in ("t_hit", "primitive_ids", "primitive_uvs", "geometry_ids"):
        assert np.array_equal(got[k], want[k])
    with_mesh = packrt.Scene.open(tmp_path / "s.prt", cache_bytes=1 << 20, vertices=v, triangles=t)
    assert np.array_equal(with_mesh.cast_rays(rays)["primitive_normals"], want["primitive_normals"])
    assert with_mesh.add_triangles(*R.cube(0.1)) == 1  # built again, in the file's representation
    assert with_mesh.spec == scene.spec and with_mesh.stats()["triangles"] == len(t) + 12
    with pytest.raises(packrt.Error, match="no more triangles"):
        loaded.add_triangles(*R.cube())
    with pytest.raises(packrt.Error, match="not the one"):
        packrt.Scene.load(tmp_path / "s.prt", vertices=v, triangles=t[:-1])
    (tmp_path / "bad.prt").write_bytes(b"PRT" + bytes(100))
    with pytest.raises(packrt.Error):
        packrt.Scene.load(tmp_path / "bad.prt")


def test_open_reads_an_out_of_core_block_file_through_a_small_cache(tmp_path):
    v, t = R.icosphere(3)
    packrt.Scene(v, t, spec="ooc").save(tmp_path / "o.prt")
    scene = packrt.Scene.open(tmp_path / "o.prt", cache_bytes=1 << 20, vertices=v, triangles=t)
    assert scene.spec.startswith("ooc")
    rays = R.random_rays(2000, seed=12)
    check_against_reference(scene.cast_rays(rays), rays, v, t)


def test_stats_split_bytes_into_tree_and_geometry():
    v, t = R.icosphere(3)
    st = packrt.Scene(v, t).stats()
    assert st["spec"].startswith(packrt.DEFAULT_SPEC) and st["triangles"] == len(t)
    assert st["bytes_tree"] > 0 and st["bytes_geometry"] > 0
    assert st["bytes"] == st["bytes_tree"] + st["bytes_geometry"] + st["bytes_other"]
    assert st["bytes_per_triangle_tree"] == pytest.approx(st["bytes_tree"] / len(t))
    assert st["bytes_per_triangle"] == pytest.approx(st["bytes"] / len(t))
    assert repr(packrt.Scene(v, t, spec="aabb:float3")).startswith("packrt.Scene(spec='aabb:float3")


def test_from_file_reads_a_ply_and_generate_makes_a_closed_sphere(tmp_path):
    v, t = R.cube()
    R.write_ply(tmp_path / "c.ply", v, t)
    scene = packrt.Scene.from_file(tmp_path / "c.ply", spec="aabb:float3")
    assert np.array_equal(scene.triangles, t) and np.array_equal(scene.vertices, v.astype(np.float32))
    check_against_reference(scene.cast_rays(R.random_rays(2000)), R.random_rays(2000), v, t)
    with pytest.raises(packrt.Error, match="nothing.ply"):
        packrt.Scene.from_file(tmp_path / "nothing.ply")
    sphere = packrt.Scene.generate("sphere", 2000)
    rays = np.zeros((100, 6), np.float32)  # from the centre outwards: all hit a closed sphere
    rays[:, 3:] = np.random.default_rng(0).normal(size=(100, 3))
    assert (sphere.cast_rays(rays)["primitive_ids"] != packrt.INVALID_ID).all()


def test_create_rays_pinhole_matches_open3d_geometry():
    w, h, fov = 9, 7, 60.0
    eye, center, up = np.array([1.0, 2, 5]), np.array([0.0, 0.5, 0]), np.array([0.0, 1, 0])
    rays = packrt.Scene.create_rays_pinhole(fov, center, eye, up, w, h)
    assert rays.shape == (h, w, 6) and rays.dtype == np.float32
    assert np.allclose(rays[..., :3], eye)
    fwd = (center - eye) / np.linalg.norm(center - eye)
    right = np.cross(up, fwd)  # Open3D's image x axis: cross(up, view)
    right /= np.linalg.norm(right)
    down = np.cross(fwd, right)
    d = rays[..., 3:].astype(np.float64)
    assert np.allclose(d @ fwd, 1, atol=1e-6)  # unit depth: t_hit is the z distance
    f = 0.5 * w / np.tan(np.radians(fov) / 2)  # fov_deg is horizontal, as Open3D's
    xs = (np.arange(w) + 0.5 - w / 2) / f
    ys = (np.arange(h) + 0.5 - h / 2) / f
    assert np.allclose(d @ right, np.broadcast_to(xs, (h, w)), atol=1e-6)
    assert np.allclose(d @ down, np.broadcast_to(ys[:, None], (h, w)), atol=1e-6)
    assert np.allclose(d[h // 2, w // 2], fwd, atol=1e-6)
    # Depth of a plane facing the camera is its distance along the view axis for every pixel.
    plane_v = np.array([[-50, -50, 0], [50, -50, 0], [50, 50, 0], [-50, 50, 0]], np.float64)
    scene = packrt.Scene(plane_v, np.array([[0, 1, 2], [0, 2, 3]]))
    straight = packrt.Scene.create_rays_pinhole(fov, [0, 0, 0], [0, 0, 4], up, w, h)
    assert np.allclose(scene.cast_rays(straight)["t_hit"], 4.0, rtol=1e-6)


def test_add_triangles_makes_geometries_with_their_own_ids():
    cube_v, cube_t = R.cube(0.5)
    sphere_v, sphere_t = R.icosphere(2, radius=0.5)
    sphere_v = sphere_v + [2.0, 0, 0]
    soup_v, soup_t = R.soup(50, seed=3)
    soup_v = soup_v * 0.3 + [-2.0, 0, 0]
    scene = packrt.Scene()
    assert repr(scene) == "packrt.Scene(no triangles)"
    with pytest.raises(packrt.Error, match="no triangles"):
        scene.cast_rays(np.zeros(6))
    assert scene.add_triangles(cube_v, cube_t) == 0
    assert scene.add_triangles(types.SimpleNamespace(vertices=sphere_v, faces=sphere_t)) == 1
    assert scene.add_triangles(soup_v, soup_t) == 2
    # The brute force on the three meshes together, with scene-wide triangle ids.
    v = np.concatenate([cube_v, sphere_v, soup_v])
    t = np.concatenate([cube_t, sphere_t + len(cube_v), soup_t + len(cube_v) + len(sphere_v)])
    first = np.array([0, len(cube_t), len(cube_t) + len(sphere_t)])
    rng = np.random.default_rng(13)
    o = np.concatenate([rng.uniform(-3, 3, (3000, 1)), rng.uniform(-1, 1, (3000, 1)), np.full((3000, 1), 4.0)], 1)
    rays = np.concatenate([o, np.tile([0, 0, -1.0], (3000, 1)) + rng.normal(0, 0.05, (3000, 3))], 1).astype(np.float32)
    ans = scene.cast_rays(rays)
    _, rprim, _, _, amb = R.closest_hits(rays, v, t)
    hit = ~amb & (rprim >= 0)
    geom = np.searchsorted(first, rprim[hit], side="right") - 1
    assert set(geom) == {0, 1, 2}
    assert np.array_equal(ans["geometry_ids"][hit], geom)
    assert np.array_equal(ans["primitive_ids"][hit], rprim[hit] - first[geom])
    miss = ~amb & (rprim < 0)
    assert miss.any() and (ans["geometry_ids"][miss] == packrt.INVALID_ID).all()
    assert (ans["primitive_ids"][miss] == packrt.INVALID_ID).all()
    # A scene built from arrays takes more geometries too: its mesh is geometry 0.
    grown = packrt.Scene(cube_v, cube_t)
    assert grown.add_triangles(sphere_v, sphere_t) == 1
    assert set(grown.cast_rays(rays)["geometry_ids"][hit]) <= {0, 1, packrt.INVALID_ID}
