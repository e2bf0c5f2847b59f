"""The contour rule of the conservative depth buffer: pixels covered by a union of triangles.

A pixel is wholly covered by a triangle mesh when the ray through its centre meets the
mesh and no contour edge of the mesh crosses the pixel: the outline of the mesh's
projection lies on its contour edges (Appel 1967 [1]_; the edges where the mesh's
silhouette can lie, as in Markosian et al. 1997 [2]_, sec. 2): boundary edges,
non-manifold edges, and edges whose two faces lie on one side of the plane through the
eye and the edge (a fold as seen from the eye: front-facing against back-facing or
edge-on, whatever the winding). Every ray through such a pixel then meets the mesh on a
triangle whose projection touches the pixel, no farther than that triangle's farthest
point in the view pyramid: the pixel's depth. The occluders of a buffer are taken
together as one mesh (vertices merged at equal positions), so that closed non-convex
parts and sheets of many small triangles cover pixels as a union where no single
triangle or convex piece covers a whole pixel.

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
from ._depth_kernel import (
    PYRAMID_SLACK,
    TOUCH_SLACK,
    _camera_triangle,
    _clip_to_pyramid,
    _side,
)

#: A fold is told from a smooth edge when both opposite vertices lie off the plane through
#: the eye and the edge by more than this fraction of (edge plane normal length x their
#: distance from the eye); nearer, the edge counts as a contour (edge-on faces).
FOLD_TOLERANCE = 1e-9


def edge_topology(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The edges of a triangle soup with vertices merged at equal positions.

    Returns
    -------
    edges : (e, 2) int64
        Vertex indices (into ``vertices``) of each distinct edge.
    opposite : (e, 2) int64
        The vertex opposite the edge in each of its two faces when exactly two faces share
        it; ``-1`` in both for a boundary or non-manifold edge (always a contour).
    """
    if len(faces) == 0:
        return np.zeros((0, 2), np.int64), np.zeros((0, 2), np.int64)
    _, first, inverse = np.unique(vertices, axis=0, return_index=True, return_inverse=True)
    merged = inverse.reshape(-1)[faces]
    pairs = np.concatenate([merged[:, [0, 1]], merged[:, [1, 2]], merged[:, [2, 0]]])
    opp = np.concatenate([merged[:, 2], merged[:, 0], merged[:, 1]])
    keep = pairs[:, 0] != pairs[:, 1]  # an edge of a degenerate face: its others count
    pairs, opp = np.sort(pairs[keep], axis=1), opp[keep]
    uniq, which, count = np.unique(pairs, axis=0, return_inverse=True, return_counts=True)
    which = which.reshape(-1)
    order = np.argsort(which, kind="stable")
    start = np.r_[0, np.cumsum(count)[:-1]]
    opposite = np.full((len(uniq), 2), -1, np.int64)
    two = count == 2
    opposite[two, 0] = opp[order[start[two]]]
    opposite[two, 1] = opp[order[start[two] + 1]]
    # a degenerate neighbour (its opposite vertex on the edge) is caught by the fold test
    return first[uniq], np.where(opposite >= 0, first[np.maximum(opposite, 0)], -1)


@njit_cached()
def _clip_segment(ax, ay, p, q):  # pragma: no cover
    """Parameters (t0, t1) of segment p->q (camera coordinates) inside the widened view
    pyramid; t0 > t1 when it misses it."""
    t0 = 0.0
    t1 = 1.0
    for k in range(4):
        g0 = _side(k, ax, ay, p[0], p[1], p[2])
        g1 = _side(k, ax, ay, q[0], q[1], q[2])
        if g0 < 0.0 and g1 < 0.0:
            return 1.0, 0.0
        if g0 < 0.0:
            t0 = max(t0, g0 / (g0 - g1))
        elif g1 < 0.0:
            t1 = min(t1, g0 / (g0 - g1))
    return t0, t1


@njit_cached()
def contour_pixels(vertices, edges, opposite, eye, r, u, f, hx, hy, crossed):
    """Mark in ``crossed`` (H, W) bool every pixel whose square (widened by
    :data:`TOUCH_SLACK`) a contour edge's part in the view pyramid crosses (see the module
    notes); returns the number of contour edges."""
    h, w = crossed.shape
    ax = hx * (1.0 + PYRAMID_SLACK)
    ay = hy * (1.0 + PYRAMID_SLACK)
    p = np.empty(3)
    q = np.empty(3)
    found = 0
    for k in range(edges.shape[0]):
        a = edges[k, 0]
        b = edges[k, 1]
        for m in range(3):
            p[m] = vertices[a, m] - eye[m]
            q[m] = vertices[b, m] - eye[m]
        if opposite[k, 0] >= 0:  # two faces: a fold when both lie on one side
            nx = p[1] * q[2] - p[2] * q[1]
            ny = p[2] * q[0] - p[0] * q[2]
            nz = p[0] * q[1] - p[1] * q[0]
            nn = math.sqrt(nx * nx + ny * ny + nz * nz)
            s = np.empty(2)
            ok = nn > 0.0
            for j in range(2):
                c = opposite[k, j]
                dx = vertices[c, 0] - eye[0]
                dy = vertices[c, 1] - eye[1]
                dz = vertices[c, 2] - eye[2]
                s[j] = nx * dx + ny * dy + nz * dz
                if abs(s[j]) <= FOLD_TOLERANCE * nn * math.sqrt(dx * dx + dy * dy + dz * dz):
                    ok = False
            if ok and s[0] * s[1] < 0.0:
                continue  # the faces on both sides: not on the outline
        found += 1
        # to camera coordinates (right, up, forward)
        px = p[0] * r[0] + p[1] * r[1] + p[2] * r[2]
        py = p[0] * u[0] + p[1] * u[1] + p[2] * u[2]
        pz = p[0] * f[0] + p[1] * f[1] + p[2] * f[2]
        qx = q[0] * r[0] + q[1] * r[1] + q[2] * r[2]
        qy = q[0] * u[0] + q[1] * u[1] + q[2] * u[2]
        qz = q[0] * f[0] + q[1] * f[1] + q[2] * f[2]
        p[0], p[1], p[2] = px, py, pz
        q[0], q[1], q[2] = qx, qy, qz
        t0, t1 = _clip_segment(ax, ay, p, q)
        if t0 > t1:
            continue
        z0 = pz + t0 * (qz - pz)
        z1 = pz + t1 * (qz - pz)
        if not (z0 > 0.0 and z1 > 0.0):  # through the eye: every pixel on its way
            crossed[:, :] = True
            continue
        x0 = px + t0 * (qx - px)
        y0 = py + t0 * (qy - py)
        x1 = px + t1 * (qx - px)
        y1 = py + t1 * (qy - py)
        c0 = (x0 / z0 * (0.5 / hx) + 0.5) * w
        r0 = (0.5 - y0 / z0 * (0.5 / hy)) * h
        c1 = (x1 / z1 * (0.5 / hx) + 0.5) * w
        r1 = (0.5 - y1 / z1 * (0.5 / hy)) * h
        j0 = max(math.floor(min(c0, c1) - TOUCH_SLACK), 0)
        j1 = min(math.floor(max(c0, c1) + TOUCH_SLACK), w - 1)
        i0 = max(math.floor(min(r0, r1) - TOUCH_SLACK), 0)
        i1 = min(math.floor(max(r0, r1) + TOUCH_SLACK), h - 1)
        ex = c1 - c0
        ey = r1 - r0
        reach = TOUCH_SLACK * math.sqrt(ex * ex + ey * ey)
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                # the segment's line with all four corners strictly on one side: apart
                lo = np.inf
                hi = -np.inf
                for aa in range(2):
                    for bb in range(2):
                        cross = ex * (i + aa - r0) - ey * (j + bb - c0)
                        lo = min(lo, cross)
                        hi = max(hi, cross)
                if lo > reach or hi < -reach:
                    continue
                crossed[i, j] = True
    return found


@njit_cached()
def farthest_touching(tri, eye, r, u, f, hx, hy, far):
    """Per pixel of ``far`` (H, W), the largest distance from the eye of the farthest
    vertex of the part in the view pyramid of any triangle of ``tri`` (m, 3, 3) whose
    projection's bounding rectangle (widened by :data:`TOUCH_SLACK`) touches the pixel
    (``far`` holds -inf where none does); ``inf`` for pixels of a triangle through the
    eye."""
    h, w = far.shape
    ax = hx * (1.0 + PYRAMID_SLACK)
    ay = hy * (1.0 + PYRAMID_SLACK)
    px = np.empty(8)
    py = np.empty(8)
    pz = np.empty(8)
    qx = np.empty(8)
    qy = np.empty(8)
    qz = np.empty(8)
    for k in range(tri.shape[0]):
        _camera_triangle(tri, k, eye, r, u, f, px, py, pz)
        n = _clip_to_pyramid(ax, ay, px, py, pz, qx, qy, qz, 3)
        if n == 0:
            continue
        dist = 0.0
        zmin = np.inf
        cmin = np.inf
        cmax = -np.inf
        rmin = np.inf
        rmax = -np.inf
        for m in range(n):
            dist = max(dist, math.sqrt(px[m] * px[m] + py[m] * py[m] + pz[m] * pz[m]))
            zmin = min(zmin, pz[m])
        if not zmin > 0.0:
            far[:, :] = np.inf
            continue
        for m in range(n):
            col = (px[m] / pz[m] * (0.5 / hx) + 0.5) * w
            row = (0.5 - py[m] / pz[m] * (0.5 / hy)) * h
            cmin = min(cmin, col)
            cmax = max(cmax, col)
            rmin = min(rmin, row)
            rmax = max(rmax, row)
        j0 = max(math.floor(cmin - TOUCH_SLACK), 0)
        j1 = min(math.floor(cmax + TOUCH_SLACK), w - 1)
        i0 = max(math.floor(rmin - TOUCH_SLACK), 0)
        i1 = min(math.floor(rmax + TOUCH_SLACK), h - 1)
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                if dist > far[i, j]:
                    far[i, j] = dist
