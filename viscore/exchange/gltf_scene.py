"""A glTF/GLB file read bounded: its JSON, its node hierarchy walked once, its geometry.

The one reader of glTF structure for every loader of viscore: the level loader
(:mod:`viscore.level.scene_graph`), the ``-occonly`` occluder reader
(:mod:`viscore.exchange.occonly_gltf`) and :func:`viscore.load_mesh`. What it
checks, before trimesh parses any geometry (glTF 2.0 [1]_):

- the JSON: a GLB split as the GLB specification says; at most
  :data:`MAX_JSON_OBJECTS` objects, counted on the bytes before the JSON is
  parsed (a file of a million nodes is refused in milliseconds);
- the node hierarchy (:func:`_node_hierarchy`, sec. 3.5.1-3.5.3): at most
  :data:`MAX_NODES` nodes and :data:`MAX_NODE_DEPTH` levels, disjoint strict
  trees (no cycle, one parent per node, a scene's nodes are roots), indices in
  range, and each node's transform: finite numbers of the right count, a
  ``matrix`` whose last row is ``0, 0, 0, 1`` (the specification requires a
  matrix decomposable to translation, rotation and scale; a projective one is
  refused when the file is read, naming the node);
- the geometry's references (:func:`check_gltf_geometry`, sec. 3.6-3.7):
  every buffer view inside its buffer (the GLB's binary chunk, a buffer's
  declared ``byteLength``), every accessor inside its buffer view, stride
  included; a sparse accessor a primitive reads its positions or indices
  from is refused (trimesh would read its base values, silently wrong); a
  mesh without primitives is said in one warning line;
- the referenced files (:class:`viscore.exchange.file_access.FolderResolver`):
  inside the file's folder, regular files, a buffer file no longer than its
  declared ``byteLength`` (only those bytes are read).

trimesh then parses the geometry of a copy of the file whose nodes are one
root per mesh (:func:`_mesh_library`), so it never walks the file's own node
hierarchy.

References
----------
.. [1] The Khronos 3D Formats Working Group. "glTF 2.0 Specification",
   version 2.0.1. The Khronos Group, 2021.
   https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html
"""

from __future__ import annotations

import io
import json
import logging
import re
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from .._validate import InputError, check_memory
from .file_access import (
    PARSE_BYTES_PER_FILE_BYTE,
    FolderResolver,
    UriOutsideFolder,
    _quoted,
    read_regular,
    trimesh_loading,
)
from .gltf_meshopt import EXTENSION as MESHOPT
from .gltf_meshopt import decode_meshopt_glb

__all__ = ["MAX_NODES", "MAX_NODE_DEPTH", "MAX_JSON_OBJECTS", "read_gltf",
           "check_gltf_geometry", "instanced_triangles", "world_transforms"]

_log = logging.getLogger(__name__)

_EYE = np.eye(4)
_EYE.flags.writeable = False

#: Deepest glTF node hierarchy read, in levels (a scene's root node is level 1).
#: Authored hierarchies (CAD assemblies, character rigs, scene graphs exported
#: from DCC tools) are tens of levels deep, rarely a few hundred; a chain of
#: thousands is generated or hostile. The transforms are composed iteratively
#: here, so depth costs nothing in viscore, but trimesh's own scene graph (which
#: trimesh's exporters use on the same file) composes
#: a path with ``numpy.linalg.multi_dot``, which recurses once per level, and
#: fails with RecursionError near Python's default recursion limit of 1,000: a
#: deeper file is refused here too rather than accepted by one reader of
#: viscore and not by the other. World transforms lose about one float64 ulp
#: per level, ~1e-13 relative at this depth.
MAX_NODE_DEPTH = 1_000
#: Most glTF nodes read. The real levels viscore was tried on have up to a few
#: hundred mesh nodes and a city of instanced props tens of thousands; a file of
#: a million nodes costs gigabytes before anything is culled.
MAX_NODES = 250_000
#: Most JSON objects (``{...}``) in a glTF's JSON, counted on its bytes before it
#: is parsed (a node is one to three objects; a parsed object costs ~0.5 kB).
MAX_JSON_OBJECTS = 1_000_000

#: GLB layout (glTF 2.0, "GLB File Format Specification"): a 12-byte header
#: (magic, version, total length), then chunks of (length, type, data), the
#: first one the JSON.
_GLB_HEADER = struct.Struct("<4sII")
_GLB_CHUNK = struct.Struct("<I4s")
_GLB_MAGIC = b"glTF"
_GLB_JSON = b"JSON"
_GLB_BIN = b"BIN\0"
_GLB_VERSION = 2
_GLB_ALIGN = 4
_UINT32_MAX = 2**32 - 1

#: Longest node name quoted in a message (a hostile name could fill a screen).
_NAME_CHARS = 60
#: Nodes of a cycle listed in its message before "...".
_CYCLE_SHOWN = 6

#: Accessor component types (bytes each) and element types (components each),
#: glTF 2.0 sec. 3.6.2.
_COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
_TYPE_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9,
                    "MAT4": 16}
#: Primitive modes (sec. 3.7.2.1) and the triangles of ``n`` vertices they draw.
_TRIANGLES, _STRIP, _FAN = 4, 5, 6


def _quote(value, limit: int = _NAME_CHARS) -> str:
    """``repr`` of a name, URI or value from the file, cut to about ``limit`` characters
    (the file readers' :func:`~viscore.exchange.file_access._quoted` at glTF's length)."""
    return _quoted(value, limit)


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
    objects = text.count("{")
    if objects > MAX_JSON_OBJECTS:
        raise InputError(f"{label}: its JSON holds {objects:,} objects, more than the "
                         f"{MAX_JSON_OBJECTS:,} viscore reads (a glTF of more than "
                         f"{MAX_NODES:,} nodes); not parsed")
    try:
        header = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise InputError(f"{label}: not a valid {what} file (not JSON: "
                         f"{' '.join(str(exc).split())[:120]})") from None
    if not isinstance(header, dict):
        raise InputError(f"{label}: not a valid {what} file (its JSON is a "
                         f"{type(header).__name__}, not an object)")
    if _SURROGATE_ESCAPE.search(text):  # rare: a walk of the strings only then
        _check_unicode(header, label)
    return header, layout


#: A JSON escape of a UTF-16 surrogate, ``\\ud800`` to ``\\udfff``: valid Unicode only as
#: a pair (high then low), which ``json.loads`` joins into one character.
_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F][0-9a-fA-F]{2}")


def _check_unicode(header: dict, label: str) -> None:
    """Refuse a lone surrogate escape in any string of the JSON (key or value).

    glTF's JSON is UTF-8 text, which cannot hold an unpaired surrogate (RFC 8259
    sec. 8.2: such strings behave unpredictably); one in a node's name would reach the
    Godot scene, the JSON document and the report page, none of which can encode it.
    """
    stack: list[tuple[str, object]] = [("", header)]
    while stack:
        where, value = stack.pop()
        if isinstance(value, dict):
            items = list(value.items())
            for key, _ in items:
                _check_text(key, f"{where}.{_quote(key)}" if where else _quote(key), label)
            stack.extend((f"{where}.{k}" if where else str(k), v) for k, v in items)
        elif isinstance(value, list):
            stack.extend((f"{where}[{i}]", v) for i, v in enumerate(value))
        elif isinstance(value, str):
            _check_text(value, where, label)


def _check_text(text: str, where: str, label: str) -> None:
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        raise InputError(f"{label}: {where} holds a lone UTF-16 surrogate escape "
                         f"({ascii(text)[:_NAME_CHARS]}), not Unicode text (RFC 8259 sec. 8.2)"
                         ) from None


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


def _parse_gltf_library(data: bytes, fmt: str, path: Path, label: str,
                        header: dict | None = None) -> trimesh.Scene:
    """trimesh's parse of the geometry of a glTF/GLB file (see :func:`_mesh_library`).

    Referenced files are read by :class:`viscore.exchange.file_access.FolderResolver`,
    a buffer file no longer than the ``byteLength`` ``header`` declares for it.
    """
    resolver = FolderResolver(path, label, declared=_declared_buffers(header or {}))
    token = trimesh_loading.set(True)
    try:
        try:  # only trimesh's parser is wrapped: a failure in our code below is a bug
            with np.errstate(all="ignore"):
                scene = trimesh.load_scene(file_obj=io.BytesIO(data), file_type=fmt,
                                           resolver=resolver, process=False)
        except InputError:
            raise
        except UriOutsideFolder as exc:
            raise InputError(f"{label}: buffer URI {_quote(exc.uri, 200)} points outside the "
                             f"folder of the file ({path.resolve().parent}); glTF URIs must "
                             "stay inside that folder (not read)") from None
        except MemoryError:
            raise InputError(f"{label}: not enough memory to read this file") from None
        except FileNotFoundError as exc:
            missing = exc.filename or " ".join(str(exc).split())[:200]
            raise InputError(f"{label}: a file it references is missing ({missing})") from None
        except Exception as exc:  # noqa: BLE001 - trimesh raises many types on bad files
            detail = " ".join(f"{type(exc).__name__}: {exc}".split())[:200]
            raise InputError(f"{label}: not a valid {fmt.upper()} file ({detail})") from None
    finally:
        trimesh_loading.reset(token)
    resolver.raise_refusal()  # an image trimesh skipped: refused all the same
    for uri in resolver.outside:  # images: trimesh skips a texture it cannot read
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
    if n > MAX_NODES:
        raise InputError(f"{label}: {n:,} nodes, more than the {MAX_NODES:,} viscore reads")
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
        kids = node.get("children", [])
        if not (type(kids) is list and all(type(c) is int and 0 <= c < n for c in kids)):
            _index_list(kids, n, f"{_node_label(nodes, i)} 'children'", label)  # its message
        children.append(list(dict.fromkeys(kids)) if kids else [])

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
    if depth and max(depth.values()) > MAX_NODE_DEPTH:
        deepest = max(depth, key=depth.__getitem__)
        raise InputError(f"{label}: the node hierarchy is {depth[deepest]:,} levels deep (at "
                         f"{_node_label(nodes, deepest)}), deeper than the {MAX_NODE_DEPTH:,} "
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
            if not np.array_equal(matrix[3], _EYE[3]):
                row = ", ".join(f"{x:g}" for x in matrix[3])
                raise InputError(f"{label}: {where}: 'matrix' is not affine (its last row is "
                                 f"{row}, not 0, 0, 0, 1); glTF 2.0 requires a matrix made of "
                                 "a translation, a rotation and a scale")
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


# ------------------------------------------------------- glTF: buffers, views, accessors
def _uint(value, what: str, label: str, *, low: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise InputError(f"{label}: {what} must be an integer >= {low}, got {_quote(value)}")
    return value


def _listed(header: dict, key: str, label: str) -> list:
    value = header.get(key, [])
    if not isinstance(value, list):
        raise InputError(f"{label}: {key!r} must be a list, got {type(value).__name__}")
    return value


def _data_uri_bytes(uri: str) -> int | None:
    """Bytes a base64 ``data:`` URI decodes to (without decoding it), or None."""
    head, sep, body = uri.partition("base64,")
    if not sep or not head.startswith("data:"):
        return None
    body = body.strip()
    return len(body) * 3 // 4 - (len(body) - len(body.rstrip("=")))


def _declared_buffers(header: dict) -> dict[str, int]:
    """External buffer URI -> its declared ``byteLength`` (what the resolver may read)."""
    out = {}
    buffers = header.get("buffers")
    for b in buffers if isinstance(buffers, list) else []:
        if isinstance(b, dict) and isinstance(b.get("uri"), str) and \
                _data_uri_bytes(b["uri"]) is None and isinstance(b.get("byteLength"), int):
            out[b["uri"].strip()] = b["byteLength"]
    return out


def _buffer_lengths(header: dict, layout: tuple[int, int, int], data: bytes, fmt: str,
                    label: str) -> list[int]:
    """Bytes each buffer holds: the GLB binary chunk for a buffer without a URI, a data
    URI's decoded length, else its declared ``byteLength`` (its file is checked
    against it when read)."""
    binary = None
    if fmt == "glb":
        end = layout[2]
        if end + _GLB_CHUNK.size <= len(data):
            length, kind = _GLB_CHUNK.unpack_from(data, end)
            if kind == _GLB_BIN:
                binary = min(length, len(data) - end - _GLB_CHUNK.size)
    lengths = []
    for k, b in enumerate(_listed(header, "buffers", label)):
        where = f"buffer {k}"
        if not isinstance(b, dict):
            raise InputError(f"{label}: {where} must be a JSON object")
        declared = _uint(b.get("byteLength"), f"{where} byteLength", label, low=1)
        uri = b.get("uri")
        if uri is None:
            if k != 0 or binary is None:
                raise InputError(f"{label}: {where} has no URI and no GLB binary chunk holds it")
            if declared > binary:
                raise InputError(f"{label}: {where} declares {declared:,} bytes, but the GLB "
                                 f"binary chunk holds {binary:,}")
        elif isinstance(uri, str) and (size := _data_uri_bytes(uri)) is not None:
            if declared > size:
                raise InputError(f"{label}: {where} declares {declared:,} bytes, but its data "
                                 f"URI holds {size:,}")
        elif not isinstance(uri, str):
            raise InputError(f"{label}: {where} 'uri' must be a string, got {_quote(uri)}")
        lengths.append(declared)
    return lengths


def _check_views(header: dict, lengths: list[int], label: str) -> list[tuple[int, int]]:
    """(byteLength, byteStride or 0) of each buffer view, each checked inside its buffer."""
    views = []
    for k, view in enumerate(_listed(header, "bufferViews", label)):
        where = f"bufferView {k}"
        if not isinstance(view, dict):
            raise InputError(f"{label}: {where} must be a JSON object")
        buffer = _uint(view.get("buffer"), f"{where} buffer", label)
        if buffer >= len(lengths):
            raise InputError(f"{label}: {where} refers to buffer {buffer}, but the file has "
                             f"{len(lengths)}")
        offset = _uint(view.get("byteOffset", 0), f"{where} byteOffset", label)
        length = _uint(view.get("byteLength"), f"{where} byteLength", label, low=1)
        stride = _uint(view.get("byteStride", 0), f"{where} byteStride", label)
        if offset + length > lengths[buffer]:
            raise InputError(f"{label}: {where} runs past its buffer: byteOffset {offset:,} + "
                             f"byteLength {length:,} > buffer {buffer}'s {lengths[buffer]:,} "
                             "bytes")
        if stride and stride > length:
            raise InputError(f"{label}: {where} byteStride {stride:,} is longer than its "
                             f"byteLength {length:,}")
        views.append((length, stride))
    return views


def _check_accessors(header: dict, views: list[tuple[int, int]], label: str) -> list[int]:
    """The element count of each accessor, each checked inside its buffer view."""
    counts = []
    for k, acc in enumerate(_listed(header, "accessors", label)):
        where = f"accessor {k}"
        if not isinstance(acc, dict):
            raise InputError(f"{label}: {where} must be a JSON object")
        count = _uint(acc.get("count"), f"{where} count", label)
        component = acc.get("componentType")
        kind = acc.get("type")
        if component not in _COMPONENT_BYTES or isinstance(component, bool):
            raise InputError(f"{label}: {where} has an unknown componentType "
                             f"{_quote(component)}")
        if kind not in _TYPE_COMPONENTS:
            raise InputError(f"{label}: {where} has an unknown type {_quote(kind)}")
        counts.append(count)
        if "bufferView" not in acc:  # zeros trimesh allocates (or a sparse substitution)
            check_memory(count * _COMPONENT_BYTES[component] * _TYPE_COMPONENTS[kind],
                         f"{label} ({where}: {count:,} elements without a buffer view)")
            continue
        view = _uint(acc["bufferView"], f"{where} bufferView", label)
        if view >= len(views):
            raise InputError(f"{label}: {where} refers to bufferView {view}, but the file has "
                             f"{len(views)}")
        offset = _uint(acc.get("byteOffset", 0), f"{where} byteOffset", label)
        element = _COMPONENT_BYTES[component] * _TYPE_COMPONENTS[kind]
        length, stride = views[view]
        end = offset + (max(count, 1) - 1) * (stride or element) + element
        if end > length:
            what = f"byteStride {stride} x " if stride else ""
            raise InputError(f"{label}: {where} runs past bufferView {view}: byteOffset "
                             f"{offset:,} + {what}count {count:,} needs {end:,} bytes, the "
                             f"view has {length:,}")
    return counts


def check_gltf_geometry(header: dict, layout: tuple[int, int, int], data: bytes, fmt: str,
                        label: str) -> None:
    """Check a glTF's buffers, buffer views, accessors and meshes before trimesh reads them.

    Parameters
    ----------
    header : dict
        The file's JSON (:func:`_gltf_json`).
    layout : (int, int, int)
        For a GLB, its total length, JSON chunk length and the JSON chunk's end.
    data : bytes
        The file's bytes (a GLB's binary chunk is measured there).
    fmt : {'glb', 'gltf'}
    label : str
        Names the file in messages.

    Raises
    ------
    InputError
        One line naming the file and the item: a buffer view running past its
        buffer (``byteOffset + byteLength``), a stride longer than its view, an
        accessor running past its view (stride included), a buffer larger than
        the GLB binary chunk or its data URI, an index or count that is not a
        non-negative integer, an unknown component or element type, a sparse
        accessor that a primitive reads its ``POSITION`` or ``indices`` from.

    Notes
    -----
    A mesh without primitives (the specification requires at least one) is
    dropped by trimesh; that is said in one warning line naming the meshes
    and how many nodes use them.
    """
    lengths = _buffer_lengths(header, layout, data, fmt, label)
    views = _check_views(header, lengths, label)
    accessors = _listed(header, "accessors", label)
    _check_accessors(header, views, label)
    empty = []
    for m, mesh in enumerate(_listed(header, "meshes", label)):
        if not isinstance(mesh, dict):
            raise InputError(f"{label}: mesh {m} must be a JSON object")
        primitives = mesh.get("primitives", [])
        if not isinstance(primitives, list) or not primitives:
            empty.append(m)
            continue
        for p, prim in enumerate(primitives):
            if not isinstance(prim, dict) or not isinstance(prim.get("attributes"), dict):
                raise InputError(f"{label}: mesh {m} primitive {p} has no attributes object")
            used = {"POSITION": prim["attributes"].get("POSITION"),
                    "indices": prim.get("indices")}
            for role, a in used.items():
                if a is None:
                    continue
                a = _uint(a, f"mesh {m} primitive {p} {role}", label)
                if a >= len(accessors):
                    raise InputError(f"{label}: mesh {m} primitive {p} {role} refers to "
                                     f"accessor {a}, but the file has {len(accessors)}")
                if "sparse" in accessors[a]:
                    raise InputError(f"{label}: mesh {m} primitive {p} reads its {role} from "
                                     f"accessor {a}, which is sparse; viscore does not read "
                                     "sparse accessors (export without sparse storage)")
    if empty:
        nodes = header.get("nodes", [])
        users = sum(1 for n in nodes if isinstance(n, dict) and n.get("mesh") in empty) \
            if isinstance(nodes, list) else 0
        shown = ", ".join(str(m) for m in empty[:_CYCLE_SHOWN]) + (
            ", ..." if len(empty) > _CYCLE_SHOWN else "")
        _log.warning("%s: %s mesh%s without primitives (%s), used by %s node%s: left out "
                     "(glTF 2.0 requires at least one primitive per mesh)", label,
                     f"{len(empty):,}", "" if len(empty) == 1 else "es", shown, f"{users:,}",
                     "" if users == 1 else "s")


def _mesh_triangles(header: dict) -> list[int]:
    """Triangles each glTF mesh draws, from its accessors' counts (nothing is decoded)."""
    accessors = header.get("accessors", [])
    out = []
    for mesh in header.get("meshes", []):
        total = 0
        for prim in mesh.get("primitives", []) if isinstance(mesh, dict) else []:
            mode = prim.get("mode", _TRIANGLES)
            index = prim.get("indices", prim.get("attributes", {}).get("POSITION"))
            if not isinstance(index, int) or not 0 <= index < len(accessors):
                continue
            n = accessors[index].get("count", 0)
            n = n if isinstance(n, int) else 0
            total += n // 3 if mode == _TRIANGLES else max(0, n - 2) if mode in (
                _STRIP, _FAN) else 0
        out.append(total)
    return out


def instanced_triangles(header: dict, tree: _Hierarchy) -> int:
    """Triangles of a glTF's default scene with every instance counted, before any is built.

    Each reachable node with a mesh counts that mesh's triangles (from the
    accessors' counts), so a mesh placed by a thousand nodes counts a thousand
    times.
    """
    per_mesh = _mesh_triangles(header)
    nodes = header.get("nodes", [])
    total = 0
    for v in tree.order:
        mesh = nodes[v].get("mesh")
        if isinstance(mesh, int) and not isinstance(mesh, bool) and 0 <= mesh < len(per_mesh):
            total += per_mesh[mesh]
    return total


def world_transforms(header: dict, tree: _Hierarchy, label: str) -> dict[int, np.ndarray]:
    """``(4, 4) float64`` world transform of each reachable node, parents first.

    World = parent's world x local (``matrix`` x T x R x S, :func:`_local_matrix`),
    one pass over :attr:`_Hierarchy.order`, linear in the number of nodes.
    """
    nodes = header.get("nodes", [])
    world: dict[int, np.ndarray] = {}
    with np.errstate(all="ignore"):  # non-finite or huge transforms: refused by the caller
        for v in tree.order:
            local = _local_matrix(nodes[v], label, _node_label(nodes, v))
            above = tree.parent[v]
            world[v] = local if above == -1 else np.dot(world[above], local)
    return world


def read_gltf(path: Path, label: str) -> tuple[bytes, dict, tuple[int, int, int], str]:
    """A glTF/GLB file read and checked up to its geometry, which trimesh parses next.

    The file is read as a regular file within the memory limit
    (:func:`viscore.exchange.file_access.read_regular`), its JSON parsed
    (:func:`_gltf_json`), Draco compression refused, meshopt-compressed views
    of a GLB decoded (:func:`viscore.exchange.gltf_meshopt.decode_meshopt_glb`),
    and its buffers, views and accessors checked (:func:`check_gltf_geometry`).

    Returns
    -------
    data : bytes
        The file (decoded when it was meshopt-compressed).
    header : dict
        Its JSON.
    layout : (int, int, int)
        For a GLB, its total length, JSON chunk length and JSON chunk end.
    fmt : {'glb', 'gltf'}
    """
    fmt = path.suffix.lower().lstrip(".")
    data = read_regular(path, label, what=f"a {fmt.upper()} file",
                        bytes_per_byte=PARSE_BYTES_PER_FILE_BYTE)
    header, layout = _gltf_json(data, fmt, label)
    _refuse_compressed(header, fmt, label)
    if fmt == "glb":  # meshopt-compressed views and normalized positions made plain
        plain, _ = decode_meshopt_glb(data, header, layout[2], label)
        if plain is not data:
            data = plain
            header, layout = _gltf_json(data, fmt, label)
    check_gltf_geometry(header, layout, data, fmt, label)
    return data, header, layout, fmt
