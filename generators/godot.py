"""The old path of the ``godot`` baseline, kept so that its imports keep working.

The bake lives in :mod:`viscore.generators.baselines.godot`.
"""

from .baselines.godot import bake_surface, generate_godot

__all__ = ["generate_godot", "bake_surface"]
