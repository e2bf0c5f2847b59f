"""Scenes as objects: every mesh node of a glTF/GLB file is one object and one occludee.

The culling simulation (:mod:`viscore.metrics.culling`) needs a scene as a set
of objects, each with its own bounding box and triangle count, as a
scene-graph renderer sees it (Papaioannou et al. 2006 [1]_, sec. 4: the
culled unit is a scene-graph node tested through its bounding volume).
:func:`load_scene_objects` reads a glTF/GLB file (or a built-in culling scene,
or a ``trimesh.Scene``) and returns a :class:`SceneObjects`: one object per
node that carries a triangle mesh, with its world transform; instancing is
honoured, so a mesh referenced by many nodes is stored once and each node is
its own object. Other mesh formats (OBJ, PLY, ...) are read by
:func:`viscore.load_mesh` as a single object.

World axes: glTF is +Y up by its specification, so objects read from
glTF/GLB get ``up = (0, 1, 0)``; a single mesh from another format gets
viscore's +Z.

The built-in culling scenes ``city`` and ``city-dense`` are GLB files made by
``data/make_city.py``, resolved from the folder of the other built-in scenes.

glTF node hierarchy (glTF 2.0 [2]_, sec. 3.5.1-3.5.3): the world transforms
are composed here, in one iterative pass over the node list of the file's JSON
(``nodes[i].children``, ``matrix`` or ``translation``/``rotation``/``scale``,
``mesh``), linear in the number of nodes; trimesh parses the geometry only.
The hierarchy must be what the specification requires, a set of disjoint
strict trees: a cycle, a node with two parents, or a scene root that is some
node's child is refused with one line naming the nodes, and so is a hierarchy
deeper than ``_MAX_NODE_DEPTH`` levels. Buffer and image URIs must resolve
inside the folder of the glTF/GLB file; nothing outside it is read.

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006 (Plzen), UNION Agency,
   ISBN 80-86943-03-8.
.. [2] The Khronos 3D Formats Working Group. "glTF 2.0 Specification",
   version 2.0.1. The Khronos Group, 2021.
   https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html
"""

from __future__ import annotations

import hashlib
import io
import json
import logging
import os
import stat
import struct
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import numpy.typing as npt
import trimesh

from .._validate import InputError, check_memory
from ..exchange.gltf_meshopt import EXTENSION as MESHOPT
from ..exchange.gltf_meshopt import decode_meshopt_glb
from ..exchange.mesh_io import (
    _BYTES_PER_TRIANGLE,
    _describe_without_triangles,
    _kind,
    _loading,
    _read_regular_file,
    _refuse_path,
    _suffix,
    load_mesh,
    validate_mesh,
)
from ..exchange.mesh_validation import _MAX_COORDINATE, _MAX_OFFSET_RATIO
from ..ray.embree_scene import Scene
from .hidden_nodes import hidden_reason

__all__ = ["SceneObjects", "load_scene_objects", "culling_scene_names", "culling_scene_path",
           "culling_scene_descriptions"]

_log = logging.getLogger(__name__)

#: Built-in culling scenes: name -> (file beside the other built-in scenes, description).
_CULLING_SCENES = {
    "city": ("city.glb", "street grid of multi-panel buildings (occluders) and 1,000+ instanced "
                         "cars, lamps, benches and trees (occludees); glTF, +Y up"),
    "city-dense": ("city_dense.glb", "denser, taller city: more buildings closer together, "
                                     "more occludees; glTF, +Y up"),
}

#: Up axis of glTF (its specification: +Y up) and of viscore's own meshes (+Z).
_GLTF_UP = (0.0, 1.0, 0.0)
_VISCORE_UP = (0.0, 0.0, 1.0)

#: A node transform whose 3x3 part has a determinant below this fraction of the
#: cube of its largest entry is singular (a zero scale that flattens the mesh).
_SINGULAR_RELATIVE = 1e-12

_EYE = np.eye(4)
_EYE.flags.writeable = False

#: Deepest glTF node hierarchy read, in levels (a scene's root node is level 1).
#: Authored hierarchies (CAD assemblies, character rigs, scene graphs exported
#: from DCC tools) are tens of levels deep, rarely a few hundred; a chain of
#: thousands is generated or hostile. The transforms are composed iteratively
#: here, so depth costs nothing in viscore, but trimesh's own scene graph (which
#: ``viscore.load_mesh`` and trimesh's exporters use on the same file) composes
#: a path with ``numpy.linalg.multi_dot``, which recurses once per level, and
#: fails with RecursionError near Python's default recursion limit of 1,000: a
#: deeper file is refused here too rather than accepted by one reader of
#: viscore and not by the other. World transforms lose about one float64 ulp
#: per level, ~1e-13 relative at this depth.
_MAX_NODE_DEPTH = 1_000

#: Compatibility with trimesh's scene graph, which loaded glTF transforms before
#: (trimesh 5.2, ``trimesh/scene/transforms.py``), kept so that valid files load
#: to the same float64 transforms: below the root, a node's local transform
#: within this (max abs difference) of the identity is dropped from the product.
_NEAR_IDENTITY = 1e-8
#: ... and a world transform whose 3x3 part is rigid to within these bounds on
#: ``max |A A^T - I|`` is re-orthonormalised by SVD (``SceneGraph(repair_rigid=1e-5)``
#: and ``transformations.fix_rigid``; e.g. a rotation matrix written in float32).
_RIGID_REPAIR_LOW = 1e-13
_RIGID_REPAIR_HIGH = 1e-5

#: GLB layout (glTF 2.0, "GLB File Format Specification"): a 12-byte header
#: (magic, version, total length), then chunks of (length, type, data), the
#: first one the JSON.
_GLB_HEADER = struct.Struct("<4sII")
_GLB_CHUNK = struct.Struct("<I4s")
_GLB_MAGIC = b"glTF"
_GLB_JSON = b"JSON"
_GLB_VERSION = 2
_GLB_ALIGN = 4
_UINT32_MAX = 2**32 - 1

#: Longest node name quoted in a message (a hostile name could fill a screen).
_NAME_CHARS = 60
#: Nodes of a cycle listed in its message before "...".
_CYCLE_SHOWN = 6


def culling_scene_descriptions() -> dict[str, str]:
    """Name -> one-line description of every built-in culling scene.

    Examples
    --------
    >>> sorted(culling_scene_descriptions())
    ['city', 'city-dense']
    """
    return {name: desc for name, (_, desc) in _CULLING_SCENES.items()}


def culling_scene_names() -> list[str]:
    """Names of the built-in culling scenes (``city``, ``city-dense``)."""
    return list(_CULLING_SCENES)


def culling_scene_path(name: str) -> Path:
    """Path of the GLB file behind a built-in culling scene.

    Raises
    ------
    InputError
        If ``name`` is not a built-in culling scene, or its file is missing.
    """
    from ..builtin_scenes import _procedural_dir

    if name not in _CULLING_SCENES:
        raise InputError(f"{name}: not a built-in culling scene "
                         f"(built-in: {', '.join(_CULLING_SCENES)})")
    path = _procedural_dir() / _CULLING_SCENES[name][0]
    if not path.is_file():
        raise InputError(f"{name}: built-in scene file is missing at {path}; "
                         "run data/make_city.py or reinstall viscore")
    return path


#: An object is flat when its box's extent along the up axis is under this fraction of
#: its widest horizontal extent (ground, terrain, floor slabs).
FLAT_RATIO = 0.1
#: A flat object whose box makes the level's diagonal more than this many times that of
#: the non-flat objects' box (an outer ground plane, a sea around a town) does not set
#: the level's extent: its built part is the non-flat objects' box.
LEVEL_SPAN = 2.0
#: Largest objects checked by :meth:`SceneObjects.sky` (a sky box around a sky dome).
SKY_CANDIDATES = 3


@dataclass(frozen=True, eq=False)
class SceneObjects:
    """The objects of a scene: shared meshes, one world transform per object.

    Attributes
    ----------
    names : tuple of str
        (n,) node name of each object (unique).
    mesh_ids : (n,) int64
        Index into ``meshes`` of each object's geometry.
    transforms : (n, 4, 4) float64
        Local-to-world transform of each object.
    meshes : tuple of trimesh.Trimesh
        (m,) the distinct geometries, each stored once in its local frame
        (validated by :func:`viscore.validate_mesh`); identical copies under
        other names are stored once too.
    mesh_names : tuple of str
        (m,) name of each geometry.
    lower, upper : (n, 3) float64
        World-space axis-aligned bounding box of each object, world units.
    triangles : (n,) int64
        Triangle count of each object.
    up : (3,) float64
        The scene's up axis: +Y for glTF, +Z otherwise.
    source : str
        File or scene name the objects came from.
    see_through : (n,) bool
        Objects drawn see-through by their glTF material
        (:func:`see_through_material`: ``alphaMode`` ``BLEND`` or ``MASK`` with
        some alpha under opaque: glass, water, foliage cut-outs); all False
        when not given (a mesh file has no materials).

    Notes
    -----
    Objects are ordered by node name. World-space triangles are computed on
    demand (:meth:`object_triangles`, :meth:`object_mesh`); the one Embree
    scene of everything, with its triangle-to-object map, is built once on
    first use (:attr:`combined`).
    """

    names: tuple[str, ...]
    mesh_ids: np.ndarray
    transforms: np.ndarray
    meshes: tuple[trimesh.Trimesh, ...]
    mesh_names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    triangles: np.ndarray
    up: np.ndarray
    source: str
    see_through: np.ndarray | None = None

    def __post_init__(self) -> None:
        flags = (np.zeros(len(self.names), dtype=bool) if self.see_through is None
                 else np.array(self.see_through, dtype=bool).reshape(len(self.names)))
        flags.flags.writeable = False
        object.__setattr__(self, "see_through", flags)

    def __len__(self) -> int:
        return len(self.names)

    def __getstate__(self) -> dict:
        """Pickled without :attr:`combined`: the baked level is rebuilt where it is used
        (a worker of a spread walk), not shipped (7.5M triangles on the city tiled 4 x 4)."""
        state = dict(self.__dict__)
        state.pop("combined", None)
        return state

    @property
    def bounds(self) -> np.ndarray:
        """``(2, 3) float64`` lower and upper corner of the whole scene, world units."""
        return np.stack([self.lower.min(axis=0), self.upper.max(axis=0)])

    def flat(self, up: npt.ArrayLike | None = None) -> np.ndarray:
        """``(n,) bool``: objects whose box's extent along ``up`` (default :attr:`up`) is
        under :data:`FLAT_RATIO` of its widest horizontal extent (ground, terrain, floor
        slabs)."""
        u = np.abs(np.asarray(self.up if up is None else up, dtype=np.float64))
        u = u / np.linalg.norm(u)
        extent = self.upper - self.lower
        along = extent @ u
        # the widest horizontal extent: of the box's extent with its part along up removed
        across = np.linalg.norm(extent - np.outer(along, u), axis=1) if np.count_nonzero(
            u) > 1 else np.delete(extent, int(np.argmax(u)), axis=1).max(axis=1)
        return along < FLAT_RATIO * across

    def sky(self) -> np.ndarray:
        """``(n,) bool``: objects that surround the rest of the level from afar (a sky
        dome or sky box): the object's box holds the centre of the box of the other
        objects, and every vertex lies farther from that box than :data:`LEVEL_SPAN`
        times its diagonal.

        Only the :data:`SKY_CANDIDATES` objects of largest box are checked, largest
        first, each against the objects not yet found to be sky; the first that is not
        a sky ends the search. A level of one object has none.

        Examples
        --------
        >>> import trimesh
        >>> scene = trimesh.Scene()
        >>> _ = scene.add_geometry(trimesh.creation.box(extents=[2, 2, 2]), node_name="house")
        >>> _ = scene.add_geometry(trimesh.creation.icosphere(radius=500.0), node_name="sky")
        >>> objects = load_scene_objects(scene)
        >>> [objects.names[i] for i in np.flatnonzero(objects.sky())]
        ['sky']
        """
        sky = np.zeros(len(self), dtype=bool)
        order = np.argsort(-np.linalg.norm(self.upper - self.lower, axis=1), kind="stable")
        for i in order[:SKY_CANDIDATES]:
            rest = ~sky
            rest[i] = False
            if not rest.any():
                break
            lo, hi = self.lower[rest].min(axis=0), self.upper[rest].max(axis=0)
            v = self.object_vertices(int(i))
            gap = np.linalg.norm(np.maximum(0.0, np.maximum(lo - v, v - hi)), axis=1)
            centre = (lo + hi) / 2
            around = bool(np.all((self.lower[i] <= centre) & (centre <= self.upper[i])))
            if not (len(v) and around) or gap.min() <= LEVEL_SPAN * float(
                    np.linalg.norm(hi - lo)):
                break
            sky[i] = True
        return sky

    def built_bounds(self, up: npt.ArrayLike | None = None) -> tuple[np.ndarray, bool]:
        """``(2, 3)`` the box of the level's built part, and whether it is not the whole.

        The box of the objects that are neither flat nor sky (:meth:`sky`) when
        the others (an outer ground plane, a sea around a town, a sky dome)
        make the whole box's diagonal more than :data:`LEVEL_SPAN` times its
        diagonal; otherwise :attr:`bounds`.
        """
        whole = self.bounds
        outer = self.flat(up) | self.sky()
        if outer.all() or not outer.any():
            return whole, False
        built = np.stack([self.lower[~outer].min(axis=0), self.upper[~outer].max(axis=0)])
        span = float(np.linalg.norm(built[1] - built[0]))
        if span > 0 and float(np.linalg.norm(whole[1] - whole[0])) > LEVEL_SPAN * span:
            return built, True
        return whole, False

    @property
    def total_triangles(self) -> int:
        """Triangles of all objects, instances counted each time."""
        return int(self.triangles.sum())

    def _index(self, i: int) -> int:
        if not isinstance(i, (int, np.integer)) or not -len(self) <= int(i) < len(self):
            raise InputError(f"object index: expected an integer in [0, {len(self)}), got {i!r}")
        return int(i) % len(self)

    def object_vertices(self, i: int) -> np.ndarray:
        """``(v, 3) float64`` world-space vertices of object ``i``."""
        i = self._index(i)
        m = self.transforms[i]
        v = np.asarray(self.meshes[self.mesh_ids[i]].vertices, dtype=np.float64)
        return v @ m[:3, :3].T + m[:3, 3]

    def object_triangles(self, i: int) -> np.ndarray:
        """``(t, 3, 3) float64`` world-space triangles of object ``i``."""
        i = self._index(i)
        return self.object_vertices(i)[np.asarray(self.meshes[self.mesh_ids[i]].faces)]

    def object_mesh(self, i: int) -> trimesh.Trimesh:
        """Object ``i`` as a world-space :class:`trimesh.Trimesh` (a new mesh)."""
        i = self._index(i)
        mesh = trimesh.Trimesh(self.object_vertices(i),
                               np.array(self.meshes[self.mesh_ids[i]].faces), process=False)
        mesh.metadata["name"] = self.names[i]
        return mesh

    def instances(self, mesh_id: int) -> np.ndarray:
        """``(k,) int64`` indices of the objects that instance geometry ``mesh_id``."""
        return np.flatnonzero(self.mesh_ids == mesh_id)

    @cached_property
    def combined(self) -> tuple[Scene, np.ndarray]:
        """One :class:`~viscore.Scene` of every object, and its triangle -> object map.

        Returns
        -------
        scene : Scene
            Every instance baked into one world-space triangle soup.
        triangle_object : (F,) int64
            Object index of each triangle of ``scene``; use it on the triangle
            ids of :meth:`Scene.first_hit` (``-1`` on a miss stays a miss via
            ``np.where``) for an object-id image.
        """
        check_memory(float(self.total_triangles) * _BYTES_PER_TRIANGLE,
                     f"{self.source} ({self.total_triangles:,} triangles with instances baked)")
        # one array each, filled mesh by mesh (a list of pieces and its concatenation
        # held the level's vertices twice more while the Scene copied them)
        used = [(mesh_id, self.instances(mesh_id)) for mesh_id in range(len(self.meshes))]
        used = [(mesh_id, idx) for mesh_id, idx in used if len(idx)]
        total_v = sum(len(idx) * len(self.meshes[m].vertices) for m, idx in used)
        total_f = sum(len(idx) * len(self.meshes[m].faces) for m, idx in used)
        vertices = np.empty((total_v, 3))
        faces = np.empty((total_f, 3), dtype=np.int64)
        triangle_object = np.empty(total_f, dtype=np.int64)
        base = row = 0
        for mesh_id, idx in used:
            mesh = self.meshes[mesh_id]
            v = np.asarray(mesh.vertices, dtype=np.float64)
            f = np.asarray(mesh.faces, dtype=np.int64)
            mats = self.transforms[idx]
            vk = np.einsum("kij,nj->kni", mats[:, :3, :3], v) + mats[:, None, :3, 3]
            vertices[base:base + vk.shape[0] * vk.shape[1]] = vk.reshape(-1, 3)
            del vk
            offsets = base + len(v) * np.arange(len(idx))
            rows = len(idx) * len(f)
            faces[row:row + rows] = (f[None] + offsets[:, None, None]).reshape(-1, 3)
            triangle_object[row:row + rows] = np.repeat(idx, len(f))
            base += len(idx) * len(v)
            row += rows
        mesh = trimesh.Trimesh(vertices, faces, process=False)
        del vertices, faces
        triangle_object.flags.writeable = False
        return Scene(mesh), triangle_object


# --------------------------------------------------------------------------- loading
def _node_transforms(scene: trimesh.Scene, label: str
                     ) -> tuple[list[str], list[str], np.ndarray]:
    """Node names, geometry names and ``(n, 4, 4)`` world transforms of the mesh nodes."""
    names, geoms, mats = [], [], []
    for node in sorted(scene.graph.nodes_geometry):
        with np.errstate(all="ignore"):  # a huge scale overflows in trimesh; refused below
            matrix, geometry = scene.graph[node]
        g = scene.geometry.get(geometry)
        if not isinstance(g, trimesh.Trimesh) or len(g.faces) == 0:
            continue
        names.append(str(node))
        geoms.append(str(geometry))
        mats.append(np.asarray(matrix, dtype=np.float64))
    if not names:
        raise InputError(f"{label}: {_describe_without_triangles(scene)}")
    return names, geoms, np.asarray(mats, dtype=np.float64).reshape(-1, 4, 4)


def _from_trimesh_scene(scene: trimesh.Scene, label: str, up) -> SceneObjects:
    names, geoms, mats = _node_transforms(scene, label)
    return _scene_objects(names, geoms, mats, scene.geometry, label, up)


def geometry_digest(mesh: trimesh.Trimesh) -> bytes:
    """SHA-256 of a mesh's vertices (float64) and faces (int64), in order: equal exactly
    when the two are the same geometry vertex for vertex and face for face."""
    return hashlib.sha256(
        np.ascontiguousarray(mesh.vertices, dtype="<f8").tobytes() + b"|"
        + np.ascontiguousarray(mesh.faces, dtype="<i8").tobytes()).digest()


def _scene_objects(names: list[str], geoms: list[str], mats: np.ndarray, geometry: dict,
                   label: str, up) -> SceneObjects:
    """Check the world transforms and build the :class:`SceneObjects` (objects in given order).

    An object is see-through when its geometry's material (as trimesh read it)
    draws it so (:func:`see_through_material`).
    """
    if not np.isfinite(mats).all():
        bad = names[int(np.flatnonzero(~np.isfinite(mats).all(axis=(1, 2)))[0])]
        raise InputError(f"{label}: node {bad!r} has a transform with NaN or infinite values")
    lin = mats[:, :3, :3]
    scale = np.abs(lin).max(axis=(1, 2))
    with np.errstate(over="ignore", invalid="ignore"):
        det = np.abs(np.linalg.det(lin))
        cube = scale**3
    huge = ~(np.isfinite(det) & np.isfinite(cube))
    if huge.any():
        bad = names[int(np.flatnonzero(huge)[0])]
        raise InputError(f"{label}: node {bad!r} has a transform whose scale "
                         f"({scale[huge][0]:.3g}) is beyond what float64 can hold in a volume")
    singular = ~(det > _SINGULAR_RELATIVE * cube)
    if singular.any():
        bad = names[int(np.flatnonzero(singular)[0])]
        raise InputError(f"{label}: node {bad!r} has a singular transform (a zero scale "
                         "flattens its mesh)")
    names_once = list(dict.fromkeys(geoms))
    # geometries equal vertex for vertex and face for face (a level exported without
    # instancing: every copy of a room its own glTF mesh, each in the same local frame)
    # are stored once, under the first one's name, as instances of one mesh would be
    index: dict[str, int] = {}
    first: dict[bytes, int] = {}
    mesh_names: list[str] = []
    kept: list[trimesh.Trimesh] = []
    for g in names_once:
        mesh = validate_mesh(geometry[g], name=f"{label}:{g}")
        digest = geometry_digest(mesh)
        if digest not in first:
            first[digest] = len(kept)
            kept.append(mesh)
            mesh_names.append(g)
        index[g] = first[digest]
    meshes = tuple(kept)
    mesh_ids = np.array([index[g] for g in geoms], dtype=np.int64)
    n = len(names)
    lower, upper = np.empty((n, 3)), np.empty((n, 3))
    for mesh_id, mesh in enumerate(meshes):
        idx = np.flatnonzero(mesh_ids == mesh_id)
        v = np.asarray(mesh.vertices, dtype=np.float64)
        # corners of the local box would give a looser box: transform the vertices,
        # in chunks of instances so memory stays ~ 16M coordinates
        chunk = max(1, 16_000_000 // max(1, 3 * len(v)))
        for a in range(0, len(idx), chunk):
            sel = idx[a:a + chunk]
            with np.errstate(over="ignore", invalid="ignore"):
                vk = np.einsum("kij,nj->kni", mats[sel, :3, :3], v) + mats[sel, None, :3, 3]
            lower[sel] = vk.min(axis=1)
            upper[sel] = vk.max(axis=1)
    if not (np.isfinite(lower).all() and np.isfinite(upper).all()):
        raise InputError(f"{label}: node transforms place vertices beyond float64's range")
    lo, hi = lower.min(axis=0), upper.max(axis=0)
    biggest = float(max(np.abs(lo).max(), np.abs(hi).max()))
    diagonal = float(np.linalg.norm(hi - lo))
    if biggest > _MAX_COORDINATE:
        raise InputError(f"{label}: world coordinates up to {biggest:.3g} exceed "
                         f"{_MAX_COORDINATE:.0e}; scale the scene down")
    if biggest > _MAX_OFFSET_RATIO * diagonal:
        raise InputError(f"{label}: the scene (extent {diagonal:.3g}) lies {biggest:.3g} from "
                         f"the origin, more than {_MAX_OFFSET_RATIO:.0e} x its extent")
    triangles = np.array([len(meshes[k].faces) for k in mesh_ids], dtype=np.int64)
    for arr in (mesh_ids, mats, lower, upper, triangles):
        arr.flags.writeable = False
    up_vec = np.array(up, dtype=np.float64)
    up_vec.flags.writeable = False
    # once per geometry: a material's texture is read for its alpha, and a level places
    # one geometry in many objects
    clear = {g: see_through_material(geometry[g]) for g in names_once}
    see_through = np.array([clear[g] for g in geoms], dtype=bool)
    return SceneObjects(names=tuple(names), mesh_ids=mesh_ids, transforms=mats, meshes=meshes,
                        mesh_names=tuple(mesh_names), lower=lower, upper=upper,
                        triangles=triangles, up=up_vec, source=label, see_through=see_through)


#: glTF alpha modes drawn see-through: alpha blending and alpha testing (cut-outs), the
#: two Godot imports as transparent materials and leaves out of its occluder bake.
TRANSPARENT_ALPHA_MODES = ("BLEND", "MASK")


def transparent_material(geometry) -> bool:
    """Whether a geometry's material, as trimesh read it from glTF, draws it see-through.

    True for ``alphaMode`` ``BLEND`` or ``MASK`` (:data:`TRANSPARENT_ALPHA_MODES`);
    False for ``OPAQUE``, no material, or a geometry that is not a mesh.
    """
    material = getattr(getattr(geometry, "visual", None), "material", None)
    mode = getattr(material, "alphaMode", None)
    return str(mode).upper() in TRANSPARENT_ALPHA_MODES if mode else False


#: Least alpha (base colour factor x texture) at which an alpha-blended surface is
#: drawn as good as opaque: what lies behind shows through at most 5%.
OPAQUE_ALPHA = 0.95


def _least_alpha(material) -> float:
    """Least alpha a glTF material draws: its base colour factor's alpha times the least
    alpha of its base colour texture (1 without an alpha channel); vertex colours are
    not read."""
    factor = getattr(material, "baseColorFactor", None)
    alpha = 1.0
    if factor is not None and len(factor) == 4:
        f = np.asarray(factor)
        alpha = float(f[3]) / 255.0 if f.dtype.kind in "ui" else float(f[3])
    texture = getattr(material, "baseColorTexture", None)
    if texture is not None and alpha > 0:
        try:
            bands = texture.getbands()
            if "A" in bands:
                alpha *= texture.getchannel("A").getextrema()[0] / 255.0
        except (AttributeError, ValueError, OSError):  # not a PIL image: alpha unknown
            return 0.0
    return alpha


def see_through_material(geometry) -> bool:
    """Whether a glTF primitive is drawn see-through, as far as its material says.

    Its alpha mode is ``BLEND`` and its least alpha (:func:`_least_alpha`) is
    under :data:`OPAQUE_ALPHA`, or ``MASK`` and some alpha is under its
    ``alphaCutoff`` (default 0.5): a blended surface whose every texel is
    opaque (a ground exported with blending on) and a cut-out that cuts
    nothing are opaque.
    """
    if not transparent_material(geometry):
        return False
    material = geometry.visual.material
    alpha = _least_alpha(material)
    if str(material.alphaMode).upper() == "MASK":
        cutoff = getattr(material, "alphaCutoff", None)
        return alpha < (0.5 if cutoff is None else float(cutoff))
    return alpha < OPAQUE_ALPHA


# ----------------------------------------------------------- glTF: JSON and URIs
class _UriOutsideFolder(Exception):
    """A buffer URI that resolves outside the folder of the glTF file (never read)."""

    def __init__(self, uri: str):
        super().__init__(uri)
        self.uri = uri


class _FolderResolver(trimesh.resolvers.FilePathResolver):
    """trimesh's file resolver for the assets of one glTF file, confined to its folder.

    Tries the names trimesh's resolver tries (the URI, the URI without a leading
    ``/``, its last path component), each only if it resolves (symbolic links
    followed) inside the folder, and reads only regular files: a URI escaping the
    folder raises :class:`_UriOutsideFolder` (recorded in ``refused``: trimesh
    skips an image it cannot read, so those are reported after the load) and a
    FIFO or device is refused with :class:`InputError` without being opened.
    """

    def __init__(self, path: Path, label: str):
        super().__init__(str(path.resolve()))
        self._label = label
        self.refused: list[str] = []

    def get(self, name: str) -> bytes:
        folder = Path(self.parent).resolve()
        text = str(name).strip()
        try:
            for candidate in (text, text.lstrip("/"), os.path.split(text)[-1]):
                target = (folder / candidate).resolve()
                if target.is_relative_to(folder) and target.exists():
                    mode = os.stat(target).st_mode
                    if not stat.S_ISREG(mode):
                        raise InputError(f"{self._label}: URI {_quote(name)} is {_kind(mode)}, "
                                         "not a regular file (not read)")
                    with open(target, "rb") as fh:
                        return fh.read()
            escapes = not (folder / text).resolve().is_relative_to(folder)
        except InputError:
            raise
        except (OSError, RuntimeError, ValueError) as exc:  # NUL byte, link loop, no access
            raise InputError(f"{self._label}: URI {_quote(name)} cannot be read "
                             f"({' '.join(str(exc).split())[:120]})") from None
        if escapes:
            self.refused.append(str(name))
            raise _UriOutsideFolder(str(name))
        raise FileNotFoundError(name)


def _quote(value, limit: int = _NAME_CHARS) -> str:
    """``repr`` of a name, URI or value from the file, cut to about ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


def _gltf_json(data: bytes, fmt: str, label: str) -> tuple[dict, tuple[int, int, int]]:
    """The JSON of a glTF/GLB file, and for a GLB its (total length, JSON chunk length, end).

    A GLB is split as trimesh's reader splits it; a malformed one is refused here
    with the same kind of message trimesh's reader gave ("not a valid GLB file").
    """
    what = fmt.upper()
    layout = (0, 0, 0)
    if fmt == "gltf":
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise InputError(f"{label}: not a valid GLTF file (not JSON: "
                             f"{' '.join(str(exc).split())[:120]})") from None
    else:
        if len(data) < _GLB_HEADER.size + _GLB_CHUNK.size:
            raise InputError(f"{label}: not a valid GLB file ({len(data)} bytes, shorter than "
                             "the GLB header)")
        magic, version, length = _GLB_HEADER.unpack_from(data)
        chunk_length, chunk_type = _GLB_CHUNK.unpack_from(data, _GLB_HEADER.size)
        if magic != _GLB_MAGIC:
            raise InputError(f"{label}: not a valid GLB file (incorrect header: no 'glTF' magic)")
        if version != _GLB_VERSION:
            raise InputError(f"{label}: not a valid GLB file (GLB version {version}; only "
                             "glTF 2.0 is supported)")
        if chunk_type != _GLB_JSON:
            raise InputError(f"{label}: not a valid GLB file (no initial JSON chunk)")
        start = _GLB_HEADER.size + _GLB_CHUNK.size
        end = start + chunk_length
        if end > len(data):
            raise InputError(f"{label}: not a valid GLB file (its JSON chunk of {chunk_length:,} "
                             f"bytes runs past the end of the file)")
        text = trimesh.util.decode_text(data[start:end])
        layout = (length, chunk_length, end)
    try:
        header = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise InputError(f"{label}: not a valid {what} file (not JSON: "
                         f"{' '.join(str(exc).split())[:120]})") from None
    if not isinstance(header, dict):
        raise InputError(f"{label}: not a valid {what} file (its JSON is a "
                         f"{type(header).__name__}, not an object)")
    return header, layout


#: Required glTF extensions that compress geometry, which trimesh's reader cannot decode.
_COMPRESSIONS = (MESHOPT, "KHR_draco_mesh_compression")


def _refuse_compressed(header: dict, fmt: str, label: str) -> None:
    """One line for a glTF whose geometry needs a decoder we do not have (its
    ``extensionsRequired`` names Draco compression, or meshopt compression outside a
    GLB, which :func:`viscore.exchange.gltf_meshopt.decode_meshopt_glb` decodes; glTF 2.0
    sec. 3.12)."""
    required = header.get("extensionsRequired")
    names = [n for n in _COMPRESSIONS if isinstance(required, list) and n in required
             and not (fmt == "glb" and n == MESHOPT)]
    if names:
        raise InputError(f"{label}: its geometry is compressed with {' and '.join(names)}, "
                         f"which viscore cannot decode; export the {fmt.upper()} without "
                         "mesh compression (gltf-transform and gltfpack can write one)")


def _mesh_library(data: bytes, header: dict, fmt: str, layout: tuple[int, int, int],
                  label: str) -> bytes:
    """The same file with its node hierarchy replaced by one root node per glTF mesh.

    trimesh then parses the geometry (buffers, accessors, primitives, materials
    exactly as in the original file) without ever seeing the original nodes, and
    node ``str(m)`` of its scene carries mesh ``m``: one geometry, or one child
    per primitive when the mesh has several.
    """
    meshes = header.get("meshes", [])
    count = len(meshes) if isinstance(meshes, list) else 0
    flat = {k: v for k, v in header.items() if k not in ("nodes", "scenes", "scene")}
    flat["nodes"] = [{"name": str(m), "mesh": m} for m in range(count)]
    flat["scenes"] = [{"nodes": list(range(count))}]
    flat["scene"] = 0
    try:
        text = json.dumps(flat).encode("utf-8")
    except (ValueError, RecursionError) as exc:
        raise InputError(f"{label}: not a valid {fmt.upper()} file "
                         f"({' '.join(str(exc).split())[:120]})") from None
    if fmt == "gltf":
        return text
    length, chunk_length, end = layout
    text += b" " * (-len(text) % _GLB_ALIGN)
    # the total length moves with the JSON chunk, so the binary chunks after it are
    # read exactly as in the original file
    total = min(_UINT32_MAX, max(0, length - chunk_length + len(text)))
    return b"".join([_GLB_HEADER.pack(_GLB_MAGIC, _GLB_VERSION, total),
                     _GLB_CHUNK.pack(len(text), _GLB_JSON), text, memoryview(data)[end:]])


def _mesh_geometries(library: trimesh.Scene, count: int) -> list[list[str]]:
    """Geometry names of each glTF mesh in :func:`_mesh_library`'s scene, in primitive order."""
    order = {g: k for k, g in enumerate(library.geometry)}
    parents = library.graph.transforms.parents
    data = library.graph.transforms.node_data
    geometries: list[list[str]] = [[] for _ in range(count)]
    for node in library.graph.nodes_geometry:
        owner = node if node.isdigit() else parents[node]  # a mesh, or one of its primitives
        geometries[int(owner)].append(data[node]["geometry"])
    return [sorted(g, key=order.__getitem__) for g in geometries]


def _parse_gltf_library(data: bytes, fmt: str, path: Path, label: str) -> trimesh.Scene:
    """trimesh's parse of the geometry of a glTF/GLB file (see :func:`_mesh_library`)."""
    resolver = _FolderResolver(path, label)
    token = _loading.set(True)
    try:
        try:  # only trimesh's parser is wrapped: a failure in our code below is a bug
            with np.errstate(all="ignore"):
                scene = trimesh.load_scene(file_obj=io.BytesIO(data), file_type=fmt,
                                           resolver=resolver, process=False)
        except InputError:
            raise
        except _UriOutsideFolder as exc:
            raise InputError(f"{label}: buffer URI {_quote(exc.uri)} points outside the folder "
                             f"of the file ({path.resolve().parent}); glTF URIs must stay "
                             "inside that folder (not read)") from None
        except MemoryError:
            raise InputError(f"{label}: not enough memory to read this file") from None
        except FileNotFoundError as exc:
            missing = exc.filename or " ".join(str(exc).split())[:200]
            raise InputError(f"{label}: a file it references is missing ({missing})") from None
        except Exception as exc:  # noqa: BLE001 - trimesh raises many types on bad files
            detail = " ".join(f"{type(exc).__name__}: {exc}".split())[:200]
            raise InputError(f"{label}: not a valid {fmt.upper()} file ({detail})") from None
    finally:
        _loading.reset(token)
    for uri in resolver.refused:  # images: trimesh skips a texture it cannot read
        _log.warning("%s: image URI %s points outside the folder of the file (%s); glTF URIs "
                     "must stay inside that folder: not read, the texture is skipped",
                     label, _quote(uri), path.resolve().parent)
    return scene


# ------------------------------------------------------- glTF: the node hierarchy
@dataclass(frozen=True)
class _Hierarchy:
    """The checked node hierarchy of the default scene of a glTF file."""

    names: list[str]          # (N,) node names as trimesh made them (unique)
    order: list[int]          # reachable nodes, each parent before its children
    parent: list[int]         # (N,) parent node of each node, -1 for a root
    depth: dict[int, int]     # level of each reachable node, roots 1


def _node_label(nodes: list, i: int) -> str:
    """``node 3 ('wheel')`` for messages; the name as written in the file."""
    name = nodes[i].get("name") if isinstance(nodes[i], dict) else None
    return f"node {i} ({_quote(name)})" if isinstance(name, str) else f"node {i} (no name)"


def _index_list(value, size: int, what: str, label: str) -> list[int]:
    """A JSON list of indices into an array of ``size`` items, checked."""
    if not isinstance(value, list):
        raise InputError(f"{label}: {what} must be a list of indices, got "
                         f"{type(value).__name__}")
    for v in value:
        if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < size:
            raise InputError(f"{label}: {what} lists {_quote(v)}, not an index below {size}")
    return value


def _node_hierarchy(header: dict, label: str) -> _Hierarchy:
    """Check the node hierarchy of a glTF file and order the nodes of its default scene.

    glTF 2.0, sec. 3.5.1-3.5.2: "The node hierarchy MUST be a set of disjoint
    strict trees" (no cycles, at most one parent per node) and the nodes a
    scene lists MUST be root nodes. All nodes are checked, not only the
    default scene's; an index listed twice among one node's children or one
    scene's roots counts once (as trimesh read it).
    """
    nodes = header.get("nodes", [])
    if not isinstance(nodes, list):
        raise InputError(f"{label}: 'nodes' must be a list, got {type(nodes).__name__}")
    n = len(nodes)
    for i, node in enumerate(nodes):
        if not isinstance(node, dict):
            raise InputError(f"{label}: node {i} must be a JSON object, got "
                             f"{type(node).__name__}")
        if "name" in node and not isinstance(node["name"], str):
            raise InputError(f"{label}: node {i}: 'name' must be a string, got "
                             f"{type(node['name']).__name__}")
    # names exactly as trimesh's glTF reader made them (unique, 'world' renamed)
    name_index: dict[str, int] = {}
    counts: dict = {}
    for i, node in enumerate(nodes):
        name_index[trimesh.util.unique_name(node.get("name", str(i)), name_index,
                                            counts=counts)] = i
    names = [""] * n
    for name, i in name_index.items():
        names[i] = name
    base = trimesh.scene.transforms.DEFAULT_BASE_FRAME
    if base in name_index:
        names[name_index[base]] = trimesh.util.unique_name(base, set(names))

    children: list[list[int]] = []
    for i, node in enumerate(nodes):
        kids = _index_list(node.get("children", []), n, f"{_node_label(nodes, i)} 'children'",
                           label)
        children.append(list(dict.fromkeys(kids)))

    # no cycles: iterative depth-first search over the children lists; a child
    # still on the search path closes a cycle (colour 1: on the path, 2: done)
    colour = [0] * n
    for start in range(n):
        if colour[start]:
            continue
        colour[start] = 1
        path = [start]
        cursor = [0]
        while path:
            v, k = path[-1], cursor[-1]
            if k == len(children[v]):
                colour[v] = 2
                path.pop()
                cursor.pop()
                continue
            cursor[-1] = k + 1
            c = children[v][k]
            if colour[c] == 1:
                loop = path[path.index(c):]
                shown = " -> ".join(str(w) for w in loop[:_CYCLE_SHOWN])
                shown += " -> ..." if len(loop) > _CYCLE_SHOWN else f" -> {c}"
                raise InputError(f"{label}: {_node_label(nodes, c)} is its own descendant: "
                                 f"the node hierarchy has a cycle ({shown}), and glTF 2.0 "
                                 "requires disjoint strict trees")
            if colour[c] == 0:
                colour[c] = 1
                path.append(c)
                cursor.append(0)

    # at most one parent per node
    parent = [-1] * n
    for i in range(n):
        for c in children[i]:
            if parent[c] != -1:
                raise InputError(f"{label}: {_node_label(nodes, c)} has two parents, "
                                 f"{_node_label(nodes, parent[c])} and {_node_label(nodes, i)}; "
                                 "glTF 2.0 requires disjoint strict trees (each node has at "
                                 "most one parent)")
            parent[c] = i

    # the default scene's roots
    scenes = header.get("scenes", [])
    if not isinstance(scenes, list):
        raise InputError(f"{label}: 'scenes' must be a list, got {type(scenes).__name__}")
    roots: list[int] = []
    if scenes:
        index = header.get("scene", 0)
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(scenes):
            raise InputError(f"{label}: 'scene' is {_quote(index)}, not an index below "
                             f"{len(scenes)} (the number of scenes)")
        scene = scenes[index]
        if not isinstance(scene, dict):
            raise InputError(f"{label}: scene {index} must be a JSON object, got "
                             f"{type(scene).__name__}")
        roots = list(dict.fromkeys(_index_list(scene.get("nodes", []), n,
                                               f"scene {index} 'nodes'", label)))
        for r in roots:
            if parent[r] != -1:
                raise InputError(f"{label}: {_node_label(nodes, r)} is a root of scene {index} "
                                 f"and a child of {_node_label(nodes, parent[r])}; glTF 2.0 "
                                 "requires a scene's nodes to be root nodes")

    # depth-first order from the roots, iterative: each node once (a forest)
    order: list[int] = []
    depth: dict[int, int] = {}
    stack = [(r, 1) for r in reversed(roots)]
    while stack:
        v, level = stack.pop()
        order.append(v)
        depth[v] = level
        stack.extend((c, level + 1) for c in reversed(children[v]))
    if depth and max(depth.values()) > _MAX_NODE_DEPTH:
        deepest = max(depth, key=depth.__getitem__)
        raise InputError(f"{label}: the node hierarchy is {depth[deepest]:,} levels deep (at "
                         f"{_node_label(nodes, deepest)}), deeper than the {_MAX_NODE_DEPTH:,} "
                         "levels viscore reads")
    return _Hierarchy(names=names, order=order, parent=parent, depth=depth)


#: glTF node transform properties and their number of components (sec. 3.5.3),
#: and the JSON number types (``bool`` is an ``int`` subclass, not a number here).
_TRANSFORM_SIZES = {"matrix": 16, "translation": 3, "rotation": 4, "scale": 3}
_NUMBER_TYPES = {int, float}


def _local_matrix(node: dict, label: str, where: str) -> np.ndarray:
    """``(4, 4) float64`` local transform of a glTF node, computed as trimesh 5.2 computes it.

    ``matrix`` (column-major) times T times R times S, each product a
    ``np.dot`` in this order, so the bits match trimesh's glTF reader.
    """
    for key, size in _TRANSFORM_SIZES.items():
        if key in node:
            value = node[key]
            if (not isinstance(value, list) or len(value) != size
                    or not set(map(type, value)) <= _NUMBER_TYPES):
                raise InputError(f"{label}: {where}: {key!r} must be a list of {size} numbers, "
                                 f"got {_quote(value)}")
    try:
        if "matrix" in node:
            matrix = np.array(node["matrix"], dtype=np.float64).reshape((4, 4)).T
        else:
            matrix = _EYE
        if "translation" in node:
            matrix = np.dot(matrix, trimesh.transformations.translation_matrix(
                node["translation"]))
        if "rotation" in node:
            quat = np.reshape(node["rotation"], 4)[[3, 0, 1, 2]]  # glTF XYZW -> WXYZ
            matrix = np.dot(matrix, trimesh.transformations.quaternion_matrix(quat))
        if "scale" in node:
            matrix = np.dot(matrix, np.diag(np.concatenate((node["scale"], [1.0]))))
    except OverflowError:  # an integer beyond float64 in the JSON
        raise InputError(f"{label}: {where} has a transform value beyond float64's "
                         "range") from None
    return matrix


def _repair_rigid(mats: np.ndarray) -> np.ndarray:
    """trimesh's ``fix_rigid`` on ``(n, 4, 4)`` transforms: nearly rigid ones re-orthonormalised.

    See ``_RIGID_REPAIR_LOW``; the repair itself is trimesh's, operation for operation.
    """
    lin = mats[:, :3, :3]
    with np.errstate(all="ignore"):  # non-finite transforms: refused afterwards
        check = np.abs(lin @ lin.transpose(0, 2, 1) - _EYE[:3, :3]).max(axis=(1, 2))
    for i in np.flatnonzero((check > _RIGID_REPAIR_LOW) & (check < _RIGID_REPAIR_HIGH)):
        u, _, v = np.linalg.svd(mats[i, :3, :3])
        mats[i, :3, :3] = np.dot(u, v)
        mats[i, 3, :3] = 0.0
        mats[i, 3, 3] = 1.0
    return mats


def _gltf_objects(header: dict, tree: _Hierarchy, library: trimesh.Scene, label: str
                  ) -> tuple[list[str], list[str], np.ndarray]:
    """Object names, geometry names and ``(n, 4, 4)`` world transforms, ordered by name.

    One pass over the nodes, parents first: a node's world transform is its
    parent's times its local one. As trimesh's scene graph did, a node at level
    1 keeps its local transform as is, and below it the local transforms within
    ``_NEAR_IDENTITY`` of the identity are left out of the product.
    """
    nodes = header.get("nodes", [])
    meshes = header.get("meshes", [])
    count = len(meshes) if isinstance(meshes, list) else 0
    geometries = _mesh_geometries(library, count)
    taken = set(tree.names)
    product: dict[int, np.ndarray | None] = {}  # world transform without near-identities
    hidden: dict[int, str | None] = {-1: None}  # why a node is not drawn (inherited)
    objects = []
    with np.errstate(all="ignore"):  # non-finite or huge transforms: refused afterwards
        for v in tree.order:
            node = nodes[v]
            local = _local_matrix(node, label, _node_label(nodes, v))
            above = product.get(tree.parent[v])
            # NaN compares False: a non-finite transform is kept, then refused
            if not np.abs(local - _EYE).max() <= _NEAR_IDENTITY:
                above = local if above is None else np.dot(above, local)
            product[v] = above
            hidden[v] = hidden[tree.parent[v]] or hidden_reason(node)
            if "mesh" not in node:
                continue
            mesh = node["mesh"]
            if isinstance(mesh, bool) or not isinstance(mesh, int) or not 0 <= mesh < count:
                raise InputError(f"{label}: {_node_label(nodes, v)} refers to mesh "
                                 f"{_quote(mesh)}, but the file has {count} meshes")
            below = _EYE if above is None else above
            geoms = geometries[mesh]
            if len(geoms) == 1:
                world = local if tree.depth[v] == 1 else below
                objects.append((tree.names[v], geoms[0], world, hidden[v]))
                continue
            for k, geom in enumerate(geoms):  # one object per primitive
                name = trimesh.util.unique_name(f"{tree.names[v]}_{k}", taken)
                taken.add(name)
                objects.append((name, geom, below, hidden[v]))
    objects = [o for o in sorted(objects, key=lambda o: o[0])
               if isinstance(g := library.geometry.get(o[1]), trimesh.Trimesh) and len(g.faces)]
    if not objects:
        raise InputError(f"{label}: {_describe_without_triangles(library)}")
    drawn = [o for o in objects if o[3] is None]
    if not drawn:
        _log.warning("%s: every mesh node is marked as not drawn (%s); reading them all",
                     label, _hidden_summary(objects))
        drawn = objects
    elif len(drawn) < len(objects):
        left = len(objects) - len(drawn)
        _log.warning("%s: left out %s mesh node%s marked as not drawn: %s", label,
                     f"{left:,}", "" if left == 1 else "s",
                     _hidden_summary([o for o in objects if o[3] is not None]))
    names = [o[0] for o in drawn]
    geoms = [o[1] for o in drawn]
    mats = np.array([o[2] for o in drawn], dtype=np.float64).reshape(-1, 4, 4)
    return names, geoms, _repair_rigid(mats)


def _hidden_summary(objects: list, shown: int = 4) -> str:
    """``'__collision__' (a collision name), ...`` for the first ``shown`` hidden objects."""
    parts = [f"{_quote(name)} ({why})" for name, _, _, why in objects[:shown]]
    if len(objects) > shown:
        parts.append(f"and {len(objects) - shown:,} more")
    return ", ".join(parts)


def _load_gltf(path: Path, label: str) -> SceneObjects:
    """Objects of a glTF/GLB file: hierarchy checked and composed here, geometry by trimesh."""
    fmt = _suffix(path.name)
    data = _read_regular_file(path, label)
    header, layout = _gltf_json(data, fmt, label)
    _refuse_compressed(header, fmt, label)
    if fmt == "glb":  # meshopt-compressed views and normalized positions made plain
        plain, _ = decode_meshopt_glb(data, header, layout[2], label)
        if plain is not data:
            data = plain
            header, layout = _gltf_json(data, fmt, label)
    tree = _node_hierarchy(header, label)
    library = _mesh_library(data, header, fmt, layout, label)
    del data
    scene = _parse_gltf_library(library, fmt, path, label)
    names, geoms, mats = _gltf_objects(header, tree, scene, label)
    return _scene_objects(names, geoms, mats, scene.geometry, label, _GLTF_UP)


def load_scene_objects(source: str | os.PathLike | trimesh.Scene | trimesh.Trimesh
                       ) -> SceneObjects:
    """Load a scene as objects: every mesh node is an object (instancing honoured).

    Parameters
    ----------
    source : str, path, trimesh.Scene or trimesh.Trimesh
        A glTF (``.gltf`` with its buffers beside it) or GLB file; a built-in
        culling scene name (:func:`culling_scene_names`: ``city``,
        ``city-dense``); a ``trimesh.Scene``; or any other mesh file or
        built-in scene :func:`viscore.load_mesh` reads, or a mesh, as one
        object.

    Returns
    -------
    SceneObjects
        One object per node carrying a triangle mesh, ordered by node name;
        each distinct geometry stored once: instances of one glTF mesh, and
        meshes equal vertex for vertex and face for face in their local
        frames (copies exported without instancing), share one entry of
        ``meshes``, named after the first. A glTF mesh with several
        primitives gives one object per primitive, named ``<node>_<k>``
        (``k`` the primitive's position; made unique if taken). Nodes the
        file marks as not drawn (:func:`viscore.level.hidden_nodes.hidden_reason`:
        ``KHR_node_visibility``, ``extras.visible`` false, Godot's
        ``-colonly``/``-navmesh``/``-noimp``/``-occonly`` hints, Unreal's
        ``UCX_`` prefixes, collision names) and their subtrees are left out,
        with a logged warning naming them; when every mesh node is so
        marked, all are read.

    Raises
    ------
    InputError
        One line naming the file: a path that does not exist (and is no
        built-in scene), is not a regular file, is empty, not a valid file of
        its format, holds no triangles; a geometry that
        :func:`viscore.validate_mesh` refuses; a node transform with NaN or
        infinite values or a zero scale; world coordinates beyond what
        :func:`viscore.validate_mesh` accepts. For glTF/GLB also, naming the
        node (index and name): a cycle in the node hierarchy; a node with
        two parents; a scene root that is another node's child; a hierarchy
        deeper than 1,000 levels (``_MAX_NODE_DEPTH``); a child, scene or
        mesh index out of range; a malformed transform. And a buffer URI
        that resolves outside the folder of the file (named with the URI;
        never read).

    Notes
    -----
    glTF world transforms are composed in one iterative pass over the node
    list, parents first (world = parent world x local, local = matrix x T x
    R x S as trimesh computes it), linear in the number of nodes. On a valid
    file they equal those trimesh's scene graph gave before, bit for bit,
    down to two levels of non-identity transforms; deeper, trimesh
    multiplied the path right to left and the results may differ in the
    last bits (~1e-16 relative). Inherited from trimesh and kept for that
    equality: below the root, a local transform within 1e-8 of the identity
    is ignored, and a world transform within 1e-5 of rigid is
    re-orthonormalised (a scale within ~5e-6 of 1 reads as 1). The glTF
    rule that nodes form disjoint strict trees is enforced rather than
    loading one path of a node with two parents (or every path): such a
    file is invalid, and its instances would depend on the reader. An
    image URI outside the folder is not read either: the texture is
    skipped with a logged warning (geometry does not need it). Cameras,
    skins and animations are ignored; a camera node is a node like any
    other.

    Examples
    --------
    >>> import trimesh
    >>> scene = trimesh.Scene()
    >>> _ = scene.add_geometry(trimesh.creation.box(), geom_name="box", node_name="a")
    >>> scene.graph.update(frame_to="b", geometry="box",
    ...                    matrix=trimesh.transformations.translation_matrix((3, 0, 0)))
    >>> objects = load_scene_objects(scene)
    >>> len(objects), len(objects.meshes), int(objects.triangles.sum())
    (2, 1, 24)
    """
    if isinstance(source, trimesh.Scene):
        return _from_trimesh_scene(source, "scene", _GLTF_UP)
    if isinstance(source, trimesh.Trimesh):
        mesh = validate_mesh(source, name=str(source.metadata.get("name", "mesh")))
        return _single(mesh, str(source.metadata.get("name", "mesh")))
    try:
        path = Path(os.fspath(source))
    except TypeError:
        raise InputError(f"scene: expected a file path, a scene name or a trimesh.Scene, "
                         f"got {type(source).__name__}") from None
    label = str(source)
    if not os.path.lexists(path) and label in _CULLING_SCENES:
        path = culling_scene_path(label)
    fmt = _suffix(path.name)
    if fmt in ("glb", "gltf"):
        if not os.path.lexists(path):
            try:
                os.stat(path)
            except OSError as exc:
                raise _refuse_path(path, label, exc) from None
        return _load_gltf(path, label)
    try:
        mesh = load_mesh(source)
    except InputError as exc:
        if not os.path.lexists(path) and "not a built-in scene" in str(exc):
            raise InputError(f"{label}: no such file, and not a built-in scene (culling: "
                             f"{', '.join(_CULLING_SCENES)})") from None
        raise
    return _single(mesh, label)


def _single(mesh: trimesh.Trimesh, label: str) -> SceneObjects:
    scene = trimesh.Scene()
    scene.add_geometry(mesh, geom_name=Path(label).stem or "mesh",
                       node_name=Path(label).stem or "mesh")
    objects = _from_trimesh_scene(scene, label, _VISCORE_UP)
    return objects
