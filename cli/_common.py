"""Output helpers shared by the subcommands: JSON or text, atomic files, errors."""

from __future__ import annotations

import json
import math
import os
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


def write_atomic(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and a rename.

    A killed process leaves either the old file or the new one, never half.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def fail(message: str, code: int = 2) -> int:
    """One line on stderr; returns the exit code."""
    print(f"viscore: error: {message}", file=sys.stderr)
    return code


#: Mesh formats the CLI writes.
MESH_FORMATS = {"ply", "obj", "stl", "glb", "off"}


def check_mesh_path(path: str | os.PathLike) -> str:
    """The format of an output mesh path, or InputError for an unknown suffix."""
    from viscore import InputError

    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in MESH_FORMATS:
        raise InputError(f"{path}: unknown mesh format '.{suffix}'; use "
                         + ", ".join(f".{f}" for f in sorted(MESH_FORMATS)))
    return suffix


def write_mesh(path: str | os.PathLike, mesh) -> None:
    """Export a trimesh mesh atomically in the format its suffix names."""
    import trimesh

    data = trimesh.exchange.export.export_mesh(mesh, None, file_type=check_mesh_path(path))
    write_atomic(path, data if isinstance(data, bytes) else data.encode())


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
