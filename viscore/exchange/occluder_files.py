"""Engine occluder files in and out: Godot 4 occluders, ``-occonly`` glTF, any mesh.

The formats of the Godot 4 engine [1]_ (``ArrayOccluder3D`` [2]_ in
``OccluderInstance3D`` nodes [3]_, text scenes [4]_), each in a module of its own.

References
----------
.. [1] Godot Engine contributors. "Godot Engine", version 4,
   https://godotengine.org (source: https://github.com/godotengine/godot).
.. [2] Godot Engine documentation, class reference "ArrayOccluder3D",
   https://docs.godotengine.org/en/stable/classes/class_arrayoccluder3d.html
.. [3] Godot Engine documentation, class reference "OccluderInstance3D",
   https://docs.godotengine.org/en/stable/classes/class_occluderinstance3d.html
.. [4] Godot Engine documentation, "TSCN file format",
   https://docs.godotengine.org/en/stable/contributing/development/file_formats/tscn.html
   and the variant text writer ``core/variant/variant_parser.cpp``.
.. [5] Godot Engine source, ``core/io/resource_format_binary.cpp`` and
   ``core/io/resource_format_binary.h`` (``ResourceLoaderBinary``,
   ``ResourceFormatSaverBinaryInstance``; binary format version 6).
.. [6] Godot Engine documentation, "Node type customization using name
   suffixes",
   https://docs.godotengine.org/en/stable/tutorials/assets_pipeline/importing_3d_scenes/node_type_customization.html
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt
import trimesh

from .._validate import InputError
from .godot_binary import (  # noqa: F401 - BINARY_FORMATS kept at its old path
    BINARY_FORMATS,
    _load_occ,
    _load_occ_file,
    _occluder_mesh,
    _read_file,
)
from .godot_text import (  # noqa: F401 - TEXT_FORMATS kept at its old path
    TEXT_FORMATS,
    OccluderInstance,
    _checked_scene,
    _load_tres,
    _load_tscn,
    tres_text,
    tscn_text,
)
from .occonly_gltf import _load_gltf, occonly_glb_bytes

__all__ = ["OccluderInstance", "load_occluder", "tscn_text", "tres_text", "occonly_glb_bytes",
           "write_occluders"]

# ----------------------------------------------------------------------------- reading


def load_occluder(path: str | os.PathLike) -> trimesh.Trimesh:
    """Read an engine's occluder file as one world-space triangle soup.

    Parameters
    ----------
    path : str or path
        ``.tscn`` (Godot 4 text scene: every ``OccluderInstance3D`` node with
        an ``ArrayOccluder3D``, placed by its node path's transforms), ``.tres``
        (Godot 4 text ``ArrayOccluder3D`` resource), ``.occ`` or ``.res``
        (Godot 4 binary ``ArrayOccluder3D`` resource, as Godot's bake writes),
        ``.glb``/``.gltf`` (nodes with Godot's ``-occ``/``-occonly`` suffix,
        or every mesh node when none has it), or any other mesh file
        :func:`viscore.load_mesh` reads.

    Returns
    -------
    mesh : trimesh.Trimesh
        World-space vertices ``(n, 3) float64`` (world units of the file) and
        faces ``(m, 3) int64``, unprocessed (no vertex merging, no triangle
        dropped). ``mesh.metadata`` holds ``name`` (the path),
        ``source_format`` (``godot-tscn``, ``godot-tres``, ``godot-occ``,
        ``glb-occonly``, ``glb``, ...; ``mesh`` for other files) and, for
        scenes, ``object_names`` and ``object_triangles`` (node paths and
        their triangle counts, in the order of the faces).

    Raises
    ------
    InputError
        One line naming the file: missing, not a regular file, empty; not
        valid in its format (malformed text, a truncated binary, a count
        beyond the file's length, an unknown variant type); a resource that is
        not an ``ArrayOccluder3D``; a node referencing a sub-resource the
        file does not define; an external occluder or a glTF URI pointing
        outside the file's folder; NaN or infinite values; indices out of
        range; no triangles at all.

    Notes
    -----
    Godot stores coordinates as float32; text values are rounded to float32
    as Godot does, binary values are read at the precision the file declares.
    Transforms compose down the node path (a ``Node3D`` under a plain
    ``Node`` and a ``top_level`` node start afresh, as in Godot). Not read:
    occluders inside instanced sub-scenes of a ``.tscn``, the box, sphere,
    quad and polygon occluder shapes, compressed (``RSCC``) binaries.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> quad = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = pathlib.Path(tmp) / "quad.tres"
    ...     _ = path.write_text(tres_text(quad, [0, 1, 2, 0, 2, 3]))
    ...     mesh = load_occluder(path)
    >>> len(mesh.faces), mesh.metadata["source_format"]
    (2, 'godot-tres')
    """
    try:
        p = Path(os.fspath(path))
    except TypeError:
        raise InputError(f"occluder: expected a file path, got {type(path).__name__}") from None
    label = str(path)
    suffix = p.suffix.lower()
    if suffix in (".occ", ".res"):
        v, f = _load_occ_file(p, label)
        return _occluder_mesh(v, f, label, "godot-occ", [p.stem], [len(f)])
    if suffix == ".tres":
        v, f = _load_tres(_read_file(p, label), label)
        return _occluder_mesh(v, f, label, "godot-tres", [p.stem], [len(f)])
    if suffix == ".tscn":
        return _load_tscn(_read_file(p, label), p, label)
    if suffix in (".glb", ".gltf"):
        return _load_gltf(p, label)
    from .mesh_io import load_mesh

    mesh = load_mesh(p)
    mesh.metadata.update({"name": label, "source_format": "mesh"})
    return mesh


# ----------------------------------------------------------------------------- writing


def write_occluders(path: str | os.PathLike, instances: Sequence[OccluderInstance],
                    meshes: Mapping[str, tuple[npt.ArrayLike, npt.ArrayLike]]) -> None:
    """Write occluders atomically, in the format the path's extension names.

    Parameters
    ----------
    path : str or path
        ``.tscn`` (:func:`tscn_text`), ``.glb`` (:func:`occonly_glb_bytes`) or
        ``.tres`` (:func:`tres_text` of all instances baked into world space,
        as one ``ArrayOccluder3D``, like Godot's bake). Its folder must exist.
    instances : sequence of OccluderInstance
        The placed occluders.
    meshes : mapping str -> (vertices, indices)
        Local-space mesh of each ``mesh_key``.

    Raises
    ------
    InputError
        An unknown extension, a folder that does not exist, or input the
        writers refuse.
    OSError
        If writing fails; the file is then left as it was.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> quad = ([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [0, 1, 2, 0, 2, 3])
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     out = pathlib.Path(tmp) / "occluders.tscn"
    ...     write_occluders(out, [OccluderInstance("wall", "quad")], {"quad": quad})
    ...     len(load_occluder(out).faces)
    2
    """
    from .._atomic import write_atomic

    p = Path(os.fspath(path))
    suffix = p.suffix.lower()
    if suffix == ".tscn":
        data = tscn_text(instances, meshes).encode("utf-8")
    elif suffix == ".glb":
        data = occonly_glb_bytes(instances, meshes)
    elif suffix == ".tres":
        instances, used = _checked_scene(instances, meshes)
        parts_v, parts_i, offset = [], [], 0
        for inst in instances:
            v32, idx = used[inst.mesh_key]
            mat = inst.transform.astype(np.float32).astype(np.float64)
            parts_v.append(v32.astype(np.float64) @ mat[:3, :3].T + mat[:3, 3])
            parts_i.append(idx + offset)
            offset += len(v32)
        data = tres_text(np.concatenate(parts_v), np.concatenate(parts_i)).encode("utf-8")
    else:
        raise InputError(f"{path}: extension '{suffix or '(none)'}' is not an occluder output; "
                         "use .tscn, .glb or .tres")
    write_atomic(p, data)
