"""aabb-skins: axis-aligned boxes inside the mesh (Leone et al. 2012, the occluder-skins
paper, sec. 4; Naaji's box-filling note)."""

from .generator import boxes_mesh, generate_aabb_skins

__all__ = ["generate_aabb_skins", "boxes_mesh"]
