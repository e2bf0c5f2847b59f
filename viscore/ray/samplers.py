"""Seeded samplers: view directions, view positions and rays between regions.

Uniform directions for the orbit protocol and the occlusion measure (Silvennoinen
et al. 2014 [1]_, secs. 3 and 6.1), grid positions for the volume protocol (Wu et
al. 2022 [2]_, sec. 3.2), random rays for the conservativeness check.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .._validate import InputError, as_positive, as_positive_int, as_seed, as_vector, check_memory

__all__ = ["directions_uniform", "directions_fibonacci", "grid_positions", "rays_between",
           "stream_seed", "directions_uniform_batches"]

_GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))

#: Peak bytes per sampled direction (the (n, 2) uniforms, three (n,) temporaries
#: and the (n, 3) result, float64) and per random ray (origins, targets,
#: vectors, directions, lengths and temporaries).
_BYTES_PER_DIRECTION = 96
_BYTES_PER_RAY = 200

#: Most grid positions :func:`grid_positions` makes (1.2 GB of float64).
_MAX_GRID_POSITIONS = 50_000_000


def stream_seed(seed: int, stream: str) -> int:
    """Seed of an independent, named random stream derived from ``seed``.

    One evaluation seed drives several Monte-Carlo draws (view directions,
    quads, the bootstrap, the occlusion measure's directions); drawing them
    all from ``default_rng(seed)`` would make their errors correlated. Each
    stream takes ``SeedSequence([seed, crc32(stream)])`` instead.

    Parameters
    ----------
    seed : int
        Non-negative integer of any size.
    stream : str
        Name of the stream, e.g. ``'bootstrap'``.

    Returns
    -------
    int
        A 64-bit non-negative seed, the same for the same ``(seed, stream)``.

    Examples
    --------
    >>> stream_seed(0, "bootstrap") == stream_seed(0, "bootstrap") != stream_seed(1, "bootstrap")
    True
    """
    import zlib

    seed = as_seed(seed)
    words = np.random.SeedSequence([seed, zlib.crc32(stream.encode())]).generate_state(
        2, dtype=np.uint32)
    return int(words[0]) | (int(words[1]) << 32)


def directions_uniform(n: int, *, seed: int = 0) -> np.ndarray:
    """``n`` independent directions uniform on the unit sphere.

    Parameters
    ----------
    n : int
        Number of directions.
    seed : int, optional
        Seed of ``np.random.default_rng``, a non-negative integer of any size;
        default 0.

    Returns
    -------
    directions : (n, 3) float64
        Unit vectors. The first k of n directions equal ``directions_uniform(k)``
        with the same seed.

    Raises
    ------
    InputError
        If ``n`` is not a positive integer, its arrays would not fit in memory,
        or ``seed`` is not a non-negative integer.

    Examples
    --------
    >>> d = directions_uniform(4, seed=1)
    >>> bool(np.allclose(np.linalg.norm(d, axis=1), 1))
    True
    """
    n = as_positive_int(n, "n")
    seed = as_seed(seed)
    check_memory(n * _BYTES_PER_DIRECTION, f"{n:,} directions")
    u = np.random.default_rng(seed).random((n, 2))  # row by row: prefixes agree across n
    return _sphere_points(u)


def directions_uniform_batches(n: int, *, seed: int = 0, batch: int = 4096):
    """:func:`directions_uniform` ``(n, seed)`` drawn ``batch`` rows at a time.

    Yields ``(m, 3) float64`` blocks whose concatenation equals
    ``directions_uniform(n, seed=seed)`` bit for bit, so that long runs hold
    one batch in memory instead of all ``n`` directions.

    Examples
    --------
    >>> blocks = list(directions_uniform_batches(5, seed=3, batch=2))
    >>> bool(np.array_equal(np.concatenate(blocks), directions_uniform(5, seed=3)))
    True
    """
    n = as_positive_int(n, "n")
    batch = as_positive_int(batch, "batch")
    rng = np.random.default_rng(as_seed(seed))
    for a in range(0, n, batch):
        yield _sphere_points(rng.random((min(batch, n - a), 2)))


def _sphere_points(u: np.ndarray) -> np.ndarray:
    """Uniform unit vectors from (m, 2) uniforms in [0, 1): z uniform, azimuth uniform."""
    z = 2.0 * u[:, 0] - 1.0
    phi = 2.0 * np.pi * u[:, 1]
    s = np.sqrt(1.0 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)


def directions_fibonacci(n: int, *, seed: int | None = None) -> np.ndarray:
    """``n`` well-spread directions on the Fibonacci spiral (deterministic).

    Parameters
    ----------
    n : int
        Number of directions.
    seed : int, optional
        If given (a non-negative integer of any size), the spiral is rotated
        by a seeded uniform random rotation (randomised quasi-Monte-Carlo:
        unbiased and low variance). Default None: no rotation.

    Returns
    -------
    directions : (n, 3) float64
        Unit vectors; the i-th has z = 1 - (2 i + 1) / n before rotation.
    """
    n = as_positive_int(n, "n")
    seed = None if seed is None else as_seed(seed)
    check_memory(n * _BYTES_PER_DIRECTION, f"{n:,} directions")
    i = np.arange(n)
    z = 1.0 - (2.0 * i + 1.0) / n
    s = np.sqrt(1.0 - z * z)
    phi = _GOLDEN_ANGLE * i
    d = np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)
    if seed is not None:
        q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
        q = q * np.sign(np.diag(r))  # Haar-distributed orthogonal matrix
        if np.linalg.det(q) < 0:
            q[:, 0] = -q[:, 0]
        d = d @ q.T
    return d


def grid_positions(lo: npt.ArrayLike, hi: npt.ArrayLike, spacing: float) -> np.ndarray:
    """Centres of the cubic cells of side ``spacing`` that tile the box [lo, hi].

    The grid is centred in the box: ``ceil(extent / spacing)`` cells per axis
    (at least one), so its cells may overhang the box by less than one
    ``spacing`` in total per axis.

    Returns
    -------
    positions : (m, 3) float64
        World units, x varying slowest.

    Raises
    ------
    InputError
        If ``hi < lo`` on an axis, ``spacing <= 0``, or the grid would have
        more than 50 million positions (counted in floating point, so a tiny
        spacing is refused, never overflowed).

    Examples
    --------
    >>> grid_positions((0, 0, 0), (1, 1, 1), 0.5).shape
    (8, 3)
    """
    lo = as_vector(lo, "lo")
    hi = as_vector(hi, "hi")
    spacing = as_positive(spacing, "spacing")
    if (hi < lo).any():
        raise InputError(f"hi: must be >= lo on every axis, got lo={lo}, hi={hi}")
    with np.errstate(over="ignore"):
        per_axis = np.maximum(1.0, np.ceil((hi - lo) / spacing - 1e-9))  # float: no overflow
        total = float(np.prod(per_axis))
    if not total <= _MAX_GRID_POSITIONS:
        raise InputError(f"spacing: {spacing:g} gives {total:.3g} grid positions "
                         f"(limit {_MAX_GRID_POSITIONS:,})")
    check_memory(total * 3 * 8 * 3, f"spacing={spacing:g} ({int(total):,} grid positions)")
    counts = per_axis.astype(np.int64)
    start = 0.5 * (lo + hi) - 0.5 * spacing * (counts - 1)
    axes = [start[k] + spacing * np.arange(counts[k]) for k in range(3)]
    g = np.meshgrid(*axes, indexing="ij")
    return np.stack([a.reshape(-1) for a in g], axis=1)


def rays_between(box_a: npt.ArrayLike, box_b: npt.ArrayLike, n: int, *,
                 seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random segments from a uniform point in box A to a uniform point in box B.

    Parameters
    ----------
    box_a, box_b : (2, 3) float
        Lower and upper corners, world units.
    n : int
        Number of rays.
    seed : int, optional
        A non-negative integer of any size. Default 0.

    Returns
    -------
    origins : (n, 3) float64
    directions : (n, 3) float64
        Unit vectors from origin to target (a coincident pair gets +Z).
    lengths : (n,) float64
        Distance from origin to target, world units.

    Raises
    ------
    InputError
        If a box is not finite (2, 3) corners with lo <= hi, ``n`` is not a
        positive integer or does not fit in memory, or ``seed`` is invalid.
    """
    n = as_positive_int(n, "n")
    seed = as_seed(seed)
    check_memory(n * _BYTES_PER_RAY, f"{n:,} rays")
    a = np.asarray(box_a, dtype=np.float64)
    b = np.asarray(box_b, dtype=np.float64)
    for name, box in (("box_a", a), ("box_b", b)):
        if box.shape != (2, 3) or not np.isfinite(box).all() or (box[1] < box[0]).any():
            raise InputError(f"{name}: expected finite (2, 3) corners with lo <= hi")
    rng = np.random.default_rng(seed)
    origins = rng.uniform(a[0], a[1], (n, 3))
    targets = rng.uniform(b[0], b[1], (n, 3))
    v = targets - origins
    lengths = np.linalg.norm(v, axis=1)
    dirs = np.where(lengths[:, None] > 0, v / np.maximum(lengths, 1e-300)[:, None], [0, 0, 1])
    return origins, dirs, lengths
