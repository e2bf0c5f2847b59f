"""Godot 4 text resources and scenes (``.tres``/``.tscn``) in and out.

Reads and writes ``ArrayOccluder3D`` resources [2]_ and scenes of
``OccluderInstance3D`` nodes [3]_ in Godot's text format [4]_.

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
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt
import trimesh

from .._validate import InputError
from .godot_binary import (
    _OCCLUDER_TYPE,
    _checked_geometry,
    _instances_mesh,
    _load_occ_file,
    _read_file,
)

__all__ = ["OccluderInstance", "tres_text", "tscn_text", "text_sections", "text_transform"]

#: Godot's text resource format versions read here (Godot 4 writes 3; 4 once a
#: PackedVector4Array is present).
TEXT_FORMATS = ("3", "4")
#: Characters Godot forbids in node names (``Node::validate_node_name``).
_INVALID_NODE_CHARS = '.:@/"%'
#: Largest float32, Godot's real_t.
_FLOAT32_MAX = float(np.finfo(np.float32).max)
#: Largest index a PackedInt32Array holds.
_INT32_MAX = 2**31 - 1
#: Sub-resource id: the class name, "_" and this many characters (as Godot's
#: ``Resource::generate_scene_unique_id``).
_ID_CHARS = 5
_ID_ALPHABET = "abcdefghijklmnopqrstuvwxyz0123456789"

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
        if "\\" not in value:
            return value[1:-1]
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
    counted, line = 0, 1  # line numbers counted on from the last section: linear in the text
    while True:
        pos = _SPACE.match(text, pos).end()  # type: ignore[union-attr]
        if pos >= n:
            break
        line += text.count("\n", counted, pos)
        counted = pos
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
    if np.abs(vals).max() > _FLOAT32_MAX:
        raise InputError(f"{label}: {what}: a value of {np.abs(vals).max():.3g}, beyond "
                         "float32's range (Godot stores transforms as float32)")
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
    sub = f"{label} -> {ref_path}"
    try:
        target = (folder / rel).resolve()
    except RuntimeError:  # pathlib's "Symlink loop"
        raise InputError(f"{sub}: a loop of symbolic links (node {node!r})") from None
    except OSError as exc:
        raise InputError(f"{sub}: cannot be reached ({exc.strerror or exc}; node "
                         f"{node!r})") from None
    if not target.is_relative_to(folder):
        raise InputError(f"{label}: node {node!r}: occluder path {ref_path!r} points outside "
                         "the scene's folder (refused)")
    suffix = target.suffix.lower()
    if suffix not in (".occ", ".res", ".tres"):
        raise InputError(f"{label}: node {node!r}: occluder {ref_path!r} is not an .occ, .res "
                         "or .tres file")
    if suffix == ".tres":
        return _load_tres(_read_file(target, sub), sub)
    return _load_occ_file(target, sub)


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
        chain: list = []  # from the node up to the first ancestor already known or the root
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
                local = _transform(node.props["transform"], label, f"node {name!r} transform")
                with np.errstate(over="ignore", invalid="ignore"):  # refused when placed
                    mat = mat @ local
            world[name] = mat
        return world[node_path]

    cache: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
    placed: list[tuple[str, tuple[str, str], np.ndarray]] = []
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
        placed.append((node_path, key, world_of(node_path, node_path)))
    if not placed:
        raise InputError(f"{label}: no OccluderInstance3D node holds an occluder")
    return _instances_mesh(cache, placed, label, "godot-tscn")  # type: ignore[arg-type]


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


def text_sections(data: bytes, label: str = "file") -> list[tuple[str, dict, dict]]:
    r"""The ``[tag attr=value ...]`` sections of a Godot text scene or resource.

    Returns
    -------
    list of (str, dict, dict)
        Per section in file order: its tag (``node``, ``ext_resource``, ...),
        its header attributes (strings unquoted) and its properties (raw text
        values, as ``Transform3D(...)``).

    Raises
    ------
    InputError
        On text that is not a Godot text file (one line naming ``label``).

    Examples
    --------
    >>> text_sections(b'[gd_scene format=3]\n[node name="A" type="Node3D"]\nlayers = 2\n')[1]
    ('node', {'name': 'A', 'type': 'Node3D'}, {'layers': '2'})
    """
    return [(s.tag, dict(s.attrs), dict(s.props)) for s in _parse_godot_text(data, label)]


def text_transform(value: str, label: str = "file", what: str = "transform") -> np.ndarray:
    """A ``Transform3D(basis rows, origin)`` text value as a (4, 4) float64 matrix.

    Godot writes the basis row by row, then the origin (``p -> B p + o``); the
    values are rounded to float32, Godot's ``real_t``.

    Examples
    --------
    >>> text_transform("Transform3D(1, 0, 0, 0, 1, 0, 0, 0, 1, 2, 3, 4)")[:3, 3].tolist()
    [2.0, 3.0, 4.0]
    """
    return _transform(value, label, what)


# ----------------------------------------------------------------------------- instances

#: Godot's default ``bake_mask`` of an ``OccluderInstance3D``: every layer.
GODOT_DEFAULT_MASK = 0xFFFFFFFF

__all__ += ["tscn_instances", "GODOT_DEFAULT_MASK"]


def tscn_instances(text: str, resource: str) -> dict:
    """Instances of one packed scene in a Godot 4 text scene, and its occluder nodes' settings.

    Parameters
    ----------
    text : str
        The ``.tscn`` text (``[node ...]`` sections whose ``parent`` paths
        start from the root, as Godot writes them).
    resource : str
        File name of the instanced scene (``room.glb``): nodes with
        ``instance=ExtResource(id)`` of an ``ext_resource`` whose path ends so.

    Returns
    -------
    dict
        ``names`` (list of str) and ``transforms`` ((n, 4, 4) float64, world
        transforms of the instances relative to the first
        ``OccluderInstance3D``, the frame its bake is in: Godot's
        ``OccluderInstance3D::_bake_node`` uses
        ``get_global_transform().affine_inverse() * mi->get_global_transform()``);
        ``occluder`` (its node name, ``bake_mask`` (default
        :data:`GODOT_DEFAULT_MASK`), whether the file sets it
        (``bake_mask_set``) and ``bake_simplification_distance``, None when
        unset) or None; ``mesh_nodes``: every ``MeshInstance3D`` section
        (name, parent, ``layers``, whether ``layers & bake_mask`` lets the
        bake take it).

    Raises
    ------
    InputError
        On text that is not a Godot text file, a node whose parent is not in
        the file (a node inside an instanced scene placing children of its
        own is fine: ``Rooms/Room/RedSphere``), a malformed transform, or a
        ``bake_mask``, ``bake_simplification_distance`` or ``layers`` that is
        not a number.

    Examples
    --------
    >>> scene = '''[gd_scene format=3]
    ... [ext_resource type="PackedScene" path="res://room.glb" id="1_r"]
    ... [node name="Root" type="Node3D"]
    ... [node name="Room" parent="." instance=ExtResource("1_r")]
    ... transform = Transform3D(1, 0, 0, 0, 1, 0, 0, 0, 1, 4, 0, 0)
    ... '''
    >>> found = tscn_instances(scene, "room.glb")
    >>> found["names"], found["transforms"][0, :3, 3].tolist(), found["occluder"]
    (['Room'], [4.0, 0.0, 0.0], None)
    """
    sections = text_sections(text.encode("utf-8"), "scene")
    ext_ids = {attrs.get("id", "") for tag, attrs, _ in sections if tag == "ext_resource"
               and attrs.get("path", "").endswith(resource)}
    local: dict[str, np.ndarray] = {}
    parent_of: dict[str, str | None] = {}
    order = []
    for tag, attrs, body in sections:
        if tag != "node":
            continue
        name, parent = attrs.get("name", ""), attrs.get("parent")
        path = "." if parent is None else name if parent == "." else f"{parent}/{name}"
        value = body.get("transform")
        local[path] = np.eye(4) if value is None else text_transform(value, "scene", path)
        parent_of[path] = None if parent is None else parent
        order.append((path, attrs, body))
    world: dict[str, np.ndarray] = {}

    def world_of(path: str) -> np.ndarray:
        chain = []  # the node, then its ancestors up to one already placed or the root
        current: str | None = path
        while current is not None and current not in world:
            if current not in local:
                raise InputError(f"scene: node {current!r} is not in the file")
            chain.append(current)
            current = parent_of[current]
        for node in reversed(chain):
            parent = parent_of[node]
            world[node] = local[node] if parent is None else world[parent] @ local[node]
        return world[path]

    occluder, base = None, np.eye(4)
    for path, attrs, body in order:
        if attrs.get("type") == "OccluderInstance3D" and occluder is None:
            mask = body.get("bake_mask")
            dist = body.get("bake_simplification_distance")
            try:
                distance = None if dist is None else float(dist)
                if mask is not None and not mask.isdigit():
                    raise ValueError(mask)
            except ValueError:
                raise InputError(f"scene: node {path!r}: bake_mask {mask!r} or "
                                 f"bake_simplification_distance {dist!r} is not a number"
                                 ) from None
            occluder = {"name": attrs.get("name", ""),
                        "bake_mask": GODOT_DEFAULT_MASK if mask is None else int(mask),
                        "bake_mask_set": mask is not None,
                        "bake_simplification_distance": distance}
            base = np.linalg.inv(world_of(path))
    mask = GODOT_DEFAULT_MASK if occluder is None else occluder["bake_mask"]
    names, mats, mesh_nodes = [], [], []
    for path, attrs, body in order:
        ref = _RESOURCE_REF.match(attrs.get("instance", "").strip())
        if ref and ref.group(1) == "Ext" and (
                ref.group(2) if ref.group(2) is not None else ref.group(3)) in ext_ids:
            names.append(attrs.get("name", ""))
            mats.append(base @ world_of(path))
        if attrs.get("type") == "MeshInstance3D":
            layers = body.get("layers")
            if layers is not None and not layers.isdigit():
                raise InputError(f"scene: node {path!r}: layers {layers!r} is not a number")
            layers = 1 if layers is None else int(layers)
            mesh_nodes.append({"name": attrs.get("name", ""), "parent": attrs.get("parent"),
                               "layers": layers, "in_bake_mask": bool(layers & mask)})
    return {"names": names, "transforms": np.array(mats).reshape(-1, 4, 4),
            "occluder": occluder, "mesh_nodes": mesh_nodes}
