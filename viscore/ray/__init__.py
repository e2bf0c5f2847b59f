"""Rays and cameras: the Embree scene, ray bundles, coverage and depth images, seeded samplers."""

from .cameras import OrthoCamera, PerspectiveCamera, camera_basis, cube_cameras
from .embree_scene import AllHits, Scene, cpu_cores, get_workers, set_workers
from .enclosing_ball import minimum_enclosing_ball
from .images import coverage_image, depth_image
from .render import ObjectImage, object_image, overlay, shade
from .samplers import (
    directions_fibonacci,
    directions_uniform,
    directions_uniform_batches,
    grid_positions,
    rays_between,
    stream_seed,
)

__all__ = ["Scene", "AllHits", "cpu_cores", "get_workers", "set_workers", "OrthoCamera",
           "PerspectiveCamera", "camera_basis", "cube_cameras", "coverage_image", "depth_image",
           "directions_fibonacci", "directions_uniform", "directions_uniform_batches",
           "grid_positions", "rays_between", "stream_seed", "minimum_enclosing_ball",
           "ObjectImage", "object_image", "shade", "overlay"]
