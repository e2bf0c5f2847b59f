"""Bootstrap intervals over views: percentile and BCa (Efron 1987; Efron and Tibshirani 1993).

Every pooled figure is a ratio of sums over views (Silvennoinen et al. 2014, sec.
6.1; Wu et al. 2022, sec. 3.2): views are resampled with replacement.

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
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from viscore import InputError
from viscore._validate import as_fraction, as_positive_int, as_seed, check_memory

__all__ = ["bootstrap_ratio", "BOOTSTRAP_RESAMPLES", "BOOTSTRAP_METHODS"]

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
