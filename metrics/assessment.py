"""Assessment of one occluder: precision/recall, occlusion measure, conservativeness.

The orbit (Silvennoinen et al. 2014, sec. 6.1) or volume (Wu et al. 2022, sec.
3.2) precision and recall, the occlusion measure (sec. 3) and the ray-wise check.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
.. [3] Clopper, C. J., Pearson, E. S. "The use of confidence or fiducial limits
   illustrated in the case of the binomial". Biometrika 26(4), 1934,
   pp. 404-413. :DOI:`10.1093/biomet/26.4.404`
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import trimesh

from viscore import InputError, stream_seed
from viscore._validate import as_fraction, as_positive_int

from ._views import scene_of
from .conservativeness import check_conservative
from .erosion import occlusion_measure
from .frames import evaluation_box, orbit_frame
from .precision_recall import (
    PER_VIEW_ARRAYS,
    PrecisionRecall,
    record_from_json,
    record_to_json,
)
from .reference_views import ReferenceViews, check_protocol

__all__ = ["OccluderAssessment", "assess_occluder"]


@dataclass(frozen=True)
class OccluderAssessment:
    """Everything a study reports about one occluder, under the toolkit's JSON names.

    Attributes
    ----------
    method : str or None
        Generator name (from an ``Occluder``), None for a bare mesh.
    params : dict
        Generator parameters (from an ``Occluder``), else empty.
    triangles : int
        Faces of the occluder mesh (0 for none).
    precision, recall : float
        Pooled quad precision and recall (NaN when undefined).
    precision_ci, recall_ci : list of 2 float
        95% percentile bootstrap intervals over views.
    occlusion_measure, occlusion_measure_se : float
        Total occlusion measure of the occluder and its standard error,
        world units cubed (0 for an empty occluder).
    violations, rays : int
        Conservativeness rays on which the occluder is hit first, of ``rays``.
    violation_rate, violation_upper_bound : float
        ``violations / rays`` and its one-sided Clopper-Pearson upper bound
        at ``confidence``.
    confidence : float
    seconds : float
        Wall time of the occluder's generation (from an ``Occluder``); NaN
        for a bare mesh.
    seconds_evaluate, seconds_measure, seconds_validate : float
        Wall time of the three steps (scoring only: the reference views are
        built beforehand).
    per_view : dict of arrays
        The evaluation's per-view figures (see :class:`PrecisionRecall`).
    protocol : {'orbit', 'volume'}
    depth_aware : bool
    seed : int
        Seed of the views, also of the measure's directions and the rays.
    evaluation : dict
        Settings of the views (``PrecisionRecall.params``) and of the measure
        (``directions``, ``measure_resolution``) and the check (``domain``).
    info : dict
        Method-specific figures of the generator (from an ``Occluder``).
    """

    method: str | None
    params: dict
    triangles: int
    precision: float
    recall: float
    precision_ci: list
    recall_ci: list
    occlusion_measure: float
    occlusion_measure_se: float
    violations: int
    rays: int
    violation_rate: float
    violation_upper_bound: float
    confidence: float
    seconds: float
    seconds_evaluate: float
    seconds_measure: float
    seconds_validate: float
    per_view: dict = field(metadata=PER_VIEW_ARRAYS)
    protocol: str = "orbit"
    depth_aware: bool = False
    seed: int = 0
    evaluation: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """JSON document: every field under its name, arrays as lists, NaN as None."""
        return record_to_json(self)

    @classmethod
    def from_json(cls, document: dict) -> OccluderAssessment:
        """The assessment of a :meth:`to_json` document (other keys are ignored)."""
        return record_from_json(cls, document)

    def precision_recall(self) -> PrecisionRecall:
        """The evaluation as a :class:`PrecisionRecall` (for paired comparisons, Bayes)."""
        return PrecisionRecall(
            precision=self.precision, recall=self.recall, precision_ci=self.precision_ci,
            recall_ci=self.recall_ci, per_view=self.per_view, protocol=self.protocol,
            depth_aware=self.depth_aware, seed=self.seed,
            params={k: v for k, v in self.evaluation.items()
                    if k not in _CHECK_SETTINGS}, seconds=self.seconds_evaluate)


#: Evaluation settings of the measure and the check (the rest are the views').
_CHECK_SETTINGS = ("directions", "measure_resolution", "domain", "rays", "confidence")


def assess_occluder(reference: ReferenceViews | trimesh.Trimesh, occluder, *,
                    directions: int = 64, measure_resolution: int | None = None,
                    rays: int = 100_000, confidence: float = 0.95, domain: str = "orbit",
                    view_settings: dict | None = None
                    ) -> OccluderAssessment:
    """Evaluate, measure and check one occluder against the original's views.

    Parameters
    ----------
    reference : ReferenceViews or trimesh.Trimesh
        The original's views, built once and reused for many occluders; or
        the original mesh itself, whose views are then built here from
        ``view_settings`` (keywords of :class:`ReferenceViews`) and dropped.
    occluder : trimesh.Trimesh, None or Occluder
        The occluder mesh (None or empty: covers nothing), or a generator's
        ``Occluder``, whose ``method``, ``params``, ``seconds`` and ``info``
        are carried into the result.
    directions : int, optional
        Directions of the occlusion measure (default 64).
    measure_resolution : int, optional
        Pixels per side of the measure's projections; default the views'.
    rays : int, optional
        Conservativeness rays (default 100,000).
    confidence : float, optional
        Of the violation rate's upper bound, in (0, 1). Default 0.95.
    domain : {'orbit', 'volume'}, optional
        Where the conservativeness rays start (default 'orbit').
    view_settings : dict, optional
        Only with a mesh as ``reference``.

    Returns
    -------
    OccluderAssessment

    Raises
    ------
    InputError
        On bad settings or meshes (checked before the work of each step).

    Notes
    -----
    One Embree scene per mesh: the occluder's :class:`~viscore.Scene` is built
    once and cast by all three steps, and the check casts the views' own scene
    of the original (:attr:`ReferenceViews.scene`) in their orbit frame.

    Deterministic: the views' seed also seeds the measure's directions and the
    conservativeness rays, each through its own stream
    (``viscore.stream_seed(seed, 'occlusion-measure')``, ``'conservativeness'``)
    so that neither repeats the view directions' draws; the same views,
    occluder and settings give the same assessment (times aside).

    Examples
    --------
    >>> box = trimesh.creation.box()
    >>> views = ReferenceViews(box, views=4, quads=200, resolution=24)
    >>> a = assess_occluder(views, box, directions=2, rays=500)
    >>> float(a.recall), a.violations, a.triangles
    (1.0, 0, 12)
    """
    if isinstance(reference, ReferenceViews):
        if view_settings:
            raise InputError("view_settings: only with a mesh as reference (the views are "
                             "built already)")
        views = reference
    elif isinstance(reference, trimesh.Trimesh):
        views = ReferenceViews(reference, **{"cache": False, **(view_settings or {})})
    else:
        raise InputError(f"reference: expected ReferenceViews or a trimesh.Trimesh, got "
                         f"{type(reference).__name__}")
    directions = as_positive_int(directions, "directions")
    rays = as_positive_int(rays, "rays")
    measure_resolution = as_positive_int(views.resolution if measure_resolution is None
                                         else measure_resolution, "measure_resolution",
                                         maximum=8192)
    confidence = as_fraction(confidence, "confidence", open_low=True)
    if confidence >= 1:
        raise InputError("confidence: expected a number in (0, 1), got 1")
    domain = check_protocol(domain, "domain")
    seed = views.seed
    generated = hasattr(occluder, "mesh") and hasattr(occluder, "method")
    mesh = occluder.mesh if generated else occluder
    if mesh is not None and not isinstance(mesh, trimesh.Trimesh):
        raise InputError(f"occluder: expected a trimesh.Trimesh, an Occluder or None, got "
                         f"{type(mesh).__name__}")
    target = mesh if mesh is not None and len(mesh.faces) else None
    # one Embree scene per mesh: the occluder's is built here for the three steps, the
    # original's is the views' own
    scene = scene_of(target, "occluder")
    pr = views.score(scene)
    start = time.perf_counter()
    if target is not None:
        om = occlusion_measure(scene, directions=directions, resolution=measure_resolution,  # type: ignore[arg-type]
                               seed=stream_seed(seed, "occlusion-measure"),
                               frame=orbit_frame(target))  # the occluder mesh's own window
        measure, measure_se = om.occlusion_measure, om.occlusion_measure_se
    else:
        measure, measure_se = 0.0, 0.0
    seconds_measure = time.perf_counter() - start
    if domain == "orbit":  # the original's orbit frame: the views' when they are orbit views
        frame = ((views.center, views.extent) if views.protocol == "orbit"
                 else orbit_frame(views.mesh))
    else:
        frame = evaluation_box(views.mesh)[:2]
    cons = check_conservative(views.scene, scene, rays=rays, confidence=confidence,
                              domain=domain, seed=stream_seed(seed, "conservativeness"),
                              frame=frame)
    return OccluderAssessment(
        method=occluder.method if generated else None,
        params=dict(occluder.params) if generated else {},
        triangles=0 if target is None else len(target.faces),
        precision=pr.precision, recall=pr.recall, precision_ci=pr.precision_ci,
        recall_ci=pr.recall_ci, occlusion_measure=measure, occlusion_measure_se=measure_se,
        violations=cons.violations, rays=cons.rays, violation_rate=cons.violation_rate,
        violation_upper_bound=cons.violation_upper_bound, confidence=cons.confidence,
        seconds=float(occluder.seconds) if generated else math.nan,
        seconds_evaluate=pr.seconds, seconds_measure=seconds_measure,
        seconds_validate=cons.seconds, per_view=pr.per_view, protocol=pr.protocol,
        depth_aware=pr.depth_aware, seed=seed,
        evaluation={**pr.params, "directions": directions,
                    "measure_resolution": measure_resolution, "domain": domain},
        info=dict(occluder.info) if generated else {})
