"""Inside tests of points in triangle soups: parity votes, settled by winding numbers.

Ray-parity votes (:func:`viscore.points_inside_parity`) are the fast
stand-in for the winding number (DESIGN.md, "The core"); they fail where a
ray crosses coincident faces, as where two closed parts touch (a building
standing on a slab): the two faces at one distance count once. Where the six
votes disagree, :func:`points_inside` computes the generalized winding number
of Jacobson, Kavan and Sorkine-Hornung, "Robust inside-outside segmentation
using generalized winding numbers", ACM TOG 32(4), 2013 (the winding-number
voxelization of seed 001, sec. 3.1.2): the sum over triangles of the signed
solid angle (Van Oosterom and Strackee 1983) over 4 pi, which is 1 inside a
closed oriented surface, 0 outside, counts overlapping parts once each, and
degrades gracefully on open surfaces.
"""

from __future__ import annotations

import numba
import numpy as np

from ._validate import as_points

__all__ = ["winding_numbers", "points_inside"]

#: |w| at or above this is inside (Jacobson et al. 2013 threshold at 1/2).
WINDING_THRESHOLD = 0.5


@numba.njit(cache=True, parallel=True)
def _winding(points, tri):
    out = np.zeros(points.shape[0])
    for i in numba.prange(points.shape[0]):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        acc = 0.0
        for t in range(tri.shape[0]):
            ax, ay, az = tri[t, 0, 0] - px, tri[t, 0, 1] - py, tri[t, 0, 2] - pz
            bx, by, bz = tri[t, 1, 0] - px, tri[t, 1, 1] - py, tri[t, 1, 2] - pz
            cx, cy, cz = tri[t, 2, 0] - px, tri[t, 2, 1] - py, tri[t, 2, 2] - pz
            la = np.sqrt(ax * ax + ay * ay + az * az)
            lb = np.sqrt(bx * bx + by * by + bz * bz)
            lc = np.sqrt(cx * cx + cy * cy + cz * cz)
            det = (ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx)
                   + az * (bx * cy - by * cx))
            den = (la * lb * lc + (ax * bx + ay * by + az * bz) * lc
                   + (bx * cx + by * cy + bz * cz) * la + (cx * ax + cy * ay + cz * az) * lb)
            acc += 2.0 * np.arctan2(det, den)
        out[i] = acc / (4.0 * np.pi)
    return out


def winding_numbers(vertices: np.ndarray, faces: np.ndarray, points) -> np.ndarray:
    """Generalized winding number of each point with respect to a triangle soup.

    Parameters
    ----------
    vertices : (v, 3) float
    faces : (f, 3) int
    points : (n, 3) float

    Returns
    -------
    w : (n,) float64
        1 inside a closed outward-oriented surface, 0 outside, -1 inside an
        inward-oriented one; fractional near open surfaces. Cost n x f,
        spread over :func:`viscore.get_workers` threads.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box()
    >>> np.round(winding_numbers(box.vertices, box.faces, [[0, 0, 0], [2, 0, 0]]), 6).tolist()
    [1.0, 0.0]
    """
    from .scene import get_workers

    pts = as_points(points, "points", allow_empty=True)
    tri = np.ascontiguousarray(np.asarray(vertices, dtype=np.float64)[np.asarray(faces)])
    numba.set_num_threads(min(get_workers(), numba.config.NUMBA_NUM_THREADS))
    return _winding(np.ascontiguousarray(pts), tri)


def points_inside(scene, points) -> np.ndarray:
    """Inside test of points: unanimous parity votes, else the winding number.

    Parameters
    ----------
    scene : Scene
        Scene of the mesh (its vertices and faces give the winding number).
    points : (n, 3) float

    Returns
    -------
    inside : (n,) bool
        All six parity votes inside: True; none: False; otherwise
        |winding number| >= 1/2.
    """
    from .voxels import parity_votes

    pts = as_points(points, "points", allow_empty=True)
    votes = parity_votes(scene, pts)
    inside = votes == 6
    mixed = np.flatnonzero((votes > 0) & (votes < 6))
    if len(mixed):
        w = winding_numbers(scene.vertices, scene.faces, pts[mixed])
        inside[mixed] = np.abs(w) >= WINDING_THRESHOLD
    return inside
