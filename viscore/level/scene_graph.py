"""Scenes as objects: every mesh node of a glTF/GLB file is one object and one occludee.

The culled unit is a scene-graph node tested through its bounding volume
(Papaioannou et al. 2006 [1]_, sec. 4); nodes are composed as glTF 2.0 [2]_, sec. 3, says.

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
import logging
import os
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import numpy.typing as npt
import trimesh

from .._validate import InputError, check_memory
from ..exchange.gltf_scene import (  # noqa: F401 - the names these had here, kept
    _CYCLE_SHOWN,
    _GLB_HEADER,
    _NAME_CHARS,
    _gltf_json,
    _Hierarchy,
    _index_list,
    _local_matrix,
    _mesh_geometries,
    _mesh_library,
    _node_hierarchy,
    _node_label,
    _parse_gltf_library,
    _quote,
    _refuse_compressed,
    read_gltf,
)
from ..exchange.gltf_scene import MAX_NODE_DEPTH as _MAX_NODE_DEPTH  # noqa: F401
from ..exchange.mesh_io import (
    _BYTES_PER_TRIANGLE,
    _describe_without_triangles,
    _refuse_path,
    _suffix,
    load_mesh,
    validate_mesh,
)
from ..exchange.mesh_validation import _MAX_COORDINATE, _MAX_OFFSET_RATIO
from ..ray.cameras import horizontal_basis
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
#: The largest object around the others is a landscape (:meth:`SceneObjects.built_bounds`)
#: only when it holds under this share of their triangles: a coarse terrain around a
#: detailed town (2,345 of 77,093 in a game's lakeside towns), not a map's main mesh
#: around a few props (96-98% in exported shooter maps).
LANDSCAPE_SHARE = 0.25
#: Most objects from whose tops :meth:`SceneObjects.built_bounds` casts a ray up to tell
#: a landscape around them from a roof over them.
ROOF_SAMPLES = 256
#: Objects whose boxes, seen from above, come within this many median object diagonals
#: of each other are of one district (:meth:`SceneObjects.built_bounds`): the buildings of
#: a town across its streets and squares, not two towns kilometres apart.
DISTRICT_GAP = 5.0
#: The district of most objects is the built part only when it holds at least this share
#: of the built objects' triangles (one of two towns: 37,415 of 77,093), not one clump
#: of a scatter of props across an open map.
DISTRICT_SHARE = 0.3
#: Most cells along a side of the grid the districts are marked on.
DISTRICT_CELLS = 1024
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

        Three things around a level do not set its extent, each only when it makes
        the box's diagonal more than :data:`LEVEL_SPAN` times that of what it
        surrounds:

        - the *outer* objects: flat ones (an outer ground plane, a sea around a
          town) and a sky (:meth:`sky`);
        - a *landscape*: the largest other object, when its box holds the centre
          of the others' box, it holds under :data:`LANDSCAPE_SHARE` of their
          triangles and it is not over most of them (a coarse terrain of hills
          around a detailed town, not flat because of its mountains; not a map's
          main mesh around its props, nor a hall's shell over its machines);
        - the *outskirts*: objects whose boxes, seen from above, come within
          :data:`DISTRICT_GAP` median box diagonals of each other are of one
          district, and the district of most objects is the built part when the
          others lie far from it and it holds :data:`DISTRICT_SHARE` of their
          triangles (two towns kilometres apart on a lake's shores, islands
          between them).

        Returns :attr:`bounds` and False when none of these applies.
        """
        axis = self.up if up is None else up
        whole = self.bounds
        outer = self.flat(axis) | self.sky()
        if outer.all():
            return whole, False

        def box(mask: np.ndarray) -> np.ndarray:
            return np.stack([self.lower[mask].min(axis=0), self.upper[mask].max(axis=0)])

        def span(b: np.ndarray) -> float:
            return float(np.linalg.norm(b[1] - b[0]))

        inner = ~outer
        # a landscape: the largest built object, around the others' box from far wider
        order = np.flatnonzero(inner)
        if len(order) > 1:
            big = order[int(np.argmax(np.linalg.norm(self.upper[order] - self.lower[order],
                                                     axis=1)))]
            rest = inner.copy()
            rest[big] = False
            centre = box(rest).mean(axis=0)
            around = bool(np.all((self.lower[big] <= centre) & (centre <= self.upper[big])))
            coarse = self.triangles[big] < LANDSCAPE_SHARE * self.triangles[inner].sum()
            if around and coarse and span(np.stack([self.lower[big], self.upper[big]])) \
                    > LEVEL_SPAN * span(box(rest)) and not self._roofs(big, rest, axis):
                inner = rest
        # the outskirts: the largest district, when the built part is far wider
        district = self._districts(axis, inner)
        labels = district[inner]
        if len(labels):
            main = district == int(np.bincount(labels).argmax())
            share = self.triangles[main].sum() / max(1, self.triangles[inner].sum())
            if share >= DISTRICT_SHARE and span(box(inner)) > LEVEL_SPAN * span(box(main)):
                inner = main
        built = box(inner)
        if span(built) > 0 and span(whole) > LEVEL_SPAN * span(built):
            return built, True
        return whole, False

    def _roofs(self, big: int, under: np.ndarray, up: npt.ArrayLike) -> bool:
        """Whether object ``big`` is over most of the objects ``under``: a ray cast up from
        the top of each one's box (at most :data:`ROOF_SAMPLES`, evenly taken) first hits
        ``big`` for at least half of them (a hall's shell over its machines, not the
        hills around a town)."""
        u = np.asarray(up, dtype=np.float64)
        u = u / np.linalg.norm(u)
        which = np.flatnonzero(under)
        which = which[np.linspace(0, len(which) - 1, min(ROOF_SAMPLES, len(which)))
                      .astype(np.int64)]
        centre = (self.lower[which] + self.upper[which]) / 2
        top = np.where(u > 0, self.upper[which], self.lower[which]) @ u
        origins = centre + np.outer(top - centre @ u, u)
        scene, owner = self.combined
        _, tri = scene.first_hit(origins + 1e-6 * max(1.0, float(np.abs(origins).max())) * u,
                                 np.broadcast_to(u, origins.shape))
        hit = np.where(tri >= 0, owner[np.maximum(tri, 0)], -1)
        return bool(np.mean(hit == big) >= 0.5)

    def _districts(self, up: npt.ArrayLike, among: np.ndarray) -> np.ndarray:
        """``(n,) int64``: a district number per object of ``among`` (-1 for the others).

        The boxes, seen from above along ``up`` and widened by half of
        :data:`DISTRICT_GAP` times their median diagonal on each side, are marked on
        a grid of cells that wide (at most :data:`DISTRICT_CELLS` along a side,
        wider cells beyond); marked cells that touch form a district, and each
        object belongs to the district of its box's centre.
        """
        from scipy import ndimage

        u = np.asarray(up, dtype=np.float64)
        u = u / np.linalg.norm(u)
        district = np.full(len(self), -1, dtype=np.int64)
        keep = np.flatnonzero(among)
        if not len(keep):
            return district
        e1, e2 = horizontal_basis(u)
        corners = np.stack([np.where(np.array([x, y, z]), self.upper[keep], self.lower[keep])
                            for x in (0, 1) for y in (0, 1) for z in (0, 1)], axis=1)
        plane = np.stack([corners @ e1, corners @ e2], axis=2)  # (k, 8, 2)
        lo, hi = plane.min(axis=1), plane.max(axis=1)
        gap = DISTRICT_GAP * float(np.median(np.linalg.norm(self.upper[keep]
                                                            - self.lower[keep], axis=1)))
        origin = lo.min(axis=0) - gap
        extent = float((hi.max(axis=0) + gap - origin).max())
        cell = max(gap, extent / DISTRICT_CELLS, 1e-300)
        shape = np.minimum(np.ceil((hi.max(axis=0) + gap - origin) / cell).astype(np.int64)
                           + 1, DISTRICT_CELLS + 1)
        first = np.clip(((lo - gap / 2 - origin) / cell).astype(np.int64), 0, shape - 1)
        last = np.clip(((hi + gap / 2 - origin) / cell).astype(np.int64), 0, shape - 1)
        # each box's cells marked by a 2-D difference array: +1 at its first corner,
        # -1 past its last, summed along both axes
        marks = np.zeros(shape + 1, dtype=np.int64)
        np.add.at(marks, (first[:, 0], first[:, 1]), 1)
        np.add.at(marks, (last[:, 0] + 1, first[:, 1]), -1)
        np.add.at(marks, (first[:, 0], last[:, 1] + 1), -1)
        np.add.at(marks, (last[:, 0] + 1, last[:, 1] + 1), 1)
        covered = marks.cumsum(axis=0).cumsum(axis=1)[:-1, :-1] > 0
        labels, _ = ndimage.label(covered, structure=np.ones((3, 3)))
        centre = np.clip((((lo + hi) / 2 - origin) / cell).astype(np.int64), 0, shape - 1)
        district[keep] = labels[centre[:, 0], centre[:, 1]] - 1
        return district

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


def _check_affine(names: list[str], mats: np.ndarray, label: str) -> None:
    """Refuse a world transform whose last row is not ``0, 0, 0, 1`` (a projective map:
    glTF nodes and Godot transforms are affine), naming the node, when the level is read."""
    bad = ~(mats[:, 3] == _EYE[3]).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        row = ", ".join(f"{x:g}" for x in mats[i, 3])
        raise InputError(f"{label}: node {names[i]!r} has a transform that is not affine (its "
                         f"last row is {row}, not 0, 0, 0, 1)")


def _flattening(names: list[str], lin: np.ndarray, det: np.ndarray, scale: np.ndarray, i: int,
                label: str) -> InputError:
    """The refusal of node ``i``'s transform, whose volume scale is under
    ``_SINGULAR_RELATIVE`` x its largest entry cubed: a zero scale when a column is
    (near) zero, otherwise a stretch so uneven (a shear) that it flattens the mesh."""
    columns = np.linalg.norm(lin[i], axis=0)
    if det[i] == 0 or columns.min() <= _SINGULAR_RELATIVE * columns.max():
        why = "a singular transform (a zero scale flattens its mesh)"
    else:
        why = (f"a transform that flattens its mesh: its volume scale {det[i]:.3g} is under "
               f"{_SINGULAR_RELATIVE:g} x its largest entry {scale[i]:.3g} cubed (a shear or "
               "an uneven scale this extreme)")
    return InputError(f"{label}: node {names[i]!r} has {why}")


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
    _check_affine(names, mats, label)
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
        raise _flattening(names, lin, det, scale, int(np.flatnonzero(singular)[0]), label)
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
    data, header, layout, fmt = read_gltf(path, label)
    tree = _node_hierarchy(header, label)
    library = _mesh_library(data, header, fmt, layout, label)
    del data
    scene = _parse_gltf_library(library, fmt, path, label, header)
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
