"""The mesh queries under Open3D's names (count_intersections, list_intersections,
compute_closest_points, compute_distance, compute_signed_distance, compute_occupancy) against
the double-precision brute force. They need a library with issue 28's functions; against one
without, only the last test runs (the clear error)."""
import numpy as np
import pytest

import packrt
import reference as R

needs_queries = pytest.mark.skipif(not packrt.has_mesh_queries(),
                                   reason="this libpackrt.so has no mesh queries yet (issue 28)")
MESHES = {"cube": R.cube(), "icosphere": R.icosphere(2), "soup": R.soup(100, seed=9)}


def open_box():
    """The cube without its +z face: open, so parity and winding disagree near the hole."""
    v, t = R.cube()
    keep = ~(v[t][:, :, 2] > 0).all(axis=1)
    return v, t[keep]


@needs_queries
@pytest.mark.parametrize("name", MESHES)
def test_count_and_list_intersections_match_brute_force(name):
    v, t = MESHES[name]
    scene = packrt.Scene(v, t)
    rays = R.random_rays(400, seed=41)
    ref = R.all_hits(rays, v, t)
    ok = np.array([not a for _, _, a in ref])
    assert ok.mean() > 0.8
    counts = scene.count_intersections(rays)
    assert counts.dtype == np.int32 and counts.shape == (400,)
    assert np.array_equal(counts[ok], [len(ref[i][1]) for i in np.flatnonzero(ok)])
    ans = scene.list_intersections(rays)
    splits = ans["ray_splits"]
    assert splits.shape == (401,) and splits[0] == 0 and np.array_equal(np.diff(splits), counts)
    assert np.array_equal(ans["ray_ids"], np.repeat(np.arange(400), counts))
    v1 = v[t[ans["primitive_ids"], 1]] - v[t[ans["primitive_ids"], 0]]
    v2 = v[t[ans["primitive_ids"], 2]] - v[t[ans["primitive_ids"], 0]]
    for i in np.flatnonzero(ok):
        s = slice(splits[i], splits[i + 1])
        assert np.array_equal(ans["primitive_ids"][s], ref[i][1]), i
        np.testing.assert_allclose(ans["t_hit"][s], ref[i][0], rtol=2e-5, atol=1e-6)
        # The barycentrics rebuild the point on the ray.
        uv = ans["primitive_uvs"][s].astype(np.float64)
        p = v[t[ref[i][1], 0]] + uv[:, :1] * v1[s] + uv[:, 1:] * v2[s]
        np.testing.assert_allclose(p, rays[i, :3] + ref[i][0][:, None] * rays[i, 3:].astype(np.float64), atol=1e-4)
    assert counts.max() >= 2


@needs_queries
def test_counts_keep_the_rays_shape_and_interval_and_do_not_depend_on_threads():
    v, t = R.icosphere(2)
    scene = packrt.Scene(v, t)
    rays = R.random_rays(6000, seed=42)
    c = scene.count_intersections(rays.reshape(20, 300, 6), tfar=1.0)
    assert c.shape == (20, 300)
    ref = R.all_hits(rays[:300], v, t, tfar=1.0)
    ok = np.array([not a for _, _, a in ref])
    assert np.array_equal(c[0][ok], [len(ref[i][1]) for i in np.flatnonzero(ok)])
    assert np.array_equal(scene.count_intersections(rays, threads=1), scene.count_intersections(rays, threads=0))


@needs_queries
def test_rays_through_cube_edges_and_vertices_cross_once_per_side():
    scene = packrt.Scene(*R.cube())
    through = np.array([[1, 1, 0], [1, 0, -1], [0, -1, 1], [1, 1, 1], [-1, 1, -1]], np.float64)
    rays = np.concatenate([-3 * through, through], axis=1)
    assert np.array_equal(scene.count_intersections(rays), np.full(len(through), 2))
    out = np.concatenate([np.zeros_like(through), through], axis=1)
    assert np.array_equal(scene.count_intersections(out), np.ones(len(through)))


@needs_queries
@pytest.mark.parametrize("name", MESHES)
def test_compute_closest_points_matches_brute_force(name):
    v, t = MESHES[name]
    scene = packrt.Scene(v, t)
    p = np.random.default_rng(43).uniform(-2, 2, (1500, 3)).astype(np.float32)
    q, dist, prim, second = R.closest_points(p, v, t)
    ans = scene.compute_closest_points(p.reshape(30, 50, 3))
    assert ans["points"].shape == (30, 50, 3) and ans["primitive_ids"].shape == (30, 50)
    got = {k: a.reshape((1500,) + a.shape[2:]) for k, a in ans.items()}
    assert (np.abs(got["points"] - q) <= 2e-5 * (1 + dist[:, None])).all()
    # Where several triangles are about as near (edges and corners of closed meshes), any of
    # them will do: the one named must be as near as the nearest.
    _, all_dist = R.point_triangle(p, v, t)
    named = all_dist[np.arange(len(p)), got["primitive_ids"]]
    assert (np.abs(named - dist) <= 1e-5 * (1 + dist)).all()
    clear = second - dist > 1e-4
    assert clear.mean() > 0.2
    assert np.array_equal(got["primitive_ids"][clear], prim[clear])
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    np.testing.assert_allclose(got["primitive_normals"][clear], n[prim[clear]], atol=1e-5)
    assert (got["geometry_ids"] == 0).all()
    uv = got["primitive_uvs"].astype(np.float64)
    tri = v[t[got["primitive_ids"]]]
    rebuilt = tri[:, 0] + uv[:, :1] * (tri[:, 1] - tri[:, 0]) + uv[:, 1:] * (tri[:, 2] - tri[:, 0])
    np.testing.assert_allclose(rebuilt, q, atol=1e-4)
    np.testing.assert_allclose(scene.compute_distance(p), dist, rtol=1e-5, atol=1e-6)


@needs_queries
def test_closest_points_of_non_finite_points_are_invalid():
    scene = packrt.Scene(*R.cube())
    ans = scene.compute_closest_points(np.array([[np.nan, 0, 0], [0, 0, 0]], np.float32))
    assert ans["primitive_ids"][0] == packrt.INVALID_ID and ans["geometry_ids"][0] == packrt.INVALID_ID
    assert ans["primitive_ids"][1] != packrt.INVALID_ID
    assert np.isinf(scene.compute_distance(np.array([np.inf, 0, 0], np.float32)))


@needs_queries
@pytest.mark.parametrize("name", ["cube", "icosphere"])
def test_signed_distance_and_occupancy_of_closed_meshes(name):
    v, t = MESHES[name]
    scene = packrt.Scene(v, t)
    p = np.random.default_rng(44).uniform(-1.5, 1.5, (2000, 3)).astype(np.float32)
    _, dist, _, _ = R.closest_points(p, v, t)
    p, dist = p[dist > 1e-3], dist[dist > 1e-3]
    inside = R.winding_numbers(p, v, t) > 0.5
    assert inside.any() and not inside.all()
    occ = scene.compute_occupancy(p)
    assert occ.dtype == np.float32 and np.array_equal(occ, inside.astype(np.float32))
    sd = scene.compute_signed_distance(p)
    np.testing.assert_allclose(sd, np.where(inside, -dist, dist), rtol=1e-5, atol=1e-6)
    assert np.array_equal(scene.compute_occupancy(p, threads=1), scene.compute_occupancy(p, threads=0))


@needs_queries
def test_winding_number_and_containment_of_an_open_mesh():
    v, t = open_box()
    scene = packrt.Scene(v, t)
    p = np.random.default_rng(45).uniform(-1.5, 1.5, (2000, 3)).astype(np.float32)
    _, dist, _, _ = R.closest_points(p, v, t)
    p = p[dist > 1e-3]
    w = R.winding_numbers(p, v, t)
    np.testing.assert_allclose(scene.compute_winding_number(p), w, atol=1e-4)
    assert ((w > 0.1) & (w < 0.9)).any()  # the hole makes fractional values
    clear = np.abs(w - 0.5) > 1e-3
    assert np.array_equal(scene.compute_occupancy(p)[clear] > 0, (w >= 0.5)[clear])
    # The fast winding number (Barill et al. 2018, beta 2) within 0.01 of the exact one, and
    # containment by it alone.
    np.testing.assert_allclose(scene.compute_winding_number(p, beta=2), w, atol=1e-2)
    clear = np.abs(w - 0.5) > 1e-2
    assert np.array_equal(scene.compute_occupancy(p, method="winding")[clear] > 0, (w >= 0.5)[clear])
    with pytest.raises(packrt.Error, match="method"):
        scene.compute_occupancy(p, method="vote")


@needs_queries
def test_representations_without_mesh_queries_raise_unsupported():
    v, t = R.icosphere(2)
    with pytest.raises(packrt.Error, match="unsupported"):
        packrt.Scene(v, t, spec="raystrips").count_intersections(R.random_rays(4))


@pytest.mark.skipif(packrt.has_mesh_queries(), reason="the library has the mesh queries")
def test_a_library_without_mesh_queries_says_so():
    scene = packrt.Scene(*R.cube())
    for call in (lambda: scene.count_intersections(np.zeros((1, 6))), lambda: scene.compute_distance(np.zeros(3)),
                 lambda: scene.compute_occupancy(np.zeros(3))):
        with pytest.raises(packrt.Error, match="mesh queries"):
            call()


@needs_queries
def test_point_and_crossing_queries_name_add_triangles_geometries():
    a_v, a_t = R.cube(0.5)
    b_v, b_t = R.icosphere(2, radius=0.5)
    b_v = b_v + [2.0, 0, 0]
    scene = packrt.Scene()
    scene.add_triangles(a_v, a_t)
    scene.add_triangles(b_v, b_t)
    p = np.array([[-0.9, 0.1, 0.2], [2.9, 0.1, 0.0], [0.1, 0.0, 0.0], [2.1, 0.05, 0.0]], np.float32)
    ans = scene.compute_closest_points(p)
    assert ans["geometry_ids"].tolist() == [0, 1, 0, 1]
    assert (ans["primitive_ids"][[1, 3]] < len(b_t)).all()
    d_a = R.point_triangle(p[[0, 2]], a_v, a_t)[1]
    assert np.allclose(d_a[[0, 1], ans["primitive_ids"][[0, 2]]], d_a.min(axis=1), atol=1e-6)
    rays = np.array([[-3, 0.1, 0.05, 1, 0, 0]], np.float32)  # through the cube, then the sphere
    hits = scene.list_intersections(rays)
    assert hits["geometry_ids"].tolist() == [0, 0, 1, 1]
    assert (hits["primitive_ids"][:2] < len(a_t)).all() and (hits["primitive_ids"][2:] < len(b_t)).all()
