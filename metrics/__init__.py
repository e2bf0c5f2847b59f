"""metrics: occlusion measure, quad precision/recall, conservativeness.

The numbers researchers cite, built on the viscore core, to the protocols of
DESIGN.md: the occlusion measure of seed 000 sec. 3, the orbit protocol of
seed 000 sec. 6.1, the volume protocol of seed 001 sec. 3.2 (and the
depth-aware variant of both), and the ray-wise conservativeness check.
"""

from .ablation import AblationResult, ablation_plot, convergence_ablation
from .assessment import OccluderAssessment, assess_occluder
from .bayes import BetaModelSummary, hierarchical_beta_model
from .bootstrap import bootstrap_ratio
from .conservativeness import (
    ConservativenessReport,
    assert_conservative,
    check_conservative,
    clopper_pearson_upper,
)
from .erosion import (
    OcclusionMeasure,
    directional_occlusion_measure,
    erosion_curve,
    occlusion_measure,
)
from .orbit import orbit_frame, orbit_precision_recall
from .paired import PairedDifference, paired_difference
from .precision_recall import PrecisionRecall
from .quads import QuadCounts, classify_quads, classify_quads_depth, sample_quads
from .reference_views import PROTOCOLS, ReferenceViews
from .silhouettes import SILHOUETTE_COLOURS, silhouette_image
from .uncertainty import distribution_plot, uncertainty_report
from .volume import evaluation_box, volume_positions, volume_precision_recall

__all__ = [
    "ConservativenessReport", "check_conservative", "assert_conservative",
    "clopper_pearson_upper", "OcclusionMeasure", "occlusion_measure",
    "directional_occlusion_measure", "erosion_curve", "orbit_frame", "orbit_precision_recall",
    "PrecisionRecall", "QuadCounts", "classify_quads", "classify_quads_depth", "sample_quads",
    "volume_positions", "volume_precision_recall", "evaluate",
    "bootstrap_ratio", "PairedDifference", "paired_difference", "BetaModelSummary",
    "hierarchical_beta_model", "AblationResult", "convergence_ablation", "ablation_plot",
    "uncertainty_report", "distribution_plot", "silhouette_image", "SILHOUETTE_COLOURS",
    "evaluation_box", "ReferenceViews", "PROTOCOLS", "OccluderAssessment", "assess_occluder",
]


def evaluate(mesh, occluder, *, protocol: str = "orbit", **params) -> PrecisionRecall:
    """Precision and recall by protocol name (settings passed on as keywords).

    Parameters
    ----------
    mesh, occluder : trimesh.Trimesh
        The original and the occluder (None or empty: covers nothing).
    protocol : {'orbit', 'volume'}, optional
        Default 'orbit'.
    **params
        Settings of that protocol: those of :func:`orbit_precision_recall` or
        :func:`volume_precision_recall`.

    Returns
    -------
    PrecisionRecall

    Raises
    ------
    InputError
        On an unknown protocol (the message lists the valid names), a setting
        the protocol does not have, or a bad value.
    """
    import inspect

    from viscore import InputError

    from .reference_views import check_protocol

    function = {"orbit": orbit_precision_recall,
                "volume": volume_precision_recall}[check_protocol(protocol)]
    known = list(inspect.signature(function).parameters)[2:]
    unknown = sorted(set(params) - set(known))
    if unknown:
        raise InputError(f"{unknown[0]}: not a setting of the {protocol} protocol "
                         f"(settings: {', '.join(known)})")
    return function(mesh, occluder, **params)
