"""Bootstrap intervals over views: percentile and BCa (Efron 1987; Efron and Tibshirani 1993),
and over the frames of a walk by blocks (Politis and Romano 1992; Politis and White 2004).

Every pooled figure is a ratio of sums over views (Silvennoinen et al. 2014, sec.
6.1; Wu et al. 2022, sec. 3.2): views are resampled with replacement.

Frames along a camera walk are not independent: neighbouring frames see
nearly the same objects. :func:`block_bootstrap_ratio` therefore resamples
runs of consecutive frames, the circular block bootstrap of Politis and
Romano (1992), with the block length chosen from the data by the rule of
Politis and White (2004) as corrected by Patton, Politis and White (2009)
(:func:`block_length`).

References
----------
.. [1] Efron, B. "Better Bootstrap Confidence Intervals". Journal of the
   American Statistical Association 82(397), 1987, pp. 171-185.
   :DOI:`10.1080/01621459.1987.10478410`
.. [2] Efron, B., Tibshirani, R. J. "An Introduction to the Bootstrap".
   Chapman & Hall/CRC, 1993, ch. 13-14. :DOI:`10.1201/9780429246593`
.. [3] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [4] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
.. [5] Politis, D. N., Romano, J. P. "A Circular Block-Resampling Procedure
   for Stationary Data". In: LePage, R., Billard, L. (eds.), Exploring the
   Limits of Bootstrap, Wiley, 1992, pp. 263-270.
.. [6] Politis, D. N., White, H. "Automatic Block-Length Selection for the
   Dependent Bootstrap". Econometric Reviews 23(1), 2004, pp. 53-70.
   :DOI:`10.1081/ETC-120028836`
.. [7] Patton, A., Politis, D. N., White, H. "Correction to 'Automatic
   Block-Length Selection for the Dependent Bootstrap'". Econometric Reviews
   28(4), 2009, pp. 372-375. :DOI:`10.1080/07474930802459016`
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from viscore import InputError
from viscore._validate import as_fraction, as_positive_int, as_seed, check_memory

__all__ = ["bootstrap_ratio", "block_bootstrap_ratio", "block_length", "BOOTSTRAP_RESAMPLES",
           "BOOTSTRAP_METHODS"]

#: Bootstrap resamples used by default: enough for 95% intervals whose end
#: points move by well under their own width between seeds.
BOOTSTRAP_RESAMPLES = 2000

#: Interval methods of :func:`bootstrap_ratio`.
BOOTSTRAP_METHODS = ("percentile", "bca")

#: Resampled view indices drawn per block (elements of a (rows, n) block): bounds
#: the working memory of a bootstrap to about 16 bytes x this, whatever its size.
_BLOCK_ELEMENTS = 1 << 22

#: Bytes per element of one block of resampled indices (int64 index and one
#: gathered column).
_BYTES_PER_BLOCK_ELEMENT = 16


def _bootstrap_memory(views: int, resamples: int, columns: int = 2) -> float:
    """Estimated peak bytes of a bootstrap of ``columns`` per-view sums.

    Per resample: one float64 sum per column, the replicates and the sort
    copy of the quantiles; per view: the jackknife arrays; plus one block of
    resampled indices (see :func:`_resampled_sums`).
    """
    block = min(float(views) * resamples, float(max(_BLOCK_ELEMENTS, views)))
    return (8.0 * (columns + 3) * resamples + _BYTES_PER_BLOCK_ELEMENT * block
            + 8.0 * (columns + 4) * views)


def _resampled_sums(rng: np.random.Generator, n: int, resamples: int, *columns: np.ndarray
                   ) -> list[np.ndarray]:
    """Sums of each column over ``resamples`` draws of ``n`` views with replacement.

    Draws the (resamples, n) indices in row blocks of about ``_BLOCK_ELEMENTS``
    elements, so memory stays bounded; the draws are the same as one
    ``rng.integers(0, n, size=(resamples, n))`` call.

    Returns
    -------
    list of (resamples,) float64
        One array per column.
    """
    rows = max(1, _BLOCK_ELEMENTS // max(n, 1))
    out = [np.empty(resamples) for _ in columns]
    for start in range(0, resamples, rows):
        stop = min(resamples, start + rows)
        idx = rng.integers(0, n, size=(stop - start, n))
        for o, col in zip(out, columns, strict=True):
            o[start:stop] = col[idx].sum(axis=1)
    return out


def bootstrap_ratio(num, den, *, method: str = "percentile", confidence: float = 0.95,
                    resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0
                    ) -> tuple[float, float]:
    """Bootstrap interval of sum(num) / sum(den), resampling views with replacement.

    Parameters
    ----------
    num, den : (n,) float
        Per-view numerator and denominator (e.g. Nt and Nt + Pf).
    method : {'percentile', 'bca'}, optional
        Percentile (default) or bias-corrected and accelerated [1]_.
    confidence : float, optional
        Two-sided level in (0, 1], default 0.95.
    resamples : int, optional
        Default 2000.
    seed : int, optional
        Non-negative integer of any size; seeds ``numpy.random.default_rng``.
        Default 0.

    Returns
    -------
    (low, high) : tuple of float
        NaN when fewer than two views have ``den > 0``. A degenerate case
        (every resample gives the same value) returns that value twice.

    Raises
    ------
    InputError
        On an unknown method, a bad confidence, resamples or seed, mismatched
        lengths, or when the resamples x views would not fit in memory.

    Notes
    -----
    Deterministic given ``seed``. Resampled indices are drawn in blocks, so
    the working memory is about 40 bytes per resample plus one block of
    max(2**22, n) indices (64 MiB up to 4 million views). BCa:
    ``z0 = Phi^-1(share of replicates below the estimate, ties counted
    half)``, acceleration
    ``a = sum(d^3) / (6 (sum d^2)^1.5)`` with ``d`` the deviations of the
    leave-one-view-out estimates from their mean ([2]_, eq. 14.15); the same
    definitions as ``scipy.stats.bootstrap(method='BCa')``.

    References
    ----------
    .. [1] Efron, B. "Better Bootstrap Confidence Intervals". Journal of the
       American Statistical Association 82(397), 1987, pp. 171-185.
       :DOI:`10.1080/01621459.1987.10478410`
    .. [2] Efron, B., Tibshirani, R. J. "An Introduction to the Bootstrap".
       Chapman & Hall/CRC, 1993. :DOI:`10.1201/9780429246593`

    Examples
    --------
    >>> lo, hi = bootstrap_ratio(np.arange(1.0, 41), np.full(40, 40.0), seed=1)
    >>> bool(lo < 20.5 / 40 < hi)
    True
    """
    if method not in BOOTSTRAP_METHODS:
        raise InputError(f"method: expected one of {', '.join(BOOTSTRAP_METHODS)}, "
                         f"got {method!r}")
    confidence = as_fraction(confidence, "confidence", open_low=True)
    resamples = as_positive_int(resamples, "resamples")
    seed = as_seed(seed)
    num = np.asarray(num, dtype=np.float64)
    den = np.asarray(den, dtype=np.float64)
    if num.shape != den.shape or num.ndim != 1:
        raise InputError(f"num, den: expected two (n,) arrays, got {num.shape} and {den.shape}")
    if (den > 0).sum() < 2:
        return (float("nan"), float("nan"))
    n = len(num)
    check_memory(_bootstrap_memory(n, resamples), f"bootstrap of {n} views x {resamples} resamples")
    s_num, s_den = _resampled_sums(np.random.default_rng(seed), n, resamples, num, den)
    ok = s_den > 0
    boot = s_num[ok] / s_den[ok]
    if len(boot) == 0:
        return (float("nan"), float("nan"))
    alpha = (1 - confidence) / 2
    if boot.max() - boot.min() <= 1e-15 * max(1.0, abs(boot.max())):
        return (float(boot[0]), float(boot[0]))
    if method == "percentile":
        return (float(np.quantile(boot, alpha)), float(np.quantile(boot, 1 - alpha)))
    theta = num.sum() / den.sum()
    share = ((boot < theta).sum() + 0.5 * (boot == theta).sum()) / len(boot)
    z0 = stats.norm.ppf(np.clip(share, 1 / (2 * len(boot)), 1 - 1 / (2 * len(boot))))
    accel = _jackknife_acceleration(num, den)
    z = stats.norm.ppf([alpha, 1 - alpha])
    adjusted = stats.norm.cdf(z0 + (z0 + z) / (1 - accel * (z0 + z)))
    return (float(np.quantile(boot, adjusted[0])), float(np.quantile(boot, adjusted[1])))


def _jackknife_acceleration(num: np.ndarray, den: np.ndarray) -> float:
    """BCa acceleration from the leave-one-view-out ratios (Efron and Tibshirani, eq. 14.15).

    Positive when the estimator's distribution is skewed to the right (the
    interval then stretches further above the estimate than below).
    """
    dj = den.sum() - den
    with np.errstate(invalid="ignore", divide="ignore"):
        jack = (num.sum() - num) / dj
    jack = jack[dj > 0]
    dev = jack.mean() - jack
    peak = np.abs(dev).max() if len(dev) else 0.0
    if not np.isfinite(peak) or peak == 0:
        return 0.0
    dev = dev / peak  # the acceleration is scale-free; cubes of 1e60-sized values overflow
    denom = 6.0 * (dev**2).sum() ** 1.5
    return float((dev**3).sum() / denom) if denom > 0 else 0.0


# --------------------------------------------------------------------------- frames by blocks
#: Politis and White (2004), sec. 3.2: the constant c of the threshold
#: c sqrt(log10(n) / n) under which a sample autocorrelation counts as zero
#: (their suggested c = 2, an approximate 95% bound).
_PW_THRESHOLD = 2.0
#: ... and the least number of consecutive lags K_N that must all be under it,
#: K_N = max(this, sqrt(log10 n)).
_PW_LAGS = 5


def _flat_top(t: np.ndarray) -> np.ndarray:
    """The trapezoidal flat-top lag window of Politis and White (2004): 1 up to |t| = 1/2,
    then linearly down to 0 at |t| = 1."""
    t = np.abs(t)
    return np.where(t <= 0.5, 1.0, np.where(t <= 1.0, 2.0 * (1.0 - t), 0.0))


def _linearised(num: np.ndarray, den: np.ndarray | None) -> np.ndarray:
    """The series whose dependence governs sum(num) / sum(den): ``num - ratio * den``
    (the ratio's influence per frame, up to the constant 1 / mean(den))."""
    if den is None:
        return num
    total = den.sum()
    return num - (num.sum() / total if total != 0 else 0.0) * den


def _as_series(num, den, name: str = "num, den") -> tuple[np.ndarray, np.ndarray | None]:
    num = np.asarray(num, dtype=np.float64)
    den = None if den is None else np.asarray(den, dtype=np.float64)
    if num.ndim != 1 or (den is not None and den.shape != num.shape):
        raise InputError(f"{name}: expected (n,) arrays of one length, got {num.shape}"
                         + ("" if den is None else f" and {den.shape}"))
    if not np.isfinite(num).all() or (den is not None and not np.isfinite(den).all()):
        raise InputError(f"{name}: expected finite values")
    return num, den


def block_length(num, den=None) -> int:
    """Block length of the circular block bootstrap for a series, chosen from the data.

    The rule of Politis and White (2004) [1]_ for the circular block bootstrap, with
    the correction of Patton, Politis and White (2009) [2]_:
    ``b = (2 G^2 / D)^(1/3) n^(1/3)``, ``G = sum_k w(k/M) |k| R(k)``,
    ``D = 4/3 (sum_k w(k/M) R(k))^2`` over ``|k| <= M``, with ``R`` the sample
    autocovariances and ``w`` the flat-top lag window; ``M = 2 m``, where ``m``
    is the first lag after which ``K_N = max(5, sqrt(log10 n))`` consecutive
    sample autocorrelations are all under ``2 sqrt(log10(n) / n)``.

    Parameters
    ----------
    num : (n,) float
        The series (per frame), or the numerators of a ratio of sums.
    den : (n,) float, optional
        The denominators: the block length is then that of the ratio's
        linearisation ``num - (sum(num) / sum(den)) den``.

    Returns
    -------
    block : int
        At least 1 (1 for an uncorrelated series, a constant one, or fewer
        than 3 values), at most ``ceil(min(3 sqrt(n), n / 3))``.

    Raises
    ------
    InputError
        On arrays that are not (n,), of different lengths, or not finite.

    Notes
    -----
    Deterministic. ``M`` is capped at ``ceil(sqrt(n)) + K_N`` as in [1]_.

    References
    ----------
    .. [1] Politis, D. N., White, H. "Automatic Block-Length Selection for the
       Dependent Bootstrap". Econometric Reviews 23(1), 2004, pp. 53-70.
       :DOI:`10.1081/ETC-120028836`
    .. [2] Patton, A., Politis, D. N., White, H. "Correction to 'Automatic
       Block-Length Selection for the Dependent Bootstrap'". Econometric Reviews
       28(4), 2009, pp. 372-375. :DOI:`10.1080/07474930802459016`

    Examples
    --------
    >>> block_length(np.repeat([0.0, 1.0, 0.0, 1.0], 25)) > 1   # runs of 25 equal frames
    True
    >>> block_length(np.random.default_rng(0).normal(size=200))   # independent frames
    1
    """
    num, den = _as_series(num, den)
    x = _linearised(num, den)
    n = len(x)
    if n < 3:
        return 1
    x = x - x.mean()
    var = float(x @ x) / n
    if var <= 1e-300:
        return 1
    lags = max(_PW_LAGS, int(np.ceil(np.sqrt(np.log10(n)))))
    m_max = int(np.ceil(np.sqrt(n))) + lags
    top = min(n - 1, m_max + lags)
    acov = np.array([float(x[:n - k] @ x[k:]) / n for k in range(top + 1)])  # per lag
    small = np.abs(acov / acov[0]) < _PW_THRESHOLD * np.sqrt(np.log10(n) / n)
    m = m_max
    for start in range(0, max(0, top - lags) + 1):  # first run of `lags` small ones
        if small[start + 1:start + 1 + lags].all():
            m = start
            break
    big_m = min(2 * m, m_max, top)
    if big_m == 0:
        return 1
    k = np.arange(1, big_m + 1)
    w = _flat_top(k / big_m)
    g0 = acov[0] + 2.0 * float((w * acov[1:big_m + 1]).sum())
    g = 2.0 * float((w * k * acov[1:big_m + 1]).sum())
    if g0 <= 0 or g <= 0:  # no positive dependence to keep together
        return 1
    d_cb = 4.0 / 3.0 * g0**2
    b = (2.0 * g**2 / d_cb) ** (1.0 / 3.0) * n ** (1.0 / 3.0)
    b_max = int(np.ceil(min(3.0 * np.sqrt(n), n / 3.0)))
    return int(max(1, min(b_max, round(b))))


def _circular_sums(x: np.ndarray, length: int) -> np.ndarray:
    """(n,) sums of ``length`` consecutive values of ``x`` from each start, wrapping round."""
    if length == 1:
        return x
    ext = np.concatenate([x, x[:length - 1]])
    c = np.concatenate([[0.0], np.cumsum(ext)])
    return c[length:length + len(x)] - c[:len(x)]


def _resampled_block_sums(rng: np.random.Generator, n: int, resamples: int, block: int,
                          *columns: np.ndarray) -> list[np.ndarray]:
    """Sums of each column over ``resamples`` circular block resamples of ``n`` frames.

    Each resample joins ``k = ceil(n / block)`` blocks of consecutive frames
    from uniform random starts, the last one cut to ``n - (k - 1) block``
    frames, so every resample has ``n`` frames. With ``block`` 1 the draws are
    those of :func:`_resampled_sums`.
    """
    k = -(-n // block)
    last = n - (k - 1) * block
    whole = [_circular_sums(c, block) for c in columns]
    tail = [_circular_sums(c, last) for c in columns]
    rows = max(1, _BLOCK_ELEMENTS // max(k, 1))
    out = [np.empty(resamples) for _ in columns]
    for start in range(0, resamples, rows):
        stop = min(resamples, start + rows)
        idx = rng.integers(0, n, size=(stop - start, k))
        for o, w, t in zip(out, whole, tail, strict=True):
            o[start:stop] = w[idx[:, :-1]].sum(axis=1) + t[idx[:, -1]]
    return out


def block_bootstrap_ratio(num, den, *, block: int | None = None, confidence: float = 0.95,
                          resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0
                          ) -> tuple[float, float]:
    """Percentile interval of sum(num) / sum(den) by the circular block bootstrap over frames.

    For figures summed over the frames of a walk (objects culled over objects
    in view), where neighbouring frames are alike: each resample joins blocks
    of ``block`` consecutive frames from random starts, the series read as a
    circle (Politis and Romano 1992 [1]_), so the dependence within a block
    is kept.

    Parameters
    ----------
    num, den : (n,) float
        Per-frame numerator and denominator, in walk order.
    block : int, optional
        Frames per block, in [1, n]; default :func:`block_length` of the
        ratio. With 1 this is :func:`bootstrap_ratio` (percentile), draw for
        draw.
    confidence : float, optional
        Two-sided level in (0, 1], default 0.95.
    resamples : int, optional
        Default 2000.
    seed : int, optional
        Seeds ``numpy.random.default_rng``; default 0.

    Returns
    -------
    (low, high) : tuple of float
        NaN when fewer than two frames have ``den > 0``; a degenerate case
        (every resample gives the same value) returns that value twice.

    Raises
    ------
    InputError
        Bad arrays, block, confidence, resamples or seed, or resamples that
        would not fit in memory.

    Notes
    -----
    Deterministic given ``seed``. Resamples whose denominator sums to zero
    are left out. Percentile intervals only: BCa's jackknife acceleration
    assumes independent units.

    References
    ----------
    .. [1] Politis, D. N., Romano, J. P. "A Circular Block-Resampling
       Procedure for Stationary Data". In: LePage, R., Billard, L. (eds.),
       Exploring the Limits of Bootstrap, Wiley, 1992, pp. 263-270.
    .. [2] Politis, D. N., White, H. "Automatic Block-Length Selection for the
       Dependent Bootstrap". Econometric Reviews 23(1), 2004, pp. 53-70.
       :DOI:`10.1081/ETC-120028836`

    Examples
    --------
    >>> culled = np.repeat([2.0, 8.0], 20)          # two stretches of a walk
    >>> lo, hi = block_bootstrap_ratio(culled, np.full(40, 10.0), block=5, seed=1)
    >>> bool(lo < 0.5 < hi)
    True
    """
    confidence = as_fraction(confidence, "confidence", open_low=True)
    resamples = as_positive_int(resamples, "resamples")
    seed = as_seed(seed)
    num, den = _as_series(num, den)
    n = len(num)
    if (den > 0).sum() < 2:  # type: ignore[operator, union-attr]
        return (float("nan"), float("nan"))
    block = block_length(num, den) if block is None else as_positive_int(block, "block",
                                                                          maximum=n)
    check_memory(_bootstrap_memory(n, resamples),
                 f"block bootstrap of {n} frames x {resamples} resamples")
    s_num, s_den = _resampled_block_sums(np.random.default_rng(seed), n, resamples, block,
                                         num, den)  # type: ignore[arg-type]
    ok = s_den > 0
    boot = s_num[ok] / s_den[ok]
    if len(boot) == 0:
        return (float("nan"), float("nan"))
    if boot.max() - boot.min() <= 1e-15 * max(1.0, abs(boot.max())):
        return (float(boot[0]), float(boot[0]))
    alpha = (1 - confidence) / 2
    return (float(np.quantile(boot, alpha)), float(np.quantile(boot, 1 - alpha)))
