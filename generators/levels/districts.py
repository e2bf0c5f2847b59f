"""A large level's joined occluder made district by district: the ground cut into a grid of
squares, each square's planar pieces generated together with its share of the budget.

The selection by occlusion measure (Silvennoinen et al. 2014 [1]_, sec. 3 and sec. 4.5)
spends the budget on the candidates of most measure per triangle, and the measure
grows faster than a shape's area. Over a whole level one part can hold the town and its
ground (sauer-tatooine: 58,443 of 67,022 triangles, 2 km across): the ground's large
sheets and the roofs take the budget first, and the occluder lacks the street walls a
player sees. Cut into districts, the candidates of a district compete only with each
other, for a share of the budget that grows with its triangles (:func:`district_budgets`);
the town's districts, where most of the triangles are, get most of it, and their walls
with it. Each district is measured in its own orbit frame.

The share goes with the square root of a district's triangles, not with their number:
measured on ten Sauerbraten and Red Eclipse maps (docs/culling.md), shares by the number
took budget from the plain rooms of indoor maps (whose few large walls the whole level's
selection takes first: sauer-depot 0.72 to 0.64 of the hidden share culled), equal shares
starved the detailed ones (redeclipse-institute 0.89 to 0.78); the square root kept both
within 0.04 and gave sauer-tatooine the same 0.55 as shares by the number.

A district holds whole *pieces*: the faces joined across shared edges within one
plane region (:func:`generators._plane_regions.plane_regions`), so that a floor of two
triangles is never cut into two faces alone in their planes (which the generators
read as curved and skip). A piece goes to the square of its area-weighted centre, a
face of a curved surface (a piece of its own) to that of its own centre.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["district_labels", "district_budgets", "DISTRICT_TRIANGLES", "MAX_DISTRICTS"]

#: Triangles per district asked of a joined occluder's input: a level of fewer than four
#: times this is made whole, as before.
DISTRICT_TRIANGLES = 1000

#: Most districts along each side of the ground.
MAX_DISTRICTS = 8

#: Coplanarity tolerance of the pieces, fraction of the input's diagonal (that of
#: surface-patches' regions, ``PLANE_TOLERANCE``).
_PLANE_TOLERANCE = 1e-7


def _pieces(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(f,) int64: per face, its piece (faces of one plane region joined across shared
    edges; a face in no region, or alone, is a piece of its own)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    from .._plane_regions import plane_regions

    n = len(faces)
    diag = float(np.linalg.norm(np.ptp(vertices, axis=0))) if len(vertices) else 0.0
    region = np.full(n, -1, dtype=np.int64)
    for k, r in enumerate(plane_regions(vertices, faces, tolerance=_PLANE_TOLERANCE * diag)):
        region[r.faces] = k
    _, merged = np.unique(vertices, axis=0, return_inverse=True)
    fm = merged.reshape(-1)[faces]
    edges = np.sort(fm[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    face = np.repeat(np.arange(n), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, face = edges[order], face[order]
    same = (edges[1:] == edges[:-1]).all(axis=1)
    a, b = face[:-1][same], face[1:][same]
    keep = (region[a] == region[b]) & (region[a] >= 0)
    graph = sp.coo_matrix((np.ones(int(keep.sum())), (a[keep], b[keep])), shape=(n, n))
    return connected_components(graph, directed=False)[1].astype(np.int64)


def district_labels(vertices: np.ndarray, faces: np.ndarray, up: np.ndarray
                    ) -> tuple[np.ndarray, int]:
    """Each face's district, and the number of districts along each side.

    Parameters
    ----------
    vertices : (v, 3) float
        World units.
    faces : (f, 3) int
    up : (3,) float
        The level's up direction (the ground's normal).

    Returns
    -------
    label : (f,) int64
        Per face, its district (``row * side + column`` of the ground grid over the
        pieces' centres); all 0 when the input is made whole.
    side : int
        Districts along each side: ``floor(sqrt(f / DISTRICT_TRIANGLES))``, at most
        :data:`MAX_DISTRICTS`; 1 below four times :data:`DISTRICT_TRIANGLES` faces.

    Notes
    -----
    Deterministic. A piece (module docstring) is never split between districts.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    side = min(MAX_DISTRICTS, int(math.isqrt(len(faces) // DISTRICT_TRIANGLES)))
    if side <= 1:
        return np.zeros(len(faces), dtype=np.int64), 1
    up = np.asarray(up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    axis_a = np.cross(up, np.eye(3)[int(np.argmin(np.abs(up)))])
    axis_a /= np.linalg.norm(axis_a)
    axis_b = np.cross(up, axis_a)
    tri = vertices[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    weight = area + 1e-300  # a degenerate face still has a centre
    centre = tri.mean(axis=1) @ np.stack([axis_a, axis_b], axis=1)  # (f, 2) on the ground
    piece = _pieces(vertices, faces)
    count = int(piece.max()) + 1
    sums = np.zeros((count, 2))
    np.add.at(sums, piece, centre * weight[:, None])
    at = sums / np.bincount(piece, weights=weight, minlength=count)[:, None]
    lo, hi = centre.min(axis=0), centre.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    cell = np.clip(np.floor((at - lo) / span * side).astype(np.int64), 0, side - 1)
    return (cell[:, 0] * side + cell[:, 1])[piece], side


def district_budgets(triangles: np.ndarray, budget: int) -> np.ndarray:
    """(d,) int64: ``budget`` shared by the districts in proportion to the square root of
    their ``triangles`` (module docstring), largest remainders first, so that the shares
    add up to ``budget`` exactly."""
    weight = np.sqrt(np.asarray(triangles, dtype=np.float64))
    exact = budget * weight / weight.sum()
    share = np.floor(exact).astype(np.int64)
    left = int(budget - share.sum())
    if left > 0:
        share[np.argsort(-(exact - share), kind="stable")[:left]] += 1
    return share
