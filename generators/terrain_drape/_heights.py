"""The lowest surface of a mesh as a height field, sampled by vertical rays."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from viscore.ray.embree_scene import Scene

__all__ = ["HeightGrid", "lowest_surface", "LONG_FACTOR"]

#: At most this many times ``resolution`` points along the longer side (a footprint with
#: no width, a wall seen along the up axis, gets one row of them, not an unbounded one).
LONG_FACTOR = 32.0


@dataclass(frozen=True)
class HeightGrid:
    """Heights on a regular grid across the up axis.

    Attributes
    ----------
    up : int
        Index of the up axis; ``axes`` the two horizontal ones, in order.
    axes : tuple of int
    origin : (2,) float
        World coordinates (along ``axes``) of grid point (0, 0).
    spacing : float
        Distance between neighbouring grid points, world units.
    heights : (nx, ny) float64
        Height of the lowest surface above each point (``nan`` off the footprint).
    mask : (nx, ny) bool
        The footprint: points whose ray hit.
    """

    up: int
    axes: tuple[int, int]
    origin: np.ndarray
    spacing: float
    heights: np.ndarray
    mask: np.ndarray

    def points(self, ij: np.ndarray, z: np.ndarray) -> np.ndarray:
        """World points at fractional grid coordinates ``ij`` (n, 2) and heights ``z`` (n,)."""
        out = np.empty((len(ij), 3))
        out[:, self.axes[0]] = self.origin[0] + ij[:, 0] * self.spacing
        out[:, self.axes[1]] = self.origin[1] + ij[:, 1] * self.spacing
        out[:, self.up] = z
        return out


def lowest_surface(mesh: trimesh.Trimesh, up: int, resolution: int) -> HeightGrid:
    """Sample the lowest surface of ``mesh`` seen from below along axis ``up``.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    up : int
        0, 1 or 2.
    resolution : int
        Grid points along each side of a square footprint: about
        ``resolution^2`` points over the bounding box whatever its shape (a
        road 1000 x 1 at 192 gets 6 rows of 6,000), at most
        :data:`LONG_FACTOR` x ``resolution`` along its longer side.

    Returns
    -------
    HeightGrid

    Examples
    --------
    >>> sheet = trimesh.creation.box(extents=(4, 2, 1))
    >>> g = lowest_surface(sheet, 2, 9)
    >>> g.heights.shape, round(float(np.nanmax(g.heights)), 5)
    ((12, 7), -0.5)
    """
    lo, hi = np.asarray(mesh.bounds, dtype=np.float64)
    axes = tuple(int(a) for a in (0, 1, 2) if a != up)
    extent = hi[list(axes)] - lo[list(axes)]
    # about resolution^2 points over the box: a long narrow footprint (a road) gets rows
    # across it too, not one
    spacing = max(float(np.sqrt(extent[0] * extent[1])),
                  float(extent.max()) / LONG_FACTOR) / max(resolution - 1, 1)
    counts = np.maximum(np.round(extent / spacing).astype(int) + 1, 1)
    # centre the grid on the box so both rims are sampled alike
    origin = lo[list(axes)] + 0.5 * (extent - (counts - 1) * spacing)
    ii, jj = np.meshgrid(np.arange(counts[0]), np.arange(counts[1]), indexing="ij")
    start = lo[up] - 0.01 * max(float(hi[up] - lo[up]), spacing) - spacing
    grid = HeightGrid(up, axes, origin, spacing, np.empty(0), np.empty(0, bool))  # type: ignore[arg-type]
    o = grid.points(np.stack([ii.ravel(), jj.ravel()], 1).astype(np.float64),
                    np.full(ii.size, start))
    d = np.zeros(3)
    d[up] = 1.0
    t, _ = Scene.shared(mesh).first_hit(o, np.broadcast_to(d, o.shape))
    heights = (start + t).reshape(ii.shape)
    mask = np.isfinite(heights)
    heights[~mask] = np.nan
    return HeightGrid(up, axes, origin, spacing, heights, mask)  # type: ignore[arg-type]
