"""Welding eroded patches back onto the creases of the input they came from."""

from __future__ import annotations

import numpy as np
import shapely

__all__ = ["crease_lines", "weld_points", "welded_ring"]

#: Smallest sine of the angle between two planes for their line to be welded to
#: (nearly parallel planes meet far away and at an ill-conditioned line).
MIN_SINE = 1e-3


def crease_lines(vertices: np.ndarray, faces: np.ndarray, face_region: np.ndarray,
                 planes: np.ndarray, *, grid: float, wanted: np.ndarray | None = None
                 ) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """The creases of each region: edges it shares with a face of another plane.

    Parameters
    ----------
    vertices : (v, 3) float64
    faces : (f, 3) int64
    face_region : (f,) int64
        Region of each face (-1: none, such as a degenerate face).
    planes : (r, 4) float64
        Each region's unit normal and offset (``n . x = offset``).
    grid : float
        World units within which two vertices are one (matched by position).
    wanted : (w,) int, optional
        The regions whose creases are wanted (default all).

    Returns
    -------
    dict
        Region -> ``(segments, partner)``: the shared edges ``(k, 2, 3)`` (the
        region's own face's vertices) and the region of the face across each
        ``(k,)``. Regions whose planes are parallel within :data:`MIN_SINE`
        are not each other's creases.
    """
    if len(faces) == 0:
        return {}
    key = np.round(np.asarray(vertices, dtype=np.float64) / grid).astype(np.int64)
    _, vid = np.unique(key, axis=0, return_inverse=True)
    vid = vid.reshape(-1)
    corner = np.array([[0, 1], [1, 2], [2, 0]])
    ends = faces[:, corner]  # (f, 3, 2) vertex indices of each edge
    ids = np.sort(vid[ends], axis=2).reshape(-1, 2)
    face = np.repeat(np.arange(len(faces)), 3)
    keep = (ids[:, 0] != ids[:, 1]) & (face_region[face] >= 0)
    ids, face, edge = ids[keep], face[keep], np.flatnonzero(keep)
    order = np.lexsort((face_region[face], ids[:, 1], ids[:, 0]))
    ids, face, edge = ids[order], face[order], edge[order]
    same = np.all(ids[1:] == ids[:-1], axis=1)
    a, b = face[:-1][same], face[1:][same]
    ea, eb = edge[:-1][same], edge[1:][same]
    ra, rb = face_region[a], face_region[b]
    cross = np.linalg.norm(np.cross(planes[ra, :3], planes[rb, :3]), axis=1)
    ok = (ra != rb) & (cross > MIN_SINE)
    # both ways: the crease is one of each region's
    own = np.concatenate([ra[ok], rb[ok]])
    partner = np.concatenate([rb[ok], ra[ok]])
    flat = ends.reshape(-1, 2)
    seg_edges = np.concatenate([ea[ok], eb[ok]])
    if wanted is not None:
        mine = np.isin(own, wanted)
        own, partner, seg_edges = own[mine], partner[mine], seg_edges[mine]
    segments = vertices[flat[seg_edges]]  # (k, 2, 3)
    out: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    if len(own) == 0:
        return out
    by = np.argsort(own, kind="stable")
    bounds = np.flatnonzero(np.r_[True, own[by][1:] != own[by][:-1], True])
    for s, e in zip(bounds[:-1], bounds[1:], strict=True):  # a loop over regions with creases
        rows = by[s:e]
        out[int(own[rows[0]])] = (segments[rows], partner[rows])
    return out


def _line(plane_a: np.ndarray, plane_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A point and the unit direction of the line where two planes meet."""
    n1, d1, n2, d2 = plane_a[:3], plane_a[3], plane_b[:3], plane_b[3]
    direction = np.cross(n1, n2)
    sq = float(direction @ direction)
    point = np.cross(d1 * n2 - d2 * n1, direction) / sq
    return point, direction / np.sqrt(sq)


def _region_edges(region: int, creases: dict, planes: np.ndarray, kept: dict) -> tuple:
    """A region's crease edges of non-zero length, as :func:`weld_points` reads them: their
    starts, spans and squared lengths, partner regions, and for each the point and unit
    direction of its plane pair's line (``kept[region, partner]``, found once)."""
    segs, partner = creases[region]
    s0, s1 = segs[:, 0], segs[:, 1]
    span = s1 - s0
    length2 = np.einsum("ij,ij->i", span, span)
    good = length2 > 0
    s0, span, length2, partner = s0[good], span[good], length2[good], partner[good]
    parts, which = np.unique(partner, return_inverse=True)
    for p in parts.tolist():
        if (region, p) not in kept:
            kept[region, p] = _line(planes[region], planes[p])
    point = np.array([kept[region, p][0] for p in parts.tolist()]).reshape(-1, 3)
    direction = np.array([kept[region, p][1] for p in parts.tolist()]).reshape(-1, 3)
    which = which.ravel()
    return s0, span, length2, partner, point[which], direction[which]


def weld_points(points: np.ndarray, region: int, creases: dict, planes: np.ndarray, *,
                reach: float, lines: dict | None = None) -> np.ndarray:
    """``points`` of a patch of ``region`` moved onto the creases within ``reach``.

    A point within ``reach`` of one of the region's crease edges
    (:func:`crease_lines`) moves to its perpendicular foot on the line of the
    two planes (which the edge lies on, up to the planes' tolerance); a point
    near edges of two or more partner planes moves to the point where its own
    plane and the two nearest partners' meet, when that point is within
    twice ``reach``. Others stay. ``points`` are (m, 3) world units in
    the region's plane; returns a new array. ``lines``, a dict the caller keeps
    for one occluder's welds, holds each (region, partner) plane pair's line
    and each ``("region", region)``'s edges (:func:`_region_edges`), found once.
    """
    out = np.array(points, dtype=np.float64, copy=True)
    if region not in creases or len(out) == 0:
        return out
    kept = {} if lines is None else lines
    if ("region", region) not in kept:
        kept["region", region] = _region_edges(region, creases, planes, kept)
    s0, span, length2, partner, point, direction = kept["region", region]
    if len(partner) == 0:
        return out
    # (m, k): distance of each point to each edge (within reach, its foot on the line is
    # within reach of the edge too), and that foot (for the points near some edge)
    rel = out[:, None, :] - s0[None]
    t = np.clip(np.einsum("mkj,kj->mk", rel, span) / length2, 0.0, 1.0)
    near = np.linalg.norm(rel - t[..., None] * span[None], axis=2)
    hit = near <= reach
    rows = np.flatnonzero(hit.any(axis=1))
    foot = point[None] + np.einsum("mkj,kj->mk", out[rows][:, None, :] - point[None],
                                   direction)[..., None] * direction[None]
    for i, m in enumerate(rows):  # a loop over the few points beside a crease
        ks = np.flatnonzero(hit[m])
        parts = np.unique(partner[ks])
        if len(parts) == 1:
            k = ks[np.argmin(near[m, ks])]
            out[m] = foot[i, k]
            continue
        # the two nearest partners of different lines: the corner of three planes
        best = [partner[ks][np.argmin(near[m, ks])]]
        rest = [p for p in parts if p != best[0]]
        second = min(rest, key=lambda p: near[m, ks][partner[ks] == p].min())
        normals = planes[[region, best[0], second], :3]
        if abs(np.linalg.det(normals)) < MIN_SINE:
            continue
        corner_point = np.linalg.solve(normals, planes[[region, best[0], second], 3])
        if np.linalg.norm(corner_point - out[m]) <= 2.0 * reach:
            out[m] = corner_point
    return out


def welded_ring(xy: np.ndarray, moved_xy: np.ndarray, triangles: np.ndarray, union, *,
                tolerance: float) -> bool:
    """Whether a patch's moved vertices may replace its own.

    ``xy`` and ``moved_xy`` are the patch's in-plane vertices before and after
    :func:`weld_points`, ``triangles`` (t, 3) its triangles, ``union`` the
    region's exact union in the same plane coordinates. True when every moved
    triangle keeps its orientation, is not degenerate, and lies in ``union``
    grown by ``tolerance``.
    """
    if np.array_equal(xy, moved_xy):
        return False

    def signed(p: np.ndarray) -> np.ndarray:
        a, b, c = p[triangles[:, 0]], p[triangles[:, 1]], p[triangles[:, 2]]
        return ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))

    before, after = signed(xy), signed(moved_xy)
    if np.any(after * np.sign(before) <= 0):
        return False
    grown = shapely.buffer(union, tolerance, join_style="mitre")
    return bool(shapely.covers(grown, shapely.polygons(moved_xy[triangles])).all())
