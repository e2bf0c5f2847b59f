"""Mesh loading and validation: any file trimesh reads, as a triangle soup.

Input meshes are never assumed watertight, manifold, oriented or connected
(DESIGN.md, "The core"). What cannot be used at all is refused with one
:class:`~viscore.InputError` naming the file: no file, an unreadable or empty
file, NaN or infinite coordinates, zero extent. Degenerate faces are dropped
with a count in the log.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np
import trimesh

from ._validate import InputError
from .constants import DEGENERATE_AREA_RELATIVE

__all__ = ["load_mesh", "validate_mesh"]

_log = logging.getLogger(__name__)

#: Largest coordinate accepted: float32 holds ~3.4e38, and ray distances and
#: squared norms must stay finite, so leave many orders of margin.
_MAX_COORDINATE = 1e18


def validate_mesh(mesh: trimesh.Trimesh, *, name: str = "mesh") -> trimesh.Trimesh:
    """Check a triangle soup and return a cleaned copy.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Any triangle mesh; open, non-manifold and multi-component meshes are
        normal input.
    name : str, optional
        How the mesh is named in error messages (a file path, usually).

    Returns
    -------
    mesh : trimesh.Trimesh
        A new mesh without degenerate faces (zero area or repeated vertex
        indices) and unreferenced vertices; otherwise unchanged: no merging,
        no re-orientation, duplicated faces kept.

    Raises
    ------
    InputError
        If the mesh has no faces, NaN or infinite coordinates, coordinates
        beyond 1e18 (float32 ray tracing), zero extent, or no face left after
        dropping degenerate ones.

    Examples
    --------
    >>> import trimesh
    >>> len(validate_mesh(trimesh.creation.box()).faces)
    12
    """
    if not isinstance(mesh, trimesh.Trimesh):
        raise InputError(f"{name}: expected a triangle mesh, got {type(mesh).__name__}")
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if len(faces) == 0 or len(vertices) == 0:
        raise InputError(f"{name}: the mesh is empty (no triangles)")
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise InputError(f"{name}: faces must be triangles, got shape {faces.shape}")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise InputError(f"{name}: faces index vertices that do not exist")
    used = vertices[np.unique(faces)]
    if not np.isfinite(used).all():
        raise InputError(f"{name}: vertex coordinates contain NaN or infinite values")
    if np.abs(used).max() > _MAX_COORDINATE:
        raise InputError(f"{name}: coordinates up to {np.abs(used).max():.3g} exceed the "
                         f"{_MAX_COORDINATE:.0e} that Embree's float32 arithmetic can trace")
    extent = used.max(axis=0) - used.min(axis=0)
    diagonal = float(np.linalg.norm(extent))
    if diagonal <= 0:
        raise InputError(f"{name}: the mesh has zero extent (all vertices coincide)")
    tri = vertices[faces]
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (
        faces[:, 0] == faces[:, 2])
    keep = ~repeated & (0.5 * area2 > DEGENERATE_AREA_RELATIVE * diagonal**2)
    dropped = int((~keep).sum())
    if dropped:
        _log.info("%s: dropped %d degenerate face(s) of %d", name, dropped, len(faces))
    if not keep.any():
        raise InputError(f"{name}: every face is degenerate (zero area)")
    clean = trimesh.Trimesh(vertices=vertices, faces=faces[keep], process=False)
    clean.remove_unreferenced_vertices()
    clean.metadata["name"] = name
    clean.metadata["dropped_degenerate_faces"] = dropped
    return clean


def load_mesh(source: str | os.PathLike | trimesh.Trimesh) -> trimesh.Trimesh:
    """Load a mesh file, a built-in scene name or a mesh object, and validate it.

    Parameters
    ----------
    source : str, path or trimesh.Trimesh
        A file in any format trimesh reads (OBJ, PLY, STL, OFF, GLB, ...);
        multi-part scenes are concatenated into one triangle soup. A string
        that is not an existing path is looked up among the built-in scenes
        (:func:`viscore.scene_names`).

    Returns
    -------
    mesh : trimesh.Trimesh
        Validated as by :func:`validate_mesh`; ``mesh.metadata["name"]`` holds
        the file or scene name.

    Raises
    ------
    InputError
        If the file does not exist and is no built-in scene, cannot be parsed,
        holds no triangles, or fails :func:`validate_mesh`.

    Examples
    --------
    >>> mesh = load_mesh("box-with-hole")
    >>> bool(len(mesh.faces) > 12)
    True
    """
    if isinstance(source, trimesh.Trimesh):
        return validate_mesh(source, name=str(source.metadata.get("name", "mesh")))
    from .builtin_scenes import scene_names, scene_path

    path = Path(os.fspath(source))
    label = str(source)
    if not path.exists():
        if label in scene_names():
            path = scene_path(label)
        else:
            raise InputError(
                f"{label}: no such file, and not a built-in scene "
                f"(built-in: {', '.join(scene_names())})")
    if path.is_dir():
        raise InputError(f"{label}: is a directory, expected a mesh file")
    if path.stat().st_size == 0:
        raise InputError(f"{label}: the file is empty")
    try:
        loaded = trimesh.load(str(path), force="mesh", process=False)
    except Exception as exc:  # trimesh raises many types for malformed files
        raise InputError(f"{label}: cannot read mesh ({type(exc).__name__}: {exc})") from exc
    if not isinstance(loaded, trimesh.Trimesh) or len(getattr(loaded, "faces", [])) == 0:
        raise InputError(f"{label}: the file holds no triangles")
    return validate_mesh(loaded, name=label)
