"""Volume precision/recall: six 90-degree frusta from view positions filling the space.

The 3D-domain protocol of Wu et al. 2022, sec. 3.2, eqs. 4-7, with the
accelerations of its sec. 3.3.

References
----------
.. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
"""

from __future__ import annotations

import trimesh

# kept for old import paths: the volume protocol's geometry lives in .frames, below
# ReferenceViews
from .frames import (
    MAX_GRID_POSITIONS,
    SPACING_FRACTION,
    evaluation_box,
    frusta_see_box,
    volume_positions,
    volume_positions_bytes,
)
from .precision_recall import PrecisionRecall
from .reference_views import ReferenceViews, score_once

__all__ = ["volume_precision_recall", "volume_positions", "evaluation_box",
           "volume_positions_bytes", "frusta_see_box", "SPACING_FRACTION",
           "MAX_GRID_POSITIONS"]


def volume_precision_recall(mesh: trimesh.Trimesh, occluder: trimesh.Trimesh | None, *,
                            spacing: float | None = None, padding: float | None = None,
                            quads: int = 5000, resolution: int = 256, seed: int = 0,
                            depth_aware: bool = False, depth_levels: int = 32,
                            merge_views: bool = True, jitter: bool = False
                            ) -> PrecisionRecall:
    """Precision and recall of an occluder from positions filling the space around it.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The original.
    occluder : trimesh.Trimesh or None
        The occluder; None or empty covers nothing.
    spacing : float, optional
        dx, world units; default 4% of the bounding-box diagonal (Wu et al. 2022, sec. 4.1).
    padding : float, optional
        Bounding-box growth, world units; default its smallest side (Wu et al. 2022, sec. 4).
    quads : int, optional
        Q per frustum, default 5,000 (Wu et al. 2022, sec. 4.1).
    resolution : int, optional
        R, default 256.
    seed : int, optional
        Seeds the quads (one child seed per position). Default 0.
    depth_aware : bool, optional
        Classify by depth instead of coverage.
    depth_levels : int, optional
        Quad depth values of the depth-aware variant (default 32).
    merge_views : bool, optional
        Octree view merging with volume weights (default True): one seeded
        random grid position per merged block (see :func:`volume_positions`).
    jitter : bool, optional
        Shift the position grid by a seeded uniform offset of up to half a
        spacing per axis (default False: the grid is centred in the domain).

    Returns
    -------
    PrecisionRecall
        ``precision``, ``recall``: weighted means of P_x, R_x where defined;
        ``per_view`` holds each position's counts, weight and position.

    Notes
    -----
    The number of rays is about positions x 6 x R^2: at the defaults that is
    large (tens of thousands of positions); lower ``resolution`` or raise
    ``spacing`` for quick runs. The ray count is logged before casting.
    Equivalent to ``ReferenceViews(mesh, protocol='volume', ...).score(occluder)``,
    with ``seconds`` and ``timing`` covering both steps.

    See Also
    --------
    ReferenceViews : the original's views built once, to score many occluders.
    """
    return score_once(ReferenceViews(mesh, protocol="volume", spacing=spacing, padding=padding,
                                     quads=quads, resolution=resolution, seed=seed,
                                     depth_aware=depth_aware, depth_levels=depth_levels,
                                     merge_views=merge_views, jitter=jitter, cache=False),
                      occluder)
