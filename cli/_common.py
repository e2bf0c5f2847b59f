"""Output helpers shared by the subcommands: JSON or text, atomic files, errors."""

from __future__ import annotations

import io
import json
import math
import os
import stat
import sys
import tempfile
from pathlib import Path

import numpy as np


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, (np.bool_,)):
        return bool(value)
    if isinstance(value, Path):
        return str(value)
    return value


def dumps(document: dict) -> str:
    """JSON text of a result document; NaN and inf become null."""
    return json.dumps(_jsonable(document), indent=2)


def emit(document: dict, as_json: bool, text: str) -> None:
    """Print the JSON document or the human-readable text on stdout."""
    print(dumps(document) if as_json else text)


def _umask() -> int:
    """The process umask, read without changing it where Linux allows."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)  # pragma: no cover - not Linux: read by setting and restoring
    os.umask(mask)
    return mask


def check_output_path(path: str | os.PathLike) -> Path:
    """Refuse, before any work, an output file path that cannot be written.

    The folder must exist (it is never created: a typo must not silently make
    a tree) and be a folder, and the path must not be a directory.

    Raises
    ------
    InputError
        One line naming the path and the problem.
    """
    from viscore import InputError

    path = Path(path)
    parent = path.parent
    if path.name in ("", ".", ".."):
        raise InputError(f"{path}: expected a file name, got a folder")
    try:
        st = os.stat(parent)
    except FileNotFoundError:
        raise InputError(f"{path}: the folder {str(parent)!r} does not exist "
                         "(it is not created)") from None
    except NotADirectoryError:
        raise InputError(f"{path}: a component of the folder {str(parent)!r} is a file") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot reach the folder {str(parent)!r} "
                         f"({exc.strerror or exc})") from None
    if not stat.S_ISDIR(st.st_mode):
        raise InputError(f"{path}: {str(parent)!r} is not a folder")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, expected a file path")
    return path


def write_atomic(path: str | os.PathLike, data: bytes, *, parents: bool = False) -> None:
    """Write ``data`` to ``path`` through a temporary file and a rename.

    A killed process leaves either the old file or the new one, never half,
    and a failed write leaves nothing new at ``path``. The file gets the mode
    a plain ``open(path, "w")`` would give: an existing file keeps its mode, a
    new one gets ``0o666 & ~umask``.

    Parameters
    ----------
    path : path
        The output file.
    data : bytes
        Its whole content.
    parents : bool, optional
        Create missing parent folders (for folders the caller owns, such as a
        study's ``occluders/``). Default False: a missing folder is an error,
        never silently created.

    Raises
    ------
    InputError
        If the folder does not exist (and ``parents`` is False), or ``path``
        is a directory.
    OSError
        If writing fails (permissions, full disk); its ``filename`` is
        ``path``, never the internal temporary file.
    """
    path = Path(path)
    if parents:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, str(path.parent)) from None
    check_output_path(path)
    try:
        mode = stat.S_IMODE(os.stat(path).st_mode)
    except OSError:
        mode = 0o666 & ~_umask()
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        with os.fdopen(fd, "wb") as fh:
            os.fchmod(fh.fileno(), mode)
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:  # name the user's path, not the temporary file
        raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None
    finally:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
    try:  # make the rename durable; some filesystems cannot fsync a folder
        dir_fd = os.open(path.parent, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dir_fd)
    except OSError:
        pass
    finally:
        os.close(dir_fd)


def fail(message: str, code: int = 2) -> int:
    """One line on stderr; returns the exit code."""
    print(f"viscore: error: {message}", file=sys.stderr)
    return code


#: Mesh formats the CLI writes.
MESH_FORMATS = {"ply", "obj", "stl", "glb", "off"}


def check_mesh_path(path: str | os.PathLike) -> str:
    """The format of an output mesh path, checked before any work.

    Raises
    ------
    InputError
        For an unknown suffix, or a path :func:`check_output_path` refuses
        (missing folder, a directory).
    """
    from viscore import InputError

    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in MESH_FORMATS:
        raise InputError(f"{path}: unknown mesh format '.{suffix}'; use "
                         + ", ".join(f".{f}" for f in sorted(MESH_FORMATS)))
    check_output_path(path)
    return suffix


def _text_rows(prefix: str, rows: np.ndarray, fmt: str) -> str:
    """Rows of numbers as text lines, each ``prefix`` + the row formatted by ``fmt``."""
    buf = io.StringIO()
    np.savetxt(buf, rows, fmt=fmt, delimiter=" ", newline="\n", comments="")
    text = buf.getvalue()
    if not prefix:
        return text
    return "".join(prefix + line + "\n" for line in text.splitlines())


def _mesh_bytes(mesh, fmt: str, path) -> bytes:
    """File content of a mesh; float64 coordinates wherever the format allows.

    OBJ and OFF are written as text with 17 significant digits and PLY with
    ``double`` vertex properties, so they hold any mesh viscore accepts
    exactly (trimesh writes 8 fixed decimals or float32). STL and GLB store
    float32 by their specifications: a mesh float32 cannot hold (coordinates
    beyond its range, or an extent below its resolution at the mesh's
    position) is refused rather than written corrupted.
    """
    from viscore import InputError

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
        header = ("ply\nformat binary_little_endian 1.0\n"
                  f"element vertex {len(vertices)}\n"
                  "property double x\nproperty double y\nproperty double z\n"
                  f"element face {len(faces)}\n"
                  "property list uchar int vertex_indices\nend_header\n").encode()
        packed = np.empty(len(faces), dtype=[("n", "u1"), ("f", "<i4", (3,))])
        packed["n"] = 3
        packed["f"] = faces
        return header + vertices.astype("<f8").tobytes() + packed.tobytes()
    if len(vertices):
        with np.errstate(over="ignore"):
            v32 = vertices.astype(np.float32).astype(np.float64)
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        extent = float(np.max(hi - lo))
        if not np.isfinite(v32).all() or np.abs(v32 - vertices).max() > 2.0**-20 * extent:
            raise InputError(
                f"{path}: .{fmt} stores float32 coordinates, which cannot hold this mesh "
                f"(extent {extent:.3g}, coordinates up to {np.abs(vertices).max():.3g}); "
                "write .obj, .off or .ply (float64)")
    import trimesh

    data = trimesh.exchange.export.export_mesh(mesh, None, file_type=fmt)
    return data if isinstance(data, bytes) else data.encode()


def write_mesh(path: str | os.PathLike, mesh) -> None:
    """Export a mesh atomically in the format its suffix names.

    OBJ, OFF and PLY keep float64 coordinates; STL and GLB (float32 by their
    specifications) refuse a mesh float32 cannot hold, with one line.
    """
    write_atomic(path, _mesh_bytes(mesh, check_mesh_path(path), path))


def parse_list(text: str, kind: type, option: str) -> tuple:
    """Comma-separated positive numbers of an option, or InputError naming it."""
    from viscore import InputError

    try:
        values = tuple(kind(v) for v in str(text).split(",") if v.strip())
    except ValueError as exc:
        raise InputError(f"{option}: expected comma-separated numbers, got {text!r}") from exc
    if not values or min(values) <= 0:
        raise InputError(f"{option}: expected positive numbers, got {text!r}")
    return values
