"""Uncertainty report of one occluder: bootstrap intervals and Bayesian summaries.

Gathers, for one (mesh, occluder) pair, what DESIGN.md's "Uncertainty" asks
of every figure: percentile and BCa bootstrap intervals over views for the
pooled precision and recall (:mod:`viscore.metrics.bootstrap`) and for the total
occlusion measure, and the hierarchical Beta models of per-view recall and
precision (:mod:`viscore.metrics.bayes`) with their convergence diagnostics.
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import trimesh

from .bayes import BetaModelSummary, hierarchical_beta_model
from .bootstrap import bootstrap_ratio
from .erosion import occlusion_measure
from .orbit import orbit_precision_recall
from .precision_recall import PrecisionRecall
from .volume import volume_precision_recall

__all__ = ["uncertainty_report", "distribution_plot"]


def uncertainty_report(mesh: trimesh.Trimesh, occluder: trimesh.Trimesh, *,
                       protocol: str = "orbit", views: int = 256, quads: int | None = None,
                       resolution: int = 256, directions: int = 64, threshold: float = 0.9,
                       steps: int = 4000, seed: int = 0, spacing: float | None = None
                       ) -> tuple[dict, PrecisionRecall, dict[str, BetaModelSummary]]:
    """Intervals, posterior summaries and diagnostics for one occluder.

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
    """
    if protocol == "orbit":
        result = orbit_precision_recall(mesh, occluder, views=views, quads=quads or 32000,
                                        resolution=resolution, seed=seed)
    else:
        result = volume_precision_recall(mesh, occluder, quads=quads or 5000,
                                         resolution=resolution, seed=seed, spacing=spacing)
    om = occlusion_measure(occluder, directions=directions, resolution=resolution, seed=seed)
    per_dir = 4 * np.pi * om.per_view["measure"]
    ones = np.ones_like(per_dir)
    models = {q: hierarchical_beta_model(result, quantity=q, threshold=threshold, steps=steps,
                                         seed=seed) for q in ("recall", "precision")}
    report = {
        "protocol": protocol, "views": result.views, "seed": seed,
        "precision": result.precision, "recall": result.recall,
        "precision_ci": result.precision_ci, "recall_ci": result.recall_ci,
        "precision_ci_bca": list(bootstrap_ratio(*result.ratio_parts("precision"),
                                                 method="bca", seed=seed)),
        "recall_ci_bca": list(bootstrap_ratio(*result.ratio_parts("recall"), method="bca",
                                              seed=seed)),
        "occlusion_measure": om.occlusion_measure,
        "occlusion_measure_se": om.occlusion_measure_se,
        "occlusion_measure_ci": list(bootstrap_ratio(per_dir, ones, seed=seed)),
        "occlusion_measure_ci_bca": list(bootstrap_ratio(per_dir, ones, method="bca",
                                                         seed=seed)),
        "bayes": {q: asdict(m) for q, m in models.items()},
        "params": result.params,
    }
    return report, result, models


def distribution_plot(result: PrecisionRecall, models: dict[str, BetaModelSummary], path
                      ) -> None:
    """PNG: per-view histograms of quad recall and precision with the fitted population."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy import stats

    pv = result.per_view
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    for ax, q, den in ((axes[0], "recall", "quads_orig"), (axes[1], "precision", "quads_occ")):
        n = np.asarray(pv[den], float)
        k = np.asarray(pv["quads_both"], float)
        rates = k[n > 0] / n[n > 0]
        m = models[q]
        ax.hist(rates, bins=30, range=(0, 1), density=True, alpha=0.6, label="views")
        x = np.linspace(0.001, 0.999, 400)
        phi = m.mean * (1 - m.mean) / max(m.spread**2, 1e-12) - 1
        if phi > 0:
            ax.plot(x, stats.beta.pdf(x, m.mean * phi, (1 - m.mean) * phi), "k-",
                    label="population (posterior mean)")
        ax.axvline(m.mean, color="C3", lw=1, label=f"mean {m.mean:.3f}")
        ax.set_xlabel(f"{q} per view (per quad)")
        ax.set_ylabel("density")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
