"""packrt for Python: numpy arrays in, numpy arrays out, over libpackrt.so (cffi, ABI mode).

    import packrt
    scene = packrt.Scene(vertices, triangles)          # (V, 3) float, (T, 3) int
    ans = scene.cast_rays(rays)                        # rays (..., 6): origin, direction
    ans["t_hit"], ans["primitive_ids"], ans["primitive_normals"]

The names follow Open3D's RaycastingScene; packrt.trimesh has trimesh's ray interface.
"""
from ._ffi import library_path
from .scene import DEFAULT_SPEC, INVALID_ID, Error, Scene, has_mesh_queries

__all__ = ["Scene", "Error", "INVALID_ID", "DEFAULT_SPEC", "has_mesh_queries", "library_path"]
