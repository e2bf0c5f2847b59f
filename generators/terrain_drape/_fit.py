"""A few-triangle surface under a height field, by linear programming on a grid of quads."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
import scipy.sparse

__all__ = ["Drape", "fit_drape"]

#: Slack (height units) above which a triangle counts as not held by the shell.
SLACK_TOLERANCE = 1e-9
#: Rounds of drop-and-solve before giving up on a rectangle.
MAX_ROUNDS = 6


@dataclass(frozen=True)
class Drape:
    """A fitted drape in grid coordinates.

    Attributes
    ----------
    corners : (v, 2) float
        Quad corners, fractional grid coordinates.
    heights : (v,) float
        Heights at the corners.
    triangles : (t, 3) int
        The kept triangles (indices into ``corners``).
    samples : int
        Sample points under the kept triangles (their projected area in cells).
    """

    corners: np.ndarray
    heights: np.ndarray
    triangles: np.ndarray
    samples: int


def _layout(lo: np.ndarray, hi: np.ndarray, nx: int, ny: int):
    """Corners and triangles of ``nx`` x ``ny`` quads over the rectangle [lo, hi]."""
    u = np.linspace(lo[0], hi[0], nx + 1)
    v = np.linspace(lo[1], hi[1], ny + 1)
    corners = np.stack(np.meshgrid(u, v, indexing="ij"), -1).reshape(-1, 2)
    idx = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    # quad q -> triangles 2q (a, b, c) and 2q + 1 (a, c, d)
    triangles = np.stack([np.stack([a, b, c], 1), np.stack([a, c, d], 1)], 1).reshape(-1, 3)
    return corners, triangles


def _samples_in(lo, hi, nx, ny, shape):
    """Grid points in the rectangle: their triangle and barycentric corner weights."""
    i = np.arange(int(np.ceil(lo[0])), int(np.floor(hi[0])) + 1)
    j = np.arange(int(np.ceil(lo[1])), int(np.floor(hi[1])) + 1)
    i = i[(i >= 0) & (i < shape[0])]
    j = j[(j >= 0) & (j < shape[1])]
    ii, jj = (a.ravel() for a in np.meshgrid(i, j, indexing="ij"))
    wx = (hi[0] - lo[0]) / nx
    wy = (hi[1] - lo[1]) / ny
    fx = (ii - lo[0]) / wx
    fy = (jj - lo[1]) / wy
    qx = np.clip(np.floor(fx).astype(int), 0, nx - 1)
    qy = np.clip(np.floor(fy).astype(int), 0, ny - 1)
    s, t = fx - qx, fy - qy
    lower = s >= t  # triangle (a, b, c) of the quad
    tri = 2 * (qx * ny + qy) + (~lower)
    # weights on the triangle's own corners, in its (a, b, c) / (a, c, d) order
    w = np.where(lower[:, None], np.stack([1 - s, s - t, t], 1),
                 np.stack([1 - t, s, t - s], 1))
    return ii, jj, tri, w


def _solve(rows_tri, w, corner_of, low, high, keep, n_corners, elastic):
    """One LP over the samples of the kept triangles; returns (heights, slack) or None."""
    sel = keep[rows_tri]
    tri, w, lo_b, hi_b = rows_tri[sel], w[sel], low[sel], high[sel]
    cols = corner_of[tri]  # (m, 3)
    m = len(tri)
    if m == 0:
        return None
    kept = np.flatnonzero(keep)
    slot = np.full(len(keep), -1)
    slot[kept] = np.arange(len(kept))
    n_slack = len(kept) if elastic else 0
    rows = np.repeat(np.arange(m), 3)
    f = scipy.sparse.csr_matrix((w.ravel(), (rows, cols.ravel())), shape=(m, n_corners))
    bounded = np.isfinite(lo_b)  # a lower bound of -inf is no bound
    if elastic:
        s = scipy.sparse.csr_matrix((np.ones(m), (np.arange(m), slot[tri])),
                                    shape=(m, n_slack))
        a_ub = scipy.sparse.vstack([scipy.sparse.hstack([f, -s]),
                                    scipy.sparse.hstack([-f, -s])[bounded]]).tocsr()
        counts = np.bincount(slot[tri], minlength=n_slack).astype(np.float64)
        cost = np.concatenate([np.zeros(n_corners), counts])
    else:
        a_ub = scipy.sparse.vstack([f, (-f)[bounded]]).tocsr()
        used = np.zeros(n_corners)
        np.add.at(used, cols.ravel(), w.ravel())
        cost = -used / max(m, 1)
    b_ub = np.concatenate([hi_b, -lo_b[bounded]])
    bounds = [(None, None)] * n_corners + [(0, None)] * n_slack
    res = scipy.optimize.linprog(cost, A_ub=a_ub, b_ub=b_ub, bounds=bounds, method="highs")
    if res.status != 0:
        return None
    x = res.x
    slack = np.zeros(len(keep))
    if elastic:
        slack[kept] = x[n_corners:]
    return x[:n_corners], slack


def fit_drape(low: np.ndarray, high: np.ndarray, lo: np.ndarray, hi: np.ndarray,
              nx: int, ny: int) -> Drape | None:
    """Fit ``nx`` x ``ny`` quads over the rectangle ``[lo, hi]`` (grid coordinates) into the shell.

    Parameters
    ----------
    low, high : (gx, gy) float
        Bounds at the grid points; ``low = -inf`` is no lower bound (the
        drape is then the highest under ``high``). A point with ``low >=
        high`` or ``high`` not finite (off the footprint) holds nothing, and
        a triangle over it is dropped.
    lo, hi : (2,) float
        The rectangle, fractional grid coordinates.
    nx, ny : int
        Quads along each side.

    Returns
    -------
    Drape or None
        None when no triangle can be held.

    Examples
    --------
    A shell 0.1 thick around the plane ``z = i``: the drape is that plane.

    >>> i = np.arange(11.0)[:, None] + np.zeros((1, 11))
    >>> d = fit_drape(i - 0.05, i + 0.05, np.array([0., 0.]), np.array([10., 10.]), 2, 2)
    >>> len(d.triangles), bool(np.allclose(d.heights, d.corners[:, 0], atol=0.05))
    (8, True)
    """
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    corners, triangles = _layout(lo, hi, nx, ny)
    ii, jj, tri, w = _samples_in(lo, hi, nx, ny, low.shape)
    if len(ii) == 0:
        return None
    lo_b, hi_b = low[ii, jj], high[ii, jj]
    dead = ~(np.isfinite(hi_b) & (lo_b < hi_b))  # lo_b may be -inf: no lower bound
    keep = np.ones(len(triangles), bool)
    keep[np.unique(tri[dead])] = False
    live = ~dead
    tri, w, lo_b, hi_b = tri[live], w[live], lo_b[live], hi_b[live]
    # a triangle with no sample inside it cannot be checked: drop it
    keep &= np.bincount(tri, minlength=len(triangles)) > 0
    for _ in range(MAX_ROUNDS):
        if not keep.any():
            return None
        hard = _solve(tri, w, triangles, lo_b, hi_b, keep, len(corners), elastic=False)
        if hard is not None:
            heights, _ = hard
            held = keep[tri]
            return Drape(corners, heights, triangles[keep], int(held.sum()))
        soft = _solve(tri, w, triangles, lo_b, hi_b, keep, len(corners), elastic=True)
        if soft is None:
            return None
        _, slack = soft
        worst = slack > SLACK_TOLERANCE
        if not worst.any():  # numerically feasible but HiGHS disagreed: drop the largest
            worst = slack >= slack.max()
        keep &= ~worst
    return None
