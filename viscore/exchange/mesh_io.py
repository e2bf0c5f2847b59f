"""Mesh files in and out: any file trimesh reads, as a triangle soup, and every format we write."""

from __future__ import annotations

import codecs
import io
import logging
import os
import re
import stat
import zipfile
from pathlib import Path

import numpy as np
import trimesh

from .._validate import InputError, _human_bytes, check_memory
from .file_access import (
    PARSE_BYTES_PER_FILE_BYTE,
    FolderResolver,
    UriOutsideFolder,
    file_kind,
    read_regular,
    refuse_path,
)
from .file_access import trimesh_loading as _loading
from .gltf_scene import (
    _declared_buffers,
    _gltf_json,
    _node_hierarchy,
    check_gltf_geometry,
    instanced_triangles,
    world_transforms,
)
from .mesh_validation import validate_mesh

__all__ = ["load_mesh", "validate_mesh", "ply_bytes"]

_log = logging.getLogger(__name__)


#: Peak bytes of memory per byte of mesh file while it is parsed (see file_access).
_PARSE_BYTES_PER_FILE_BYTE = PARSE_BYTES_PER_FILE_BYTE

#: Bytes per triangle of a mesh held in memory with its vertices and the
#: copies that validation and scene concatenation make (faces 24 + vertices
#: up to 3 x 24 per triangle, x ~3 copies).
_BYTES_PER_TRIANGLE = 300

#: Extensions whose text is decoded here before parsing.
_TEXT_FORMATS = {"obj", "off"}

#: Archive extensions handled here (members are loaded by their own extensions).
_ARCHIVES = {"zip"}

# --------------------------------------------------------------------------- files
#: The helpers of :mod:`viscore.exchange.file_access` under the names the level loader
#: imports them by.
_refuse_path = refuse_path
_kind = file_kind


def _read_regular_file(path: Path, label: str) -> bytes:
    """The bytes of a regular mesh file, refused before reading when a parse of it
    would pass the memory limit (:func:`viscore.exchange.file_access.read_regular`)."""
    return read_regular(path, label, what="a mesh file",
                        bytes_per_byte=_PARSE_BYTES_PER_FILE_BYTE)


#: Share of a text's leading bytes whose pattern of NUL bytes marks it as BOM-less
#: UTF-16 or UTF-32 (ASCII text in those encodings: every 2nd or 4th byte is a
#: character, the others NUL).
_UTF_NUL_SHARE = 0.95
#: Leading bytes sampled for that test.
_UTF_SAMPLE = 4096


def _bomless_utf(data: bytes) -> str | None:
    """``'utf-32-le'``, ``'utf-32-be'``, ``'utf-16-le'``, ``'utf-16-be'`` or None.

    Mesh text files are ASCII numbers and keywords: in UTF-16 without a
    byte-order mark every other byte is NUL (the odd ones little-endian, the
    even ones big-endian), in UTF-32 three bytes of four.
    """
    sample = np.frombuffer(data[:_UTF_SAMPLE - _UTF_SAMPLE % 4], dtype=np.uint8)
    sample = sample[:len(sample) - len(sample) % 4]
    if len(sample) < 4:
        return None
    nul = sample.reshape(-1, 4) == 0
    share = nul.mean(axis=0)
    for codec, pattern in (("utf-32-le", (0, 1, 1, 1)), ("utf-32-be", (1, 1, 1, 0)),
                           ("utf-16-le", (0, 1, 0, 1)), ("utf-16-be", (1, 0, 1, 0))):
        expect = np.array(pattern, dtype=bool)
        if (share[expect] >= _UTF_NUL_SHARE).all() and (share[~expect] <= 1 - _UTF_NUL_SHARE).all():
            return codec
    return None


def _decode_text(data: bytes) -> str:
    """Text of a mesh file in any common encoding (see the module docstring)."""
    for bom, codec in ((codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"),
                       (codecs.BOM_UTF8, "utf-8-sig"), (codecs.BOM_UTF16_LE, "utf-16"),
                       (codecs.BOM_UTF16_BE, "utf-16")):
        if data.startswith(bom):
            try:
                return data.decode(codec)
            except UnicodeDecodeError:
                break
    codec = _bomless_utf(data) if b"\x00" in data[:_UTF_SAMPLE] else None
    if codec is not None:  # (its ASCII would pass for UTF-8, NULs and all)
        try:
            return data.decode(codec)
        except UnicodeDecodeError:
            pass
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        pass
    if b"\x00" in data[:4096]:  # BOM-less UTF-16/32
        try:
            from charset_normalizer import from_bytes
        except ImportError:  # pragma: no cover - it is a dependency
            from_bytes = None  # type: ignore[assignment]
        if from_bytes is not None:
            best = from_bytes(data[:65536]).best()
            if best is not None and best.encoding.startswith("utf_"):
                try:
                    return data.decode(best.encoding)
                except (UnicodeDecodeError, LookupError):
                    pass
    return data.decode("latin-1")  # every byte maps; ASCII numbers and keywords survive


#: Control characters that never occur in a text mesh file.
_BINARY_BYTES = re.compile(r"[\x00-\x08\x0e-\x1f\x7f]")


def _require_text(text: str, label: str, fmt: str) -> None:
    head = text[:65536]
    if len(_BINARY_BYTES.findall(head)) > 0.01 * max(1, len(head)):
        raise InputError(f"{label}: binary data, not a text {fmt} file")


#: An index (or number) 0 in an OBJ file; on a face or line element it is invalid
#: (OBJ counts from 1; trimesh would read it as -1, the last vertex).
_OBJ_ZERO_TOKEN = re.compile(r"[ \t/][+-]?0+(?=[\s/]|$)")
#: A face or line element of an OBJ file (the text's line ends made ``\n`` first).
_OBJ_ELEMENT = re.compile(r"^[ \t]*[fl][ \t][^\n]*", re.MULTILINE)
#: Most vertices of one OBJ face. Real files hold triangles, quads and n-gons of
#: a few hundred vertices (a disc's cap); a face line of millions of indices is
#: no polygon, and trimesh's reader spends gigabytes on one.
MAX_OBJ_FACE_VERTICES = 65_536


def _obj_zero_index(text: str) -> str | None:
    """The first face or line element of an OBJ text with an index 0, or None.

    One pass over the element lines (linear in the text; zeros on ``v`` lines
    are never looked at).
    """
    for line in _OBJ_ELEMENT.finditer(text):
        if _OBJ_ZERO_TOKEN.search(line.group()):
            return line.group().strip()
    return None


def _obj_face_census(payload: bytes) -> tuple[int, int, int]:
    """Triangles the faces of an OBJ text make as fans, its largest face's vertex count,
    and the 1-based line of that face; vectorised over the bytes (no Python loop per
    line, no list of tokens).
    """
    buf = np.frombuffer(payload, dtype=np.uint8)
    if not len(buf):
        return 0, 0, 0
    blank = (buf == ord(" ")) | (buf == ord("\t")) | (buf == ord("\n"))
    starts = np.flatnonzero(~blank & np.concatenate(([True], blank[:-1])))  # token starts
    if not len(starts):
        return 0, 0, 0
    line_ends = np.flatnonzero(buf == ord("\n"))
    line_of = np.searchsorted(line_ends, starts)  # 0-based line of each token (sorted)
    first = np.flatnonzero(np.diff(line_of, prepend=-1))  # each line's first token
    tokens = np.diff(first, append=len(starts))
    lines = line_of[first]
    head = starts[first]
    after = np.minimum(head + 1, len(buf) - 1)
    face = (buf[head] == ord("f")) & ((buf[after] == ord(" ")) | (buf[after] == ord("\t")))
    sizes = tokens[face] - 1
    if not len(sizes):
        return 0, 0, 0
    biggest = int(np.argmax(sizes))
    triangles = int(np.maximum(sizes - 2, 0).sum())
    return triangles, int(sizes[biggest]), int(lines[face][biggest]) + 1


def _check_obj_faces(payload: bytes, label: str) -> None:
    """Refuse, before trimesh parses it, an OBJ whose faces are too large or too many."""
    triangles, largest, line = _obj_face_census(payload)
    if largest > MAX_OBJ_FACE_VERTICES:
        raise InputError(f"{label}: line {line:,}: a face of {largest:,} vertices; viscore "
                         f"reads OBJ faces of up to {MAX_OBJ_FACE_VERTICES:,}")
    check_memory(triangles * _BYTES_PER_TRIANGLE, f"{label} ({triangles:,} triangles in "
                 "its faces)")


def _fan(polygons: list[np.ndarray]) -> np.ndarray:
    """Triangles of a list of polygons (vertex index arrays), as fans from the first vertex."""
    tris = []
    for k in sorted({len(p) for p in polygons}):
        block = np.array([p for p in polygons if len(p) == k], dtype=np.int64)
        for i in range(1, k - 1):
            tris.append(block[:, [0, i, i + 1]])
    return np.concatenate(tris) if tris else np.zeros((0, 3), dtype=np.int64)


def _parse_off(text: str, label: str) -> trimesh.Trimesh:
    """An OFF (or COFF/NOFF) file: header, counts, vertices, polygons."""
    lines = [t for t in (ln.split("#", 1)[0].split() for ln in text.splitlines()) if t]
    if not lines or not lines[0][0].upper().endswith("OFF"):
        raise InputError(f"{label}: not an OFF file (no OFF header)")
    if len(lines[0]) > 1 and lines[0][1].upper() == "BINARY":
        raise InputError(f"{label}: binary OFF is not supported; save it as text OFF")
    head, rest = (lines[0][1:], lines[1:]) if len(lines[0]) > 1 else (
        lines[1] if len(lines) > 1 else [], lines[2:])
    try:
        nv, nf = int(head[0]), int(head[1])
    except (IndexError, ValueError):
        raise InputError(f"{label}: not a valid OFF file (no vertex and face counts)") from None
    if nv < 0 or nf < 0:
        raise InputError(f"{label}: not a valid OFF file (negative counts {nv}, {nf})")
    if len(rest) < nv + nf:
        raise InputError(f"{label}: truncated OFF file ({nv} vertices and {nf} faces "
                         f"announced, {len(rest)} lines found)")
    try:
        vertices = np.array([t[:3] for t in rest[:nv]], dtype=np.float64).reshape(nv, 3)
        polygons = []
        for t in rest[nv:nv + nf]:
            k = int(t[0])
            if k < 0 or len(t) < k + 1:
                raise ValueError(f"face line {' '.join(t[:8])!r}")
            polygons.append(np.array(t[1:k + 1], dtype=np.int64))
    except ValueError as exc:
        raise InputError(f"{label}: not a valid OFF file ({exc})") from None
    faces = _fan([p for p in polygons if len(p) >= 3])
    if len(faces) and (faces.min() < 0 or faces.max() >= nv):
        raise InputError(f"{label}: OFF face indices outside 0..{nv - 1}")
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


def _describe_without_triangles(scene: trimesh.Scene) -> str:
    kinds = {}
    for g in scene.geometry.values():
        if isinstance(g, trimesh.PointCloud):
            key = f"{len(g.vertices)} points"
        elif isinstance(g, trimesh.Trimesh):
            continue
        else:  # Path2D / Path3D
            key = "lines"
        kinds[key] = True
    what = f" (only {', '.join(kinds)})" if kinds else ""
    return f"holds no triangles{what}"


def _scene_instances(scene: trimesh.Scene) -> list[tuple[trimesh.Trimesh, np.ndarray]]:
    """Each triangle mesh of a scene with the ``(k, 4, 4)`` transforms of its k instances."""
    transforms: dict = {}
    for node in scene.graph.nodes_geometry:
        matrix, geometry = scene.graph[node]
        transforms.setdefault(geometry, []).append(matrix)
    out = []
    for geometry, mats in transforms.items():
        g = scene.geometry.get(geometry)
        if isinstance(g, trimesh.Trimesh) and len(g.faces):
            out.append((g, np.asarray(mats, dtype=np.float64)))
    return out


def _bake(instances: list[tuple[trimesh.Trimesh, np.ndarray]]) -> trimesh.Trimesh:
    """One triangle soup with every instance transformed (vectorised per mesh)."""
    vertices, faces, base = [], [], 0
    for g, mats in instances:
        v = np.asarray(g.vertices, dtype=np.float64)
        f = np.asarray(g.faces, dtype=np.int64)
        k = len(mats)
        with np.errstate(all="ignore"):  # non-finite transforms are refused by validation
            vk = np.einsum("kij,nj->kni", mats[:, :3, :3], v) + mats[:, None, :3, 3]
        vertices.append(vk.reshape(-1, 3))
        faces.append((f[None] + (base + len(v) * np.arange(k))[:, None, None]).reshape(-1, 3))
        base += k * len(v)
    return trimesh.Trimesh(vertices=np.concatenate(vertices), faces=np.concatenate(faces),
                           process=False)


def _parse(data: bytes, fmt: str, label: str, resolver) -> trimesh.Trimesh:
    """Parse the bytes of one mesh file of format ``fmt`` into one triangle soup."""
    name = fmt.upper()
    if fmt == "off":
        text = _decode_text(data)
        _require_text(text, label, name)
        return _parse_off(text, label)
    payload = data
    if fmt == "obj":
        text = _decode_text(data)
        _require_text(text, label, name)
        # classic Mac line ends (a lone CR) too: trimesh splits lines at LF only
        text = text.replace("\r\n", "\n").replace("\r", "\n")
        line = _obj_zero_index(text)
        if line is not None:
            raise InputError(f"{label}: OBJ index 0 in {line[:60]!r} (OBJ indices start at 1)")
        payload = text.encode("utf-8")
        _check_obj_faces(payload, label)
    elif fmt == "stl":
        binary = len(data) >= 84 and len(data) == 84 + 50 * int.from_bytes(data[80:84], "little")
        if not binary:
            text = _decode_text(data)
            if not re.search(r"\bfacet\b", text[:65536], re.I) or _BINARY_BYTES.search(
                    text[:65536]):
                raise InputError(f"{label}: not an STL file (neither binary STL, whose size "
                                 "must be 84 + 50 x its triangle count, nor ASCII 'solid ... "
                                 "facet')")
            payload = text.encode("utf-8")
    elif fmt in ("gltf", "glb"):
        # the structure read and bounded as the level loader reads it, before trimesh
        header, layout = _gltf_json(data, fmt, label)
        check_gltf_geometry(header, layout, data, fmt, label)
        tree = _node_hierarchy(header, label)
        world_transforms(header, tree, label)  # every reachable node's transform checked
        triangles = instanced_triangles(header, tree)
        check_memory(triangles * _BYTES_PER_TRIANGLE,
                     f"{label} ({triangles:,} triangles with instances baked)")
        if isinstance(resolver, FolderResolver):
            resolver.declared.update(_declared_buffers(header))
    token = _loading.set(True)
    try:
        # only trimesh's parsing is wrapped: a failure in our own code below is a bug
        # (exit 3), not a malformed file
        try:
            scene = trimesh.load_scene(file_obj=io.BytesIO(payload), file_type=fmt,
                                       resolver=resolver, process=False)
        except InputError:
            raise
        except UriOutsideFolder as exc:
            raise InputError(f"{label}: the file it references, {exc.uri[:120]!r}, is outside "
                             "its folder (refused, not read)") from None
        except MemoryError:
            raise InputError(f"{label}: not enough memory to read this file") from None
        except FileNotFoundError as exc:  # an external buffer, texture or material
            missing = exc.filename or " ".join(str(exc).split())[:200]
            raise InputError(f"{label}: a file it references is missing ({missing})") from None
        except Exception as exc:  # noqa: BLE001 - trimesh raises many types on malformed files
            detail = " ".join(f"{type(exc).__name__}: {exc}".split())[:200]
            raise InputError(f"{label}: not a valid {name} file ({detail})") from None
        if isinstance(resolver, FolderResolver):
            resolver.raise_refusal()  # a material or texture trimesh skipped: refused
            for uri in resolver.outside:
                _log.warning("%s: %r is outside the folder of the file: not read, its texture "
                             "or material is skipped", label, uri[:120])
        instances = _scene_instances(scene)
        if not instances:
            raise InputError(f"{label}: {_describe_without_triangles(scene)}")
        triangles = sum(len(g.faces) * len(m) for g, m in instances)
        check_memory(triangles * _BYTES_PER_TRIANGLE,
                     f"{label} ({triangles:,} triangles with instances baked)")
        try:
            mesh = _bake(instances)
        except MemoryError:
            raise InputError(f"{label}: not enough memory to read this file") from None
    finally:
        _loading.reset(token)
    return mesh


def _parse_zip(data: bytes, label: str, readable: set[str]) -> trimesh.Trimesh:
    """Every mesh file in a ZIP archive, concatenated; sizes checked before inflating."""
    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
        infos = [i for i in archive.infolist() if not i.is_dir()]
    except Exception as exc:  # noqa: BLE001 - zipfile raises many types on damaged archives
        raise InputError(f"{label}: not a valid ZIP file ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())[:200]})") from None
    members = [i for i in infos if _suffix(i.filename) in readable - _ARCHIVES]
    if not members:
        raise InputError(f"{label}: the archive holds no mesh file (of {len(infos)} files)")
    inflated = sum(i.file_size for i in infos)
    check_memory(inflated * _PARSE_BYTES_PER_FILE_BYTE,
                 f"{label} (inflates to {_human_bytes(inflated)})")
    try:
        # zipfile never inflates a member beyond the size its directory entry declares
        files = {i.filename: io.BytesIO(archive.read(i)) for i in infos}
    except MemoryError:
        raise InputError(f"{label}: not enough memory to inflate the archive") from None
    except Exception as exc:  # noqa: BLE001 - zlib.error, EOFError, BadZipFile (CRC), ...
        raise InputError(f"{label}: damaged ZIP file ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())[:200]})") from None
    resolver = trimesh.resolvers.ZipResolver(files)
    meshes = [_parse(files[i.filename].getvalue(), _suffix(i.filename),
                     f"{label}:{i.filename}", resolver) for i in members]
    return meshes[0] if len(meshes) == 1 else trimesh.util.concatenate(meshes)  # type: ignore[return-value]


def _suffix(name: str) -> str:
    return Path(name).suffix.lower().lstrip(".")


def load_mesh(source: str | os.PathLike | trimesh.Trimesh) -> trimesh.Trimesh:
    """Load a mesh file, a built-in scene name or a mesh object, and validate it.

    Parameters
    ----------
    source : str, path or trimesh.Trimesh
        A regular file in a format trimesh reads, chosen by its extension
        (OBJ, PLY, STL, OFF, GLB, GLTF with its buffers beside it, a ZIP of
        those, ...). Scenes are baked into one triangle soup: every node's
        transform is applied and instanced meshes appear once per instance.
        A string that is not an existing path is looked up among the built-in
        scenes (:func:`viscore.scene_names`).

    Returns
    -------
    mesh : trimesh.Trimesh
        Validated as by :func:`validate_mesh`; ``mesh.metadata["name"]`` holds
        the file or scene name.

    Raises
    ------
    InputError
        One line naming the file, if the path does not exist (and is no
        built-in scene), is a dangling link, a directory, a FIFO, a device
        or otherwise not a regular file, cannot be read, is empty, has an
        extension no reader handles, is not a valid file of its format (OBJ
        index 0 and OBJ faces of more than :data:`MAX_OBJ_FACE_VERTICES`
        vertices included), references a file that is not a regular file, lies
        outside its folder or is longer than its referrer declares (a glTF
        buffer) or its content needs (an image), holds no triangles (a point
        cloud, lines only), its
        parsed size or a ZIP's inflated size exceeds the memory limit
        (:func:`viscore._validate.check_memory`), or it fails
        :func:`validate_mesh`.

    Examples
    --------
    >>> mesh = load_mesh("box-with-hole")
    >>> bool(len(mesh.faces) > 12)
    True
    """
    if isinstance(source, trimesh.Trimesh):
        return validate_mesh(source, name=str(source.metadata.get("name", "mesh")))
    from ..builtin_scenes import scene_names, scene_path

    try:
        path = Path(os.fspath(source))
    except TypeError:
        raise InputError(f"mesh: expected a file path, a scene name or a trimesh.Trimesh, "
                         f"got {type(source).__name__}") from None
    label = str(source)
    if not os.path.lexists(path):
        if label in scene_names():
            path = scene_path(label)
        else:
            try:
                os.stat(path)
            except FileNotFoundError:
                import difflib

                close = difflib.get_close_matches(Path(label).stem.replace("_", "-"),
                                                  scene_names(), n=1, cutoff=0.8)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise InputError(f"{label}: no such file, and not a built-in scene "
                                 f"(built-in: {', '.join(scene_names())}){hint}") from None
            except OSError as exc:  # a file used as a folder, a folder we may not enter
                raise _refuse_path(path, label, exc) from None
    readable = set(trimesh.available_formats()) | {"off"}
    fmt = _suffix(path.name)
    if fmt not in readable:
        try:
            st = os.stat(path)
        except OSError as exc:
            raise _refuse_path(path, label, exc) from None
        if not stat.S_ISREG(st.st_mode):
            raise InputError(f"{label}: {_kind(st.st_mode)}, expected a mesh file")
        known = ", ".join(f".{f}" for f in ("obj", "ply", "stl", "off", "glb", "gltf", "zip"))
        what = f"extension '.{fmt}'" if fmt else "no extension"
        raise InputError(f"{label}: {what}, so no known mesh format; use one of {known}, ...")
    data = _read_regular_file(path, label)
    if fmt in _ARCHIVES:
        mesh = _parse_zip(data, label, readable)
    else:
        mesh = _parse(data, fmt, label, FolderResolver(path, label))
    return validate_mesh(mesh, name=label)


def ply_bytes(mesh: trimesh.Trimesh) -> bytes:
    """Binary little-endian PLY of a triangle mesh with ``double`` vertex coordinates.

    trimesh writes PLY vertices as float32; this writer keeps every float64
    coordinate exactly, so an occluder read back is the one that was scored.

    Examples
    --------
    >>> box = trimesh.creation.box()
    >>> data = ply_bytes(box)
    >>> data.startswith(b"ply") and b"property double x" in data
    True
    >>> back = trimesh.load(trimesh.util.wrap_as_stream(data), file_type="ply", process=False)
    >>> bool(np.array_equal(back.vertices, box.vertices))
    True
    """
    vertices = np.asarray(mesh.vertices, dtype="<f8")
    faces = np.asarray(mesh.faces, dtype=np.int64)
    header = ("ply\nformat binary_little_endian 1.0\n"
              f"element vertex {len(vertices)}\n"
              "property double x\nproperty double y\nproperty double z\n"
              f"element face {len(faces)}\n"
              "property list uchar int vertex_indices\nend_header\n").encode()
    packed = np.empty(len(faces), dtype=[("n", "u1"), ("f", "<i4", (3,))])
    packed["n"] = 3
    packed["f"] = faces
    return header + vertices.tobytes() + packed.tobytes()


#: Mesh formats :func:`save_mesh` writes (file suffixes, lower case, no dot).
SAVE_FORMATS = frozenset({"ply", "obj", "stl", "glb", "off"})


def mesh_format(path: str | os.PathLike) -> str:
    """The format :func:`save_mesh` writes for ``path``: its suffix, checked.

    Raises
    ------
    InputError
        For a suffix that is not one of :data:`SAVE_FORMATS`.

    Examples
    --------
    >>> mesh_format("occluder.OBJ")
    'obj'
    """
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in SAVE_FORMATS:
        raise InputError(f"{path}: unknown mesh format '.{suffix}'; use "
                         + ", ".join(f".{f}" for f in sorted(SAVE_FORMATS)))
    return suffix


def _text_rows(prefix: str, rows: np.ndarray, fmt: str) -> str:
    """Rows of numbers as text lines, each ``prefix`` + the row formatted by ``fmt``."""
    buf = io.StringIO()
    np.savetxt(buf, rows, fmt=fmt, delimiter=" ", newline="\n", comments="")
    text = buf.getvalue()
    if not prefix:
        return text
    return "".join(prefix + line + "\n" for line in text.splitlines())


def mesh_bytes(mesh: trimesh.Trimesh, format: str, *, name: str | os.PathLike | None = None
               ) -> bytes:
    """File content of a triangle mesh; float64 coordinates wherever the format allows.

    OBJ and OFF are written as text with 17 significant digits and PLY with
    ``double`` vertex properties (:func:`ply_bytes`), so they hold any mesh
    viscore accepts exactly (trimesh writes 8 fixed decimals or float32). STL
    and GLB store float32 by their specifications (written by trimesh): a mesh
    float32 cannot hold (coordinates beyond its range, or an extent below its
    resolution at the mesh's position) is refused rather than written corrupted.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    format : {'ply', 'obj', 'off', 'stl', 'glb'}
    name : str or path-like, optional
        Named in the error message (the output file). Default ``'mesh'``.

    Raises
    ------
    InputError
        For an unknown format, or STL/GLB of a mesh float32 cannot hold.

    Examples
    --------
    >>> mesh_bytes(trimesh.creation.box(), "off").splitlines()[:2]
    [b'OFF', b'8 12 0']
    """
    fmt = str(format).lower()
    if fmt not in SAVE_FORMATS:
        raise InputError(f"format: expected one of {', '.join(sorted(SAVE_FORMATS))}, "
                         f"got {format!r}")
    name = "mesh" if name is None else name
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if fmt == "obj":
        text = _text_rows("v ", vertices, "%.17g") + _text_rows("f ", faces + 1, "%d")
        return text.encode()
    if fmt == "off":
        text = (f"OFF\n{len(vertices)} {len(faces)} 0\n" + _text_rows("", vertices, "%.17g")
                + _text_rows("3 ", faces, "%d"))
        return text.encode()
    if fmt == "ply":
        return ply_bytes(mesh)
    if len(vertices):
        with np.errstate(over="ignore"):
            v32 = vertices.astype(np.float32).astype(np.float64)
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        extent = float(np.max(hi - lo))
        if not np.isfinite(v32).all() or np.abs(v32 - vertices).max() > 2.0**-20 * extent:
            raise InputError(
                f"{name}: .{fmt} stores float32 coordinates, which cannot hold this mesh "
                f"(extent {extent:.3g}, coordinates up to {np.abs(vertices).max():.3g}); "
                "write .obj, .off or .ply (float64)")
    data = trimesh.exchange.export.export_mesh(mesh, None, file_type=fmt)
    if fmt == "glb":  # trimesh leaves bufferView.target out
        from .glb_targets import with_buffer_view_targets

        return with_buffer_view_targets(data)
    return data if isinstance(data, bytes) else data.encode()


def save_mesh(mesh: trimesh.Trimesh, path_or_file, *, format: str | None = None) -> None:
    """Write a triangle mesh as PLY (float64), OBJ, OFF, STL or GLB.

    A path is written atomically (:func:`viscore._atomic.write_atomic`: the
    old file or the new one, never half; its folder must exist); an open
    binary file gets the bytes of :func:`mesh_bytes`.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    path_or_file : str, path-like or binary file object
    format : str, optional
        One of :data:`SAVE_FORMATS`. Default: the path's suffix (required for
        a file object).

    Raises
    ------
    InputError
        Unknown format, a folder that does not exist, or STL/GLB of a mesh
        float32 cannot hold (see :func:`mesh_bytes`).

    Examples
    --------
    >>> buf = io.BytesIO()
    >>> save_mesh(trimesh.creation.box(), buf, format="obj")
    >>> buf.getvalue().count(b"\\nf ")
    12
    """
    from .._atomic import write_atomic

    if hasattr(path_or_file, "write"):
        if format is None:
            raise InputError("format: needed when writing to a file object")
        path_or_file.write(mesh_bytes(mesh, format))
        return
    fmt = mesh_format(path_or_file) if format is None else format
    write_atomic(path_or_file, mesh_bytes(mesh, fmt, name=path_or_file))
