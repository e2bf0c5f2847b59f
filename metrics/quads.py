"""Random screen-aligned quads and their Nt / Pf / Nf classification.

The occludee test of the precision/recall protocols: Silvennoinen et al.
2014, sec. 6.1 (seeds/000) and the building-occluders paper, sec. 3.2, eq. 6
(seeds/001), with the bookkeeping of DESIGN.md. With n pixels in a quad, a of
them occluded by the original and b by the occluder:

- a == n and b == n: true negatives, Nt += n
- a == n and b < n: lost occlusion (the papers' false positives), Pf += n
- b == n and a < n: false occlusion (false negatives), Nf += n - a

Counts over a quad come from summed-area tables, O(1) per quad. The
depth-aware variant gives each quad a depth and counts a pixel as occluded
when the buffer's depth there is nearer than the quad (the occludee test of
the occluder-skins paper, sec. 6, seeds/002); quad depths take one of
``depth_levels`` values so that one summed-area table per level answers all
quads.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["QuadCounts", "sample_quads", "classify_quads", "classify_quads_depth",
           "summed_area_table"]


@dataclass(frozen=True)
class QuadCounts:
    """Pixel counts of one view (or one frustum), DESIGN.md's Nt, Pf, Nf.

    Attributes
    ----------
    nt : int
        Pixels of quads occluded by both (true negatives).
    pf : int
        Pixels of quads occluded by the original only (lost occlusion).
    nf : int
        Unoccluded-by-original pixels of quads the occluder occludes (false occlusion).
    quads : int
        Quads sampled.
    q_orig : int
        Quads fully occluded by the original (a == n).
    q_occ : int
        Quads fully occluded by the occluder (b == n).
    q_both : int
        Quads fully occluded by both. Per-quad recall of the view is
        q_both / q_orig and per-quad precision q_both / q_occ: quads are
        independent draws given the view, so these are binomial counts
        (the Bayesian models of :mod:`viscore.metrics.bayes` use them).
    """

    nt: int
    pf: int
    nf: int
    quads: int
    q_orig: int = 0
    q_occ: int = 0
    q_both: int = 0


def summed_area_table(image: np.ndarray) -> np.ndarray:
    """``(R+1, C+1) int64`` table S with S[i, j] = sum of image[:i, :j].

    Examples
    --------
    >>> int(summed_area_table(np.ones((3, 4), bool))[-1, -1])
    12
    """
    s = np.zeros((image.shape[0] + 1, image.shape[1] + 1), dtype=np.int64)
    np.cumsum(np.cumsum(image, axis=0, dtype=np.int64), axis=1, out=s[1:, 1:])
    return s


def _rect_sum(sat: np.ndarray, r0, c0, r1, c1) -> np.ndarray:
    """Sums over rows [r0, r1) and columns [c0, c1) for arrays of rectangles."""
    return sat[r1, c1] - sat[r0, c1] - sat[r1, c0] + sat[r0, c0]


def sample_quads(box: tuple[int, int, int, int], count: int, rng: np.random.Generator
                 ) -> np.ndarray:
    """Random axis-aligned quads inside a pixel box, as in DESIGN.md's orbit protocol.

    Parameters
    ----------
    box : (row0, col0, row1, col1)
        Inclusive-exclusive pixel box [row0, row1) x [col0, col1), non-empty.
    count : int
        Q, the number of quads.
    rng : numpy.random.Generator

    Returns
    -------
    quads : (Q, 4) int64
        row0, col0, row1, col1 (exclusive ends). Width is uniform in
        [1, max(1, W // 4)], height in [1, max(1, H // 4)], position uniform
        so that the quad lies inside the box.

    Examples
    --------
    >>> q = sample_quads((0, 0, 8, 8), 100, np.random.default_rng(0))
    >>> bool(((q[:, 2] - q[:, 0]) <= 2).all() and (q[:, 2] <= 8).all())
    True
    """
    r0, c0, r1, c1 = box
    h_box, w_box = r1 - r0, c1 - c0
    w = rng.integers(1, max(1, w_box // 4), size=count, endpoint=True)
    h = rng.integers(1, max(1, h_box // 4), size=count, endpoint=True)
    x = c0 + rng.integers(0, w_box - w, endpoint=True)
    y = r0 + rng.integers(0, h_box - h, endpoint=True)
    return np.stack([y, x, y + h, x + w], axis=1)


def _tally(n: np.ndarray, a: np.ndarray, b: np.ndarray) -> QuadCounts:
    full_a = a == n
    full_b = b == n
    both = full_a & full_b
    return QuadCounts(nt=int(n[both].sum()), pf=int(n[full_a & ~full_b].sum()),
                      nf=int((n - a)[full_b & ~full_a].sum()), quads=len(n),
                      q_orig=int(full_a.sum()), q_occ=int(full_b.sum()), q_both=int(both.sum()))


def classify_quads(original: np.ndarray, occluder: np.ndarray, quads: np.ndarray) -> QuadCounts:
    """Nt, Pf, Nf of quads over two coverage images.

    Parameters
    ----------
    original, occluder : (R, C) bool
        Pixels covered (occluded) by the original mesh and by the occluder.
    quads : (Q, 4) int
        From :func:`sample_quads`.

    Returns
    -------
    QuadCounts

    Examples
    --------
    >>> orig = np.ones((4, 4), bool); occ = orig.copy(); occ[0, 0] = False
    >>> classify_quads(orig, occ, np.array([[0, 0, 2, 2], [2, 2, 4, 4]]))
    QuadCounts(nt=4, pf=4, nf=0, quads=2, q_orig=2, q_occ=1, q_both=1)
    """
    r0, c0, r1, c1 = quads.T
    n = (r1 - r0) * (c1 - c0)
    a = _rect_sum(summed_area_table(original), r0, c0, r1, c1)
    b = _rect_sum(summed_area_table(occluder), r0, c0, r1, c1)
    return _tally(n, a, b)


def _level_sums(depth: np.ndarray, levels: np.ndarray, level: np.ndarray, r0, c0, r1, c1
                ) -> np.ndarray:
    """Pixels nearer than each quad's depth level, from one stacked summed-area table."""
    table = np.zeros((len(levels), depth.shape[0] + 1, depth.shape[1] + 1), dtype=np.int32)
    nearer = depth[None, :, :] < levels[:, None, None]
    np.cumsum(np.cumsum(nearer, axis=1, dtype=np.int32), axis=2, out=table[:, 1:, 1:])
    return (table[level, r1, c1] - table[level, r0, c1] - table[level, r1, c0]
            + table[level, r0, c0]).astype(np.int64)


def classify_quads_depth(original_depth: np.ndarray, occluder_depth: np.ndarray,
                         quads: np.ndarray, rng: np.random.Generator, *,
                         depth_levels: int = 32) -> QuadCounts:
    """Depth-aware Nt, Pf, Nf: a pixel occludes a quad when its depth is nearer.

    Each quad gets a depth drawn uniformly from ``depth_levels`` evenly spaced
    values spanning the original's finite depths in the image (the midpoints
    of equal bins); a buffer occludes the pixel when its depth is strictly
    smaller. ``inf`` (empty) never occludes.

    Parameters
    ----------
    original_depth, occluder_depth : (R, C) float
        Depth images, ``inf`` where empty.
    quads : (Q, 4) int
    rng : numpy.random.Generator
        Draws the quad depths.
    depth_levels : int, optional
        Number of quad depth values, default 32.

    Returns
    -------
    QuadCounts
    """
    finite = original_depth[np.isfinite(original_depth)]
    if finite.size == 0:
        return QuadCounts(0, 0, 0, len(quads))
    lo, hi = float(finite.min()), float(finite.max())
    levels = lo + (hi - lo) * (np.arange(depth_levels) + 0.5) / depth_levels
    level = rng.integers(0, depth_levels, size=len(quads))
    r0, c0, r1, c1 = quads.T
    n = (r1 - r0) * (c1 - c0)
    a = _level_sums(original_depth, levels, level, r0, c0, r1, c1)
    b = _level_sums(occluder_depth, levels, level, r0, c0, r1, c1)
    return _tally(n, a, b)
