"""Bootstrap intervals over views: percentile and BCa (DESIGN.md, "Uncertainty").

Views (or view positions) are the independent units of every protocol;
quads and pixels within one view are not, so resampling draws whole views
with replacement. Every pooled figure of the toolkit is a ratio of sums over
views, sum(num) / sum(den): pooled precision Nt / (Nt + Nf), pooled recall
Nt / (Nt + Pf), the volume protocol's weighted means sum(w P_x) / sum(w),
and the total occlusion measure, 4 pi times a plain mean (den = 1).

BCa follows Efron (1987), "Better bootstrap confidence intervals", JASA 82:
bias correction z0 from the share of resamples below the estimate, and
acceleration from the jackknife (leave one view out).
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from viscore import InputError
from viscore._validate import as_fraction, as_positive_int

__all__ = ["bootstrap_ratio", "BOOTSTRAP_RESAMPLES"]

#: Bootstrap resamples used by default: enough for 95% intervals whose end
#: points move by well under their own width between seeds.
BOOTSTRAP_RESAMPLES = 2000


def _ratio(num: np.ndarray, den: np.ndarray) -> float:
    d = den.sum()
    return float(num.sum() / d) if d > 0 else float("nan")


def bootstrap_ratio(num, den, *, method: str = "percentile", confidence: float = 0.95,
                    resamples: int = BOOTSTRAP_RESAMPLES, seed: int | None = 0
                    ) -> tuple[float, float]:
    """Bootstrap interval of sum(num) / sum(den), resampling views with replacement.

    Parameters
    ----------
    num, den : (n,) float
        Per-view numerator and denominator (e.g. Nt and Nt + Pf).
    method : {'percentile', 'bca'}, optional
        Percentile (default) or bias-corrected and accelerated.
    confidence : float, optional
        Two-sided level, default 0.95.
    resamples : int, optional
        Default 2000.
    seed : int, optional
        Default 0.

    Returns
    -------
    (low, high) : tuple of float
        NaN when fewer than two views have ``den > 0``. A degenerate case
        (every resample gives the same value) returns that value twice.

    Raises
    ------
    InputError
        On an unknown method, a bad confidence or mismatched lengths.

    Examples
    --------
    >>> lo, hi = bootstrap_ratio(np.arange(1.0, 41), np.full(40, 40.0), seed=1)
    >>> bool(lo < 20.5 / 40 < hi)
    True
    """
    if method not in ("percentile", "bca"):
        raise InputError(f"method: expected 'percentile' or 'bca', got {method!r}")
    confidence = as_fraction(confidence, "confidence", open_low=True)
    resamples = as_positive_int(resamples, "resamples")
    num = np.asarray(num, dtype=np.float64)
    den = np.asarray(den, dtype=np.float64)
    if num.shape != den.shape or num.ndim != 1:
        raise InputError(f"num, den: expected two (n,) arrays, got {num.shape} and {den.shape}")
    if (den > 0).sum() < 2:
        return (float("nan"), float("nan"))
    n = len(num)
    idx = np.random.default_rng(seed).integers(0, n, size=(resamples, n))
    d = den[idx].sum(axis=1)
    ok = d > 0
    boot = num[idx].sum(axis=1)[ok] / d[ok]
    alpha = (1 - confidence) / 2
    if boot.max() - boot.min() <= 1e-15 * max(1.0, abs(boot.max())):
        return (float(boot[0]), float(boot[0]))
    if method == "percentile":
        return (float(np.quantile(boot, alpha)), float(np.quantile(boot, 1 - alpha)))
    theta = _ratio(num, den)
    share = ((boot < theta).sum() + 0.5 * (boot == theta).sum()) / len(boot)
    z0 = stats.norm.ppf(np.clip(share, 1 / (2 * len(boot)), 1 - 1 / (2 * len(boot))))
    dj = den.sum() - den
    with np.errstate(invalid="ignore", divide="ignore"):
        jack = (num.sum() - num) / dj
    jack = jack[dj > 0]
    dev = jack.mean() - jack
    denom = 6.0 * (dev**2).sum() ** 1.5
    accel = float((dev**3).sum() / denom) if denom > 0 else 0.0
    z = stats.norm.ppf([alpha, 1 - alpha])
    adjusted = stats.norm.cdf(z0 + (z0 + z) / (1 - accel * (z0 + z)))
    return (float(np.quantile(boot, adjusted[0])), float(np.quantile(boot, adjusted[1])))
