"""Paired comparison of two occluders of one mesh evaluated on the same views.

DESIGN.md, "Uncertainty": comparisons between methods use the same views.
Resampling the views jointly keeps the pairing, so the view-to-view spread
that both occluders share cancels from the difference.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from viscore import InputError
from viscore._validate import as_fraction, as_positive_int

from .bootstrap import BOOTSTRAP_RESAMPLES
from .precision_recall import PrecisionRecall

__all__ = ["PairedDifference", "paired_difference"]


@dataclass(frozen=True)
class PairedDifference:
    """Difference A - B of pooled precision and recall on shared views.

    Attributes
    ----------
    precision_diff, recall_diff : float
        A minus B.
    precision_diff_ci, recall_diff_ci : list of 2 float
        Percentile bootstrap intervals (views resampled jointly).
    prob_a_better_precision, prob_a_better_recall : float
        Share of bootstrap resamples in which A is strictly higher (ties
        count one half): the bootstrap probability that A is better.
    views : int
    confidence : float
    seed : int
    """

    precision_diff: float
    recall_diff: float
    precision_diff_ci: list
    recall_diff_ci: list
    prob_a_better_precision: float
    prob_a_better_recall: float
    views: int
    confidence: float
    seed: int


def _same_views(a: PrecisionRecall, b: PrecisionRecall) -> bool:
    key = "direction" if a.protocol == "orbit" else "position"
    if a.protocol != b.protocol or a.seed != b.seed or a.views != b.views:
        return False
    return bool(np.array_equal(np.asarray(a.per_view[key]), np.asarray(b.per_view[key])))


def paired_difference(a: PrecisionRecall, b: PrecisionRecall, *, confidence: float = 0.95,
                      resamples: int = BOOTSTRAP_RESAMPLES, seed: int | None = 0
                      ) -> PairedDifference:
    """Bootstrap the difference of two evaluations made on the same views.

    Parameters
    ----------
    a, b : PrecisionRecall
        Same protocol, seed and views (directions or positions), e.g. two
        occluders of one mesh evaluated with the same settings.
    confidence : float, optional
        Default 0.95.
    resamples : int, optional
        Default 2000.
    seed : int, optional
        Seeds the resampling. Default 0.

    Returns
    -------
    PairedDifference

    Raises
    ------
    InputError
        If the two evaluations do not share their views.

    Examples
    --------
    >>> import trimesh
    >>> from viscore.metrics import orbit_precision_recall
    >>> box = trimesh.creation.box(); small = box.copy(); _ = small.apply_scale(0.5)
    >>> ra = orbit_precision_recall(box, box, views=6, quads=200, resolution=24)
    >>> rb = orbit_precision_recall(box, small, views=6, quads=200, resolution=24)
    >>> d = paired_difference(ra, rb)
    >>> d.recall_diff > 0, d.prob_a_better_recall
    (True, 1.0)
    """
    confidence = as_fraction(confidence, "confidence", open_low=True)
    resamples = as_positive_int(resamples, "resamples")
    if not _same_views(a, b):
        raise InputError("a, b: the evaluations do not share their views (protocol, seed and "
                         "view directions or positions must match)")
    n = a.views
    idx = np.random.default_rng(seed).integers(0, n, size=(resamples, n))
    alpha = (1 - confidence) / 2

    def stat(r: PrecisionRecall, which: str, rows=None):
        num, den = r.ratio_parts(which)
        if rows is None:
            return num.sum() / den.sum() if den.sum() > 0 else np.nan
        d = den[rows].sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return num[rows].sum(axis=1) / d

    out = {}
    for which in ("precision", "recall"):
        diff = stat(a, which) - stat(b, which)
        boot = stat(a, which, idx) - stat(b, which, idx)
        boot = boot[np.isfinite(boot)]
        if len(boot) == 0:
            out[which] = (float(diff), [np.nan, np.nan], np.nan)
            continue
        better = float(((boot > 0).sum() + 0.5 * (boot == 0).sum()) / len(boot))
        out[which] = (float(diff), [float(np.quantile(boot, alpha)),
                                    float(np.quantile(boot, 1 - alpha))], better)
    return PairedDifference(
        precision_diff=out["precision"][0], recall_diff=out["recall"][0],
        precision_diff_ci=out["precision"][1], recall_diff_ci=out["recall"][1],
        prob_a_better_precision=out["precision"][2], prob_a_better_recall=out["recall"][2],
        views=n, confidence=confidence, seed=seed)
