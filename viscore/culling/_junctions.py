"""The conservative depth buffer's junction rule: a pixel covered by the union of occluder
triangles from different sheets or meshes (a road laid on the ground, a roof on its walls,
a T-junction), decided exactly in the pixel's square.

The other rules cover a pixel by one convex piece, one coplanar region, one patch, or one
sheet (:mod:`viscore.culling._sheets`): triangles joined across shared edges. Where two
separate meshes meet, no edge is shared and each mesh's contour crosses the pixel. This
rule asks nothing of connectivity and tests the cover itself:

A buffer pixel still open, whose four corner rays all hit an occluder, is tested with the
occluder triangles whose projection meets its square ``Q`` (widened by the crease rule's
slack), lying wholly in front of the eye (every vertex at least the near cut ``z0`` ahead)
and not edge-on (projected area over a millionth of a pixel): at most
:data:`MAX_CANDIDATES` of them (a pixel with more stays open), of which the
:data:`MAX_USED` with the smallest *reach* (the largest distance from the eye over the
triangle's part in the pixel's pyramid) are used. Sorted by reach, the shortest prefix of
them whose projections cover ``Q`` gives the pixel the depth of its last triangle's reach
(plus the depth margin); when none covers it, the pixel stays open.

Why a covered pixel is never nearer than the occluders. If the projections of triangles
``T_1..T_m`` cover ``Q``, every ray through the pixel meets one of them, so its first hit
is no farther than that triangle's distance along it, at most that triangle's reach. The
reach is exact: the distance from the eye is convex on a plane, so its largest value over
the triangle's part in the pyramid (a convex polygon, the projected triangle clipped to
``Q``) is at a vertex of that polygon, and each vertex is lifted back to the triangle's
plane. Triangles left out only make the cover harder to reach.

Why the cover test is exact. Let ``U = Q - (T_1 u ... u T_m)`` (projections, closed),
relatively open in ``Q``. If ``U`` is not empty: either no triangle meets the interior of
``Q``, and the inner side of every side of ``Q`` is uncovered, or (``Q``'s interior being
connected) ``U`` has a boundary point ``p`` inside ``Q`` on an edge ``e`` of some
``T_i``, with ``U`` on the outer side of ``e`` near ``p`` (on its inner side lies
``T_i``). The test splits each side of ``Q`` and each edge of every ``T_i`` (clipped to
``Q``) at every point where another edge crosses or touches it and at the ends of the
edges along the same line (extra split points are harmless). Each edge is taken from its
lexicographically smaller end (column, then row), so that an edge shared by two
triangles is one segment in both, with the same ends and bit-identical crossings with
every other edge (its tested side is on the right of the triangle's counter-clockwise
edge, whichever way it runs). Along each piece between two split points no edge meets
it, so whether the triangles cover its outer side (for ``Q``'s sides: the inner side) is
the same all along, and is decided at its midpoint: a triangle covers that side when
the midpoint lies strictly inside it, or on its boundary with every edge through the
midpoint parallel to the piece and the triangle on the tested side. A piece whose side
no triangle covers shows ``U`` is not empty; when every piece's side is covered, ``U``
has no boundary point inside ``Q``, no uncovered side of ``Q``, and is empty.

Rounding. Coordinates are taken relative to the pixel, in pixels; "strictly inside" is
by more than :data:`ON_EDGE` times (1 + the largest coordinate of the pixel's
triangles), and a midpoint within that of an edge's line is on it: two edges along one
line count as meeting when they are that close (float rounding of one line computed
twice), so a gap narrower than that (about a billionth of a pixel for triangles near the
pixel, up to a thousandth when one of the pixel's triangles reaches ``MAX_COORD``
pixels away, such as a ground vertex near the eye) is taken as closed; the same number,
as a sine, decides that two edges are parallel. A piece no longer than the tolerance is
not tested: where edges meet at one point in exact arithmetic (the edges of a fan at its
vertex, a T-junction's vertex a rounding off the edge it lies on, a pixel side crossing
both lines there), their crossings, computed from different lines, land a rounding apart
and leave such a piece, whose midpoint lies on an edge through it that is not parallel
to it, so no triangle would cover it and the pixel would stay open. Hence an uncovered
part of the pixel whose boundary pieces are each no longer than the tolerance (a hole
the size of the rounding) is taken as closed, as a gap narrower than the tolerance is.
A longer piece whose midpoint lies within the tolerance of an edge not parallel to it is
not covered, leaving the pixel open (never the other way).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit_cached
from .._sort_kernels import sort_prefix, stable_order

__all__ = ["junction_depths", "MAX_CANDIDATES", "MAX_USED", "ON_EDGE"]

#: A pixel meeting more occluder triangles than this stays open (a budget per pixel).
MAX_CANDIDATES = 256
#: The triangles of smallest reach a pixel's cover is sought among.
MAX_USED = 24
#: Relative tolerance (of the pixel's coordinates' size) for a point on an edge's line.
ON_EDGE = 1e-9
#: Least projected area (pixels squared) of a triangle the rule uses: an edge-on one
#: covers no area.
MIN_AREA = 1e-6
#: Largest projected coordinate (pixels from the pixel) of a triangle the rule uses:
#: farther vertices (a triangle grazing the near cut) lose the float precision the test
#: needs.
MAX_COORD = 1e6


@njit_cached()
def _project(vc, faces, z0, hx, hy, w, h, tri2, ok):  # pragma: no cover
    """Each triangle's projection in buffer pixels (column, row), counter-clockwise:
    ``tri2`` (T, 3, 2); ``ok`` False for one not wholly in front of ``z0`` or edge-on."""
    for t in range(len(faces)):
        ok[t] = False
        good = True
        for k in range(3):
            v = faces[t, k]
            z = vc[v, 2]
            if not z >= z0:
                good = False
                break
            tri2[t, k, 0] = (vc[v, 0] / z * (0.5 / hx) + 0.5) * w
            tri2[t, k, 1] = (0.5 - vc[v, 1] / z * (0.5 / hy)) * h
        if not good:
            continue
        ax, ay = tri2[t, 0, 0], tri2[t, 0, 1]
        area = 0.5 * ((tri2[t, 1, 0] - ax) * (tri2[t, 2, 1] - ay)
                      - (tri2[t, 1, 1] - ay) * (tri2[t, 2, 0] - ax))
        if abs(area) <= MIN_AREA:
            continue
        if area < 0:  # counter-clockwise in (column, row)
            for c in range(2):
                tmp = tri2[t, 1, c]
                tri2[t, 1, c] = tri2[t, 2, c]
                tri2[t, 2, c] = tmp
        ok[t] = True


@njit_cached()
def _meets(tri2, t, c0, r0, c1, r1):  # pragma: no cover
    """Whether projected triangle ``t`` meets the square [c0, c1] x [r0, r1] (closed):
    no edge line has the square wholly outside."""
    for k in range(3):
        ax, ay = tri2[t, k, 0], tri2[t, k, 1]
        bx, by = tri2[t, (k + 1) % 3, 0], tri2[t, (k + 1) % 3, 1]
        ex, ey = bx - ax, by - ay
        out = True
        for cx in (c0, c1):
            for cy in (r0, r1):
                if ex * (cy - ay) - ey * (cx - ax) >= 0.0:
                    out = False
        if out:
            return False
    return True


@njit_cached()
def _widened_box(tri2, t, slack):  # pragma: no cover
    """Projected triangle ``t``'s bounding box widened by ``slack``: (cmin, cmax, rmin,
    rmax), buffer pixels."""
    cmin = min(tri2[t, 0, 0], tri2[t, 1, 0], tri2[t, 2, 0]) - slack
    cmax = max(tri2[t, 0, 0], tri2[t, 1, 0], tri2[t, 2, 0]) + slack
    rmin = min(tri2[t, 0, 1], tri2[t, 1, 1], tri2[t, 2, 1]) - slack
    rmax = max(tri2[t, 0, 1], tri2[t, 1, 1], tri2[t, 2, 1]) + slack
    return cmin, cmax, rmin, rmax


@njit_cached()
def _bins(tri2, ok, pix_i, pix_j, row_start, w, slack, count, fill, start, cand
          ):  # pragma: no cover
    """Per tested pixel ``(pix_i, pix_j)`` (row-major order; ``row_start`` (H + 1,) the
    index of each row's first), the triangles meeting its widened square: counted into
    ``count`` when ``fill`` is False, else listed into ``cand`` from ``start``, in
    triangle order."""
    h = len(row_start) - 1
    for t in range(len(tri2)):
        if not ok[t]:
            continue
        cmin, cmax, rmin, rmax = _widened_box(tri2, t, slack)
        if cmax < 0 or rmax < 0 or cmin > w or rmin > h:
            continue
        j0, j1 = max(0, int(math.floor(cmin)) - 1), min(w - 1, int(math.floor(cmax)) + 1)
        i0, i1 = max(0, int(math.floor(rmin)) - 1), min(h - 1, int(math.floor(rmax)) + 1)
        if j0 > j1 or i0 > i1 or row_start[i1 + 1] == row_start[i0]:
            continue
        for i in range(i0, i1 + 1):
            # the row's first tested pixel at a column >= j0 (binary search)
            lo, hi = row_start[i], row_start[i + 1]
            while lo < hi:
                mid = (lo + hi) // 2
                if pix_j[mid] < j0:
                    lo = mid + 1
                else:
                    hi = mid
            s = lo
            while s < row_start[i + 1] and pix_j[s] <= j1:
                j = pix_j[s]
                if _meets(tri2, t, j - slack, i - slack, j + 1 + slack, i + 1 + slack):
                    if fill and count[s] < start[s + 1] - start[s]:
                        cand[start[s] + count[s]] = t
                    count[s] += 1
                s += 1


@njit_cached()
def _reach(tri2, vc, faces, t, c0, r0, c1, r1, w, h, hx, hy, poly, tmp):  # pragma: no cover
    """The largest distance from the eye over triangle ``t``'s part in the pyramid of the
    square [c0, c1] x [r0, r1] (-1 when they do not meet): the projected triangle clipped
    to the square (Sutherland-Hodgman), each vertex lifted to the triangle's plane."""
    n = 3
    for k in range(3):
        poly[k, 0] = tri2[t, k, 0]
        poly[k, 1] = tri2[t, k, 1]
    for side in range(4):
        axis = side // 2
        bound = (c0, c1, r0, r1)[side]
        lower = side % 2 == 0
        m = 0
        for k in range(n):
            px, py = poly[k, 0], poly[k, 1]
            qx, qy = poly[(k + 1) % n, 0], poly[(k + 1) % n, 1]
            pv = px if axis == 0 else py
            qv = qx if axis == 0 else qy
            pin = pv >= bound if lower else pv <= bound
            qin = qv >= bound if lower else qv <= bound
            if pin:
                tmp[m, 0], tmp[m, 1] = px, py
                m += 1
            if pin != qin:
                s = (bound - pv) / (qv - pv)
                tmp[m, 0], tmp[m, 1] = px + s * (qx - px), py + s * (qy - py)
                if axis == 0:
                    tmp[m, 0] = bound
                else:
                    tmp[m, 1] = bound
                m += 1
        n = m
        if n == 0:
            return -1.0
        for k in range(n):
            poly[k, 0], poly[k, 1] = tmp[k, 0], tmp[k, 1]
    # the triangle's plane in camera coordinates: n . p = n . a
    a0, a1, a2 = vc[faces[t, 0], 0], vc[faces[t, 0], 1], vc[faces[t, 0], 2]
    b0, b1, b2 = vc[faces[t, 1], 0] - a0, vc[faces[t, 1], 1] - a1, vc[faces[t, 1], 2] - a2
    e0, e1, e2 = vc[faces[t, 2], 0] - a0, vc[faces[t, 2], 1] - a1, vc[faces[t, 2], 2] - a2
    n0, n1, n2 = b1 * e2 - b2 * e1, b2 * e0 - b0 * e2, b0 * e1 - b1 * e0
    off = n0 * a0 + n1 * a1 + n2 * a2
    far = 0.0
    for k in range(n):
        x = (poly[k, 0] / w - 0.5) * (2.0 * hx)
        y = (0.5 - poly[k, 1] / h) * (2.0 * hy)
        den = n0 * x + n1 * y + n2
        if den == 0.0:
            return np.inf
        tt = off / den
        if not tt > 0.0:
            return np.inf
        d = tt * math.sqrt(x * x + y * y + 1.0)
        if d > far:
            far = d
    return far


@njit_cached()
def _edge(loc, t, k):  # pragma: no cover
    """Edge ``k`` of triangle ``t`` of ``loc``: its start, its vector and its length."""
    ax, ay = loc[t, k, 0], loc[t, k, 1]
    ex, ey = loc[t, (k + 1) % 3, 0] - ax, loc[t, (k + 1) % 3, 1] - ay
    return ax, ay, ex, ey, math.sqrt(ex * ex + ey * ey)


@njit_cached()
def _side_covered(loc, m, mx, my, nx, ny, sx, sy, tol):  # pragma: no cover
    """Whether one of the first ``m`` triangles ``loc`` (pixel-relative, counter-clockwise)
    covers the side ``(nx, ny)`` of the point ``(mx, my)`` on a piece along unit
    ``(sx, sy)``: the point strictly inside, or on its boundary with every edge through
    it parallel to the piece and the triangle on that side."""
    for t in range(m):
        inside = True
        for k in range(3):
            ax, ay, ex, ey, le = _edge(loc, t, k)
            # signed distance from the edge's line, positive inside (rows grow down:
            # counter-clockwise in (column, row) puts the inside on the cross's sign)
            dist = (ex * (my - ay) - ey * (mx - ax)) / le
            if dist > tol:
                continue
            if dist < -tol:
                inside = False
                break
            # on the edge's line: parallel to the piece, and the inside towards the side
            ux, uy = ex / le, ey / le
            if abs(ux * sy - uy * sx) > tol:
                inside = False
                break
            # the inward normal of the edge, (-uy, ux) in these coordinates
            if -uy * nx + ux * ny <= 0.5:
                inside = False
                break
        if inside:
            return True
    return False


@njit_cached()
def _segment(loc, s, q0, q1):  # pragma: no cover
    """Segment ``s`` of the cover test: the square's sides (0-3, counter-clockwise: inside
    on the left), then the triangles' edges (``4 + 3 t + k``): its ends, and whether they
    are in the triangle's counter-clockwise order. A triangle's edge runs from its
    lexicographically smaller end (column, then row), so that the copies of an edge shared
    by two triangles are the same segment and give bit-identical crossings."""
    if s < 4:
        if s == 0:
            return q0, q0, q1, q0, True
        if s == 1:
            return q1, q0, q1, q1, True
        if s == 2:
            return q1, q1, q0, q1, True
        return q0, q1, q0, q0, True
    t, k = (s - 4) // 3, (s - 4) % 3
    ax, ay = loc[t, k, 0], loc[t, k, 1]
    bx, by = loc[t, (k + 1) % 3, 0], loc[t, (k + 1) % 3, 1]
    if bx < ax or (bx == ax and by < ay):
        return bx, by, ax, ay, False
    return ax, ay, bx, by, True


@njit_cached()
def _clipped(px, py, dx, dy, q0, q1):  # pragma: no cover
    """The parameters ``(ta, tb)`` of the part of ``p + t d``, ``t`` in [0, 1], in the
    square [q0, q1]^2 (Liang-Barsky; ``tb < ta`` when none)."""
    ta, tb = 0.0, 1.0
    for axis in range(2):
        pv = px if axis == 0 else py
        dv = dx if axis == 0 else dy
        if dv == 0.0:
            if pv < q0 or pv > q1:
                return 1.0, 0.0
            continue
        u0, u1 = (q0 - pv) / dv, (q1 - pv) / dv
        if u0 > u1:
            u0, u1 = u1, u0
        ta, tb = max(ta, u0), min(tb, u1)
    return ta, tb


@njit_cached()
def _in_some(loc, m, x, y, tol):  # pragma: no cover
    """Whether the point lies in one of the first ``m`` triangles, within ``tol``."""
    for t in range(m):
        inside = True
        for k in range(3):
            ax, ay, ex, ey, le = _edge(loc, t, k)
            if ex * (y - ay) - ey * (x - ax) < -tol * le:
                inside = False
                break
        if inside:
            return True
    return False


@njit_cached()
def _covers(loc, m, q0, q1, tol, params, live):  # pragma: no cover
    """Whether the first ``m`` triangles ``loc`` (pixel-relative, counter-clockwise)
    cover the square [q0, q1]^2: no piece longer than ``tol`` of a side of the square or
    of a triangle's edge within it has its tested side uncovered (the module docstring's
    argument). A point of a 3 x 3 grid over the square in no triangle answers no at
    once."""
    for a in range(3):
        for b in range(3):
            x = q0 + 0.5 * a * (q1 - q0)
            y = q0 + 0.5 * b * (q1 - q0)
            if not _in_some(loc, m, x, y, tol):
                return False
    # the segments meeting the square (only they can split a piece inside it)
    nlive = 0
    for s in range(4 + 3 * m):
        px, py, qx, qy, _ = _segment(loc, s, q0, q1)
        ta, tb = _clipped(px, py, qx - px, qy - py, q0, q1)
        if tb >= ta:
            live[nlive] = s
            nlive += 1
    for si in range(nlive):
        s = live[si]
        px, py, qx, qy, ccw = _segment(loc, s, q0, q1)
        dx, dy = qx - px, qy - py
        length = math.sqrt(dx * dx + dy * dy)
        if length == 0.0:
            continue
        ta, tb = _clipped(px, py, dx, dy, q0, q1)
        if tb <= ta:
            continue
        # the tested side: the square's inside (left of its sides), a triangle's outside
        # (right of its counter-clockwise edges, left when the edge runs the other way)
        sx, sy = dx / length, dy / length
        if s < 4 or not ccw:
            nx, ny = -sy, sx
        else:
            nx, ny = sy, -sx
        # split points: every other edge crossing or touching, and ends along the line
        n = 0
        params[n] = ta
        n += 1
        params[n] = tb
        n += 1
        for oi in range(nlive):
            o = live[oi]
            if o == s:
                continue
            ax, ay, bx, by, _ = _segment(loc, o, q0, q1)
            ex, ey = bx - ax, by - ay
            den = dx * ey - dy * ex
            le = math.sqrt(ex * ex + ey * ey)
            if abs(den) <= tol * length * max(le, 1e-300):  # parallel: the ends along
                params[n] = ((ax - px) * dx + (ay - py) * dy) / (length * length)
                params[n + 1] = ((bx - px) * dx + (by - py) * dy) / (length * length)
                n += 2
                continue
            # p + a d = c + b e
            a = ((ax - px) * ey - (ay - py) * ex) / den
            b = ((ax - px) * dy - (ay - py) * dx) / den
            slackb = tol / max(le, 1e-300)
            if b >= -slackb and b <= 1.0 + slackb:
                params[n] = a
                n += 1
        sort_prefix(params, n)  # params[:n] ascending
        ps = params
        short = tol / length  # a piece no longer than the tolerance is not tested
        for k in range(n - 1):
            lo, hi = max(ps[k], ta), min(ps[k + 1], tb)
            if hi - lo <= short:
                continue
            mid = 0.5 * (lo + hi)
            mx, my = px + mid * dx, py + mid * dy
            if not _side_covered(loc, m, mx, my, nx, ny, sx, sy, tol):
                return False
    return True


@njit_cached()
def _cover_pixels(tri2, vc, faces, cand, start, pix_i, pix_j, slack, w, h, hx, hy, out
                  ):  # pragma: no cover
    """Per tested pixel, the reach of the shortest covering prefix of its triangles (by
    reach) into ``out`` (inf where none covers)."""
    poly = np.empty((16, 2))
    tmp = np.empty((16, 2))
    loc = np.empty((MAX_USED, 3, 2))
    params = np.empty(2 + 2 * (4 + 3 * MAX_USED) + 8)
    live = np.empty(4 + 3 * MAX_USED, dtype=np.int64)
    order_a = np.empty(MAX_CANDIDATES, dtype=np.int64)
    order_b = np.empty(MAX_CANDIDATES, dtype=np.int64)
    for p in range(len(pix_i)):
        out[p] = np.inf
        n = start[p + 1] - start[p]
        if n == 0 or n > MAX_CANDIDATES:
            continue
        i, j = pix_i[p], pix_j[p]
        c0, r0, c1, r1 = j - slack, i - slack, j + 1 + slack, i + 1 + slack
        reach = np.empty(n)
        for k in range(n):
            reach[k] = _reach(tri2, vc, faces, cand[start[p] + k], c0, r0, c1, r1, w, h, hx,
                              hy, poly, tmp)
        order = stable_order(reach, n, order_a, order_b)
        m = 0
        big = 1.0
        for k in range(n):
            rk = reach[order[k]]
            if rk < 0.0:
                continue  # the part in the square is empty (an edge touching it)
            if rk == np.inf or m == MAX_USED:
                break
            t = cand[start[p] + order[k]]
            for v in range(3):
                loc[m, v, 0] = tri2[t, v, 0] - j
                loc[m, v, 1] = tri2[t, v, 1] - i
                big = max(big, 1.0 + abs(loc[m, v, 0]), 1.0 + abs(loc[m, v, 1]))
            order[m] = order[k]
            m += 1
        if m == 0 or big > MAX_COORD:
            continue
        tol = ON_EDGE * big
        q0, q1 = -slack, 1.0 + slack
        # the shortest covering prefix (covering grows with the prefix): tried from the
        # shortest, most failing at once on the grid of points
        for k in range(1, m + 1):
            if _covers(loc, k, q0, q1, tol, params, live):
                out[p] = reach[order[k - 1]]
                break


def junction_depths(vertices: np.ndarray, faces: np.ndarray, todo: np.ndarray,
                    eye: np.ndarray, basis, hx: float, hy: float, z0: float, slack: float
                    ) -> np.ndarray:
    """Depths of the pixels that the union of occluder triangles covers (the module
    docstring's rule), before the depth margin.

    Parameters
    ----------
    vertices : (V, 3) float
        Occluder vertices, world units.
    faces : (T, 3) int
        Occluder triangles.
    todo : (H, W) bool
        The buffer pixels to test.
    eye : (3,) float
        The camera's position.
    basis : tuple of three (3,) float
        The camera's forward, right and up unit vectors.
    hx, hy : float
        Tangents of the camera's horizontal and vertical half angles.
    z0 : float
        Near cut: a triangle with a vertex less than this ahead of the eye is not used.
    slack : float
        Widening of each pixel's square, in pixels.

    Returns
    -------
    (k,) float64
        For each of the ``k`` pixels of ``todo``, in row-major order (that of
        ``todo[mask]`` and ``np.nonzero(todo)``), the reach of the shortest covering prefix
        of its triangles; ``inf`` where none covers it.

    Notes
    -----
    No array of the frame's size is made: the triangles are binned to the tested pixels
    through each row's run of them.
    """
    h, w = todo.shape
    pix_i, pix_j = np.nonzero(todo)
    if not len(pix_i):
        return np.full(0, np.inf)
    f, r, u = basis
    rel = np.asarray(vertices, dtype=np.float64) - np.asarray(eye, dtype=np.float64)
    vc = np.ascontiguousarray(np.stack([rel @ r, rel @ u, rel @ f], axis=1))
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    tri2 = np.empty((len(faces), 3, 2))
    ok = np.empty(len(faces), dtype=bool)
    _project(vc, faces, z0, hx, hy, w, h, tri2, ok)
    row_start = np.searchsorted(pix_i, np.arange(h + 1))
    count = np.zeros(len(pix_i), dtype=np.int64)
    start = np.zeros(len(pix_i) + 1, dtype=np.int64)
    cand = np.zeros(0, dtype=np.int64)
    _bins(tri2, ok, pix_i, pix_j, row_start, w, slack, count, False, start, cand)
    start[1:] = np.cumsum(np.minimum(count, MAX_CANDIDATES + 1))
    cand = np.zeros(int(start[-1]), dtype=np.int64)
    full = count.copy()
    count[:] = 0
    _bins(tri2, ok, pix_i, pix_j, row_start, w, slack, count, True, start, cand)
    depth = np.empty(len(pix_i))
    _cover_pixels(tri2, vc, faces, cand, start, pix_i, pix_j, slack, w, h, hx, hy, depth)
    depth[full > MAX_CANDIDATES] = np.inf  # over the budget: listed short, left open
    return depth
