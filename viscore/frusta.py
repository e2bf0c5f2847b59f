"""Shadow-frustum occlusion culling with convex solid and planar occluders (the old path).

Kept for old import paths: the frusta and their box tests are in
:mod:`viscore.shadow_frusta`, the per-frame runtime
(:class:`~viscore.frustum_culler.FrustumCuller`) in :mod:`viscore.frustum_culler`;
``from viscore.frusta import ...`` keeps working for every name it exported.
"""

from .frustum_culler import ACTIVE_OCCLUDERS, FrustumCuller

# kept for old import paths
from .shadow_frusta import (
    MARGIN_RELATIVE,
    SHAPE_TOLERANCE,
    Frustum,
    boxes_in_frusta,
    boxes_in_frustum,
    polygon_frustum,
    rank_planar,
    rank_solids,
    solid_faces_as_polygons,
    solid_frustum,
)

__all__ = ["Frustum", "solid_frustum", "polygon_frustum", "boxes_in_frustum",
           "boxes_in_frusta", "rank_solids", "rank_planar", "FrustumCuller",
           "solid_faces_as_polygons", "ACTIVE_OCCLUDERS", "MARGIN_RELATIVE",
           "SHAPE_TOLERANCE"]
