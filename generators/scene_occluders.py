"""Occluders for the objects of a scene, and the culling runtimes they feed.

The bridge between a scene of objects (:mod:`viscore.level.scene_graph`), the
registered generators and the culling simulation
(:mod:`viscore.metrics.culling`), which never imports generators: objects above
a size threshold (or named) get an occluder from each chosen method; each
distinct mesh is generated once, in its own frame, and every instance gets
the occluder moved by its transform (conservativeness is kept by any
invertible affine map: a point inside the mesh stays inside its image). Then
:func:`culling_runtimes` builds the runtimes compared in the simulation: no
occlusion culling, shadow frusta of convex solids and of their faces
(Papaioannou et al. 2006 [1]_), and a conservative depth buffer per method
(occluder skins [2]_, sec. 5-6), fed per frame by the cut of a hierarchy
(Silvennoinen et al. 2014 [3]_, sec. 5) when the method makes one.

A method of :data:`JOINED_METHODS` (``surface-patches``) is run for the
culling runtime once on all the occluder objects together, in world space
(:func:`joined_occluder`), unless per-object occluders are asked for: its
occluder is cut from planar regions, and a roof or wall that continues
across neighbouring objects (the rooms of a level) is then one region. Cut
object by object, each piece is eroded inside its own object's surface, and
the sliver between two neighbours' pieces is a real gap in the occluders
that the conservative depth buffer must keep open along every seam. The
joined occluder is conservative for the union of the objects' surfaces,
which is what the scene draws.

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006 (Plzen), UNION Agency,
   ISBN 80-86943-03-8.
.. [2] "Occluder Skins" (occluder generation from axis-aligned boxes for a
   hierarchical-occlusion-map culler; authors and venue not in the text we
   have), sec. 5-6.
.. [3] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import os
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt
import trimesh
from viscore.metrics.culling import (
    Runtime,
    depth_buffer_runtime,
    frusta_runtime,
    no_culling,
)

from viscore import InputError
from viscore._validate import as_positive, as_positive_int, as_seed
from viscore.level.scene_graph import SceneObjects

from ._held_logs import call_held, release, report_parts
from .occluder import Occluder
from .registry import REGISTRY, generate, get_generator, parse_method

__all__ = ["occluder_objects", "scene_occluders", "scene_hierarchy", "transform_occluder",
           "culling_runtimes", "frusta_method", "file_occluder", "SIZE_FACTOR",
           "OCCLUDE_MANIFEST", "JOINED_METHODS", "joined_occluder", "generate_held"]

_log = logging.getLogger(__name__)

#: Default size threshold of the occluder objects: this many times the median
#: object's bounding-box diagonal (in the built-in cities: buildings and the
#: ground, not cars, lamps, benches or trees).
SIZE_FACTOR = 2.5

#: Distinct hierarchy cuts whose occluder scenes are kept between frames.
_CUT_CACHE = 8

#: Smallest |determinant| of a manifest's ``to_godot`` taken as invertible (a rotation's is 1).
_MIN_DETERMINANT = 1e-12

_UNIT_BOX = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])

#: The manifest ``viscore occlude`` writes beside its occluder files.
OCCLUDE_MANIFEST = "occlude.json"


def occluder_objects(objects: SceneObjects, *, size_threshold: float | None = None,
                     names: Sequence[str] | None = None) -> np.ndarray:
    """The objects that get occluders: the named ones, or those above a size threshold.

    Parameters
    ----------
    objects : SceneObjects
    size_threshold : float, optional
        Bounding-box diagonal, world units, from which an object gets an
        occluder. Default :data:`SIZE_FACTOR` x the median object's diagonal.
        A see-through object (``objects.see_through``) never passes it.
    names : sequence of str, optional
        Object names; when given, exactly these objects (``size_threshold``
        is then not used).

    Returns
    -------
    indices : (k,) int64
        Object indices, ascending.

    Raises
    ------
    InputError
        On an unknown name (listing a few known ones), a non-positive
        threshold, or when no object qualifies.
    """
    if names is not None:
        names = list(dict.fromkeys(names))
        index = {n: i for i, n in enumerate(objects.names)}
        unknown = [n for n in names if n not in index]
        if unknown or not names:
            some = ", ".join(objects.names[:5]) + (", ..." if len(objects) > 5 else "")
            raise InputError(f"occluders: no object named {', '.join(unknown) or '(none given)'}"
                             f" in {objects.source} (objects: {some})")
        return np.array(sorted(index[n] for n in names), dtype=np.int64)
    size = np.linalg.norm(objects.upper - objects.lower, axis=1)
    if size_threshold is None:
        threshold = SIZE_FACTOR * float(np.median(size))
    else:
        threshold = as_positive(size_threshold, "size_threshold")
    chosen = np.flatnonzero((size >= threshold) & ~objects.see_through)
    if len(chosen) == 0:
        what = ("size_threshold" if size_threshold is not None else
                f"the default size threshold ({SIZE_FACTOR} x the median object's diagonal)")
        solid = ~objects.see_through
        largest = float(size[solid].max()) if solid.any() else 0.0
        raise InputError(f"{what}: no object of {objects.source} is {threshold:.4g} or larger "
                         f"(the largest is {largest:.4g}, world units"
                         + (", see-through objects left out" if not solid.all() else "") + ")")
    return chosen.astype(np.int64)


def _move(points: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    return np.asarray(points, dtype=np.float64) @ matrix[:3, :3].T + matrix[:3, 3]


def _move_node(node: dict, matrix: np.ndarray, stretch: float) -> dict:
    lo, hi = np.asarray(node["bounds"], dtype=np.float64)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    moved = _move(corners, matrix)
    out = dict(node)
    out["bounds"] = np.stack([moved.min(axis=0), moved.max(axis=0)])
    mesh = node["occluder"]
    out["occluder"] = trimesh.Trimesh(_move(mesh.vertices, matrix) if len(mesh.vertices) else
                                      np.zeros((0, 3)), np.array(mesh.faces), process=False)
    if "error" in node:
        out["error"] = float(node["error"]) * stretch
    out["children"] = [_move_node(c, matrix, stretch) for c in node["children"]]
    return out


def transform_occluder(occluder: Occluder, matrix: np.ndarray) -> Occluder:
    """The occluder moved by a 4 x 4 affine transform (an instance's node transform).

    The mesh, ``solids`` and ``polygons`` are transformed; ``boxes`` become
    ``solids`` (a rotated box is no longer axis-aligned; the boxes key is
    dropped); a ``hierarchy`` gets transformed node meshes, the bounding boxes
    of its transformed node bounds, and errors scaled by the largest stretch
    of the transform. A mirroring transform reverses the faces, so solids
    stay outward-facing.

    Parameters
    ----------
    occluder : Occluder
    matrix : (4, 4) float
        Local-to-world transform; its 3 x 3 part must be invertible.

    Returns
    -------
    Occluder
        A new occluder; ``info["transformed"]`` is True.
    """
    m = np.asarray(matrix, dtype=np.float64)
    flip = np.linalg.det(m[:3, :3]) < 0

    def faces(f):
        f = np.array(f, dtype=np.int64)
        return f[:, ::-1].copy() if flip and len(f) else f

    mesh = occluder.mesh
    vertices = _move(mesh.vertices, m) if len(mesh.vertices) else np.zeros((0, 3))
    moved = trimesh.Trimesh(vertices, faces(mesh.faces), process=False)
    parts = {}
    solids = [(_move(v, m), faces(f)) for v, f in occluder.parts.get("solids", [])]
    if "boxes" in occluder.parts and not solids:
        for lo, hi in np.asarray(occluder.parts["boxes"], dtype=np.float64):
            solids.append((_move(lo + np.asarray(_UNIT_BOX.vertices) * (hi - lo), m),
                           faces(_UNIT_BOX.faces)))
    if solids or "solids" in occluder.parts or "boxes" in occluder.parts:
        parts["solids"] = solids
    if "polygons" in occluder.parts:
        parts["polygons"] = [_move(p, m) for p in occluder.parts["polygons"]]
    if "hierarchy" in occluder.parts:
        stretch = float(np.linalg.svd(m[:3, :3], compute_uv=False).max())
        parts["hierarchy"] = _move_node(occluder.parts["hierarchy"], m, stretch)
    for key, value in occluder.parts.items():
        if key not in ("solids", "boxes", "polygons", "hierarchy"):
            parts[key] = value
    return dataclasses.replace(occluder, mesh=moved, parts=parts,
                               info={**occluder.info, "transformed": True})


def scene_occluders(objects: SceneObjects, indices: Sequence[int], method: str, *,
                    seed: int = 0, progress: Callable[[int], None] | None = None,
                    made: Mapping[int, tuple[Occluder, list]] | None = None,
                    **params) -> dict[int, Occluder]:
    """World-space occluders of some objects by one registered method.

    Parameters
    ----------
    objects : SceneObjects
    indices : sequence of int
        The objects (:func:`occluder_objects`).
    method : str
        A registered generator (:data:`viscore.generators.REGISTRY`).
    seed : int, optional
        Passed to the generator (default 0).
    progress : callable, optional
        Called with 1 after each distinct mesh is generated.
    made : mapping of int -> (Occluder, list of logging.LogRecord), optional
        Meshes already generated with these options (by mesh id, in the
        mesh's frame), each with the records its generation held
        (:func:`generate_held`): not generated again.
    **params
        Options of the generator, checked by the registry before any work.

    Returns
    -------
    dict of int -> Occluder
        Object index -> its occluder in world units; objects whose occluder
        has no triangles and no parts are left out.

    Raises
    ------
    InputError
        Unknown method or option, a bad value.
    """
    spec = get_generator(method)
    seed = as_seed(seed)
    spec.check_params({**params, "seed": seed})
    indices = np.asarray(indices, dtype=np.int64)
    out: dict[int, Occluder] = {}
    distinct = np.unique(objects.mesh_ids[indices])
    # a warning every mesh gives (an open mesh for --conservative) is said once, with how
    # many meshes gave it
    said: list[tuple[int, logging.LogRecord]] = []
    for mesh_id in distinct:
        if made is not None and int(mesh_id) in made:
            local, records = made[int(mesh_id)]
        else:
            try:
                local, records = generate_held(objects, int(mesh_id), method, seed=seed,
                                               **params)
            except BaseException:  # what was held before is said as it was, then the error
                release([r for _, r in said])
                raise
        said += [(int(mesh_id), r) for r in records]
        if progress is not None:
            progress(1)
        if local.triangles == 0 and not any(len(v) if hasattr(v, "__len__") else 1
                                            for v in local.parts.values()):
            continue
        for i in indices[objects.mesh_ids[indices] == mesh_id]:
            out[int(i)] = transform_occluder(local, objects.transforms[i])
    report_parts(said, len(distinct), what="meshes", label=method, one="mesh",
                 names={int(m): str(objects.meshes[m].metadata.get("name", ""))
                        for m in distinct})
    return dict(sorted(out.items()))


def generate_held(objects: SceneObjects, mesh_id: int, method: str, *, seed: int = 0,
                  **params) -> tuple[Occluder, list[logging.LogRecord]]:
    """One distinct mesh's occluder (in its own frame) and the log records its generation
    made, held back (:func:`viscore.generators._held_logs.call_held`) for the caller to
    say; on an error the records are said as they were, then the error raised."""
    return call_held(generate, method, objects.meshes[mesh_id], seed=seed, **params)


#: Methods whose culling runtime is generated once over the occluder objects together
#: (:func:`joined_occluder`), with the method's default budget times the objects.
JOINED_METHODS = ("surface-patches",)

#: Key of the joined occluder among a runtime's occluders (objects are >= 0, a
#: scene's hierarchy -1).
_JOINED = -2


def joined_occluder(objects: SceneObjects, indices: Sequence[int], method: str, *,
                    seed: int = 0, **params) -> Occluder:
    """One world-space occluder of the union of some objects, by one registered method.

    The objects' world-space triangles form one mesh (vertices are not
    merged), generated once. Without a ``budget`` in ``params`` the budget is
    the method's default times the number of objects, so that the level gets
    what its objects would get one by one; likewise a ``min_area`` option (a
    share of the input's face area, surface-patches') is the method's
    default over the number of objects: a share of the mean object's area.

    Parameters
    ----------
    objects : SceneObjects
    indices : sequence of int
        The objects (:func:`occluder_objects`).
    method : str
        A registered generator.
    seed : int, optional
        Passed to the generator (default 0).
    **params
        Options of the generator.

    Returns
    -------
    Occluder
        In world units; ``info["joined_objects"]`` is the number of objects.

    Examples
    --------
    >>> from viscore.level.scene_graph import load_scene_objects
    >>> level = trimesh.Scene()
    >>> for k in range(2):   # two unit cubes side by side: their tops are one region
    ...     _ = level.add_geometry(trimesh.creation.box(bounds=[[k, 0, 0], [k + 1, 1, 1]]),
    ...                            node_name=f"cube{k}")
    >>> occ = joined_occluder(load_scene_objects(level), [0, 1], "surface-patches")
    >>> occ.info["joined_objects"], bool(occ.info["conservative_guaranteed"])
    (2, True)
    """
    import inspect

    spec = get_generator(method)
    seed = as_seed(seed)
    indices = np.asarray(indices, dtype=np.int64)
    params = dict(params)
    if "budget" not in params and spec.budgeted:
        default = inspect.signature(spec.function).parameters.get("budget")
        if default is not None and isinstance(default.default, int):
            params["budget"] = default.default * len(indices)
    floor = next((o for o in spec.options if o.name == "min_area"), None)
    if floor is not None and "min_area" not in params and isinstance(floor.default, float):
        # a share of the input's area: of the mean object's, not of the level's (a ground
        # plane 2 km across would set a floor larger than every wall of the town on it)
        params["min_area"] = floor.default / len(indices)
    spec.check_params({**params, "seed": seed})
    verts, faces, offset = [], [], 0
    for i in indices:
        v = objects.object_vertices(int(i))
        verts.append(v)
        faces.append(np.asarray(objects.meshes[objects.mesh_ids[i]].faces) + offset)
        offset += len(v)
    mesh = trimesh.Trimesh(np.concatenate(verts), np.concatenate(faces), process=False)
    occ = generate(method, mesh, seed=seed, **params)
    occ.info["joined_objects"] = len(indices)
    return occ


def scene_hierarchy(objects: SceneObjects, indices: Sequence[int], method: str, *,
                    seed: int = 0, **params) -> Occluder:
    """One occluder of a hierarchical method over all the given objects together.

    The objects' world meshes are joined into one mesh and handed to the
    generator, which builds its tree over the scene's parts (Silvennoinen et
    al. 2014, sec. 5: one hierarchy over the scene, cut per frame).

    Parameters
    ----------
    objects : SceneObjects
    indices : sequence of int
    method : str
        A registered generator whose occluders carry ``parts["hierarchy"]``.
    seed : int, optional
    **params
        Its options.

    Returns
    -------
    Occluder
    """
    meshes = [objects.object_mesh(int(i)) for i in indices]
    joined = trimesh.util.concatenate(meshes) if len(meshes) > 1 else meshes[0]
    return generate(method, joined, seed=as_seed(seed), **params)


def frusta_method() -> str:
    """The method whose solids feed the frusta runtimes: ``solid-frusta`` if registered,
    else ``aabb-skins`` (its boxes are convex solids)."""
    return "solid-frusta" if "solid-frusta" in REGISTRY else "aabb-skins"


def _manifest_entry(path: Path) -> tuple[dict, dict] | None:
    """The ``viscore occlude`` manifest beside ``path`` and the method summary listing it."""
    try:
        doc = json.loads((path.parent / OCCLUDE_MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    methods = doc.get("methods") if isinstance(doc, dict) else None
    if not isinstance(methods, dict):
        return None
    for summary in methods.values():
        files = summary.get("files") if isinstance(summary, dict) else None
        if isinstance(files, list) and path.name in files:
            return doc, summary
    return None


def _from_godot(doc: dict, manifest: Path) -> np.ndarray | None:
    """The inverse of a manifest's ``to_godot`` (None for the identity or none given)."""
    raw = doc.get("to_godot")
    if raw is None:
        return None
    try:
        matrix = np.asarray(raw, dtype=np.float64)
        ok = matrix.shape == (4, 4) and bool(np.isfinite(matrix).all())
    except (TypeError, ValueError):
        ok = False
    if not ok or abs(np.linalg.det(matrix[:3, :3])) < _MIN_DETERMINANT:
        raise InputError(f"{manifest}: to_godot is not an invertible 4 x 4 transform")
    if np.array_equal(matrix, np.eye(4)):
        return None
    return np.linalg.inv(matrix)


def file_occluder(path: str | os.PathLike) -> Occluder:
    """An occluder file made by another tool, as one occluder in the level's world space.

    Parameters
    ----------
    path : str or path
        Any file :func:`viscore.load_occluder` reads: a Godot 4 ``.tscn``,
        ``.tres`` or binary ``.occ``/``.res`` (as Godot's occluder bake
        writes), a glTF/GLB with ``-occonly`` nodes, or any mesh file.

    Returns
    -------
    Occluder
        ``mesh``: every triangle of the file in world units (one occluder
        set); ``method``: the file's stem; ``params``: ``{"file": path}``;
        ``double_sided`` True (drawn from both sides, as Godot's occluders
        are); ``seconds`` NaN (not generated here); ``info``:
        ``conservative_guaranteed`` (see Notes), ``file``, ``source_format``
        and ``from_godot_frame`` (whether the manifest's frame was undone).

    Raises
    ------
    InputError
        As :func:`viscore.load_occluder` (one line naming the file), or a
        ``viscore occlude`` manifest whose ``to_godot`` is not an invertible
        transform.

    Notes
    -----
    The conservativeness claim is False unless the file says otherwise: a
    ``conservative_guaranteed`` entry in the loaded mesh's metadata, or,
    for a file that ``viscore occlude`` wrote, its manifest
    (:data:`OCCLUDE_MANIFEST` in the same folder, whose method summary lists
    the file under ``files``) and that summary's ``conservative_guaranteed``.
    Such a file is in Godot's +Y-up frame; the manifest's ``to_godot`` is
    undone, so the triangles are in the level's own frame (the frame
    :func:`viscore.level.scene_graph.load_scene_objects` reads the level in). A file
    without a manifest is taken as it stands (Godot and glTF are both +Y up).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from viscore import tres_text
    >>> quad = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = pathlib.Path(tmp) / "wall.tres"
    ...     _ = path.write_text(tres_text(quad, [0, 1, 2, 0, 2, 3]))
    ...     occ = file_occluder(path)
    >>> occ.method, occ.triangles, occ.info["conservative_guaranteed"]
    ('wall', 2, False)
    """
    from viscore import load_occluder

    try:
        p = Path(os.fspath(path))
    except TypeError:
        raise InputError(f"occluder file: expected a path, got {type(path).__name__}") from None
    mesh = load_occluder(p)
    claim = mesh.metadata.get("conservative_guaranteed")
    moved = False
    entry = _manifest_entry(p)
    if entry is not None:
        doc, summary = entry
        if claim is None:
            claim = summary.get("conservative_guaranteed") is True
        inverse = _from_godot(doc, p.parent / OCCLUDE_MANIFEST)
        if inverse is not None:
            faces = np.asarray(mesh.faces, dtype=np.int64)
            if np.linalg.det(inverse[:3, :3]) < 0:
                faces = faces[:, ::-1].copy()
            mesh = trimesh.Trimesh(_move(mesh.vertices, inverse), faces, process=False,
                                   metadata=dict(mesh.metadata))
            moved = True
    info = {"conservative_guaranteed": bool(claim), "file": str(path),
            "source_format": mesh.metadata.get("source_format"), "from_godot_frame": moved}
    return Occluder(mesh=mesh, method=p.stem, params={"file": str(path)}, double_sided=True,
                    seconds=math.nan, info=info)


def _guaranteed(occluder: Occluder, method: str) -> bool:
    """Whether one occluder carries the conservativeness guarantee.

    The generator's own word when it gives one (``info["conservative_guaranteed"]``:
    aabb-skins, solid-frusta and planar-sections say False for an open or
    inconsistently oriented mesh, where nothing is guaranteed); otherwise the
    registry's flag, which promises conservativeness on closed meshes only, so
    the occluder's own mesh must be closed and consistently oriented too.
    """
    said = occluder.info.get("conservative_guaranteed")
    if said is not None:
        return bool(said)
    if not get_generator(method).conservative:
        return False
    mesh = occluder.mesh
    return bool(len(mesh.faces)) and mesh.is_watertight and mesh.is_winding_consistent


def _solids(occluders: Sequence[Occluder]) -> list[tuple[np.ndarray, np.ndarray]]:
    solids = []
    for occ in occluders:
        if len(occ.parts.get("solids", [])):
            solids.extend((np.asarray(v), np.asarray(f)) for v, f in occ.parts["solids"])
        elif len(occ.parts.get("boxes", [])):
            for lo, hi in np.asarray(occ.parts["boxes"], dtype=np.float64):
                solids.append((lo + np.asarray(_UNIT_BOX.vertices) * (hi - lo),
                               np.asarray(_UNIT_BOX.faces)))
    return solids


def _hierarchy_source(occluders: list[Occluder], width_of: Callable) -> Callable:
    """Per-frame occluders from the hierarchies' cuts (others always drawn), cached by cut."""
    from viscore.culling.depth_buffer import OccluderScene

    from .planar_hierarchy import cut_hierarchy, index_hierarchy

    trees = [index_hierarchy(o.parts["hierarchy"]) for o in occluders if "hierarchy" in o.parts]
    static = [o for o in occluders if "hierarchy" not in o.parts]
    cache: OrderedDict = OrderedDict()

    def per_frame(camera):
        chosen, key = list(static), []
        for t, tree in enumerate(trees):
            nodes = cut_hierarchy(tree, camera.position, fov_degrees=camera.fov,
                                  screen_pixels=width_of(camera))
            for node in nodes:
                if len(node["occluder"].faces):
                    chosen.append(node["occluder"])
                    key.append((t, id(node)))
        key = tuple(key)
        if key not in cache:
            cache[key] = OccluderScene(chosen)
            if len(cache) > _CUT_CACHE:
                cache.popitem(last=False)
        else:
            cache.move_to_end(key)
        return cache[key]

    return per_frame


def culling_runtimes(objects: SceneObjects, indices: Sequence[int], methods: Sequence[str], *,
                     active: int = 15, reduction: int = 4, seed: int = 0,
                     frusta: bool = True, frusta_source: str | None = None,
                     cap: str = "front-faces", rank: str = "faces",
                     params: dict[str, dict] | None = None,
                     progress: Callable[[int], None] | None = None,
                     files: Mapping[str, Occluder] | None = None,
                     joined: Sequence[str] | None = None,
                     flat: npt.ArrayLike | None = None
                     ) -> tuple[dict[str, Runtime], dict]:
    """The runtimes of the culling simulation for a scene's occluder objects.

    Parameters
    ----------
    objects : SceneObjects
    indices : sequence of int
        Objects that get occluders (:func:`occluder_objects`).
    methods : sequence of str
        Registered generators; each gives a ``depth-buffer:<method>`` runtime.
    active : int, optional
        Active occluders per frame of the frusta runtimes (default 15).
    reduction : int, optional
        Depth buffer: screen pixels per buffer pixel along each side (default
        4: 320 x 180 for 1280 x 720).
    seed : int, optional
        Passed to every generator.
    frusta : bool, optional
        Build ``planar-frusta`` and ``solid-frusta`` from the solids of
        ``frusta_source`` (default True).
    frusta_source : str, optional
        The method whose solids (or boxes) feed the frusta runtimes; default
        :func:`frusta_method` (``solid-frusta`` when registered).
    cap, rank : str, optional
        Near cap and ranking of ``solid-frusta`` (default 'front-faces' and
        'faces'; the paper's are 'eq2' and 'eq4'): see
        :func:`viscore.metrics.culling.frusta_runtime`.
    params : dict of str -> dict, optional
        Generator options per method.
    progress : callable, optional
        Called with 1 after each distinct mesh generated (all methods).
    files : mapping of str -> Occluder, optional
        Occluders made by other tools (:func:`file_occluder`), by name; each
        gives a ``depth-buffer:<name>`` runtime after the methods' (a name
        that is also a method's is refused). The whole file's triangles are
        one occluder set in world space, prepared once as a method's
        occluders are; its guarantee is the file's
        ``info["conservative_guaranteed"]`` (False unless the file says so).
    joined : sequence of str, optional
        Methods generated once over all the objects together
        (:func:`joined_occluder`) instead of mesh by mesh; default those of
        :data:`JOINED_METHODS` among ``methods``, variants with options
        (``surface-patches:ground=auto``) included; ``()`` for none.
    flat : (n,) bool, optional
        Per object of ``objects``, whether it is flat (a level's terrain or
        ground: :attr:`viscore.generators.level_objects.LevelObjects.flat`). A
        method for height fields (``GeneratorSpec.inputs``, such as
        ``terrain-drape``) then makes occluders for the flat objects among
        ``indices`` only, as ``viscore occlude`` does; without ``flat``, for
        all of them.

    Returns
    -------
    runtimes : dict of str -> Runtime
        ``none``, then ``planar-frusta`` and ``solid-frusta``, then
        ``depth-buffer:<method>`` per method, then ``depth-buffer:<name>``
        per file. A method whose occluders carry
        a joined method has one occluder over all the objects; one that carries
        a hierarchy (probed on the first mesh) gets one tree over all the
        objects (:func:`scene_hierarchy`), cut for each frame's camera
        (``cut_hierarchy`` with the camera's horizontal field of view and
        width in pixels); the cut's occluder scenes are cached by cut.
    info : dict
        Per runtime: the source method, occluder count, ``conservative``
        (True only when every occluder it uses carries the guarantee: the
        generator's ``info["conservative_guaranteed"]`` when it reports one,
        for example False for aabb-skins or solid-frusta on an open mesh;
        else the registry flag and a closed, consistently oriented occluder
        mesh) and ``not_guaranteed``, the names of the objects whose occluders
        lack it. A file's entry has ``method`` None, ``file``, ``triangles``
        and ``source_format`` instead.

    Raises
    ------
    InputError
        Unknown method, bad option, a file name that is also a method's.
    """
    active = as_positive_int(active, "active")
    reduction = as_positive_int(reduction, "reduction", maximum=1024)
    params = dict(params or {})
    methods = list(dict.fromkeys(methods))
    for m in methods:
        get_generator(m)
    files = dict(files or {})
    for name, occ in files.items():
        if name in methods:
            raise InputError(f"files: {name!r} is also a method; depth-buffer:{name} would "
                             "name two runtimes")
        if not isinstance(occ, Occluder):
            raise InputError(f"files[{name!r}]: expected an Occluder (file_occluder), got "
                             f"{type(occ).__name__}")
    source = (frusta_method() if frusta_source is None
              else parse_method(frusta_source, "frusta_source").label)
    joined = set(m for m in methods if get_generator(m).name in JOINED_METHODS) \
        if joined is None else set(joined)
    for m in joined:
        if m not in methods:
            raise InputError(f"joined: {m!r} is not one of the methods")
    cache: dict[str, dict[int, Occluder]] = {}

    indices = all_indices = np.asarray(indices, dtype=np.int64)
    is_flat = None if flat is None else np.asarray(flat, dtype=bool)
    if is_flat is not None and is_flat.shape != (len(objects),):
        raise InputError(f"flat: expected one flag per object ({len(objects)}), got shape "
                         f"{is_flat.shape}")

    def occluders(method: str) -> dict[int, Occluder]:
        if method not in cache:
            indices = method_indices(method, all_indices, is_flat)
            if not len(indices):
                _log.info("%s is for height fields, and none of the %d objects is flat",
                          method, len(all_indices))
                cache[method] = {}
                return cache[method]
            _log.debug("generating %s occluders for %d objects", method, len(indices))
            options = params.get(method, {})
            if method in joined and len(indices):
                occ = joined_occluder(objects, indices, method, seed=seed, **options)
                if progress is not None:
                    progress(len(set(objects.mesh_ids[indices].tolist())))
                cache[method] = {_JOINED: occ} if occ.triangles else {}
                return cache[method]
            # a probe on the first distinct mesh: a hierarchical method gets one
            # tree over all the occluder objects instead of one per mesh
            # (kept for the mesh by mesh generation: the first mesh is made once)
            first = int(objects.mesh_ids[indices[0]])
            probe, records = generate_held(objects, first, method, seed=seed, **options)
            if "hierarchy" in probe.parts:
                release(records)
                cache[method] = {-1: scene_hierarchy(objects, indices, method, seed=seed,
                                                     **options)}
                if progress is not None:
                    progress(len(set(objects.mesh_ids[indices].tolist())))
            else:
                cache[method] = scene_occluders(objects, indices, method, seed=seed,
                                                progress=progress,
                                                made={first: (probe, records)}, **options)
        return cache[method]

    runtimes: dict[str, Runtime] = {"none": no_culling()}
    info: dict[str, dict] = {"none": {"method": None, "occluders": 0, "conservative": True}}
    if frusta:
        solids = _solids(occluders(source).values())
        unsure = [i for i, o in occluders(source).items() if not _guaranteed(o, source)]
        conservative = not unsure
        for mode in ("planar", "solid"):
            name = f"{mode}-frusta"
            runtimes[name] = frusta_runtime(solids, mode=mode, active=active, cap=cap,
                                            rank=rank, conservative=conservative)
            info[name] = {"method": source, "occluders": runtimes[name].occluders,
                          "solids": len(solids), "conservative": conservative,
                          "not_guaranteed": _unsure_names(objects, unsure), "active": active}
            if mode == "solid":
                info[name].update(cap=cap, rank=rank)
    for m in methods:
        occ = list(occluders(m).values())
        name = f"depth-buffer:{m}"
        unsure = [i for i, o in occluders(m).items() if not _guaranteed(o, m)]
        conservative = not unsure  # no occluder: it culls nothing
        if not occ:
            _log.warning("%s made no occluder for the %s: %s culls nothing", m,
                         "object" if len(indices) == 1 else f"{len(indices):,} objects", name)
            runtimes[name] = Runtime(cull=no_culling().cull, conservative=conservative)
        elif any("hierarchy" in o.parts for o in occ):
            source_fn = _hierarchy_source(occ, lambda camera: camera.shape[1])
            runtimes[name] = depth_buffer_runtime(source_fn, reduction=reduction,
                                                  conservative=conservative, count=len(occ))
        else:
            runtimes[name] = depth_buffer_runtime(occ, reduction=reduction,
                                                  conservative=conservative)
        info[name] = {"method": m, "occluders": len(occ), "conservative": conservative,
                      "not_guaranteed": _unsure_names(objects, unsure),
                      "hierarchy": any("hierarchy" in o.parts for o in occ),
                      "joined": m in joined}
    for name, occ in files.items():
        runtime = f"depth-buffer:{name}"
        conservative = bool(occ.info.get("conservative_guaranteed", False))
        # the whole file is one occluder set in world space, prepared once
        runtimes[runtime] = depth_buffer_runtime([occ], reduction=reduction,
                                                 conservative=conservative)
        info[runtime] = {"method": None, "file": occ.info.get("file", occ.params.get("file")),
                         "source_format": occ.info.get("source_format"), "occluders": 1,
                         "triangles": occ.triangles, "conservative": conservative,
                         "not_guaranteed": [] if conservative else [f"(file {name})"],
                         "hierarchy": False}
    return runtimes, info


def method_indices(method: str, indices: npt.ArrayLike, flat: npt.ArrayLike | None
                   ) -> np.ndarray:
    """The occluder objects ``indices`` a method makes occluders for: the flat ones (per
    object of the scene, ``flat``) for a method for height fields
    (``GeneratorSpec.inputs``), all of them otherwise or without ``flat``."""
    indices = np.asarray(indices, dtype=np.int64)
    if flat is None or get_generator(method).inputs != "height-fields":
        return indices
    return indices[np.asarray(flat, dtype=bool)[indices]]


def _unsure_names(objects: SceneObjects, indices: Sequence[int]) -> list[str]:
    """Names of the objects whose occluders lack the guarantee (-1: a scene's hierarchy,
    -2: the joined occluder)."""
    return [objects.names[i] if i >= 0 else "(hierarchy over the occluder objects)"
            if i == -1 else "(the occluder objects joined)" for i in indices]
