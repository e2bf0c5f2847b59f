"""Height-field patches of occluder triangles for the conservative depth buffer's crease rule."""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit_cached
from ._sheets import corner_distance
from .shadow_frusta import _cross

__all__ = ["height_field_patches", "flat_pairs", "patch_frame", "INJECTIVE_TOLERANCE"]

#: Relative gap allowed between the sum of a patch's projected triangle areas and the
#: area of their union (shapely), for the projection to count as one-to-one; at most a
#: millionth of the patch's smallest projected triangle.
INJECTIVE_TOLERANCE = 1e-9
#: Least ``|cos|`` of the angle between a patch triangle's normal and the patch's axis
#: (about 78 degrees from it at most): steeper triangles are left out of patches.
MIN_FACING = 0.2
#: Relative size under which the side of a vertex from the plane through the eye and
#: an edge counts as none (the edge is then a boundary edge).
SIDE_TOLERANCE = 1e-12
#: Planes of two triangles agree (one flat) to this fraction of the scene's size.
FLAT_TOLERANCE = 1e-11


def height_field_patches(vertices: np.ndarray, faces: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Patch of each triangle (-1: none) and the patches' edges.

    Axes are tried by the area the triangles' projections cover along them,
    largest first (x, y, z on a tie): the triangles not in a patch yet
    that face one way along the axis (within :data:`MIN_FACING`) are joined across edges
    they share with exactly one other such triangle (vertices joined by exact
    coordinates), and each connected set of two or more triangles whose
    projections have disjoint interiors, and that is not planar (a planar
    one is a coplanar region's), becomes a patch. A set that fails loses its
    triangles that overlap another in projection (a fold) and is joined and
    tested once more.

    Returns
    -------
    patch : (n,) int64
    edges : (m, 5) int64
        Per edge of a patch: its two vertices, then the third vertex of each
        patch triangle on it (the second -1 for an edge with one patch
        triangle: a boundary edge), then the patch.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    patch = np.full(len(f), -1, dtype=np.int64)
    if len(f) < 2:
        return patch, np.zeros((0, 5), dtype=np.int64)
    _, vid = np.unique(v, axis=0, return_inverse=True)
    vid = vid.reshape(-1)
    fid = vid[f]
    tri = v[f]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    size = np.linalg.norm(normal, axis=1)
    count = 0
    # the axis the sheet faces most first: along another one a terrain folds into
    # fragments that would take its triangles
    for axis in np.argsort(-np.abs(normal).sum(axis=0), kind="stable"):
        keep = np.delete([0, 1, 2], axis)
        # steep triangles stay out: a triangle almost edge-on along the axis covers
        # almost no area there, so the area test could not tell it pierces the sheet
        free = (patch < 0) & (np.abs(normal[:, axis]) >= MIN_FACING * size)
        # triangles facing one way along the axis (a solid's top, its bottom) are joined
        # apart; a fold shows as triangles overlapping in projection: those are left out,
        # and what remains is joined and tested again
        avail = [np.flatnonzero(free & (normal[:, axis] > 0)),
                 np.flatnonzero(free & (normal[:, axis] < 0))]
        for _ in range(2):
            members_of = [m for part in avail for m in _components(fid, part)]
            avail = []
            for members in members_of:
                unit = normal[members] / size[members, None]
                if np.abs(unit @ unit[0]).min() > 1.0 - 1e-12:  # planar: regions do it
                    continue
                flat = tri[members][:, :, keep]
                if _one_to_one(flat, 0.5 * np.abs(normal[members, axis])):
                    patch[members] = count
                    count += 1
                else:
                    avail.append(members[~_overlapping(flat)])
    return patch, _patch_edges(f, fid, patch)


def flat_pairs(vertices: np.ndarray, faces: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Planar flats and the pairs of them that meet at a crease (a wall and the floor).

    A *flat* is a set of two or more triangles connected through edges (vertices joined
    by exact coordinates) lying in one plane (normals and offsets within
    :data:`FLAT_TOLERANCE` of the scene's size, either orientation). Two flats that
    share an edge make a *pair* when each is one layer in its plane (the test of
    :func:`height_field_patches`) and, along one of the two bisectors of their normals
    (``n_a + n_b``, ``n_a - n_b``), both face the direction within :data:`MIN_FACING`
    and their projections along it have disjoint interiors (:func:`_separated`): the
    pair is then the graph of a function over the plane
    across that direction, so it never meets itself, and the crease rule of the
    module docstring holds for it as for a terrain's patch (its proof asks no more of
    a patch than to be such a graph, along any direction). A pixel whose four corner
    rays first hit the two flats of a pair is covered by the rule with the pair as its
    patch.

    Returns
    -------
    flat : (f,) int64
        The flat of each triangle, -1 for none.
    pairs : (P,) int64
        The pairs, sorted, each as ``a * F + b`` for its flats ``a < b`` (``F`` the
        number of flats).
    edges : (m, 6) int64
        The edges of the flats that are not inside one: its two vertices, the
        third vertex of each triangle on it (the second -1 for a boundary edge: one
        triangle, three or more, or two that make no pair), then the flats on either
        side (-1 for none).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    none = (np.full(len(f), -1, dtype=np.int64), np.zeros(0, dtype=np.int64),
            np.zeros((0, 6), dtype=np.int64))
    if len(f) < 4:
        return none
    _, vid = np.unique(v, axis=0, return_inverse=True)
    fid = vid.reshape(-1)[f]
    tri = v[f]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    size = np.linalg.norm(normal, axis=1)
    ok = size > 0
    unit = normal / np.where(ok, size, 1.0)[:, None]
    offset = np.einsum("ij,ij->i", unit, tri[:, 0])
    scale = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))) or 1.0
    # every use of every edge, grouped by edge (vertex ids)
    n = len(f)
    rows = [np.stack([f[:, a], f[:, b], f[:, c], fid[:, a], fid[:, b], np.arange(n)], axis=1)
            for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1))]
    e = np.concatenate(rows)
    key = np.stack([np.minimum(e[:, 3], e[:, 4]), np.maximum(e[:, 3], e[:, 4])], axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    order = np.argsort(inverse, kind="stable")
    e, inverse = e[order], inverse[order]
    two = counts[inverse] == 2
    first = np.r_[True, inverse[1:] != inverse[:-1]]
    pos = np.flatnonzero(two & first)  # the first use of each edge of two triangles
    ta, tb = e[pos, 5], e[pos + 1, 5]
    dot = np.einsum("ij,ij->i", unit[ta], unit[tb])
    sign = np.where(dot < 0, -1.0, 1.0)
    same = ok[ta] & ok[tb] & (np.abs(dot) >= 1.0 - FLAT_TOLERANCE) \
        & (np.abs(offset[ta] - sign * offset[tb]) <= FLAT_TOLERANCE * scale)
    graph = coo_matrix((np.ones(int(same.sum())), (ta[same], tb[same])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    big = (np.bincount(label) >= 2)[label] & ok
    flat = np.full(n, -1, dtype=np.int64)
    flat[big] = np.unique(label[big], return_inverse=True)[1].reshape(-1)
    nf = int(flat.max()) + 1 if big.any() else 0
    if nf < 2:
        return flat, none[1], none[2]
    # pairs: flats meeting at an edge of two triangles, a graph along a bisector
    fa, fb = flat[ta], flat[tb]
    meet = ~same & (fa >= 0) & (fb >= 0) & (fa != fb)
    pair_key = np.minimum(fa, fb) * nf + np.maximum(fa, fb)
    keys, where = np.unique(pair_key[meet], return_index=True)
    on_edge = e[pos[meet][where], 0]  # a vertex of a shared edge of each pair
    order = np.argsort(flat, kind="stable")
    bounds = np.searchsorted(flat[order], np.arange(nf + 1))
    members = [order[bounds[k]:bounds[k + 1]] for k in range(nf)]
    flat_normal = np.array([unit[m[np.argmax(size[m])]] for m in members])
    # whether each flat of a pair is one layer in its plane, all at once
    simple = np.zeros(nf, dtype=bool)
    tested = np.unique(np.concatenate([keys // nf, keys % nf]))
    simple[tested] = _one_layers([tri[members[g]] for g in tested], flat_normal[tested])
    good = np.zeros(len(keys), dtype=bool)
    for k, (key, vertex) in enumerate(zip(keys, on_edge, strict=True)):
        a_, b_ = int(key // nf), int(key % nf)
        if simple[a_] and simple[b_]:
            ta_, tb_ = tri[members[a_]], tri[members[b_]]
            good[k] = _separated(ta_, tb_, flat_normal[a_], flat_normal[b_], v[vertex], scale)
    pairs = keys[good]
    # the edges: a pair's crease (both third vertices), or a boundary of a flat
    crease = meet & np.isin(pair_key, pairs)
    out = [np.stack([e[pos, 0], e[pos, 1], e[pos, 2], e[pos + 1, 2], fa, fb], axis=1)[crease]]
    # the other uses of edges touching a flat, each a boundary edge of that flat (an edge
    # inside a flat is no boundary: its two triangles are one plane)
    inside = np.zeros(len(e), dtype=bool)
    inside[pos[same & (fa == fb)]] = True
    inside[pos[same & (fa == fb)] + 1] = True
    paired = np.zeros(len(e), dtype=bool)
    paired[pos[crease]] = True
    paired[pos[crease] + 1] = True
    rest = ~inside & ~paired & (flat[e[:, 5]] >= 0)
    out.append(np.stack([e[rest, 0], e[rest, 1], e[rest, 2], np.full(rest.sum(), -1),
                         flat[e[rest, 5]], np.full(rest.sum(), -1)], axis=1))
    return flat, pairs.astype(np.int64), np.concatenate(out).astype(np.int64)


def _one_to_one(flat: np.ndarray, projected: np.ndarray) -> bool:
    """Whether projected triangles ``flat`` (k, 3, 2) of areas ``projected`` have disjoint
    interiors: the area of their union (shapely) is the sum of theirs, up to a millionth
    of the smallest triangle (float noise of the union's area) and never more than
    :data:`INJECTIVE_TOLERANCE` of the whole."""
    import shapely

    return _disjoint(projected, shapely.union_all(shapely.polygons(flat)).area)


def _disjoint(projected: np.ndarray, union: float) -> bool:
    """The test of :func:`_one_to_one` on the triangles' areas and their union's."""
    area = projected.sum()
    return abs(union - area) <= min(INJECTIVE_TOLERANCE * area, 1e-6 * projected.min())


def _across(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit axes across the unit direction ``d``."""
    ax = _cross(d, np.eye(3)[int(np.argmin(np.abs(d)))])
    ax /= np.linalg.norm(ax)
    return ax, _cross(d, ax)


def _one_layers(tris: list[np.ndarray], normals: np.ndarray) -> np.ndarray:
    """Per planar set of triangles ``tris[k]`` ``(m_k, 3, 3)`` (unit normal ``normals[k]``),
    whether they have disjoint interiors in their plane (the test of
    :func:`height_field_patches`, along the normal). The same test as
    :func:`_one_to_one` on each, with the unions of the sets of one size taken in one
    shapely call (``union_all`` along an axis: the same union of each row)."""
    import shapely

    flats, areas = [], []
    for t, normal in zip(tris, normals, strict=True):  # a loop over flats, not rays
        ax, ay = _across(normal)
        flat = np.stack([t @ ax, t @ ay], axis=2)
        e1, e2 = flat[:, 1] - flat[:, 0], flat[:, 2] - flat[:, 0]
        flats.append(flat)
        areas.append(0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]))
    out = np.zeros(len(tris), dtype=bool)
    counts = np.array([len(t) for t in tris], dtype=np.int64)
    for m in np.unique(counts):  # a loop over set sizes
        which = np.flatnonzero(counts == m)
        polys = shapely.polygons(np.concatenate([flats[k] for k in which]))
        union = shapely.area(shapely.union_all(polys.reshape(len(which), m), axis=1))
        out[which] = [_disjoint(areas[k], float(a)) for k, a in zip(which, union, strict=True)]
    return out


def _separated(ta: np.ndarray, tb: np.ndarray, na: np.ndarray, nb: np.ndarray,
               point: np.ndarray, scale: float) -> bool:
    """Whether two planar flats (triangles ``ta``, ``tb``, unit normals ``na``, ``nb``),
    each one layer in its plane and meeting along the line of their planes through
    ``point``, are one graph along a bisector ``d`` of their normals: both face ``d``
    within :data:`MIN_FACING`, and their projections along ``d`` have disjoint
    interiors. The plane through the line along ``d`` has each flat mostly on one side
    of it, one on each; projected along ``d`` (which lies in that plane) a triangle keeps
    to its side of the line's image, so only the triangles reaching across the plane
    can meet the other flat's images: those pairs are intersected (shapely), each
    overlap allowed a millionth of the smaller triangle (float rounding)."""

    line = _cross(na, nb)
    if np.linalg.norm(line) == 0:
        return False
    line /= np.linalg.norm(line)
    tol = 1e-12 * scale
    for d in (na + nb, na - nb):
        d = d / np.linalg.norm(d)
        if min(abs(float(na @ d)), abs(float(nb @ d))) < MIN_FACING:
            continue
        m = _cross(d, line)
        sa, sb = (ta - point) @ m, (tb - point) @ m  # (k, 3) per vertex
        if sa.sum() > 0:  # a on the negative side, b on the positive
            sa, sb = -sa, -sb
        if sb.sum() <= 0:
            continue  # both on one side: this bisector folds them onto each other
        wrong_a = (sa > tol).any(axis=1)
        wrong_b = (sb < -tol).any(axis=1)
        if not wrong_a.any() and not wrong_b.any():
            return True
        ax, ay = _across(d)
        pa = np.stack([ta @ ax, ta @ ay], axis=2)
        pb = np.stack([tb @ ax, tb @ ay], axis=2)
        if _images_meet(pa[wrong_a], pb) or _images_meet(pa, pb[wrong_b]):
            continue
        return True
    return False


def _images_meet(p: np.ndarray, q: np.ndarray) -> bool:
    """Whether any of the 2D triangles ``p`` (k, 3, 2) overlaps any of ``q`` by more than a
    millionth of the smaller one's area."""
    import shapely

    if len(p) == 0 or len(q) == 0:
        return False
    lo_p, hi_p = p.min(axis=1), p.max(axis=1)
    lo_q, hi_q = q.min(axis=1), q.max(axis=1)
    i, j = np.nonzero(((lo_p[:, None] < hi_q[None]) & (lo_q[None] < hi_p[:, None])).all(axis=2))
    if len(i) == 0:
        return False
    a, b = shapely.polygons(p[i]), shapely.polygons(q[j])
    inter = shapely.area(shapely.intersection(a, b))
    return bool((inter > 1e-6 * np.minimum(shapely.area(a), shapely.area(b))).any())


def _components(fid: np.ndarray, avail: np.ndarray) -> list[np.ndarray]:
    """The triangles ``avail`` (indices into ``fid``) joined across the edges two of them
    share: each connected set of two or more, as indices into ``fid``."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    if len(avail) < 2:
        return []
    pairs = _edge_pairs(fid[avail])
    n = len(avail)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    k, label = connected_components(graph, directed=False)
    return [avail[label == c] for c in np.flatnonzero(np.bincount(label, minlength=k) >= 2)]


def _overlapping(flat: np.ndarray) -> np.ndarray:
    """(k,) bool: projected triangles ``flat`` (k, 3, 2) whose interior overlaps another's
    (an intersection of area over :data:`INJECTIVE_TOLERANCE` of the smaller)."""
    import shapely

    polys = shapely.polygons(flat)
    a, b = shapely.STRtree(polys).query(polys, predicate="intersects")
    pick = a < b
    a, b = a[pick], b[pick]
    inter = shapely.area(shapely.intersection(polys[a], polys[b]))
    small = np.minimum(shapely.area(polys[a]), shapely.area(polys[b]))
    bad = inter > INJECTIVE_TOLERANCE * np.maximum(small, 1e-300)
    out = np.zeros(len(flat), dtype=bool)
    out[a[bad]] = True
    out[b[bad]] = True
    return out


def _edge_pairs(fid: np.ndarray) -> np.ndarray:
    """(k, 2) triangles (rows of ``fid``) that share an edge no third triangle has."""
    n = len(fid)
    e = np.sort(np.stack([fid[:, [0, 1]], fid[:, [1, 2]], fid[:, [2, 0]]], axis=1), axis=2)
    e = e.reshape(-1, 2)
    owner = np.repeat(np.arange(n), 3)
    _, inverse, counts = np.unique(e, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    two = counts[inverse] == 2
    order = np.argsort(inverse[two], kind="stable")
    own = owner[two][order]
    return own.reshape(-1, 2)


def _patch_edges(f: np.ndarray, fid: np.ndarray, patch: np.ndarray) -> np.ndarray:
    """The (m, 5) edges of the patches (see :func:`height_field_patches`)."""
    inside = np.flatnonzero(patch >= 0)
    if len(inside) == 0:
        return np.zeros((0, 5), dtype=np.int64)
    rows = []
    for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        rows.append(np.stack([f[inside, a], f[inside, b], f[inside, c],
                              fid[inside, a], fid[inside, b], patch[inside]], axis=1))
    e = np.concatenate(rows)
    key = np.stack([np.minimum(e[:, 3], e[:, 4]), np.maximum(e[:, 3], e[:, 4]), e[:, 5]],
                   axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    order = np.argsort(inverse, kind="stable")
    e, inverse = e[order], inverse[order]
    first = np.r_[True, inverse[1:] != inverse[:-1]]
    start = np.flatnonzero(first)
    out = []
    for s in start:
        k = counts[inverse[s]]
        if k == 2:  # an edge inside the patch: both third vertices
            out.append([e[s, 0], e[s, 1], e[s, 2], e[s + 1, 2], e[s, 5]])
        else:  # the patch's border (or an edge of three or more): boundary, each time
            out.extend([e[s + j, 0], e[s + j, 1], e[s + j, 2], -1, e[s, 5]] for j in range(k))
    return np.asarray(out, dtype=np.int64).reshape(-1, 5)


@njit_cached()
def patch_frame(vert, edges, eye, r, u, f, hx, hy, w, h, z0, reach, slack, pa, pb,
                blocked, crease, disabled, corners, folds, fold_end):  # pragma: no cover
    """One frame's images of the patches' edges (see the module docstring).

    ``edges`` (m, 6): two vertices, the third vertex of each triangle on the
    edge (the second -1: a boundary edge), the patch (or flat) of each (the
    second -1 for none). ``pa``, ``pb`` (H, W): the patch of each pixel, as
    the two groups its corners hit (a patch: both the same; a pair of flats:
    both flats; -1: not a candidate). An edge matters to a pixel when one of
    its groups is one of the pixel's. Sets ``blocked[i, j]`` where such an
    edge's image meets pixel ``(i, j)`` widened by ``slack`` pixels, unless it
    is a crease of the pixel's patch (its groups are the pixel's two, and its
    triangles lie on either side of the plane through the eye and the edge);
    then raises ``crease[i, j]`` to the largest distance at the ends of its
    part within the pixel widened by ``slack``. Sets ``disabled[g]`` for a
    group with an edge within ``reach`` of the eye. Parts of edges nearer than
    ``z0`` along the view are cut off. With ``corners`` (the sheet rule of
    :mod:`viscore.culling._sheets`), a crease also raises ``crease[i, j]`` to the
    distance at each corner of the pixel whose ray passes through one of its two
    triangles, and a fold of the pixel's sheet (an edge of two of its triangles, both
    strictly on one side of the plane through the eye and the edge) does not block the
    pixel: it counts in ``folds[i, j]``, sets ``fold_end[i, j]`` when an end of its part
    within the widened pixel is an end of the edge (or of its part in front of ``z0``),
    and raises ``crease[i, j]`` as a crease does.
    """
    kx = 0.5 / hx
    ky = 0.5 / hy
    for k in range(edges.shape[0]):
        a0 = vert[edges[k, 0], 0] - eye[0]
        a1 = vert[edges[k, 0], 1] - eye[1]
        a2 = vert[edges[k, 0], 2] - eye[2]
        b0 = vert[edges[k, 1], 0] - eye[0]
        b1 = vert[edges[k, 1], 1] - eye[1]
        b2 = vert[edges[k, 1], 2] - eye[2]
        ax_ = a0 * r[0] + a1 * r[1] + a2 * r[2]
        ay_ = a0 * u[0] + a1 * u[1] + a2 * u[2]
        az_ = a0 * f[0] + a1 * f[1] + a2 * f[2]
        bx_ = b0 * r[0] + b1 * r[1] + b2 * r[2]
        by_ = b0 * u[0] + b1 * u[1] + b2 * u[2]
        bz_ = b0 * f[0] + b1 * f[1] + b2 * f[2]
        d0, d1, d2 = b0 - a0, b1 - a1, b2 - a2
        dd = d0 * d0 + d1 * d1 + d2 * d2
        t = 0.0 if dd == 0 else min(1.0, max(0.0, -(a0 * d0 + a1 * d1 + a2 * d2) / dd))
        c0, c1, c2 = a0 + t * d0, a1 + t * d1, a2 + t * d2
        ga, gb = edges[k, 4], edges[k, 5]
        if math.sqrt(c0 * c0 + c1 * c1 + c2 * c2) <= reach:
            disabled[ga] = True
            if gb >= 0:
                disabled[gb] = True
            continue
        is_crease = False
        is_fold = False
        if edges[k, 3] >= 0:
            nx = a1 * b2 - a2 * b1
            ny = a2 * b0 - a0 * b2
            nz = a0 * b1 - a1 * b0
            p0, p1, p2 = (vert[edges[k, 2], 0] - eye[0], vert[edges[k, 2], 1] - eye[1],
                          vert[edges[k, 2], 2] - eye[2])
            q0, q1, q2 = (vert[edges[k, 3], 0] - eye[0], vert[edges[k, 3], 1] - eye[1],
                          vert[edges[k, 3], 2] - eye[2])
            sp = nx * p0 + ny * p1 + nz * p2
            sq = nx * q0 + ny * q1 + nz * q2
            # a side within rounding of the plane counts as none: a boundary edge
            nn = math.sqrt(nx * nx + ny * ny + nz * nz)
            ep = SIDE_TOLERANCE * nn * math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
            eq = SIDE_TOLERANCE * nn * math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
            is_crease = (sp > ep and sq < -eq) or (sp < -ep and sq > eq)
            is_fold = (sp > ep and sq > eq) or (sp < -ep and sq < -eq)
        # the part in front of z0
        s0, s1 = 0.0, 1.0
        if az_ < z0 and bz_ < z0:
            continue
        if az_ < z0:
            s0 = (z0 - az_) / (bz_ - az_)
        elif bz_ < z0:
            s1 = (z0 - az_) / (bz_ - az_)
        dx, dy, dz = bx_ - ax_, by_ - ay_, bz_ - az_
        # image columns of the part's ends (monotone along the segment)
        ca = ((ax_ + s0 * dx) / (az_ + s0 * dz) * kx + 0.5) * w
        cb = ((ax_ + s1 * dx) / (az_ + s1 * dz) * kx + 0.5) * w
        # clamped as floats first: a column far off the screen does not fit an int64
        j0 = int(math.floor(min(max(0.0, min(ca, cb) - slack), float(w))))
        j1 = int(math.floor(max(min(w - 1.0, max(ca, cb) + slack), -1.0)))
        for j in range(j0, j1 + 1):
            # the parameters of the part within the column widened by slack: the column
            # is monotone along the segment, so the part is one interval
            left, right = j - slack, j + 1 + slack
            lo, hi = _within(left, right, ((left / w) - 0.5) / kx, ((right / w) - 0.5) / kx,
                             ca, cb, ax_, az_, dx, dz, s0, s1)
            if lo > hi:
                continue
            ra = (0.5 - (ay_ + lo * dy) / (az_ + lo * dz) * ky) * h
            rb = (0.5 - (ay_ + hi * dy) / (az_ + hi * dz) * ky) * h
            i0 = int(math.floor(min(max(0.0, min(ra, rb) - slack), float(h))))
            i1 = int(math.floor(max(min(h - 1.0, max(ra, rb) + slack), -1.0)))
            if i0 > i1:
                continue
            for i in range(i0, i1 + 1):
                qa, qb = pa[i, j], pb[i, j]
                if qa < 0 or not (ga == qa or ga == qb or (gb >= 0 and (gb == qa or gb == qb))):
                    continue  # not the pixel's patch: its edges do not bound it
                ours = (ga == qa and gb == qb) or (ga == qb and gb == qa)
                bend = corners and is_fold and ours
                if not (is_crease or bend) or not ours:
                    blocked[i, j] = True
                    continue
                # the crease's part within the pixel's rows (widened by slack): the row is
                # monotone along the segment too
                top, bottom = i - slack, i + 1 + slack
                t0, t1 = _within(top, bottom, (0.5 - top / h) / ky, (0.5 - bottom / h) / ky,
                                 ra, rb, ay_, az_, dy, dz, lo, hi)
                if t0 > t1:
                    continue
                if bend:
                    folds[i, j] += 1
                    if t0 <= s0 or t1 >= s1:
                        fold_end[i, j] = True
                far = max(math.sqrt((a0 + t0 * d0) ** 2 + (a1 + t0 * d1) ** 2
                                    + (a2 + t0 * d2) ** 2),
                          math.sqrt((a0 + t1 * d0) ** 2 + (a1 + t1 * d1) ** 2
                                    + (a2 + t1 * d2) ** 2))
                if far > crease[i, j]:
                    crease[i, j] = far
                if corners:
                    for side in range(2):
                        c = edges[k, 2 + side]
                        for ki in range(2):
                            for kj in range(2):
                                dist = corner_distance(vert, edges[k, 0], edges[k, 1], c, eye,
                                                       r, u, f, hx, hy, w, h, i + ki, j + kj)
                                if dist > crease[i, j]:
                                    crease[i, j] = dist


@njit_cached()
def _within(low, high, q_low, q_high, ca, cb, a_, az_, da, dz, s0, s1):  # pragma: no cover
    """``(lo, hi)``: the parameters of the part of the segment ``s0 .. s1`` whose image
    coordinate (``ca`` at ``s0``, ``cb`` at ``s1``, monotone between: a column or a row)
    lies in ``[low, high]``; ``q_low``, ``q_high`` are those bounds as ratios ``x / z``
    (or ``y / z``) of the camera coordinates, ``a_ + s da`` over ``az_ + s dz``."""
    if ca <= cb:
        lo = s0 if ca >= low else _at(q_low, a_, az_, da, dz, s0, s1)
        hi = s1 if cb <= high else _at(q_high, a_, az_, da, dz, s0, s1)
    else:
        lo = s0 if ca <= high else _at(q_high, a_, az_, da, dz, s0, s1)
        hi = s1 if cb >= low else _at(q_low, a_, az_, da, dz, s0, s1)
    return lo, hi


@njit_cached()
def _at(q, a_, az_, da, dz, s0, s1):  # pragma: no cover
    """The parameter in [s0, s1] where the segment's ratio ``(a_ + s da) / (az_ + s dz)``
    reaches ``q``."""
    den = da - q * dz
    if den == 0.0:
        return s0
    return min(s1, max(s0, (q * az_ - a_) / den))
