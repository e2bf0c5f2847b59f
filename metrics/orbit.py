"""Orbit precision/recall: orthographic views from uniform directions around the mesh.

Silvennoinen et al. 2014, sec. 6.1 (seeds/000), as fixed by DESIGN.md: N view
directions uniform on the sphere; orthographic; the image plane through the
centre of the original's smallest enclosing sphere; square extent = its
diameter x 1.01; R x R pixels, one ray per pixel centre; Q random quads per
view inside the screen bounding box of the original's covered pixels.
"""

from __future__ import annotations

import time

import numpy as np
import trimesh

from viscore import OrthoCamera, directions_uniform
from viscore._validate import as_positive_int
from viscore.enclosing_ball import minimum_enclosing_ball

from ._views import depths, scene_of
from .bootstrap import bootstrap_ratio
from .precision_recall import PrecisionRecall, ratio
from .quads import QuadCounts, classify_quads, classify_quads_depth, sample_quads

__all__ = ["orbit_precision_recall", "orbit_frame", "view_counts"]

#: Extent of the orthographic window as a multiple of the enclosing sphere's
#: diameter (DESIGN.md, orbit protocol).
EXTENT_FACTOR = 1.01

#: Views cast in one Embree batch.
_VIEWS_PER_BATCH = 8


def orbit_frame(mesh: trimesh.Trimesh) -> tuple[np.ndarray, float]:
    """Centre and window extent of the orbit protocol for an original mesh.

    Returns
    -------
    center : (3,) float64
        Centre of the smallest enclosing sphere of the vertices (flat and
        collinear meshes included, see :func:`viscore.enclosing_ball.minimum_enclosing_ball`).
    extent : float
        Its diameter x 1.01, world units.
    """
    center, radius = minimum_enclosing_ball(mesh.vertices)
    return center, float(2 * radius * EXTENT_FACTOR)


def view_counts(d_orig: np.ndarray, d_occ: np.ndarray, quads: int, rng: np.random.Generator, *,
                depth_aware: bool = False, depth_levels: int = 32) -> QuadCounts:
    """Nt, Pf, Nf of one orbit view from its two depth images (inf where empty).

    The quads lie in the screen bounding box of the original's covered
    pixels (seed 000, sec. 6.1); a view where the original covers nothing
    gets no quads and zero counts.
    """
    covered = np.isfinite(d_orig)
    rows = np.flatnonzero(covered.any(axis=1))
    if len(rows) == 0:
        return QuadCounts(0, 0, 0, 0)
    cols = np.flatnonzero(covered.any(axis=0))
    box = (rows[0], cols[0], rows[-1] + 1, cols[-1] + 1)
    q = sample_quads(box, quads, rng)
    if depth_aware:
        return classify_quads_depth(d_orig, d_occ, q, rng, depth_levels=depth_levels)
    return classify_quads(covered, np.isfinite(d_occ), q)


def orbit_precision_recall(mesh: trimesh.Trimesh, occluder: trimesh.Trimesh | None, *,
                           views: int = 256, quads: int = 32000, resolution: int = 256,
                           seed: int = 0, depth_aware: bool = False,
                           depth_levels: int = 32) -> PrecisionRecall:
    """Precision and recall of an occluder over orthographic views around the mesh.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The original.
    occluder : trimesh.Trimesh or None
        The occluder; None or an empty mesh covers nothing.
    views : int, optional
        N, view directions uniform on the sphere (default 256, seed 000 Fig. 11).
    quads : int, optional
        Q, quads per view (default 32,000, seed 000 sec. 6.1).
    resolution : int, optional
        R, pixels per image side (default 256).
    seed : int, optional
        Seeds the directions and, per view, the quads. Default 0.
    depth_aware : bool, optional
        Classify by depth (DESIGN.md's depth-aware variant) instead of coverage.
    depth_levels : int, optional
        Quad depth values of the depth-aware variant (default 32).

    Returns
    -------
    PrecisionRecall
        Pooled over views: P = sum Nt / (sum Nt + sum Nf), R = sum Nt / (sum Nt + sum Pf).

    Raises
    ------
    InputError
        On a non-positive count or resolution, or an empty original.

    Notes
    -----
    Views where the original covers no pixel get no quads and contribute
    zeros. Deterministic given ``seed``: view k's quads come from the k-th
    child of ``SeedSequence(seed)``, so the first views of a run with more
    views are the same views.

    Examples
    --------
    >>> box = trimesh.creation.box()
    >>> r = orbit_precision_recall(box, box, views=4, quads=100, resolution=32)
    >>> float(r.precision), float(r.recall)
    (1.0, 1.0)
    """
    views = as_positive_int(views, "views")
    quads = as_positive_int(quads, "quads")
    resolution = as_positive_int(resolution, "resolution", maximum=8192)
    start = time.perf_counter()
    original = scene_of(mesh, "mesh")
    other = scene_of(occluder, "occluder")
    center, extent = orbit_frame(mesh)
    directions = directions_uniform(views, seed=seed)
    children = np.random.SeedSequence(seed).spawn(views)
    nt = np.zeros(views, dtype=np.int64)
    pf = np.zeros(views, dtype=np.int64)
    nf = np.zeros(views, dtype=np.int64)
    qcount = np.zeros((views, 3), dtype=np.int64)  # q_orig, q_occ, q_both
    timing: dict = {}
    t_quads = 0.0
    for b0 in range(0, views, _VIEWS_PER_BATCH):
        ks = range(b0, min(views, b0 + _VIEWS_PER_BATCH))
        cams = [OrthoCamera(directions[k], center, extent, resolution) for k in ks]
        d_orig = depths(original, cams, timing)
        d_occ = depths(other, cams, timing)
        t0 = time.perf_counter()
        for j, k in enumerate(ks):
            rng = np.random.default_rng(children[k])
            c = view_counts(d_orig[j], d_occ[j], quads, rng, depth_aware=depth_aware,
                            depth_levels=depth_levels)
            nt[k], pf[k], nf[k] = c.nt, c.pf, c.nf
            qcount[k] = c.q_orig, c.q_occ, c.q_both
        t_quads += time.perf_counter() - t0
    timing["seconds_quads"] = t_quads
    per_view = {
        "nt": nt, "pf": pf, "nf": nf,
        "precision": ratio(nt, nt + nf), "recall": ratio(nt, nt + pf),
        "weight": np.ones(views), "direction": directions,
        "quads_orig": qcount[:, 0], "quads_occ": qcount[:, 1], "quads_both": qcount[:, 2],
    }
    return PrecisionRecall(
        precision=float(ratio(nt.sum(), nt.sum() + nf.sum())),
        recall=float(ratio(nt.sum(), nt.sum() + pf.sum())),
        precision_ci=list(bootstrap_ratio(nt, nt + nf, seed=seed)),
        recall_ci=list(bootstrap_ratio(nt, nt + pf, seed=seed)),
        per_view=per_view, protocol="orbit", depth_aware=bool(depth_aware), seed=seed,
        params={"views": views, "quads": quads, "resolution": resolution,
                "center": center.tolist(), "extent": extent,
                **({"depth_levels": depth_levels} if depth_aware else {})},
        seconds=time.perf_counter() - start, timing=timing)
