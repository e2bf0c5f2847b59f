"""Output helpers shared by the subcommands: JSON or text, atomic files, errors.

Files are written by the core's shared helpers (:func:`viscore._atomic.write_atomic`,
:func:`viscore._atomic.file_mode`) and meshes by :func:`viscore.mesh_io.save_mesh`.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from viscore.metrics.precision_recall import jsonable

from viscore._atomic import check_output_path, file_mode, write_atomic
from viscore.mesh_io import SAVE_FORMATS, mesh_format, save_mesh

__all__ = ["dumps", "emit", "check_output_path", "write_atomic", "file_mode", "check_mesh_path",
           "write_mesh", "parse_list", "check_output_folder"]


def dumps(document: dict) -> str:
    """JSON text of a result document; NaN and inf become null."""
    return json.dumps(jsonable(document), indent=2)


def emit(document: dict, as_json: bool, text: str) -> None:
    """Print the JSON document or the human-readable text on stdout."""
    print(dumps(document) if as_json else text)


#: Mesh formats the CLI writes (:data:`viscore.mesh_io.SAVE_FORMATS`).
MESH_FORMATS = SAVE_FORMATS


def check_mesh_path(path: str | os.PathLike) -> str:
    """The format of an output mesh path, checked before any work.

    Raises
    ------
    InputError
        For an unknown suffix (:func:`viscore.mesh_io.mesh_format`), or a path
        :func:`check_output_path` refuses (missing folder, a directory).
    """
    suffix = mesh_format(path)
    check_output_path(path)
    return suffix


def write_mesh(path: str | os.PathLike, mesh) -> None:
    """Export a mesh atomically in the format its suffix names (:func:`viscore.mesh_io.save_mesh`).

    OBJ, OFF and PLY keep float64 coordinates; STL and GLB (float32 by their
    specifications) refuse a mesh float32 cannot hold, with one line.
    """
    save_mesh(mesh, path, format=check_mesh_path(path))


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
