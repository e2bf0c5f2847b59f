"""The hidden floor under an open height field: below it, some line through a point misses it."""

from __future__ import annotations

import math

import numpy as np

from viscore._jit import njit_cached

__all__ = ["hidden_floor", "lattice_directions"]


def lattice_directions(reach: int = 3) -> np.ndarray:
    """Primitive integer directions ``(a, b)``, one per orientation, ``max(|a|, |b|) <= reach``.

    Examples
    --------
    >>> lattice_directions(1).tolist()
    [[0, 1], [1, -1], [1, 0], [1, 1]]
    >>> len(lattice_directions(3))
    16
    """
    out = []
    for a in range(0, reach + 1):
        for b in range(-reach, reach + 1):
            if (a == 0 and b <= 0) or math.gcd(a, abs(b)) != 1:
                continue
            out.append((a, b))
    return np.asarray(out, dtype=np.int64)


@njit_cached(nogil=True)
def _envelope_along(h, mask, a, b, out):  # pragma: no cover - compiled
    """``out = max(out, c_(a,b))`` at every masked grid point, over all lines along (a, b)."""
    nx, ny = h.shape
    ks = np.empty(nx + ny, np.int64)
    hs = np.empty(nx + ny, np.float64)
    hull = np.empty(nx + ny, np.int64)
    px = np.empty(nx + ny, np.int64)
    py = np.empty(nx + ny, np.int64)
    for i0 in range(nx):
        for j0 in range(ny):
            # a line starts where the step back leaves the grid
            pi, pj = i0 - a, j0 - b
            if 0 <= pi < nx and 0 <= pj < ny:
                continue
            n = 0
            k = 0
            i, j = i0, j0
            while 0 <= i < nx and 0 <= j < ny:
                if mask[i, j]:
                    ks[n] = k
                    hs[n] = h[i, j]
                    px[n] = i
                    py[n] = j
                    n += 1
                k += 1
                i += a
                j += b
            if n == 0:
                continue
            # lower convex hull of (ks, hs), ks increasing (monotone chain)
            m = 0
            for q in range(n):
                while m >= 2:
                    o, p = hull[m - 2], hull[m - 1]
                    cross = (ks[p] - ks[o]) * (hs[q] - hs[o]) - (hs[p] - hs[o]) * (ks[q] - ks[o])
                    if cross <= 0.0:
                        m -= 1
                    else:
                        break
                hull[m] = q
                m += 1
            # evaluate the hull at every sample of the line
            seg = 0
            for q in range(n):
                while seg < m - 2 and ks[hull[seg + 1]] < ks[q]:
                    seg += 1
                lo, hi = hull[seg], hull[min(seg + 1, m - 1)]
                if hi == lo:
                    value = hs[lo]
                else:
                    w = (ks[q] - ks[lo]) / (ks[hi] - ks[lo])
                    value = hs[lo] + w * (hs[hi] - hs[lo])
                if value > out[px[q], py[q]]:
                    out[px[q], py[q]] = value


def hidden_floor(h: np.ndarray, mask: np.ndarray, *, reach: int = 3) -> np.ndarray:
    """The hidden floor ``g = max_u c_u`` of the height field ``h`` over ``mask`` (module doc).

    Parameters
    ----------
    h : (nx, ny) float
        Heights of the sheet at the grid points (any value where ``mask`` is False).
    mask : (nx, ny) bool
        Grid points that the sheet covers (its footprint; holes allowed: a
        line through a hole is not held by it).
    reach : int, optional
        Lattice directions up to ``max(|a|, |b|) = reach`` (16 orientations at 3).

    Returns
    -------
    g : (nx, ny) float64
        The floor at each masked point (``g <= h``; ``g == h`` where every
        envelope touches the sheet, as on the footprint's boundary); ``-inf``
        off the mask.

    Examples
    --------
    A dome ``1 - x^2 - y^2`` over the square ``[-1, 1]^2`` is concave, so each
    envelope is the chord between the rim points: at the centre the highest
    is along an axis, from rim heights 0. A lattice line can end short of the
    rim, which only raises ``g`` (safe): hence ``reach=1`` for the exact value.

    >>> x = np.linspace(-1, 1, 21)
    >>> dome = 1 - np.add.outer(x ** 2, x ** 2)
    >>> g = hidden_floor(dome, np.ones_like(dome, bool), reach=1)
    >>> float(round(g[10, 10], 6)), float(dome[10, 10])
    (0.0, 1.0)
    >>> bool((g <= dome + 1e-12).all())
    True
    """
    h = np.ascontiguousarray(h, dtype=np.float64)
    mask = np.ascontiguousarray(mask, dtype=np.bool_)
    out = np.full(h.shape, -np.inf)
    for a, b in lattice_directions(reach):
        _envelope_along(h, mask, int(a), int(b), out)
    out[~mask] = -np.inf
    return out
