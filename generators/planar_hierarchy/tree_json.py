"""An occluder hierarchy on disk: ``STEM.hierarchy.json`` and one PLY per node."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import trimesh

from viscore import InputError
from viscore._atomic import FileSet, check_output_path
from viscore.exchange.mesh_io import ply_bytes

from .cut import index_hierarchy
from .tree import _empty_mesh, _walk

__all__ = ["hierarchy_to_json", "hierarchy_files", "hierarchy_from_json"]

#: Format name and version written into, and required from, the tree JSON.
_FORMAT = "viscore-occluder-hierarchy"
_VERSION = 1


def hierarchy_to_json(tree: dict, folder: str | os.PathLike, stem: str) -> Path:
    """Write a hierarchy as ``STEM.hierarchy.json`` plus one PLY per node occluder.

    Parameters
    ----------
    tree : dict
        The root node (:func:`build_hierarchy`).
    folder : path
        An existing folder (it is not created).
    stem : str
        File name stem, without any folder: ``STEM.node0003.ply`` holds node
        3's occluder (float64 binary PLY); nodes whose occluder has no faces
        get no file (``"mesh": null``).

    Returns
    -------
    Path
        The JSON file: ``{"format", "version", "builder", "nodes": [...]}``,
        each node with ``id``, ``bounds``, ``geometry_bounds``, ``error``,
        ``voxel_size``, ``dilation``, ``triangles``, ``double_sided``,
        ``objects``, ``children`` (ids) and ``mesh`` (file name relative to
        the JSON's folder, or null). Node ids are pre-order, root 0.

    Raises
    ------
    InputError
        A missing folder, a stem with a folder in it, or a tree
        :func:`index_hierarchy` refuses; before any file is written.
    OSError
        If writing fails; then none of the files is left (earlier files of
        those names keep their content).

    Notes
    -----
    The files are one set, written all or none (:class:`viscore._atomic.FileSet`:
    into a temporary folder beside them, then moved into place, meshes first
    and the JSON last), so a JSON never names a mesh not written.

    Examples
    --------
    >>> import tempfile
    >>> from viscore.generators import build_hierarchy
    >>> root = build_hierarchy(trimesh.creation.box(), node_occluder="qem", budget=12)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     path = hierarchy_to_json(root, d, "box")
    ...     back = hierarchy_from_json(path)
    ...     print(path.name, len(back["occluder"].faces))
    box.hierarchy.json 12
    """
    _check_stem(stem)
    folder = Path(folder)
    json_path = check_output_path(folder / f"{stem}.hierarchy.json")
    files = hierarchy_files(tree, stem)
    with FileSet(folder) as out:
        for name, data in files.items():
            out.write(name, data)
    return json_path


def _check_stem(stem: object) -> None:
    if not isinstance(stem, str) or not stem or Path(stem).name != stem or stem in (".", ".."):
        raise InputError(f"stem: expected a file name without a folder, got {stem!r}")


def hierarchy_files(tree: dict, stem: str) -> dict[str, bytes]:
    """The files :func:`hierarchy_to_json` writes, as names and bytes, without writing.

    Parameters
    ----------
    tree : dict
        The root node (:func:`build_hierarchy`).
    stem : str
        File name stem, without any folder.

    Returns
    -------
    dict of str -> bytes
        ``STEM.nodeNNNN.ply`` per node with faces, in node order, then
        ``STEM.hierarchy.json`` (last); the names are relative to one folder.

    Raises
    ------
    InputError
        A stem with a folder in it, or a tree :func:`index_hierarchy` refuses.

    Examples
    --------
    >>> from viscore.generators import build_hierarchy
    >>> root = build_hierarchy(trimesh.creation.box(), node_occluder="qem", budget=12)
    >>> list(hierarchy_files(root, "box"))
    ['box.node0000.ply', 'box.hierarchy.json']
    """
    _check_stem(stem)
    index = index_hierarchy(tree)
    nodes = list(index.nodes)
    ids = {id(n): i for i, n in enumerate(nodes)}
    records = []
    files: dict[str, bytes] = {}
    for i, n in enumerate(nodes):
        occ = n.get("occluder")
        name = None
        if isinstance(occ, trimesh.Trimesh) and len(occ.faces):
            name = f"{stem}.node{i:04d}.ply"
            files[name] = ply_bytes(occ)
        gb = n.get("geometry_bounds", n["bounds"])
        records.append({
            "id": i, "bounds": np.asarray(n["bounds"], dtype=float).tolist(),
            "geometry_bounds": np.asarray(gb, dtype=float).tolist(),
            "error": float(n["error"]), "voxel_size": float(n.get("voxel_size", n["error"])),
            "dilation": int(n.get("dilation", 0)),
            "triangles": 0 if name is None else len(occ.faces),
            "double_sided": bool(n.get("double_sided", True)),
            "objects": [int(o) for o in np.asarray(n.get("objects", []), dtype=np.int64)],
            "children": [ids[id(c)] for c in n["children"]], "mesh": name,
            "note": str(n.get("note", ""))})
    doc = {"format": _FORMAT, "version": _VERSION, "builder": str(tree.get("builder", "")),
           "nodes": records}
    files[f"{stem}.hierarchy.json"] = json.dumps(doc, indent=1).encode()
    return files


def _load_ply(path: Path, label: str) -> trimesh.Trimesh:
    try:
        with open(path, "rb") as fh:
            loaded = trimesh.exchange.ply.load_ply(fh)
    except OSError as exc:
        raise InputError(f"{label}: cannot read {path} ({exc.strerror or exc})") from None
    except Exception as exc:  # trimesh's parser raises many kinds on a bad file
        raise InputError(f"{label}: {path} is not a valid PLY file ({exc})") from None
    return trimesh.Trimesh(np.asarray(loaded["vertices"], dtype=np.float64),
                           np.asarray(loaded["faces"], dtype=np.int64).reshape(-1, 3),
                           process=False)


def hierarchy_from_json(path: str | os.PathLike) -> dict:
    """Read a hierarchy written by :func:`hierarchy_to_json`.

    Parameters
    ----------
    path : path
        The ``.hierarchy.json`` file; node meshes are read from its folder.

    Returns
    -------
    dict
        The root node with the same keys as :func:`build_hierarchy` gives
        (``seconds`` excepted); empty occluders where ``mesh`` is null.

    Raises
    ------
    InputError
        An unreadable or malformed file, a node mesh missing, outside the
        JSON's folder or not a valid PLY, a child id that is not a later node
        or a node used twice, or bounds and errors :func:`index_hierarchy`
        refuses.
    """
    path = Path(path)
    label = str(path)
    try:
        doc = json.loads(path.read_text())
    except OSError as exc:
        raise InputError(f"{label}: cannot read ({exc.strerror or exc})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{label}: not a JSON file ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != _FORMAT \
            or doc.get("version") != _VERSION or not isinstance(doc.get("nodes"), list) \
            or not doc["nodes"]:
        raise InputError(f"{label}: not a {_FORMAT} version {_VERSION} file")
    records = doc["nodes"]
    nodes, seen = [], set()
    for i, r in enumerate(records):
        if not isinstance(r, dict) or r.get("id") != i:
            raise InputError(f"{label}: node {i} is not a record with id {i}")
        children = r.get("children")
        if not isinstance(children, list) or any(
                not isinstance(c, int) or isinstance(c, bool) or c <= i or c >= len(records)
                or c in seen for c in children):
            raise InputError(f"{label}: node {i}: children must be ids of later nodes, "
                             "each used once")
        seen.update(children)
        name = r.get("mesh")
        if name is None:
            mesh = _empty_mesh()
        elif not isinstance(name, str) or Path(name).name != name or name in (".", ".."):
            raise InputError(f"{label}: node {i}: mesh must be a file name in the JSON's "
                             f"folder, got {name!r}")
        else:
            mesh = _load_ply(path.parent / name, f"{label}: node {i}")
        try:
            node = {"id": i, "bounds": np.array(r["bounds"], dtype=np.float64),
                    "geometry_bounds": np.array(r["geometry_bounds"], dtype=np.float64),
                    "error": float(r["error"]), "voxel_size": float(r["voxel_size"]),
                    "dilation": int(r["dilation"]), "triangles": len(mesh.faces),
                    "double_sided": bool(r["double_sided"]),
                    "objects": np.array(r["objects"], dtype=np.int64).reshape(-1),
                    "occluder": mesh, "children": children, "note": str(r.get("note", ""))}
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{label}: node {i}: missing or malformed field ({exc})") from None
        if node["triangles"] != r.get("triangles"):
            raise InputError(f"{label}: node {i}: {name} has {node['triangles']} triangles, "
                             f"the JSON says {r.get('triangles')}")
        nodes.append(node)
    if 0 in seen:
        raise InputError(f"{label}: the root is some node's child")
    for n in nodes:
        n["children"] = [nodes[c] for c in n["children"]]  # type: ignore[attr-defined]
    if len(_walk(nodes[0])) != len(nodes):
        raise InputError(f"{label}: some nodes are not below the root")
    nodes[0]["builder"] = str(doc.get("builder", ""))
    index_hierarchy(nodes[0])  # bounds and errors checked
    return nodes[0]

