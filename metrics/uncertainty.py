"""Uncertainty report of one occluder: bootstrap intervals and Bayesian summaries.

Bootstrap intervals over views (Efron 1987) and hierarchical Beta models of the
orbit (Silvennoinen et al. 2014, sec. 6.1) or volume (Wu et al. 2022, sec. 3.2) figures.

References
----------
.. [1] Efron, B. "Better Bootstrap Confidence Intervals". Journal of the
   American Statistical Association 82(397), 1987, pp. 171-185.
   :DOI:`10.1080/01621459.1987.10478410`
.. [2] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [3] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
.. [4] Gelman, A., Carlin, J. B., Stern, H. S., Dunson, D. B., Vehtari, A.,
   Rubin, D. B. "Bayesian Data Analysis", 3rd ed. CRC Press, 2013.
   :DOI:`10.1201/b16018`
.. [5] Foreman-Mackey, D., Hogg, D. W., Lang, D., Goodman, J. "emcee: The MCMC
   Hammer". Publications of the Astronomical Society of the Pacific 125(925),
   2013, pp. 306-312. :DOI:`10.1086/670067`
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import trimesh

from viscore import stream_seed
from viscore._validate import (
    as_fraction,
    as_positive,
    as_positive_int,
    as_seed,
    check_memory,
)

from .bayes import BAYES_QUANTITIES, BetaModelSummary, check_model_memory, hierarchical_beta_model
from .bootstrap import BOOTSTRAP_RESAMPLES, _bootstrap_memory, bootstrap_ratio
from .erosion import occlusion_measure
from .orbit import orbit_precision_recall
from .precision_recall import PrecisionRecall
from .reference_views import DEFAULT_QUADS, check_protocol
from .volume import volume_precision_recall

__all__ = ["uncertainty_report"]

#: emcee walkers of the Beta models (the default of :func:`hierarchical_beta_model`).
_WALKERS = 32

#: Largest image side, pixels (the limit of the orbit, volume and measure functions).
_MAX_RESOLUTION = 8192


def uncertainty_report(mesh: trimesh.Trimesh, occluder: trimesh.Trimesh, *,
                       protocol: str = "orbit", views: int = 256, quads: int | None = None,
                       resolution: int = 256, directions: int = 64, threshold: float = 0.9,
                       steps: int = 4000, seed: int = 0, spacing: float | None = None
                       ) -> tuple[dict, PrecisionRecall, dict[str, BetaModelSummary]]:
    """Intervals, posterior summaries and diagnostics for one occluder.

    Parameters
    ----------
    mesh, occluder : trimesh.Trimesh
        The original and its occluder.
    protocol : {'orbit', 'volume'}, optional
        Evaluation protocol, default 'orbit'.
    views : int, optional
        Orbit views (ignored by the volume protocol). Default 256.
    quads : int, optional
        Quads per view; default 32,000 (orbit) or 5,000 (volume).
    resolution : int, optional
        Pixels per image side, at most 8192. Default 256.
    directions : int, optional
        Directions of the occlusion measure. Default 64.
    threshold : float, optional
        In [0, 1], for the Beta models' tail probability. Default 0.9.
    steps : int, optional
        emcee steps per walker. Default 4000.
    seed : int, optional
        Non-negative integer of any size; seeds the evaluation, the
        bootstraps and the Beta models. Default 0.
    spacing : float, optional
        Volume protocol: view spacing in world units (default: the protocol's).

    Returns
    -------
    report : dict
        ``precision``, ``recall``, ``precision_ci`` and ``recall_ci``
        (percentile), ``precision_ci_bca``, ``recall_ci_bca``,
        ``occlusion_measure`` of the occluder with ``occlusion_measure_se``,
        ``occlusion_measure_ci`` and ``occlusion_measure_ci_bca`` (bootstrap
        over directions), ``bayes`` (one summary per quantity), ``seed``.
    result : PrecisionRecall
        The evaluation behind it (for plots).
    models : dict
        The two :class:`BetaModelSummary` objects.

    Raises
    ------
    InputError
        On an unknown protocol or a bad option, checked before any work, or
        when the bootstraps or Beta models would not fit in memory (checked
        before the evaluation for the orbit protocol, whose view count is
        known in advance).

    Notes
    -----
    Deterministic given ``seed``.
    """
    protocol = check_protocol(protocol)
    views = as_positive_int(views, "views")
    quads = DEFAULT_QUADS[protocol] if quads is None else as_positive_int(quads, "quads")
    resolution = as_positive_int(resolution, "resolution", maximum=_MAX_RESOLUTION)
    directions = as_positive_int(directions, "directions")
    threshold = as_fraction(threshold, "threshold")
    steps = as_positive_int(steps, "steps")
    seed = as_seed(seed)
    if spacing is not None:
        spacing = as_positive(spacing, "spacing")
    check_memory(_bootstrap_memory(directions, BOOTSTRAP_RESAMPLES),
                 f"bootstrap of {directions} directions x {BOOTSTRAP_RESAMPLES} resamples")
    if protocol == "orbit":
        check_memory(_bootstrap_memory(views, BOOTSTRAP_RESAMPLES, columns=8),
                     f"bootstrap of {views} views x {BOOTSTRAP_RESAMPLES} resamples")
        check_model_memory(walkers=_WALKERS, steps=steps, views=views)
        result = orbit_precision_recall(mesh, occluder, views=views, quads=quads,
                                        resolution=resolution, seed=seed)
    else:
        check_model_memory(walkers=_WALKERS, steps=steps, views=1)
        result = volume_precision_recall(mesh, occluder, quads=quads, resolution=resolution,
                                         seed=seed, spacing=spacing)
    om = occlusion_measure(occluder, directions=directions, resolution=resolution,
                           seed=stream_seed(seed, "occlusion-measure"))
    per_dir = 4 * np.pi * om.per_view["measure"]
    ones = np.ones_like(per_dir)
    models = {q: hierarchical_beta_model(result, quantity=q, threshold=threshold,
                                         walkers=_WALKERS, steps=steps,
                                         seed=stream_seed(seed, f"beta-model-{q}"))
              for q in BAYES_QUANTITIES}
    boot = stream_seed(seed, "bootstrap")  # as the percentile intervals of the result
    report = {
        "protocol": protocol, "views": result.views, "seed": seed,
        "precision": result.precision, "recall": result.recall,
        "precision_ci": result.precision_ci, "recall_ci": result.recall_ci,
        "precision_ci_bca": list(bootstrap_ratio(*result.ratio_parts("precision"),
                                                 method="bca", seed=boot)),
        "recall_ci_bca": list(bootstrap_ratio(*result.ratio_parts("recall"), method="bca",
                                              seed=boot)),
        "occlusion_measure": om.occlusion_measure,
        "occlusion_measure_se": om.occlusion_measure_se,
        "occlusion_measure_ci": list(bootstrap_ratio(per_dir, ones, seed=boot)),
        "occlusion_measure_ci_bca": list(bootstrap_ratio(per_dir, ones, method="bca",
                                                         seed=boot)),
        "bayes": {q: asdict(m) for q, m in models.items()},
        "params": result.params,
    }
    return report, result, models
