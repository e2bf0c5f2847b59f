"""Baselines: quadric edge-collapse decimation (Garland and Heckbert 1997), the bounding
box, the original mesh, and Godot 4's occluder bake (meshoptimizer simplify)."""

from .generic import generate_bbox, generate_original, generate_qem
from .godot import generate_godot, godot_imported_surface

__all__ = ["generate_qem", "generate_bbox", "generate_original", "generate_godot",
           "godot_imported_surface"]
