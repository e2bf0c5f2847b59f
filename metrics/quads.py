"""Random screen-aligned quads and their Nt / Pf / Nf classification.

The occludee test of the precision/recall protocols: Silvennoinen et al.
2014, sec. 6.1 [1]_ and Wu et al. 2022, sec. 3.2, eq. 6 [2]_, with this
bookkeeping. With n pixels in a quad, a of
them occluded by the original and b by the occluder:

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
.. [3] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
   Bursztyn, A. P. M. "Implementing software occlusion culling for real-time
   applications". XVIII Congreso Argentino de Ciencias de la Computacion
   (CACIC 2012), Workshop de Computacion Grafica, Imagenes y Visualizacion,
   2012. http://sedici.unlp.edu.ar/handle/10915/23640
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from viscore._jit import njit_cached

__all__ = ["QuadCounts", "sample_quads", "classify_quads", "classify_quads_depth",
           "summed_area_table"]

# Shared with the sibling modules (not user API): depth_levels_of, rect_sums,
# level_sums, quad_pixels, tally, level_table_bytes, ImageQuads, image_quads,
# original_tally, occluder_counts.


@dataclass(frozen=True)
class QuadCounts:
    """Pixel counts of one view (or one frustum), Nt, Pf, Nf.

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
    """Random axis-aligned quads inside a pixel box, as in the orbit protocol.

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


def quad_pixels(quads: np.ndarray) -> np.ndarray:
    """``(Q,) int64`` pixels in each quad."""
    q = quads.astype(np.int64, copy=False)
    return (q[:, 2] - q[:, 0]) * (q[:, 3] - q[:, 1])


def tally(n: np.ndarray, a: np.ndarray, b: np.ndarray) -> QuadCounts:
    """The one Nt / Pf / Nf bookkeeping of every protocol, from per-quad counts.

    ``n`` pixels per quad, ``a`` of them occluded by the original, ``b`` by
    the occluder (``(Q,)`` integers each).
    """
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
    return tally(quad_pixels(quads), rect_sums(original, quads), rect_sums(occluder, quads))


#: Bytes one stacked summed-area table of the depth-aware variant may take; more
#: levels than fit are counted a chunk at a time (same counts, bounded memory).
LEVEL_TABLE_BYTES = 256 * 2**20


def level_table_bytes(resolution: int, depth_levels: int) -> float:
    """Peak bytes of the depth-aware level tables of one R x R image (after chunking)."""
    per_level = 4.0 * (resolution + 1) ** 2 + resolution**2  # int32 table + bool mask
    return per_level * min(depth_levels, max(1, LEVEL_TABLE_BYTES // int(per_level)))


def depth_levels_of(depth: np.ndarray, depth_levels: int) -> np.ndarray | None:
    """The quad depth values of one original depth image: midpoints of equal bins.

    ``depth_levels`` evenly spaced values spanning the ORIGINAL's finite depths
    in the image (never the occluder's); None when the image is empty.
    """
    finite = depth[np.isfinite(depth)]
    if finite.size == 0:
        return None
    lo, hi = float(finite.min()), float(finite.max())
    return lo + (hi - lo) * (np.arange(depth_levels) + 0.5) / depth_levels


def rect_sums(image: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """``(Q,) int64`` count of True pixels of ``image`` in each quad (row0, col0, row1, col1)."""
    r0, c0, r1, c1 = quads.T
    return _rect_sum(summed_area_table(image), r0, c0, r1, c1)


def level_sums(depth: np.ndarray, levels: np.ndarray, level: np.ndarray, quads: np.ndarray
               ) -> np.ndarray:
    """``(Q,) int64`` pixels strictly nearer than each quad's depth level.

    A pixel occludes a quad at depth z when its buffer depth is ``< z``
    (``inf``, empty, never does). One stacked summed-area table answers every
    quad; levels are taken a chunk at a time so that the table stays within
    ``LEVEL_TABLE_BYTES``.
    """
    r0, c0, r1, c1 = quads.T
    rows, cols = depth.shape[0] + 1, depth.shape[1] + 1
    per_level = 4 * rows * cols + depth.size
    step = max(1, LEVEL_TABLE_BYTES // per_level)
    out = np.empty(len(level), dtype=np.int64)
    for first in range(0, len(levels), step):
        chunk = levels[first:first + step]
        table = np.zeros((len(chunk), rows, cols), dtype=np.int32)
        nearer = depth[None, :, :] < chunk[:, None, None]
        np.cumsum(np.cumsum(nearer, axis=1, dtype=np.int32), axis=2, out=table[:, 1:, 1:])
        del nearer
        sel = slice(None) if len(chunk) == len(levels) else (level >= first) & (
            level < first + len(chunk))
        lv = level[sel] - first
        a, b, c, d = r0[sel], c0[sel], r1[sel], c1[sel]
        out[sel] = (table[lv, c, d] - table[lv, a, d] - table[lv, c, b]
                    + table[lv, a, b]).astype(np.int64)
    return out


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
    box = (0, 0) + original_depth.shape
    ref = original_tally(0, 0, original_depth, box, quads, rng, depth_aware=True,
                         depth_levels=depth_levels)
    return occluder_counts(ref, occluder_depth)


@dataclass(frozen=True, eq=False)
class ImageQuads:
    """The original's side of one image (an orbit view or a volume frustum).

    ``unit`` is the row of ``per_view`` it counts in (orbit view, volume
    position) and ``cam`` its camera (orbit view, volume frustum 0-5).
    ``quads`` are ``(Q, 4)`` (int16 when the box allows) row0, col0, row1, col1 relative to
    ``box`` (the pixels the occluder must be cast for), or None when the
    image counts nothing (an orbit view the original misses; a depth-aware
    frustum the original misses). ``n`` and ``a`` are the pixels of each quad
    and those the original occludes; ``level`` the depth-level index of each
    quad and ``levels`` the level depths (depth-aware only).
    """

    unit: int
    cam: int
    box: tuple
    quads: np.ndarray | None
    n: np.ndarray | None = None
    a: np.ndarray | None = None
    level: np.ndarray | None = None
    levels: np.ndarray | None = None

    @property
    def nbytes(self) -> int:
        return sum(x.nbytes for x in (self.quads, self.n, self.a, self.level, self.levels)
                   if x is not None)


def image_quads(unit: int, cam: int, depth: np.ndarray, quads: int,
                rng: np.random.Generator, *, whole_screen: bool, depth_aware: bool,
                depth_levels: int) -> ImageQuads:
    """Draw one image's quads and tally the original over them.

    Orbit (``whole_screen=False``): inside the bounding box of the original's
    covered pixels, nothing where it covers none. Volume: the whole screen.
    """
    res = depth.shape
    if whole_screen:
        box = (0, 0, res[0], res[1])
    else:
        covered = np.isfinite(depth)
        rows = np.flatnonzero(covered.any(axis=1))
        if len(rows) == 0:
            return ImageQuads(unit, cam, (0, 0, 0, 0), None)
        cols = np.flatnonzero(covered.any(axis=0))
        box = (int(rows[0]), int(cols[0]), int(rows[-1]) + 1, int(cols[-1]) + 1)
    return original_tally(unit, cam, depth, box, sample_quads(box, quads, rng), rng,
                          depth_aware=depth_aware, depth_levels=depth_levels)


def original_tally(unit: int, cam: int, depth: np.ndarray, box: tuple, quads: np.ndarray,
                   rng: np.random.Generator, *, depth_aware: bool, depth_levels: int
                   ) -> ImageQuads:
    """The original's side of given quads (absolute pixels, inside ``box``).

    Depth-aware: the quads' depths are drawn from ``rng`` among levels
    spanning the ORIGINAL's finite depths over the box; an image the original
    misses counts nothing.
    """
    region = depth[box[0]:box[2], box[1]:box[3]]
    small = max(region.shape, default=0) < 2**15  # compact storage for cached views
    rel = (quads - np.array([box[0], box[1], box[0], box[1]])).astype(
        np.int16 if small else np.int64)
    n = quad_pixels(quads)
    if depth_aware:
        levels = depth_levels_of(region, depth_levels)
        if levels is None:  # nothing of the original here: no depth, no counts
            return ImageQuads(unit, cam, box, None)
        level = rng.integers(0, depth_levels, size=len(quads))
        a = level_sums(region, levels, level, rel)
        return ImageQuads(unit, cam, box, rel, n.astype(np.int32), a.astype(np.int32),
                          level.astype(np.int16 if depth_levels <= 2**15 else np.int64),
                          levels)
    a = rect_sums(np.isfinite(region), rel)
    return ImageQuads(unit, cam, box, rel, n.astype(np.int32), a.astype(np.int32))


def occluder_counts(ref: ImageQuads, occluder_region: np.ndarray | None) -> QuadCounts:
    """Nt, Pf, Nf of one image from the occluder's pixels over ``ref.box``.

    ``occluder_region`` is the occluder's coverage (bool) or depth (float,
    ``inf`` empty) over the box, or None where the occluder cannot be seen.
    """
    if ref.quads is None:
        return QuadCounts(0, 0, 0, 0)
    if occluder_region is not None and ref.levels is None and occluder_region.dtype == bool:
        counts = np.zeros(6, dtype=np.int64)
        _coverage_tally(np.ascontiguousarray(occluder_region), ref.quads, ref.n, ref.a, counts)
        nt, pf, nf, q_orig, q_occ, q_both = (int(c) for c in counts)
        return QuadCounts(nt=nt, pf=pf, nf=nf, quads=len(ref.quads), q_orig=q_orig,
                          q_occ=q_occ, q_both=q_both)
    quads = ref.quads.astype(np.int64)
    if occluder_region is None:
        b = np.zeros(len(quads), dtype=np.int64)
    elif ref.levels is not None:
        b = level_sums(occluder_region, ref.levels, ref.level.astype(np.int64), quads)  # type: ignore[union-attr]
    else:
        b = rect_sums(occluder_region, quads)
    return tally(ref.n, ref.a, b)  # type: ignore[arg-type]


@njit_cached(nogil=True)
def _coverage_tally(region, quads, n, a, out):  # pragma: no cover - compiled
    """:func:`tally` of the occluder's coverage ``region`` over ``quads`` (row0, col0, row1,
    col1 in the region), as :func:`rect_sums` and :func:`tally` count it, in one pass:
    ``out`` gets nt, pf, nf, q_orig, q_occ, q_both. Integer counts: the same as theirs."""
    h, w = region.shape
    sat = np.zeros((h + 1, w + 1), dtype=np.int64)
    for i in range(h):
        run = 0
        for j in range(w):
            run += region[i, j]
            sat[i + 1, j + 1] = sat[i, j + 1] + run
    nt = pf = nf = q_orig = q_occ = q_both = 0
    for k in range(quads.shape[0]):
        r0, c0, r1, c1 = quads[k, 0], quads[k, 1], quads[k, 2], quads[k, 3]
        b = sat[r1, c1] - sat[r0, c1] - sat[r1, c0] + sat[r0, c0]
        nk, ak = n[k], a[k]
        full_a = ak == nk
        full_b = b == nk
        if full_a:
            q_orig += 1
        if full_b:
            q_occ += 1
        if full_a and full_b:
            q_both += 1
            nt += nk
        elif full_a:
            pf += nk
        elif full_b:
            nf += nk - ak
    out[0], out[1], out[2] = nt, pf, nf
    out[3], out[4], out[5] = q_orig, q_occ, q_both
