"""Planar sections, step 4.5: greedy alpha-complete selection, then the budget cut.

Silvennoinen et al. 2014 [1]_, sec. 4.5.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 3, 4.5, Fig. 11)
.. [2] Minoux, M. "Accelerated greedy algorithms for maximizing submodular
   set functions". Optimization Techniques, Lecture Notes in Control and
   Information Sciences 7, Springer, 1978, pp. 234-243.
   :DOI:`10.1007/BFb0006528` (the lazy evaluation of the greedy steps)
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from .._polygon_chain import SimplificationChain
from .._soup_measure import (
    MEASURE_DIRECTIONS,
    MEASURE_RESOLUTION,
    measure_directions,
    project_candidates,
    soup_measures,
    soup_totals,
)

__all__ = ["Selection", "measure_directions", "project_candidates", "soup_measures",
           "select_greedy", "GreedySearch", "reduce_to_budget", "MEASURE_DIRECTIONS",
           "MEASURE_RESOLUTION"]


@dataclass(frozen=True)
class Selection:
    """Outcome of the greedy search and the budget cut.

    Attributes
    ----------
    chosen : (k,) int64
        Candidates added by the greedy search, in order.
    totals : (k,) float64
        Total measure of the soup after each addition (mean over directions,
        world units^3 for ``'om'``, ^2 for ``'area'``).
    stages : (k,) int64
        Chain stage kept for each chosen candidate after the budget cut;
        -1 where the cut removed it.
    triangles : int
        Triangles of the cut.
    """

    chosen: np.ndarray
    totals: np.ndarray
    stages: np.ndarray
    triangles: int


def select_greedy(bitmaps: np.ndarray, pixel: float, *, alpha: float, measure: str = "om",
                  max_polygons: int | None = None, lazy: bool = True
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Greedy alpha-complete selection of whole candidates (sec. 4.5).

    Parameters
    ----------
    bitmaps : (n, N, R, R) bool
        From :func:`project_candidates`.
    pixel : float
        Measure pixel side, world units.
    alpha : float
        Stop when the best addition raises the total by less than ``alpha``
        percent of it.
    measure : {'om', 'area'}
        Total occlusion measure, or projected area of the soup (the paper's
        surface-area comparison, Fig. 11).
    max_polygons : int, optional
        Stop at this many polygons (a budget of B triangles keeps at most B).
    lazy : bool, optional
        Evaluate candidates in order of their gain at the previous step and
        stop once the best gain found is at least the next candidate's
        previous gain (lazy greedy [2]_). Exact when gains only
        shrink as the soup grows, as the projected area's do; the
        occlusion measure's can grow (two polygons side by side block wider
        beams than either), so the choice can differ from the exhaustive
        search (``lazy=False``); on the bunny (53 triangles, 64^3) both pick
        the same 12 polygons, the lazy one in half the time. Default True.

    Returns
    -------
    chosen : (k,) int64
    totals : (k,) float64
        Mean over directions of the soup's measure after each addition.
    """
    return GreedySearch(bitmaps, pixel, alpha=alpha, measure=measure, lazy=lazy).result(
        max_polygons)


class GreedySearch:
    """The greedy search of :func:`select_greedy`, kept to be taken further.

    The search's state after k additions does not depend on how many it was
    allowed: the selection with at most m polygons is the first m of the
    selection with at most M >= m (the count only ends the loop). A search
    asked for M after m goes on from where it stopped, so the budgets of one
    mesh share one search (the same choices and totals, bit for bit, as a
    search made anew for each).
    """

    def __init__(self, bitmaps: np.ndarray, pixel: float, *, alpha: float,
                 measure: str = "om", lazy: bool = True) -> None:
        self.bitmaps = np.ascontiguousarray(bitmaps, dtype=bool)
        n, nd = self.bitmaps.shape[:2]
        self.alpha, self.measure, self.lazy = alpha, measure, lazy
        self.union = np.zeros(self.bitmaps.shape[1:], dtype=bool)
        self.base = np.zeros(nd)
        self.done = np.zeros(n, dtype=bool)
        self.bound = np.full(n, np.inf)  # gain at the last evaluation (pixel units)
        self.chosen: list[int] = []
        self.totals: list[float] = []
        self.scale = pixel**2 if measure == "area" else pixel**3
        self.current = 0.0
        self.ended = False  # stopped by the search itself, not by a count
        self._lock = threading.Lock()

    def result(self, max_polygons: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(chosen, totals)`` of the search with at most ``max_polygons`` (None: no
        limit), going on from the last call where that asks for more (thread-safe)."""
        with self._lock:
            self._extend(max_polygons)
        k = len(self.chosen) if max_polygons is None else min(len(self.chosen), max_polygons)
        return (np.asarray(self.chosen[:k], dtype=np.int64),
                np.asarray(self.totals[:k], dtype=np.float64))

    def _extend(self, max_polygons: int | None) -> None:
        bitmaps, bound, done, nd = self.bitmaps, self.bound, self.done, len(self.base)
        measure, lazy = self.measure, self.lazy
        while not self.ended and (max_polygons is None or len(self.chosen) < max_polygons):
            if done.all():
                self.ended = True
                break
            order = np.flatnonzero(~done)
            order = order[np.argsort(-bound[order], kind="stable")]
            best, best_gain = -1, -np.inf
            chunk = max(1, len(order) // 8) if lazy else len(order)
            for first in range(0, len(order), chunk):
                if lazy and best >= 0 and best_gain >= bound[order[first]]:
                    break
                ids = order[first:first + chunk]
                t = soup_totals(ids, self.union, bitmaps, self.base, measure=measure)
                bound[ids] = t - self.current
                k = ids[int(np.argmax(bound[ids]))]
                if bound[k] > best_gain:
                    best, best_gain = int(k), float(bound[k])
            if best < 0 or best_gain <= 0:
                self.ended = True
                break
            if self.chosen and best_gain <= self.alpha / 100.0 * self.current:
                self.ended = True
                break
            self.chosen.append(best)
            done[best] = True
            self.union |= bitmaps[best]
            self.base = soup_measures(self.union, 1.0, measure=measure)
            self.current = float(self.base.sum())
            self.totals.append(self.current * self.scale / nd)


#: The measured budget-cut rules start at this multiple of the budget (area before).
MEASURE_FROM = 1.25


def _next_stages(chain: SimplificationChain) -> np.ndarray:
    """``(S,)`` int64: for each stage, the first later stage with fewer triangles;
    ``chain.stages`` means removed."""
    counts = np.asarray(chain.counts)
    out = np.full(len(counts), len(counts), dtype=np.int64)
    for s in range(len(counts)):
        later = np.flatnonzero(counts[s + 1:] < counts[s])
        if len(later):
            out[s] = s + 1 + int(later[0])
    return out


def reduce_to_budget(chains: list[SimplificationChain], budget: int | None, *,
                     reduce: str = "area", bitmaps_of=None, pixel: float = 1.0,
                     measure_from: float = MEASURE_FROM) -> tuple[np.ndarray, int]:
    """Walk down the chains one triangle at a time until the cut fits the budget (sec. 4.5).

    Parameters
    ----------
    chains : list of SimplificationChain
        Those of the chosen candidates, in order.
    budget : int or None
        None: keep the full polygons.
    reduce : {'area', 'projected-area', 'om'}
        Keep, at each step, the cut of largest surface area, the sum of its
        polygons' areas (``'area'``, the paper's rule, default); or of
        largest projected area over the measure directions, A(I_{d,0}) of
        the paper's sec. 3.1 (``'projected-area'``: overlaps count once); or
        of largest occlusion measure (``'om'``, slower). ``bitmaps_of(i, s)``
        gives candidate i's stage-s bitmaps ``(N, R, R)`` (not needed for
        ``'area'``).
    measure_from : float, optional
        The ``'projected-area'`` and ``'om'`` rules take over once the cut
        has at most ``measure_from`` times the budget triangles; above that,
        steps follow the area rule (they remove ears of almost no area, where
        the rules agree, and each measured step costs a projection per
        candidate). Default :data:`MEASURE_FROM`.

    Returns
    -------
    stages : (k,) int64
        Stage kept per chain, -1 when removed.
    triangles : int
    """
    k = len(chains)
    stage = np.zeros(k, dtype=np.int64)
    tri = int(sum(int(c.counts[0]) for c in chains))
    if budget is None:
        return stage, tri
    nexts = [_next_stages(ch) for ch in chains]
    ends = np.array([ch.stages for ch in chains], dtype=np.int64)

    def area_loss(i: int) -> float:  # area the next step of chain i removes (-inf: done)
        s, ch = int(stage[i]), chains[i]
        if s >= ch.stages:
            return -np.inf
        nxt = nexts[i][s]
        return -(ch.areas[s] - (ch.areas[nxt] if nxt < ch.stages else 0.0))

    by_area_vals = np.array([area_loss(i) for i in range(k)], dtype=np.float64)
    counts_img = cover = base = None
    # 'om': each chain's per-direction values of its next step, kept until a step changes
    # the images of some directions (stale: recomputed there only, so the values, and
    # their sums in the same order, are those a whole recomputation gives)
    kept_vals: list = [None] * k
    # and the images those values are the measures of: a direction whose counts a step
    # changed can leave a chain's image as it was (a pixel still covered), and keeps its
    # value (the measure of one image is the same bits however it is batched)
    kept_after: list = [None] * k
    stale = np.ones((k, 1), dtype=bool)
    while tri > budget:
        by_area = reduce == "area" or tri > measure_from * budget
        if not by_area and counts_img is None:
            counts_img = sum(bitmaps_of(i, int(stage[i])).astype(np.int32) for i in range(k)
                             if stage[i] < chains[i].stages)
            stale = np.ones((k, len(counts_img)), dtype=bool)
        best, best_val, best_next = -1, -np.inf, -1
        if by_area:  # the first chain of largest value, as the loop below takes it
            if (stage < ends).any():
                best = int(np.argmax(by_area_vals))
                best_next = int(nexts[best][stage[best]])
        else:
            if reduce == "om" and cover is None:
                cover = counts_img > 0  # type: ignore[operator]
                base = soup_measures(cover, pixel)  # type: ignore[arg-type]
            for i, ch in enumerate(chains):
                s = int(stage[i])
                if s >= ch.stages:
                    continue
                nxt = int(nexts[i][s])
                if reduce == "projected-area":  # pixels only this polygon covers, lost
                    lost = bitmaps_of(i, s) & (counts_img == 1)
                    if nxt < ch.stages:
                        lost &= ~bitmaps_of(i, nxt)
                    val = -float(np.count_nonzero(lost))
                else:  # directions whose image the step leaves as it is keep their value
                    todo = stale[i]
                    if todo.any():
                        img = counts_img[todo] - bitmaps_of(i, s)[todo]  # type: ignore[index]
                        if nxt < ch.stages:
                            img = img + bitmaps_of(i, nxt)[todo]
                        after = img > 0
                        changed = (after != cover[todo]).reshape(len(after), -1).any(axis=1)  # type: ignore[index]
                        vals = base.copy() if kept_vals[i] is None else kept_vals[i].copy()  # type: ignore[union-attr]
                        part = base[todo].copy()  # type: ignore[index]
                        if kept_after[i] is not None:  # an image measured for this chain before
                            again = changed & (kept_after[i][todo] == after).reshape(
                                len(after), -1).all(axis=1)
                            part[again] = vals[todo][again]
                            changed &= ~again
                        if changed.any():
                            part[changed] = soup_measures(after[changed], pixel)
                        vals[todo] = part
                        kept_vals[i] = vals
                        if kept_after[i] is None:
                            kept_after[i] = np.empty_like(cover)
                        kept_after[i][todo] = after
                        stale[i] = False
                    val = float(kept_vals[i].sum())
                if val > best_val:
                    best, best_val, best_next = i, val, nxt
        if best < 0:
            break
        ch = chains[best]
        s = int(stage[best])
        after = int(ch.counts[best_next]) if best_next < ch.stages else 0
        tri -= int(ch.counts[s]) - after
        if counts_img is not None:
            step_img = bitmaps_of(best, s).astype(np.int32)
            if best_next < ch.stages:
                step_img = step_img - bitmaps_of(best, best_next)
            counts_img = counts_img - step_img
            if cover is not None:  # measured again only in the directions whose image changed
                after_step = np.asarray(counts_img > 0)
                moved = (after_step != cover).reshape(len(after_step), -1).any(axis=1)
                cover = after_step
                if moved.any():
                    base = base.copy()  # type: ignore[union-attr]
                    base[moved] = soup_measures(cover[moved], pixel)
            # the directions whose counts this step changed, for every chain; the chain
            # stepped, all of its own
            stale |= step_img.reshape(len(step_img), -1).any(axis=1)
            stale[best] = True
        stage[best] = best_next
        by_area_vals[best] = area_loss(best)
    stage[stage >= np.array([c.stages for c in chains], dtype=np.int64)] = -1
    return stage, tri
