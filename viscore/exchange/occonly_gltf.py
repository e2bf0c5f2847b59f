"""glTF/GLB occluders in and out: nodes named with Godot's ``-occ``/``-occonly`` suffix.

Godot's importer turns nodes named ``-occ``/``-occonly`` into occluders [2]_;
Godot [1]_ and glTF share their axes, so no conversion is needed.

References
----------
.. [1] Godot Engine contributors. "Godot Engine", version 4,
   https://godotengine.org (source: https://github.com/godotengine/godot).
.. [2] Godot Engine documentation, "Node type customization using name
   suffixes",
   https://docs.godotengine.org/en/stable/tutorials/assets_pipeline/importing_3d_scenes/node_type_customization.html
"""

from __future__ import annotations

import io
import os
import re
import stat
from collections.abc import Mapping, Sequence
from pathlib import Path
from urllib.parse import unquote

import numpy as np
import numpy.typing as npt
import trimesh

from .._validate import InputError
from .godot_binary import _checked_geometry, _occluder_mesh, _placed, _read_file
from .godot_text import OccluderInstance, _checked_scene, _unique

__all__ = ["occonly_glb_bytes"]

# ----------------------------------------------------------------------------- glTF


def _occluder_hint(name: str) -> str | None:
    """Godot's import suffix of a node name: ``"occonly"``, ``"occ"`` or None.

    As Godot's ``_teststr``: trailing digits, spaces, ``_`` and ``.`` (added by
    Blender to duplicates) are ignored; ``$occ``, ``-occ`` and ``_occ`` count,
    case-insensitively.
    """
    what = name.rstrip("0123456789 _.\t").lower()
    for hint in ("occonly", "occ"):
        if f"${hint}" in what or what.endswith((f"-{hint}", f"_{hint}")):
            return hint
    return None


class _FolderResolver(trimesh.resolvers.FilePathResolver):
    """Resolve glTF URIs inside the file's folder only; refuse and record the rest."""

    def __init__(self, path: Path, label: str) -> None:
        super().__init__(str(path.resolve()))
        self.root = path.resolve().parent
        self.label = label
        self.refused: str | None = None

    def get(self, name: str) -> bytes:
        uri = unquote(str(name).strip())
        bad = ("://" in uri or uri.startswith(("file:", "/", "\\")) or Path(uri).is_absolute()
               or re.match(r"^[A-Za-z]:", uri) is not None)
        target = None if bad else (self.root / uri).resolve()
        if target is None or not target.is_relative_to(self.root):
            self.refused = (f"{self.label}: the URI {str(name)[:120]!r} points outside the "
                            "file's folder (refused, not read)")
            raise InputError(self.refused)
        try:
            st = os.stat(target)
        except OSError:
            self.refused = f"{self.label}: a file it references is missing ({str(name)[:120]!r})"
            raise InputError(self.refused) from None
        if not stat.S_ISREG(st.st_mode):
            self.refused = (f"{self.label}: the URI {str(name)[:120]!r} is not a regular "
                            "file (refused)")
            raise InputError(self.refused)
        return target.read_bytes()


def _object_node(node: str, parents: Mapping[str, str], carriers: set[str]) -> str:
    """The glTF node a trimesh graph node stands for.

    trimesh splits a mesh of several primitives into child nodes named
    ``<node>_<6 hex>`` under the glTF node; those count as their parent.
    """
    parent = parents.get(node)
    if (parent is not None and parent not in carriers
            and re.fullmatch(re.escape(parent) + r"_[0-9a-f]{6}", node)):
        return parent
    return node


def _load_gltf(path: Path, label: str) -> trimesh.Trimesh:
    fmt = path.suffix.lower().lstrip(".")
    data = _read_file(path, label)
    resolver = _FolderResolver(path, label)
    try:
        with np.errstate(all="ignore"):
            scene = trimesh.load_scene(file_obj=io.BytesIO(data), file_type=fmt,
                                       resolver=resolver, process=False)
    except InputError:
        raise
    except MemoryError:
        raise InputError(f"{label}: not enough memory to read this file") from None
    except Exception as exc:  # noqa: BLE001 - trimesh raises many types on bad files
        if resolver.refused:
            raise InputError(resolver.refused) from None
        detail = " ".join(f"{type(exc).__name__}: {exc}".split())[:200]
        raise InputError(f"{label}: not a valid {fmt.upper()} file ({detail})") from None
    if resolver.refused:  # trimesh may swallow a failed image; the refusal stands
        raise InputError(resolver.refused)
    carriers = set(scene.graph.nodes_geometry)
    parents = scene.graph.transforms.parents
    items = []
    for node in sorted(carriers):
        mat, gname = scene.graph[node]
        geom = scene.geometry.get(gname)
        if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
            continue
        items.append((_object_node(node, parents, carriers), np.asarray(mat, np.float64), geom))
    if not items:
        raise InputError(f"{label}: no node carries a triangle mesh")
    marked = [it for it in items if _occluder_hint(it[0])]
    parts_v, parts_f, names, counts = [], [], [], []
    offset = 0
    for name, mat, geom in marked or items:
        if not np.isfinite(mat).all():
            raise InputError(f"{label}: node {name!r} has a NaN or infinite transform")
        vertices, faces = _checked_geometry(geom.vertices, geom.faces, label, f"node {name!r}")
        parts_v.append(_placed(vertices, mat, label, name))
        parts_f.append(faces + offset)
        offset += len(vertices)
        names.append(name)
        counts.append(len(faces))
    return _occluder_mesh(np.concatenate(parts_v), np.concatenate(parts_f), label,
                          f"{fmt}-occonly" if marked else fmt, names, counts)


# ----------------------------------------------------------------------------- writing


def occonly_glb_bytes(instances: Sequence[OccluderInstance],
                      meshes: Mapping[str, tuple[npt.ArrayLike, npt.ArrayLike]]) -> bytes:
    """A GLB whose nodes carry Godot's ``-occonly`` suffix, one glTF mesh per distinct mesh.

    Parameters
    ----------
    instances : sequence of OccluderInstance
        The placed occluders; each becomes a node ``<name>-occonly`` with its
        transform (its name is kept when it already ends in ``-occonly``).
    meshes : mapping str -> (vertices, indices)
        Local-space mesh of each ``mesh_key``, as for :func:`tscn_text`.

    Returns
    -------
    glb : bytes
        A binary glTF 2.0 file: float32 positions, uint32 indices, one mesh per
        key used and one node per instance referencing it (instancing). On
        import Godot turns each node into an ``OccluderInstance3D`` that is
        not drawn; glTF and Godot are both +Y up, so coordinates are kept.

    Raises
    ------
    InputError
        As :func:`tscn_text`.

    Examples
    --------
    >>> quad = ([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [0, 1, 2, 0, 2, 3])
    >>> glb = occonly_glb_bytes([OccluderInstance("wall", "quad")], {"quad": quad})
    >>> glb[:4]
    b'glTF'
    """
    instances, used = _checked_scene(instances, meshes)
    names = []
    for inst in instances:
        hint = _occluder_hint(inst.name)
        names.append(inst.name if hint == "occonly" else f"{inst.name}-occonly")
    names = _unique(names)
    scene = trimesh.Scene()
    added: set[str] = set()
    for inst, name in zip(instances, names, strict=True):
        matrix = np.array(inst.transform, dtype=np.float64)
        if inst.mesh_key not in added:
            v32, idx = used[inst.mesh_key]
            mesh = trimesh.Trimesh(vertices=v32.astype(np.float64), faces=idx.reshape(-1, 3),
                                   process=False)
            scene.add_geometry(mesh, geom_name=inst.mesh_key, node_name=name, transform=matrix)
            added.add(inst.mesh_key)
        else:
            scene.graph.update(frame_to=name, frame_from=scene.graph.base_frame,
                               geometry=inst.mesh_key, matrix=matrix)
    return trimesh.exchange.gltf.export_glb(scene, include_normals=False)
