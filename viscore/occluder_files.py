"""Engine occluder files in and out: Godot 4 occluders, ``-occonly`` glTF, any mesh.

An engine culls with its own occluders; to measure them beside ours they must
be read in world space, and ours must be written so that the engine uses them.
This module reads and writes the formats of the Godot 4 engine [1]_:

- text resources (``.tres``) whose main resource is an ``ArrayOccluder3D``
  [2]_ (``vertices = PackedVector3Array(...)``, ``indices =
  PackedInt32Array(...)``), and text scenes (``.tscn``) whose
  ``OccluderInstance3D`` nodes [3]_ hold such occluders as sub-resources (or
  as external ``.occ``/``.tres`` files beside the scene), placed by the
  ``transform`` of the node and of its ancestors [4]_;
- binary resources (``.occ``, the ``RSRC`` format of Godot's
  ``ResourceFormatSaverBinary`` [5]_), which is what Godot's occluder bake
  writes;
- glTF/GLB files whose nodes carry Godot's ``-occ``/``-occonly`` import
  suffix [6]_ (``-occonly``: the node becomes an occluder and is not drawn);
- any other mesh file :func:`viscore.load_mesh` reads, as one occluder.

Godot's text format stores a ``Transform3D`` as its 3x3 basis **row by row**
followed by the origin: ``Transform3D(xx, xy, xz, yx, yy, yz, zx, zy, zz, ox,
oy, oz)`` is the affine map ``p -> B @ p + o`` with ``B[0] = (xx, xy, xz)``
(Godot's ``Basis`` stores rows, ``Basis::xform`` dots each row with the
point). Godot stores geometry as float32 (``real_t``); values read here are
those float32 values widened to float64, and values written round-trip to
the same float32 values.

World axes: Godot and glTF are both +Y up, right-handed, so a scene written
here and its ``-occonly`` glTF place the same triangles at the same world
coordinates.

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

import hashlib
import io
import os
import re
import stat
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote

import numpy as np
import numpy.typing as npt
import trimesh

from ._validate import InputError

__all__ = ["OccluderInstance", "load_occluder", "tscn_text", "tres_text", "occonly_glb_bytes",
           "write_occluders"]

#: Godot's text resource format versions read here (Godot 4 writes 3; 4 once a
#: PackedVector4Array is present).
TEXT_FORMATS = ("3", "4")
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
#: Characters Godot forbids in node names (``Node::validate_node_name``).
_INVALID_NODE_CHARS = '.:@/"%'
#: Largest index a PackedInt32Array holds.
_INT32_MAX = 2**31 - 1
#: Sub-resource id: the class name, "_" and this many characters (as Godot's
#: ``Resource::generate_scene_unique_id``).
_ID_CHARS = 5
_ID_ALPHABET = "abcdefghijklmnopqrstuvwxyz0123456789"
_OCCLUDER_TYPE = "ArrayOccluder3D"

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
    """The bytes of a regular, non-empty file, or one-line :class:`InputError`."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise InputError(f"{label}: no such file") from None
    except OSError as exc:
        raise InputError(f"{label}: cannot reach the file ({exc.strerror or exc})") from None
    if stat.S_ISDIR(st.st_mode):
        raise InputError(f"{label}: is a directory, expected an occluder file")
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{label}: not a regular file, expected an occluder file")
    if st.st_size == 0:
        raise InputError(f"{label}: the file is empty")
    try:
        return path.read_bytes()
    except MemoryError:
        raise InputError(f"{label}: not enough memory to read this file") from None
    except OSError as exc:
        raise InputError(f"{label}: cannot read the file ({exc.strerror or exc})") from None


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


def _occluder_mesh(vertices: np.ndarray, faces: np.ndarray, label: str, fmt: str,
                   names: list[str], counts: list[int]) -> trimesh.Trimesh:
    if len(faces) == 0:
        raise InputError(f"{label}: the occluders hold no triangles")
    mesh = trimesh.Trimesh(vertices=np.ascontiguousarray(vertices, dtype=np.float64),
                           faces=np.ascontiguousarray(faces, dtype=np.int64), process=False)
    mesh.metadata.update({"name": label, "source_format": fmt, "object_names": list(names),
                          "object_triangles": [int(c) for c in counts]})
    return mesh


# ----------------------------------------------------------------------------- Godot text


@dataclass
class _Section:
    """One ``[tag attr=value ...]`` section of a Godot text file and its properties."""

    tag: str
    attrs: dict[str, str]
    line: int
    props: dict[str, str] = field(default_factory=dict)


_TOKEN = re.compile(r'"(?:[^"\\]|\\.)*"|[\[\](){}\n"]', re.DOTALL)
_SPACE = re.compile(r"[ \t\r\n\ufeff]*")
_ATTR = re.compile(r'([A-Za-z_][\w]*)\s*=\s*("(?:[^"\\]|\\.)*"|[A-Za-z_]\w*\([^)]*\)|[^\s\]]+)')
_RESOURCE_REF = re.compile(r'^(Sub|Ext)Resource\(\s*(?:"((?:[^"\\]|\\.)*)"|(\d+))\s*\)$')


def _unquote(value: str) -> str:
    if len(value) >= 2 and value[0] == '"' and value[-1] == '"':
        return re.sub(r"\\(.)", r"\1", value[1:-1])
    return value


def _scan(text: str, start: int, label: str, *, header: bool) -> int:
    """End of a header (just past its ``]``) or of a property value (its newline)."""
    depth = 0
    for m in _TOKEN.finditer(text, start):
        tok = m.group()
        if len(tok) > 1:  # a whole string literal
            continue
        if tok == '"':
            line = text.count("\n", 0, m.start()) + 1
            raise InputError(f"{label}: line {line}: unterminated string")
        if tok in "([{":
            depth += 1
        elif tok in ")]}":
            depth -= 1
            if depth < 0:
                if header and tok == "]":
                    return m.end()
                line = text.count("\n", 0, m.start()) + 1
                raise InputError(f"{label}: line {line}: unbalanced '{tok}'")
        elif depth == 0 and not header:  # newline outside brackets ends the value
            return m.start()
    if depth or header:
        line = text.count("\n", 0, start) + 1
        raise InputError(f"{label}: line {line}: unclosed bracket before the end of the file")
    return len(text)


def _parse_godot_text(data: bytes, label: str) -> list[_Section]:
    """Split a Godot text resource or scene into sections with raw property values."""
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{label}: not a Godot text file (not UTF-8 text)") from None
    sections: list[_Section] = []
    pos, n = 0, len(text)
    while True:
        pos = _SPACE.match(text, pos).end()
        if pos >= n:
            break
        line = text.count("\n", 0, pos) + 1
        if text[pos] == ";":  # comment line
            end = text.find("\n", pos)
            pos = n if end < 0 else end
            continue
        if text[pos] == "[":
            end = _scan(text, pos + 1, label, header=True)
            head = text[pos + 1:end - 1].strip()
            tag = head.split(None, 1)[0] if head else ""
            if not re.fullmatch(r"[A-Za-z_]\w*", tag):
                raise InputError(f"{label}: line {line}: not a section header: [{head[:60]}]")
            attrs = {k: _unquote(v) for k, v in _ATTR.findall(head[len(tag):])}
            sections.append(_Section(tag, attrs, line))
            pos = end
            continue
        eq = text.find("=", pos)
        nl = text.find("\n", pos)
        if eq < 0 or 0 <= nl < eq:
            raise InputError(f"{label}: line {line}: expected 'name = value' or a "
                             f"[section], got {text[pos:nl if nl >= 0 else n][:60]!r}")
        if not sections:
            raise InputError(f"{label}: line {line}: a property before any [section]")
        end = _scan(text, eq + 1, label, header=False)
        sections[-1].props[_unquote(text[pos:eq].strip())] = text[eq + 1:end].strip()
        pos = end
    if not sections:
        raise InputError(f"{label}: no [gd_resource] or [gd_scene] header (empty or not a "
                         "Godot text file)")
    return sections


def _call_body(value: str, ctor: str, label: str, what: str) -> str:
    m = re.fullmatch(rf"{ctor}\s*\((.*)\)", value.strip(), re.DOTALL)
    if m is None:
        raise InputError(f"{label}: {what}: expected {ctor}(...), got {value[:60]!r}")
    return m.group(1)


def _numbers(body: str, dtype: type, label: str, what: str) -> np.ndarray:
    body = body.strip()
    if not body:
        return np.zeros(0, dtype=dtype)
    try:
        return np.array(body.split(","), dtype=dtype)
    except (ValueError, OverflowError):
        raise InputError(f"{label}: {what}: not a list of numbers") from None


def _text_occluder(section: _Section, label: str, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and indices of an ``ArrayOccluder3D`` section (float32 values)."""
    props = section.props
    vertices = np.zeros(0)
    indices = np.zeros(0, dtype=np.int64)
    if "vertices" in props:
        body = _call_body(props["vertices"], "PackedVector3Array", label, f"{what} vertices")
        vertices = _numbers(body, np.float64, label, f"{what} vertices")
        if len(vertices) % 3:
            raise InputError(f"{label}: {what} vertices: {len(vertices)} numbers, not a "
                             "multiple of 3")
    if "indices" in props:
        body = _call_body(props["indices"], "PackedInt32Array", label, f"{what} indices")
        indices = _numbers(body, np.int64, label, f"{what} indices")
    if not np.isfinite(vertices).all():
        raise InputError(f"{label}: {what} has NaN or infinite vertex coordinates")
    with np.errstate(over="ignore"):
        vertices = vertices.astype(np.float32).astype(np.float64)  # Godot's real_t
    return _checked_geometry(vertices, indices, label, what)


def _transform(value: str, label: str, what: str) -> np.ndarray:
    """A ``Transform3D(basis rows, origin)`` text value as a (4, 4) float64 matrix."""
    vals = _numbers(_call_body(value, "Transform3D", label, what), np.float64, label, what)
    if len(vals) != 12:
        raise InputError(f"{label}: {what}: expected 12 numbers, got {len(vals)}")
    if not np.isfinite(vals).all():
        raise InputError(f"{label}: {what}: NaN or infinite values")
    mat = np.eye(4)
    mat[:3, :3] = vals[:9].astype(np.float32).reshape(3, 3)  # rows of Godot's Basis
    mat[:3, 3] = vals[9:].astype(np.float32)
    return mat


def _header(sections: list[_Section], tag: str, label: str) -> _Section:
    head = sections[0]
    if head.tag != tag:
        raise InputError(f"{label}: expected a [{tag}] header, got [{head.tag}]")
    fmt = head.attrs.get("format", "")
    if fmt not in TEXT_FORMATS:
        raise InputError(f"{label}: text format={fmt or '?'} is not Godot 4's "
                         f"(format={' or '.join(TEXT_FORMATS)})")
    return head


def _load_tres(data: bytes, label: str) -> tuple[np.ndarray, np.ndarray]:
    sections = _parse_godot_text(data, label)
    head = _header(sections, "gd_resource", label)
    kind = head.attrs.get("type", "?")
    if kind != _OCCLUDER_TYPE:
        raise InputError(f"{label}: a Godot {kind} resource, not an {_OCCLUDER_TYPE}")
    main = [s for s in sections if s.tag == "resource"]
    if not main:
        raise InputError(f"{label}: no [resource] section")
    return _text_occluder(main[-1], label, "the resource")


def _external_occluder(scene_path: Path, ref_path: str, label: str,
                       node: str) -> tuple[np.ndarray, np.ndarray]:
    """Follow an ExtResource occluder to a ``.occ``/``.tres`` file inside the scene's folder."""
    folder = scene_path.parent.resolve()
    rel = ref_path[len("res://"):] if ref_path.startswith("res://") else ref_path
    if not rel or "://" in rel or Path(rel).is_absolute() or re.match(r"^[A-Za-z]:", rel):
        raise InputError(f"{label}: node {node!r}: occluder path {ref_path!r} cannot be "
                         "resolved inside the scene's folder")
    target = (folder / rel).resolve()
    if not target.is_relative_to(folder):
        raise InputError(f"{label}: node {node!r}: occluder path {ref_path!r} points outside "
                         "the scene's folder (refused)")
    sub = f"{label} -> {ref_path}"
    suffix = target.suffix.lower()
    if suffix not in (".occ", ".res", ".tres"):
        raise InputError(f"{label}: node {node!r}: occluder {ref_path!r} is not an .occ, .res "
                         "or .tres file")
    raw = _read_file(target, sub)
    if suffix == ".tres":
        return _load_tres(raw, sub)
    return _load_occ(raw, sub)


def _load_tscn(data: bytes, path: Path, label: str) -> trimesh.Trimesh:
    sections = _parse_godot_text(data, label)
    _header(sections, "gd_scene", label)
    ext = {s.attrs.get("id", ""): s for s in sections if s.tag == "ext_resource"}
    sub = {s.attrs.get("id", ""): s for s in sections if s.tag == "sub_resource"}
    nodes = [s for s in sections if s.tag == "node"]
    if not nodes:
        raise InputError(f"{label}: the scene has no nodes")
    by_path: dict[str, _Section] = {}
    for k, node in enumerate(nodes):
        name = node.attrs.get("name", "")
        parent = node.attrs.get("parent")
        if k == 0 or parent is None:
            node_path = "."
        elif parent == ".":
            node_path = name
        else:
            node_path = f"{parent}/{name}"
        by_path[node_path] = node

    world: dict[str, np.ndarray] = {}

    def world_of(node_path: str, asked_by: str) -> np.ndarray:
        chain = []  # from the node up to the first ancestor already known or the root
        current: str | None = node_path
        while current is not None and current not in world:
            node = by_path.get(current)
            if node is None:
                raise InputError(f"{label}: node {asked_by!r}: its parent {current!r} is not "
                                 "in this file (inside an instanced scene?), so its transform "
                                 "is unknown")
            if len(chain) > len(by_path):
                raise InputError(f"{label}: node {asked_by!r}: its parent path loops")
            chain.append(current)
            parent = node.attrs.get("parent")
            top_level = node.props.get("top_level", "false").strip() == "true"
            parent_node = by_path.get(parent) if parent is not None else None
            if current == "." or top_level or (parent_node is not None
                                              and parent_node.attrs.get("type") == "Node"):
                current = None  # starts afresh: the root, top_level, or under a plain Node
            else:
                current = parent
        mat = np.eye(4) if current is None else world[current]
        for name in reversed(chain):
            node = by_path[name]
            if "transform" in node.props:
                mat = mat @ _transform(node.props["transform"], label,
                                       f"node {name!r} transform")
            world[name] = mat
        return world[node_path]

    cache: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
    parts_v, parts_f, names, counts = [], [], [], []
    offset = 0
    for node_path, node in by_path.items():
        if node.attrs.get("type") != "OccluderInstance3D" or "occluder" not in node.props:
            continue
        value = node.props["occluder"].strip()
        if value == "null":
            continue
        m = _RESOURCE_REF.match(value)
        if m is None:
            raise InputError(f"{label}: node {node_path!r}: occluder is not a SubResource or "
                             f"ExtResource reference ({value[:60]!r})")
        kind, ref = m.group(1), m.group(2) if m.group(2) is not None else m.group(3)
        key = (kind, ref)
        if key not in cache:
            if kind == "Sub":
                res = sub.get(ref)
                if res is None:
                    raise InputError(f"{label}: node {node_path!r} references sub-resource "
                                     f"{ref!r}, which the file does not define")
                if res.attrs.get("type") != _OCCLUDER_TYPE:
                    raise InputError(f"{label}: node {node_path!r}: occluder {ref!r} is a "
                                     f"{res.attrs.get('type', '?')}, not an {_OCCLUDER_TYPE}")
                cache[key] = _text_occluder(res, label, f"sub-resource {ref!r}")
            else:
                res = ext.get(ref)
                if res is None:
                    raise InputError(f"{label}: node {node_path!r} references external "
                                     f"resource {ref!r}, which the file does not declare")
                if res.attrs.get("type", _OCCLUDER_TYPE) != _OCCLUDER_TYPE:
                    raise InputError(f"{label}: node {node_path!r}: occluder {ref!r} is a "
                                     f"{res.attrs.get('type')}, not an {_OCCLUDER_TYPE}")
                cache[key] = _external_occluder(path, res.attrs.get("path", ""), label,
                                                node_path)
        vertices, faces = cache[key]
        mat = world_of(node_path, node_path)
        with np.errstate(over="ignore", invalid="ignore"):
            placed = vertices @ mat[:3, :3].T + mat[:3, 3]
        if not np.isfinite(placed).all():
            raise InputError(f"{label}: node {node_path!r}: its transform places vertices "
                             "beyond float64's range")
        parts_v.append(placed)
        parts_f.append(faces + offset)
        offset += len(vertices)
        names.append(node_path)
        counts.append(len(faces))
    if not names:
        raise InputError(f"{label}: no OccluderInstance3D node holds an occluder")
    return _occluder_mesh(np.concatenate(parts_v), np.concatenate(parts_f), label,
                          "godot-tscn", names, counts)


# ----------------------------------------------------------------------------- Godot binary


class _Reader:
    """Bounds-checked reads over the bytes of a binary resource."""

    def __init__(self, data: bytes, label: str) -> None:
        self.data = data
        self.pos = 0
        self.end = "<"
        self.real = 4
        self.label = label

    def need(self, size: int, what: str) -> None:
        if size < 0 or self.pos + size > len(self.data):
            raise InputError(f"{self.label}: truncated Godot binary resource ({what} needs "
                             f"{size} bytes at offset {self.pos}, the file has "
                             f"{len(self.data)})")

    def take(self, size: int, what: str) -> bytes:
        self.need(size, what)
        out = self.data[self.pos:self.pos + size]
        self.pos += size
        return out

    def u32(self, what: str) -> int:
        return struct.unpack(self.end + "I", self.take(4, what))[0]

    def u64(self, what: str) -> int:
        return struct.unpack(self.end + "Q", self.take(8, what))[0]

    def string(self, what: str) -> str:
        size = self.u32(what)
        raw = self.take(size, what)
        try:
            return raw.split(b"\0", 1)[0].decode("utf-8")
        except UnicodeDecodeError:
            raise InputError(f"{self.label}: {what} is not UTF-8 text") from None

    def count(self, item_bytes: int, what: str) -> int:
        """An item count, refused when its items cannot fit in the bytes left."""
        n = self.u32(what)
        left = len(self.data) - self.pos
        if n * item_bytes > left:
            raise InputError(f"{self.label}: {what}: {n} items of {item_bytes} bytes exceed "
                             f"the {left} bytes left in the file")
        return n

    def array(self, n: int, kind: str, item: int, what: str) -> np.ndarray:
        raw = self.take(n * item, what)
        return np.frombuffer(raw, dtype=np.dtype(f"{self.end}{kind}{item}"))


def _skip_name(r: _Reader, strings: list[str], what: str) -> str:
    """A property or node-path name: a string-table index, or inline when the top bit is set."""
    idx = r.u32(what)
    if idx & 0x80000000:
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
        r.string(what)
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
        if n * per * 4 > len(r.data) - r.pos:
            raise InputError(f"{r.label}: {what}: {n} items exceed the bytes left in the file")
        for _ in range(n * per):
            _variant(r, strings, what, depth + 1)
    elif kind == _V_PACKED_BYTE:
        n = r.count(1, what)
        r.take(n + (-n) % 4, what)
    elif kind == _V_PACKED_STRING:
        n = r.count(4, what)
        for _ in range(n):
            r.string(what)
    elif kind in _V_PACKED:
        reals, extra = _V_PACKED[kind]
        item = reals * r.real + extra
        n = r.count(item, what)
        if kind == _V_PACKED_VECTOR3:
            return r.array(n * 3, "f", r.real, what).astype(np.float64).reshape(-1, 3)
        if kind == _V_PACKED_INT32:
            return r.array(n, "i", 4, what).astype(np.int64)
        r.take(n * item, what)
    else:
        raise InputError(f"{r.label}: {what}: unknown variant type {kind} at offset {at} "
                         "(corrupt file or a newer Godot format)")
    return None


def _load_occ(data: bytes, label: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and indices of a binary ``ArrayOccluder3D`` resource (``RSRC``)."""
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
    if main >= len(data):
        raise InputError(f"{label}: the main resource's offset {main} is beyond the file's "
                         f"{len(data)} bytes")
    r.pos = main
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
    vertices = found.get("vertices", np.zeros((0, 3)))
    indices = found.get("indices", np.zeros(0, dtype=np.int64))
    return _checked_geometry(vertices, indices, label, "the occluder")


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
        with np.errstate(over="ignore", invalid="ignore"):
            placed = vertices @ mat[:3, :3].T + mat[:3, 3]
        if not np.isfinite(placed).all():
            raise InputError(f"{label}: node {name!r}: its transform places vertices beyond "
                             "float64's range")
        parts_v.append(placed)
        parts_f.append(faces + offset)
        offset += len(vertices)
        names.append(name)
        counts.append(len(faces))
    return _occluder_mesh(np.concatenate(parts_v), np.concatenate(parts_f), label,
                          f"{fmt}-occonly" if marked else fmt, names, counts)


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
        v, f = _load_occ(_read_file(p, label), label)
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


@dataclass(frozen=True)
class OccluderInstance:
    """One placed occluder: a node of an engine scene using a shared mesh.

    Parameters
    ----------
    name : str
        Object name; becomes the node name (characters Godot forbids in node
        names, ``. : @ / " %``, are replaced by ``_`` when writing).
    mesh_key : str
        Key of its local-space mesh in the ``meshes`` mapping given to the
        writers; instances sharing a key share one resource (instancing).
    transform : (4, 4) float64, optional
        Affine local-to-world matrix (world = ``T @ [p, 1]``), in world units;
        bottom row ``(0, 0, 0, 1)``. Default: identity.

    Raises
    ------
    InputError
        If ``name`` or ``mesh_key`` is not a non-empty string, or the
        transform is not a finite affine (4, 4) matrix.
    """

    name: str
    mesh_key: str
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        for label in ("name", "mesh_key"):
            value = getattr(self, label)
            if not isinstance(value, str) or not value.strip():
                raise InputError(f"OccluderInstance.{label}: expected a non-empty string, "
                                 f"got {value!r:.60}")
        try:
            mat = np.array(self.transform, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError(f"OccluderInstance {self.name!r}: transform: expected a (4, 4) "
                             "array of numbers") from None
        if mat.shape != (4, 4):
            raise InputError(f"OccluderInstance {self.name!r}: transform: expected shape "
                             f"(4, 4), got {mat.shape}")
        if not np.isfinite(mat).all():
            raise InputError(f"OccluderInstance {self.name!r}: transform has NaN or infinite "
                             "values")
        if not np.array_equal(mat[3], [0, 0, 0, 1]):
            raise InputError(f"OccluderInstance {self.name!r}: transform is not affine "
                             "(bottom row must be 0, 0, 0, 1)")
        mat.flags.writeable = False
        object.__setattr__(self, "transform", mat)


def _local_mesh(vertices: npt.ArrayLike, indices: npt.ArrayLike,
                what: str) -> tuple[np.ndarray, np.ndarray]:
    """Validated float32 vertices ``(n, 3)`` and int64 indices ``(3m,)``."""
    try:
        v = np.asarray(vertices, dtype=np.float64)
        i = np.asarray(indices)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected arrays of numbers") from None
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0:
        raise InputError(f"{what}: vertices: expected shape (n, 3) with n >= 1, got {v.shape}")
    if not np.isfinite(v).all():
        raise InputError(f"{what}: vertices contain NaN or infinite values")
    with np.errstate(over="ignore"):
        v32 = v.astype(np.float32)
    if not np.isfinite(v32).all():
        raise InputError(f"{what}: vertices beyond float32's range (Godot stores float32)")
    if i.size and not np.issubdtype(i.dtype, np.integer):
        if not np.issubdtype(i.dtype, np.floating) or not np.array_equal(i, np.round(i)):
            raise InputError(f"{what}: indices: expected integers")
    i = i.astype(np.int64).reshape(-1)
    if len(i) == 0 or len(i) % 3:
        raise InputError(f"{what}: indices: expected a positive multiple of 3, got {len(i)}")
    if i.min() < 0 or i.max() >= len(v):
        raise InputError(f"{what}: indices outside 0..{len(v) - 1}")
    if len(v) > _INT32_MAX:
        raise InputError(f"{what}: more vertices than a PackedInt32Array can index")
    return v32, i


def _float_texts(values: np.ndarray) -> list[str]:
    """float32 values as Godot-style text that parses back to the same float32.

    Shortest round-trip digits; integral values without ``.0`` and zero as
    ``0`` (as Godot's ``rtos_fix`` writes them inside vectors).
    """
    v32 = np.asarray(values, dtype=np.float32).ravel()
    out = []
    for x in v32:
        s = str(x)
        if s.endswith(".0"):
            s = s[:-2]
        out.append("0" if s == "-0" else s)
    if out:
        back = np.array(out, dtype=np.float64).astype(np.float32)
        for k in np.flatnonzero(back != v32):  # double rounding: write the exact value
            out[k] = repr(float(v32[k]))
    return out


def _packed_vector3(v32: np.ndarray) -> str:
    return f"PackedVector3Array({', '.join(_float_texts(v32))})"


def _packed_int32(indices: np.ndarray) -> str:
    return f"PackedInt32Array({', '.join(map(str, indices.tolist()))})"


def _transform_text(mat: np.ndarray) -> str:
    vals = np.concatenate([mat[:3, :3].reshape(-1), mat[:3, 3]])  # basis rows, then origin
    return f"Transform3D({', '.join(_float_texts(vals))})"


def _node_name(name: str) -> str:
    clean = "".join("_" if c in _INVALID_NODE_CHARS or ord(c) < 32 else c for c in name)
    return clean.strip() or "Occluder"


def _unique(names: Sequence[str]) -> list[str]:
    seen: set[str] = set()
    out = []
    for name in names:
        candidate, k = name, 2
        while candidate in seen:
            candidate, k = f"{name}_{k}", k + 1
        seen.add(candidate)
        out.append(candidate)
    return out


def _escape(text: str) -> str:
    return text.replace("\\", "\\\\").replace('"', '\\"')


def _checked_scene(instances: Sequence[OccluderInstance],
                   meshes: Mapping[str, tuple[npt.ArrayLike, npt.ArrayLike]]
                   ) -> tuple[list[OccluderInstance], dict[str, tuple[np.ndarray, np.ndarray]]]:
    instances = list(instances)
    if not instances:
        raise InputError("instances: expected at least one OccluderInstance, got none")
    used: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for inst in instances:
        if not isinstance(inst, OccluderInstance):
            raise InputError(f"instances: expected OccluderInstance items, got "
                             f"{type(inst).__name__}")
        if inst.mesh_key not in used:
            if inst.mesh_key not in meshes:
                raise InputError(f"instance {inst.name!r}: mesh_key {inst.mesh_key!r} is not "
                                 "in meshes")
            try:
                vertices, indices = meshes[inst.mesh_key]
            except (TypeError, ValueError):
                raise InputError(f"meshes[{inst.mesh_key!r}]: expected a (vertices, indices) "
                                 "pair") from None
            used[inst.mesh_key] = _local_mesh(vertices, indices, f"meshes[{inst.mesh_key!r}]")
    return instances, used


def _resource_id(key: str, taken: set[str]) -> str:
    digest = hashlib.sha256(key.encode("utf-8")).digest()
    n = int.from_bytes(digest, "big")
    chars = []
    while n:
        n, d = divmod(n, len(_ID_ALPHABET))
        chars.append(_ID_ALPHABET[d])
    base = "".join(chars)
    for size in range(_ID_CHARS, len(base) + 1):
        rid = f"{_OCCLUDER_TYPE}_{base[:size]}"
        if rid not in taken:
            taken.add(rid)
            return rid
    rid, k = f"{_OCCLUDER_TYPE}_{base}", 2  # pragma: no cover - a full 50-char collision
    while f"{rid}{k}" in taken:
        k += 1
    taken.add(f"{rid}{k}")
    return f"{rid}{k}"


def tres_text(vertices: npt.ArrayLike, indices: npt.ArrayLike) -> str:
    """A Godot 4 text resource (``.tres``) holding one ``ArrayOccluder3D``.

    Parameters
    ----------
    vertices : (n, 3) float
        Occluder vertices in world units (the space of the node that will use
        the resource).
    indices : (m, 3) or (3m,) int
        Triangle vertex indices.

    Returns
    -------
    text : str
        ``[gd_resource type="ArrayOccluder3D" format=3]`` and a ``[resource]``
        with ``vertices = PackedVector3Array(...)`` and ``indices =
        PackedInt32Array(...)``; floats round-trip to the same float32 values.

    Raises
    ------
    InputError
        If the vertices are not a finite (n, 3) array within float32's range,
        or the indices are not a positive multiple of 3 integers in range.

    Examples
    --------
    >>> print(tres_text([(0, 0, 0), (1, 0, 0), (0, 1, 0.5)], [0, 1, 2]))
    [gd_resource type="ArrayOccluder3D" format=3]
    <BLANKLINE>
    [resource]
    vertices = PackedVector3Array(0, 0, 0, 1, 0, 0, 0, 1, 0.5)
    indices = PackedInt32Array(0, 1, 2)
    <BLANKLINE>
    """
    v32, idx = _local_mesh(vertices, indices, "occluder")
    return (f'[gd_resource type="{_OCCLUDER_TYPE}" format=3]\n\n[resource]\n'
            f"vertices = {_packed_vector3(v32)}\nindices = {_packed_int32(idx)}\n")


def tscn_text(instances: Sequence[OccluderInstance],
              meshes: Mapping[str, tuple[npt.ArrayLike, npt.ArrayLike]], *,
              root_name: str = "Occluders") -> str:
    """A Godot 4 text scene (``.tscn``): one ``OccluderInstance3D`` per instance.

    Parameters
    ----------
    instances : sequence of OccluderInstance
        The placed occluders, in node order.
    meshes : mapping str -> (vertices, indices)
        Local-space mesh of each ``mesh_key``: vertices ``(n, 3)`` in local
        units, indices ``(m, 3)`` or ``(3m,)``.
    root_name : str, optional
        Name of the root ``Node3D``. Default ``"Occluders"``.

    Returns
    -------
    text : str
        ``[gd_scene format=3]``; one ``[sub_resource type="ArrayOccluder3D"
        id="ArrayOccluder3D_xxxxx"]`` per distinct mesh used, in local space
        and shared by all its instances; a root ``Node3D``; one
        ``OccluderInstance3D`` child per instance with ``transform =
        Transform3D(...)`` (omitted for the identity, as Godot omits
        defaults) and ``occluder = SubResource(...)``.

    Raises
    ------
    InputError
        If there are no instances, an instance's ``mesh_key`` is missing from
        ``meshes``, or a mesh fails the checks of :func:`tres_text`.

    Notes
    -----
    Deterministic: sub-resource ids derive from the mesh keys, so the same
    input gives the same file. Node names are made valid for Godot and
    unique (``name_2``, ...). No ``uid`` is written: Godot assigns one on
    import. The Godot 4.4+ header has no ``load_steps``; older 4.x read it
    without.

    Examples
    --------
    >>> quad = ([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [0, 1, 2, 0, 2, 3])
    >>> moved = np.eye(4)
    >>> moved[0, 3] = 2.0
    >>> text = tscn_text([OccluderInstance("a", "quad"), OccluderInstance("b", "quad", moved)],
    ...                  {"quad": quad})
    >>> text.count("[sub_resource"), text.count('type="OccluderInstance3D"')
    (1, 2)
    >>> print([line for line in text.splitlines() if line.startswith("transform")][0])
    transform = Transform3D(1, 0, 0, 0, 1, 0, 0, 0, 1, 2, 0, 0)
    """
    instances, used = _checked_scene(instances, meshes)
    taken: set[str] = set()
    ids = {key: _resource_id(key, taken) for key in used}
    out = ["[gd_scene format=3]", ""]
    for key, (v32, idx) in used.items():
        out += [f'[sub_resource type="{_OCCLUDER_TYPE}" id="{ids[key]}"]',
                f"vertices = {_packed_vector3(v32)}", f"indices = {_packed_int32(idx)}", ""]
    out += [f'[node name="{_escape(_node_name(root_name))}" type="Node3D"]', ""]
    names = _unique([_node_name(inst.name) for inst in instances])
    for inst, name in zip(instances, names, strict=True):
        out.append(f'[node name="{_escape(name)}" type="OccluderInstance3D" parent="."]')
        mat32 = inst.transform.astype(np.float32)
        if not np.array_equal(mat32, np.eye(4, dtype=np.float32)):
            out.append(f"transform = {_transform_text(mat32)}")
        out += [f'occluder = SubResource("{ids[inst.mesh_key]}")', ""]
    return "\n".join(out[:-1]) + "\n"


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
    from ._atomic import write_atomic

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
