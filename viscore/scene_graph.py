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

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006 (Plzen), UNION Agency,
   ISBN 80-86943-03-8.
"""

from __future__ import annotations

import io
import logging
import os
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import trimesh

from ._validate import InputError, check_memory
from .mesh_io import (
    _BYTES_PER_TRIANGLE,
    _MAX_COORDINATE,
    _MAX_OFFSET_RATIO,
    _describe_without_triangles,
    _loading,
    _read_regular_file,
    _refuse_path,
    _suffix,
    load_mesh,
    validate_mesh,
)
from .scene import Scene

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
    from .builtin_scenes import _procedural_dir

    if name not in _CULLING_SCENES:
        raise InputError(f"{name}: not a built-in culling scene "
                         f"(built-in: {', '.join(_CULLING_SCENES)})")
    path = _procedural_dir() / _CULLING_SCENES[name][0]
    if not path.is_file():
        raise InputError(f"{name}: built-in scene file is missing at {path}; "
                         "run data/make_city.py or reinstall viscore")
    return path


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
        (validated by :func:`viscore.validate_mesh`).
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

    def __len__(self) -> int:
        return len(self.names)

    @property
    def bounds(self) -> np.ndarray:
        """``(2, 3) float64`` lower and upper corner of the whole scene, world units."""
        return np.stack([self.lower.min(axis=0), self.upper.max(axis=0)])

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
        vertices, faces, owner, base = [], [], [], 0
        for mesh_id, mesh in enumerate(self.meshes):
            idx = self.instances(mesh_id)
            if len(idx) == 0:
                continue
            v = np.asarray(mesh.vertices, dtype=np.float64)
            f = np.asarray(mesh.faces, dtype=np.int64)
            mats = self.transforms[idx]
            vk = np.einsum("kij,nj->kni", mats[:, :3, :3], v) + mats[:, None, :3, 3]
            vertices.append(vk.reshape(-1, 3))
            offsets = base + len(v) * np.arange(len(idx))
            faces.append((f[None] + offsets[:, None, None]).reshape(-1, 3))
            owner.append(np.repeat(idx, len(f)))
            base += len(idx) * len(v)
        mesh = trimesh.Trimesh(np.concatenate(vertices), np.concatenate(faces), process=False)
        triangle_object = np.concatenate(owner).astype(np.int64)
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
    mesh_names = list(dict.fromkeys(geoms))
    index = {g: k for k, g in enumerate(mesh_names)}
    meshes = tuple(validate_mesh(scene.geometry[g], name=f"{label}:{g}") for g in mesh_names)
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
    return SceneObjects(names=tuple(names), mesh_ids=mesh_ids, transforms=mats, meshes=meshes,
                        mesh_names=tuple(mesh_names), lower=lower, upper=upper,
                        triangles=triangles, up=up_vec, source=label)


def _parse_gltf(path: Path, label: str) -> trimesh.Scene:
    fmt = _suffix(path.name)
    data = _read_regular_file(path, label)
    if fmt == "gltf":
        import json

        try:
            json.loads(data.decode("utf-8-sig"))
        except (UnicodeDecodeError, ValueError) as exc:
            raise InputError(f"{label}: not a valid GLTF file (not JSON: "
                             f"{' '.join(str(exc).split())[:120]})") from None
    resolver = trimesh.resolvers.FilePathResolver(str(path.resolve()))
    token = _loading.set(True)
    try:
        try:  # only trimesh's parser is wrapped: a failure in our code below is a bug
            with np.errstate(all="ignore"):  # non-finite transforms: refused afterwards
                return trimesh.load_scene(file_obj=io.BytesIO(data), file_type=fmt,
                                          resolver=resolver, process=False)
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
        each distinct geometry stored once.

    Raises
    ------
    InputError
        One line naming the file: a path that does not exist (and is no
        built-in scene), is not a regular file, is empty, not a valid file of
        its format, holds no triangles; a geometry that
        :func:`viscore.validate_mesh` refuses; a node transform with NaN or
        infinite values or a zero scale; world coordinates beyond what
        :func:`viscore.validate_mesh` accepts.

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
        scene = _parse_gltf(path, label)
        return _from_trimesh_scene(scene, label, _GLTF_UP)
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
