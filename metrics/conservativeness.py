"""Ray-wise conservativeness: is the occluder ever hit before the original?

Along a ray from the evaluation domain, the occluder must not be hit before
the original; a violation is t_occluder < t_original - eps (a miss is
t = inf). The rate comes with a one-sided Clopper-Pearson upper bound [4]_.
Conservative occluders are the goal of the occluder-skins paper [1]_ (sec. 4)
and the box-filling note [2]_; the building-occluders paper calls the same
property conservative enforcement [3]_ (sec. 3.1). Flat occluders (planar
sections, single polygons) and flat originals are accepted: a ray that meets
a flat original and a coplanar occluder at the same point is no violation.

References
----------
.. [1] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
   Bursztyn, A. P. M. "Implementing software occlusion culling for real-time
   applications". XVIII Congreso Argentino de Ciencias de la Computacion
   (CACIC 2012), Workshop de Computacion Grafica, Imagenes y Visualizacion,
   2012. http://sedici.unlp.edu.ar/handle/10915/23640
.. [2] Naaji, K. "Automatic Occluder Generation". A Graphics Diary (blog),
   15 November 2019. http://karim.naaji.fr/automatic_occluder_geneneration.html
.. [3] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
.. [4] Clopper, C. J., Pearson, E. S. "The use of confidence or fiducial limits
   illustrated in the case of the binomial". Biometrika 26(4), 1934,
   pp. 404-413. :DOI:`10.1093/biomet/26.4.404`
"""

from __future__ import annotations

import numbers
import time
from dataclasses import dataclass

import numpy as np
import trimesh
from scipy import stats

from viscore import InputError, Scene, directions_uniform, points_inside
from viscore._validate import (
    as_fraction,
    as_positive,
    as_positive_int,
    as_seed,
    as_vector,
    check_memory,
)
from viscore.constants import CONSERVATIVE_EPS_RELATIVE

from ._views import scene_of
from .frames import evaluation_box, orbit_frame

__all__ = ["ConservativenessReport", "check_conservative", "assert_conservative",
           "clopper_pearson_upper"]

#: Worst violating rays kept in the report.
WORST_RAYS = 10

#: Rays drawn and cast per batch: memory does not grow with the ray count.
_RAYS_PER_BATCH = 1 << 18

#: Peak bytes per ray of one batch: origins, targets, directions and their
#: temporaries (float64 x 3 each), both hit distances and triangle ids, the
#: Embree float32 copies, and the volume domain's rejection candidates
#: (twice the batch, with their inside test), rounded up.
_BYTES_PER_RAY = 1024


def clopper_pearson_upper(violations: int, rays: int, confidence: float) -> float:
    """One-sided Clopper-Pearson upper bound on a binomial rate.

    Examples
    --------
    >>> round(clopper_pearson_upper(0, 1000, 0.95), 5)   # the "rule of three": ~3 / n
    0.00299
    """
    if violations >= rays:
        return 1.0
    return float(stats.beta.ppf(confidence, violations + 1, rays - violations))


@dataclass(frozen=True)
class ConservativenessReport:
    """Outcome of a ray-wise conservativeness check.

    Attributes
    ----------
    rays : int
        Rays cast.
    violations : int
        Rays on which the occluder is hit more than ``eps`` before the original.
    violation_rate : float
        violations / rays.
    violation_upper_bound : float
        One-sided Clopper-Pearson upper bound at ``confidence``.
    confidence : float
    domain : {'orbit', 'volume'}
    worst : list of dict
        Up to 10 violating rays, worst first: ``origin``, ``direction``,
        ``t_original``, ``t_occluder`` (world units; None for a miss).
    eps : float
        Tolerance, world units.
    seed : int
    seconds : float
    """

    rays: int
    violations: int
    violation_rate: float
    violation_upper_bound: float
    confidence: float
    domain: str
    worst: list
    eps: float
    seed: int
    seconds: float

    def passes(self, max_rate: float) -> bool:
        """True when the upper bound is at most ``max_rate``; ``max_rate=0`` means no violation.

        A Clopper-Pearson bound is never 0, so a zero tolerance is read as
        "no violating ray".
        """
        max_rate = as_fraction(max_rate, "max_rate")
        if max_rate == 0:
            return self.violations == 0
        return self.violation_upper_bound <= max_rate

    def summary(self) -> str:
        """One paragraph for people: rate, bound and the worst ray."""
        text = (f"{self.violations} of {self.rays:,} rays hit the occluder before the original "
                f"(rate {self.violation_rate:.3g}; {100 * self.confidence:g}% upper bound "
                f"{self.violation_upper_bound:.3g}; {self.domain} domain, seed {self.seed})")
        if self.worst:
            w = self.worst[0]
            text += (f"\nworst ray: origin {np.round(w['origin'], 6).tolist()}, direction "
                     f"{np.round(w['direction'], 6).tolist()}, occluder at {w['t_occluder']:.6g}"
                     f", original at {w['t_original']}")
        return text


def _domain_rays(domain: str, frame, scene: Scene, n: int, rng: np.random.Generator):
    """``n`` rays of the domain: (origins, unit directions), each (n, 3) float64.

    ``frame`` is the orbit frame (center, extent) or the volume box (lo, hi).
    """
    if domain == "orbit":
        center, extent = frame
        radius = 0.5 * extent
        origins = center + radius * directions_uniform(n, seed=int(rng.integers(2**31)))
        targets = center + radius * np.cbrt(rng.random(n))[:, None] * directions_uniform(
            n, seed=int(rng.integers(2**31)))
        d = targets - origins
        return origins, d / np.linalg.norm(d, axis=1)[:, None]
    lo, hi = frame
    origins = np.zeros((0, 3))
    for _ in range(20):  # rejection of points inside the mesh
        cand = rng.uniform(lo, hi, (max(n - len(origins), 1) * 2, 3))
        cand = cand[~points_inside(scene, cand)]
        origins = np.concatenate([origins, cand])[:n]
        if len(origins) == n:
            break
    else:
        raise InputError("mesh: the volume domain is almost all inside the mesh")
    return origins, directions_uniform(n, seed=int(rng.integers(2**31)))


def check_conservative(mesh: trimesh.Trimesh | Scene, occluder: trimesh.Trimesh | Scene | None,
                       *, rays: int = 100_000, confidence: float = 0.95, domain: str = "orbit",
                       seed: int = 0, eps: float | None = None, frame: tuple | None = None
                       ) -> ConservativenessReport:
    """Cast random rays and count those that hit the occluder before the original.

    Parameters
    ----------
    mesh, occluder : trimesh.Trimesh or Scene
        Original and occluder (None or empty: never violates). Either may be
        flat (a planar section, a single triangle or quad) or open. A
        :class:`~viscore.Scene` already built for one (for example
        :attr:`ReferenceViews.scene <viscore.metrics.ReferenceViews.scene>`) is
        cast as it is, without building another Embree scene.
    rays : int, optional
        Default 100,000.
    confidence : float, optional
        Of the one-sided upper bound, in (0, 1). Default 0.95.
    domain : {'orbit', 'volume'}, optional
        'orbit': rays from uniform points on the orbit sphere (smallest
        enclosing sphere x 1.01, flat meshes included) towards uniform points
        inside it. 'volume': uniform origins in the padded bounding box
        outside the mesh (a flat mesh's box is padded by the view spacing),
        uniform directions.
    seed : int, optional
        A non-negative integer. Default 0.
    eps : float, optional
        Tolerance in world units, >= 0; default 1e-5 x bounding-box diagonal.
    frame : tuple, optional
        The domain's frame of the original, when it is known already: the
        orbit frame ``(center, extent)`` of :func:`viscore.metrics.orbit_frame`
        (``ReferenceViews.center, .extent`` of orbit views), or the volume box
        ``(lo, hi)`` of :func:`viscore.metrics.evaluation_box`. Default:
        computed from ``mesh`` (from a Scene's vertices and bounds when
        ``mesh`` is one).

    Returns
    -------
    ConservativenessReport

    Raises
    ------
    InputError
        On a bad argument or an empty original.

    Notes
    -----
    Rays are drawn and cast in batches of 262,144: memory does not grow with
    ``rays`` (a batch needs about 256 MB at most, checked before any work).
    Deterministic given ``seed``.

    References
    ----------
    .. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
       Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
       :DOI:`10.1111/cgf.14669`

    Examples
    --------
    >>> box = trimesh.creation.box()
    >>> inner = box.copy(); _ = inner.apply_scale(0.5)
    >>> check_conservative(box, inner, rays=1000).violations
    0
    """
    rays = as_positive_int(rays, "rays")
    confidence = as_fraction(confidence, "confidence", open_low=True)
    if confidence >= 1:
        raise InputError("confidence: expected a number in (0, 1), got 1")
    if domain not in ("orbit", "volume"):
        raise InputError(f"domain: expected 'orbit' or 'volume', got {domain!r}")
    seed = as_seed(seed)
    if eps is not None:
        if isinstance(eps, bool) or not isinstance(eps, numbers.Real) or not (
                np.isfinite(eps) and eps >= 0):
            raise InputError(f"eps: expected a finite number >= 0, got {eps!r}")
        eps = float(eps)
    if frame is not None:
        try:
            first, second = frame
        except (TypeError, ValueError) as exc:
            raise InputError(f"frame: expected (center, extent) or (lo, hi), got {frame!r:.80}"
                             ) from exc
        frame = ((as_vector(first, "frame center"), as_positive(second, "frame extent"))
                 if domain == "orbit" else (as_vector(first, "frame lo"),
                                            as_vector(second, "frame hi")))
    check_memory(min(rays, _RAYS_PER_BATCH) * _BYTES_PER_RAY, f"rays={rays}")
    start = time.perf_counter()
    original = scene_of(mesh, "mesh")
    other = scene_of(occluder, "occluder")
    eps = CONSERVATIVE_EPS_RELATIVE * original.diagonal if eps is None else eps
    if frame is None:
        frame = orbit_frame(mesh) if domain == "orbit" else evaluation_box(mesh)[:2]
    rng = np.random.default_rng(seed)
    violations = 0
    worst: list[tuple] = []  # (-gap, ray index, description), best first
    for first in range(0, rays if other is not None else 0, _RAYS_PER_BATCH):
        n = min(_RAYS_PER_BATCH, rays - first)
        o, d = _domain_rays(domain, frame, original, n, rng)
        t_orig, _ = original.first_hit(o, d)
        t_occ, _ = other.first_hit(o, d)
        with np.errstate(invalid="ignore"):  # both miss: inf - inf = nan, not a violation
            gap = t_orig - t_occ  # occluder hit, original missed: inf, a violation
        bad = np.flatnonzero(gap > eps)
        violations += len(bad)
        for i in bad[np.argsort(-gap[bad], kind="stable")][:WORST_RAYS]:
            worst.append((-gap[i], first + i, {
                "origin": o[i].tolist(), "direction": d[i].tolist(),
                "t_original": None if np.isinf(t_orig[i]) else float(t_orig[i]),
                "t_occluder": float(t_occ[i])}))
        worst = sorted(worst, key=lambda w: w[:2])[:WORST_RAYS]
    return ConservativenessReport(
        rays=rays, violations=violations, violation_rate=violations / rays,
        violation_upper_bound=clopper_pearson_upper(violations, rays, confidence),
        confidence=confidence, domain=domain, worst=[w[2] for w in worst],
        eps=eps, seed=seed, seconds=time.perf_counter() - start)


def assert_conservative(mesh: trimesh.Trimesh, occluder: trimesh.Trimesh | None, *,
                        max_rate: float = 0.0, rays: int = 100_000, confidence: float = 0.95,
                        domain: str = "orbit", seed: int = 0) -> ConservativenessReport:
    """Raise AssertionError when the occluder is not conservative enough; for test suites.

    Fails when the one-sided upper bound on the violation rate exceeds
    ``max_rate``, or, with the default ``max_rate=0``, when any ray violates
    (a bound is never 0, so zero tolerance means zero violations).

    Parameters
    ----------
    mesh, occluder, rays, confidence, domain, seed
        As in :func:`check_conservative`.
    max_rate : float, optional
        Largest acceptable upper bound on the violation rate, in [0, 1].
        Default 0 (no violating ray).

    Returns
    -------
    ConservativenessReport
        When the check passes.

    Raises
    ------
    AssertionError
        With the report's summary (rate, bound, worst ray).

    Examples
    --------
    >>> box = trimesh.creation.box()
    >>> big = box.copy(); _ = big.apply_scale(2.0)
    >>> assert_conservative(box, big, rays=1000)
    Traceback (most recent call last):
    ...
    AssertionError: ...
    """
    max_rate = as_fraction(max_rate, "max_rate")
    report = check_conservative(mesh, occluder, rays=rays, confidence=confidence,
                                domain=domain, seed=seed)
    if not report.passes(max_rate):
        raise AssertionError(f"occluder is not conservative (max rate {max_rate:g}): "
                             + report.summary())
    return report
