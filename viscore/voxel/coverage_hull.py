"""Voxels that a mesh hides from every direction: its coverage hull, sampled.

Its points project inside the surface's own projection in every orthographic view:
the precision of the orbit protocol (Silvennoinen et al. 2014, sec. 6.1 [1]_), pointwise.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 6.1)
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from .._validate import InputError
from ..ray.cameras import camera_basis
from ..ray.samplers import directions_fibonacci
from .grid import VoxelGrid

__all__ = ["covered_voxels", "exposure", "exposed_count", "hull_directions", "HULL_DIRECTIONS",
           "PIXELS_PER_VOXEL", "MARGIN"]

#: Line directions tested by default (a half sphere of Fibonacci points plus the axes).
HULL_DIRECTIONS = 96

#: Coverage-image pixels per voxel side.
PIXELS_PER_VOXEL = 2

#: Covered radius around a voxel's centre, voxels: half a voxel, the reach of a slice's
#: pixel square past the centre it was sampled at. (Planar sections of the built-in
#: tower's ground fill, 64^3, 64 triangles, 128 orbit views, a voxel kept when at most
#: 10% of all directions expose it: a margin of 0.5 gives P 0.9945 R 0.973, the voxel's
#: whole projected radius, 0.87, gives 0.9951 / 0.839.)
MARGIN = 0.5


def hull_directions(n: int = HULL_DIRECTIONS) -> np.ndarray:
    """``n`` line directions: Fibonacci points of the upper half sphere, then the three axes.

    Examples
    --------
    >>> d = hull_directions(8)
    >>> d.shape, bool(np.allclose(np.linalg.norm(d, axis=1), 1)), bool((d[:, 2] >= 0).all())
    ((11, 3), True, True)
    """
    sphere = directions_fibonacci(2 * int(n))
    half = sphere[sphere[:, 2] >= 0][:n]
    return np.concatenate([half, np.eye(3)])


def covered_voxels(scene, grid: VoxelGrid, index: np.ndarray, *,
                   directions: np.ndarray | None = None, misses: float = 0.0,
                   margin: float = MARGIN) -> np.ndarray:
    """Which voxels the mesh of ``scene`` covers from every direction, or all but a share.

    Parameters
    ----------
    scene : viscore.Scene
        The mesh.
    grid : VoxelGrid
    index : (n, 3) int
        The voxels to test.
    directions : (k, 3) float, optional
        Line directions (default :func:`hull_directions`).
    misses : float, optional
        Share of the directions in which a voxel may be uncovered and still
        count, in [0, 1). Default 0: covered in every direction.
    margin : float, optional
        Radius around the voxel's centre, in voxels, that must be covered
        too (the coverage images are eroded by it). Default :data:`MARGIN`.

    Returns
    -------
    (n,) bool
        True where at most ``floor(misses * k)`` directions expose the voxel
        (:func:`exposure`).

    Examples
    --------
    >>> import trimesh
    >>> from viscore import Scene, voxelize
    >>> box = trimesh.creation.box(extents=(1, 1, 1))
    >>> grid = voxelize(box, resolution=8).grid
    >>> cells = np.array([[6, 6, 6], [6, 6, 0]])  # the centre, and one under the box
    >>> covered_voxels(Scene(box), grid, cells).tolist()
    [True, False]
    """
    if not 0 <= misses < 1:
        raise InputError(f"misses: expected a share in [0, 1), got {misses!r}")
    dirs = hull_directions() if directions is None else np.asarray(directions, np.float64)
    bits = exposure(scene, grid, index, directions=dirs, margin=margin)
    return exposed_count(bits, np.ones(len(dirs), bool)) <= math.floor(misses * len(dirs))


def exposure(scene, grid: VoxelGrid, index: np.ndarray, *,
             directions: np.ndarray | None = None, margin: float = MARGIN) -> np.ndarray:
    """Which line directions leave each voxel exposed.

    A voxel is exposed in a direction when its centre falls outside the
    mesh's orthographic coverage image in that direction (pixel = voxel /
    :data:`PIXELS_PER_VOXEL`, rays at the pixel centres) eroded by
    ``margin`` voxels.

    Parameters
    ----------
    scene : viscore.Scene
        The mesh.
    grid : VoxelGrid
    index : (n, 3) int
        The voxels to test.
    directions : (k, 3) float, optional
        Line directions (default :func:`hull_directions`).
    margin : float, optional
        Covered radius around each centre, voxels (default :data:`MARGIN`).

    Returns
    -------
    (n, ceil(k / 8)) uint8
        Bit j of row i (:func:`numpy.packbits` order) is set when direction j
        exposes voxel i.
    """
    index = np.asarray(index)
    if index.ndim != 2 or index.shape[1] != 3:
        raise InputError(f"index: expected (n, 3) voxel indices, got shape {index.shape}")
    dirs = hull_directions() if directions is None else np.asarray(directions, np.float64)
    centers = grid.centers(index)
    shape = np.asarray(grid.shape, dtype=np.float64)
    middle = np.asarray(grid.origin, dtype=np.float64) + 0.5 * shape * grid.pitch
    radius = 0.5 * grid.pitch * float(np.linalg.norm(shape)) + grid.pitch
    pixel = grid.pitch / PIXELS_PER_VOXEL
    side = int(math.ceil(2 * radius / pixel)) + 1
    erosion = int(math.ceil(margin * PIXELS_PER_VOXEL - 1e-9))
    structure = np.ones((2 * erosion + 1, 2 * erosion + 1), bool)
    steps = (np.arange(side) - 0.5 * (side - 1)) * pixel
    rows, cols = np.meshgrid(steps, steps, indexing="ij")
    bits = np.zeros((len(index), len(dirs)), bool)
    for k, d in enumerate(dirs):
        if len(index) == 0:
            break
        f, right, up = camera_basis(d)
        origins = (middle - f * radius) + cols.reshape(-1, 1) * right + rows.reshape(-1, 1) * up
        hit = scene.any_hit(origins, np.broadcast_to(f, origins.shape),
                            max_distance=2 * radius).reshape(side, side)
        inner = ndimage.binary_erosion(hit, structure=structure, border_value=0) if (
            erosion) else hit
        rel = centers - middle
        j = np.rint(rel @ right / pixel + 0.5 * (side - 1)).astype(np.int64)
        i = np.rint(rel @ up / pixel + 0.5 * (side - 1)).astype(np.int64)
        inside = (i >= 0) & (i < side) & (j >= 0) & (j < side)
        ok = np.zeros(len(index), bool)
        ok[inside] = inner[i[inside], j[inside]]
        bits[~ok, k] = True
    return np.packbits(bits, axis=1)


#: Set bits of each byte value.
_POPCOUNT = np.array([bin(i).count("1") for i in range(256)], dtype=np.int64)


def exposed_count(bits: np.ndarray, among: np.ndarray) -> np.ndarray:
    """How many of the directions flagged in ``among`` expose each voxel.

    Parameters
    ----------
    bits : (n, ceil(k / 8)) uint8
        :func:`exposure` of n voxels over k directions.
    among : (k,) bool
        The directions to count.

    Returns
    -------
    (n,) int64

    Examples
    --------
    >>> bits = np.packbits(np.array([[True, False, True], [False, False, True]]), axis=1)
    >>> exposed_count(bits, np.array([True, True, False])).tolist()
    [1, 0]
    """
    return _POPCOUNT[bits & np.packbits(np.asarray(among, bool))].sum(axis=1)
