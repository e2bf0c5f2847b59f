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
.. [4] Godot Engine contributors. ``GLTFDocument::_parse_meshes``,
   modules/gltf/gltf_document.cpp; ``SurfaceTool::create_from_triangle_arrays``
   and ``SurfaceTool::index``, scene/resources/surface_tool.cpp; Godot Engine 4,
   https://github.com/godotengine/godot (the importer emulated here)
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import trimesh

from viscore import InputError, validate_mesh
from viscore._validate import as_points
from viscore.level.scene_graph import transparent_material

from ..occluder import Occluder
from ..specs import GeneratorOption, checked_by

__all__ = ["generate_godot", "bake_surface", "godot_imported_surface", "OPTIONS"]

#: Godot's cap on the simplified index count of one surface (12 triangles).
GODOT_TARGET_INDEX_COUNT = 36

#: Default bake distance as a share of the bounding-box diagonal: Godot's default
#: ``bake_simplification_distance`` is 0.1 m, about 1% of a 10 m building's diagonal.
DEFAULT_DISTANCE_SHARE = 0.01

#: The options of :func:`generate_godot`, declared once: the registry's spec, the command
#: line's flags and the generator's own checks (:func:`..specs.checked_by`).
OPTIONS = (
    GeneratorOption("distance", float, None,
                    "bake simplification distance in world units; 0 keeps the mesh",
                    low=0, default_text="1% of the bounding-box diagonal"),
)


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


@checked_by(OPTIONS)
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
    if distance is None:  # (a given distance is checked by OPTIONS)
        distance = DEFAULT_DISTANCE_SHARE * float(np.linalg.norm(np.ptp(points, axis=0)))
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


def _file_normals(path: Path) -> dict[str, np.ndarray]:
    """The vertex normals a glTF file holds, by trimesh's geometry name (none: not there).

    Read from trimesh's glTF reader's own output (:func:`trimesh.exchange.gltf.load_glb`,
    ``load_gltf``), which passes a primitive's ``NORMAL`` attribute on as
    ``vertex_normals`` and leaves the key out when the file has none.
    """
    from trimesh.exchange.gltf import load_glb, load_gltf

    with open(path, "rb") as fh:
        if path.suffix.lower() == ".glb":
            doc = load_glb(fh)
        else:
            doc = load_gltf(fh, resolver=trimesh.resolvers.FilePathResolver(path))  # type: ignore[arg-type]
    return {name: np.asarray(kwargs["vertex_normals"])
            for name, kwargs in doc.get("geometry", {}).items()
            if isinstance(kwargs, dict) and "vertex_normals" in kwargs}


def godot_imported_surface(path: str | os.PathLike, node: str
                           ) -> tuple[np.ndarray, np.ndarray, int]:
    """One glTF node's surface as Godot's glTF importer gives it to the occluder bake.

    Each triangle's second and third corners swapped (glTF is
    counter-clockwise, Godot clockwise: "convert ccw to cw" in
    ``GLTFDocument::_parse_meshes`` [4]_), then vertices equal in position,
    normal (when the file has normals) and UV, bit for bit as float32, merged
    into one, in the order of their first use
    (``SurfaceTool::create_from_triangle_arrays`` and ``SurfaceTool::index``).

    Parameters
    ----------
    path : str or path-like
        A ``.glb`` or ``.gltf`` file.
    node : str
        The name of a node of its scene graph that places a mesh.

    Returns
    -------
    vertices : (m, 3) float64
        The merged vertices, in the file's world frame (the node's transform
        applied).
    faces : (f, 3) int64
        Clockwise triangles indexing ``vertices``.
    file_vertices : int
        The vertex count of the file's mesh, before the merge.

    Raises
    ------
    InputError
        When the file cannot be read as a glTF scene or ``node`` places no
        mesh in it.

    Notes
    -----
    Deterministic. Positions are merged only where normal and UV agree too,
    as Godot's importer does: a cube's corner stays three vertices when its
    faces carry their own normals.
    """
    path = Path(path)
    try:
        scene = trimesh.load(path, force="scene", process=False)
        normals = _file_normals(path)
    except Exception as exc:  # noqa: BLE001 - a file trimesh cannot read as glTF
        raise InputError(f"{path}: cannot be read as a glTF scene ({exc})") from None
    try:
        transform, name = scene.graph[node]  # type: ignore[attr-defined]
        geometry = scene.geometry[name]  # type: ignore[attr-defined]
    except (KeyError, ValueError, TypeError):
        raise InputError(f"{path}: no node {node!r} placing a mesh") from None
    if not isinstance(geometry, trimesh.Trimesh):
        raise InputError(f"{path}: node {node!r} places no triangle mesh")
    faces = np.asarray(geometry.faces, dtype=np.int64)[:, [0, 2, 1]]
    attributes = [np.asarray(geometry.vertices, dtype=np.float32)]
    if name in normals:  # normals read from the file
        attributes.append(np.asarray(normals[name], dtype=np.float32))
    uv = getattr(geometry.visual, "uv", None)
    if uv is not None:
        attributes.append(np.asarray(uv, dtype=np.float32))
    key = np.ascontiguousarray(np.hstack(attributes)).view(np.int32)
    corners = faces.reshape(-1)
    _, first, label = np.unique(key[corners], axis=0, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first)] = np.arange(len(first))
    vertices = trimesh.transform_points(geometry.vertices, transform)[corners[np.sort(first)]]
    return vertices, rank[label.reshape(-1)].reshape(-1, 3), len(geometry.vertices)
