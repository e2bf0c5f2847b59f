"""Mesh validation: what a triangle soup must be for the ray-cast core to use it.

:func:`validate_mesh` refuses, with one :class:`~viscore.InputError`, a mesh
that is empty, has NaN or infinite coordinates, zero extent, or a scale
float32 ray tracing cannot hold, and drops degenerate faces with a count in
``mesh.metadata``. :func:`viscore.load_mesh` calls it on every file it reads.
"""

from __future__ import annotations

import logging

import numpy as np
import trimesh

from .._validate import InputError
from ..constants import DEGENERATE_AREA_RELATIVE

__all__ = ["validate_mesh"]

_log = logging.getLogger(__name__)

#: Largest coordinate magnitude and smallest bounding-box diagonal accepted,
#: world units. Inside the Scene every mesh is translated to its centre and
#: scaled to unit size, so Embree's float32 never sees these magnitudes; the
#: limits keep the float64 arithmetic of the metrics (areas ~ L^2, volumes
#: ~ L^3, products with counts) inside float64's normal range 1e-308..1e308
#: with margin, and keep subnormal (denormal) extents out.
_MAX_COORDINATE = 1e90
_MIN_DIAGONAL = 1e-90

#: Largest ratio of the farthest coordinate from the origin to the bounding-box
#: diagonal. World coordinates (mesh and ray origins) are float64: their
#: rounding, eps64 x |x| ~ 1.1e-16 x |x|, must stay below float32's relative
#: precision of the centred, unit-scaled scene (2^-24 ~ 6e-8 of its size), which
#: holds up to |x| / diagonal ~ 5e8; 1e8 leaves a factor of 5.
_MAX_OFFSET_RATIO = 1e8

#: Largest share of the non-degenerate faces that may be too small for float32
#: after the mesh is scaled to unit size (area below
#: ``DEGENERATE_AREA_RELATIVE`` x diagonal^2: a few float32 ulps, sides under
#: ~1e-7 of the mesh's extent, or needles whose height is): beyond it the mesh
#: is refused rather than reduced to a remnant (a model plus one vertex 1e30
#: away, whose faces all collapse). Below it they are dropped: slivers of a CAD
#: mesh, and the needles of a game map, 1.3% of the faces of a 12 km one.
_MAX_COLLAPSED_SHARE = 0.5

#: Share of the non-degenerate faces dropped as too small for float32 above which
#: the drop is said in a warning (under it, at debug level).
_WARN_COLLAPSED_SHARE = 0.01

def validate_mesh(mesh: trimesh.Trimesh, *, name: str = "mesh") -> trimesh.Trimesh:
    """Check a triangle soup and return a cleaned copy.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Any triangle mesh; open, non-manifold, flat and multi-component meshes
        are normal input, at any scale float32 ray tracing can hold after the
        :class:`~viscore.Scene` centres it and scales it to unit size.
    name : str, optional
        How the mesh is named in error messages (a file path, usually).

    Returns
    -------
    mesh : trimesh.Trimesh
        A new mesh without degenerate faces (repeated vertex indices, or an
        area below 1e-14 of the squared bounding-box diagonal: sides under
        ~1e-7 of the extent, which float32 cannot resolve) and unreferenced
        vertices; otherwise unchanged: no merging, no re-orientation,
        duplicated faces kept. ``metadata["dropped_degenerate_faces"]`` holds
        the count dropped.

    Raises
    ------
    InputError
        If the mesh has no faces, NaN or infinite coordinates, zero extent,
        or a scale float32 cannot hold: coordinates beyond 1e90 in magnitude,
        a diagonal below 1e-90 (subnormal coordinates included), a mesh
        farther from the origin than 1e8 x its own diagonal, or more than 1% of
        its faces below float32's resolution of its own extent (a far outlier
        vertex makes the rest of the mesh collapse); or if every face is
        degenerate.

    Notes
    -----
    Scale is free: a cube of side 1e-30 or 1e30 is valid, since ray queries are
    made on the centred, unit-scaled mesh and distances are scaled back
    (float32's error is relative). What is refused is a mesh float32 cannot
    hold relative to its own size.

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
    referenced = np.zeros(len(vertices), dtype=bool)
    referenced[faces.ravel()] = True
    used = vertices[referenced]
    if not np.isfinite(used).all():
        raise InputError(f"{name}: vertex coordinates contain NaN or infinite values")
    biggest = float(np.abs(used).max())
    if biggest > _MAX_COORDINATE:
        raise InputError(f"{name}: coordinates up to {biggest:.3g} exceed {_MAX_COORDINATE:.0e} "
                         "(areas and volumes would overflow float64); scale the mesh down")
    lo, hi = used.min(axis=0), used.max(axis=0)
    extent = hi - lo
    longest = float(extent.max())
    if longest <= 0:
        raise InputError(f"{name}: the mesh has zero extent (all vertices coincide)")
    diagonal = longest * float(np.linalg.norm(extent / longest))  # no under- or overflow
    if diagonal < _MIN_DIAGONAL:
        raise InputError(f"{name}: the mesh's extent {diagonal:.3g} is below {_MIN_DIAGONAL:.0e}"
                         " (its areas and volumes would underflow float64; subnormal "
                         "coordinates are refused too); scale the mesh up")
    if biggest > _MAX_OFFSET_RATIO * diagonal:
        raise InputError(
            f"{name}: the mesh (extent {diagonal:.3g}) lies {biggest:.3g} from the origin, "
            f"more than {_MAX_OFFSET_RATIO:.0e} x its extent: float64 coordinates there are "
            "too coarse for it; translate it towards the origin")
    # area relative to diagonal^2 from edge vectors (differences first, so that a
    # far-off mesh loses nothing more), scaled to unit size: no over- or underflow
    tri = vertices[faces]
    area = 0.5 * np.linalg.norm(np.cross((tri[:, 1] - tri[:, 0]) / diagonal,
                                         (tri[:, 2] - tri[:, 0]) / diagonal), axis=1)
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (
        faces[:, 0] == faces[:, 2])
    degenerate = repeated | (area == 0)
    too_small = ~degenerate & (area <= DEGENERATE_AREA_RELATIVE)
    real = int((~degenerate).sum())
    if real and too_small.sum() > _MAX_COLLAPSED_SHARE * real:
        raise InputError(
            f"{name}: {int(too_small.sum())} of {real} faces are smaller than float32 can "
            f"resolve at the mesh's extent {diagonal:.3g} (sides under ~1e-7 of it): the "
            "extent is dominated by far-away vertices; remove them or split the mesh")
    keep = ~degenerate & ~too_small
    dropped = int((~keep).sum())
    if real and too_small.sum() > _WARN_COLLAPSED_SHARE * real:
        _log.warning("%s: dropped %d of %d faces as smaller than float32 resolves at the "
                     "mesh's extent %.3g (slivers, or sides under ~1e-7 of it); they hide "
                     "nothing at that scale", name, int(too_small.sum()), real, diagonal)
    elif dropped:
        _log.debug("%s: dropped %d degenerate face(s) of %d", name, dropped, len(faces))
    if not keep.any():
        raise InputError(f"{name}: every face is degenerate (zero area)")
    kept = faces[keep]
    referenced[:] = False
    referenced[kept.ravel()] = True
    new_index = np.cumsum(referenced) - 1  # old vertex index -> new, for referenced ones
    clean = trimesh.Trimesh(vertices=vertices[referenced], faces=new_index[kept],
                            process=False)
    clean.metadata["name"] = name
    clean.metadata["dropped_degenerate_faces"] = dropped
    return clean
