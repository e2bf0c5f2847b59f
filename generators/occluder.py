"""The ``Occluder`` type every generator returns, and the schema of its ``parts``.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification Using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (polygons, sec. 4; the
   occluder hierarchy, sec. 5)
.. [2] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006 (convex solid occluders)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import trimesh

__all__ = ["Occluder", "check_parts", "PART_KEYS"]

#: The keys of ``Occluder.parts`` with a documented schema.
PART_KEYS = ("boxes", "polygons", "solids", "hierarchy")


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
        The method's own geometry, by the schema of this module's docstring:
        ``boxes`` (k, 2, 3) float64, ``polygons`` list of (m_i, 3) float64,
        ``solids`` list of ((v, 3) float64, (f, 3) int64), ``hierarchy`` a
        tree of nodes; world units. Any key may be absent.
    info : dict
        Method-specific figures (e.g. ``inside`` classification used, ``fill``);
        ``over_budget`` (bool) whenever a budget was given to
        :func:`viscore.generators.generate`.
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


def _corners(value, what: str, shape: tuple) -> np.ndarray:
    arr = np.asarray(value)
    if arr.ndim != len(shape) or any(
            s is not None and a != s for a, s in zip(arr.shape, shape, strict=True)):
        want = "(" + ", ".join("k" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"parts[{what}]: expected shape {want}, got {arr.shape}")
    if not np.issubdtype(arr.dtype, np.floating) or not np.isfinite(arr).all():
        raise ValueError(f"parts[{what}]: expected finite floats, got {arr.dtype}")
    if (arr[..., 0, :] > arr[..., 1, :]).any():
        raise ValueError(f"parts[{what}]: a lower corner exceeds its upper corner")
    return arr


def _check_node(node, where: str, parent: np.ndarray | None, depth: int) -> int:
    if depth > 64:
        raise ValueError(f"parts[{where}]: deeper than 64 levels (a cycle?)")
    if not isinstance(node, dict) or not {"bounds", "occluder", "children"} <= set(node):
        raise ValueError(f"parts[{where}]: expected a dict with bounds, occluder, children")
    bounds = _corners(node["bounds"], f"{where}.bounds", (2, 3))
    if parent is not None:
        slack = 1e-9 * max(1.0, float(np.abs(parent).max()))
        if (bounds[0] < parent[0] - slack).any() or (bounds[1] > parent[1] + slack).any():
            raise ValueError(f"parts[{where}]: bounds leave the parent's bounds")
    if not isinstance(node["occluder"], trimesh.Trimesh):
        raise ValueError(f"parts[{where}].occluder: expected a trimesh.Trimesh")
    count = 1
    for i, child in enumerate(node["children"]):
        count += _check_node(child, f"{where}.children[{i}]", bounds, depth + 1)
    return count


def check_parts(parts: dict) -> dict:
    """Check ``Occluder.parts`` against the schema; returns the keys found and their sizes.

    Parameters
    ----------
    parts : dict
        An occluder's parts. Keys outside :data:`PART_KEYS` are allowed and
        not checked.

    Returns
    -------
    dict
        For each schema key present, the number of boxes, polygons, solids
        or hierarchy nodes.

    Raises
    ------
    ValueError
        Naming the key and what is wrong (shape, dtype, non-finite values,
        inverted corners, a polygon under 3 vertices, a face index out of
        range, a child outside its parent). A generator producing such parts
        has a bug: this is not an :class:`~viscore.InputError`.

    Examples
    --------
    >>> import numpy as np
    >>> check_parts({"boxes": np.array([[[0.0, 0, 0], [1, 1, 1]]])})
    {'boxes': 1}
    """
    found = {}
    if "boxes" in parts:
        found["boxes"] = len(_corners(parts["boxes"], "boxes", (None, 2, 3)))
    if "polygons" in parts:
        for i, loop in enumerate(parts["polygons"]):
            arr = np.asarray(loop)
            if arr.ndim != 2 or arr.shape[1] != 3 or len(arr) < 3:
                raise ValueError(f"parts[polygons][{i}]: expected (m >= 3, 3), got {arr.shape}")
            if not np.issubdtype(arr.dtype, np.floating) or not np.isfinite(arr).all():
                raise ValueError(f"parts[polygons][{i}]: expected finite floats")
        found["polygons"] = len(parts["polygons"])
    if "solids" in parts:
        for i, solid in enumerate(parts["solids"]):
            vertices, faces = (np.asarray(a) for a in solid)
            if vertices.ndim != 2 or vertices.shape[1] != 3 or not np.isfinite(vertices).all():
                raise ValueError(f"parts[solids][{i}]: vertices must be finite (v, 3)")
            if faces.ndim != 2 or faces.shape[1] != 3 or not np.issubdtype(faces.dtype, np.integer):
                raise ValueError(f"parts[solids][{i}]: faces must be (f, 3) integers")
            if len(faces) and (faces.min() < 0 or faces.max() >= len(vertices)):
                raise ValueError(f"parts[solids][{i}]: a face indexes a missing vertex")
        found["solids"] = len(parts["solids"])
    if "hierarchy" in parts:
        found["hierarchy"] = _check_node(parts["hierarchy"], "hierarchy", None, 0)
    return found
