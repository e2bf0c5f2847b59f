"""planar-sections: double-sided planar sections of the voxelized solid, chosen by
occlusion measure (Silvennoinen et al. 2014, sec. 4; the precision floor is ours)."""

from .generator import generate_planar_sections, screen_space_voxel_size

__all__ = ["generate_planar_sections", "screen_space_voxel_size"]
