"""``godot``: the occluder bake of the Godot 4 engine, reproduced with meshoptimizer.

Godot's ``OccluderInstance3D::_bake_surface`` skips every surface whose
material is transparent (alpha blending or alpha scissor), moves the
surface's vertices to world space and simplifies it on its own with
meshoptimizer's ``meshopt_simplify``:

References
----------
.. [1] Godot Engine contributors. ``OccluderInstance3D::_bake_surface``,
   scene/3d/occluder_instance_3d.cpp, Godot Engine 4,
   https://github.com/godotengine/godot (the bake reproduced here)
.. [2] Kapoulkine, A. "meshoptimizer: Mesh optimization library",
   https://github.com/zeux/meshoptimizer (``meshopt_simplify``,
   ``meshopt_simplifyScale``)
.. [3] Garland, M., Heckbert, P. S. "Surface Simplification Using Quadric Error
   Metrics". Proceedings of SIGGRAPH '97, ACM, 1997, pp. 209-216.
   :DOI:`10.1145/258734.258849` (the error metric meshoptimizer's simplifier uses)
"""

from __future__ import annotations

import numbers
import time

import numpy as np
import trimesh

from viscore import InputError, validate_mesh
from viscore._validate import as_points
from viscore.level.scene_graph import transparent_material

from ..occluder import Occluder

__all__ = ["generate_godot", "bake_surface"]

#: Godot's cap on the simplified index count of one surface (12 triangles).
GODOT_TARGET_INDEX_COUNT = 36

#: Default bake distance as a share of the bounding-box diagonal: Godot's default
#: ``bake_simplification_distance`` is 0.1 m, about 1% of a 10 m building's diagonal.
DEFAULT_DISTANCE_SHARE = 0.01


def bake_surface(vertices: np.ndarray, faces: np.ndarray, distance: float
                 ) -> tuple[np.ndarray, np.ndarray, float]:
    """Simplify one surface as Godot's occluder bake does.

    Parameters
    ----------
    vertices : (n, 3) float
        World-space positions, converted to float32 for meshoptimizer after a
        scaling by a power of two that brings the largest coordinate to [1, 2):
        float32 then holds any mesh viscore accepts (1e-90 to 1e90, beyond
        float32's range), and the result is the same as unscaled wherever
        float32 holds the mesh (a power of two scales float32 values exactly).
    faces : (f, 3) int
        Triangles indexing ``vertices``.
    distance : float
        Bake simplification distance, world units, >= 0; 0 keeps the surface.

    Returns
    -------
    vertices : (m, 3) float64
        The referenced vertices of the simplified surface.
    faces : (g, 3) int64
        Its triangles, ``g <= f``.
    error : float
        meshoptimizer's resulting error, world units (0 when not simplified).

    Examples
    --------
    >>> import trimesh
    >>> sphere = trimesh.creation.icosphere(subdivisions=3)
    >>> v, f, err = bake_surface(sphere.vertices, sphere.faces, 0.5)
    >>> len(f) < len(sphere.faces)
    True
    """
    import meshoptimizer

    faces = np.asarray(faces, dtype=np.int64)
    vertices = np.asarray(vertices, dtype=np.float64)
    peak = float(np.abs(vertices).max()) if vertices.size else 0.0
    shift = 2.0 ** -np.floor(np.log2(peak)) if peak > 0 else 1.0  # exact in float32
    positions = np.ascontiguousarray(vertices * shift, dtype=np.float32)
    error = 0.0
    if distance > 0 and len(faces):
        indices = np.ascontiguousarray(faces.reshape(-1), dtype=np.uint32)
        stride = positions.itemsize * 3
        scale = meshoptimizer.simplify_scale(positions, len(positions), stride)
        destination = np.empty(len(indices), dtype=np.uint32)
        result_error = np.zeros(1, dtype=np.float32)
        # relative to the mesh; a distance beyond float32's range: simplify all it can
        relative = float(distance) * shift / float(scale) if scale > 0 else np.inf
        target = float(np.float32(min(relative, float(np.finfo(np.float32).max))))
        count = meshoptimizer.simplify(
            destination, indices, positions, len(indices), len(positions), stride,
            target_index_count=min(len(indices), GODOT_TARGET_INDEX_COUNT),
            target_error=target,
            options=meshoptimizer.SIMPLIFY_LOCK_BORDER, result_error=result_error)
        faces = destination[:count].astype(np.int64).reshape(-1, 3)
        error = float(result_error[0]) * float(scale) / shift
    used, inverse = np.unique(faces.reshape(-1), return_inverse=True)
    return vertices[used], inverse.reshape(-1, 3).astype(np.int64), error


def _surfaces(mesh) -> tuple[list[tuple[np.ndarray, np.ndarray]], int]:
    """World-space (vertices, faces) per surface, and the number of transparent ones dropped."""
    if isinstance(mesh, trimesh.Trimesh):
        return [(np.asarray(mesh.vertices, dtype=np.float64),
                 np.asarray(mesh.faces, dtype=np.int64))], 0
    if isinstance(mesh, trimesh.Scene):
        out, dropped = [], 0
        for node in mesh.graph.nodes_geometry:
            transform, name = mesh.graph[node]
            geometry = mesh.geometry[name]
            if not isinstance(geometry, trimesh.Trimesh) or len(geometry.faces) == 0:
                continue
            if transparent_material(geometry):
                dropped += 1
                continue
            out.append((trimesh.transform_points(geometry.vertices, transform),
                        np.asarray(geometry.faces, dtype=np.int64)))
        return out, dropped
    raise InputError(f"mesh: expected a trimesh.Trimesh or trimesh.Scene, "
                     f"got {type(mesh).__name__}")


def generate_godot(mesh: trimesh.Trimesh | trimesh.Scene, *, distance: float | None = None,
                   budget: int | None = None, seed: int = 0) -> Occluder:
    """Godot 4's occluder bake: meshoptimizer simplification per surface, borders locked.

    Parameters
    ----------
    mesh : trimesh.Trimesh or trimesh.Scene
        A mesh (one surface) or a scene (one surface per placed geometry;
        transparent materials dropped).
    distance : float, optional
        Godot's ``bake_simplification_distance`` in world units, >= 0 (0: no
        simplification). Default: 1% of the bounding-box diagonal.
    budget : int, optional
        Ignored (not a budgeted method); accepted for the common signature.
        :func:`viscore.generators.generate` flags a result over it.
    seed : int, optional
        Unused (deterministic); accepted for the common signature.

    Returns
    -------
    Occluder
        Double-sided (the simplified surfaces may be open). ``params``:
        ``distance`` used; ``info``: ``surfaces`` baked,
        ``transparent_surfaces_dropped``, ``error`` (largest meshoptimizer
        error over the surfaces, world units).

    Raises
    ------
    InputError
        On a negative or non-finite distance, or when no opaque surface is left.

    Notes
    -----
    Deterministic. Not conservative. Open boundaries are locked: on meshes
    made of open parts (a building of separate wall panels) little or nothing
    is removed.

    Examples
    --------
    >>> occ = generate_godot(trimesh.creation.icosphere(subdivisions=3), distance=0.2)
    >>> occ.triangles < 1280
    True
    """
    start = time.perf_counter()
    surfaces, dropped = _surfaces(mesh)
    if not surfaces:
        raise InputError("mesh: no opaque surface to bake"
                         + (f" ({dropped} transparent dropped)" if dropped else ""))
    points = np.concatenate([v[np.unique(f)] for v, f in surfaces if len(f)])
    points = as_points(points, "mesh vertices")
    if distance is None:
        distance = DEFAULT_DISTANCE_SHARE * float(np.linalg.norm(np.ptp(points, axis=0)))
    elif (isinstance(distance, bool) or not isinstance(distance, numbers.Real)
          or not np.isfinite(distance) or distance < 0):
        raise InputError(f"distance: expected a finite number >= 0, got {distance!r}")
    distance = float(distance)
    all_vertices, all_faces, offset, worst = [], [], 0, 0.0
    for vertices, faces in surfaces:
        v, f, err = bake_surface(vertices, faces, distance)
        all_vertices.append(v)
        all_faces.append(f + offset)
        offset += len(v)
        worst = max(worst, err)
    out = trimesh.Trimesh(np.concatenate(all_vertices), np.concatenate(all_faces), process=False)
    if len(out.faces) == 0:
        raise InputError("mesh: the bake removed every triangle")
    out = validate_mesh(out, name="godot")
    return Occluder(mesh=out, method="godot", params={"distance": distance},
                    double_sided=True, seconds=time.perf_counter() - start,
                    info={"surfaces": len(surfaces), "transparent_surfaces_dropped": dropped,
                          "error": worst})
