"""generators: occluder generators, one module per method, plus baselines.

Every generator is ``generate(mesh, **params) -> Occluder`` and is registered
by its CLI name in :data:`REGISTRY` (DESIGN.md, "Generators").
"""

from .aabb_skins import boxes_mesh, generate_aabb_skins
from .baselines import generate_bbox, generate_original, generate_qem
from .occluder import Occluder
from .registry import REGISTRY, GeneratorSpec, generate, get_generator

__all__ = ["Occluder", "REGISTRY", "GeneratorSpec", "generate", "get_generator",
           "generate_aabb_skins", "boxes_mesh", "generate_qem", "generate_bbox",
           "generate_original"]
