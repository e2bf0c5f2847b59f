"""Surface patches, step 4 with overlap: the knapsack's values discounted by the soup.

Selection by the occlusion measure of the whole soup (Silvennoinen et al. [1]_,
sec. 4.5 and sec. 3, eqs. 2-3).

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (secs. 3 and 4.5)
.. [2] Minoux, M. "Accelerated greedy algorithms for maximizing submodular
   set functions". Optimization Techniques, Lecture Notes in Control and
   Information Sciences 7, Springer, 1978, pp. 234-243.
   :DOI:`10.1007/BFb0006528`
"""

from __future__ import annotations

import numpy as np

from .._soup_measure import (
    MEASURE_DIRECTIONS,
    MEASURE_RESOLUTION,
    measure_directions,
    project_candidates,
    soup_measures,
    soup_totals,
)

__all__ = ["select_with_overlap", "candidate_bitmaps", "LEFTOVER_SHARE"]

#: Share given, once nothing adds to the soup, to the candidates the others hide in
#: every direction: they still block views from between them (inside a building),
#: so the budget left goes to them in the order of their own values.
LEFTOVER_SHARE = 1e-9


def select_with_overlap(values: list[np.ndarray], counts: list[np.ndarray],
                        bitmaps: np.ndarray, budget: int) -> np.ndarray:
    """Greedy multiple-choice knapsack with each candidate's value times its share.

    Parameters
    ----------
    values, counts : list of (S_i,) arrays
        Per candidate, the value and triangle count of each stage (counts
        non-increasing along the chain).
    bitmaps : (k, N, R, R) bool
        Each whole candidate seen along N directions.
    budget : int
        Largest triangle count.

    Returns
    -------
    (k,) int64
        Stage kept per candidate, -1 for none.
    """
    k = len(values)
    stage = np.full(k, -1, dtype=np.int64)
    if k == 0:
        return stage
    bitmaps = np.ascontiguousarray(bitmaps, dtype=bool)
    nd = bitmaps.shape[1]
    empty = np.zeros(bitmaps.shape[1:], dtype=bool)
    alone = soup_totals(np.arange(k), empty, bitmaps, np.zeros(nd))
    owner = np.repeat(np.arange(k), [len(c) for c in counts])
    flat_c = np.concatenate(counts).astype(np.int64)
    flat_v = np.concatenate(values).astype(np.float64)
    first = np.concatenate([[0], np.cumsum([len(c) for c in counts])[:-1]])
    cur_v = np.zeros(k)
    cur_c = np.zeros(k, dtype=np.int64)
    # a candidate under a pixel of the images (a wall of a house across a whole level)
    # cannot be measured against the soup: it keeps its own value (share 1)
    share = np.ones(k)
    fresh = np.zeros(k, dtype=bool)
    covers = np.zeros(bitmaps.shape[1:], dtype=np.int32)  # chosen candidates per pixel
    base = np.zeros(nd)  # the soup's per-direction measure
    left = int(budget)
    leftover = False
    while True:
        dc = flat_c - cur_c[owner]
        dv = (flat_v - cur_v[owner]) * share[owner]
        ok = (dc > 0) & (dc <= left) & (dv > 0)
        if not ok.any():
            hidden = (share <= 0) & (alone > 0) & (stage < 0)
            if leftover or not hidden.any():
                return stage
            leftover = True  # shares are final from here: no candidate joins the soup's maps
            share[hidden] = LEFTOVER_SHARE
            fresh[:] = True
            continue
        j = int(np.argmax(np.where(ok, dv / np.maximum(dc, 1), -np.inf)))
        i = int(owner[j])
        if not fresh[i]:  # its share against the others as they are now, then pick again
            fresh[i] = True
            if stage[i] < 0:
                gain = float(soup_totals([i], covers > 0, bitmaps, base)[0] - base.sum())  # type: ignore[arg-type]
            else:
                others = (covers - bitmaps[i]) > 0
                gain = float(base.sum()) - float(soup_measures(others, 1.0).sum())
            share[i] = max(gain, 0.0) / alone[i] if alone[i] > 0 else 1.0
            continue
        left -= int(dc[j])
        if stage[i] < 0 and not leftover and alone[i] > 0:  # the soup's images change
            covers += bitmaps[i]
            base = soup_measures(covers > 0, 1.0)
            fresh[:] = False
        stage[i] = j - first[i]
        cur_v[i] = flat_v[j]
        cur_c[i] = flat_c[j]


def candidate_bitmaps(mesh, rings: list[np.ndarray], box_loops: list[np.ndarray],
                      sheets: list[np.ndarray] | tuple[np.ndarray, ...] = ()) -> np.ndarray:
    """``(k, N, R, R) bool``: the patch candidates' world loops, then each box (six loops in a
    row, OR-ed), then each sheet chunk (``(m, 3, 3)`` triangles, OR-ed), seen along the
    measure directions over ``mesh``'s orbit frame."""
    from viscore.metrics.frames import orbit_frame

    center, extent = orbit_frame(mesh)
    dirs = measure_directions(MEASURE_DIRECTIONS)
    tris = [t for chunk in sheets for t in chunk]
    maps = project_candidates(list(rings) + list(box_loops) + tris, dirs, center, extent,
                              MEASURE_RESOLUTION)
    if not box_loops and not tris:
        return maps
    patches, boxes, tris = np.split(maps, [len(rings), len(rings) + len(box_loops)])
    boxes = boxes.reshape(-1, 6, *maps.shape[1:]).any(axis=1)
    if sheets:  # each chunk's triangles, OR-ed (a chunk has one triangle at least)
        starts = np.cumsum([0] + [len(chunk) for chunk in sheets[:-1]])
        tris = np.logical_or.reduceat(tris, starts, axis=0)
    return np.concatenate([patches, boxes, tris])
