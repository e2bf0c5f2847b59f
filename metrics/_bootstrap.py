"""Percentile bootstrap over views for pooled ratios (DESIGN.md, "Uncertainty").

Views (or view positions) are the independent units; quads within one view
are not, so resampling is over views with replacement.
"""

from __future__ import annotations

import numpy as np

#: Bootstrap resamples used by default: enough for 95% percentile intervals
#: whose end points move by well under their own width between seeds.
BOOTSTRAP_RESAMPLES = 2000


def resample_indices(n: int, resamples: int, rng: np.random.Generator) -> np.ndarray:
    """``(resamples, n) int`` indices drawn with replacement."""
    return rng.integers(0, n, size=(resamples, n))


def ratio_interval(num: np.ndarray, den: np.ndarray, *, confidence: float = 0.95,
                   resamples: int = BOOTSTRAP_RESAMPLES, seed: int | None = 0
                   ) -> tuple[float, float]:
    """Percentile interval of sum(num) / sum(den), resampling the views.

    Returns (nan, nan) when there are fewer than two views with ``den > 0``.
    """
    num = np.asarray(num, dtype=np.float64)
    den = np.asarray(den, dtype=np.float64)
    if (den > 0).sum() < 2:
        return (float("nan"), float("nan"))
    idx = resample_indices(len(num), resamples, np.random.default_rng(seed))
    d = den[idx].sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        stats = num[idx].sum(axis=1) / d
    stats = stats[d > 0]
    alpha = (1 - confidence) / 2
    return (float(np.quantile(stats, alpha)), float(np.quantile(stats, 1 - alpha)))


def weighted_mean_interval(values: np.ndarray, weights: np.ndarray, *, confidence: float = 0.95,
                           resamples: int = BOOTSTRAP_RESAMPLES, seed: int | None = 0
                           ) -> tuple[float, float]:
    """Percentile interval of the weighted mean of defined (non-NaN) values."""
    values = np.asarray(values, dtype=np.float64)
    ok = np.isfinite(values)
    v, w = values[ok], np.asarray(weights, dtype=np.float64)[ok]
    if len(v) < 2:
        return (float("nan"), float("nan"))
    return ratio_interval(v * w, w, confidence=confidence, resamples=resamples, seed=seed)
