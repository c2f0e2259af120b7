"""packrt.trimesh.RayMeshIntersector in the scenarios of trimesh's own ray tests (trimesh is
not in Debian, so they are rewritten here): cube containment, rays through vertices and
edges, multiple hits, empty input. Each runs on the library's mesh queries ("native", skipped
while the library lacks them) and on the fallback that casts again past each hit ("recast")."""
import types

import numpy as np
import pytest

import packrt
import packrt.trimesh as ptm
import reference as R


@pytest.fixture(params=["native", "recast"])
def mode(request, monkeypatch):
    if request.param == "native" and not packrt.has_mesh_queries():
        pytest.skip("this libpackrt.so has no mesh queries yet (issue 28)")
    if request.param == "recast":
        monkeypatch.setattr(ptm, "has_mesh_queries", lambda: False)
    return request.param


def box():
    return ptm.RayMeshIntersector(*R.cube())


def test_accepts_a_mesh_object_or_arrays_and_answers_intersects_first():
    v, t = R.icosphere(2)
    by_object = ptm.RayMeshIntersector(types.SimpleNamespace(vertices=v, faces=t))
    rays = R.random_rays(2000, seed=31)
    first = by_object.intersects_first(rays[:, :3], rays[:, 3:])
    assert first.dtype == np.int64 and first.shape == (2000,)
    _, rprim, _, _, amb = R.closest_hits(rays, v, t)
    assert np.array_equal(first[~amb], rprim[~amb])  # -1 on a miss, as trimesh
    assert (first == -1).any()
    assert np.array_equal(ptm.RayMeshIntersector(v, t).intersects_first(rays[:, :3], rays[:, 3:]), first)
    assert np.array_equal(by_object.intersects_any(rays[:, :3], rays[:, 3:]), first >= 0)


def test_contains_points_of_a_cube(mode):
    ray = box()
    p = np.random.default_rng(0).uniform(-2, 2, (3000, 3))
    d = np.abs(p).max(axis=1)
    p = p[np.abs(d - 1) > 1e-3]  # away from the surface, where inside/outside is clear
    got = ray.contains_points(p)
    assert got.dtype == np.bool_
    assert np.array_equal(got, d[np.abs(d - 1) > 1e-3] < 1)
    assert ray.contains_points([0.0, 0.0, 0.0]).tolist() == [True]  # a single point
    assert ray.contains_points(np.zeros((0, 3))).shape == (0,)


def test_contains_points_of_an_icosphere_against_the_winding_number(mode):
    v, t = R.icosphere(2)
    p = np.random.default_rng(1).uniform(-1.2, 1.2, (2000, 3))
    _, dist, _, _ = R.closest_points(p, v, t)
    p = p[dist > 1e-3]
    assert np.array_equal(ptm.RayMeshIntersector(v, t).contains_points(p), R.winding_numbers(p, v, t) > 0.5)


def test_rays_through_vertices_hit_once(mode):
    ray = box()
    v, _ = R.cube()
    origins = np.zeros_like(v)
    assert ray.intersects_any(origins, v).all()
    locations, index_ray, index_tri = ray.intersects_location(origins, v)
    assert np.array_equal(np.bincount(index_ray, minlength=len(v)), np.ones(len(v)))
    assert np.allclose(locations[np.argsort(index_ray)], v)


def test_rays_through_edges_enter_and_leave_once(mode):
    ray = box()
    mids = np.array([[1, 1, 0], [1, -1, 0], [-1, 1, 0], [-1, -1, 0], [0, 1, 1], [0, -1, -1], [1, 0, 1], [-1, 0, 1]],
                    np.float64)
    # From the centre out through each edge's midpoint: one crossing.
    _, index_ray, _ = ray.intersects_location(np.zeros_like(mids), mids)
    assert np.array_equal(np.bincount(index_ray, minlength=len(mids)), np.ones(len(mids)))
    # From outside, in through one edge and out through the opposite one: two crossings.
    locations, index_ray, _ = ray.intersects_location(-2 * mids, mids)
    assert np.array_equal(np.bincount(index_ray, minlength=len(mids)), 2 * np.ones(len(mids)))
    order = np.lexsort((np.linalg.norm(locations - (-2 * mids)[index_ray], axis=1), index_ray))
    assert np.allclose(locations[order], np.stack([-mids, mids], axis=1).reshape(-1, 3), atol=1e-6)


def test_multiple_hits_list_every_crossing_nearest_first(mode):
    ray = box()
    rng = np.random.default_rng(2)
    n = 200
    origins = np.concatenate([rng.uniform(-0.9, 0.9, (n, 2)), np.full((n, 1), -5.0)], axis=1)
    dirs = np.tile([0.0, 0.0, 1.0], (n, 1))
    index_tri, index_ray, locations = ray.intersects_id(origins, dirs, return_locations=True)
    assert index_tri.dtype == np.int64 and index_ray.dtype == np.int64 and locations.dtype == np.float64
    assert np.array_equal(np.bincount(index_ray, minlength=n), np.full(n, 2))
    assert np.array_equal(index_ray, np.repeat(np.arange(n), 2))  # by ray, nearest first
    assert np.allclose(locations[:, 2], np.tile([-1.0, 1.0], n))
    assert np.allclose(locations[:, :2], np.repeat(origins[:, :2], 2, axis=0))
    v, t = R.cube()
    centroid_z = v[t].mean(axis=1)[:, 2]
    assert np.array_equal(centroid_z[index_tri], np.tile([-1.0, 1.0], n))  # triangles of the -z then +z face
    tri1, ray1 = ray.intersects_id(origins, dirs, multiple_hits=False)
    assert np.array_equal(ray1, np.arange(n)) and np.array_equal(tri1, index_tri[::2])


def test_multiple_hits_of_a_soup_match_brute_force_and_respect_max_hits(mode):
    v, t = R.soup(300, seed=4)
    ray = ptm.RayMeshIntersector(v, t)
    rays = R.random_rays(300, seed=5, spread=0.8)
    ref = R.all_hits(rays, v, t)
    ok = np.array([not a for _, _, a in ref])
    assert ok.mean() > 0.8
    index_tri, index_ray = ray.intersects_id(rays[:, :3], rays[:, 3:], max_hits=1000)
    for i in np.flatnonzero(ok):
        assert np.array_equal(index_tri[index_ray == i], ref[i][1]), i
    assert max(len(r[1]) for r in ref) > 3
    capped_tri, capped_ray = ray.intersects_id(rays[:, :3], rays[:, 3:], max_hits=2)
    for i in np.flatnonzero(ok):
        assert np.array_equal(capped_tri[capped_ray == i], ref[i][1][:2]), i


def test_empty_input_gives_empty_answers(mode):
    ray = box()
    empty = np.zeros((0, 3))
    locations, index_ray, index_tri = ray.intersects_location(empty, empty)
    assert locations.shape == (0, 3) and index_ray.shape == (0,) and index_tri.shape == (0,)
    assert ray.intersects_first(empty, empty).shape == (0,)
    assert ray.intersects_any(empty, empty).shape == (0,)
    tri, rid = ray.intersects_id(empty, empty, multiple_hits=False)
    assert tri.shape == rid.shape == (0,)


def test_mismatched_origins_and_directions_raise():
    with pytest.raises(packrt.Error):
        box().intersects_first(np.zeros((3, 3)), np.zeros((2, 3)))
