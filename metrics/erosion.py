"""Erosion-based occlusion measure of an object (Silvennoinen et al. 2014, sec. 3).

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [2] Felzenszwalb, P. F., Huttenlocher, D. P. "Distance Transforms of
   Sampled Functions". Theory of Computing 8, 2012, pp. 415-428.
   :DOI:`10.4086/toc.2012.v008a019`
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import trimesh

from viscore import InputError, OrthoCamera, Scene, directions_uniform_batches
from viscore._jit import njit_cached
from viscore._validate import (
    as_positive,
    as_positive_int,
    as_seed,
    as_unit_vectors,
    as_vector,
    check_memory,
)

from ._views import scene_of
from .frames import orbit_frame

__all__ = ["OcclusionMeasure", "directional_occlusion_measure", "occlusion_measure",
           "erosion_curve", "BOUNDARY_STEPS"]

#: Bisection rays per boundary crossing: the crossing is located to 1/64 of
#: a pixel. Measured on disks, turned squares and parallelograms: 0 steps
#: (mid-points) err by -0.4% to -1.0% at 512 px, 2 steps by -0.1% to -0.2%,
#: 4 or more by less than 0.05%; beyond that the error is the Riemann sum's
#: own (second order).
BOUNDARY_STEPS = 5

#: Largest image side, pixels.
_MAX_RESOLUTION = 8192

#: Rays per Embree call of the coverage and bisection casts (bounds their
#: float64 origin and direction buffers, about 60 MB).
_RAYS_PER_BATCH = 1 << 20

#: Directions drawn per batch: memory does not grow with the direction count.
_DIRECTIONS_PER_BATCH = 1024

#: Peak bytes per pixel of one view: the padded coverage (1), the crossing
#: positions (2 x 8), the squared distances and the transform's work array
#: (3 x 8), the radius map (8), rounded up.
_BYTES_PER_PIXEL = 64

#: Bytes per ray of one batch: float64 origins, directions and pixel points,
#: the Embree float32 copies and the hit flags, rounded up.
_BYTES_PER_RAY = 96

#: Bytes kept per direction: M(d) and A(I_{d,0}), float64 each.
_BYTES_PER_DIRECTION = 16


# ---------------------------------------------------------------- distance transform
@njit_cached()
def _row_crossing_distances(seeds: np.ndarray, out_t: np.ndarray) -> None:  # pragma: no cover
    """Squared distance from each pixel centre to the crossings on the pixel rows.

    ``seeds[i, g]`` (H, W-1) is the offset (pixels, in [0, 1]) of the
    crossing on row ``i`` between the centres of columns ``g`` and ``g + 1``,
    NaN if none; pixel centres are at integer coordinates. Pass 1 gives each
    pixel the nearest crossing on its own row; pass 2 is the lower envelope
    of parabolas down each column (Felzenszwalb and Huttenlocher 2012,
    algorithm DT(f)), exact. ``out_t`` (W, H), the transposed image, takes
    the minimum of itself and the result (both passes then run along
    contiguous memory).
    """
    w, h = out_t.shape
    g = np.empty((w, h))  # transposed: column j of the image is row j here
    for i in range(h):
        last = -np.inf
        for j in range(w):
            if j >= 1 and not np.isnan(seeds[i, j - 1]):
                last = j - 1 + seeds[i, j - 1]
            g[j, i] = (j - last) ** 2
        nxt = np.inf
        for j in range(w - 1, -1, -1):
            if j <= w - 2 and not np.isnan(seeds[i, j]):
                nxt = j + seeds[i, j]
            d = (nxt - j) ** 2
            if d < g[j, i]:
                g[j, i] = d
    v = np.empty(h, dtype=np.int64)
    z = np.empty(h + 1)
    for j in range(w):
        lower_envelope_min(g[j], v, z, out_t[j])


@njit_cached()
def lower_envelope_min(f: np.ndarray, v: np.ndarray, z: np.ndarray,
                       row: np.ndarray) -> None:  # pragma: no cover
    """Minimum of ``row`` and the lower envelope of parabolas ``(q - p)^2 + f[p]``.

    One pass of the exact squared Euclidean distance transform (Felzenszwalb
    and Huttenlocher 2012, algorithm DT(f)): ``row[q]`` (N,) becomes
    ``min(row[q], min_p (q - p)^2 + f[p])``; entries of ``f`` (N,) equal to
    inf are skipped, and ``row`` is left as it is if all are. ``v`` (N,)
    int64 and ``z`` (N+1,) float64 are scratch buffers.
    """
    h = len(f)
    k = -1
    for q in range(h):
        fq = f[q]
        if fq == np.inf:
            continue
        if k < 0:
            k = 0
            v[0] = q
            z[0] = -np.inf
            z[1] = np.inf
            continue
        while True:
            p = v[k]
            s = ((fq + q * q) - (f[p] + p * p)) / (2.0 * (q - p))
            if s <= z[k]:
                k -= 1  # z[0] = -inf: never below 0
            else:
                break
        k += 1
        v[k] = q
        z[k] = s
        z[k + 1] = np.inf
    if k < 0:
        return
    k = 0
    for q in range(h):
        while z[k + 1] < q:
            k += 1
        p = v[k]
        d = (q - p) ** 2 + f[p]
        if d < row[q]:
            row[q] = d


def _crossings(padded: np.ndarray, inside: Callable | None, steps: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """Boundary crossings between 4-neighbouring pixel centres of a padded image.

    Returns ``rows`` (H, W-1) and ``cols`` (H-1, W): the crossing's offset in
    pixels from the first pixel of the pair (left, upper), NaN where the
    pair's coverage agrees. Bisected with ``inside`` (continuous pixel
    coordinates of the unpadded image), else 0.5.
    """
    rows = np.full((padded.shape[0], padded.shape[1] - 1), np.nan)
    cols = np.full((padded.shape[0] - 1, padded.shape[1]), np.nan)
    for out, a, b, axis in ((rows, padded[:, :-1], padded[:, 1:], 1),
                            (cols, padded[:-1, :], padded[1:, :], 0)):
        i, j = np.nonzero(a != b)
        if inside is None or steps == 0 or len(i) == 0:
            out[i, j] = 0.5
            continue
        first_in = a[i, j]
        for lo_end in range(0, len(i), _RAYS_PER_BATCH):
            sl = slice(lo_end, lo_end + _RAYS_PER_BATCH)
            # pixel (i, j) of the padded image is centred at (j - 0.5, i - 0.5) of the image
            start = np.stack([j[sl] - 0.5, i[sl] - 0.5], axis=1)
            step = np.zeros_like(start)
            step[:, 0 if axis == 1 else 1] = 1.0
            lo = np.where(first_in[sl], 0.0, 1.0)  # covered end
            hi = 1.0 - lo                           # uncovered end
            for _ in range(steps):
                mid = 0.5 * (lo + hi)
                hit = inside(start + mid[:, None] * step)
                lo = np.where(hit, mid, lo)
                hi = np.where(hit, hi, mid)
            out[i[sl], j[sl]] = 0.5 * (lo + hi)
    return rows, cols


def _erosion_radius(covered: np.ndarray, pixel: float, inside: Callable | None = None,
                    steps: int = BOUNDARY_STEPS) -> np.ndarray:
    """Radius (world units) at which erosion removes each pixel centre; 0 outside I_d.

    The Euclidean distance from each covered pixel centre to the nearest
    boundary crossing (see :func:`_crossings`); the image is padded so that
    its border is background.
    """
    padded = np.pad(covered, 1)
    rows, cols = _crossings(padded, inside, steps)
    d2 = np.full(padded.shape, np.inf)  # crossings on columns are rows of the transpose
    _row_crossing_distances(np.ascontiguousarray(cols.T), d2)
    d2t = np.full(padded.shape[::-1], np.inf)
    _row_crossing_distances(rows, d2t)
    np.minimum(d2, d2t.T, out=d2)
    del d2t
    radius = np.sqrt(d2[1:-1, 1:-1])
    radius *= pixel
    radius[~covered] = 0.0
    return radius


def _as_image(covered: npt.ArrayLike, pixel: object) -> tuple[np.ndarray, float]:
    img = np.asarray(covered)
    if img.ndim != 2 or img.size == 0:
        raise InputError(f"covered: expected a non-empty 2-D image, got shape {img.shape}")
    if img.dtype != bool:
        raise InputError(f"covered: expected a bool image, got dtype {img.dtype}")
    pixel = as_positive(pixel, "pixel")
    check_memory(float(img.size) * _BYTES_PER_PIXEL, f"an image of {img.shape[0]} x "
                 f"{img.shape[1]} pixels")
    return img, pixel


def directional_occlusion_measure(covered: npt.ArrayLike, pixel: float, *,
                                  inside: Callable | None = None,
                                  boundary_steps: int = BOUNDARY_STEPS) -> tuple[float, float]:
    """M(d) and the area A(I_{d,0}) of one coverage image (Silvennoinen et al. 2014, eqs. 1, 3).

    Parameters
    ----------
    covered : (R, C) bool
        Orthographic projection I_d, sampled at the pixel centres.
    pixel : float
        Pixel side, world units.
    inside : callable, optional
        ``inside(points) -> (n,) bool`` for ``points`` (n, 2) float64
        continuous pixel coordinates (column, row; pixel (i, j) spans
        [j, j+1) x [i, i+1), as :meth:`viscore.OrthoCamera.project`), saying
        whether I_d covers them; the boundary is then located by bisection
        between pixel centres. Default: none, the boundary is taken half-way
        between covered and uncovered pixel centres.
    boundary_steps : int, optional
        Bisection steps per boundary crossing when ``inside`` is given.
        Default :data:`BOUNDARY_STEPS` (5).

    Returns
    -------
    measure : float
        Riemann sum over covered pixels of the distance to the boundary
        times the pixel area (world units^3).
    area : float
        Covered area, world units^2.

    Raises
    ------
    InputError
        If ``covered`` is not a non-empty 2-D bool image, ``pixel`` is not
        positive, or the image does not fit in memory.

    Notes
    -----
    The estimator converges at second order on any boundary when ``inside``
    is given: axis-aligned, oblique or curved (module docstring). Without it
    the mid-point boundary is off by up to half a pixel on oblique edges, a
    first-order error (about -0.4% to -1% at 512 px). Pixels whose
    neighbours are all covered except across the image border see the
    border as boundary.

    References
    ----------
    .. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
       Simplification using Planar Sections". Computer Graphics Forum 33(1),
       2014, pp. 235-245. :DOI:`10.1111/cgf.12271`

    Examples
    --------
    >>> img = np.zeros((64, 64), bool); img[16:48, 16:48] = True
    >>> m, a = directional_occlusion_measure(img, 1 / 32)   # unit square: 1/6
    >>> round(m, 3), a
    (0.167, 1.0)
    """
    img, pixel = _as_image(covered, pixel)
    steps = _as_steps(boundary_steps)
    radius = _erosion_radius(img, pixel, inside, steps)
    return float(radius.sum() * pixel**2), float(np.count_nonzero(img) * pixel**2)


def erosion_curve(covered: npt.ArrayLike, pixel: float, radii: npt.ArrayLike, *,
                  inside: Callable | None = None,
                  boundary_steps: int = BOUNDARY_STEPS) -> np.ndarray:
    """Area A(I_{d,r}) of the eroded projection per radius (Silvennoinen et al. 2014, sec. 3.1).

    Parameters
    ----------
    covered, pixel, inside, boundary_steps
        As in :func:`directional_occlusion_measure`.
    radii : (k,) float
        Erosion radii, world units.

    Returns
    -------
    area : (k,) float64
        World units^2; non-increasing in r, and its integral over r is the
        ``measure`` of :func:`directional_occlusion_measure`.

    References
    ----------
    .. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
       Simplification using Planar Sections". Computer Graphics Forum 33(1),
       2014, pp. 235-245. :DOI:`10.1111/cgf.12271`

    Examples
    --------
    >>> img = np.zeros((64, 64), bool); img[16:48, 16:48] = True
    >>> [round(float(a), 3) for a in erosion_curve(img, 1 / 32, [0.0, 0.25, 0.5])]
    [1.0, 0.25, 0.0]
    """
    img, pixel = _as_image(covered, pixel)
    radii = np.asarray(radii, dtype=np.float64)
    if radii.ndim != 1 or not np.isfinite(radii).all():
        raise InputError(f"radii: expected a 1-D array of finite numbers, got shape {radii.shape}")
    values = np.sort(_erosion_radius(img, pixel, inside, _as_steps(boundary_steps))[img])
    above = len(values) - np.searchsorted(values, radii, side="right")
    return above * pixel**2


def _as_steps(value: object) -> int:
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value == 0:
        return 0
    return as_positive_int(value, "boundary_steps", maximum=30)


# ---------------------------------------------------------------- meshes
def _ray_inside(scene: Scene, cam: OrthoCamera) -> Callable[[np.ndarray], np.ndarray]:
    """``inside(points)`` of a camera's image: one ray per point, in batches."""
    f, r, u = cam.basis
    scale = cam.extent / cam.resolution
    # column, row -> world: the pixel (0, 0) corner plus column x scale x r - row x scale x u
    base = cam.center - cam.start * f - 0.5 * cam.extent * (r - u)
    axes = np.stack([scale * r, -scale * u])

    def inside(points: np.ndarray) -> np.ndarray:
        hit = np.empty(len(points), dtype=bool)
        for a in range(0, len(points), _RAYS_PER_BATCH):
            origins = points[a:a + _RAYS_PER_BATCH] @ axes
            origins += base
            hit[a:a + len(origins)] = scene.any_hit(origins, np.broadcast_to(f, origins.shape))
        return hit

    return inside


def _coverage(inside: Callable, resolution: int) -> np.ndarray:
    """(R, R) bool: ``inside`` at every pixel centre, a batch of rows at a time."""
    covered = np.empty((resolution, resolution), dtype=bool)
    rows_per_batch = max(1, _RAYS_PER_BATCH // resolution)
    centre = np.arange(resolution) + 0.5
    for a in range(0, resolution, rows_per_batch):
        rows = centre[a:a + rows_per_batch]
        pts = np.stack([np.tile(centre, len(rows)), np.repeat(rows, resolution)], axis=1)
        covered[a:a + len(rows)] = inside(pts).reshape(len(rows), resolution)
    return covered


def _direction_batches(directions: int | np.ndarray, seed: int):
    """Batches of unit directions: a given array, or N uniform ones drawn in batches.

    The uniform ones equal ``viscore.directions_uniform(N, seed=seed)`` (the
    same stream of the same generator, drawn a batch at a time).
    """
    if isinstance(directions, np.ndarray):
        for a in range(0, len(directions), _DIRECTIONS_PER_BATCH):
            yield directions[a:a + _DIRECTIONS_PER_BATCH]
        return
    yield from directions_uniform_batches(directions, seed=seed, batch=_DIRECTIONS_PER_BATCH)


@dataclass(frozen=True)
class OcclusionMeasure:
    """Total occlusion measure of a mesh with its Monte-Carlo error.

    Attributes
    ----------
    occlusion_measure : float
        M = 4 pi mean M(d), world units^3 x steradian.
    occlusion_measure_se : float
        Its standard error (4 pi x s.d. of M(d) / sqrt(N)); NaN for N = 1.
    surface_area_measure : float
        4 pi mean A(I_{d,0}): the plain projected-area measure, world units^2 x sr.
    per_view : dict
        ``measure`` and ``area``: (N,) float64, M(d) and A(I_{d,0}) per
        direction. The directions themselves are not kept (they would be the
        only other memory growing with N): given as an array they are the
        caller's; drawn, they are ``viscore.directions_uniform(N, seed=seed)``.
    seed : int
    params : dict
        ``directions`` (N, or ``"given"``), ``resolution``, ``center``,
        ``extent``, ``boundary_steps``, ``rays`` (total cast).
    seconds : float
    """

    occlusion_measure: float
    occlusion_measure_se: float
    surface_area_measure: float
    per_view: dict
    seed: int
    params: dict
    seconds: float


def occlusion_measure(mesh: trimesh.Trimesh | Scene, *, directions: int | npt.ArrayLike = 64,
                      resolution: int = 256, seed: int = 0,
                      frame: tuple[npt.ArrayLike, float] | None = None,
                      boundary_steps: int = BOUNDARY_STEPS) -> OcclusionMeasure:
    """Total occlusion measure M of a mesh over N directions (Silvennoinen et al. 2014, sec. 3).

    Parameters
    ----------
    mesh : trimesh.Trimesh or Scene
        Object O: any triangle soup, flat meshes (planar occluders, a single
        triangle) included; or a :class:`~viscore.Scene` already built for it,
        cast as it is (no second Embree scene).
    directions : int or (N, 3) float, optional
        N uniform random directions (default 64), or the directions
        themselves (normalised here): then ``per_view`` holds M(d) for each
        and the total is their mean x 4 pi.
    resolution : int, optional
        R of each orthographic projection, at most 8192. Default 256.
    seed : int, optional
        Seeds the random directions; a non-negative integer. Default 0.
    frame : (center, extent), optional
        Image window; default the orbit frame of ``mesh`` (its smallest
        enclosing sphere x 1.01, of a Scene's vertices for a Scene), which
        holds every projection.
    boundary_steps : int, optional
        Bisection rays per boundary crossing (0: mid-points between pixel
        centres). Default :data:`BOUNDARY_STEPS` (5).

    Returns
    -------
    OcclusionMeasure

    Raises
    ------
    InputError
        On a bad argument, an empty mesh, or when one view's images would
        not fit in memory (checked before any work).

    Notes
    -----
    Each view casts R^2 rays for the coverage image plus ``boundary_steps``
    rays per boundary crossing (about 2-4 R per simple silhouette, a few per
    cent more). Memory is that of one view (about 64 bytes per pixel plus
    fixed ray buffers) and 16 bytes per direction; it does not otherwise grow
    with N. Deterministic given ``seed``.

    References
    ----------
    .. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
       Simplification using Planar Sections". Computer Graphics Forum 33(1),
       2014, pp. 235-245. :DOI:`10.1111/cgf.12271`

    Examples
    --------
    >>> sphere = trimesh.creation.icosphere(subdivisions=4)
    >>> r = occlusion_measure(sphere, directions=4, resolution=128)
    >>> bool(abs(r.occlusion_measure / (4 * np.pi * np.pi / 3) - 1) < 0.01)
    True
    """
    if isinstance(directions, (int, np.integer)) and not isinstance(directions, bool):
        n = as_positive_int(directions, "directions")
    else:
        directions = as_unit_vectors(directions, "directions")
        n = len(directions)
        if n == 0:
            raise InputError("directions: expected at least one direction, got none")
    resolution = as_positive_int(resolution, "resolution", maximum=_MAX_RESOLUTION)
    seed = as_seed(seed)
    steps = _as_steps(boundary_steps)
    if frame is not None:
        try:
            center, extent = frame
        except (TypeError, ValueError) as exc:
            raise InputError(f"frame: expected (center, extent), got {frame!r:.80}") from exc
        center, extent = as_vector(center, "frame center"), as_positive(extent, "frame extent")
    check_memory(float(resolution) ** 2 * _BYTES_PER_PIXEL + _RAYS_PER_BATCH * _BYTES_PER_RAY
                 + float(n) * _BYTES_PER_DIRECTION,
                 f"resolution={resolution}, directions={n}")
    start = time.perf_counter()
    scene = scene_of(mesh, "mesh")
    if frame is None:
        center, extent = orbit_frame(mesh)
    measure = np.empty(n)
    area = np.empty(n)
    rays = 0
    k = 0
    for batch in _direction_batches(directions, seed):  # type: ignore[arg-type]
        for d in batch:
            cam = OrthoCamera(d, center, extent, resolution)
            inside = _ray_inside(scene, cam)  # type: ignore[arg-type]
            covered = _coverage(inside, resolution)
            counted = _CountingInside(inside)
            pixel = cam.pixel_size
            radius = _erosion_radius(covered, pixel, counted, steps)
            measure[k] = radius.sum() * pixel**2
            area[k] = np.count_nonzero(covered) * pixel**2
            rays += resolution * resolution + counted.rays
            k += 1
    peak = float(np.abs(measure).max()) if n else 0.0
    peak = peak if peak > 0 else 1.0  # std of values scaled to ~1: no overflow at 1e60 sizes
    se = peak * (measure / peak).std(ddof=1) / np.sqrt(n) if n > 1 else np.nan
    return OcclusionMeasure(
        occlusion_measure=float(4 * np.pi * measure.mean()),
        occlusion_measure_se=float(4 * np.pi * se),
        surface_area_measure=float(4 * np.pi * area.mean()),
        per_view={"measure": measure, "area": area},
        seed=seed, params={"directions": n if not isinstance(directions, np.ndarray) else "given",
                           "resolution": resolution, "center": np.asarray(center).tolist(),
                           "extent": float(extent), "boundary_steps": steps, "rays": rays},
        seconds=time.perf_counter() - start)


class _CountingInside:
    """Wraps an ``inside`` callable and counts the points it is asked about."""

    def __init__(self, inside: Callable) -> None:
        self.inside = inside
        self.rays = 0

    def __call__(self, points: np.ndarray) -> np.ndarray:
        self.rays += len(points)
        return self.inside(points)
