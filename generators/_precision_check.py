"""The precision check that generators run on orbit views of the mesh before they keep an occluder.
"""

from __future__ import annotations

import numpy as np
import trimesh

from viscore._content_cache import ContentCache

__all__ = ["CHECK_VIEWS", "CHECK_SEED_OFFSET", "CHECK_Z", "DEFAULT_MIN_PRECISION", "ratio_se",
           "check_views", "check_score", "passes"]

#: The precision floor generators keep by default (planar sections, the terrain drape).
DEFAULT_MIN_PRECISION = 0.995

#: Orbit views of the check (the metric's own resolution and quads).
CHECK_VIEWS = 64
#: Added to the generator's seed for the check views.
CHECK_SEED_OFFSET = 7919
#: One-sided 95% normal quantile of the check's lower bound.
CHECK_Z = 1.645

#: The check views of the last meshes checked in this process.
_CHECK_VIEWS = ContentCache(2)


def ratio_se(num: np.ndarray, den: np.ndarray) -> float:
    """Standard error of sum(num) / sum(den) with the views as units (the ratio estimator's
    linearization); 0 with fewer than two views."""
    k = len(num)
    if k < 2 or den.sum() <= 0:
        return 0.0
    ratio = num.sum() / den.sum()
    return float(np.sqrt(np.sum((num - ratio * den) ** 2) / (k * (k - 1))) / den.mean())


def check_views(mesh: trimesh.Trimesh, seed: int, views: int = CHECK_VIEWS):
    """The original's check views (:class:`viscore.metrics.ReferenceViews`, orbit), cast once
    per mesh (by its vertices and faces), seed and view count in a process: the budgets of
    one mesh check their occluders on the same views (scoring leaves them as they are)."""
    from viscore.metrics.reference_views import ReferenceViews

    return _CHECK_VIEWS.get(
        (np.asarray(mesh.vertices), np.asarray(mesh.faces), int(seed), int(views)),
        lambda: ReferenceViews(mesh, protocol="orbit", views=views,
                               seed=seed + CHECK_SEED_OFFSET))


def check_score(views, occluder: trimesh.Trimesh) -> dict:
    """``precision``, ``precision_se`` and ``recall`` of ``occluder`` on the check views
    (1, 0, 0 for an empty occluder: nothing to over-occlude with)."""
    if len(occluder.faces) == 0:
        return {"precision": 1.0, "precision_se": 0.0, "recall": 0.0}
    pr = views.score(occluder)
    return {"precision": float(pr.precision),
            "precision_se": ratio_se(*pr.ratio_parts("precision")),
            "recall": float(pr.recall)}


def passes(score: dict, floor: float) -> bool:
    """The check's rule: ``precision - CHECK_Z precision_se >= floor``."""
    return score["precision"] - CHECK_Z * score["precision_se"] >= floor
