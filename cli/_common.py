"""Output helpers shared by the subcommands: JSON or text, atomic files, errors."""

from __future__ import annotations

import io
import json
import os
from pathlib import Path

import numpy as np
from viscore.metrics.precision_recall import jsonable

from viscore._atomic import check_output_path, write_atomic
from viscore.mesh_io import ply_bytes

__all__ = ["dumps", "emit", "check_output_path", "write_atomic", "check_mesh_path"]


def dumps(document: dict) -> str:
    """JSON text of a result document; NaN and inf become null."""
    return json.dumps(jsonable(document), indent=2)


def emit(document: dict, as_json: bool, text: str) -> None:
    """Print the JSON document or the human-readable text on stdout."""
    print(dumps(document) if as_json else text)


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
        return ply_bytes(mesh)
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


def check_output_folder(path: str | os.PathLike, option: str = "--out") -> Path:
    """An output folder, refused before any work unless files can be made in it.

    The folder may exist; if not, its parent must (only the last component is
    created, by the caller, at the end). Writability is probed by making and
    removing a temporary folder where the files will go: permission bits say
    nothing for root, nor for a read-only mount such as ``/proc``.

    Raises
    ------
    InputError
        One line naming the path and the problem.
    """
    import tempfile

    from viscore import InputError

    path = Path(path)
    if os.path.lexists(path):
        if not path.is_dir():
            raise InputError(f"{option} {path}: exists and is not a folder")
        where = path
    else:
        where = path.absolute().parent
        if not where.is_dir():
            raise InputError(f"{option} {path}: the folder {str(path.parent)!r} does not "
                             "exist (it is not created)")
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".viscore-", dir=where))
    except OSError as exc:
        raise InputError(f"{option} {path}: cannot write in {str(where)!r} "
                         f"({exc.strerror or exc})") from None
    return path
