"""``bufferView.target`` on the GLB files viscore writes (glTF 2.0, sec. 3.6.2.1).

trimesh's GLB writer leaves ``target`` out of every buffer view; the Khronos
glTF validator then hints ``BUFFER_VIEW_TARGET_MISSING`` on each vertex and
index buffer view, and some clients upload such views late or guess their
use. :func:`with_buffer_view_targets` sets ``target`` from how the meshes use
each view: ``ARRAY_BUFFER`` (34962) for vertex attributes and morph targets,
``ELEMENT_ARRAY_BUFFER`` (34963) for indices, and leaves alone a view used
otherwise (images, sparse accessors, both roles) or that already has one. The
binary chunk is kept byte for byte; only the JSON chunk is rewritten.

References
----------
.. [1] The Khronos 3D Formats Working Group. "glTF 2.0 Specification",
   version 2.0.1. The Khronos Group, 2021, sec. 3.6.2.1 (buffer views,
   ``target``) and sec. 4.4 (GLB file format).
   https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html
"""

from __future__ import annotations

import json
import struct

from .._validate import InputError

__all__ = ["with_buffer_view_targets", "ARRAY_BUFFER", "ELEMENT_ARRAY_BUFFER"]

#: ``bufferView.target`` of vertex attribute data and of index data (WebGL enums).
ARRAY_BUFFER = 34962
ELEMENT_ARRAY_BUFFER = 34963

_MAGIC = b"glTF"
_JSON = 0x4E4F534A
_HEADER = struct.Struct("<4sII")
_CHUNK = struct.Struct("<II")


def _roles(doc: dict) -> dict[int, set]:
    """Buffer view index -> the roles its accessors play (``ARRAY_BUFFER``,
    ``ELEMENT_ARRAY_BUFFER`` or ``None`` for any other use)."""
    accessors = doc.get("accessors", [])
    roles: dict[int, set] = {}

    def use(accessor, role) -> None:
        if isinstance(accessor, int) and 0 <= accessor < len(accessors):
            a = accessors[accessor]
            if "bufferView" in a:
                roles.setdefault(a["bufferView"], set()).add(role if "sparse" not in a
                                                              else None)
            if "sparse" in a:
                for part in ("indices", "values"):
                    view = a["sparse"].get(part, {}).get("bufferView")
                    if view is not None:
                        roles.setdefault(view, set()).add(None)

    used = set()
    for mesh in doc.get("meshes", []):
        for prim in mesh.get("primitives", []):
            for accessor in prim.get("attributes", {}).values():
                use(accessor, ARRAY_BUFFER)
                used.add(accessor)
            for target in prim.get("targets", []):
                for accessor in target.values():
                    use(accessor, ARRAY_BUFFER)
                    used.add(accessor)
            if "indices" in prim:
                use(prim["indices"], ELEMENT_ARRAY_BUFFER)
                used.add(prim["indices"])
    for k in range(len(accessors)):  # accessors of animations, skins, ...: other uses
        if k not in used:
            use(k, None)
    for image in doc.get("images", []):
        if "bufferView" in image:
            roles.setdefault(image["bufferView"], set()).add(None)
    return roles


def with_buffer_view_targets(glb: bytes) -> bytes:
    """The same GLB with ``target`` set on its vertex and index buffer views.

    Parameters
    ----------
    glb : bytes
        A binary glTF 2.0 file (a JSON chunk, optionally a BIN chunk).

    Returns
    -------
    glb : bytes
        Its JSON chunk with ``bufferViews[i].target`` set where every use of
        view ``i`` is as vertex data (34962) or every use is as index data
        (34963); everything else, the binary chunk included, unchanged.

    Raises
    ------
    InputError
        If ``glb`` is not a GLB of version 2 with a JSON first chunk.

    Examples
    --------
    >>> import trimesh
    >>> glb = trimesh.exchange.gltf.export_glb(trimesh.Scene(trimesh.creation.box()))
    >>> out = with_buffer_view_targets(glb)
    >>> size = struct.unpack_from("<I", out, 12)[0]
    >>> sorted(v.get("target") for v in json.loads(out[20:20 + size])["bufferViews"])
    [34962, 34963]
    """
    data = bytes(glb)
    if len(data) < _HEADER.size + _CHUNK.size:
        raise InputError("glb: too short for a GLB file")
    magic, version, length = _HEADER.unpack_from(data, 0)
    if magic != _MAGIC or version != 2 or length > len(data):
        raise InputError("glb: not a GLB file of glTF 2.0")
    size, kind = _CHUNK.unpack_from(data, _HEADER.size)
    start = _HEADER.size + _CHUNK.size
    if kind != _JSON or start + size > length:
        raise InputError("glb: the first chunk is not JSON")
    doc = json.loads(data[start:start + size].decode("utf-8"))
    views = doc.get("bufferViews", [])
    changed = False
    for index, roles in _roles(doc).items():
        if (isinstance(index, int) and 0 <= index < len(views) and len(roles) == 1
                and None not in roles and "target" not in views[index]):
            views[index]["target"] = next(iter(roles))
            changed = True
    if not changed:
        return data
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)  # chunks are 4-byte aligned, JSON padded with spaces
    rest = data[start + size:length]
    total = _HEADER.size + _CHUNK.size + len(text) + len(rest)
    return (_HEADER.pack(_MAGIC, 2, total) + _CHUNK.pack(len(text), _JSON) + text + rest)
