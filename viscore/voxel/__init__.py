"""Voxels: surface, outside and inner voxels, winding numbers, wall thickness, coverage hulls."""

from .grid import (
    VoxelGrid,
    Voxelization,
    inner_voxels_six_direction,
    inside_voxels_parity,
    inside_voxels_winding,
    outside_voxels,
    points_inside_parity,
    surface_voxels,
    voxel_boundary_mesh,
    voxel_grid,
    voxelize,
)
from .wall_thickness import WallThickness, wall_thickness, wall_voxel_size
from .winding import is_closed_oriented, points_inside, winding_numbers

__all__ = ["VoxelGrid", "Voxelization", "voxel_grid", "voxelize", "surface_voxels",
           "outside_voxels", "inner_voxels_six_direction", "inside_voxels_parity",
           "inside_voxels_winding", "points_inside_parity", "voxel_boundary_mesh",
           "points_inside", "winding_numbers", "is_closed_oriented", "WallThickness",
           "wall_thickness", "wall_voxel_size"]
