"""Orbit precision/recall: orthographic views from uniform directions around the mesh.

Silvennoinen et al. 2014, sec. 6.1 [1]_, with its settings fixed.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
"""

from __future__ import annotations

import trimesh

from viscore._validate import as_positive_int

# kept for old import paths: the orbit frame lives in .frames, below ReferenceViews
from .frames import EXTENT_FACTOR, orbit_frame
from .precision_recall import PrecisionRecall
from .reference_views import ReferenceViews, score_once

__all__ = ["orbit_precision_recall", "orbit_frame", "EXTENT_FACTOR"]


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
        N, view directions uniform on the sphere (default 256, Silvennoinen et al. 2014, Fig. 11).
    quads : int, optional
        Q, quads per view (default 32,000, Silvennoinen et al. 2014, sec. 6.1).
    resolution : int, optional
        R, pixels per image side (default 256).
    seed : int, optional
        Seeds the directions and, per view, the quads. Default 0.
    depth_aware : bool, optional
        Classify by depth (the depth-aware variant) instead of coverage.
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

    See Also
    --------
    ReferenceViews : the original's views built once, to score many occluders.

    Notes
    -----
    Views where the original covers no pixel get no quads and contribute
    zeros. Deterministic given ``seed``: view k's quads come from the k-th
    child of ``SeedSequence(seed)``, so the first views of a run with more
    views are the same views. Equivalent to
    ``ReferenceViews(mesh, views=..., ...).score(occluder)``, with
    ``seconds`` and ``timing`` covering both steps.

    References
    ----------
    .. [1] A. Silvennoinen, H. Saransaari, S. Laine, J. Lehtinen, "Occluder
       simplification using planar sections", Computer Graphics Forum 33(1),
       2014, sec. 6.1. :DOI:`10.1111/cgf.12271`

    Examples
    --------
    >>> box = trimesh.creation.box()
    >>> r = orbit_precision_recall(box, box, views=4, quads=100, resolution=32)
    >>> float(r.precision), float(r.recall)
    (1.0, 1.0)
    """
    views = as_positive_int(views, "views")
    return score_once(ReferenceViews(mesh, views=views, quads=quads, resolution=resolution,
                                     seed=seed, depth_aware=depth_aware,
                                     depth_levels=depth_levels, cache=False), occluder)
