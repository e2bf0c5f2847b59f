"""Culling runtimes: shadow frusta and their per-frame culler, the conservative depth buffer,
occludee bounds."""

from .depth_buffer import DEFAULT_REDUCTION, ConservativeDepthBuffer, OccluderScene
from .frustum_culler import ACTIVE_OCCLUDERS, FrustumCuller
from .occludee_bounds import (
    AUTO_MIN_SIZE,
    DEFAULT_BOUNDS,
    DEFAULT_CLUSTERS,
    MAX_CLUSTERS,
    MESHLET_TRIANGLES,
    cluster_boxes,
    object_cluster_boxes,
    occludee_boxes,
    parse_bounds,
)
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

__all__ = ["ConservativeDepthBuffer", "OccluderScene", "DEFAULT_REDUCTION", "FrustumCuller",
           "Frustum", "solid_frustum", "polygon_frustum", "boxes_in_frustum", "boxes_in_frusta",
           "rank_solids", "rank_planar", "solid_faces_as_polygons", "cluster_boxes",
           "object_cluster_boxes", "occludee_boxes", "DEFAULT_CLUSTERS", "MAX_CLUSTERS",
           "AUTO_MIN_SIZE", "ACTIVE_OCCLUDERS", "MARGIN_RELATIVE", "SHAPE_TOLERANCE",
           "DEFAULT_BOUNDS", "MESHLET_TRIANGLES", "parse_bounds"]
