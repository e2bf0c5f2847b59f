"""metrics: occlusion measure, quad precision/recall, conservativeness.

The numbers researchers cite, built on the viscore core, to the protocols of
DESIGN.md: the occlusion measure of seed 000 sec. 3, the orbit protocol of
seed 000 sec. 6.1, the volume protocol of seed 001 sec. 3.2 (and the
depth-aware variant of both), and the ray-wise conservativeness check.
"""

from .ablation import AblationResult, ablation_plot, convergence_ablation
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
from .orbit import orbit_frame, orbit_precision_recall, view_counts
from .paired import PairedDifference, paired_difference
from .precision_recall import PrecisionRecall
from .quads import QuadCounts, classify_quads, classify_quads_depth, sample_quads
from .silhouettes import SILHOUETTE_COLOURS, silhouette_image
from .uncertainty import distribution_plot, uncertainty_report
from .volume import evaluation_box, volume_positions, volume_precision_recall

__all__ = [
    "ConservativenessReport", "check_conservative", "assert_conservative",
    "clopper_pearson_upper", "OcclusionMeasure", "occlusion_measure",
    "directional_occlusion_measure", "erosion_curve", "orbit_frame", "orbit_precision_recall",
    "PrecisionRecall", "QuadCounts", "classify_quads", "classify_quads_depth", "sample_quads",
    "volume_positions", "volume_precision_recall", "evaluate", "view_counts",
    "bootstrap_ratio", "PairedDifference", "paired_difference", "BetaModelSummary",
    "hierarchical_beta_model", "AblationResult", "convergence_ablation", "ablation_plot",
    "uncertainty_report", "distribution_plot", "silhouette_image", "SILHOUETTE_COLOURS",
    "evaluation_box",
]


def evaluate(mesh, occluder, *, protocol: str = "orbit", **params) -> PrecisionRecall:
    """Precision and recall by protocol name: 'orbit' or 'volume' (keywords passed on)."""
    from viscore import InputError

    if protocol == "orbit":
        return orbit_precision_recall(mesh, occluder, **params)
    if protocol == "volume":
        return volume_precision_recall(mesh, occluder, **params)
    raise InputError(f"protocol: expected 'orbit' or 'volume', got {protocol!r}")
