"""packrt.trimesh.RayMeshIntersector: trimesh's ray interface (trimesh.ray.ray_pyembree /
ray_triangle) on packrt, so code written for `mesh.ray` runs unchanged:

    from packrt.trimesh import RayMeshIntersector
    ray = RayMeshIntersector(mesh)            # anything with .vertices and .faces, or
    ray = RayMeshIntersector(vertices, faces)
    locations, index_ray, index_tri = ray.intersects_location(origins, directions)

Return values follow trimesh: triangle and ray indices are int64, a miss in intersects_first
is -1, locations are float64. Directions need not be unit length. Hits of one ray are listed
together, nearest first. Crossings through a shared edge or vertex count once (the library's
watertight test), the case trimesh's own intersectors get wrong.
"""
import numpy as np

from .scene import INVALID_ID, Error, Scene, has_mesh_queries


def _origins_directions(ray_origins, ray_directions):
    o = np.asarray(ray_origins, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(ray_directions, dtype=np.float64).reshape(-1, 3)
    if o.shape != d.shape:
        raise Error("invalid argument", f"{len(o)} ray origins but {len(d)} directions")
    return o, d, np.concatenate([o, d], axis=1).astype(np.float32)


class RayMeshIntersector:
    """trimesh's RayMeshIntersector over a packrt Scene (spec None: packrt.DEFAULT_SPEC)."""

    def __init__(self, geometry, faces=None, spec=None, threads=0):
        if faces is None:  # a trimesh.Trimesh, or anything with vertices and faces
            geometry, faces = geometry.vertices, geometry.faces
        self.scene = Scene(np.asarray(geometry, dtype=np.float64), np.asarray(faces), spec=spec, threads=threads)
        self.threads = threads

    def intersects_first(self, ray_origins, ray_directions, **kwargs):
        """Index of the first triangle each ray hits, -1 for a miss (int64)."""
        _, _, rays = _origins_directions(ray_origins, ray_directions)
        prim = self.scene.cast_rays(rays, threads=self.threads)["primitive_ids"]
        return np.where(prim == INVALID_ID, -1, prim.astype(np.int64))

    def intersects_any(self, ray_origins, ray_directions, **kwargs):
        """True for each ray that hits the mesh."""
        _, _, rays = _origins_directions(ray_origins, ray_directions)
        return self.scene.test_occlusions(rays, threads=self.threads)

    def intersects_id(self, ray_origins, ray_directions, multiple_hits=True, max_hits=20, return_locations=False,
                      **kwargs):
        """(index_tri, index_ray[, locations]) of the hits: the first of each ray, or with
        multiple_hits up to max_hits crossings of each ray, nearest first."""
        o, d, rays = _origins_directions(ray_origins, ray_directions)
        if multiple_hits:
            index_ray, index_tri, t = self._all_hits(rays, max_hits)
        else:
            ans = self.scene.cast_rays(rays, threads=self.threads)
            index_ray = np.flatnonzero(ans["primitive_ids"] != INVALID_ID)
            index_tri = ans["primitive_ids"][index_ray].astype(np.int64)
            t = ans["t_hit"][index_ray]
        if not return_locations:
            return index_tri, index_ray
        locations = o[index_ray] + d[index_ray] * t.astype(np.float64)[:, None]
        return index_tri, index_ray, locations

    def intersects_location(self, ray_origins, ray_directions, multiple_hits=True, **kwargs):
        """(locations, index_ray, index_tri) of the hits, as intersects_id."""
        index_tri, index_ray, locations = self.intersects_id(ray_origins, ray_directions, multiple_hits=multiple_hits,
                                                             return_locations=True, **kwargs)
        return locations, index_ray, index_tri

    def intersects_count(self, ray_origins, ray_directions):
        """Number of crossings of each ray (int64), as the multiple-hit methods count them."""
        _, _, rays = _origins_directions(ray_origins, ray_directions)
        index_ray, _, _ = self._all_hits(rays, None)
        return np.bincount(index_ray, minlength=len(rays)).astype(np.int64)

    def contains_points(self, points):
        """True for each (n, 3) point inside the mesh (library containment: crossing parity
        along several rays, the generalized winding number where they disagree)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if has_mesh_queries():
            return self.scene._contains(p, self.threads, None)
        # Libraries without containment: parity along three fixed skew directions, majority.
        dirs = np.array([[0.4395064455, 0.617598629942, 0.652231566745],
                         [-0.70710678, 0.0012312, 0.70710567],
                         [0.1235, -0.981, 0.149]])
        votes = np.zeros(len(p), np.int64)
        for d in dirs:
            votes += self.intersects_count(p, np.broadcast_to(d, p.shape)) % 2
        return votes >= 2

    def _all_hits(self, rays, max_hits):
        """(index_ray int64, index_tri int64, t float32) of every crossing, by ray, nearest first."""
        if has_mesh_queries():
            ans = self.scene.list_intersections(rays, threads=self.threads)
            index_ray = ans["ray_ids"].astype(np.int64)
            index_tri = ans["primitive_ids"].astype(np.int64)
            t = ans["t_hit"]
            if max_hits is not None:
                rank = np.arange(len(index_ray)) - ans["ray_splits"][:-1].astype(np.int64)[index_ray]
                keep = rank < max_hits
                index_ray, index_tri, t = index_ray[keep], index_tri[keep], t[keep]
            return index_ray, index_tri, t
        return self._all_hits_recast(rays, max_hits)

    def _all_hits_recast(self, rays, max_hits):
        """Libraries without prt_intersect_all: cast again from just past each hit (tnear =
        the next float after t). Every triangle met at the same t is skipped together, so a
        crossing through an edge or vertex counts once, but so does a coplanar overlap."""
        n = len(rays)
        tnear = np.zeros(n, np.float32)
        active = np.arange(n)
        found = []
        rounds = 0
        while len(active) and (max_hits is None or rounds < max_hits):
            ans = self.scene.cast_rays(rays[active], tnear=tnear[active], threads=self.threads)
            hit = ans["primitive_ids"] != INVALID_ID
            active = active[hit]
            t = ans["t_hit"][hit]
            found.append((active, ans["primitive_ids"][hit].astype(np.int64), t, rounds))
            tnear[active] = np.nextafter(t, np.float32(np.inf))
            rounds += 1
        if not found:
            return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.float32)
        index_ray = np.concatenate([f[0] for f in found]).astype(np.int64)
        index_tri = np.concatenate([f[1] for f in found])
        t = np.concatenate([f[2] for f in found])
        rank = np.concatenate([np.full(len(f[0]), f[3]) for f in found])
        order = np.lexsort((rank, index_ray))
        return index_ray[order], index_tri[order], t[order]
