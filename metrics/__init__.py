"""viscore.metrics: occlusion measure, quad precision/recall, conservativeness, uncertainty.

The numbers researchers cite, built on the viscore core: the occlusion
measure (Silvennoinen et al. 2014 [1]_, sec. 3), the orbit precision/recall
protocol (ibid., sec. 6.1), the volume protocol (Wu et al. 2022 [2]_, sec. 3.2),
the depth-aware variant of both, the ray-wise conservativeness check, and
intervals and models for each figure.

- Evaluate: :func:`evaluate`, :func:`orbit_precision_recall`,
  :func:`volume_precision_recall`; to score many occluders against one
  original, build its :class:`ReferenceViews` once and call ``score``.
- Assess one occluder (precision/recall, measure, conservativeness, under the
  JSON names): :func:`assess_occluder` -> :class:`OccluderAssessment`.
- Uncertainty: :func:`bootstrap_ratio`, :func:`paired_difference`,
  :func:`hierarchical_beta_model`, :func:`uncertainty_report`,
  :func:`convergence_ablation`; figures in :mod:`viscore.metrics.plots`.

- Where the protocols look from (:mod:`viscore.metrics.frames`):
  :func:`orbit_frame`, :func:`evaluation_box`, :func:`volume_positions`.
- Culling: :func:`simulate_culling` along a :func:`camera_path` with the
  runtimes of :mod:`viscore.metrics.culling_runtimes`.
- Two meshes triangle for triangle (:mod:`viscore.metrics.mesh_match`):
  :func:`match_triangles`, :func:`surface_distance`.
- Memory a computation will need, checked before it starts
  (:mod:`viscore.metrics.estimates`): :func:`measure_bytes`,
  :func:`evaluation_bytes`, :func:`conservativeness_bytes`, :func:`study_bytes`;
  results as plain JSON values: :func:`jsonable`.

Other helpers shared between the modules (boxes, tallies) are imported from
their modules, not from here.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
"""

from .ablation import AblationResult, convergence_ablation
from .assessment import OccluderAssessment, assess_occluder
from .bayes import BetaModelSummary, hierarchical_beta_model
from .bootstrap import bootstrap_ratio
from .camera_paths import (
    PathCamera,
    camera_path,
    camera_path_json,
    camera_stances,
    camera_walk,
    guess_eye_height,
    read_camera_path,
)
from .conservativeness import (
    ConservativenessReport,
    assert_conservative,
    check_conservative,
    clopper_pearson_upper,
)
from .culling import (
    DEFAULT_HEIGHT,
    DEFAULT_WIDTH,
    CullingResult,
    RuntimeFrames,
    check_camera_path,
    check_culling_memory,
    simulate_culling,
)
from .culling_gap import GAP_CAUSES, CullingGap, culling_gap
from .culling_runtimes import (
    Runtime,
    depth_buffer_runtime,
    frusta_runtime,
    no_culling,
    view_frustum_mask,
)
from .erosion import (
    OcclusionMeasure,
    directional_occlusion_measure,
    erosion_curve,
    occlusion_measure,
)
from .estimates import conservativeness_bytes, evaluation_bytes, measure_bytes, study_bytes
from .frames import evaluation_box, orbit_frame, volume_positions
from .mesh_match import match_triangles, surface_distance
from .orbit import orbit_precision_recall
from .paired import PairedDifference, paired_difference
from .plots import (
    ablation_plot,
    budget_plot,
    culling_plot,
    distribution_plot,
    picture_grid,
    recall_plot,
    silhouette_plot,
    walk_plot,
)
from .precision_recall import PrecisionRecall, jsonable
from .quads import QuadCounts, classify_quads, classify_quads_depth, sample_quads
from .reference_views import PROTOCOLS, ReferenceViews
from .silhouettes import SILHOUETTE_COLOURS, silhouette_image
from .uncertainty import uncertainty_report
from .volume import volume_precision_recall

__all__ = [
    # evaluation
    "evaluate", "PROTOCOLS", "ReferenceViews", "PrecisionRecall", "orbit_precision_recall",
    "volume_precision_recall", "QuadCounts", "classify_quads", "classify_quads_depth",
    "sample_quads",
    # where the protocols look from
    "orbit_frame", "evaluation_box", "volume_positions",
    # one occluder, assessed
    "assess_occluder", "OccluderAssessment",
    # occlusion measure
    "occlusion_measure", "OcclusionMeasure", "directional_occlusion_measure", "erosion_curve",
    # conservativeness
    "check_conservative", "assert_conservative", "ConservativenessReport",
    "clopper_pearson_upper",
    # uncertainty
    "bootstrap_ratio", "paired_difference", "PairedDifference", "hierarchical_beta_model",
    "BetaModelSummary", "uncertainty_report", "convergence_ablation", "AblationResult",
    # culling simulation
    "simulate_culling", "CullingResult", "RuntimeFrames", "Runtime", "no_culling",
    "culling_gap", "CullingGap", "GAP_CAUSES",
    "frusta_runtime", "depth_buffer_runtime", "view_frustum_mask", "camera_path",
    "read_camera_path", "camera_path_json", "PathCamera", "camera_walk", "camera_stances",
    "guess_eye_height", "culling_plot", "check_camera_path",
    "check_culling_memory", "DEFAULT_WIDTH", "DEFAULT_HEIGHT",
    # two meshes, triangle for triangle
    "match_triangles", "surface_distance",
    # memory estimates, JSON values
    "measure_bytes", "evaluation_bytes", "conservativeness_bytes", "study_bytes", "jsonable",
    # figures
    "ablation_plot", "distribution_plot", "silhouette_image", "SILHOUETTE_COLOURS",
    "recall_plot", "budget_plot", "silhouette_plot", "walk_plot", "picture_grid",
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
    known = list(inspect.signature(function).parameters)[2:]  # type: ignore[arg-type]
    unknown = sorted(set(params) - set(known))
    if unknown:
        raise InputError(f"{unknown[0]}: not a setting of the {protocol} protocol "
                         f"(settings: {', '.join(known)})")
    return function(mesh, occluder, **params)  # type: ignore[operator]
