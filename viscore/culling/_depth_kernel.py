"""numba kernels of the conservative depth buffer (:mod:`viscore.culling.depth_buffer`)."""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit_cached


@njit_cached()
def tile_corners(ti, tj, s, stride, facet, xs, ys, r, u, f, need, d32):
    """List the corners of the tiles (top-left pixel row ``ti``, column ``tj``, side
    ``s``) not cast yet (``facet == -2``), each once, marking them pending (-3): their flat
    indices in ``need`` and their unit ray directions (world, float32) in ``d32``;
    returns how many."""
    n = 0
    for k in range(ti.shape[0]):
        for a in range(2):
            i = ti[k] + a * s
            for b in range(2):
                j = tj[k] + b * s
                c = i * stride + j
                if facet[c] != -2:
                    continue
                facet[c] = -3
                need[n] = c
                x = xs[j]
                y = ys[i]
                dx = x * r[0] + y * u[0] + f[0]
                dy = x * r[1] + y * u[1] + f[1]
                dz = x * r[2] + y * u[2] + f[2]
                norm = math.sqrt(dx * dx + dy * dy + dz * dz)
                d32[n, 0] = dx / norm
                d32[n, 1] = dy / norm
                d32[n, 2] = dz / norm
                n += 1
    return n


@njit_cached()
def _outside(k, solid_plane, solid_ok, eye, tol, outside):
    """Whether the eye is strictly outside solid ``k`` (above one of its face planes by
    more than ``tol``); cached in ``outside`` (int8, -1: not known yet)."""
    if outside[k] < 0:
        outside[k] = 0
        for p in range(solid_plane.shape[1]):
            pl = solid_plane[k, p]
            if solid_ok[k, p] and pl[0] * eye[0] + pl[1] * eye[1] + pl[2] * eye[2] - pl[3] > tol:
                outside[k] = 1
                break
    return outside[k] == 1


@njit_cached()
def store_hits(need, tri, tri_facet, tri_solid, tri_region, n_facets, solid_plane, solid_ok,
               eye, tol, outside, facet, piece, region):
    """Label corners ``need`` by the triangle ``tri`` their ray first hit (-1: miss):
    ``facet`` its planar facet, ``piece`` its convex piece (the solid, numbered from
    ``n_facets``, when the eye is outside it (:func:`_outside`); else the facet),
    ``region`` its coplanar region (-1: none); -1 on a miss. Returns the number of
    hits."""
    hits = 0
    for k in range(need.shape[0]):
        c = need[k]
        t = tri[k]
        if t < 0:
            facet[c] = -1
            piece[c] = -1
            region[c] = -1
            continue
        hits += 1
        fa = tri_facet[t]
        sd = tri_solid[t]
        facet[c] = fa
        region[c] = tri_region[t]
        if sd >= 0 and _outside(sd, solid_plane, solid_ok, eye, tol, outside):
            piece[c] = n_facets + sd
        else:
            piece[c] = fa
    return hits


@njit_cached()
def _pushed_offset(pl, eye):  # pragma: no cover
    """The signed distance ``offset - n . eye`` from the eye to plane ``pl`` (n.x =
    offset, slack), the plane pushed its slack away from the eye."""
    num = pl[3] - (pl[0] * eye[0] + pl[1] * eye[1] + pl[2] * eye[2])
    return num + pl[4] if num > 0 else num - pl[4]


@njit_cached()
def _coefficient(pl, eye, r, u, f, coef, p):
    """Row ``p`` of ``coef``: plane ``pl`` (n.x = offset, slack) pushed ``slack`` away
    from the eye, as (a, b, c) with the plane at parameter 1 / (a x + b y + c) along the
    direction x r + y u + f from the eye. A ray that meets a facet lying within ``slack``
    of its plane meets it no farther than the pushed plane."""
    num = _pushed_offset(pl, eye)
    coef[p, 0] = (pl[0] * r[0] + pl[1] * r[1] + pl[2] * r[2]) / num
    coef[p, 1] = (pl[0] * u[0] + pl[1] * u[1] + pl[2] * u[2]) / num
    coef[p, 2] = (pl[0] * f[0] + pl[1] * f[1] + pl[2] * f[2]) / num


@njit_cached()
def _fill(depth, i0, j0, s, coef, planes, xs, ys, margin, corner, plane):
    """Pixels of one covered tile (those inside ``depth``): per pixel the largest entry
    distance of its four corner rays into the piece of ``planes`` rows of ``coef``
    (along the direction (x, y, 1): its length over the smallest a x + b y + c, for a
    solid over its planes facing the eye), plus ``margin``; ``inf`` where a corner ray
    does not enter.

    With one plane (a facet or a coplanar region covering the tile), ``plane`` (H, W, 4)
    also gets per pixel its (a, b, c) and the threshold ``1 + margin * g``, ``g`` the
    largest a x + b y + c over the pixel's corners (all positive; else the threshold
    stays ``inf``): a point ``q`` (camera coordinates: along r, u, f from the eye) in
    the pixel's pyramid is at least ``margin`` behind the plane, so hidden, when
    ``a q_r + b q_u + c q_f`` reaches the threshold (:func:`_triangle_hidden`)."""
    h, w = depth.shape
    if planes == 1:
        for a in range(min(s, h - i0)):
            for b in range(min(s, w - j0)):
                g_max = -np.inf
                for da in range(2):
                    for db in range(2):
                        g = coef[0, 0] * xs[j0 + b + db] + coef[0, 1] * ys[i0 + a + da] \
                            + coef[0, 2]
                        g_max = max(g_max, g) if g > 0 else np.inf
                if np.isfinite(g_max):
                    plane[i0 + a, j0 + b, 0] = coef[0, 0]
                    plane[i0 + a, j0 + b, 1] = coef[0, 1]
                    plane[i0 + a, j0 + b, 2] = coef[0, 2]
                    plane[i0 + a, j0 + b, 3] = 1.0 + margin * g_max
    for a in range(s + 1):
        y = ys[i0 + a]
        for b in range(s + 1):
            x = xs[j0 + b]
            g = np.inf
            for p in range(planes):
                v = coef[p, 0] * x + coef[p, 1] * y + coef[p, 2]
                if v < g:
                    g = v
            corner[a, b] = math.sqrt(x * x + y * y + 1.0) / g if g > 0 else np.inf
    for a in range(min(s, h - i0)):
        for b in range(min(s, w - j0)):
            t = max(max(corner[a, b], corner[a, b + 1]),
                    max(corner[a + 1, b], corner[a + 1, b + 1]))
            depth[i0 + a, j0 + b] = t + margin


@njit_cached()
def _clip(p, q, t0, t1):
    """One Liang-Barsky step: the parameter range (t0, t1) of a segment kept by the
    half-plane p t <= q; (1, 0) when nothing is left."""
    if p == 0.0:
        return (t0, t1) if q >= 0.0 else (1.0, 0.0)
    t = q / p
    if p < 0.0:
        return max(t0, t), t1
    return t0, min(t1, t)


@njit_cached()
def _crosses(segments, a, b, r0, r1, c0, c1):
    """Whether one of ``segments[a:b]`` (row, column of both ends, screen pixels; NaN:
    not in front of the eye) meets the closed rectangle rows ``r0..r1``, columns
    ``c0..c1`` (Liang-Barsky clipping)."""
    for k in range(a, b):
        ra = segments[k, 0]
        ca = segments[k, 1]
        rb = segments[k, 2]
        cb = segments[k, 3]
        if not (ra == ra):
            continue
        if max(ra, rb) < r0 or min(ra, rb) > r1 or max(ca, cb) < c0 or min(ca, cb) > c1:
            continue
        t0, t1 = _in_rectangle(ra, ca, rb - ra, cb - ca, r0, r1, c0, c1)
        if t0 <= t1:
            return True
    return False


@njit_cached()
def _in_rectangle(ra, ca, dr, dc, r0, r1, c0, c1):  # pragma: no cover
    """The parameter range (t0, t1) of the segment from (ra, ca) along (dr, dc), t in
    [0, 1], inside the closed rectangle rows r0..r1, columns c0..c1 (Liang-Barsky);
    empty when t0 > t1."""
    t0, t1 = _clip(-dc, ca - c0, 0.0, 1.0)
    t0, t1 = _clip(dc, c1 - ca, t0, t1)
    t0, t1 = _clip(-dr, ra - r0, t0, t1)
    return _clip(dr, r1 - ra, t0, t1)


@njit_cached()
def settle_tiles(ti, tj, s, stride, facet, piece, region, n_facets, facet_plane, solid_plane,
                 solid_ok, region_plane, segments, seg_start, region_ok, seg_slack, eye, r, u,
                 f, tol, xs, ys, margin, thin, depth, corner, coef, child_i, child_j, plane):
    """Settle the tiles of side ``s`` whose corners are labelled.

    A tile whose four corners hit one planar facet, or one convex solid, is
    filled (:func:`_fill`: the facet's plane, or the solid's planes facing the
    eye); so is a tile whose four corners hit one coplanar region (``region_ok``
    this frame) when no boundary segment of the region's union (``segments``, screen
    rows and columns of the ends, from ``seg_start``) crosses the tile widened by
    ``seg_slack`` pixels (:func:`_crosses`: the region's plane). Otherwise,
    when ``s > 1``, it is split if some corner hits, or if
    none does and a rectangle of ``thin`` (k, 5: row_min, row_max, col_min,
    col_max, smaller side; pixels) narrower than ``s`` overlaps it. Children
    (top-left pixel inside ``depth``) are written to ``child_i``, ``child_j``.
    Returns (children, tiles filled).
    """
    h, w = depth.shape
    n = 0
    tiles = 0
    half = s // 2
    for k in range(ti.shape[0]):
        i0 = ti[k]
        j0 = tj[k]
        c00 = i0 * stride + j0
        c01 = c00 + s
        c10 = c00 + s * stride
        c11 = c10 + s
        f0 = facet[c00]
        p0 = piece[c00]
        if f0 >= 0 and facet[c01] == f0 and facet[c10] == f0 and facet[c11] == f0:
            pl = facet_plane[f0]
            if abs(pl[3] - (pl[0] * eye[0] + pl[1] * eye[1] + pl[2] * eye[2])) > tol:
                _coefficient(pl, eye, r, u, f, coef, 0)
                _fill(depth, i0, j0, s, coef, 1, xs, ys, margin, corner, plane)
                tiles += 1
            continue
        if p0 >= 0 and piece[c01] == p0 and piece[c10] == p0 and piece[c11] == p0:
            sd = p0 - n_facets
            planes = 0
            for p in range(solid_plane.shape[1]):
                pl = solid_plane[sd, p]
                if solid_ok[sd, p] and pl[0] * eye[0] + pl[1] * eye[1] + pl[2] * eye[2] \
                        - pl[3] > tol:
                    _coefficient(pl, eye, r, u, f, coef, planes)
                    planes += 1
            if planes:
                _fill(depth, i0, j0, s, coef, planes, xs, ys, margin, corner, plane)
                tiles += 1
            continue
        g0 = region[c00]
        if g0 >= 0 and region[c01] == g0 and region[c10] == g0 and region[c11] == g0 \
                and region_ok[g0] and not _crosses(segments, seg_start[g0], seg_start[g0 + 1],
                                                   i0 - seg_slack, i0 + s + seg_slack,
                                                   j0 - seg_slack, j0 + s + seg_slack):
            pl = region_plane[g0]
            if abs(pl[3] - (pl[0] * eye[0] + pl[1] * eye[1] + pl[2] * eye[2])) > tol:
                _coefficient(pl, eye, r, u, f, coef, 0)
                _fill(depth, i0, j0, s, coef, 1, xs, ys, margin, corner, plane)
                tiles += 1
                continue
        if s == 1:
            continue
        split = p0 >= 0 or piece[c01] >= 0 or piece[c10] >= 0 or piece[c11] >= 0
        if not split:
            for q in range(thin.shape[0]):
                if thin[q, 4] < s and thin[q, 0] <= i0 + s and thin[q, 1] >= i0 \
                        and thin[q, 2] <= j0 + s and thin[q, 3] >= j0:
                    split = True
                    break
        if split:
            for a in range(2):
                for b in range(2):
                    ci = i0 + a * half
                    cj = j0 + b * half
                    if ci < h and cj < w:
                        child_i[n] = ci
                        child_j[n] = cj
                        n += 1
    return n, tiles


@njit_cached()
def _box_screen(lo, hi, q, eye, r, u, f, hx, hy, w, h):  # pragma: no cover
    """(ok, row_min, row_max, col_min, col_max): the screen rectangle (buffer pixels,
    not clipped) of box q's 8 corners; ok is False when a corner is not strictly in
    front of the eye's plane (the rectangle is then meaningless)."""
    cmin = np.inf
    cmax = -np.inf
    rmin = np.inf
    rmax = -np.inf
    for m in range(8):
        px = (hi[q, 0] if m & 4 else lo[q, 0]) - eye[0]
        py = (hi[q, 1] if m & 2 else lo[q, 1]) - eye[1]
        pz = (hi[q, 2] if m & 1 else lo[q, 2]) - eye[2]
        z = px * f[0] + py * f[1] + pz * f[2]
        if not z > 0:
            return False, rmin, rmax, cmin, cmax
        col = ((px * r[0] + py * r[1] + pz * r[2]) / z * (0.5 / hx) + 0.5) * w
        row = (0.5 - (px * u[0] + py * u[1] + pz * u[2]) / z * (0.5 / hy)) * h
        cmin = min(cmin, col)
        cmax = max(cmax, col)
        rmin = min(rmin, row)
        rmax = max(rmax, row)
    return True, rmin, rmax, cmin, cmax


#: Relative widening of the view pyramid's sides when a box is clipped to it
#: (:func:`_clipped_screen`): a clipped vertex rounded outwards only lowers the box's
#: nearest depth and widens its rectangle.
PYRAMID_SLACK = 1e-9


@njit_cached()
def _clipped_screen(lo, hi, q, eye, r, u, f, hx, hy, w, h):  # pragma: no cover
    """(ok, row_min, row_max, col_min, col_max, z_min) of the part of box q inside the
    view pyramid (the four side planes through the eye and the image edges): the screen
    rectangle (buffer pixels) and smallest forward depth ``f . (p - eye)`` of its vertices.

    The vertices of box ∩ pyramid are among: the box's corners inside the pyramid, the
    crossings of its 12 edges with the 4 side planes, and the entry and exit points of
    the pyramid's 4 edge rays (the image corners' rays) in the box. All are listed, each
    kept when inside every side plane widened by :data:`PYRAMID_SLACK` (a superset:
    z_min only lower, the rectangle only wider). ok is False when the part is empty or
    reaches the eye (z_min not > 0)."""
    # corners in camera coordinates (right, up, forward)
    cx = np.empty(8)
    cy = np.empty(8)
    cz = np.empty(8)
    for m in range(8):
        px = (hi[q, 0] if m & 4 else lo[q, 0]) - eye[0]
        py = (hi[q, 1] if m & 2 else lo[q, 1]) - eye[1]
        pz = (hi[q, 2] if m & 1 else lo[q, 2]) - eye[2]
        cx[m] = px * r[0] + py * r[1] + pz * r[2]
        cy[m] = px * u[0] + py * u[1] + pz * u[2]
        cz[m] = px * f[0] + py * f[1] + pz * f[2]
    ax = hx * (1.0 + PYRAMID_SLACK)
    ay = hy * (1.0 + PYRAMID_SLACK)
    # candidate vertices: 8 corners, 12 edges x 4 planes, 4 rays x 2
    vx = np.empty(64)
    vy = np.empty(64)
    vz = np.empty(64)
    n = 0
    for m in range(8):
        vx[n] = cx[m]
        vy[n] = cy[m]
        vz[n] = cz[m]
        n += 1
    for m in range(8):
        for bit in (1, 2, 4):
            if m & bit:
                continue
            e = m | bit
            for k in range(4):
                sx = 1.0 if k == 0 else (-1.0 if k == 1 else 0.0)
                sy = 1.0 if k == 2 else (-1.0 if k == 3 else 0.0)
                # side plane value g = a z - s x (or y): >= 0 inside
                g0 = ax * cz[m] * abs(sx) + ay * cz[m] * abs(sy) - sx * cx[m] - sy * cy[m]
                g1 = ax * cz[e] * abs(sx) + ay * cz[e] * abs(sy) - sx * cx[e] - sy * cy[e]
                if (g0 < 0) == (g1 < 0) or g0 == g1:
                    continue
                t = g0 / (g0 - g1)
                vx[n] = cx[m] + t * (cx[e] - cx[m])
                vy[n] = cy[m] + t * (cy[e] - cy[m])
                vz[n] = cz[m] + t * (cz[e] - cz[m])
                n += 1
    for k in range(4):
        dxw = (ax if k & 1 else -ax)
        dyw = (ay if k & 2 else -ay)
        # the ray eye + t (dxw r + dyw u + f), t >= 0, against the world box (slab test)
        t0 = 0.0
        t1 = np.inf
        empty = False
        for a in range(3):
            d = dxw * r[a] + dyw * u[a] + f[a]
            if d == 0.0:
                if eye[a] < lo[q, a] or eye[a] > hi[q, a]:
                    empty = True
                    break
                continue
            ta = (lo[q, a] - eye[a]) / d
            tb = (hi[q, a] - eye[a]) / d
            if ta > tb:
                ta, tb = tb, ta
            t0 = max(t0, ta)
            t1 = min(t1, tb)
        if empty or not t0 <= t1:
            continue
        for t in (t0, t1):
            vx[n] = t * dxw
            vy[n] = t * dyw
            vz[n] = t
            n += 1
    zmin = np.inf
    cmin = np.inf
    cmax = -np.inf
    rmin = np.inf
    rmax = -np.inf
    tol = 2.0 * PYRAMID_SLACK
    for i in range(n):
        z = vz[i]
        # inside every widened side plane (a vertex on a plane is rounded outwards)
        if abs(vx[i]) > ax * z + tol * (abs(vx[i]) + abs(z)) \
                or abs(vy[i]) > ay * z + tol * (abs(vy[i]) + abs(z)):
            continue
        zmin = min(zmin, z)
        if not z > 0:
            return False, rmin, rmax, cmin, cmax, zmin
        col = (vx[i] / z * (0.5 / hx) + 0.5) * w
        row = (0.5 - vy[i] / z * (0.5 / hy)) * h
        cmin = min(cmin, col)
        cmax = max(cmax, col)
        rmin = min(rmin, row)
        rmax = max(rmax, row)
    return zmin < np.inf and zmin > 0, rmin, rmax, cmin, cmax, zmin


@njit_cached()
def clipped_rectangles(lo, hi, eye, r, u, f, hx, hy, w, h, rect, zmin, ok):
    """Per box, :func:`_clipped_screen` into ``rect`` (n, 4: row_min, row_max, col_min,
    col_max), ``zmin`` and ``ok`` (the numpy side's twin of the occludee test's
    clipping)."""
    for q in range(lo.shape[0]):
        k, a, b, c, d, z = _clipped_screen(lo, hi, q, eye, r, u, f, hx, hy, w, h)
        ok[q] = k
        rect[q, 0] = a
        rect[q, 1] = b
        rect[q, 2] = c
        rect[q, 3] = d
        zmin[q] = z


@njit_cached()
def thin_rectangles(lo, hi, eye, r, u, f, hx, hy, w, h, rect):
    """Write into ``rect`` (k, 5: row_min, row_max, col_min, col_max, smaller side;
    buffer pixels) the screen rectangles of the boxes wholly in front of the eye's plane
    that meet the ``h`` x ``w`` screen and are at least a pixel wide and high (a box
    narrower cannot cover a pixel); returns k."""
    k = 0
    for q in range(lo.shape[0]):
        ok, rmin, rmax, cmin, cmax = _box_screen(lo, hi, q, eye, r, u, f, hx, hy, w, h)
        size = min(rmax - rmin, cmax - cmin)
        if ok and size >= 1.0 and rmax >= 0 and rmin <= h and cmax >= 0 and cmin <= w:
            rect[k, 0] = rmin
            rect[k, 1] = rmax
            rect[k, 2] = cmin
            rect[k, 3] = cmax
            rect[k, 4] = size
            k += 1
    return k


@njit_cached()
def occluded_boxes(lo, hi, eye, r, u, f, hx, hy, slack, depth, out):
    """Set ``out[k]`` for the boxes hidden in the buffer: the eye outside, the screen
    rectangle (widened by ``slack`` pixels) meeting the screen, and every pixel it touches
    nearer than a lower bound of the distance at which a ray through the pixel meets the
    box: the larger of the box's distance and its least forward depth times the secant of
    the pixel's ray nearest the view axis. A box with a corner on or behind the eye's plane,
    or reaching beyond the screen, is tested by its part in the view pyramid
    (:func:`_clipped_screen`), with that part's least forward depth."""
    h, w = depth.shape
    for k in range(lo.shape[0]):
        d2 = 0.0
        for a in range(3):
            g = max(max(lo[k, a] - eye[a], eye[a] - hi[k, a]), 0.0)
            d2 += g * g
        near = math.sqrt(d2)
        if not near > 0:
            continue
        ok, rmin, rmax, cmin, cmax = _box_screen(lo, hi, k, eye, r, u, f, hx, hy, w, h)
        # the box's least forward depth: a ray through a pixel meets it no nearer than
        # that times the ray's secant, a bound that grows with the pixel's distance from
        # the view axis where the Euclidean distance to the box does not
        zmin = 0.0
        for a in range(3):
            zmin += min(f[a] * (lo[k, a] - eye[a]), f[a] * (hi[k, a] - eye[a]))
        if not ok or cmin < 0.0 or cmax > w or rmin < 0.0 or rmax > h:
            # a corner on or behind the eye's plane, or beyond the screen's edge: the part
            # in the view pyramid, at its least forward depth (the part behind the screen's
            # edge may be nearer than any a pixel sees)
            ok, rmin, rmax, cmin, cmax, zmin = _clipped_screen(lo, hi, k, eye, r, u, f,
                                                               hx, hy, w, h)
            if not ok:
                continue
        c0 = math.floor(cmin - slack)
        c1 = math.floor(cmax + slack)
        r0 = math.floor(rmin - slack)
        r1 = math.floor(rmax + slack)
        if c1 < 0 or c0 > w - 1 or r1 < 0 or r0 > h - 1:
            continue
        c0 = max(c0, 0)
        r0 = max(r0, 0)
        c1 = min(c1, w - 1)
        r1 = min(r1, h - 1)
        hidden = True
        for i in range(r0, r1 + 1):
            yb = _nearest_to_centre(i, h, hy)
            for j in range(c0, c1 + 1):
                bound = near
                if zmin > 0:
                    xb = _nearest_to_centre(j, w, hx)
                    bound = max(near, zmin * math.sqrt(1.0 + xb * xb + yb * yb) * SEC_SHRINK)
                if not depth[i, j] < bound:
                    hidden = False
                    break
            if not hidden:
                break
        out[k] = hidden


#: Relative shrink of a clipped box's per-pixel distance bound (``z_min`` times the
#: secant of the pixel's ray nearest the view axis) against its float rounding.
SEC_SHRINK = 1.0 - 1e-12


@njit_cached()
def _nearest_to_centre(i, n, half):  # pragma: no cover
    """The image-plane coordinate (``x / z`` or ``y / z``, any sign) of the pixel edge or
    axis crossing of pixel ``i`` of ``n`` nearest the view axis, in absolute value: the
    least ``|x / z|`` over the pixel, for a half-extent ``half`` (``tan`` of the half
    field of view)."""
    a = abs((i / n - 0.5) * 2.0 * half)
    b = abs(((i + 1) / n - 0.5) * 2.0 * half)
    if (i / n - 0.5) * ((i + 1) / n - 0.5) <= 0.0:
        return 0.0
    return min(a, b)


@njit_cached()
def _plane_distance(pl, eye, r, u, f, x, y):  # pragma: no cover
    """Distance from the eye along the direction x r + y u + f to plane ``pl`` (n.x =
    offset, slack) pushed its slack away from the eye; inf when the ray does not meet it
    in front of the eye."""
    num = _pushed_offset(pl, eye)
    den = 0.0
    for a in range(3):
        den += pl[a] * (x * r[a] + y * u[a] + f[a])
    t = num / den if den != 0.0 else -1.0
    return t * math.sqrt(x * x + y * y + 1.0) if t > 0 else np.inf


@njit_cached()
def _crosses_side(segments, k, r0, r1, c0, c1, a0, ar, ac, slack):  # pragma: no cover
    """Whether segment ``k`` (row, column of both ends; NaN: not in front of the eye)
    meets the closed rectangle rows ``r0..r1``, columns ``c0..c1`` where
    ``a0 + ar row + ac col >= -slack`` (a side of a line, ``(ar, ac)`` of unit length)."""
    ra = segments[k, 0]
    ca = segments[k, 1]
    rb = segments[k, 2]
    cb = segments[k, 3]
    if not (ra == ra):
        return False
    dr = rb - ra
    dc = cb - ca
    t0, t1 = _in_rectangle(ra, ca, dr, dc, r0, r1, c0, c1)
    t0, t1 = _clip(-(ar * dr + ac * dc), a0 + ar * ra + ac * ca + slack, t0, t1)
    return t0 <= t1


@njit_cached()
def region_creases(depth, facet, region, stride, region_plane, region_ok, segments,
                   seg_start, seg3d, xs, ys, hx, hy, eye, r, u, f, tol, on_tol, margin, slack):
    """Fill the pixels still without depth whose rays all meet a coplanar region behind
    whatever a corner hits first (a pillar's silhouette against the wall behind it), or
    whose corners hit two coplanar regions that meet along a line through the pixel (a
    wall standing on a floor, two walls at a corner, with or without a shared edge).
    Returns the pixels filled.

    The background: every corner ray hits something, one of them first hits region
    ``R``, no boundary segment of ``R`` meets the pixel (widened by ``slack``), and all
    four corner rays meet ``R``'s plane in front of the eye. The rays meet the plane in a
    convex quadrilateral with a point of ``R`` at a corner; a point of it outside ``R``
    would put a boundary point of ``R`` inside it, whose image lies in the pixel. So
    every ray of the pixel meets ``R``, no farther than the largest distance to its plane
    at the corners (the coplanar rule of :func:`settle_tiles` with one corner in ``R``
    instead of four); the nearest such bound over the corners' regions is kept.

    A pixel qualifies when its four corner rays hit regions ``A`` and ``B`` (planes not
    parallel, the eye off both), the image of their planes' line ``L`` separates the
    corners that hit ``A`` from those that hit ``B``, and every boundary segment of
    ``A`` that meets ``A``'s side of the pixel, and of ``B`` that meets ``B``'s side
    (each widened by ``slack`` pixels; :func:`_crosses_side`), lies on ``L`` (both ends
    within ``on_tol`` of both planes). Then on each side of ``L``'s image the pixel's
    rays meet that side's region: the side is convex, a corner of it hits the region,
    and no boundary of the region crosses it; the distance to a plane over a convex
    set of directions is largest at a vertex, so the depth is the largest over the
    side's corners and the two points where ``L``'s image crosses the pixel's edges
    (the plane pushed by its slack; plus ``margin``).
    """
    h, w = depth.shape
    filled = 0
    cidx = np.empty(4, dtype=np.int64)
    cx = np.empty(4)
    cy = np.empty(4)
    side = np.empty(4)
    lab = np.empty(4, dtype=np.int64)
    for i in range(h):
        for j in range(w):
            if depth[i, j] < np.inf:
                continue
            # corners in order around the pixel: top-left, top-right, bottom-right,
            # bottom-left
            cidx[0] = i * stride + j
            cidx[1] = i * stride + j + 1
            cidx[2] = (i + 1) * stride + j + 1
            cidx[3] = (i + 1) * stride + j
            cx[0] = xs[j]
            cx[1] = xs[j + 1]
            cx[2] = xs[j + 1]
            cx[3] = xs[j]
            cy[0] = ys[i]
            cy[1] = ys[i]
            cy[2] = ys[i + 1]
            cy[3] = ys[i + 1]
            good = True
            for k in range(4):
                if facet[cidx[k]] < 0:  # a miss, or not cast
                    good = False
                    break
                lab[k] = region[cidx[k]]
            if not good:
                continue
            # a background: one region a corner hits, no boundary of it crossing the pixel
            best = np.inf
            for k in range(4):
                g = lab[k]
                if g < 0 or not region_ok[g] or (k > 0 and g == lab[0]) \
                        or (k > 1 and g == lab[1]) or (k > 2 and g == lab[2]):
                    continue
                t = 0.0
                for q in range(4):
                    t = max(t, _plane_distance(region_plane[g], eye, r, u, f, cx[q], cy[q]))
                if t < best and not _crosses(segments, seg_start[g], seg_start[g + 1],
                                             i - slack, i + 1 + slack, j - slack,
                                             j + 1 + slack):
                    best = t
            if best < np.inf:
                depth[i, j] = best + margin
                filled += 1
                continue
            for k in range(4):
                if lab[k] < 0 or not region_ok[lab[k]]:
                    good = False
            if not good:
                continue
            ga = lab[0]
            gb = -1
            for k in range(1, 4):
                if lab[k] != ga:
                    if gb < 0:
                        gb = lab[k]
                    elif lab[k] != gb:
                        good = False
            if not good or gb < 0:
                continue
            pa = region_plane[ga]
            pb = region_plane[gb]
            ha = pa[3] - (pa[0] * eye[0] + pa[1] * eye[1] + pa[2] * eye[2])
            hb = pb[3] - (pb[0] * eye[0] + pb[1] * eye[1] + pb[2] * eye[2])
            if abs(ha) <= tol or abs(hb) <= tol:
                continue
            cross = (pa[1] * pb[2] - pa[2] * pb[1]) ** 2 + (pa[2] * pb[0] - pa[0] * pb[2]) ** 2 \
                + (pa[0] * pb[1] - pa[1] * pb[0]) ** 2
            if cross < 1e-12:
                continue
            # the plane through the eye and L: m . d = 0 where both planes are as far
            m0 = ha * pb[0] - hb * pa[0]
            m1 = ha * pb[1] - hb * pa[1]
            m2 = ha * pb[2] - hb * pa[2]
            sa = 0.0  # the sign of A's side
            for k in range(4):
                d0 = f[0] + cx[k] * r[0] + cy[k] * u[0]
                d1 = f[1] + cx[k] * r[1] + cy[k] * u[1]
                d2 = f[2] + cx[k] * r[2] + cy[k] * u[2]
                side[k] = m0 * d0 + m1 * d1 + m2 * d2
                if side[k] == 0.0:
                    good = False
                    break
                sg = 1.0 if side[k] > 0 else -1.0
                want = sg if lab[k] == ga else -sg
                if sa == 0.0:
                    sa = want
                elif want != sa:
                    good = False
                    break
            if not good:
                continue
            # L's image on the buffer, as a distance in pixels from it, positive on A's side
            mr = m0 * r[0] + m1 * r[1] + m2 * r[2]
            mu = m0 * u[0] + m1 * u[1] + m2 * u[2]
            mf = m0 * f[0] + m1 * f[1] + m2 * f[2]
            ac = sa * mr * 2.0 * hx / w
            ar = -sa * mu * 2.0 * hy / h
            a0 = sa * (mf - mr * hx + mu * hy)
            norm = math.sqrt(ac * ac + ar * ar)
            if not norm > 0.0:
                continue
            # every boundary segment of A meeting A's side of the pixel, and of B meeting
            # B's side, lies on L
            for g in (ga, gb):
                sg = 1.0 if g == ga else -1.0
                for s in range(seg_start[g], seg_start[g + 1]):
                    if not _crosses_side(segments, s, i - slack, i + 1 + slack, j - slack,
                                         j + 1 + slack, sg * a0 / norm, sg * ar / norm,
                                         sg * ac / norm, slack):
                        continue
                    for e in range(2):
                        p0 = seg3d[s, e, 0]
                        p1 = seg3d[s, e, 1]
                        p2 = seg3d[s, e, 2]
                        if abs(pa[0] * p0 + pa[1] * p1 + pa[2] * p2 - pa[3]) > on_tol \
                                or abs(pb[0] * p0 + pb[1] * p1 + pb[2] * p2 - pb[3]) > on_tol:
                            good = False
                    if not good:
                        break
                if not good:
                    break
            if not good:
                continue
            t = 0.0
            for k in range(4):
                pl = pa if lab[k] == ga else pb
                t = max(t, _plane_distance(pl, eye, r, u, f, cx[k], cy[k]))
                n = (k + 1) % 4
                if (side[k] > 0) != (side[n] > 0):  # L's image crosses this edge
                    lam = side[k] / (side[k] - side[n])
                    x = cx[k] + lam * (cx[n] - cx[k])
                    y = cy[k] + lam * (cy[n] - cy[k])
                    t = max(t, max(_plane_distance(pa, eye, r, u, f, x, y),
                                   _plane_distance(pb, eye, r, u, f, x, y)))
            if t < np.inf:
                depth[i, j] = t + margin
                filled += 1
    return filled


#: Widening of a pixel square, in buffer pixels, when testing whether a triangle's
#: projection touches it (:func:`_triangle_hidden`): the projection is computed in
#: float64, so a triangle grazing a pixel is counted as touching it.
TOUCH_SLACK = 1e-6

#: Relative shrink of a triangle's per-pixel depth bound against the float rounding of
#: its plane's inverse depth (kept only where the plane's offset is well conditioned,
#: :data:`PLANE_CONDITION`).
DEPTH_SHRINK = 1.0 - 1e-9

#: A triangle's plane bounds its depth over a pixel only when its offset from the eye is
#: at least this fraction of (normal length x distance of a vertex): a plane nearly
#: through the eye (seen edge-on) falls back on the triangle's least forward depth.
PLANE_CONDITION = 1e-6


@njit_cached()
def _side(k, ax, ay, x, y, z):  # pragma: no cover
    """Value of widened view-pyramid side plane ``k`` (0: right, 1: left, 2: top,
    3: bottom) at camera point (x, y, z): >= 0 inside."""
    if k == 0:
        return ax * z - x
    if k == 1:
        return ax * z + x
    if k == 2:
        return ay * z - y
    return ay * z + y


@njit_cached()
def _clip_to_pyramid(ax, ay, px, py, pz, qx, qy, qz, n):  # pragma: no cover
    """Clip the convex polygon ``(px, py, pz)[:n]`` (camera coordinates) to the four side
    planes of the view pyramid widened to half-extents ``ax``, ``ay`` (Sutherland-Hodgman,
    ``qx, qy, qz`` scratch); the clipped polygon is left in ``px, py, pz``. Returns its
    vertex count, 0 when nothing of it lies inside."""
    for side in range(4):
        out = 0
        for m in range(n):
            e = m + 1 if m + 1 < n else 0
            g0 = _side(side, ax, ay, px[m], py[m], pz[m])
            g1 = _side(side, ax, ay, px[e], py[e], pz[e])
            if g0 >= 0.0:
                qx[out] = px[m]
                qy[out] = py[m]
                qz[out] = pz[m]
                out += 1
            if (g0 >= 0.0) != (g1 >= 0.0):
                t = g0 / (g0 - g1)
                qx[out] = px[m] + t * (px[e] - px[m])
                qy[out] = py[m] + t * (py[e] - py[m])
                qz[out] = pz[m] + t * (pz[e] - pz[m])
                out += 1
        n = out
        if n == 0:
            return 0
        for m in range(n):
            px[m] = qx[m]
            py[m] = qy[m]
            pz[m] = qz[m]
    return n


@njit_cached()
def _camera_triangle(tri, k, eye, r, u, f, px, py, pz):  # pragma: no cover
    """Triangle ``k`` of ``tri`` (m, 3, 3) in camera coordinates (along ``r``, ``u``, ``f``
    from ``eye``) into ``px``, ``py``, ``pz`` [0:3]."""
    for m in range(3):
        dx = tri[k, m, 0] - eye[0]
        dy = tri[k, m, 1] - eye[1]
        dz = tri[k, m, 2] - eye[2]
        px[m] = dx * r[0] + dy * r[1] + dz * r[2]
        py[m] = dx * u[0] + dy * u[1] + dz * u[2]
        pz[m] = dx * f[0] + dy * f[1] + dz * f[2]


@njit_cached()
def _outside_an_edge(sc, sr, n, orient, c0, r0, c1, r1):  # pragma: no cover
    """Whether the rectangle [c0, c1] x [r0, r1] lies wholly outside one edge of the convex
    polygon ``(sc, sr)[:n]`` (screen coordinates; ``orient`` the sign of its doubled area),
    by more than :data:`TOUCH_SLACK` times the edge's length: a separating axis."""
    for m in range(n):
        e = m + 1 if m + 1 < n else 0
        ex = sc[e] - sc[m]
        ey = sr[e] - sr[m]
        reach = TOUCH_SLACK * math.sqrt(ex * ex + ey * ey)
        apart = True
        for y in (r0, r1):
            for x in (c0, c1):
                if orient * (ex * (y - sr[m]) - ey * (x - sc[m])) >= -reach:
                    apart = False
        if apart:
            return True
    return False


@njit_cached()
def _triangle_hidden(tri, k, eye, r, u, f, hx, hy, depth, plane, px, py, pz, qx, qy, qz,
                     sc, sr, rec, nrec):  # pragma: no cover
    """Whether no ray of the buffer's screen meets triangle ``k`` of ``tri`` (m, 3, 3)
    nearer than the buffer's depth: its part in the view pyramid (clipped to the four
    side planes widened by :data:`PYRAMID_SLACK`) is empty, or every buffer pixel that
    part's projection may touch holds a depth nearer than a lower bound of the triangle's
    distance along any ray through the pixel, or is covered by one plane (``plane``,
    :func:`_fill`) that the whole clipped part lies behind. ``px`` ... ``sr`` are scratch
    arrays of at least 8 entries.

    ``rec`` (L, 3) int64 and ``nrec`` (1,) int64: with ``L > 0``, a pixel that fails is
    listed as ``(k, row, column)`` at ``rec[nrec[0]]`` (``nrec[0]`` then grows) instead
    of answering False, while there is room; the answer True then means hidden in every
    pixel not listed (the listed ones are left to the cover rule of
    :mod:`viscore.culling._occludee_cover`)."""
    h, w = depth.shape
    _camera_triangle(tri, k, eye, r, u, f, px, py, pz)
    # the plane in camera coordinates, before clipping: n . p = c
    e1x, e1y, e1z = px[1] - px[0], py[1] - py[0], pz[1] - pz[0]
    e2x, e2y, e2z = px[2] - px[0], py[2] - py[0], pz[2] - pz[0]
    nx = e1y * e2z - e1z * e2y
    ny = e1z * e2x - e1x * e2z
    nz = e1x * e2y - e1y * e2x
    c = nx * px[0] + ny * py[0] + nz * pz[0]
    scale = math.sqrt(nx * nx + ny * ny + nz * nz) \
        * math.sqrt(px[0] * px[0] + py[0] * py[0] + pz[0] * pz[0])
    use_plane = abs(c) > PLANE_CONDITION * scale
    ax = hx * (1.0 + PYRAMID_SLACK)
    ay = hy * (1.0 + PYRAMID_SLACK)
    n = _clip_to_pyramid(ax, ay, px, py, pz, qx, qy, qz, 3)
    if n == 0:
        return True  # wholly outside the view pyramid: no ray of the screen meets it
    zmin = np.inf
    for m in range(n):
        zmin = min(zmin, pz[m])
    if not zmin > 0.0:
        return False  # reaches the eye
    cmin = np.inf
    cmax = -np.inf
    rmin = np.inf
    rmax = -np.inf
    for m in range(n):
        sc[m] = (px[m] / pz[m] * (0.5 / hx) + 0.5) * w
        sr[m] = (0.5 - py[m] / pz[m] * (0.5 / hy)) * h
        cmin = min(cmin, sc[m])
        cmax = max(cmax, sc[m])
        rmin = min(rmin, sr[m])
        rmax = max(rmax, sr[m])
    c0 = max(math.floor(cmin - TOUCH_SLACK), 0)
    c1 = min(math.floor(cmax + TOUCH_SLACK), w - 1)
    r0 = max(math.floor(rmin - TOUCH_SLACK), 0)
    r1 = min(math.floor(rmax + TOUCH_SLACK), h - 1)
    area = 0.0
    for m in range(n):
        e = m + 1 if m + 1 < n else 0
        area += sc[m] * sr[e] - sc[e] * sr[m]
    orient = 1.0 if area > 0.0 else -1.0
    edges = abs(area) > TOUCH_SLACK  # a sliver seen edge-on touches its whole rectangle
    zlow = zmin * DEPTH_SHRINK
    for i in range(r0, r1 + 1):
        yb = _nearest_to_centre(i, h, hy)
        for j in range(c0, c1 + 1):
            # separating axis: an edge of the polygon with the square outside
            if edges and _outside_an_edge(sc, sr, n, orient, j, i, j + 1, i + 1):
                continue
            zb = zlow
            if use_plane:  # 1/z is affine on the screen: its largest over the square
                inv = -np.inf
                for a in range(2):
                    y = (0.5 - (i + a) / h) * 2.0 * hy
                    for b in range(2):
                        x = ((j + b) / w - 0.5) * 2.0 * hx
                        inv = max(inv, (nx * x + ny * y + nz) / c)
                if inv > 0.0:
                    zb = max(zb, DEPTH_SHRINK / inv)
            xb = _nearest_to_centre(j, w, hx)
            bound = zb * math.sqrt(1.0 + xb * xb + yb * yb) * SEC_SHRINK
            if not depth[i, j] < bound:
                # every ray through the pixel meets the covering plane (within one piece
                # of it) before the part, which lies wholly behind it: a point that is
                # behind the plane everywhere is behind it in this pixel too
                tau = plane[i, j, 3]
                behind = tau < np.inf
                if behind:
                    for m in range(n):
                        if not plane[i, j, 0] * px[m] + plane[i, j, 1] * py[m] \
                                + plane[i, j, 2] * pz[m] >= tau:
                            behind = False
                            break
                if not behind:
                    if nrec[0] >= rec.shape[0]:
                        return False
                    rec[nrec[0], 0] = k
                    rec[nrec[0], 1] = i
                    rec[nrec[0], 2] = j
                    nrec[0] += 1
    return True


@njit_cached()
def occluded_triangles(tri, start, eye, r, u, f, hx, hy, depth, plane, out, rec, rec_start):
    """Set ``out[g]`` for the groups of triangles (``tri[start[g]:start[g + 1]]``) of which
    every triangle is hidden in the buffer (:func:`_triangle_hidden`); a group stops at its
    first triangle that is not.

    ``rec`` (L, 3) int64 and ``rec_start`` (g + 1,) int64: with ``L > 0``, up to
    ``L // g`` failing pixels per group are listed (:func:`_triangle_hidden`) as
    ``rec[rec_start[g]:rec_start[g + 1]]``, and ``out[g]`` is True when every other
    pixel passes; with ``L == 0`` nothing is listed."""
    px = np.empty(8)
    py = np.empty(8)
    pz = np.empty(8)
    qx = np.empty(8)
    qy = np.empty(8)
    qz = np.empty(8)
    sc = np.empty(8)
    sr = np.empty(8)
    groups = start.shape[0] - 1
    per = rec.shape[0] // max(groups, 1)
    nrec = np.zeros(1, dtype=np.int64)
    for g in range(groups):
        hidden = True
        rec_start[g] = nrec[0]
        room = rec[rec_start[g]:rec_start[g] + per]
        nrec[0] = 0
        for k in range(start[g], start[g + 1]):
            if not _triangle_hidden(tri, k, eye, r, u, f, hx, hy, depth, plane, px, py,
                                    pz, qx, qy, qz, sc, sr, room, nrec):
                hidden = False
                break
        nrec[0] = rec_start[g] + (nrec[0] if hidden else 0)
        out[g] = hidden
    rec_start[groups] = nrec[0]
