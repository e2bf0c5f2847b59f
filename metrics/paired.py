"""Paired comparison of two occluders of one mesh evaluated on the same views.

Both occluders are scored on the same views (Silvennoinen et al. 2014, sec. 6.1;
Wu et al. 2022, sec. 3.2), and the views are resampled jointly.

References
----------
.. [1] Efron, B., Tibshirani, R. J. "An Introduction to the Bootstrap".
   Chapman & Hall/CRC, 1993. :DOI:`10.1201/9780429246593`
.. [2] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [3] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from viscore import InputError
from viscore._validate import as_fraction, as_positive_int, as_seed, check_memory

from .bootstrap import BOOTSTRAP_RESAMPLES, _bootstrap_memory, _resampled_sums
from .precision_recall import PrecisionRecall, ratio

#: Protocols whose results can be paired, and the per-view key naming their views.
_VIEW_KEYS = {"orbit": "direction", "volume": "position"}

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


def _check_protocol(r: PrecisionRecall, name: str) -> None:
    if not isinstance(r, PrecisionRecall):
        raise InputError(f"{name}: expected a PrecisionRecall, got {type(r).__name__}")
    if r.protocol not in _VIEW_KEYS:
        raise InputError(f"{name}: unknown protocol {r.protocol!r}; expected one of "
                         f"{', '.join(_VIEW_KEYS)}")


def _same_views(a: PrecisionRecall, b: PrecisionRecall) -> bool:
    if a.protocol != b.protocol or a.seed != b.seed or a.views != b.views:
        return False
    key = _VIEW_KEYS[a.protocol]
    if key not in a.per_view or key not in b.per_view:
        return False
    return bool(np.array_equal(np.asarray(a.per_view[key]), np.asarray(b.per_view[key])))


def paired_difference(a: PrecisionRecall, b: PrecisionRecall, *, confidence: float = 0.95,
                      resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0
                      ) -> PairedDifference:
    """Bootstrap the difference of two evaluations made on the same views.

    Parameters
    ----------
    a, b : PrecisionRecall
        Same protocol ('orbit' or 'volume'), seed and views (directions or
        positions), e.g. two occluders of one mesh evaluated with the same
        settings.
    confidence : float, optional
        Two-sided level in (0, 1], default 0.95.
    resamples : int, optional
        Default 2000.
    seed : int, optional
        Non-negative integer of any size; seeds the resampling
        (``numpy.random.default_rng``). Default 0.

    Returns
    -------
    PairedDifference

    Raises
    ------
    InputError
        If either result has an unknown protocol, the two evaluations do not
        share their views, an option is bad, or the resamples x views would
        not fit in memory.

    Notes
    -----
    Deterministic given ``seed``. Both evaluations are resampled with the
    same view indices; the difference of their pooled figures is computed on
    each resample.

    References
    ----------
    .. [1] Efron, B., Tibshirani, R. J. "An Introduction to the Bootstrap".
       Chapman & Hall/CRC, 1993. :DOI:`10.1201/9780429246593`

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
    _check_protocol(a, "a")
    _check_protocol(b, "b")
    confidence = as_fraction(confidence, "confidence", open_low=True)
    resamples = as_positive_int(resamples, "resamples")
    seed = as_seed(seed)
    if not _same_views(a, b):
        raise InputError("a, b: the evaluations do not share their views (protocol, seed and "
                         "view directions or positions must match)")
    n = a.views
    check_memory(_bootstrap_memory(n, resamples, columns=8),
                 f"paired bootstrap of {n} views x {resamples} resamples")
    alpha = (1 - confidence) / 2
    parts = {which: (*a.ratio_parts(which), *b.ratio_parts(which))
             for which in ("precision", "recall")}
    sums = _resampled_sums(np.random.default_rng(seed), n, resamples,
                           *parts["precision"], *parts["recall"])
    boot_sums = {"precision": sums[:4], "recall": sums[4:]}

    out = {}
    for which in ("precision", "recall"):
        na, da, nb, db = parts[which]
        diff = ratio(na.sum(), da.sum()) - ratio(nb.sum(), db.sum())
        sa_n, sa_d, sb_n, sb_d = boot_sums[which]
        boot = ratio(sa_n, sa_d) - ratio(sb_n, sb_d)
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
