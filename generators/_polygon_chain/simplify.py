"""Planar sections, step 4.4: the progressive simplification chain of a polygon.

Silvennoinen et al. 2014 [1]_, sec. 4.4: starting from the candidate
polygon, repeatedly remove the vertex v_k whose triangle (v_k-1, v_k, v_k+1)
has the smallest area among those whose removal keeps the polygon inside the
original candidate, until one triangle is left; each stage is triangulated.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 4.4)
.. [2] Meisters, G. H. "Polygons Have Ears". The American Mathematical
   Monthly 82(6), 1975, pp. 648-651. :DOI:`10.2307/2319703`
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from viscore._jit import njit_cached
from viscore._sort_kernels import stable_order

__all__ = ["SimplificationChain", "simplification_chain"]


@njit_cached()
def _enters(px, py, qx, qy, ax, ay, bx, by, cx, cy, diagonal):  # pragma: no cover
    """Does the edge from corner (px, py) = a towards (qx, qy) enter the angle b-a-c
    (counter-clockwise from a->b to a->c), or run along the arm that is the ear's new
    edge (``diagonal`` 1: a->b, 2: a->c, 0: neither) in the same direction?"""
    ex, ey = qx - px, qy - py
    ux, uy = bx - ax, by - ay
    wx, wy = cx - ax, cy - ay
    c1 = ux * ey - uy * ex
    c2 = ex * wy - ey * wx
    if c1 > 0 and c2 > 0:
        return True
    if ex == 0 and ey == 0:
        return False
    if diagonal == 1 and c1 == 0 and (ex * ux + ey * uy) > 0:
        return True
    if diagonal == 2 and c2 == 0 and (ex * wx + ey * wy) > 0:
        return True
    return False


@njit_cached()
def _edge_sides(px, py, ax, ay, bx, by, cx, cy):  # pragma: no cover
    """Cross products of the edges a->b, b->c, c->a with the point p (all > 0: strictly inside
    a counter-clockwise triangle)."""
    d1 = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
    d2 = (cx - bx) * (py - by) - (cy - by) * (px - bx)
    d3 = (ax - cx) * (py - cy) - (ay - cy) * (px - cx)
    return d1, d2, d3


@njit_cached()
def _in_closed_triangle(px, py, ax, ay, bx, by, cx, cy):  # pragma: no cover
    d1, d2, d3 = _edge_sides(px, py, ax, ay, bx, by, cx, cy)
    return d1 >= 0 and d2 >= 0 and d3 >= 0


@njit_cached()
def _is_ear(x, y, nxt, prv, alive_list, m, a, b, c):  # pragma: no cover
    ax, ay, bx, by, cx, cy = x[a], y[a], x[b], y[b], x[c], y[c]
    for t in range(m):
        p = alive_list[t]
        if p == a or p == b or p == c:
            continue
        px, py = x[p], y[p]
        at_a = px == ax and py == ay
        at_b = px == bx and py == by
        at_c = px == cx and py == cy
        if at_a or at_b or at_c:
            for q in (nxt[p], prv[p]):
                qx, qy = x[q], y[q]
                # the arms as int64 values, not literals: one compiled _enters, not three
                if at_a and _enters(px, py, qx, qy, ax, ay, bx, by, cx, cy, np.int64(2)):
                    return False
                if at_b and _enters(px, py, qx, qy, bx, by, cx, cy, ax, ay, np.int64(0)):
                    return False
                if at_c and _enters(px, py, qx, qy, cx, cy, ax, ay, bx, by, np.int64(1)):
                    return False
        elif _in_closed_triangle(px, py, ax, ay, bx, by, cx, cy):
            return False
    return True


@njit_cached()
def _is_ear_loose(x, y, alive_list, m, a, b, c):  # pragma: no cover
    """Fallback test: no other vertex strictly inside the triangle."""
    ax, ay, bx, by, cx, cy = x[a], y[a], x[b], y[b], x[c], y[c]
    for t in range(m):
        p = alive_list[t]
        if p == a or p == b or p == c:
            continue
        d1, d2, d3 = _edge_sides(x[p], y[p], ax, ay, bx, by, cx, cy)
        if d1 > 0 and d2 > 0 and d3 > 0:
            return False
    return True


@njit_cached()
def _ear_chain(x, y, loose):  # pragma: no cover
    """Removal order and ears of the greedy smallest-ear chain.

    Returns ``removed (s,) int64`` (vertex removed at each step) and ``ears
    (s, 3) int64`` (its triangle), s <= n - 3; when s == n - 3 the three
    vertices left form the final triangle.
    """
    n = len(x)
    nxt = np.empty(n, np.int64)
    prv = np.empty(n, np.int64)
    for i in range(n):
        nxt[i] = (i + 1) % n
        prv[i] = (i - 1) % n
    alive = np.ones(n, np.bool_)
    removed = np.empty(max(n - 3, 0), np.int64)
    ears = np.empty((max(n - 3, 0), 3), np.int64)
    alive_list = np.empty(n, np.int64)
    cross = np.empty(n)
    order_a = np.empty(n, np.int64)
    order_b = np.empty(n, np.int64)
    m = n
    s = 0
    while m > 3:
        k = 0
        for i in range(n):
            if alive[i]:
                alive_list[k] = i
                k += 1
        for t in range(m):
            i = alive_list[t]
            a, c = prv[i], nxt[i]
            cross[t] = (x[i] - x[a]) * (y[c] - y[i]) - (y[i] - y[a]) * (x[c] - x[i])
        order = stable_order(cross, m, order_a, order_b)
        found = -1
        for t in order:
            if cross[t] < 0:
                continue
            i = alive_list[t]
            if cross[t] == 0 or _is_ear(x, y, nxt, prv, alive_list, m, prv[i], i, nxt[i]):
                found = i
                break
        if found < 0 and loose:  # zero-width parts: the loose ear test of ear clipping
            for t in order:
                i = alive_list[t]
                if cross[t] > 0 and _is_ear_loose(x, y, alive_list, m, prv[i], i, nxt[i]):
                    found = i
                    break
        if found < 0:
            break
        a, c = prv[found], nxt[found]
        removed[s] = found
        ears[s, 0], ears[s, 1], ears[s, 2] = a, found, c
        nxt[a] = c
        prv[c] = a
        alive[found] = False
        m -= 1
        s += 1
    return removed[:s], ears[:s]


def _twice_areas(xy: np.ndarray, tri: np.ndarray) -> np.ndarray:
    a, b, c = xy[tri[:, 0]], xy[tri[:, 1]], xy[tri[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


@dataclass(frozen=True, eq=False)
class SimplificationChain:
    """Nested stages of one polygon, from the full candidate to one triangle.

    Stage ``s`` (0 = the full polygon) has the vertices left after ``s``
    removals. Its triangles are ``triangles[s:]`` (indices into ``ring``).

    Attributes
    ----------
    ring : (n, 2) float64
        The candidate loop (pixel coordinates).
    removed : (S,) int64
        Vertex removed by each step; S stages below the full one.
    triangles : (S + t, 3) int64
        The ears in removal order, then the triangulation of the last stage
        (the final triangle, or ``mapbox_earcut``'s when no ear was left).
    counts : (S + 1,) int64
        Triangles of positive area per stage, non-increasing.
    areas : (S + 1,) float64
        Area per stage, pixels^2, non-increasing.
    """

    ring: np.ndarray
    removed: np.ndarray
    triangles: np.ndarray
    counts: np.ndarray
    areas: np.ndarray

    @property
    def stages(self) -> int:
        """Number of stages, the full polygon included."""
        return len(self.counts)

    def stage_ring(self, s: int) -> np.ndarray:
        """``(n - s, 2)`` loop of stage ``s``, in the ring's order."""
        keep = np.ones(len(self.ring), dtype=bool)
        keep[self.removed[:s]] = False
        return self.ring[keep]

    def stage_triangles(self, s: int) -> np.ndarray:
        """``(k, 3)`` triangles of stage ``s`` with positive area (indices into ``ring``)."""
        tri = self.triangles[s:]
        return tri[_twice_areas(self.ring, tri) > 0]


def simplification_chain(ring: np.ndarray, *, loose: bool = True) -> SimplificationChain:
    """Greedy smallest-ear simplification chain of a counter-clockwise weakly simple loop.

    Parameters
    ----------
    ring : (n, 2) float
        Loop with integer coordinates (exact predicates), counter-clockwise,
        no closing duplicate, n >= 3.
    loose : bool, optional
        Fall back to the loose ear test where the strict one finds no ear
        (default True). The conservative variant passes False: a loose ear
        of a degenerate loop could reach outside it.

    Returns
    -------
    SimplificationChain

    Examples
    --------
    >>> sq = np.array([[0, 0], [2, 0], [2, 1], [2, 2], [0, 2]], float)
    >>> ch = simplification_chain(sq)
    >>> ch.counts.tolist(), ch.areas.tolist()
    ([2, 2, 1], [4.0, 4.0, 2.0])
    """
    xy = np.ascontiguousarray(ring, dtype=np.float64)
    n = len(xy)
    removed, ears = _ear_chain(xy[:, 0].copy(), xy[:, 1].copy(), bool(loose))
    keep = np.ones(n, dtype=bool)
    keep[removed] = False
    left = np.flatnonzero(keep)
    if len(left) == 3:
        tail = left[None, :]
    else:
        import mapbox_earcut

        tail = left[np.asarray(mapbox_earcut.triangulate_float64(
            xy[left], np.array([len(left)], dtype=np.uint32)), dtype=np.int64).reshape(-1, 3)]
    triangles = np.concatenate([ears.reshape(-1, 3), tail]).astype(np.int64)
    twice = _twice_areas(xy, triangles)
    pos = twice > 0
    s = len(removed)
    tail_count = int(pos[s:].sum())
    tail_area = 0.5 * float(twice[s:][pos[s:]].sum())
    ear_pos = pos[:s].astype(np.int64)
    ear_area = 0.5 * np.where(pos[:s], twice[:s], 0.0)
    counts = tail_count + np.concatenate([np.cumsum(ear_pos[::-1])[::-1], [0]])
    areas = tail_area + np.concatenate([np.cumsum(ear_area[::-1])[::-1], [0.0]])
    return SimplificationChain(ring=xy, removed=removed, triangles=triangles,
                               counts=counts.astype(np.int64), areas=areas)
