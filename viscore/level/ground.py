"""The solid under open ground: height fields and open-bottomed buildings closed by a ground plane.

The flood fill of the planar-sections paper [1]_, sec. 4.1, reaches under an open
surface; the space between a ground plane and the surface above it closes it.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 4.1)
"""

from __future__ import annotations

import numbers

import numpy as np
import trimesh
from skimage.morphology import convex_hull_image

from .._validate import InputError
from ..voxel.grid import VoxelGrid

__all__ = ["ground_fill", "ground_share", "ground_layer", "guess_up", "UP_AXES"]

#: Axis names, in index order (the axes ``--up`` names).
UP_AXES = ("x", "y", "z")
#: Up guess: the mesh is clearly thinnest along an axis when its extent
#: there is under this fraction of the next smallest extent.
_THIN_LEVEL = 0.5
#: Up guess: net face area (signed normal component) along an axis, as a
#: share of the total area, from which that axis is taken as up.
_NET_AREA_SHARE = 0.05
#: Up guess of one object: a smaller net share suffices when no other axis comes near
#: (at least :data:`_NET_AREA_LEAD` times the next axis): the built-in chapel 1.9% along
#: z against 0.03%, the tower 0.26% against 0.01%.
_NET_AREA_SHARE_OBJECT = 0.002
_NET_AREA_LEAD = 4.0


def _axis(up: object) -> int:
    """Index of an up axis given as 0-2 or ``'x'``, ``'y'``, ``'z'`` (an optional ``+``)."""
    if isinstance(up, numbers.Integral) and not isinstance(up, bool) and 0 <= int(up) <= 2:
        return int(up)
    text = str(up).strip().lower().lstrip("+")
    if text not in UP_AXES:
        raise InputError(f"up: expected one of x, y, z, got {up!r}")
    return UP_AXES.index(text)


def ground_layer(grid: VoxelGrid, up: object, height: float) -> int:
    """Index along ``up`` of the lowest voxel layer whose centre is at or above ``height``.

    Examples
    --------
    >>> g = VoxelGrid(origin=np.zeros(3), pitch=1.0, shape=(4, 4, 4))
    >>> ground_layer(g, "z", 1.5), ground_layer(g, "z", 1.6), ground_layer(g, "z", -3.0)
    (1, 2, 0)
    """
    k = _axis(up)
    first = (float(height) - grid.origin[k]) / grid.pitch - 0.5
    return int(min(max(np.ceil(first - 1e-9), 0), grid.shape[k]))


def ground_fill(surface: np.ndarray, grid: VoxelGrid, *, up: object = "z",
                height: float) -> np.ndarray:
    """Voxels between the ground plane and the highest surface voxel of their column.

    Parameters
    ----------
    surface : grid.shape bool
        Surface voxels (:func:`viscore.voxelize`).
    grid : VoxelGrid
    up : {'x', 'y', 'z'} or int, optional
        The up axis (positive direction). Default ``'z'``.
    height : float
        Height of the ground plane along ``up``, world units: voxels whose
        centre lies below it are never filled.

    Returns
    -------
    grid.shape bool
        For each column along ``up`` that holds a surface voxel, every voxel
        from the ground layer (:func:`ground_layer`) to that column's highest
        surface voxel; nothing in columns without one.

    Examples
    --------
    >>> g = VoxelGrid(origin=np.zeros(3), pitch=1.0, shape=(1, 2, 5))
    >>> s = np.zeros(g.shape, bool); s[0, 0, 3] = True  # a roof over column 0, nothing over 1
    >>> ground_fill(s, g, up="z", height=1.0)[0].astype(int).tolist()
    [[0, 1, 1, 1, 0], [0, 0, 0, 0, 0]]
    """
    surface = np.asarray(surface, dtype=bool)
    if surface.shape != tuple(grid.shape):
        raise InputError(f"surface: expected the grid's shape {tuple(grid.shape)}, "
                         f"got {surface.shape}")
    k = _axis(up)
    column = np.moveaxis(surface, k, -1)
    n = column.shape[-1]
    any_hit = column.any(axis=-1)
    top = n - 1 - np.argmax(column[..., ::-1], axis=-1)  # highest surface voxel per column
    layers = np.arange(n)
    low = ground_layer(grid, k, height)
    fill = (layers >= low) & (layers <= top[..., None]) & any_hit[..., None]  # type: ignore[index]
    return np.ascontiguousarray(np.moveaxis(fill, -1, k))


def ground_share(surface: np.ndarray, up: object = "z") -> float:
    """Share of the surface's footprint that it covers from above.

    The footprint is the convex hull, across ``up``, of the columns that
    hold a surface voxel (:func:`skimage.morphology.convex_hull_image`); the
    share is the fraction of its columns that hold one. A height field
    covers its footprint (1.0 for the built-in terrain), a building its plan
    however it is turned, a ring or a diagonal pair of poles little of it.

    Examples
    --------
    >>> s = np.zeros((5, 5, 3), bool); s[:, :, 1] = True
    >>> ground_share(s, "z")
    1.0
    >>> s[1:4, 1:4] = False  # a ring: 16 of the 25 columns
    >>> ground_share(s, "z")
    0.64
    """
    covered = np.asarray(surface, dtype=bool).any(axis=_axis(up))
    if not covered.any():
        return 0.0
    hull = convex_hull_image(covered)
    return float(covered.sum() / max(int(hull.sum()), 1))


def guess_up(mesh: trimesh.Trimesh, *, level: bool = True) -> tuple[str, str]:
    """Guess the up axis of a mesh without a convention (OBJ, PLY, OFF, STL).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The level, in its own frame.
    level : bool, optional
        The mesh is a level (default), wider than tall: rule (1) below
        comes first. False for one object (a tower is taller than wide, a
        chapel longer than wide): rules (2) and (3) only, and (2) from a
        net area of 0.2 % when it is four times any other axis's.

    Returns
    -------
    axis : str
        ``'x'``, ``'y'`` or ``'z'``.
    reason : str
        One line saying which rule decided.

    Notes
    -----
    Rules in order: (1) the axis along which the level's bounding box is
    thinnest, when that extent is under half the next smallest (a map is
    wider than tall); (2) the axis of the largest net face area (area times
    the signed normal component, summed), when it is at least 5 % of the
    total area: open game geometry has roofs and ground facing up and no
    floor facing down (a closed mesh has no net area along any axis); (3)
    the axis most face area faces (absolute normal components). A guess, not
    a guarantee: pass ``up`` when the file's convention is known.

    Examples
    --------
    >>> import trimesh
    >>> guess_up(trimesh.creation.box(extents=(10, 1, 10)))[0]
    'y'
    """
    ext = np.asarray(mesh.extents, dtype=np.float64)
    order = np.argsort(ext, kind="stable")
    dims = " x ".join(f"{e:.3g}" for e in ext)
    what = "level" if level else "mesh"
    area = np.asarray(mesh.area_faces, dtype=np.float64)
    normals = np.asarray(mesh.face_normals, dtype=np.float64)
    net = np.abs(area @ normals)
    total = float(area.sum()) or 1.0
    k = int(np.argmax(net))
    thin = ext[order[0]] < _THIN_LEVEL * ext[order[1]]
    facing = net[k] >= _NET_AREA_SHARE * total or (not level and (
        net[k] >= _NET_AREA_SHARE_OBJECT * total
        and net[k] >= _NET_AREA_LEAD * np.sort(net)[-2]))
    if thin and level:
        axis = UP_AXES[int(order[0])]
        return axis, f"the {what} is thinnest along {axis} ({dims} world units)"
    if facing:
        axis = UP_AXES[k]
        return axis, (f"most net face area faces along {axis} ({100 * net[k] / total:.2g}% of the "
                      "area: open geometry facing up)")
    k = int(np.argmax(area @ np.abs(normals)))
    axis = UP_AXES[k]
    return axis, f"most face area faces along {axis} ({what} {dims} world units)"
