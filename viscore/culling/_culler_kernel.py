"""numba kernels of the shadow-frustum culling runtime: one frame's frusta, and the box test.

The frusta of Papaioannou et al. 2006 [1]_, sec. 2, and the planar frusta of
Hudson et al. 1997 [2]_, built and tested in compiled loops.

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006, Plzen, UNION Agency - Science
   Press, ISBN 80-86943-03-8.
.. [2] Hudson, T., Manocha, D., Cohen, J., Lin, M., Hoff, K., Zhang, H.
   "Accelerated Occlusion Culling using Shadow Frusta". 13th ACM Symposium on
   Computational Geometry, 1997, pp. 1-10.
"""

from __future__ import annotations

import numpy as np

from .._jit import njit_cached

__all__ = ["select_occluders", "top_k", "frame_planes", "boxes_inside_any"]


@njit_cached()
def top_k(rank, k):
    """Indices of the ``k`` largest of ``rank`` (n,), best first, ties by index (as a
    stable sort of ``-rank``), leaving out NaN and ``-inf``."""
    idx = np.empty(k, dtype=np.int64)
    val = np.empty(k)
    count = 0
    for i in range(len(rank)):
        v = rank[i]
        if not v > -np.inf:  # -inf or NaN
            continue
        if count == k:
            if not v > val[k - 1]:
                continue
            pos = k - 1
        else:
            pos = count
            count += 1
        while pos > 0 and val[pos - 1] < v:  # after every equal or better one
            idx[pos], val[pos] = idx[pos - 1], val[pos - 1]
            pos -= 1
        idx[pos], val[pos] = i, v
    return idx[:count]


@njit_cached()
def _in_view(vn, vd, c, i, neg_radius):
    """Sphere (centre c[i], radius -neg_radius[i]) not wholly outside one view plane."""
    for j in range(4):
        if not (c[i, 0] * vn[j, 0] + c[i, 1] * vn[j, 1] + c[i, 2] * vn[j, 2]) + vd[j] \
                >= neg_radius[i]:
            return False
    return True


@njit_cached()
def _planar_score(eye, neg_area, normal, centroid, i):
    """-A N.V / |V|^2 (eq. 3), V from the eye to the centroid (NaN or inf on it)."""
    vx, vy, vz = centroid[i, 0] - eye[0], centroid[i, 1] - eye[1], centroid[i, 2] - eye[2]
    return neg_area[i] * (normal[i, 0] * vx + normal[i, 1] * vy + normal[i, 2] * vz) \
        / (vx * vx + vy * vy + vz * vz)


@njit_cached(error_model="numpy")
def select_occluders(eye, has_view, forward, right, up, half_x, half_y, kind, active,
                     s_volume, s_centroid, s_neg_radius, f_neg_area, f_normal, f_centroid,
                     f_neg_radius, face_start, e_neg_area, e_normal, e_centroid,
                     e_neg_radius):
    """The frame's active set: the ``active`` best of the primary occluders and the extra
    polygons, best first, as (primary (a,) int64, extra (b,) int64).

    ``kind`` 0: the solids by eq. 4, Vol / |V|^3; 1: the solids by their best face
    (``face_start`` (s + 1,)); 2: the faces by eq. 3; extra polygons by |eq. 3|. An
    occluder whose bounding sphere lies wholly outside one of the view's four side
    planes (``has_view``; camera basis and tangents of the half angles) ranks -inf and
    is never chosen; so are NaN ranks.
    """
    vn = np.empty((4, 3))
    vd = np.empty(4)
    for j in range(4):
        h = half_x if j < 2 else half_y
        side = right if j < 2 else up
        sgn = -1.0 if j % 2 == 0 else 1.0
        nx = h * forward[0] + sgn * side[0]
        ny = h * forward[1] + sgn * side[1]
        nz = h * forward[2] + sgn * side[2]
        norm = np.sqrt(nx * nx + ny * ny + nz * nz)
        vn[j, 0], vn[j, 1], vn[j, 2] = nx / norm, ny / norm, nz / norm
        vd[j] = -(vn[j, 0] * eye[0] + vn[j, 1] * eye[1] + vn[j, 2] * eye[2])
    n_first = len(s_volume) if kind < 2 else len(f_neg_area)
    rank = np.empty(n_first + len(e_neg_area))
    if kind == 0:
        for i in range(n_first):
            dx = s_centroid[i, 0] - eye[0]
            dy = s_centroid[i, 1] - eye[1]
            dz = s_centroid[i, 2] - eye[2]
            dist = np.sqrt(dx * dx + dy * dy + dz * dz)
            r = s_volume[i] / dist ** 3.0
            if has_view and not _in_view(vn, vd, s_centroid, i, s_neg_radius):
                r = -np.inf
            rank[i] = r
    elif kind == 1:
        for i in range(n_first):
            best = -np.inf
            for q in range(face_start[i], face_start[i + 1]):
                r = _planar_score(eye, f_neg_area, f_normal, f_centroid, q)
                if has_view and not _in_view(vn, vd, f_centroid, q, f_neg_radius):
                    r = -np.inf
                if np.isnan(r) or np.isnan(best):
                    best = np.nan
                elif r > best:
                    best = r
            rank[i] = best
    else:
        for i in range(n_first):
            r = _planar_score(eye, f_neg_area, f_normal, f_centroid, i)
            if has_view and not _in_view(vn, vd, f_centroid, i, f_neg_radius):
                r = -np.inf
            rank[i] = r
    for i in range(len(e_neg_area)):
        r = abs(_planar_score(eye, e_neg_area, e_normal, e_centroid, i))
        if has_view and not _in_view(vn, vd, e_centroid, i, e_neg_radius):
            r = -np.inf
        rank[n_first + i] = r
    order = top_k(rank, active)
    n_primary = 0
    for i in range(len(order)):
        n_primary += order[i] < n_first
    primary = np.empty(n_primary, dtype=np.int64)
    extra = np.empty(len(order) - n_primary, dtype=np.int64)
    a, b = 0, 0
    for i in range(len(order)):
        if order[i] < n_first:
            primary[a] = order[i]
            a += 1
        else:
            extra[b] = order[i] - n_first
            b += 1
    return primary, extra


@njit_cached()
def _side(ex, ey, ez, ax, ay, az, bx, by, bz, ix, iy, iz, tol):
    """Unit plane through the eye and edge (a, b), inward towards (ix, iy, iz); ok flag
    (``shadow_frusta._oriented_side_planes`` for one edge)."""
    ux, uy, uz = ax - ex, ay - ey, az - ez
    vx, vy, vz = bx - ex, by - ey, bz - ez
    nx = uy * vz - uz * vy
    ny = uz * vx - ux * vz
    nz = ux * vy - uy * vx
    norm = np.sqrt(nx * nx + ny * ny + nz * nz)
    ok = norm > tol
    if ok:
        nx, ny, nz = nx / norm, ny / norm, nz / norm
    d = -(nx * ex + ny * ey + nz * ez)
    side = nx * ix + ny * iy + nz * iz + d
    ok = ok and side != 0
    if side < 0:
        return ok, -nx, -ny, -nz, -d
    return ok, nx, ny, nz, d


@njit_cached()
def _polygon(eye, q, p_points, p_start, p_next, p_normal, p_offset, p_centroid, margin,
             tol_side, tol_height, planes, row):
    """Write the planar frustum of polygon ``q`` from ``row`` on; the next free row (``row``
    itself when the eye lies in its plane or on the line of an edge: no frustum)."""
    ex, ey, ez = eye[0], eye[1], eye[2]
    nx, ny, nz = p_normal[q, 0], p_normal[q, 1], p_normal[q, 2]
    h = (nx * ex + ny * ey + nz * ez) - p_offset[q]
    if not abs(h) > tol_height:
        return row
    ix, iy, iz = p_centroid[q, 0], p_centroid[q, 1], p_centroid[q, 2]
    r = row
    for j in range(p_start[q], p_start[q + 1]):
        k = p_next[j]
        ok, sx, sy, sz, sd = _side(ex, ey, ez, p_points[j, 0], p_points[j, 1], p_points[j, 2],
                                   p_points[k, 0], p_points[k, 1], p_points[k, 2],
                                   ix, iy, iz, tol_side)
        if not ok:
            return row
        planes[r, 0], planes[r, 1], planes[r, 2], planes[r, 3] = sx, sy, sz, sd - margin
        r += 1
    sign = -1.0 if h > 0 else 1.0  # inward: the far side of the plane from the eye
    planes[r, 0], planes[r, 1], planes[r, 2] = sign * nx, sign * ny, sign * nz
    planes[r, 3] = -sign * p_offset[q] - margin
    return r + 1


@njit_cached()
def frame_planes(eye, sel_s, sel_p, s_vertices, s_normals, s_offset, s_face_start, s_edge_a,
                 s_edge_b, s_edge_face, s_twin_face, s_centroid, s_held_start, p_points,
                 p_start, p_next, p_normal, p_offset, p_centroid, front_caps, margin,
                 tol_side, tol_height):
    """The frame's frusta: planes (P, 4) grouped by frustum, and offsets (K + 1,) int64.

    ``sel_s``: selected solids (a solid holding the eye gives the planar frusta
    of its faces, polygons ``s_held_start[s]:s_held_start[s + 1]``);
    ``sel_p``: selected polygons. ``front_caps``: cap solids with their front
    faces' planes instead of the eq. 2 plane. ``margin`` is subtracted from
    every plane's ``d``.
    """
    ex, ey, ez = eye[0], eye[1], eye[2]
    bound, most = 0, 1
    for t in range(len(sel_s)):
        nf = s_face_start[sel_s[t] + 1] - s_face_start[sel_s[t]]
        bound += 4 * nf  # sides <= 3 nf and caps <= nf; a held solid's faces likewise
        most = max(most, nf)
    for t in range(len(sel_p)):
        bound += p_start[sel_p[t] + 1] - p_start[sel_p[t]] + 1
    planes = np.empty((bound, 4))
    start = np.zeros(len(sel_s) * most + len(sel_p) + 1, dtype=np.int64)
    front = np.zeros(most, dtype=np.bool_)
    sil = np.empty(3 * most, dtype=np.int64)
    row, k = 0, 0
    for t in range(len(sel_s)):
        s = sel_s[t]
        f0, f1 = s_face_start[s], s_face_start[s + 1]
        seen = 0
        for f in range(f0, f1):
            fr = (s_normals[f, 0] * ex + s_normals[f, 1] * ey + s_normals[f, 2] * ez) \
                - s_offset[f] > 0
            front[f - f0] = fr
            seen += fr
        if seen == 0:  # the eye inside the solid: its faces hide what lies beyond them
            for q in range(s_held_start[s], s_held_start[s + 1]):
                nxt = _polygon(eye, q, p_points, p_start, p_next, p_normal, p_offset,
                               p_centroid, margin, tol_side, tol_height, planes, row)
                if nxt > row:
                    row = nxt
                    k += 1
                    start[k] = row
            continue
        ix, iy, iz = s_centroid[s, 0], s_centroid[s, 1], s_centroid[s, 2]
        r, n_sil, valid = row, 0, True
        mx, my, mz = 0.0, 0.0, 0.0
        for e in range(3 * f0, 3 * f1):  # eq. 1: a front face's edge whose twin is not
            if front[s_edge_face[e] - f0] and not front[s_twin_face[e] - f0]:
                a, b = s_edge_a[e], s_edge_b[e]
                ax, ay, az = s_vertices[a, 0], s_vertices[a, 1], s_vertices[a, 2]
                ok, sx, sy, sz, sd = _side(ex, ey, ez, ax, ay, az, s_vertices[b, 0],
                                           s_vertices[b, 1], s_vertices[b, 2], ix, iy, iz,
                                           tol_side)
                if not ok:
                    valid = False
                    break
                planes[r, 0], planes[r, 1], planes[r, 2], planes[r, 3] = sx, sy, sz, sd - margin
                r += 1
                mx += ax - ex
                my += ay - ey
                mz += az - ez
                sil[n_sil] = a
                n_sil += 1
        if not valid or n_sil == 0:
            continue
        mn = np.sqrt(mx * mx + my * my + mz * mz)
        if not mn > 0:
            continue
        mx, my, mz = mx / mn, my / mn, mz / mn
        if front_caps:  # the planes of the front faces, facing away from the eye
            for f in range(f0, f1):
                if front[f - f0]:
                    planes[r, 0], planes[r, 1] = -s_normals[f, 0], -s_normals[f, 1]
                    planes[r, 2], planes[r, 3] = -s_normals[f, 2], s_offset[f] - margin
                    r += 1
        else:  # eq. 2 through the silhouette point furthest along its normal (last of ties)
            best = -np.inf
            fx, fy, fz = 0.0, 0.0, 0.0
            for j in range(n_sil):
                a = sil[j]
                along = s_vertices[a, 0] * mx + s_vertices[a, 1] * my + s_vertices[a, 2] * mz
                if j == 0 or along >= best:
                    best = along
                    fx, fy, fz = s_vertices[a, 0], s_vertices[a, 1], s_vertices[a, 2]
            planes[r, 0], planes[r, 1], planes[r, 2] = mx, my, mz
            planes[r, 3] = -(mx * fx + my * fy + mz * fz) - margin
            r += 1
        row = r
        k += 1
        start[k] = row
    for t in range(len(sel_p)):
        nxt = _polygon(eye, sel_p[t], p_points, p_start, p_next, p_normal, p_offset,
                       p_centroid, margin, tol_side, tol_height, planes, row)
        if nxt > row:
            row = nxt
            k += 1
            start[k] = row
    return planes[:row], start[:k + 1]


@njit_cached()
def boxes_inside_any(planes, start, lo, hi, out):
    """``out[i]``: box i lies wholly inside one frustum (every plane of it: the box corner
    furthest outside each plane, c.n + d - h.|n| >= 0). False when a box is not finite or
    inverted (out is then unfinished: the caller raises)."""
    k = len(start) - 1
    for i in range(len(lo)):
        l0, l1, l2 = lo[i, 0], lo[i, 1], lo[i, 2]
        u0, u1, u2 = hi[i, 0], hi[i, 1], hi[i, 2]
        if not (l0 <= u0 and l1 <= u1 and l2 <= u2):
            return False
        if not (np.isfinite(l0) and np.isfinite(l1) and np.isfinite(l2)
                and np.isfinite(u0) and np.isfinite(u1) and np.isfinite(u2)):
            return False
        c0, c1, c2 = 0.5 * (l0 + u0), 0.5 * (l1 + u1), 0.5 * (l2 + u2)
        h0, h1, h2 = 0.5 * (u0 - l0), 0.5 * (u1 - l1), 0.5 * (u2 - l2)
        hit = False
        for j in range(k):
            inside = True
            for p in range(start[j], start[j + 1]):
                n0, n1, n2 = planes[p, 0], planes[p, 1], planes[p, 2]
                w = (c0 * n0 + c1 * n1 + c2 * n2) - (h0 * abs(n0) + h1 * abs(n1)
                                                     + h2 * abs(n2)) + planes[p, 3]
                if not w >= 0:
                    inside = False
                    break
            if inside:
                hit = True
                break
        out[i] = hit
    return True
