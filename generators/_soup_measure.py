"""The occlusion measure of a polygon soup over orthographic directions, on bitmaps.

Silvennoinen et al. 2014 [1]_, sec. 3, eqs. 2-3: the mean over fixed
directions of the measure of the soup's orthographic projection.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 3)
"""

from __future__ import annotations

import threading

import numpy as np

from viscore import camera_basis, directions_fibonacci
from viscore._jit import njit_cached
from viscore._sort_kernels import sort_prefix
from viscore._validate import check_memory

__all__ = ["measure_directions", "measure_bases", "project_candidates", "soup_measures",
           "soup_totals", "in_threads", "MEASURE_DIRECTIONS", "MEASURE_RESOLUTION"]

#: Directions of the measure (upper hemisphere; M(d) = M(-d)).
MEASURE_DIRECTIONS = 24

#: Pixels per side of each measure image over the orbit frame.
MEASURE_RESOLUTION = 64


def measure_directions(n: int = MEASURE_DIRECTIONS) -> np.ndarray:
    """``(n, 3)`` Fibonacci directions of the upper hemisphere."""
    return directions_fibonacci(2 * n)[:n]


def measure_bases(directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(N, 3)`` right and ``(N, 3)`` up image axes of each direction, as
    :func:`viscore.camera_basis` gives them (for :func:`project_candidates`' ``bases``:
    callers that project many times over the same directions find them once)."""
    frames = [camera_basis(d) for d in np.asarray(directions, dtype=np.float64)]
    rights = np.array([f[1] for f in frames], dtype=np.float64).reshape(-1, 3)
    ups = np.array([f[2] for f in frames], dtype=np.float64).reshape(-1, 3)
    return rights, ups


def project_candidates(rings: list[np.ndarray], directions: np.ndarray, center: np.ndarray,
                       extent: float, resolution: int = MEASURE_RESOLUTION, *,
                       bases: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Bitmaps of planar polygons seen along each direction.

    Parameters
    ----------
    rings : list of (m_i, 3) float
        World loops (weakly simple, holes bridged).
    directions : (N, 3) float
    center, extent
        Orthographic window (the orbit frame), world units.
    resolution : int
    bases : ((N, 3), (N, 3)) float, optional
        :func:`measure_bases` of ``directions``, when the caller has it.

    Returns
    -------
    bitmaps : (n, N, R, R) bool
        True where the pixel centre's ray along the direction meets polygon i
        (even-odd rule: a bridge, walked twice, adds nothing). Row 0 at the
        top, as :meth:`viscore.OrthoCamera.project`.
    """
    n, nd, r = len(rings), len(directions), resolution
    check_memory(float(n) * nd * r * r, f"{n} candidates x {nd} directions x {r}^2 pixels")
    out = np.zeros((n, nd, r, r), dtype=bool)
    if n == 0:
        return out
    points = np.concatenate(rings) - np.asarray(center, dtype=np.float64)
    starts = np.concatenate([[0], np.cumsum([len(g) for g in rings])]).astype(np.int64)
    rights, ups = measure_bases(directions) if bases is None else bases
    for k in range(nd):  # as OrthoCamera(d, center, extent, r).project
        right, up = rights[k], ups[k]
        cols = (points @ right / extent + 0.5) * r
        rows = (0.5 - points @ up / extent) * r
        _fill_polygons(cols, rows, starts, out, k)
    return out


@njit_cached()
def _fill_polygons(xs, ys, starts, out, k):  # pragma: no cover
    """Scanline fill (even-odd) of polygon i into ``out[i, k]`` at the pixel centres."""
    n = len(starts) - 1
    r = out.shape[2]
    cross = np.empty(len(xs))
    for i in range(n):
        s, e = starts[i], starts[i + 1]
        ymin = ymax = ys[s]
        for a in range(s + 1, e):
            ymin, ymax = min(ymin, ys[a]), max(ymax, ys[a])
        r0 = max(0, int(np.ceil(ymin - 0.5)))
        r1 = min(r - 1, int(np.floor(ymax - 0.5)))
        for row in range(r0, r1 + 1):
            yc = row + 0.5
            m = np.int64(0)  # not the literal 0: sort_prefix compiled once, for int64
            for a in range(s, e):
                b = a + 1 if a + 1 < e else s
                ya, yb = ys[a], ys[b]
                if (ya > yc) != (yb > yc):
                    cross[m] = xs[a] + (yc - ya) * (xs[b] - xs[a]) / (yb - ya)
                    m += 1
            if m < 2:
                continue
            sort_prefix(cross, m)  # cross[:m] ascending
            c = cross
            for t in range(0, m - 1, 2):
                c0 = max(0, int(np.ceil(c[t] - 0.5)))
                c1 = min(r, int(np.ceil(c[t + 1] - 0.5)))
                for col in range(c0, c1):
                    out[i, k, row, col] = True


#: The measure kernel keeps squared distances times 4 as integers (pixel centres and
#: crossings on a grid of half pixels: exact); this stands for "no crossing".
_FAR = 2**62


@njit_cached(nogil=True)
def _line_distances(x, n, out):  # pragma: no cover
    """``out[j]`` (j < n): 4 x the squared distance from pixel j of the line ``x`` to the
    nearest crossing along the line (half-way between two neighbours that differ;
    outside the line is background), :data:`_FAR` where the line has none.

    One pass over the line's runs of equal pixels: a run ``[s, e)`` has its crossings
    at ``2s - 1`` (unless it is background starting the line) and ``2e - 1`` (unless it
    is background ending it), in half pixels.
    """
    s = 0
    while s < n:
        v = x[s]
        e = s + 1
        while e < n and x[e] == v:
            e += 1
        left, right = s > 0 or v, e < n or v
        lc, rc = 2 * s - 1, 2 * e - 1
        for j in range(s, e):
            d = (2 * j - lc) * (2 * j - lc) if left else _FAR
            if right and (rc - 2 * j) * (rc - 2 * j) < d:
                d = (rc - 2 * j) * (rc - 2 * j)
            out[j] = d
        s = e


@njit_cached(nogil=True)
def _root_table(n):  # pragma: no cover
    """``(n * n + 1,) float64``: ``sqrt(d / 4)`` for every ``d`` up to ``n^2``: every
    distance (pixels) :func:`_image_measure` finds in an image whose shorter side is
    at most ``n`` pixels (a covered pixel's is at most half of each side), by the same
    operations as computing each one (the same bits)."""
    out = np.empty(n * n + 1)
    for d in range(n * n + 1):
        out[d] = np.sqrt(np.float64(d) * 0.25)
    return out


@njit_cached(nogil=True)
def _image_measure(img, rows, cols, roots):  # pragma: no cover
    """Sum over covered pixels of the distance (pixels) to the nearest mid-point crossing.

    ``img`` (H, W) bool is taken with a background border around it; the covered
    pixels are summed row by row. ``rows`` and ``cols`` (H, W) int64 are scratch for
    the distances along each row and down each column (4 x squared pixels, exact
    integers; :func:`_line_distances`); ``roots`` is :func:`_root_table` of at least
    ``min(H, W)``.

    A covered pixel's distance is the least, over rows ``i +- p`` and columns ``j +- p``,
    of ``4 p^2`` plus that line's distance at the pixel's column or row; the search
    goes out from ``p = 1`` and stops once ``4 p^2`` reaches the least found (no
    farther line can give less). The border's crossings bound the first value by
    the pixel's distance to every side, so the search stays inside the image, and the
    integer found is the exact squared distance times 4.
    """
    h, w = img.shape
    for i in range(h):  # rows[i, ::1]: a view of the columns' layout, one compiled version
        _line_distances(img[i], w, rows[i, ::1])
    for j in range(w):
        _line_distances(img[:, j], h, cols[:, j])
    total = 0.0
    for i in range(h):
        for j in range(w):
            if not img[i, j]:
                continue
            best = rows[i, j]
            if cols[i, j] < best:
                best = cols[i, j]
            p = 1
            pp = 4
            while pp < best:  # p <= i, h-1-i, j, w-1-j: inside the image
                d = pp + rows[i - p, j]
                if d < best:
                    best = d
                d = pp + rows[i + p, j]
                if d < best:
                    best = d
                d = pp + cols[i, j - p]
                if d < best:
                    best = d
                d = pp + cols[i, j + p]
                if d < best:
                    best = d
                p += 1
                pp = 4 * p * p
            total += roots[best]
    return total


@njit_cached(nogil=True)
def _soup_totals(ids, union, bitmaps, base, use_area, out):  # pragma: no cover
    """``out[t]``: total over directions of the measure of (union | bitmap ``ids[t]``).

    ``base`` (N,) holds the union's own per-direction values (reused where a
    bitmap adds nothing). Pixel units (distance sums, or pixel counts).
    """
    _, nd, h, w = bitmaps.shape
    img = np.empty((h, w), np.bool_)
    rows = np.empty((h, w), np.int64)
    cols = np.empty((h, w), np.int64)
    roots = _root_table(min(h, w)) if not use_area else np.empty(0)
    for t in range(len(ids)):
        i = ids[t]
        total = 0.0
        for k in range(nd):
            adds = 0
            a0, a1, b0, b1 = h, -1, w, -1
            for a in range(h):
                for b in range(w):
                    v = union[k, a, b] or bitmaps[i, k, a, b]
                    img[a, b] = v
                    if v:
                        if not union[k, a, b]:
                            adds += 1
                        a0 = min(a0, a)
                        a1 = max(a1, a)
                        b0 = min(b0, b)
                        b1 = max(b1, b)
            if adds == 0:
                total += base[k]
            elif use_area:
                total += base[k] + adds
            else:  # the covered pixels' bounding box: outside it is background anyway
                total += _image_measure(img[a0:a1 + 1, b0:b1 + 1], rows, cols, roots)
        out[t] = total
    return out


@njit_cached(nogil=True)
def _images_measures(images, out):  # pragma: no cover
    """``out[k]`` = :func:`_image_measure` of ``images[k]`` (pixel units), measured over
    its covered pixels' bounding box as :func:`_soup_totals` measures (outside it is
    background: the same distances, so the same sum; and the same compiled version of
    :func:`_image_measure`, on a view of that layout)."""
    h, w = images.shape[1:]
    rows = np.empty((h, w), np.int64)
    cols = np.empty((h, w), np.int64)
    roots = _root_table(min(h, w))
    for k in range(len(images)):
        a0, a1, b0, b1 = h, -1, w, -1
        for a in range(h):
            for b in range(w):
                if images[k, a, b]:
                    a0 = min(a0, a)
                    a1 = max(a1, a)
                    b0 = min(b0, b)
                    b1 = max(b1, b)
        out[k] = 0.0 if a1 < 0 else _image_measure(images[k, a0:a1 + 1, b0:b1 + 1], rows,
                                                    cols, roots)


#: Fewest items (candidates of a greedy step, images of a measure) per thread: below
#: this a batch runs on the calling thread.
MIN_PER_THREAD = 8


def in_threads(kernel, items: np.ndarray, *shared, out: np.ndarray) -> np.ndarray:
    """``kernel(items[lo:hi], *shared, out[lo:hi])`` over contiguous parts of ``items`` on
    :func:`viscore.get_workers` threads (the kernels release the GIL and each part writes
    its own slice of ``out``, so the result is that of one call over all items)."""
    from viscore import get_workers

    parts = min(get_workers(), len(items) // MIN_PER_THREAD)
    if parts <= 1:
        kernel(items, *shared, out)
        return out
    cuts = np.linspace(0, len(items), parts + 1).astype(np.int64)
    pool = _helpers(parts - 1)
    jobs = [pool.submit(kernel, items[lo:hi], *shared, out[lo:hi])
            for lo, hi in zip(cuts[1:-1], cuts[2:], strict=True)]
    kernel(items[:cuts[1]], *shared, out[:cuts[1]])
    for job in jobs:
        job.result()
    return out


_pools: dict = {}
_pools_lock = threading.Lock()


def _helpers(threads: int):
    """A thread pool of at least ``threads`` threads, kept for the process (a greedy
    search makes thousands of batches; starting threads for each costs more than the
    work of the small ones). A forked child makes its own."""
    import os
    from concurrent.futures import ThreadPoolExecutor

    with _pools_lock:
        pid, pool, size = _pools.get("pool", (None, None, 0))
        if pid != os.getpid() or size < threads:
            if pid == os.getpid():
                pool.shutdown(wait=False)
            pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="viscore-measure")
            _pools["pool"] = (os.getpid(), pool, threads)
        return pool


def soup_measures(images: np.ndarray, pixel: float, *, measure: str = "om") -> np.ndarray:
    """Per-image measure, world units: M(d) (``'om'``) or projected area (``'area'``).

    Parameters
    ----------
    images : (N, R, R) bool
    pixel : float
        Pixel side, world units.

    Returns
    -------
    (N,) float64
    """
    images = np.ascontiguousarray(images, dtype=bool)
    if measure == "area":
        return images.reshape(len(images), -1).sum(axis=1) * pixel**2
    out = in_threads(_images_measures, images, out=np.empty(len(images)))
    return out * pixel**3


def soup_totals(ids: np.ndarray, union: np.ndarray, bitmaps: np.ndarray, base: np.ndarray,
                *, measure: str = "om") -> np.ndarray:
    """``(len(ids),) float64``: per candidate ``i`` in ``ids``, the sum over directions of
    the measure of ``union | bitmaps[i]``, pixel units (distance sums, or pixel counts for
    ``measure='area'``). ``base`` (N,) is the union's own per-direction values, reused
    where a bitmap adds nothing."""
    ids = np.ascontiguousarray(ids, dtype=np.int64)
    return in_threads(_soup_totals, ids, np.ascontiguousarray(union, dtype=bool), bitmaps,
                      np.asarray(base, dtype=np.float64), measure == "area",
                      out=np.empty(len(ids)))
