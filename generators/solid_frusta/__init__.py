"""solid-frusta: a few convex solids inside the mesh for shadow-frustum culling
(Papaioannou et al. 2006, sec. 2, whose solids were modelled by hand)."""

from .generator import generate_solid_frusta

__all__ = ["generate_solid_frusta"]
