"""Sheets of occluder triangles for the conservative depth buffer's sheet rule: a pixel
covered by the union of edge-connected triangles, whatever their shape.

A *sheet* is a connected set of two or more occluder triangles joined across the edges
that exactly two triangles share (vertices joined by exact coordinates): one connected
part of a mesh, closed or open, convex or not, of any number of triangles. The crease rule
of :mod:`viscore.culling._creases` asks its patches to be height fields (or two flats
meeting at an edge), so that their layers over a pixel never cross; the sheet rule asks
nothing of the shape and pays for it with the depths at the pixel's corners:

A buffer pixel whose four corner rays first hit triangles of one sheet ``S``, and whose
square (widened by the crease rule's slack) meets no *contour* edge of ``S`` (an edge
with one triangle of ``S`` or three or more, or a fold seen from the eye: both its
triangles on one side of the plane through the eye and the edge; but see the last
paragraph for one fold), is covered whole, at the largest of

- the distances at its corners to the triangles the corner rays first hit, and to those
  triangles again at every other corner whose ray passes through them;
- the distances at the ends of the part within the pixel of every crease of ``S`` (an
  edge of two triangles on either side of that plane) that meets it;
- for both triangles of each such crease, the distance at every corner of the pixel
  whose ray passes through the triangle.

Why that holds. Over the pixel's square, the projection of ``S`` from the eye is open
(a triangle's interior maps one-to-one, a crease's two triangles lie on either side of
its image, and the triangles around a vertex with only creases wind around its image)
and closed (``S`` is a finite union of closed triangles), so the part ``X`` of ``S`` in
the pixel's pyramid that holds the first hit of one corner maps onto the whole square:
every ray through the pixel meets ``S``, and first meets the occluders no farther than
it meets ``X`` (the contour argument of Appel 1967 [1]_, Markosian et al. 1997 [2]_,
sec. 2, on one sheet). ``X`` is cut by the triangles' edges into convex pieces, each a
triangle's part in the pyramid; on a plane the distance from the eye is convex, so its
largest value on a piece is at one of the piece's corners: a pixel corner inside the
triangle (a triangle with an edge in the pixel is one of a crease's two, and one without
covers the whole pixel and is then the first hit of the corner ``X`` was taken from), or
an end of an edge's part within the pixel (a crease's: every edge of ``S`` in the pixel
is one, or the pixel would be blocked). Each of them is among the distances above. No
one-to-one projection is needed: a sheet that folds over itself (a spiral ramp, a bump
on a terrain seen from low down) has several layers over the pixel, and the bound holds
for the one through the corner.

One fold may cross the pixel. A fold of ``S`` (an edge of two triangles of ``S`` both on
one side of the plane through the eye and the edge: a crest seen against the same sheet
behind it) does not block the pixel when it is the only one meeting it and its part
within the widened pixel runs from side to side (neither end of the edge inside): its
image, a straight chord, cuts the pixel's square into two convex parts, each holding a
pixel corner, whose ray first hits ``S``. The edges of ``S`` that could bound its
projection (contours) meet neither part, so each part lies wholly inside the
projection: every ray through the pixel meets ``S``. In each part, the part of ``S``
over it through that corner maps onto it, and the argument above bounds its distance,
now with the fold's two triangles and its ends counted as a crease's.

References
----------
.. [1] Appel, A. "The notion of quantitative invisibility and the machine rendering of
   solids". Proceedings of the ACM National Conference 1967, pp. 387-393.
   :DOI:`10.1145/800196.806007`
.. [2] Markosian, L., Kowalski, M. A., Trychin, S. J., Bourdev, L. D., Goldstein, D.,
   Hughes, J. F. "Real-Time Nonphotorealistic Rendering". SIGGRAPH 1997.
   :DOI:`10.1145/258734.258894`
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit_cached

__all__ = ["mesh_sheets", "corner_distance", "corner_triangle_depths", "INSIDE_TOLERANCE"]

#: A corner ray passes through a triangle when its barycentric coordinates are all at
#: least minus this (a corner on an edge, within rounding, counts as inside both
#: triangles: the larger distance is kept).
INSIDE_TOLERANCE = 1e-9

#: A corner ray within this (relative sine) of a triangle's plane gives no reliable
#: distance: the pixel is left open.
GRAZING = 1e-9


def mesh_sheets(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sheet of each triangle (-1: none) and the sheets' edges.

    Triangles are joined across the edges exactly two of them share (vertices joined
    by exact coordinates); each connected set of two or more is a sheet.

    Returns
    -------
    sheet : (n,) int64
    edges : (m, 6) int64
        Per edge of a sheet: its two vertices, the third vertex of each triangle on it
        (the second -1 for a contour edge of one triangle or of three or more, one row
        per triangle), then the sheet on either side (the second -1 for none), as the
        crease rule's edges (:func:`viscore.culling._creases.patch_frame`).

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> sheet, edges = mesh_sheets(v, [[0, 1, 2], [0, 3, 1], [0, 2, 3]])  # a box's corner
    >>> sheet.tolist(), int((edges[:, 3] >= 0).sum()), int((edges[:, 3] < 0).sum())
    ([0, 0, 0], 3, 3)
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    n = len(f)
    none = (np.full(n, -1, dtype=np.int64), np.zeros((0, 6), dtype=np.int64))
    if n < 2:
        return none
    _, vid = np.unique(v, axis=0, return_inverse=True)
    fid = vid.reshape(-1)[f]
    # every use of every edge: vertices, third vertex, merged ends, triangle
    e = np.concatenate([np.stack([f[:, a], f[:, b], f[:, c], fid[:, a], fid[:, b],
                                  np.arange(n)], axis=1)
                        for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1))])
    key = np.stack([np.minimum(e[:, 3], e[:, 4]), np.maximum(e[:, 3], e[:, 4])], axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    order = np.argsort(inverse, kind="stable")
    e, inverse = e[order], inverse[order]
    first = np.r_[True, inverse[1:] != inverse[:-1]]
    two = counts[inverse] == 2
    pos = np.flatnonzero(two & first)
    ta, tb = e[pos, 5], e[pos + 1, 5]
    joined = (ta != tb) & (e[pos, 3] != e[pos, 4])  # not a degenerate edge or triangle
    pos, ta, tb = pos[joined], ta[joined], tb[joined]
    graph = coo_matrix((np.ones(len(pos)), (ta, tb)), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    big = np.bincount(label)[label] >= 2
    sheet = np.full(n, -1, dtype=np.int64)
    if not big.any():
        return none
    sheet[big] = np.unique(label[big], return_inverse=True)[1].reshape(-1)
    g = sheet[e[:, 5]]
    inner = np.zeros(len(e), dtype=bool)
    inner[pos] = inner[pos + 1] = True
    rows = [np.stack([e[pos, 0], e[pos, 1], e[pos, 2], e[pos + 1, 2], g[pos], g[pos]],
                     axis=1),
            np.stack([e[:, 0], e[:, 1], e[:, 2], np.full(len(e), -1), g,
                      np.full(len(e), -1)], axis=1)[~inner & (g >= 0)]]
    return sheet, np.concatenate(rows).astype(np.int64)


@njit_cached()
def corner_distance(vert, a, b, c, eye, r, u, f, hx, hy, w, h, ii, jj):  # pragma: no cover
    """Distance from the eye along the ray through buffer corner (row ``ii``, column
    ``jj``) to triangle ``(a, b, c)`` (vertex indices into ``vert``) when the ray passes
    through it (barycentric coordinates within :data:`INSIDE_TOLERANCE`), -1 when it does
    not or meets its plane behind the eye, ``inf`` when it grazes the plane (within
    :data:`GRAZING`) inside the triangle's tolerance (the distance is not reliable)."""
    x = (jj / w - 0.5) * (2.0 * hx)
    y = (0.5 - ii / h) * (2.0 * hy)
    d0 = f[0] + x * r[0] + y * u[0]
    d1 = f[1] + x * r[1] + y * u[1]
    d2 = f[2] + x * r[2] + y * u[2]
    a0, a1, a2 = vert[a, 0] - eye[0], vert[a, 1] - eye[1], vert[a, 2] - eye[2]
    e10, e11, e12 = vert[b, 0] - vert[a, 0], vert[b, 1] - vert[a, 1], vert[b, 2] - vert[a, 2]
    e20, e21, e22 = vert[c, 0] - vert[a, 0], vert[c, 1] - vert[a, 1], vert[c, 2] - vert[a, 2]
    # Moller-Trumbore in float64, the origin at the eye
    p0 = d1 * e22 - d2 * e21
    p1 = d2 * e20 - d0 * e22
    p2 = d0 * e21 - d1 * e20
    det = e10 * p0 + e11 * p1 + e12 * p2
    dn = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    n0 = e11 * e22 - e12 * e21
    n1 = e12 * e20 - e10 * e22
    n2 = e10 * e21 - e11 * e20
    nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if nn == 0.0:
        return -1.0  # a degenerate triangle holds no piece of a sheet
    s0, s1, s2 = -a0, -a1, -a2
    if abs(det) <= GRAZING * nn * dn:
        # the ray along the plane: inside the triangle's slab? (barycentrics of the
        # eye's foot are not defined); unsure when the eye lies near the plane
        dist_plane = abs(s0 * n0 + s1 * n1 + s2 * n2) / nn
        scale = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2) + math.sqrt(
            e10 * e10 + e11 * e11 + e12 * e12) + math.sqrt(e20 * e20 + e21 * e21 + e22 * e22)
        return np.inf if dist_plane <= GRAZING * scale else -1.0
    inv = 1.0 / det
    bu = (s0 * p0 + s1 * p1 + s2 * p2) * inv
    q0 = s1 * e12 - s2 * e11
    q1 = s2 * e10 - s0 * e12
    q2 = s0 * e11 - s1 * e10
    bv = (d0 * q0 + d1 * q1 + d2 * q2) * inv
    t = (e20 * q0 + e21 * q1 + e22 * q2) * inv
    if bu < -INSIDE_TOLERANCE or bv < -INSIDE_TOLERANCE or bu + bv > 1.0 + INSIDE_TOLERANCE:
        return -1.0
    if not t > 0.0:
        return -1.0
    return t * dn


@njit_cached()
def corner_triangle_depths(vert, faces, corner_tri, todo, eye, r, u, f, hx, hy, out
                           ):  # pragma: no cover
    """Per pixel of ``todo`` (H, W) bool, the largest distance at its four corners to the
    triangles its corner rays first hit (``corner_tri`` (H + 1, W + 1), -1 a miss), each
    counted at every corner whose ray passes through it (:func:`corner_distance`), into
    ``out`` (H, W) (raised, never lowered)."""
    h, w = todo.shape
    for i in range(h):
        for j in range(w):
            if not todo[i, j]:
                continue
            for ci in range(2):
                for cj in range(2):
                    t = corner_tri[i + ci, j + cj]
                    if t < 0:
                        out[i, j] = np.inf
                        continue
                    for ki in range(2):
                        for kj in range(2):
                            dist = corner_distance(vert, faces[t, 0], faces[t, 1], faces[t, 2],
                                                   eye, r, u, f, hx, hy, w, h, i + ki, j + kj)
                            if dist > out[i, j]:
                                out[i, j] = dist
