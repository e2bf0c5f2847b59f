"""A game level as objects: glTF nodes, or a single mesh split into parts, and its up axis.

Every mesh node of a glTF scene [1]_ is an object (instancing honoured, secs. 3.5
and 3.7), or a single mesh is split into parts; some objects get occluders.

References
----------
.. [1] The Khronos Group. "glTF 2.0 Specification". 2021.
   https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html
"""

from __future__ import annotations

import dataclasses
import logging
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from .._validate import InputError, as_positive
from ..exchange.mesh_io import load_mesh
from .ground import UP_AXES, guess_up
from .scene_graph import (
    FLAT_RATIO,
    LEVEL_SPAN,
    SceneObjects,
    culling_scene_names,
    load_scene_objects,
)

__all__ = ["LevelObjects", "level_objects", "occluder_objects", "guess_up", "MIN_SIZE",
           "FEW_PARTS", "SPLIT_RULES", "TILE_GRID", "TILE_MIN_FACES",
           "TILE_MIN_WIDTH",
           "SIZE_FACTOR", "PART_FRACTION", "FLAT_RATIO", "FALLBACK_SHARE", "LEVEL_SPAN",
           "UP_AXES", "SEE_THROUGH_REFUSAL"]

_log = logging.getLogger(__name__)

#: Default size threshold: bounding-box diagonal, fraction of the level's. In
#: the built-in city (624 world units across) it keeps the ground and every
#: building (4.7-9.2 %) and leaves trees (1.6-1.8 %), lamps, cars and benches.
MIN_SIZE = 0.02
#: Splitting a single mesh: components under this fraction of the level's
#: diagonal are merged into parts (see the module docstring); also the gap,
#: same unit, under which they join.
PART_FRACTION = 0.02
#: When only flat objects pass the threshold and no non-flat one passes the
#: threshold against the non-flat objects' own box: non-flat objects at least
#: this share of the largest non-flat object's diagonal are chosen.
FALLBACK_SHARE = 0.5
#: Rotations from a level's frame to Godot's +Y up (right-handed, det +1).
_TO_GODOT = {
    "y": np.eye(4),
    "z": np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]]),
    "x": np.array([[0.0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]),
}
#: Formats read as a glTF scene.
_GLTF = (".glb", ".gltf")
#: Box pairs compared at once when joining small components (memory ~ 50 B each).
_PAIR_CHUNK = 2_000_000
#: A single OBJ mesh whose connected parts join into fewer pieces than this (a map
#: welded into one mesh) is split by its ``o``/``g`` groups, else by its ``usemtl``
#: groups, when it has more of them.
FEW_PARTS = 8
#: A single mesh left as one object (one connected part, no groups) of at least this
#: many triangles is cut into tiles of a square grid across its ground plane, as engines
#: chunk a welded map or terrain: one object has nothing to cull behind it.
TILE_MIN_FACES = 64
#: ... and whose box is at least this many times as wide (its longer side across the
#: ground plane) as it is tall: a level, not one object (a scan or a building).
TILE_MIN_WIDTH = 2.0
#: Tiles along the longer side of the ground plane (the shorter side gets as many of the
#: same width as it needs, at least one).
TILE_GRID = 4
#: How a level's objects were made, by :attr:`LevelObjects.split_rule`.
SPLIT_RULES = {"nodes": "its glTF mesh nodes", "parts": "its connected parts",
               "groups": "its OBJ o/g groups", "materials": "its OBJ usemtl groups",
               "tiles": f"tiles of a grid across its ground plane ({TILE_GRID} along its "
                        "longer side; it is one connected part with no groups)"}


# --------------------------------------------------------------------------- the level
@dataclass(frozen=True, eq=False)
class LevelObjects:
    """A level as objects, with the ones that get occluders chosen.

    Attributes
    ----------
    objects : SceneObjects
        Every object (glTF: every mesh node; a single mesh: its parts), in the
        level's own frame, world units.
    up : str
        The level's up axis, ``'x'``, ``'y'`` or ``'z'`` (positive direction).
    up_guessed : bool
        Whether ``up`` was guessed (:func:`guess_up`).
    up_reason : str
        One line saying how ``up`` was set.
    to_godot : (4, 4) float64
        Rotation from the level's frame to Godot's +Y-up frame.
    kind : str
        ``'gltf'``, ``'mesh'`` (a single mesh split into parts) or
        ``'gltf-mesh'`` (a glTF of one object, a map exported as one mesh: split
        into parts as a single mesh is, in world space).
    components : int
        Connected components of a single mesh before merging (0 for glTF).
    sizes : (n,) float64
        Bounding-box diagonal of each object, fraction of the level's.
    flat : (n,) bool
        Whether each object is flat (see :data:`FLAT_RATIO`).
    chosen : (k,) int64
        Indices of the objects that get occluders, ascending.
    refused : dict of str -> str
        Object name -> why it gets none (too small), for the others.
    min_size : float or None
        The size threshold used (None when objects were named).
    names : tuple of str or None
        The objects named, when given.
    split_rule : str
        How the objects were made: ``'nodes'`` (glTF mesh nodes), ``'parts'``
        (connected parts joined), ``'groups'`` (OBJ ``o``/``g`` groups) or
        ``'materials'`` (OBJ ``usemtl`` groups) or ``'tiles'`` (one connected part cut
        by a ground-plane grid); :data:`SPLIT_RULES` says each in words.
    """

    objects: SceneObjects
    up: str
    up_guessed: bool
    up_reason: str
    to_godot: np.ndarray
    kind: str
    components: int
    sizes: np.ndarray
    flat: np.ndarray
    chosen: np.ndarray
    refused: dict = field(default_factory=dict)
    min_size: float | None = MIN_SIZE
    names: tuple | None = None
    split_rule: str = "nodes"

    @property
    def source(self) -> str:
        """The file or label the level came from."""
        return self.objects.source


def _up_name(up: object) -> str | None:
    if up is None:
        return None
    text = str(up).strip().lower().lstrip("+")
    if text not in UP_AXES:
        raise InputError(f"up: expected one of {', '.join(UP_AXES)}, got {up!r}")
    return text


def _box_gaps(lo_a: np.ndarray, hi_a: np.ndarray, lo_b: np.ndarray,
              hi_b: np.ndarray) -> np.ndarray:
    """``(a, b)`` Euclidean distances between axis-aligned boxes (0 when they overlap)."""
    gap = np.maximum(0.0, np.maximum(lo_a[:, None] - hi_b[None], lo_b[None] - hi_a[:, None]))
    return np.sqrt((gap**2).sum(axis=-1))


def _split_parts(mesh: trimesh.Trimesh) -> tuple[np.ndarray, int]:
    """Part label of each face (parts numbered by first face), and the component count."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    merged = trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), process=True)
    labels = trimesh.graph.connected_component_labels(merged.face_adjacency,
                                                      node_count=len(merged.faces))
    n = int(labels.max()) + 1 if len(labels) else 0
    tri = np.asarray(mesh.vertices, dtype=np.float64)[np.asarray(mesh.faces)]
    lo = np.full((n, 3), np.inf)
    hi = np.full((n, 3), -np.inf)
    np.minimum.at(lo, labels, tri.min(axis=1))
    np.maximum.at(hi, labels, tri.max(axis=1))
    level = float(np.linalg.norm(tri.reshape(-1, 3).max(0) - tri.reshape(-1, 3).min(0)))
    limit = PART_FRACTION * level
    diag = np.linalg.norm(hi - lo, axis=1)
    big = np.flatnonzero(diag >= limit)
    small = np.flatnonzero(diag < limit)
    owner = np.arange(n)
    if len(big) and len(small):
        step = max(1, _PAIR_CHUNK // len(big))
        for a in range(0, len(small), step):
            s = small[a:a + step]
            d = _box_gaps(lo[s], hi[s], lo[big], hi[big])
            near = np.argmin(d, axis=1)
            close = d[np.arange(len(s)), near] <= limit
            owner[s[close]] = big[near[close]]
    rest = small[owner[small] == small]
    if len(rest) > 1:  # single linkage among the small components left
        from scipy.spatial import cKDTree

        centre = (lo[rest] + hi[rest]) / 2
        # small boxes have diagonals under `limit`: centres of boxes within
        # `limit` of each other are within 2 * limit
        pairs = cKDTree(centre).query_pairs(2 * limit, output_type="ndarray")
        if len(pairs):
            lo_p, hi_p = lo[rest], hi[rest]
            gap = np.maximum(0.0, np.maximum(lo_p[pairs[:, 0]] - hi_p[pairs[:, 1]],
                                             lo_p[pairs[:, 1]] - hi_p[pairs[:, 0]]))
            keep = pairs[np.sqrt((gap**2).sum(axis=1)) <= limit]
            graph = coo_matrix((np.ones(len(keep)), (keep[:, 0], keep[:, 1])),
                               shape=(len(rest), len(rest)))
            _, group = connected_components(graph, directed=False)
            first = np.full(int(group.max()) + 1, len(rest))
            np.minimum.at(first, group, np.arange(len(rest)))
            owner[rest] = rest[first[group]]
    part_of_face = owner[labels]
    _, first_face = np.unique(part_of_face, return_index=True)
    rank = np.empty(n, dtype=np.int64)
    roots = part_of_face[np.sort(first_face)]
    rank[roots] = np.arange(len(roots))
    return rank[part_of_face], n


def _by_first_face(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Labels renumbered 0, 1, ... in the order of their first face, and the old label of
    each new number."""
    values, first, inverse = np.unique(labels, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty(len(first), np.int64)
    rank[order] = np.arange(len(first))
    return rank[inverse.reshape(-1)], values[order]


def _group_parts(mesh: trimesh.Trimesh, path: str) -> tuple[np.ndarray, list, str] | None:
    """The faces of a mesh loaded from an OBJ file labelled by its ``o``/``g`` groups or,
    with fewer than two of those, its ``usemtl`` groups (:mod:`viscore.exchange.obj_groups`):
    part label per face (numbered by first face), each part's group name, and the rule
    (``'groups'`` or ``'materials'``); None when the file has neither."""
    from ..exchange.obj_groups import label_faces, obj_groups

    found = obj_groups(path)
    for rule, labels, names in (("groups", found.group, found.group_names),
                                ("materials", found.material, found.material_names)):
        if found.groups_used < 2 and rule == "groups":
            continue
        if rule == "materials" and found.materials_used < 2:
            return None
        per_face = label_faces(found, mesh.vertices, mesh.faces, labels)
        ranked, order = _by_first_face(per_face)
        return ranked, [names[k] or "ungrouped" for k in order], rule
    return None


def _level_like(mesh: trimesh.Trimesh, up: str) -> bool:
    """Whether the mesh's box is :data:`TILE_MIN_WIDTH` times as wide as it is tall."""
    extent = np.ptp(np.asarray(mesh.vertices, dtype=np.float64), axis=0)
    k = UP_AXES.index(up)
    return bool(np.delete(extent, k).max() >= TILE_MIN_WIDTH * extent[k])


def _tile_parts(mesh: trimesh.Trimesh, up: str) -> np.ndarray:
    """Tile label of each face (tiles numbered by first face): the square cell of a grid
    across the plane normal to ``up`` that holds the face's centroid, :data:`TILE_GRID`
    cells along the longer side of the mesh's box in that plane; empty cells get none."""
    across = [k for k in range(3) if k != UP_AXES.index(up)]
    centre = np.asarray(mesh.vertices, dtype=np.float64)[np.asarray(mesh.faces)].mean(axis=1)
    flat = centre[:, across]
    lo, hi = flat.min(axis=0), flat.max(axis=0)
    side = float((hi - lo).max()) / TILE_GRID
    if not side > 0.0:
        return np.zeros(len(centre), dtype=np.int64)
    cells = np.maximum(1, np.ceil((hi - lo) / side - 1e-9)).astype(np.int64)
    cell = np.minimum(((flat - lo) / side).astype(np.int64), cells - 1)
    return _by_first_face(cell[:, 0] * cells[1] + cell[:, 1])[0]


def _mesh_level(mesh: trimesh.Trimesh, label: str, up: str, *, see_through: bool = False,
                obj_path: str | None = None) -> tuple[SceneObjects, int, str]:
    """A single mesh split into parts (:func:`_split_parts`) as a :class:`SceneObjects`;
    every part is see-through when the mesh is. An OBJ file (``obj_path``) whose parts
    join into fewer than :data:`FEW_PARTS` pieces is split by its groups instead
    (:func:`_group_parts`), when it has more groups than parts; a mesh still one object,
    of at least :data:`TILE_MIN_FACES` triangles and wider than tall
    (:data:`TILE_MIN_WIDTH`), is cut into tiles (:func:`_tile_parts`).
    Returns the objects, the connected component count and the rule (:data:`SPLIT_RULES`)."""
    parts, components = _split_parts(mesh)
    count = int(parts.max()) + 1
    stem = Path(label).stem or "level"
    rule, group_names = "parts", None
    if obj_path is not None and count < FEW_PARTS:
        grouped = _group_parts(mesh, obj_path)
        if grouped is not None and len(grouped[1]) > count:
            parts, group_names, rule = grouped
            count = len(group_names)
    if count == 1 and len(mesh.faces) >= TILE_MIN_FACES and _level_like(mesh, up):
        tiles = _tile_parts(mesh, up)
        if tiles.max() > 0:
            parts, rule, count = tiles, "tiles", int(tiles.max()) + 1
    width = len(str(count))
    used_names: set = set()
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    meshes, names = [], []
    order = np.argsort(parts, kind="stable")
    bounds = np.searchsorted(parts[order], np.arange(count + 1))
    for k in range(count):
        f = faces[order[bounds[k]:bounds[k + 1]]]
        used, inverse = np.unique(f, return_inverse=True)
        part = trimesh.Trimesh(vertices[used], inverse.reshape(-1, 3), process=False)
        if group_names is None:
            names.append(f"{stem}_{'tile' if rule == 'tiles' else 'part'}{k + 1:0{width}d}")
        else:  # the group's own name, made unique
            name = " ".join(str(group_names[k]).split()) or "ungrouped"
            if name in used_names:
                name = f"{name}_{k + 1:0{width}d}"
            used_names.add(name)
            names.append(name)
        # named as a glTF level's meshes are ('file:node'), for the generators' messages
        part.metadata["name"] = f"{label}:{names[-1]}"
        meshes.append(part)
    lower = np.array([m.vertices.min(axis=0) for m in meshes])
    upper = np.array([m.vertices.max(axis=0) for m in meshes])
    up_vec = np.eye(3)[UP_AXES.index(up)]
    arrays = dict(mesh_ids=np.arange(count, dtype=np.int64),
                  transforms=np.repeat(np.eye(4)[None], count, axis=0),
                  lower=lower, upper=upper,
                  triangles=np.array([len(m.faces) for m in meshes], dtype=np.int64),
                  up=up_vec)
    for arr in arrays.values():
        arr.flags.writeable = False
    objects = SceneObjects(names=tuple(names), meshes=tuple(meshes), mesh_names=tuple(names),
                           source=label, see_through=np.full(count, see_through), **arrays)
    return objects, components, rule


#: Why an object with a transparent material gets no occluder.
SEE_THROUGH_REFUSAL = ("see-through: its material is blended or cut out (glTF alphaMode BLEND "
                       "or MASK, with some alpha under opaque), and what lies behind it "
                       "shows; engines bake no occluder from it")


def _choose(objects: SceneObjects, up: str, min_size: float | None,
            names: Sequence[str] | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Sizes, flatness, chosen indices and refusals (see the module docstring)."""
    level = float(np.linalg.norm(objects.bounds[1] - objects.bounds[0])) or 1.0
    diag = np.linalg.norm(objects.upper - objects.lower, axis=1)
    axis = np.eye(3)[UP_AXES.index(up)]
    flat = objects.flat(axis)
    box, part = objects.built_bounds(axis)
    if part:
        built = float(np.linalg.norm(box[1] - box[0]))
        _log.info("%s: its built part spans %.4g world units, %.4g with what lies around it "
                  "(flat ground or sea, a sky, a landscape, far outskirts); object sizes are "
                  "fractions of the built part", objects.source, built, level)
        level = built
    sizes = diag / level
    for arr in (sizes, flat):
        arr.flags.writeable = False
    if names is not None:
        chosen = occluder_objects(objects, names=names)
        refused = {objects.names[i]: "not named in --occluders"
                   for i in range(len(objects)) if i not in set(chosen.tolist())}
        return sizes, flat, chosen, refused
    sky = objects.sky()
    clear = objects.see_through
    mask = (sizes >= min_size) & ~sky & ~clear  # type: ignore[operator]
    solid = ~flat & ~sky & ~clear  # type: ignore[operator]
    if mask.any() and not (mask & solid).any() and solid.any():
        lo, hi = objects.lower[solid].min(axis=0), objects.upper[solid].max(axis=0)
        limit = min(min_size * float(np.linalg.norm(hi - lo)),  # type: ignore[operator]
                    FALLBACK_SHARE * float(diag[solid].max()))
        extra = solid & (diag >= limit)
        _log.info("%s: only flat objects (ground, terrain) pass the size threshold; also "
                  "choosing the %d non-flat objects of diagonal %.4g world units or more",
                  objects.source, int(extra.sum()), limit)
        mask |= extra
    chosen = np.flatnonzero(mask).astype(np.int64)
    refused = {objects.names[i]: (
        "a sky: it surrounds the rest of the level from afar, so nothing lies behind it"
        if sky[i] else SEE_THROUGH_REFUSAL if clear[i]  # type: ignore[index]
        else f"too small: its bounding-box diagonal is {sizes[i]:.2%} of the "
        f"level's, under the threshold of {min_size:.2%}") for i in np.flatnonzero(~mask)}
    return sizes, flat, chosen, refused


def level_objects(source: str | os.PathLike | trimesh.Scene | trimesh.Trimesh, *,
                  up: str | None = None, min_size: float | None = None,
                  names: Sequence[str] | None = None) -> LevelObjects:
    """Read a level as objects and choose those that get occluders.

    Parameters
    ----------
    source : str, path, trimesh.Scene or trimesh.Trimesh
        A glTF/GLB file or a ``trimesh.Scene`` (every mesh node an object,
        instancing honoured; +Y up), or a single-mesh file (OBJ, PLY, OFF,
        STL) or ``trimesh.Trimesh``, split into parts (module docstring).
    up : str, optional
        ``'x'``, ``'y'`` or ``'z'``, the level's up axis. Default: +Y for
        glTF (another axis overrides it, for files written Z-up; the Godot
        frame stays the glTF's), guessed by :func:`guess_up` for a single mesh.
    min_size : float, optional
        Bounding-box diagonal, fraction of the level's, from which an object
        gets occluders; in (0, 1]. Default :data:`MIN_SIZE` (0.02). Not used
        with ``names``.
    names : sequence of str, optional
        Exactly these objects get occluders.

    Returns
    -------
    LevelObjects

    Raises
    ------
    InputError
        A file :func:`viscore.level.scene_graph.load_scene_objects` or
        :func:`viscore.load_mesh` refuses; ``up`` not an axis; ``min_size``
        outside (0, 1]; both ``min_size`` and ``names``; a name no object has.

    Notes
    -----
    Deterministic. A flat object spanning the level is never the only kind
    chosen (module docstring). Objects under the threshold are listed in
    ``refused`` with their size.

    Examples
    --------
    >>> import trimesh
    >>> parts = [trimesh.creation.box(bounds=[[x, 0, 0], [x + 1, 1, 1]]) for x in (0, 3)]
    >>> level = level_objects(trimesh.util.concatenate(parts), up="z")
    >>> level.objects.names, level.chosen.tolist()
    (('mesh_part1', 'mesh_part2'), [0, 1])
    """
    up = _up_name(up)
    if names is not None and min_size is not None:
        raise InputError("occluders: give a size threshold or names, not both")
    if names is not None:
        names = list(dict.fromkeys(str(n).strip() for n in names if str(n).strip()))
        if not names:
            raise InputError("occluders: expected object names, got none")
    if min_size is None and names is None:
        min_size = MIN_SIZE
    if min_size is not None:
        try:
            min_size = float(min_size)
        except (TypeError, ValueError):
            raise InputError(f"min_size: expected a number in (0, 1], got {min_size!r}") from None
        if not 0.0 < min_size <= 1.0:
            raise InputError(f"min_size: expected a fraction of the level's bounding-box "
                             f"diagonal in (0, 1], got {min_size!r}")
    gltf = isinstance(source, trimesh.Scene) or (
        not isinstance(source, trimesh.Trimesh) and (
            Path(os.fspath(source)).suffix.lower() in _GLTF
            or (not Path(os.fspath(source)).exists()
                and os.fspath(source) in culling_scene_names())))
    if gltf:
        objects = load_scene_objects(source)
        kind, guessed, components, rule = "gltf", False, 0, "nodes"
        if up in (None, "y"):
            up, reason = "y", "glTF is +Y up"
        else:  # a file written +Z up (three.js and Blender scenes that skip the rotation)
            reason = f"given as {up}, over glTF's +Y"
            axis = np.eye(3)[UP_AXES.index(up)]
            axis.flags.writeable = False
            objects = dataclasses.replace(objects, up=axis)
        if len(objects) == 1 and names is None:  # a map exported as one mesh: its parts
            objects, components, rule = _mesh_level(objects.object_mesh(0), objects.source,
                                                    up, see_through=bool(objects.see_through[0]))  # type: ignore[index]
            kind = "gltf-mesh"
    else:
        label = (str(source.metadata.get("name", "mesh")) if isinstance(source, trimesh.Trimesh)
                 else str(source))
        mesh = load_mesh(source)  # type: ignore[arg-type]
        if up is None:
            up, reason = guess_up(mesh)
            guessed = True
        else:
            guessed, reason = False, f"given as {up}"
        obj = (None if isinstance(source, trimesh.Trimesh)
               or Path(os.fspath(source)).suffix.lower() != ".obj" else os.fspath(source))  # type: ignore[arg-type]
        objects, components, rule = _mesh_level(mesh, label, up, obj_path=obj)
        kind = "mesh"
    sizes, flat, chosen, refused = _choose(objects, up, min_size, names)
    # Godot reads a glTF in its own frame whatever its up: its occluders stay in that frame
    to_godot = (np.eye(4) if kind.startswith("gltf") else _TO_GODOT[up]).copy()
    to_godot.flags.writeable = False
    return LevelObjects(objects=objects, up=up, up_guessed=guessed, up_reason=reason,
                        to_godot=to_godot, kind=kind, components=components, sizes=sizes,
                        flat=flat, chosen=chosen, refused=refused,
                        min_size=None if names is not None else min_size,
                        names=None if names is None else tuple(names), split_rule=rule)


#: Default size threshold of the occluder objects: this many times the median
#: object's bounding-box diagonal (in the built-in cities: buildings and the
#: ground, not cars, lamps, benches or trees).
SIZE_FACTOR = 2.5


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
    chosen = np.flatnonzero((size >= threshold) & ~objects.see_through)  # type: ignore[operator]
    if len(chosen) == 0:
        what = ("size_threshold" if size_threshold is not None else
                f"the default size threshold ({SIZE_FACTOR} x the median object's diagonal)")
        solid = ~objects.see_through  # type: ignore[operator]
        largest = float(size[solid].max()) if solid.any() else 0.0
        raise InputError(f"{what}: no object of {objects.source} is {threshold:.4g} or larger "
                         f"(the largest is {largest:.4g}, world units"
                         + (", see-through objects left out" if not solid.all() else "") + ")")
    return chosen.astype(np.int64)
