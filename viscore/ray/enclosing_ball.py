"""Smallest enclosing ball of a point set, flat and collinear sets included.

The orbit protocol (Silvennoinen et al. 2014 [2]_, sec. 6.1) centres its window on
the smallest sphere enclosing the original; Welzl's algorithm [1]_ finds it.

References
----------
.. [1] Welzl, E. "Smallest enclosing disks (balls and ellipsoids)". New Results
   and New Trends in Computer Science, LNCS 555, Springer, 1991, pp. 359-370.
   :DOI:`10.1007/BFb0038202`
.. [2] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
"""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError

from .._content_cache import ContentCache
from .._validate import as_points

__all__ = ["minimum_enclosing_ball"]

#: Singular values below this fraction of the largest one count as zero when
#: the affine dimension of a point set is decided (float64 coordinates that
#: lie on a plane up to rounding).
_FLAT_TOLERANCE = 1e-9

#: Welzl's algorithm is run on points in a deterministic random order.
_ORDER_SEED = 0


def minimum_enclosing_ball(points) -> tuple[np.ndarray, float]:
    """Centre and radius of the smallest ball that contains every point.

    Parameters
    ----------
    points : (n, 3) float
        World coordinates, n >= 1, finite.

    Returns
    -------
    center : (3,) float64
        World coordinates of the centre.
    radius : float
        World units; 0 for a single distinct point.

    Raises
    ------
    InputError
        If ``points`` is empty, not (n, 3), or not finite.

    Notes
    -----
    Point sets spanning three dimensions use ``trimesh.nsphere.minimum_nsphere``
    (so orbit windows of solid meshes are unchanged); planar and collinear sets
    are solved exactly in their affine hull after normalising the scale, so
    that a unit square at 1e-12 or 1e12 gives the same relative answer.

    Examples
    --------
    >>> c, r = minimum_enclosing_ball([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    >>> [round(float(v), 6) for v in c], round(r, 6)
    ([0.5, 0.5, 0.0], 0.707107)
    """
    pts = as_points(points, "points")  # refuses an empty set too
    center, radius = _BALLS.get((pts,), lambda: _ball(pts))
    return center.copy(), radius


#: Last balls by content: the orbit frame of one mesh is asked by every generation and
#: every scoring of the precision floor (seconds on a scan of a million vertices).
_BALLS = ContentCache(4)


def _ball(pts: np.ndarray) -> tuple[np.ndarray, float]:
    """:func:`minimum_enclosing_ball` of checked points."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    offset = 0.5 * (lo + hi)
    scale = float(np.max(hi - lo)) / 2
    if scale == 0.0:
        return offset, 0.0
    local = (pts - offset) / scale
    singular, basis = np.linalg.svd(local - local.mean(axis=0), full_matrices=False)[1:]
    rank = int(np.sum(singular > _FLAT_TOLERANCE * singular[0]))
    if rank == 3:
        try:
            center, radius = trimesh.nsphere.minimum_nsphere(pts)
        except (QhullError, ValueError):  # qhull gave up on a near-flat set: solved below
            center, radius = np.full(3, np.nan), np.nan
        center = np.asarray(center, dtype=np.float64)
        if np.all(np.isfinite(center)) and np.isfinite(radius):
            return center, float(radius)
    origin = local.mean(axis=0)
    frame = basis[:rank]
    coords = (local - origin) @ frame.T
    hull = _hull_vertices(coords)
    center_local, radius = _welzl(hull)
    center = origin + center_local @ frame
    # rounding in the projection: take the radius over the original points
    radius = max(radius, float(np.sqrt(np.max(np.sum((local - center) ** 2, axis=1)))))
    return offset + scale * center, scale * radius


def _hull_vertices(coords: np.ndarray) -> np.ndarray:
    """The convex hull's vertices of (n, k) points (the ball depends on no others)."""
    k = coords.shape[1]
    if k == 1:
        return np.array([coords.min(axis=0), coords.max(axis=0)])
    try:
        return coords[ConvexHull(coords).vertices]
    except (QhullError, ValueError):  # qhull refuses near-degenerate input: use every point
        return np.unique(coords, axis=0)


def _ball_through(boundary: list[np.ndarray]) -> tuple[np.ndarray, float]:
    """Smallest ball with every point of ``boundary`` on its surface."""
    p0 = boundary[0]
    if len(boundary) == 1:
        return p0, 0.0
    rows = np.array([p - p0 for p in boundary[1:]])
    gram = rows @ rows.T
    rhs = 0.5 * np.sum(rows**2, axis=1)
    coef = np.linalg.lstsq(gram, rhs, rcond=None)[0]
    center = p0 + coef @ rows
    return center, float(np.linalg.norm(center - p0))


def _welzl(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Welzl's minidisk in its recursive form (in random order), for k <= 3 dimensions."""
    order = np.random.default_rng(_ORDER_SEED).permutation(len(points))
    pts = [points[i] for i in order]
    slack = 1e-12

    def outside(p, ball):
        return np.linalg.norm(p - ball[0]) > ball[1] * (1 + slack) + slack

    def solve(subset, fixed):
        ball = _ball_through(fixed) if fixed else (subset[0], 0.0)
        if len(fixed) == points.shape[1] + 1:
            return ball
        for i, p in enumerate(subset):
            if not fixed and i == 0:
                continue
            if outside(p, ball):
                ball = solve(subset[:i], [*fixed, p])
        return ball

    return solve(pts, [])
