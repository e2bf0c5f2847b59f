"""The ``Occluder`` type every generator returns (DESIGN.md, "Generators")."""

from __future__ import annotations

from dataclasses import dataclass, field

import trimesh

__all__ = ["Occluder"]


@dataclass(frozen=True, eq=False)
class Occluder:
    """An occluder mesh with the method, parameters and parts that made it.

    Attributes
    ----------
    mesh : trimesh.Trimesh
        The occluder; may be empty (no faces) when a method finds nothing.
    method : str
        Registry name of the generator.
    params : dict
        The parameters the generator used, defaults filled in.
    double_sided : bool
        True when the occluder must be drawn without back-face culling
        (open polygons, planar sections); False for closed solids.
    seconds : float
        Wall time of the generation.
    parts : dict
        The method's own parts, e.g. ``boxes`` as ``(k, 2, 3) float64``
        lower/upper corners (convex solids usable by a shadow-frustum runtime).
    info : dict
        Method-specific figures (e.g. ``inside`` classification used, ``fill``).
    """

    mesh: trimesh.Trimesh
    method: str
    params: dict
    double_sided: bool
    seconds: float
    parts: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)

    @property
    def triangles(self) -> int:
        """Triangle count of the occluder mesh."""
        return len(self.mesh.faces)

    def summary(self) -> dict:
        """JSON-ready description: method, params, triangles, seconds, info."""
        return {"method": self.method, "params": self.params, "triangles": self.triangles,
                "double_sided": self.double_sided, "seconds": self.seconds, **self.info}
