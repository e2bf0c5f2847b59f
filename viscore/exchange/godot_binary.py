"""Godot 4 binary resources (``.occ``/``.res``) in: the ``ArrayOccluder3D`` of a bake.

Reads the ``ArrayOccluder3D`` [2]_ of Godot's bake from the ``RSRC`` binary format
of ``ResourceFormatSaverBinary`` [3]_ (format version 6).

References
----------
.. [1] Godot Engine contributors. "Godot Engine", version 4,
   https://godotengine.org (source: https://github.com/godotengine/godot).
.. [2] Godot Engine documentation, class reference "ArrayOccluder3D",
   https://docs.godotengine.org/en/stable/classes/class_arrayoccluder3d.html
.. [3] Godot Engine source, ``core/io/resource_format_binary.cpp`` and
   ``core/io/resource_format_binary.h`` (``ResourceLoaderBinary``,
   ``ResourceFormatSaverBinaryInstance``; binary format version 6).
"""

from __future__ import annotations

import io
import os
import struct
from pathlib import Path
from typing import BinaryIO

import numpy as np
import trimesh

from .._validate import InputError, check_memory
from .file_access import DECLARED_SLACK, open_regular, read_regular

#: Binary resource format versions read here (Godot 4.0 wrote 4; 4.3+ writes 6).
BINARY_FORMATS = range(4, 7)
#: Header flags of the binary format (``resource_format_binary.h``).
_FLAG_UIDS = 2
_FLAG_REAL_T_IS_DOUBLE = 4
_FLAG_HAS_SCRIPT_CLASS = 8
#: Reserved 32-bit fields after the header (``RESERVED_FIELDS``).
_RESERVED_FIELDS = 11
#: Nesting depth of Arrays/Dictionaries refused in a binary resource (a bound
#: against recursion bombs; occluders hold no nested containers at all).
_MAX_NESTING = 64
_OCCLUDER_TYPE = "ArrayOccluder3D"
#: Longest string or name read from a binary resource (type names, paths, property
#: names are tens of bytes), bytes.
_MAX_STRING = 1 << 20
#: What Godot's binary saver writes after the last resource.
_RSRC_END = b"RSRC"
#: Peak bytes of memory per byte of a text occluder file while it is parsed (the
#: text, its numbers split into strings, the arrays; measured ~8 on a 13 MB
#: ``.tscn``).
_TEXT_PARSE_BYTES_PER_BYTE = 20
#: Memory per triangle and per vertex of occluders placed in world space: the soup
#: (24 bytes a face, 24 a vertex), its mesh's copies and what its users derive from it
#: (as viscore.exchange.mesh_io's per-triangle figure).
_BYTES_PER_PLACED_TRIANGLE = 300
_BYTES_PER_PLACED_VERTEX = 72
#: Coordinates placed per batch of instances of one geometry.
_PLACE_CHUNK = 16_000_000
#: Peak bytes per byte of a packed array read (the raw bytes, float64 or int64 copies).
_ARRAY_BYTES_PER_BYTE = 4

# binary variant type ids (resource_format_binary.cpp)
_V_NIL, _V_BOOL, _V_INT, _V_FLOAT, _V_STRING = 1, 2, 3, 4, 5
_V_NODE_PATH, _V_RID, _V_OBJECT = 22, 23, 24
_V_DICTIONARY, _V_ARRAY = 26, 30
_V_PACKED_BYTE, _V_PACKED_INT32, _V_PACKED_FLOAT32, _V_PACKED_STRING = 31, 32, 33, 34
_V_PACKED_VECTOR3, _V_PACKED_COLOR, _V_PACKED_VECTOR2 = 35, 36, 37
_V_INT64, _V_DOUBLE, _V_CALLABLE, _V_SIGNAL, _V_STRING_NAME = 40, 41, 42, 43, 44
_V_PACKED_INT64, _V_PACKED_FLOAT64, _V_PACKED_VECTOR4 = 48, 49, 53
#: Fixed-size variants: type id -> (reals, bytes besides the reals).
_V_FIXED = {
    10: (2, 0),   # Vector2
    11: (4, 0),   # Rect2
    12: (3, 0),   # Vector3
    13: (4, 0),   # Plane
    14: (4, 0),   # Quaternion
    15: (6, 0),   # AABB
    16: (9, 0),   # Basis
    17: (12, 0),  # Transform3D
    18: (6, 0),   # Transform2D
    20: (0, 16),  # Color: always float32
    45: (0, 8),   # Vector2i
    46: (0, 16),  # Rect2i
    47: (0, 12),  # Vector3i
    50: (4, 0),   # Vector4
    51: (0, 16),  # Vector4i
    52: (16, 0),  # Projection
}
#: Packed arrays of fixed-size items: type id -> (reals per item, bytes per item besides).
_V_PACKED = {
    _V_PACKED_INT32: (0, 4), _V_PACKED_FLOAT32: (0, 4), _V_PACKED_VECTOR2: (2, 0),
    _V_PACKED_VECTOR3: (3, 0), _V_PACKED_COLOR: (0, 16), _V_PACKED_INT64: (0, 8),
    _V_PACKED_FLOAT64: (0, 8), _V_PACKED_VECTOR4: (4, 0),
}

# ----------------------------------------------------------------------------- input checks


def _read_file(path: Path, label: str) -> bytes:
    """The bytes of a regular, non-empty text occluder file, or one-line :class:`InputError`.

    Refused before it is read when parsing it would pass the memory limit
    (:func:`viscore.exchange.file_access.read_regular`).
    """
    return read_regular(path, label, what="a Godot text file",
                        bytes_per_byte=_TEXT_PARSE_BYTES_PER_BYTE, text=True)


def _load_occ_file(path: Path, label: str) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_load_occ` of a regular file, read only where the resource's layout points."""
    with open_regular(path, label, what="an occluder file") as fh:
        if os.fstat(fh.fileno()).st_size == 0:
            raise InputError(f"{label}: the file is empty")
        return _load_occ(fh, label)


def _checked_geometry(vertices: np.ndarray, indices: np.ndarray, label: str,
                      what: str) -> tuple[np.ndarray, np.ndarray]:
    """Finite ``(n, 3) float64`` vertices and in-range ``(m, 3) int64`` faces."""
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    indices = np.asarray(indices, dtype=np.int64).reshape(-1)
    if not np.isfinite(vertices).all():
        raise InputError(f"{label}: {what} has NaN or infinite vertex coordinates")
    if len(indices) % 3:
        raise InputError(f"{label}: {what} has {len(indices)} indices, not a multiple of 3")
    if len(indices) and (indices.min() < 0 or indices.max() >= len(vertices)):
        raise InputError(f"{label}: {what} has indices outside 0..{len(vertices) - 1}")
    return vertices, indices.reshape(-1, 3)


def _placed(vertices: np.ndarray, mat: np.ndarray, label: str, node: str) -> np.ndarray:
    """``(v, 3) float64``: a node's vertices in world space by its (4, 4) transform.

    InputError when the transform carries a vertex beyond float64's range.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        placed = vertices @ mat[:3, :3].T + mat[:3, 3]
    if not np.isfinite(placed).all():
        raise InputError(f"{label}: node {node!r}: its transform places vertices beyond "
                         "float64's range")
    return placed


def _instances_mesh(geometry: dict, placed: list[tuple[str, object, np.ndarray]], label: str,
                    fmt: str) -> trimesh.Trimesh:
    """The world-space soup of placed instances, counted before any is built.

    Parameters
    ----------
    geometry : dict
        Key -> local ``(vertices (v, 3) float64, faces (t, 3) int64)``.
    placed : list of (str, key, (4, 4) float64)
        Each instance in output order: its node's name, its geometry's key and
        its world transform.

    Raises
    ------
    InputError
        When the instances together (a mesh placed by a thousand nodes counts a
        thousand times) pass the memory limit, before anything is placed; when
        a transform places a vertex beyond float64's range (naming the node);
        when no instance holds a triangle.
    """
    nv = np.array([len(geometry[key][0]) for _, key, _ in placed], dtype=np.int64)
    nf = np.array([len(geometry[key][1]) for _, key, _ in placed], dtype=np.int64)
    triangles = int(nf.sum())
    check_memory(triangles * _BYTES_PER_PLACED_TRIANGLE
                 + int(nv.sum()) * _BYTES_PER_PLACED_VERTEX,
                 f"{label} ({triangles:,} triangles with its {len(placed):,} instances placed)")
    v0 = np.concatenate(([0], np.cumsum(nv)))
    f0 = np.concatenate(([0], np.cumsum(nf)))
    vertices = np.empty((int(v0[-1]), 3), dtype=np.float64)
    faces = np.empty((int(f0[-1]), 3), dtype=np.int64)
    groups: dict = {}
    for i, (_, key, _) in enumerate(placed):
        groups.setdefault(key, []).append(i)
    for key, members in groups.items():
        v, f = geometry[key]
        chunk = max(1, _PLACE_CHUNK // max(1, 3 * len(v)))
        for a in range(0, len(members), chunk):
            sel = members[a:a + chunk]
            mats = np.stack([placed[i][2] for i in sel])
            with np.errstate(over="ignore", invalid="ignore"):
                vk = np.einsum("kij,nj->kni", mats[:, :3, :3], v) + mats[:, None, :3, 3]
            bad = ~np.isfinite(vk).all(axis=(1, 2))
            if bad.any():
                node = placed[sel[int(np.flatnonzero(bad)[0])]][0]
                raise InputError(f"{label}: node {node!r}: its transform places vertices "
                                 "beyond float64's range")
            for j, i in enumerate(sel):
                vertices[v0[i]:v0[i + 1]] = vk[j]
                faces[f0[i]:f0[i + 1]] = f + v0[i]
    return _occluder_mesh(vertices, faces, label, fmt, [name for name, _, _ in placed],
                          nf.tolist())


def _occluder_mesh(vertices: np.ndarray, faces: np.ndarray, label: str, fmt: str,
                   names: list[str], counts: list[int]) -> trimesh.Trimesh:
    if len(faces) == 0:
        raise InputError(f"{label}: the occluders hold no triangles")
    mesh = trimesh.Trimesh(vertices=np.ascontiguousarray(vertices, dtype=np.float64),
                           faces=np.ascontiguousarray(faces, dtype=np.int64), process=False)
    mesh.metadata.update({"name": label, "source_format": fmt, "object_names": list(names),
                          "object_triangles": [int(c) for c in counts]})
    return mesh


# ----------------------------------------------------------------------------- Godot binary


class _Reader:
    """Bounds-checked reads over a binary resource: its bytes, or an open file read only
    where its layout points (a file padded to gigabytes costs what it declares)."""

    def __init__(self, source: bytes | BinaryIO, label: str) -> None:
        if isinstance(source, (bytes, bytearray, memoryview)):
            self.size = len(source)
            source = io.BytesIO(source)
        else:
            self.size = os.fstat(source.fileno()).st_size
        self.file = source
        self.pos = 0
        self.end = "<"
        self.real = 4
        self.label = label

    def need(self, size: int, what: str) -> None:
        if size < 0 or self.pos + size > self.size:
            raise InputError(f"{self.label}: truncated Godot binary resource ({what} needs "
                             f"{size} bytes at offset {self.pos}, the file has "
                             f"{self.size})")

    def seek(self, pos: int) -> None:
        self.file.seek(pos)
        self.pos = pos

    def take(self, size: int, what: str) -> bytes:
        self.need(size, what)
        try:
            out = self.file.read(size)
        except OSError as exc:
            raise InputError(f"{self.label}: cannot read ({exc.strerror or exc})") from None
        if len(out) != size:
            raise InputError(f"{self.label}: the file shrank while being read")
        self.pos += size
        return out

    def u32(self, what: str) -> int:
        return struct.unpack(self.end + "I", self.take(4, what))[0]

    def u64(self, what: str) -> int:
        return struct.unpack(self.end + "Q", self.take(8, what))[0]

    def string(self, what: str) -> str:
        size = self.u32(what)
        if size > _MAX_STRING:
            raise InputError(f"{self.label}: {what}: a string of {size:,} bytes (at most "
                             f"{_MAX_STRING:,} read; a damaged file)")
        raw = self.take(size, what)
        try:
            return raw.split(b"\0", 1)[0].decode("utf-8")
        except UnicodeDecodeError:
            raise InputError(f"{self.label}: {what} is not UTF-8 text") from None

    def left(self) -> int:
        return self.size - self.pos

    def count(self, item_bytes: int, what: str) -> int:
        """An item count, refused when its items cannot fit in the bytes left."""
        n = self.u32(what)
        left = self.left()
        if n * item_bytes > left:
            raise InputError(f"{self.label}: {what}: {n} items of {item_bytes} bytes exceed "
                             f"the {left} bytes left in the file")
        return n

    def skip(self, size: int, what: str) -> None:
        self.need(size, what)
        self.seek(self.pos + size)

    def array(self, n: int, kind: str, item: int, what: str) -> np.ndarray:
        check_memory(n * item * _ARRAY_BYTES_PER_BYTE, f"{self.label} ({what}: {n:,} values)")
        raw = self.take(n * item, what)
        return np.frombuffer(raw, dtype=np.dtype(f"{self.end}{kind}{item}"))


def _skip_name(r: _Reader, strings: list[str], what: str) -> str:
    """A property or node-path name: a string-table index, or inline when the top bit is set."""
    idx = r.u32(what)
    if idx & 0x80000000:
        if idx & 0x7FFFFFFF > _MAX_STRING:
            raise InputError(f"{r.label}: {what}: a name of {idx & 0x7FFFFFFF:,} bytes (at "
                             f"most {_MAX_STRING:,} read; a damaged file)")
        raw = r.take(idx & 0x7FFFFFFF, what)
        return raw.split(b"\0", 1)[0].decode("utf-8", "replace")
    if idx >= len(strings):
        raise InputError(f"{r.label}: {what}: string index {idx} beyond the table of "
                         f"{len(strings)}")
    return strings[idx]


def _variant(r: _Reader, strings: list[str], what: str, depth: int = 0) -> object:
    """Read one variant: packed Vector3/Int32 arrays are returned, the rest skipped (None)."""
    if depth > _MAX_NESTING:
        raise InputError(f"{r.label}: {what}: containers nested deeper than {_MAX_NESTING}")
    at = r.pos
    kind = r.u32(what)
    if kind in (_V_NIL, _V_CALLABLE, _V_SIGNAL):
        return None
    if kind in (_V_BOOL, _V_INT, _V_RID):
        r.take(4, what)
    elif kind in (_V_INT64, _V_DOUBLE):
        r.take(8, what)
    elif kind == _V_FLOAT:
        r.take(r.real, what)
    elif kind in (_V_STRING, _V_STRING_NAME):
        r.skip(r.count(1, what), what)
    elif kind in _V_FIXED:
        reals, extra = _V_FIXED[kind]
        r.take(reals * r.real + extra, what)
    elif kind == _V_NODE_PATH:
        names = struct.unpack(r.end + "H", r.take(2, what))[0]
        subnames = struct.unpack(r.end + "H", r.take(2, what))[0] & 0x7FFF
        for _ in range(names + subnames):
            _skip_name(r, strings, what)
    elif kind == _V_OBJECT:
        obj = r.u32(what)
        if obj == 1:
            r.string(what)
            r.string(what)
        elif obj in (2, 3):
            r.take(4, what)
        elif obj != 0:
            raise InputError(f"{r.label}: {what}: unknown object reference kind {obj} at "
                             f"offset {at}")
    elif kind in (_V_ARRAY, _V_DICTIONARY):
        per = 2 if kind == _V_DICTIONARY else 1
        n = r.u32(what) & 0x7FFFFFFF
        if n * per * 4 > r.left():
            raise InputError(f"{r.label}: {what}: {n} items exceed the bytes left in the file")
        for _ in range(n * per):
            _variant(r, strings, what, depth + 1)
    elif kind == _V_PACKED_BYTE:
        n = r.count(1, what)
        r.skip(n + (-n) % 4, what)
    elif kind == _V_PACKED_STRING:
        n = r.count(4, what)
        for _ in range(n):
            r.skip(r.count(1, what), what)
    elif kind in _V_PACKED:
        reals, extra = _V_PACKED[kind]
        item = reals * r.real + extra
        n = r.count(item, what)
        if kind == _V_PACKED_VECTOR3:
            return r.array(n * 3, "f", r.real, what).astype(np.float64).reshape(-1, 3)
        if kind == _V_PACKED_INT32:
            return r.array(n, "i", 4, what).astype(np.int64)
        r.skip(n * item, what)
    else:
        raise InputError(f"{r.label}: {what}: unknown variant type {kind} at offset {at} "
                         "(corrupt file or a newer Godot format)")
    return None


def _load_occ(data: bytes | BinaryIO, label: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and indices of a binary ``ArrayOccluder3D`` resource (``RSRC``).

    ``data`` is the file's bytes or the open file. After the main resource, the
    file may hold Godot's closing ``RSRC`` and at most
    :data:`viscore.exchange.file_access.DECLARED_SLACK` bytes more: a file
    padded past that is refused (what its layout declares is all it holds).
    """
    r = _Reader(data, label)
    magic = r.take(4, "the header")
    if magic == b"RSCC":
        raise InputError(f"{label}: a compressed Godot binary resource (RSCC); save it "
                         "uncompressed or as .tres")
    if magic != b"RSRC":
        raise InputError(f"{label}: not a Godot binary resource (no RSRC header)")
    big_endian = r.u32("the header")
    r.u32("the header")  # "64 bits file", always 0
    r.end = ">" if big_endian else "<"
    major, minor, fmt = r.u32("the header"), r.u32("the header"), r.u32("the header")
    if major < 4:
        raise InputError(f"{label}: a Godot {major}.{minor} resource; {_OCCLUDER_TYPE} needs "
                         "Godot 4")
    if fmt not in BINARY_FORMATS:
        raise InputError(f"{label}: binary resource format {fmt} is not supported "
                         f"({BINARY_FORMATS.start}..{BINARY_FORMATS.stop - 1})")
    kind = r.string("the resource type")
    if kind != _OCCLUDER_TYPE:
        raise InputError(f"{label}: a Godot {kind or '?'} resource, not an {_OCCLUDER_TYPE}")
    r.u64("the header")  # import metadata offset
    flags = r.u32("the header")
    r.u64("the header")  # uid (present even when the UIDS flag is clear)
    if flags & _FLAG_HAS_SCRIPT_CLASS:
        r.string("the script class")
    r.real = 8 if flags & _FLAG_REAL_T_IS_DOUBLE else 4
    r.take(4 * _RESERVED_FIELDS, "the header")
    strings = [r.string("the string table") for _ in range(r.count(4, "the string table"))]
    for _ in range(r.count(8, "the external resources")):
        r.string("an external resource")
        r.string("an external resource")
        if flags & _FLAG_UIDS:
            r.u64("an external resource")
    n_internal = r.count(12, "the internal resources")
    offsets = []
    for _ in range(n_internal):
        r.string("an internal resource")
        offsets.append(r.u64("an internal resource"))
    if not offsets:
        raise InputError(f"{label}: the binary resource holds no resource")
    main = offsets[-1]  # the main resource is saved last
    if main >= r.size:
        raise InputError(f"{label}: the main resource's offset {main} is beyond the file's "
                         f"{r.size} bytes")
    r.seek(main)
    kind = r.string("the main resource")
    if kind != _OCCLUDER_TYPE:
        raise InputError(f"{label}: the main resource is a {kind or '?'}, not an "
                         f"{_OCCLUDER_TYPE}")
    found: dict[str, np.ndarray] = {}
    for _ in range(r.count(8, "the properties")):
        name = _skip_name(r, strings, "a property name")
        value = _variant(r, strings, f"property {name!r}")
        if name in ("vertices", "indices"):
            expect = np.float64 if name == "vertices" else np.int64
            if not isinstance(value, np.ndarray) or value.dtype != expect:
                array = "PackedVector3Array" if name == "vertices" else "PackedInt32Array"
                raise InputError(f"{label}: property {name!r} is not a {array}")
            found[name] = value
    if r.left() > len(_RSRC_END) + DECLARED_SLACK:
        raise InputError(f"{label}: {r.left():,} bytes after the main resource, which ends "
                         f"at byte {r.pos:,} (a padded or damaged file; not read)")
    vertices = found.get("vertices", np.zeros((0, 3)))
    indices = found.get("indices", np.zeros(0, dtype=np.int64))
    return _checked_geometry(vertices, indices, label, "the occluder")
