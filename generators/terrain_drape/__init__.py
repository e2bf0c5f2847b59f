"""Terrain drape: a few triangles just under an open height field (terrain, floors, streets)."""

from .generator import generate_terrain_drape

__all__ = ["generate_terrain_drape"]
