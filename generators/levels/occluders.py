"""Occluders for the objects of a level: each distinct mesh generated once, placed per instance.

A hierarchy's nodes (Silvennoinen et al. 2014 [1]_, sec. 5) are placed the
same way.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np
import trimesh

from viscore import InputError
from viscore._validate import as_seed
from viscore.exchange.file_access import read_regular
from viscore.level.scene_graph import SceneObjects

from .._held_logs import call_held, release, report_parts
from ..occluder import Occluder
from ..registry import generate, get_generator
from .districts import district_budgets, district_labels

__all__ = ["scene_occluders", "scene_hierarchy", "transform_occluder", "file_occluder",
           "OCCLUDE_MANIFEST", "JOINED_METHODS", "joined_occluder", "generate_held"]

_log = logging.getLogger(__name__)


#: Peak bytes of memory per byte of a manifest while it is parsed.
_JSON_BYTES_PER_BYTE = 20
#: Smallest |determinant| of a manifest's ``to_godot`` taken as invertible (a rotation's is 1).
_MIN_DETERMINANT = 1e-12

_UNIT_BOX = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])

#: The manifest ``viscore occlude`` writes beside its occluder files.
OCCLUDE_MANIFEST = "occlude.json"


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
        parts["polygons"] = [_move(p, m) for p in occluder.parts["polygons"]]  # type: ignore[misc]
    if "hierarchy" in occluder.parts:
        stretch = float(np.linalg.svd(m[:3, :3], compute_uv=False).max())
        parts["hierarchy"] = _move_node(occluder.parts["hierarchy"], m, stretch)  # type: ignore[assignment]
    for key, value in occluder.parts.items():
        if key not in ("solids", "boxes", "polygons", "hierarchy"):
            parts[key] = value
    return dataclasses.replace(occluder, mesh=moved, parts=parts,
                               info={**occluder.info, "transformed": True})


def scene_occluders(objects: SceneObjects, indices: Sequence[int] | np.ndarray, method: str, *,
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


def joined_occluder(objects: SceneObjects, indices: Sequence[int] | np.ndarray, method: str, *,
                    seed: int = 0, **params) -> Occluder:
    """One world-space occluder of the union of some objects, by one registered method.

    The objects' world-space triangles form one mesh (vertices are not
    merged), generated once. Without a ``budget`` in ``params`` the budget is
    the method's default times the number of objects, so that the level gets
    what its objects would get one by one; likewise a ``min_area`` option (a
    share of the input's face area, surface-patches') is the method's
    default over the number of objects: a share of the mean object's area.

    A level of many triangles (at least four times
    :data:`~generators.levels.districts.DISTRICT_TRIANGLES`) is made district by district
    (:mod:`generators.levels.districts`): the ground cut into up to 8 x 8 squares, each
    square's planar pieces generated together with its share of the budget (by the square
    root of its triangles) and the same smallest area in world units, the results joined:
    a district's candidates compete only with each other, so a town's street walls are not
    outbid by the large sheets of the ground around it. ``info["districts"]`` says how
    many were made (1: whole).

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
    if params.get("budget") is not None:  # no budget to share: made whole
        label, side = district_labels(mesh.vertices, mesh.faces, objects.up)
        if side > 1:
            return _district_occluder(mesh, label, method, seed, params, len(indices))
    return _whole_occluder(mesh, method, seed, params, len(indices))


def _whole_occluder(mesh: trimesh.Trimesh, method: str, seed: int, params: dict,
                    joined: int) -> Occluder:
    """The joined occluder made in one piece."""
    occ = generate(method, mesh, seed=seed, **params)
    occ.info["joined_objects"] = joined
    occ.info["districts"] = 1
    return occ


def _district_occluder(mesh: trimesh.Trimesh, label: np.ndarray, method: str, seed: int,
                       params: dict, joined: int) -> Occluder:
    """The joined occluder made district by district (:mod:`.districts`): each district's
    faces with its share of the budget and the same smallest area in world units."""
    import time

    start = time.perf_counter()
    used, counts = np.unique(label, return_counts=True)
    budgets = district_budgets(counts, int(params["budget"]))
    area = mesh.area_faces
    total = float(area.sum())
    made: list[Occluder] = []
    weights: list[float] = []
    held: list[tuple[int, logging.LogRecord]] = []
    for d, b in zip(used.tolist(), budgets.tolist(), strict=True):
        if b < 1:
            continue
        keep = label == d
        part = trimesh.Trimesh(mesh.vertices, mesh.faces[keep], process=False)
        part.remove_unreferenced_vertices()
        own = dict(params, budget=int(b))
        share = float(area[keep].sum())
        if "min_area" in params and share > 0:  # the same floor in world units
            own["min_area"] = min(1.0, float(params["min_area"]) * total / share)
        occ, records = call_held(generate, method, part, seed=seed, **own)
        held.extend((len(made), r) for r in records)
        made.append(occ)
        weights.append(share / total if total > 0 else 0.0)
    report_parts(held, len(made), what="districts", label=method)
    if not made:  # a budget under one triangle a district: made whole
        return _whole_occluder(mesh, method, seed, params, joined)
    meshes = [o.mesh for o in made if len(o.mesh.faces)]
    joined_mesh = trimesh.Trimesh(
        np.concatenate([m.vertices for m in meshes]) if meshes else np.zeros((0, 3)),
        np.concatenate([m.faces + k for m, k in zip(
            meshes, np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]]), strict=True)])
        if meshes else np.zeros((0, 3), dtype=np.int64), process=False)
    parts: dict = {}
    for o in made:
        for key, value in o.parts.items():
            if isinstance(value, list):
                parts.setdefault(key, []).extend(value)
            elif isinstance(value, np.ndarray):
                parts[key] = (np.concatenate([parts[key], value]) if key in parts else value)
    info = _merged_info([o.info for o in made], weights)
    info["joined_objects"] = joined
    info["districts"] = len(made)
    return Occluder(mesh=joined_mesh, method=made[0].method, params=dict(made[0].params,
                    budget=int(params["budget"])), double_sided=all(o.double_sided for o in made),
                    seconds=time.perf_counter() - start, parts=parts, info=info)


def _merged_info(infos: list[dict], weights: list[float]) -> dict:
    """One ``info`` of the districts' (:func:`_district_occluder`): counts added up,
    ``area_kept`` weighted by the districts' areas, the guarantees all held, a budget
    over when one was, ``seconds_steps`` added up; any other entry the largest
    district's."""
    base = dict(infos[int(np.argmax(weights))])
    for key in base:
        values: list = [i.get(key) for i in infos]
        if key == "area_kept":
            base[key] = float(sum(w * float(v or 0.0) for w, v in zip(weights, values,
                                                                         strict=True)))
        elif key == "over_budget":
            base[key] = any(bool(v) for v in values)
        elif key.endswith("guaranteed"):
            base[key] = all(v is not False for v in values)
        elif key == "seconds_steps" and all(isinstance(v, dict) for v in values):
            base[key] = {k: sum(float(v.get(k, 0.0)) for v in values) for k in base[key]}
        elif all(isinstance(v, int) and not isinstance(v, bool) for v in values):
            base[key] = int(sum(values))
    return base


def scene_hierarchy(objects: SceneObjects, indices: Sequence[int] | np.ndarray, method: str, *,
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


def _manifest_entry(path: Path) -> tuple[dict, dict] | None:
    """The ``viscore occlude`` manifest beside ``path`` and the method summary listing it."""
    manifest = path.parent / OCCLUDE_MANIFEST
    if not os.path.lexists(manifest):
        return None
    try:  # a regular file only: a FIFO in its place would block the read
        doc = json.loads(read_regular(manifest, str(manifest),
                                      bytes_per_byte=_JSON_BYTES_PER_BYTE))
    except ValueError:  # InputError included: not a manifest, the file stands alone
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

