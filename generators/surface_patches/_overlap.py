"""Surface patches, step 4 with overlap: the knapsack's values discounted by the soup.

The selection of :mod:`.generator` raises, at each step, the candidate whose
next stage adds the most value per added triangle. Taken one by one, the
values count twice what two candidates cover together: the two faces of a
thick wall, a floor and the ceiling under it, a box behind the wall that
hides it. Silvennoinen et al. [1]_, sec. 4.5, select by the occlusion
measure of the whole soup instead (sec. 3, eqs. 2-3: the mean over
orthographic directions of the measure of the soup's projection), so a
polygon adds only what the others do not already block.

Here each candidate's value is scaled by its *share*: the measure it adds
to the soup of the other chosen candidates, over the measure it has alone,
both over the directions and with the whole candidates' bitmaps of
:mod:`viscore.generators._soup_measure`.
A share is recomputed only for the candidate at the top of the queue and
only when a candidate joined the soup since (lazy evaluation, Minoux [2]_):
shares shrink as the soup grows, except where two polygons side by side
block wider beams than either, so a stale share is almost always an upper
bound. Stages within a candidate keep the generator's values (the full
stage's head-on measure, scaled by area^1.5), times the share. A candidate
that covers no pixel of the images (under a pixel of the whole input's
frame: a house's wall in a level a hundred times its size) cannot be
measured against the soup and keeps its own value (share 1).

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
