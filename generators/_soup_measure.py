"""The occlusion measure of a polygon soup over orthographic directions, on bitmaps.

Silvennoinen et al. 2014 [1]_, sec. 3, eqs. 2-3: the mean over fixed
directions of the measure of the soup's orthographic projection.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 3)
.. [2] Felzenszwalb, P. F., Huttenlocher, D. P. "Distance Transforms of
   Sampled Functions". Theory of Computing 8, 2012, pp. 415-428.
   :DOI:`10.4086/toc.2012.v008a019`
"""

from __future__ import annotations

import threading

import numpy as np

from viscore import camera_basis, directions_fibonacci
from viscore._jit import njit_cached
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
        ymin, ymax = ys[s:e].min(), ys[s:e].max()
        r0 = max(0, int(np.ceil(ymin - 0.5)))
        r1 = min(r - 1, int(np.floor(ymax - 0.5)))
        for row in range(r0, r1 + 1):
            yc = row + 0.5
            m = 0
            for a in range(s, e):
                b = a + 1 if a + 1 < e else s
                ya, yb = ys[a], ys[b]
                if (ya > yc) != (yb > yc):
                    cross[m] = xs[a] + (yc - ya) * (xs[b] - xs[a]) / (yb - ya)
                    m += 1
            if m < 2:
                continue
            c = np.sort(cross[:m])
            for t in range(0, m - 1, 2):
                c0 = max(0, int(np.ceil(c[t] - 0.5)))
                c1 = min(r, int(np.ceil(c[t + 1] - 0.5)))
                for col in range(c0, c1):
                    out[i, k, row, col] = True


#: The measure kernel keeps squared distances times 4 as integers (pixel centres and
#: crossings on a grid of half pixels: exact, and its envelope compares intersections by
#: cross-multiplying instead of dividing); this stands for "no crossing".
_FAR = 2**62


@njit_cached(nogil=True)
def _envelope4(f, n, out, v, zn, zd):  # pragma: no cover
    """``out[q] = min_p 4 (q - p)^2 + f[p]`` for q < n, integers, over the p with ``f[p]`` under
    :data:`_FAR` (all :data:`_FAR`: ``out`` is :data:`_FAR`).

    The lower envelope of parabolas (Felzenszwalb, Huttenlocher [2]_, DT(f)), with each
    intersection kept as a fraction ``zn / zd`` (zd > 0) and compared exactly. Scratch:
    ``v``, ``zn``, ``zd`` (>= n,) int64.
    """
    k = -1
    for q in range(n):
        fq = f[q]
        if fq >= _FAR:
            continue
        if k < 0:
            k = 0
            v[0] = q
            continue
        num = 0
        den = 1
        while True:  # intersection with parabola v[k]: (fq + 4q^2 - fp - 4p^2) / (8 (q - p))
            p = v[k]
            num = fq + 4 * q * q - f[p] - 4 * p * p
            den = 8 * (q - p)
            if k > 0 and num * zd[k] <= zn[k] * den:
                k -= 1
            else:
                break
        k += 1
        v[k] = q
        zn[k] = num
        zd[k] = den
    if k < 0:
        for q in range(n):
            out[q] = _FAR
        return
    last = k
    k = 0
    for q in range(n):
        while k < last and zn[k + 1] < q * zd[k + 1]:
            k += 1
        p = v[k]
        out[q] = 4 * (q - p) * (q - p) + f[p]


@njit_cached(nogil=True)
def _image_measure(img, buf_a, buf_b, col, tmp, v, zn, zd):  # pragma: no cover
    """Sum over covered pixels of the distance (pixels) to the nearest mid-point crossing.

    ``img`` (H, W) bool is taken with a background border around it; the covered
    pixels are summed row by row. Distances are found squared and times 4, as
    integers (exact), by :func:`_envelope4`. Buffers (H, W) int64 ``buf_a``,
    ``buf_b``; ``col``, ``tmp``, ``v``, ``zn``, ``zd`` int64 of length max(H, W).
    """
    h, w = img.shape
    # 1) crossings on rows (between horizontal neighbours), nearest along the row; with
    # pixel j at 2j, the crossing before it at 2j - 1 and after it at 2j + 1
    for i in range(h):
        seen, last = False, 0
        for j in range(w):
            left = img[i, j - 1] if j > 0 else False
            if img[i, j] != left:
                seen, last = True, 2 * j - 1
            buf_a[i, j] = (2 * j - last) * (2 * j - last) if seen else _FAR
        seen, nxt = False, 0
        for j in range(w - 1, -1, -1):
            right = img[i, j + 1] if j < w - 1 else False
            if img[i, j] != right:
                seen, nxt = True, 2 * j + 1
            if seen:
                d = (nxt - 2 * j) * (nxt - 2 * j)
                if d < buf_a[i, j]:
                    buf_a[i, j] = d
    for j in range(w):  # envelope down each column
        for i in range(h):
            col[i] = buf_a[i, j]
        _envelope4(col, h, tmp, v, zn, zd)
        for i in range(h):
            buf_a[i, j] = tmp[i]
    # 2) crossings on columns (between vertical neighbours), nearest along the column
    for j in range(w):
        seen, last = False, 0
        for i in range(h):
            up = img[i - 1, j] if i > 0 else False
            if img[i, j] != up:
                seen, last = True, 2 * i - 1
            buf_b[i, j] = (2 * i - last) * (2 * i - last) if seen else _FAR
        seen, nxt = False, 0
        for i in range(h - 1, -1, -1):
            down = img[i + 1, j] if i < h - 1 else False
            if img[i, j] != down:
                seen, nxt = True, 2 * i + 1
            if seen:
                d = (nxt - 2 * i) * (nxt - 2 * i)
                if d < buf_b[i, j]:
                    buf_b[i, j] = d
    total = 0.0
    for i in range(h):  # envelope along each row, then the minimum of both families
        for j in range(w):
            col[j] = buf_b[i, j]
        _envelope4(col, w, tmp, v, zn, zd)
        for j in range(w):
            if img[i, j]:
                d = tmp[j]
                if buf_a[i, j] < d:
                    d = buf_a[i, j]
                total += np.sqrt(np.float64(d) * 0.25)
    return total


@njit_cached(nogil=True)
def _soup_totals(ids, union, bitmaps, base, use_area, out):  # pragma: no cover
    """``out[t]``: total over directions of the measure of (union | bitmap ``ids[t]``).

    ``base`` (N,) holds the union's own per-direction values (reused where a
    bitmap adds nothing). Pixel units (distance sums, or pixel counts).
    """
    _, nd, h, w = bitmaps.shape
    img = np.empty((h, w), np.bool_)
    buf_a = np.empty((h, w), np.int64)
    buf_b = np.empty((h, w), np.int64)
    m = max(h, w)
    col = np.empty(m, np.int64)
    tmp = np.empty(m, np.int64)
    env_v = np.empty(m, np.int64)
    env_zn = np.empty(m, np.int64)
    env_zd = np.empty(m, np.int64)
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
                total += _image_measure(img[a0:a1 + 1, b0:b1 + 1], buf_a, buf_b, col, tmp,
                                        env_v, env_zn, env_zd)
        out[t] = total
    return out


@njit_cached(nogil=True)
def _images_measures(images, out):  # pragma: no cover
    """``out[k]`` = :func:`_image_measure` of ``images[k]`` (pixel units)."""
    h, w = images.shape[1:]
    m = max(h, w)
    buf_a = np.empty((h, w), np.int64)
    buf_b = np.empty((h, w), np.int64)
    col = np.empty(m, np.int64)
    tmp = np.empty(m, np.int64)
    env_v = np.empty(m, np.int64)
    env_zn = np.empty(m, np.int64)
    env_zd = np.empty(m, np.int64)
    for k in range(len(images)):
        out[k] = _image_measure(images[k], buf_a, buf_b, col, tmp, env_v, env_zn, env_zd)


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
