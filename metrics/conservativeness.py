"""Ray-wise conservativeness: is the occluder ever hit before the original?

A violation is a ray that meets the occluder before the original; the rate comes
with a one-sided Clopper-Pearson upper bound [4]_ (conservative occluders: [1]_
sec. 4, [2]_, [3]_).

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
.. [5] Moller, T., Trumbore, B. "Fast, minimum storage ray-triangle
   intersection". Journal of Graphics Tools 2(1), 1997, pp. 21-28.
   :DOI:`10.1080/10867651.1997.10487468`
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

#: Safety factor of the float32 error bound of an Embree hit distance (module
#: docstring): a ray whose float32 gap exceeds eps by more than the bound of both
#: hits is a violation without the float64 judgement. With factor 1 the largest
#: error measured was 0.85 of the bound (400,000 orbit and as many volume rays on
#: each of building-cottage, bunny, fat-torus and sponge). The factor only
#: decides which rays are judged again: a larger one costs time, never a violation.
FLOAT32_ERROR_FACTOR = 16.0

#: Barycentric slack of the float64 ray/triangle test: a ray within this share
#: of the triangle's size of its closed region meets it (a shared edge, a seam
#: between coplanar faces of loose parts).
BARYCENTRIC_SLACK = 1e-9

#: Smallest cos(incidence) at which the float64 test takes a ray to meet a
#: triangle's plane; below it the ray runs in the plane.
_PARALLEL_COS = 1e-12

#: Shortest probe half-length, fraction of the original's diagonal (eps may be 0).
_PROBE_RELATIVE = 1e-6

#: Unit roundoff of float32, the precision of Embree's hit distances, and of float64.
_FLOAT32_UNIT = 2.0 ** -24
_FLOAT64_UNIT = 2.0 ** -53


def _triangles(scene: Scene, tri: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First vertices and the two edges from it, float64 ``(k, 3)`` each, of triangles ``tri``."""
    v = scene.vertices[scene.faces[tri]]
    return v[:, 0], v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]


def _unit_normals(scene: Scene, tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals ``(k, 3)`` of triangles ``tri`` and the norms of their cross products."""
    _, e1, e2 = _triangles(scene, tri)
    n = np.cross(e1, e2)
    norm = np.linalg.norm(n, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.where(norm[:, None] > 0, n / norm[:, None], 0.0)
    return unit, norm


def _float32_error(scene: Scene, o: np.ndarray, d: np.ndarray, t: np.ndarray,
                   tri: np.ndarray) -> np.ndarray:
    """Bound on the float32 error of Embree's hit distances ``t`` (inf for a miss).

    ``FLOAT32_ERROR_FACTOR`` x 2^-24 x (|o - centre| + t + 2 diagonal) / cos:
    the float32 rounding of the origin, the direction and the vertices in the
    scene's unit frame (a power of two under 2 diagonals), each moving the
    plane crossing by its size over the cosine of the incidence.
    """
    err = np.full(len(t), np.inf)
    hit = np.flatnonzero((tri >= 0) & np.isfinite(t))
    if len(hit):
        unit, _ = _unit_normals(scene, tri[hit])
        cos = np.abs(np.einsum("ij,ij->i", unit, d[hit]))
        centre = 0.5 * scene.bounds[0] + 0.5 * scene.bounds[1]
        size = np.linalg.norm(o[hit] - centre, axis=1) + t[hit] + 2.0 * scene.diagonal
        with np.errstate(divide="ignore"):
            err[hit] = FLOAT32_ERROR_FACTOR * _FLOAT32_UNIT * size / cos
    return err


def _meet64(scene: Scene, tri: np.ndarray, o: np.ndarray, d: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Float64 Moller-Trumbore [5]_ of ray k against triangle ``tri[k]`` (-1: none).

    Returns ``(t_plane, meets, cos)``: the distance to the triangle's plane
    (nan where the ray runs in it, or for no triangle), whether the ray meets
    the closed triangle within :data:`BARYCENTRIC_SLACK` at ``t >= 0``, and
    the cosine of the incidence (0 for no triangle).
    """
    k = len(tri)
    t_plane = np.full(k, np.nan)
    meets = np.zeros(k, dtype=bool)
    cos = np.zeros(k)
    some = np.flatnonzero(tri >= 0)
    if len(some) == 0:
        return t_plane, meets, cos
    v0, e1, e2 = _triangles(scene, tri[some])
    oo, dd = o[some], d[some]
    pvec = np.cross(dd, e2)
    det = np.einsum("ij,ij->i", e1, pvec)  # = -(d . e1 x e2): twice the area times the cosine
    area2 = np.linalg.norm(np.cross(e1, e2), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.where(area2 > 0, np.abs(det) / area2, 0.0)
        ok = c > _PARALLEL_COS
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), np.nan)
        s = oo - v0
        u = np.einsum("ij,ij->i", s, pvec) * inv
        q = np.cross(s, e1)
        w = np.einsum("ij,ij->i", dd, q) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        inside = (ok & (u >= -BARYCENTRIC_SLACK) & (w >= -BARYCENTRIC_SLACK)
                  & (u + w <= 1.0 + BARYCENTRIC_SLACK) & (t >= 0.0))
    t_plane[some] = t
    meets[some] = inside
    cos[some] = c
    return t_plane, meets, cos


def _probe(scene: Scene, points: np.ndarray, normals: np.ndarray, half: float
           ) -> list[np.ndarray]:
    """Triangles of ``scene`` met by the segments ``points -+ half normals``, both ways.

    Two Embree segment queries along each (unit or zero) normal, one from
    each end: the triangles near each point across the surface. -1 where none
    (or a zero normal).
    """
    found = []
    usable = np.flatnonzero(np.einsum("ij,ij->i", normals, normals) > 0.5)
    for sign in (1.0, -1.0):
        tri = np.full(len(points), -1, dtype=np.int64)
        if len(usable):
            n = sign * normals[usable]
            _, hit = scene.first_hit(points[usable] - half * n, n, max_distance=2.0 * half)
            tri[usable] = hit
        found.append(tri)
    return found


def _nearest_met(scene: Scene, candidates: list[np.ndarray], o: np.ndarray, d: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Per ray, the smallest float64 distance to a candidate triangle it meets (inf: none),
    and the cosine of the incidence there (1 where none)."""
    best = np.full(len(o), np.inf)
    best_cos = np.ones(len(o))
    for tri in candidates:
        t, meets, cos = _meet64(scene, tri, o, d)
        closer = meets & (t < best)
        best = np.where(closer, t, best)
        best_cos = np.where(closer, cos, best_cos)
    return best, best_cos


def _float64_error(scene: Scene, o: np.ndarray, t: np.ndarray, cos: np.ndarray) -> np.ndarray:
    """Bound on the float64 error of a Moller-Trumbore distance (0 for a miss, t = inf).

    ``FLOAT32_ERROR_FACTOR`` x 2^-53 x (|o - centre| + t + 2 diagonal) / cos, the
    float32 bound's form at float64's unit roundoff: 5e-12 of the diagonal at
    cos 1e-3, far under the default eps, but what keeps a ray meeting the
    original and a coincident occluder from counting with ``eps=0``.
    """
    finite = np.isfinite(t)
    centre = 0.5 * scene.bounds[0] + 0.5 * scene.bounds[1]
    size = np.linalg.norm(o - centre, axis=1) + np.where(finite, t, 0.0) + 2.0 * scene.diagonal
    with np.errstate(divide="ignore"):
        err = FLOAT32_ERROR_FACTOR * _FLOAT64_UNIT * size / cos
    return np.where(finite, err, 0.0)


def _judge_float64(original: Scene, other: Scene, o: np.ndarray, d: np.ndarray,
                   tri_orig: np.ndarray, tri_occ: np.ndarray, t_occ32: np.ndarray,
                   half: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Float64 ``(t_original, t_occluder, error)`` of rays that hit the occluder.

    The occluder: the smallest float64 distance to the triangle Embree hit or
    to the occluder's triangles probed through the ray's crossing of its
    plane, else that plane's distance (else the float32 one, for a ray in the
    plane). The original: the smallest float64 distance to the triangle
    Embree hit or to those probed through the occluder's float64 point; inf
    when the ray meets none of them. ``error``: the float64 error bound of both
    distances (:func:`_float64_error`; 0 where a distance is not float64).
    """
    t_plane, _, cos_plane = _meet64(other, tri_occ, o, d)
    in_plane = ~np.isfinite(t_plane)
    t_plane = np.where(in_plane, t_occ32, t_plane)
    normal, _ = _unit_normals(other, tri_occ)
    near_occ = _probe(other, o + t_plane[:, None] * d, normal, half)
    t_occ, cos_occ = _nearest_met(other, [tri_occ, *near_occ], o, d)
    fallback = ~np.isfinite(t_occ)
    t_occ = np.where(fallback, t_plane, t_occ)
    cos_occ = np.where(fallback, cos_plane, cos_occ)
    near_orig = _probe(original, o + t_occ[:, None] * d, normal, half)
    t_orig, cos_orig = _nearest_met(original, [tri_orig, *near_orig], o, d)
    err = (_float64_error(original, o, t_orig, cos_orig)
           + np.where(in_plane & fallback, 0.0, _float64_error(other, o, t_occ, cos_occ)))
    return t_orig, t_occ, err


def _violating_rays(original: Scene, other: Scene, o: np.ndarray, d: np.ndarray, eps: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """Violating rays of a batch: ``(index, gap, t_original, t_occluder, cleared)``.

    ``index`` of the violating rays, their ``gap`` (t_original - t_occluder,
    > eps), both distances (float64 where judged again) and the number of
    float32 candidates the float64 judgement dropped (module docstring).
    """
    t_orig, tri_orig = original.first_hit(o, d)
    t_occ, tri_occ = other.first_hit(o, d)
    with np.errstate(invalid="ignore"):  # both miss: inf - inf = nan, not a violation
        gap = t_orig - t_occ  # occluder hit, original missed: inf, a violation
    flagged = np.flatnonzero(gap > eps)
    if len(flagged) == 0:
        return flagged, gap[flagged], t_orig[flagged], t_occ[flagged], 0
    of, df = o[flagged], d[flagged]
    t_orig_f, t_occ_f, gap_f = t_orig[flagged], t_occ[flagged], gap[flagged]
    tri_orig_f, tri_occ_f = tri_orig[flagged], tri_occ[flagged]
    half = max(eps, _PROBE_RELATIVE * original.diagonal)
    margin = np.zeros(len(flagged))  # the float64 error allowed on top of eps
    unsure = np.zeros(len(flagged), dtype=bool)
    hit = np.flatnonzero(tri_orig_f >= 0)
    if len(hit):  # beyond eps by more than float32 can err: a violation as it stands
        err = (_float32_error(original, of[hit], df[hit], t_orig_f[hit], tri_orig_f[hit])
               + _float32_error(other, of[hit], df[hit], t_occ_f[hit], tri_occ_f[hit]))
        unsure[hit] = ~(gap_f[hit] - eps > err)
    missed = np.flatnonzero(tri_orig_f < 0)
    if len(missed):  # the original missed: judged again only if it is near the occluder
        normal, _ = _unit_normals(other, tri_occ_f[missed])
        near = _probe(original, of[missed] + t_occ_f[missed, None] * df[missed], normal, half)
        unsure[missed] = (near[0] >= 0) | (near[1] >= 0)
    if unsure.any():
        t_orig_f[unsure], t_occ_f[unsure], margin[unsure] = _judge_float64(
            original, other, of[unsure], df[unsure], tri_orig_f[unsure], tri_occ_f[unsure],
            t_occ_f[unsure], half)
        with np.errstate(invalid="ignore"):
            gap_f[unsure] = t_orig_f[unsure] - t_occ_f[unsure]
    bad = gap_f > eps + margin
    return flagged[bad], gap_f[bad], t_orig_f[bad], t_occ_f[bad], int((~bad).sum())


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
    cleared : int
        Rays whose float32 hit distances differ by more than ``eps`` but that
        the float64 judgement of the module docstring found within ``eps``
        (grazing incidence): counted in neither ``violations`` nor ``worst``.
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
    cleared: int = 0

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
        Tolerance along the ray in world units, >= 0, on float64 distances
        (module docstring, "Tolerance"); default 1e-5 x bounding-box diagonal.
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
    Deterministic given ``seed``. A ray whose Embree (float32) distances put
    the occluder more than ``eps`` first is judged again in float64 unless
    float32's error cannot explain the gap (module docstring); the rays it
    clears are counted in ``cleared``.

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
    eps = CONSERVATIVE_EPS_RELATIVE * original.diagonal if eps is None else eps  # type: ignore[union-attr]
    if frame is None:
        frame = orbit_frame(mesh) if domain == "orbit" else evaluation_box(mesh)[:2]
    rng = np.random.default_rng(seed)
    violations = 0
    cleared = 0
    worst: list[tuple] = []  # (-gap, ray index, description), best first
    for first in range(0, rays if other is not None else 0, _RAYS_PER_BATCH):
        n = min(_RAYS_PER_BATCH, rays - first)
        o, d = _domain_rays(domain, frame, original, n, rng)  # type: ignore[arg-type]
        bad, gap, t_orig, t_occ, dropped = _violating_rays(original, other, o, d, eps)  # type: ignore[arg-type]
        violations += len(bad)
        cleared += dropped
        for k in np.argsort(-gap, kind="stable")[:WORST_RAYS]:
            i = bad[k]
            worst.append((-gap[k], first + i, {
                "origin": o[i].tolist(), "direction": d[i].tolist(),
                "t_original": None if np.isinf(t_orig[k]) else float(t_orig[k]),
                "t_occluder": float(t_occ[k])}))
        worst = sorted(worst, key=lambda w: w[:2])[:WORST_RAYS]
    return ConservativenessReport(
        rays=rays, violations=violations, violation_rate=violations / rays,
        violation_upper_bound=clopper_pearson_upper(violations, rays, confidence),
        confidence=confidence, domain=domain, worst=[w[2] for w in worst],
        eps=eps, seed=seed, seconds=time.perf_counter() - start, cleared=cleared)


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
