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

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt
import trimesh

from .._validate import InputError, check_memory
from .glb_targets import with_buffer_view_targets
from .gltf_scene import (
    _mesh_geometries,
    _mesh_library,
    _node_hierarchy,
    _node_label,
    _parse_gltf_library,
    _quote,
    instanced_triangles,
    read_gltf,
    world_transforms,
)
from .godot_binary import _BYTES_PER_PLACED_TRIANGLE, _checked_geometry, _instances_mesh
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


def _load_gltf(path: Path, label: str) -> trimesh.Trimesh:
    """The ``-occ``/``-occonly`` nodes of a glTF/GLB file (every mesh node when none is
    marked) in world space, read by the glTF reader the level loader uses.

    The file, its node hierarchy (depth, node count, cycles, transforms) and its
    buffers are checked by :mod:`viscore.exchange.gltf_scene` before any geometry is
    parsed; the instanced triangles are counted before any is placed.
    """
    data, header, layout, fmt = read_gltf(path, label)
    tree = _node_hierarchy(header, label)
    triangles = instanced_triangles(header, tree)
    check_memory(triangles * _BYTES_PER_PLACED_TRIANGLE,
                 f"{label} ({triangles:,} triangles with instances placed)")
    library = _mesh_library(data, header, fmt, layout, label)
    del data
    scene = _parse_gltf_library(library, fmt, path, label, header)
    meshes = header.get("meshes", [])
    count = len(meshes) if isinstance(meshes, list) else 0
    geometries = _mesh_geometries(scene, count)
    world = world_transforms(header, tree, label)
    nodes = header.get("nodes", [])
    local: dict[int, tuple[np.ndarray, np.ndarray] | None] = {}
    items = []
    for v in tree.order:
        mesh = nodes[v].get("mesh")
        if mesh is None:
            continue
        if isinstance(mesh, bool) or not isinstance(mesh, int) or not 0 <= mesh < count:
            raise InputError(f"{label}: {_node_label(nodes, v)} refers to mesh "
                             f"{_quote(mesh)}, but the file has {count} meshes")
        name = tree.names[v]
        if mesh not in local:  # one glTF mesh: its primitives' triangles, once
            parts = [scene.geometry[g] for g in geometries[mesh]]
            parts = [g for g in parts if isinstance(g, trimesh.Trimesh) and len(g.faces)]
            if parts:
                vertices, offset, faces = [], 0, []
                for g in parts:
                    gv, gf = _checked_geometry(g.vertices, g.faces, label, f"node {name!r}")
                    vertices.append(gv)
                    faces.append(gf + offset)
                    offset += len(gv)
                local[mesh] = (np.concatenate(vertices), np.concatenate(faces))
            else:
                local[mesh] = None
        if local[mesh] is None:
            continue
        if not np.isfinite(world[v]).all():
            raise InputError(f"{label}: node {name!r} has a NaN or infinite transform")
        items.append((name, mesh, world[v]))
    if not items:
        raise InputError(f"{label}: no node carries a triangle mesh")
    items.sort(key=lambda item: item[0])
    marked = [it for it in items if _occluder_hint(it[0])]
    return _instances_mesh(local, marked or items, label, f"{fmt}-occonly" if marked else fmt)  # type: ignore[arg-type]


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
    return with_buffer_view_targets(trimesh.exchange.gltf.export_glb(scene,
                                                                     include_normals=False))
