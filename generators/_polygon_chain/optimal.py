"""Planar sections, step 4.4 refined: the largest inscribed stages of few triangles.

Silvennoinen et al. 2014 [1]_, sec. 4.4, collapse vertices greedily; stages of
few triangles are found exactly here, by dynamic programming.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 4.4)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon

from viscore._jit import njit_cached

from .simplify import SimplificationChain, _twice_areas

__all__ = ["StageChain", "refine_chain", "best_inscribed", "MAX_TRIANGLES", "POOL"]

#: Stages with at most this many triangles are the largest inscribed polygons.
MAX_TRIANGLES = 12

#: Vertices the search chooses among (those of the greedy chain's stage with at most
#: this many vertices): the search costs O(POOL^3 MAX_TRIANGLES).
POOL = 48


@njit_cached()
def _best_subsets(xs, ys, valid, kmax):  # pragma: no cover
    """Largest-area vertex subsets of 3 .. kmax + 2 vertices that keep vertex 0.

    ``valid[i, j]`` (0 <= i < j <= n, position n is vertex 0 again): the chord
    i-j may be a stage edge. Returns (twice kept area per vertex count, -inf
    when none; chosen vertices per vertex count as a mask).
    """
    n = len(xs)
    best = np.full(kmax + 3, -np.inf)
    masks = np.zeros((kmax + 3, n), np.bool_)
    cost = np.full((n + 1, kmax + 4), np.inf)
    arg = np.full((n + 1, kmax + 4), -1, np.int64)
    ss = np.empty(n + 1)
    ss[0] = 0.0
    for t in range(n):
        u = (t + 1) % n
        ss[t + 1] = ss[t] + xs[t] * ys[u] - xs[u] * ys[t]
    total = ss[n]
    cost[0, 1] = 0.0
    for j in range(1, n + 1):
        jj = j % n
        for i in range(j):
            if i + 1 != j and not valid[i, j]:
                continue
            pocket = ss[j] - ss[i] + xs[jj] * ys[i] - xs[i] * ys[jj]
            for c in range(1, kmax + 4):
                v = cost[i, c - 1] + pocket
                if v < cost[j, c]:
                    cost[j, c] = v
                    arg[j, c] = i
    for c in range(3, kmax + 3):
        v = cost[n, c + 1]
        if v < np.inf:
            best[c] = total - v
            j, cc = n, c + 1
            while j > 0:
                i = arg[j, cc]
                masks[c, i] = True
                j, cc = i, cc - 1
    return best, masks


def _pocket_rules(xy: np.ndarray, region: Polygon, ok: np.ndarray) -> np.ndarray:
    """(n, n) bool: chords i-j whose pocket (the loop from i forward to j, closed by the
    chord) is a counter-clockwise region the candidate covers; for loops through bridges.

    On a simple loop every chord inside the candidate has such a pocket; on a loop
    through bridges a chord may instead skip a hole (the pocket's loop then winds
    around it negatively) or reach around one (the pocket then covers it). A pocket of
    zero shoelace area passes only when it bounds no area at all: a loop through a
    bridge can wind once around a part of the candidate and once, the other way, around
    a hole of the same area. All pockets are tested at once (vectorised shapely).
    """
    n = len(xy)
    out = np.zeros((n, n), dtype=bool)
    ii, jj = np.nonzero(ok)
    steps = (jj - ii) % n
    out[ii[steps == 1], jj[steps == 1]] = True
    sel = steps > 1
    ii, jj, steps = ii[sel], jj[sel], steps[sel]
    if len(ii) == 0:
        return out
    x, y = xy[:, 0], xy[:, 1]
    cross = np.concatenate([[0.0], np.cumsum(x * np.roll(y, -1) - np.roll(x, -1) * y)])
    arc = np.where(jj > ii, cross[jj] - cross[ii], cross[n] - cross[ii] + cross[jj])
    shoelace = 0.5 * (arc + x[jj] * y[ii] - x[ii] * y[jj])  # exact: integer coordinates
    # each pocket's loop i, i+1, ..., j, closed explicitly (i again)
    lengths = steps + 2
    ring_id = np.repeat(np.arange(len(ii)), lengths)
    first = np.repeat(np.cumsum(lengths) - lengths, lengths)
    offset = np.arange(len(ring_id)) - first
    vertex = np.where(offset == np.repeat(lengths - 1, lengths), 0, offset)
    vertex = (np.repeat(ii, lengths) + vertex) % n
    rings = shapely.linearrings(xy[vertex], indices=ring_id)
    fixed = shapely.buffer(shapely.polygons(rings), 0)
    area = shapely.area(fixed)
    good = np.zeros(len(ii), dtype=bool)
    zero = shoelace == 0
    good[zero] = area[zero] <= 1e-9
    pos = np.flatnonzero(shoelace > 0)
    close = np.abs(area[pos] - shoelace[pos]) <= 1e-9 * np.maximum(1.0, shoelace[pos])
    pos = pos[close]
    shapely.prepare(region)
    good[pos] = shapely.covers(region, fixed[pos])
    out[ii[good], jj[good]] = True
    return out


def _twice_loop_area(loop: np.ndarray) -> float:
    """Twice the signed (shoelace) area of a closed loop ``(n, 2)``."""
    return float(np.sum(loop[:, 0] * np.roll(loop[:, 1], -1)
                        - np.roll(loop[:, 0], -1) * loop[:, 1]))


def _weakly_simple_inside(loop: np.ndarray, region: Polygon) -> bool:
    """The loop bounds a region inside ``region`` once, counter-clockwise: its repaired
    polygon (zero-width bridges resolved by ``buffer(0)``) has the loop's shoelace area,
    which is positive, and is covered."""
    shoelace = 0.5 * _twice_loop_area(loop)
    if shoelace <= 0:
        return False
    fixed = Polygon(loop).buffer(0)
    return abs(fixed.area - shoelace) <= 1e-9 * max(1.0, shoelace) and region.covers(fixed)


def best_inscribed(ring: np.ndarray, region: Polygon, kmax: int
                   ) -> dict[int, tuple[float, np.ndarray]]:
    """Largest polygons on the vertices of ``ring`` that lie in ``region``, per triangle count.

    Parameters
    ----------
    ring : (n, 2) float
        Counter-clockwise weakly simple loop (bridged holes allowed), a
        subset of ``region``.
    region : shapely Polygon
        The candidate (holes included).
    kmax : int
        Largest triangle count searched.

    Returns
    -------
    dict
        Triangle count k (1 .. kmax) -> (area, vertex indices into ``ring``
        in loop order), for the counts where a checked polygon was found.

    Examples
    --------
    >>> sq = np.array([[0, 0], [2, 0], [4, 0], [4, 4], [0, 4]], float)
    >>> best = best_inscribed(sq, Polygon(sq), 2)
    >>> best[2][0], best[1][0]
    (16.0, 8.0)
    """
    xy = np.ascontiguousarray(ring, dtype=np.float64)
    n = len(xy)
    if n < 3 or kmax < 1:
        return {}
    i, j = np.triu_indices(n, 1)
    if np.array_equal(xy, np.rint(xy)) and np.abs(xy).max() < 2.0**50:
        # a chord the candidate covers has its midpoint in it (exact here: integer
        # coordinates): the prepared point test leaves the full test the chords that may
        # pass it
        shapely.prepare(region)
        maybe = shapely.intersects_xy(region, *(0.5 * (xy[i] + xy[j])).T)
        i, j = i[maybe], j[maybe]
    segments = shapely.linestrings(np.stack([xy[i], xy[j]], axis=1))
    ok = np.zeros((n, n), dtype=bool)
    ok[i, j] = shapely.covers(region, segments)
    ok[j, i] = ok[i, j]
    out: dict[int, tuple[float, np.ndarray]] = {}
    # every edge of a feasible polygon is a chord inside the candidate: the search over
    # those chords alone relaxes the problem, so its best polygon, where it passes the
    # check, is optimal. Where it fails (a loop through bridges, or a candidate with
    # holes: chords that skip a hole or reach around one), search again with each
    # pocket checked itself.
    rounds = [ok]
    if (not isinstance(region, Polygon) or len(region.interiors)
            or len(np.unique(xy, axis=0)) < n):
        rounds.append(None)  # type: ignore[arg-type]
    for rules in rounds:
        if rules is None:
            rules = _pocket_rules(xy, region, ok)
        best, masks = _search(xy, rules, kmax)
        for c in range(3, min(kmax + 2, n) + 1):
            if c - 2 in out or not np.isfinite(best[c]):
                continue
            idx = np.flatnonzero(masks[c])
            if _weakly_simple_inside(xy[idx], region):
                out[c - 2] = (0.5 * float(best[c]), idx)
        if len(out) == min(kmax, n - 2):
            break
    return dict(sorted(out.items()))


def _search(xy: np.ndarray, ok: np.ndarray, kmax: int) -> tuple[np.ndarray, np.ndarray]:
    """Best twice-areas and vertex masks per vertex count over all start vertices."""
    n = len(xy)
    best = np.full(kmax + 3, -np.inf)
    masks = np.zeros((kmax + 3, n), dtype=bool)
    for start in range(n):
        order = (np.arange(n + 1) + start) % n
        b, m = _best_subsets(xy[order[:n], 0].copy(), xy[order[:n], 1].copy(),
                             ok[np.ix_(order, order)], int(kmax))
        better = b > best
        best[better] = b[better]
        masks[better] = m[better][:, np.argsort(order[:n])]
    return best, masks


def _triangulate(xy: np.ndarray, idx: np.ndarray) -> np.ndarray | None:
    """Earcut triangles of the loop ``xy[idx]`` as indices into ``xy``; None when they do
    not tile it exactly."""
    import mapbox_earcut

    t = np.asarray(mapbox_earcut.triangulate_float64(
        xy[idx], np.array([len(idx)], dtype=np.uint32)), dtype=np.int64).reshape(-1, 3)
    tri = idx[t]
    twice = _twice_areas(xy, tri)
    area2 = _twice_loop_area(xy[idx])
    if (twice < 0).any() or abs(float(twice.sum()) - area2) > 1e-9 * max(1.0, abs(area2)):
        return None
    return tri[twice > 0]


def _tiles_inside(corners: np.ndarray, area: float, region: Polygon) -> bool:
    """The triangles ``(t, 3, 2)`` lie in ``region`` and tile ``area`` without overlap (the
    last guard of the containment promise, independent of how ``buffer(0)`` repairs loops)."""
    tris = shapely.polygons(corners)
    union = shapely.union_all(tris)
    tol = 1e-9 * max(1.0, area)
    return (abs(float(shapely.area(tris).sum()) - area) <= tol
            and abs(union.area - area) <= tol and region.covers(union))


@dataclass(frozen=True, eq=False)
class StageChain:
    """Stages of one polygon by triangle count, not necessarily nested.

    Same interface as :class:`.simplify.SimplificationChain`: ``ring``,
    ``counts`` (strictly decreasing), ``areas`` (decreasing), ``stages``,
    :meth:`stage_ring`, :meth:`stage_triangles`.

    Attributes
    ----------
    ring : (n, 2) float64
        The candidate loop (pixel coordinates).
    vertices : tuple of (m,) int64
        Vertex indices of each stage, in loop order.
    triangles : tuple of (t, 3) int64
        Triangles of positive area of each stage (indices into ``ring``).
    counts : (S,) int64
    areas : (S,) float64
    """

    ring: np.ndarray
    vertices: tuple
    triangles: tuple
    counts: np.ndarray
    areas: np.ndarray

    @property
    def stages(self) -> int:
        """Number of stages, the full polygon included."""
        return len(self.counts)

    def stage_ring(self, s: int) -> np.ndarray:
        """Loop of stage ``s``."""
        return self.ring[self.vertices[s]]

    def stage_triangles(self, s: int) -> np.ndarray:
        """``(k, 3)`` triangles of stage ``s`` (indices into ``ring``)."""
        return self.triangles[s]


def _first_inside(chain: SimplificationChain, region: Polygon) -> int:
    """First greedy stage whose triangles all lie in ``region``: stage ``s`` has the
    triangles ``chain.triangles[s:]``, so a stage holds every uncovered triangle of a
    later index."""
    tri = chain.triangles
    if len(tri) == 0:
        return 0
    twice = _twice_areas(chain.ring, tri)
    shapely.prepare(region)
    bad = np.flatnonzero((twice > 0)
                         & ~shapely.covers(region, shapely.polygons(chain.ring[tri])))
    return int(bad[-1]) + 1 if len(bad) else 0


def refine_chain(chain: SimplificationChain, region: Polygon, *,
                 max_triangles: int = MAX_TRIANGLES, pool: int = POOL,
                 search: bool = True) -> StageChain:
    """The chain with its stages of at most ``max_triangles`` triangles made largest.

    Parameters
    ----------
    chain : SimplificationChain
        The greedy chain of the candidate.
    region : shapely Polygon
        The candidate polygon (holes included; same coordinates as
        ``chain.ring``).
    max_triangles : int, optional
        Stages up to this many triangles are searched (default
        :data:`MAX_TRIANGLES`).
    pool : int, optional
        Vertices searched among (default :data:`POOL`).
    search : bool, optional
        Search the largest inscribed stages (default True); False keeps the
        greedy stages, only dropping those that leave the candidate.

    Returns
    -------
    StageChain
        Per triangle count, the larger of the greedy stage and the searched
        polygon; stages dominated by a later one (no more area for more
        triangles) are dropped, and so are greedy stages with a triangle the
        candidate does not cover (a loop through bridges that is not weakly
        simple, upstream), so that the first stage may not be the full
        polygon; a single stage of no triangle when none is left.

    Examples
    --------
    >>> from viscore.generators._polygon_chain import simplification_chain
    >>> ring = np.array([[0, 0], [4, 0], [4, 1], [5, 2], [4, 3], [4, 4], [0, 4]], float)
    >>> ch = refine_chain(simplification_chain(ring), Polygon(ring))
    >>> ch.counts.tolist()[-2:], ch.areas.tolist()[-2:]
    ([2, 1], [16.0, 10.0])
    """
    xy = chain.ring
    n = len(xy)
    stage_vertices = []
    keep = np.ones(n, dtype=bool)
    for s in range(chain.stages):  # vertex sets of the greedy stages (removed[:s] gone)
        stage_vertices.append(np.flatnonzero(keep))
        if s < len(chain.removed):
            keep[chain.removed[s]] = False
    options = [(int(chain.counts[s]), float(chain.areas[s]), stage_vertices[s],
                chain.stage_triangles(s)) for s in range(_first_inside(chain, region),
                                                         chain.stages)]
    small = [s for s in range(chain.stages) if len(stage_vertices[s]) <= pool]
    # no stage within the pool (a chain that stopped early): no search, the greedy chain
    base = stage_vertices[small[0]] if small and search else stage_vertices[0][:0]
    found = best_inscribed(xy[base], region, max_triangles)
    for k, (area, idx) in found.items():
        vertices = base[idx]
        tri = _triangulate(xy, vertices)
        if tri is not None and 0 < len(tri) <= k and _tiles_inside(xy[tri], area, region):
            options.append((len(tri), area, vertices, tri))
    # per count the largest area; then drop stages no larger than one with fewer triangles
    by_count: dict[int, tuple] = {}
    for opt in options:
        if opt[0] > 0 and (opt[0] not in by_count or opt[1] > by_count[opt[0]][1]):
            by_count[opt[0]] = opt
    kept, floor = [], -np.inf
    for count in sorted(by_count):
        opt = by_count[count]
        if opt[1] > floor:
            kept.append(opt)
            floor = opt[1]
    kept.reverse()
    if not kept:  # no stage with a triangle of positive area inside the candidate
        return StageChain(ring=xy, vertices=(stage_vertices[0][:0],), triangles=(
            np.zeros((0, 3), dtype=np.int64),), counts=np.zeros(1, dtype=np.int64),
            areas=np.zeros(1))
    return StageChain(ring=xy, vertices=tuple(o[2] for o in kept),
                      triangles=tuple(o[3] for o in kept),
                      counts=np.array([o[0] for o in kept], dtype=np.int64),
                      areas=np.array([o[1] for o in kept], dtype=np.float64))
