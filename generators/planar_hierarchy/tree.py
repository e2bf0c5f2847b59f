"""Hierarchical occluders and their runtime tree cut (Silvennoinen et al. 2014, sec. 5).

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (voxelization, sec. 4.1;
   hierarchical occluders, the dilation step and the runtime tree cut,
   sec. 5)
"""

from __future__ import annotations

import heapq
import inspect
import logging
import numbers
import time
from collections.abc import Callable, Sequence

import numpy as np
import trimesh

from viscore import InputError
from viscore._validate import as_positive, as_positive_int, as_seed, check_memory
from viscore.voxel.grid import (
    VOXELIZE_BYTES_PER_CELL,
    outside_voxels,
    surface_voxels,
    voxel_boundary_mesh,
    voxel_grid,
)

from .._held_logs import held_records, report_parts
from ..occluder import Occluder

__all__ = ["build_hierarchy", "dilated_voxel_mesh", "NODE_OCCLUDERS", "register_node_occluder",
           "DEFAULT_MAX_LEAVES", "DEFAULT_VOXELS", "INNER_DILATION", "MAX_DILATION", "MAX_VOXELS"]

_log = logging.getLogger(__name__)

#: Dilation steps at inner nodes: "a single dilation step" (sec. 5).
INNER_DILATION = 1

#: Voxels along a node's longest side when none are given (as planar sections).
DEFAULT_VOXELS = 64

#: Most dilation steps accepted (each adds a voxel of error).
MAX_DILATION = 8

#: Largest ``voxels`` per node (as for the other voxel methods).
MAX_VOXELS = 2048

#: Default cap on the number of leaves (each leaf and inner node gets its own
#: occluder: ``2 * max_leaves - 1`` builds at most).
DEFAULT_MAX_LEAVES = 32


#: Named per-node builders. ``planar-sections`` is the paper's; ``qem`` (quadric
#: decimation of the node's voxel mesh at inner nodes, of its geometry at the
#: leaves) and ``aabb-skins`` (boxes inside the node's voxel solid) are
#: stand-ins for comparison and tests.
NODE_OCCLUDERS = ("planar-sections", "qem", "aabb-skins")

#: The builders of :data:`NODE_OCCLUDERS` by name, registered by
#: :mod:`viscore.generators.registry` (:func:`register_node_occluder`): they are
#: other families' generators, which this family does not import.
_NODE_BUILDERS: dict[str, Callable] = {}


def register_node_occluder(name: str, builder: Callable) -> None:
    """Register the per-node builder of one of :data:`NODE_OCCLUDERS` (the registry does)."""
    if name not in NODE_OCCLUDERS:
        raise ValueError(f"node occluder {name!r} is not one of {', '.join(NODE_OCCLUDERS)}")
    _NODE_BUILDERS[name] = builder


def _resolve_builder(node_occluder) -> tuple[Callable, str]:
    if node_occluder is None:
        node_occluder = "planar-sections"
    if callable(node_occluder):
        return node_occluder, getattr(node_occluder, "__name__", "callable")
    if node_occluder in NODE_OCCLUDERS:
        if node_occluder not in _NODE_BUILDERS:
            raise LookupError(f"node_occluder {node_occluder!r}: not registered (it is "
                              "registered when viscore.generators is imported)")
        return _NODE_BUILDERS[node_occluder], node_occluder
    raise InputError(f"node_occluder: expected one of {', '.join(NODE_OCCLUDERS)} or a "
                     f"callable, got {node_occluder!r}")


def _keywords(fn: Callable) -> set:
    """Keyword names ``fn`` declares (a ``**kwargs`` catch-all is not a declaration)."""
    try:
        params = inspect.signature(fn).parameters.values()
    except (TypeError, ValueError):
        return set()
    return {p.name for p in params if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)}


# --------------------------------------------------------------------------- objects and BVH

def _scene_objects(mesh_or_meshes) -> tuple[trimesh.Trimesh, list[np.ndarray]]:
    """One mesh of the whole scene and each object's face indices into it."""
    from viscore import validate_mesh

    if isinstance(mesh_or_meshes, trimesh.Trimesh):
        mesh = validate_mesh(mesh_or_meshes, name=str(mesh_or_meshes.metadata.get("name", "mesh")))
        # components over vertices merged at equal positions (soups repeat vertices per face)
        _, inverse = np.unique(np.asarray(mesh.vertices), axis=0, return_inverse=True)
        merged = inverse.reshape(-1)[np.asarray(mesh.faces)]
        labels = trimesh.graph.connected_component_labels(
            trimesh.graph.face_adjacency(merged), node_count=len(merged))
        order = np.argsort(labels, kind="stable")
        cuts = np.flatnonzero(np.diff(labels[order])) + 1
        return mesh, np.split(order, cuts)
    if isinstance(mesh_or_meshes, (str, bytes)) or not isinstance(mesh_or_meshes, Sequence):
        raise InputError("mesh: expected a trimesh.Trimesh or a list of them, got "
                         f"{type(mesh_or_meshes).__name__}")
    if len(mesh_or_meshes) == 0:
        raise InputError("mesh: expected at least one mesh, got an empty list")
    meshes = []
    for i, m in enumerate(mesh_or_meshes):
        if not isinstance(m, trimesh.Trimesh):
            raise InputError(f"mesh[{i}]: expected a trimesh.Trimesh, got {type(m).__name__}")
        meshes.append(validate_mesh(m, name=str(m.metadata.get("name", f"mesh[{i}]"))))
    counts = np.cumsum([0] + [len(m.faces) for m in meshes])
    vcounts = np.cumsum([0] + [len(m.vertices) for m in meshes])
    vertices = np.concatenate([np.asarray(m.vertices, dtype=np.float64) for m in meshes])
    faces = np.concatenate([np.asarray(m.faces, dtype=np.int64) + off
                            for m, off in zip(meshes, vcounts[:-1], strict=True)])
    # each part is validated at its own scale; validating the whole again could drop a small
    # object's faces as degenerate at the scene's scale
    scene = trimesh.Trimesh(vertices, faces, process=False)
    return scene, [np.arange(a, b) for a, b in zip(counts[:-1], counts[1:], strict=True)]


def _split_tree(centres: np.ndarray, lo: np.ndarray, hi: np.ndarray, *, leaf_objects: int,
                max_leaves: int) -> dict:
    """Median-split BVH over objects; splits the node of largest diagonal first."""
    def node(objs):
        diag = float(np.linalg.norm(hi[objs].max(axis=0) - lo[objs].min(axis=0)))
        return {"objects": objs, "children": [], "_diag": diag}

    root = node(np.arange(len(centres)))
    heap = [(-root["_diag"], 0, root)]
    tick, leaves = 1, 1
    while heap and leaves < max_leaves:
        _, _, n = heapq.heappop(heap)
        objs = n["objects"]
        if len(objs) <= leaf_objects:
            continue
        c = centres[objs]
        axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
        # stable sort on (axis, then the others) so that ties split deterministically
        order = np.lexsort((c[:, (axis + 2) % 3], c[:, (axis + 1) % 3], c[:, axis]))
        half = len(objs) // 2
        for part in (objs[order[:half]], objs[order[half:]]):
            child = node(np.sort(part))
            n["children"].append(child)
            heapq.heappush(heap, (-child["_diag"], tick, child))
            tick += 1
        leaves += 1
    return root


def dilated_voxel_mesh(mesh: trimesh.Trimesh, *, voxel_size: float, dilation: int = 1
                       ) -> trimesh.Trimesh:
    """Closed voxel mesh of a mesh's solid after ``dilation`` dilation steps.

    Voxelization of Silvennoinen et al. 2014 [1]_, sec. 4.1 (surface voxels by
    exact triangle/box overlap, the rest of the solid by an outside flood
    fill), then the dilation step of sec. 5: each step marks every OUTSIDE
    voxel with a 6-neighbour INSIDE voxel as INSIDE. Objects whose solids
    are at most ``2 * dilation`` empty voxels apart are glued (any gap under
    ``2 * dilation * voxel_size`` is), and the solid grows by exactly
    ``dilation`` voxels.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Any triangle soup.
    voxel_size : float
        Voxel side, world units.
    dilation : int, optional
        Dilation steps, >= 0 (default 1, the paper's single step).

    Returns
    -------
    trimesh.Trimesh
        Closed, 2-manifold, oriented outwards
        (:func:`viscore.voxel.grid.voxel_boundary_mesh`); its faces lie on voxel
        boundaries, at most ``voxel_size * (1 + dilation)`` from ``mesh``
        along each axis beyond its bounding box.

    Raises
    ------
    InputError
        If the grid is too large for the memory limit (checked before any work).

    References
    ----------
    .. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
       Simplification using Planar Sections". Computer Graphics Forum 33(1),
       2014, pp. 235-245. :DOI:`10.1111/cgf.12271`

    Examples
    --------
    >>> a = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    >>> b = trimesh.creation.box(bounds=[[1.15, 0, 0], [2.15, 1, 1]])
    >>> pair = trimesh.util.concatenate([a, b])
    >>> len(dilated_voxel_mesh(pair, voxel_size=0.1, dilation=0).split())  # a gap
    2
    >>> len(dilated_voxel_mesh(pair, voxel_size=0.1, dilation=1).split())  # glued
    1
    """
    from scipy import ndimage

    pitch = as_positive(voxel_size, "voxel_size")
    dilation = int(dilation)
    bounds = np.asarray(mesh.bounds, dtype=np.float64)
    grow = dilation * pitch
    grid = voxel_grid(bounds + np.array([[-grow], [grow]]), pitch=pitch)
    cells = float(np.prod(np.array(grid.shape, dtype=np.float64)))
    check_memory(cells * VOXELIZE_BYTES_PER_CELL,
                 f"hierarchy: a {grid.shape[0]} x {grid.shape[1]} x {grid.shape[2]} voxel grid")
    solid = ~outside_voxels(surface_voxels(mesh.vertices, mesh.faces, grid))
    if dilation > 0:
        solid = ndimage.binary_dilation(solid, iterations=dilation)
    return voxel_boundary_mesh(solid, grid)


def _submesh(mesh: trimesh.Trimesh, faces: np.ndarray) -> trimesh.Trimesh:
    tri = np.asarray(mesh.faces)[faces]
    used, inverse = np.unique(tri.reshape(-1), return_inverse=True)
    return trimesh.Trimesh(np.asarray(mesh.vertices)[used], inverse.reshape(-1, 3),
                           process=False)


def _empty_mesh() -> trimesh.Trimesh:
    return trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), process=False)


def build_hierarchy(mesh_or_meshes, *, node_occluder=None, budget: int | None = 64,
                    voxels: int = 64, leaf_objects: int = 1,
                    max_leaves: int = DEFAULT_MAX_LEAVES, inner_dilation: int = INNER_DILATION,
                    seed: int = 0, jobs: int = 1, **node_options) -> dict:
    """Occluder hierarchy of a scene: a BVH over its objects, an occluder per node.

    Silvennoinen et al. 2014 [1]_, sec. 5: "we build a bounding volume
    hierarchy (BVH) and apply our algorithm independently for each node",
    with one dilation step of the voxel solid at inner nodes. The module
    docstring gives the choices the paper leaves open (objects, splits,
    voxel size per node, dilation, error).

    Parameters
    ----------
    mesh_or_meshes : trimesh.Trimesh or sequence of trimesh.Trimesh
        One mesh, whose connected components (over vertices merged at equal
        positions) are the objects; or a list of meshes, each one object.
    node_occluder : {'planar-sections', 'qem', 'aabb-skins'} or callable, optional
        The per-node builder. Default: planar sections. A callable is called
        as ``node_occluder(mesh, *, budget, seed, **kw)`` and returns an
        :class:`Occluder` or a :class:`trimesh.Trimesh`; ``kw`` holds
        the voxel size (world units) as ``voxel_size`` or ``pitch`` if it
        declares that keyword, else ``voxels`` (along the longest side of
        ``mesh``) if it declares that; the dilation steps (int) as
        ``dilation`` or ``dilate`` if it declares that, and then ``mesh`` is
        the node's geometry; otherwise, at inner nodes, ``mesh`` is the
        closed voxel mesh of the node's dilated solid
        (:func:`dilated_voxel_mesh`).
        ``node_options`` are passed on.
    budget : int or None, optional
        Triangle budget of each node's occluder (default 64); None is passed
        on to the builder (planar sections: no budget cut).
    voxels : int, optional
        Voxels along the longest side of each node's bounding box, 1 to 2048
        (default 64); the voxel size is then raised to the children's largest.
    leaf_objects : int, optional
        Split nodes until they hold at most this many objects (default 1).
    max_leaves : int, optional
        Stop splitting at this many leaves (default 32); a leaf may then
        hold more than ``leaf_objects`` objects.
    inner_dilation : int, optional
        Dilation steps at inner nodes, 0 to 8 (default 1, the paper's single
        step); leaves get none.
    seed : int, optional
        Passed to every node's builder.
    jobs : int, optional
        Processes building the nodes, 1 to 256 (default 1): the nodes are
        independent, and the tree is the same with any number.
    **node_options
        Passed to the builder at every node.

    Returns
    -------
    dict
        The root node, by the ``hierarchy`` schema of
        :mod:`viscore.generators.occluder` (``bounds`` (2, 3) float64,
        ``occluder`` trimesh, ``children``), with, per node: ``id`` (int,
        pre-order, root 0), ``objects`` ((k,) int64 object indices),
        ``geometry_bounds`` (2, 3) float64, ``voxel_size`` and ``error``
        (float, world units), ``dilation`` (int), ``triangles`` (int),
        ``double_sided`` (bool), ``seconds`` (float), and ``note`` (str, empty
        unless the builder refused the node with an :class:`InputError`: the
        node then has an empty occluder, and a warning is logged).

    What the builder logs at the nodes is held back while they are built and
    said once per distinct line at the end, with how many nodes gave it
    (``hierarchy: 29 of 57 nodes: ...``; one node:
    ``hierarchy node 12: ...``; :func:`viscore.generators._held_logs.report_parts`), refusals
    included (``no occluder: ...``).

    Raises
    ------
    InputError
        Bad options, an empty or invalid mesh, or a voxel grid beyond the
        memory limit, before any occluder is built; or the builder refused
        every node (e.g. an option it does not accept).

    Notes
    -----
    Guarantees: children's ``bounds`` lie inside their parent's; every object
    is in exactly one leaf; ``voxel_size`` and ``error`` never decrease from
    child to parent. Deterministic given the inputs and ``seed``. A node's
    occluder is whatever the builder makes; the bound ``error`` holds for
    the voxel solid it was given, and for occluders inside that solid
    (planar sections, boxes), not for decimation (``qem``).

    References
    ----------
    .. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
       Simplification using Planar Sections". Computer Graphics Forum 33(1),
       2014, pp. 235-245. :DOI:`10.1111/cgf.12271`

    Examples
    --------
    >>> boxes = [trimesh.creation.box(bounds=[[x, 0, 0], [x + 1, 1, 1]]) for x in (0, 2, 4)]
    >>> root = build_hierarchy(boxes, node_occluder="qem", budget=12, voxels=8)
    >>> len(root["children"]), sorted(int(i) for i in root["objects"])
    (2, [0, 1, 2])
    """
    budget = None if budget is None else as_positive_int(budget, "budget")
    voxels = as_positive_int(voxels, "voxels", maximum=MAX_VOXELS)
    if isinstance(inner_dilation, bool) or not isinstance(inner_dilation, numbers.Integral) \
            or not 0 <= inner_dilation <= MAX_DILATION:
        raise InputError(f"inner_dilation: expected an integer from 0 to {MAX_DILATION}, "
                         f"got {inner_dilation!r}")
    leaf_objects = as_positive_int(leaf_objects, "leaf_objects")
    max_leaves = as_positive_int(max_leaves, "max_leaves")
    seed = as_seed(seed, "seed")
    jobs = as_positive_int(jobs, "jobs", maximum=256)
    builder, builder_name = _resolve_builder(node_occluder)
    reserved = sorted(set(node_options) & {"voxel_size", "pitch", "dilation", "dilate"})
    if reserved:
        raise InputError(f"{', '.join(reserved)}: set per node by the hierarchy (voxels over "
                         "the node's extent; dilation at inner nodes)")
    mesh, objects = _scene_objects(mesh_or_meshes)

    tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)]  # (f, 3, 3)
    order = np.concatenate(objects)
    starts = np.cumsum([0] + [len(f) for f in objects[:-1]])
    lo = np.minimum.reduceat(tri.min(axis=1)[order], starts, axis=0)  # (objects, 3)
    hi = np.maximum.reduceat(tri.max(axis=1)[order], starts, axis=0)
    del tri, order
    root = _split_tree(0.5 * (lo + hi), lo, hi, leaf_objects=leaf_objects,
                       max_leaves=max_leaves)

    nodes = []  # pre-order
    stack = [root]
    while stack:
        n = stack.pop()
        n["id"] = len(nodes)
        nodes.append(n)
        stack.extend(reversed(n["children"]))
    # voxel sizes bottom-up (reverse pre-order visits children before parents)
    for n in reversed(nodes):
        objs = n["objects"]
        gb = np.stack([lo[objs].min(axis=0), hi[objs].max(axis=0)])
        n["geometry_bounds"] = gb
        own = float((gb[1] - gb[0]).max()) / voxels
        n["voxel_size"] = max([own] + [c["voxel_size"] for c in n["children"]])
        n["dilation"] = int(inner_dilation) if n["children"] else 0
    # the largest grid, checked before any work (each node's builder checks its own again)
    worst = max(float(np.prod((n["geometry_bounds"][1] - n["geometry_bounds"][0])
                              / n["voxel_size"] + 3 + 2 * n["dilation"] + 4)) for n in nodes)
    check_memory(worst * VOXELIZE_BYTES_PER_CELL, "hierarchy: the largest node's voxel grid")

    faces_of = [np.concatenate([objects[i] for i in n["objects"]]) for n in nodes]
    held: list = []  # (node id, log record): the builder's lines, said once each at the end
    failures = []
    try:
        failures = _build_nodes(nodes, mesh, faces_of, builder, held, budget=budget,
                                seed=seed, node_options=node_options, jobs=jobs)
    finally:
        if len(failures) == len(nodes):  # said once below, as the error
            held = [(i, r) for i, r in held if not getattr(r, "node_refusal", False)]
        report_parts(held, len(nodes))
    if len(failures) == len(nodes):  # bad builder options, most likely: say so once
        raise InputError(f"node_occluder {builder_name}: every node failed; the first: "
                         f"{failures[0]}")
    root["builder"] = builder_name
    return root


def _build_one(builder: Callable, geometry: trimesh.Trimesh, pitch: float, dilation: int,
               keys: tuple, budget, seed, node_options: dict) -> dict:
    """One node's occluder: what :func:`_build_nodes` needs of it, picklable.

    ``keys``: the builder's dilation keyword, voxel-size keyword and whether
    it takes ``voxels`` (:func:`_build_nodes`). The builder's log lines come
    back as ``records`` (dicts of :func:`logging.makeLogRecord`, their
    message formatted); a refusal (:class:`InputError`) as ``failure``, with
    an empty occluder.
    """
    dilate_kw, size_kw, takes_voxels = keys
    kw = dict(node_options)
    revoxelized = False
    if dilate_kw:
        kw[dilate_kw] = dilation
        given = geometry
    elif dilation:
        given = dilated_voxel_mesh(geometry, voxel_size=pitch, dilation=dilation)
        revoxelized = True
    else:
        given = geometry
    if size_kw:
        kw[size_kw] = pitch
    elif takes_voxels:
        kw["voxels"] = max(1, round(float(np.ptp(given.vertices, axis=0).max()) / pitch))
    start = time.perf_counter()
    note, failure = "", None
    try:
        with held_records() as records:
            made = builder(given, budget=budget, seed=seed, **kw)
    except InputError as exc:  # e.g. nothing to build at this node
        made, note, failure = _empty_mesh(), str(exc), exc
        refusal = _log.makeRecord(_log.name, logging.WARNING, __file__, 0,
                                  "no occluder: %s", (exc,), None)
        refusal.node_refusal = True
        records.append(refusal)
    occ_mesh = made.mesh if isinstance(made, Occluder) else made
    if not isinstance(occ_mesh, trimesh.Trimesh):
        raise TypeError(f"node_occluder returned {type(made).__name__}, "
                        "expected an Occluder or a trimesh.Trimesh")
    said = [{"name": r.name, "levelno": r.levelno, "levelname": r.levelname,
             "msg": r.getMessage(), "args": None,
             "node_refusal": bool(getattr(r, "node_refusal", False))} for r in records]
    return {"vertices": np.asarray(occ_mesh.vertices, dtype=np.float64),
            "faces": np.asarray(occ_mesh.faces, dtype=np.int64), "records": said,
            "double_sided": bool(made.double_sided) if isinstance(made, Occluder) else True,
            "revoxelized": revoxelized, "note": note, "failure": failure,
            "seconds": time.perf_counter() - start}


def _build_nodes(nodes: list, mesh: trimesh.Trimesh, faces_of: list, builder: Callable,
                 held: list, *, budget, seed, node_options: dict, jobs: int = 1
                 ) -> list[InputError]:
    """Each node's occluder (:func:`_build_one`), then its error and bounds, children first;
    returns the builder's refusals.

    The nodes are independent (sec. 5: "apply our algorithm independently for
    each node"): with ``jobs`` > 1 they are built in that many processes, the
    same occluders as in one. A builder's log lines are held back
    (:func:`held_records`) and added to ``held`` with their node's id, for
    :func:`report_parts` to say each once; a refusal leaves the node an empty
    occluder and is added as a warning of its own (marked ``node_refusal``).
    """
    names = _keywords(builder)
    keys = (next((k for k in ("dilation", "dilate") if k in names), None),
            next((k for k in ("voxel_size", "pitch") if k in names), None), "voxels" in names)
    calls = [(builder, _submesh(mesh, faces_of[n["id"]]), n["voxel_size"], n["dilation"], keys,
              budget, seed, node_options) for n in reversed(nodes)]
    if jobs > 1 and len(calls) > 1:
        from viscore import cpu_cores
        from viscore._jobs import process_pool

        workers = min(jobs, len(calls))
        with process_pool(workers, max(1, cpu_cores() // workers)) as pool:
            built = list(pool.map(_build_one, *zip(*calls, strict=True)))
    else:
        built = [_build_one(*call) for call in calls]
    failures = []
    for n, b in zip(reversed(nodes), built, strict=True):
        records = [logging.makeLogRecord(r) for r in b["records"]]
        held.extend((n["id"], r) for r in records)
        if b["failure"] is not None:
            failures.append(b["failure"])
        occ_mesh = trimesh.Trimesh(b["vertices"], b["faces"], process=False)
        pitch, dilation = n["voxel_size"], n["dilation"]
        own_error = pitch * (1 + dilation + (0.5 if b["revoxelized"] else 0.0))
        n["error"] = max([own_error] + [c["error"] for c in n["children"]])
        gb = n["geometry_bounds"]
        # the geometry grown by the error, the occluder (slices may reach past the voxel
        # solid: pixel footprints, RDP) and the children's bounds: nested by construction
        boxes = [gb[0] - n["error"], gb[1] + n["error"]]
        if len(occ_mesh.vertices):
            boxes += [np.asarray(occ_mesh.vertices, dtype=np.float64)]
        boxes += [c["bounds"] for c in n["children"]]
        stacked = np.concatenate([np.atleast_2d(x) for x in boxes])
        n["bounds"] = np.stack([stacked.min(axis=0), stacked.max(axis=0)])
        n["occluder"] = occ_mesh
        n["triangles"] = len(occ_mesh.faces)
        n["double_sided"] = b["double_sided"]
        n["seconds"] = b["seconds"]
        n["note"] = b["note"]
        n["objects"] = np.asarray(n["objects"], dtype=np.int64)
        del n["_diag"]
    return failures


def _walk(root: dict) -> list[dict]:
    out, stack = [], [root]
    while stack:
        n = stack.pop()
        out.append(n)
        stack.extend(reversed(n["children"]))
    return out


