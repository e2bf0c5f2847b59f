"""Shadow frusta of convex solid and planar occluders, and the boxes they hide.

The frusta of convex solids (Papaioannou et al. 2006 [1]_, sec. 2) and of planar
occluders (Hudson et al. 1997 [2]_), and the box-in-frustum test.

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006, Plzen, UNION Agency - Science
   Press, ISBN 80-86943-03-8 (sec. 2 eqs. 1-2, sec. 3 eqs. 3-4, Tables 1-2).
.. [2] Hudson, T., Manocha, D., Cohen, J., Lin, M., Hoff, K., Zhang, H.
   "Accelerated Occlusion Culling using Shadow Frusta". 13th ACM Symposium on
   Computational Geometry, 1997, pp. 1-10.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .._validate import InputError, as_points, as_vector

__all__ = ["Frustum", "solid_frustum", "polygon_frustum", "boxes_in_frustum",
           "boxes_in_frusta", "rank_solids", "rank_planar", "solid_faces_as_polygons"]

#: A box must lie inside every plane of a frustum by this much (relative to the
#: distance from the eye to the occluder plus the occluder's size) to be culled:
#: float64 rounding of the planes never culls a box that touches the frustum.
MARGIN_RELATIVE = 1e-9

#: Relative tolerance of the convexity and planarity checks of the inputs
#: (fraction of the solid's or polygon's bounding-box diagonal).
SHAPE_TOLERANCE = 1e-7

#: Relative length under which a side plane is degenerate (the eye on the line
#: of an edge): the occluder then gives no frustum for this eye.
_DEGENERATE_RELATIVE = 1e-12


@dataclass(frozen=True, eq=False)
class Frustum:
    """A convex shadow frustum of one occluder seen from one eye.

    Attributes
    ----------
    planes : (k, 4) float64
        Inward-positive planes ``(nx, ny, nz, d)`` with unit normals: ``x`` is
        inside when ``n . x + d >= 0``. First the side planes, each through the
        eye and one silhouette edge; then the near cap (the last row; with
        ``cap='front-faces'`` one row per front triangle). ``d`` already
        includes the safety margin (see :data:`MARGIN_RELATIVE`): a point is
        culled only when it is inside by more than the margin.
    eye : (3,) float64
        The viewpoint, world units.
    silhouette : (m, 2, 3) float64
        The silhouette edges (solid) or the polygon's edges, world units.
    near_point : (3,) float64
        The point the near cap passes through: the silhouette point furthest
        from the eye along the cap normal (solid), a polygon vertex (planar).
    kind : {'solid', 'planar'}
        Which occluder made it.
    """

    planes: np.ndarray
    eye: np.ndarray
    silhouette: np.ndarray
    near_point: np.ndarray
    kind: str

    @property
    def cap(self) -> np.ndarray:
        """``(4,)`` the last near cap plane (inward-positive: away from the eye)."""
        return self.planes[-1]


# ----------------------------------------------------------------------------- occluder sets
def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (n, 3) arrays (np.cross costs more in small calls)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _solid_arrays(vertices, faces, index: int) -> dict:
    """Validated arrays of one convex solid: twins of directed edges, normals, centroid."""
    what = f"solids[{index}]"
    v = as_points(vertices, f"{what} vertices")
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or len(f) < 4 or not np.issubdtype(f.dtype, np.integer):
        raise InputError(f"{what} faces: expected (f >= 4, 3) integer triangles, got "
                         f"{f.shape} {f.dtype}")
    f = f.astype(np.int64)
    if f.min() < 0 or f.max() >= len(v):
        raise InputError(f"{what} faces: a face indexes a missing vertex")
    tri = v[f]
    normals = _cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    volume = float(np.einsum("ij,ij->i", tri[:, 0], normals).sum() / 6.0)
    scale = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    if not volume > SHAPE_TOLERANCE * scale**3:
        raise InputError(f"{what}: expected a closed, outward-facing convex solid with volume "
                         f"(signed volume {volume:.3g})")
    # twin of each directed edge (a -> b in face i) is b -> a in the neighbour
    a = f.reshape(-1)
    b = f[:, [1, 2, 0]].reshape(-1)
    face_of = np.repeat(np.arange(len(f)), 3)
    n = len(v)
    key = a * n + b
    order = np.argsort(key)
    twin_key = b * n + a
    pos = np.searchsorted(key[order], twin_key)
    pos = np.minimum(pos, len(key) - 1)
    found = key[order][pos] == twin_key
    if not found.all() or len(np.unique(key)) != len(key):
        raise InputError(f"{what}: not a closed, consistently oriented triangle mesh "
                         "(every edge must have one twin)")
    twin_face = face_of[order][pos]
    # convexity: every vertex on the inner side of every face plane
    unit = normals / np.linalg.norm(normals, axis=1)[:, None]
    offset = np.einsum("ij,ij->i", unit, tri[:, 0])
    if (v @ unit.T - offset).max() > SHAPE_TOLERANCE * scale:
        raise InputError(f"{what}: not convex (a vertex lies outside a face plane)")
    # volume centroid from signed tetrahedra with the origin
    tet = np.einsum("ij,ij->i", tri[:, 0], normals) / 6.0
    centroid = ((tri.sum(axis=1) / 4.0) * tet[:, None]).sum(axis=0) / volume
    return {"vertices": v, "faces": f, "normals": unit, "offset": offset, "edge_a": a,
            "edge_b": b, "edge_face": face_of, "twin_face": twin_face, "volume": volume,
            "centroid": centroid, "radius": float(np.linalg.norm(v - centroid, axis=1).max()),
            "scale": scale}


def _polygon_arrays(polygon, index: int) -> dict:
    """Validated arrays of one convex planar polygon: unit normal, area, centroid."""
    what = f"polygons[{index}]"
    p = as_points(polygon, what)
    if len(p) < 3:
        raise InputError(f"{what}: expected at least 3 vertices, got {len(p)}")
    c = p.mean(axis=0)
    area_vec = 0.5 * _cross(p - c, np.roll(p, -1, axis=0) - c).sum(axis=0)
    area = float(np.linalg.norm(area_vec))
    scale = float(np.linalg.norm(p.max(axis=0) - p.min(axis=0)))
    if not area > SHAPE_TOLERANCE * scale**2:
        raise InputError(f"{what}: zero area")
    normal = area_vec / area
    if np.abs((p - c) @ normal).max() > SHAPE_TOLERANCE * scale:
        raise InputError(f"{what}: not planar")
    e = np.roll(p, -1, axis=0) - p
    turn = _cross(e, np.roll(e, -1, axis=0)) @ normal
    if turn.min() < -SHAPE_TOLERANCE * scale**2:
        raise InputError(f"{what}: not convex (or not a simple loop)")
    # the vertex mean as centre: inside a convex polygon, enough for ranking
    return {"points": p, "start": np.array([0, len(p)]), "normal": normal[None],
            "offset": np.array([normal @ c]), "area": np.array([area]), "centroid": c[None],
            "radius": np.array([np.linalg.norm(p - c, axis=1).max()]), "scale": scale}


def solid_faces_as_polygons(vertices: npt.ArrayLike, faces: npt.ArrayLike) -> list[np.ndarray]:
    """The faces of a convex solid as convex polygons (coplanar triangles merged).

    Parameters
    ----------
    vertices : (v, 3) float
    faces : (f, 3) int
        A closed, outward-facing convex solid.

    Returns
    -------
    list of (m_i, 3) float64
        One counter-clockwise (seen from outside) loop per plane of the solid:
        a box gives 6 quads. The planar-frusta runtime uses these polygons,
        each its own frustum.

    Raises
    ------
    InputError
        If the solid is not closed, oriented and convex.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box()
    >>> [len(p) for p in solid_faces_as_polygons(box.vertices, box.faces)]
    [4, 4, 4, 4, 4, 4]
    """
    p = _face_polygons(_solid_arrays(vertices, faces, 0))
    return np.split(p["points"], p["start"][1:-1])


def _plane_groups(s: dict) -> tuple[np.ndarray, np.ndarray]:
    """Triangles of a validated convex solid grouped by plane: the first triangle of each
    group (g,) and the group of each triangle (f,), 0..g-1. Each group is a face of the
    polytope, hence a convex polygon."""
    n, off = s["normals"], s["offset"]
    tol = SHAPE_TOLERANCE * s["scale"]
    same = (n @ n.T > 1 - 1e-9) & (np.abs(off[:, None] - off[None, :]) <= tol)
    first = np.argmax(same, axis=1)  # the first face on the same plane
    firsts, group = np.unique(first, return_inverse=True)
    return firsts, group.reshape(-1)


def _face_polygons(s: dict) -> dict:
    """The faces of a validated convex solid as polygon arrays, coplanar triangles merged.

    Returns points (P, 3) grouped by polygon, each loop counter-clockwise about
    its outward normal; start (g + 1,) offsets; normal (g, 3); offset (g,);
    area (g,); centroid (g, 3) (the vertex mean); radius (g,).
    """
    v, n, f = s["vertices"], s["normals"], s["faces"]
    tol = SHAPE_TOLERANCE * s["scale"]
    firsts, group = _plane_groups(s)
    g = len(firsts)
    pairs = np.unique(np.stack([np.repeat(group, 3), f.reshape(-1)], axis=1), axis=0)
    pg, pts = pairs[:, 0], v[pairs[:, 1]]
    counts = np.bincount(pg, minlength=g)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    centre = _group_sum(pts, pg, g) / counts[:, None]
    normal = n[firsts]
    ref = pts - centre[pg]
    ax = ref[start] / np.linalg.norm(ref[start], axis=1)[:, None]
    ay = _cross(normal, ax)
    ang = np.arctan2(np.einsum("ij,ij->i", ref, ay[pg]), np.einsum("ij,ij->i", ref, ax[pg]))
    order = np.lexsort((ang, pg))
    pts = pts[order]
    # drop vertices in the middle of an edge (collinear with their neighbours)
    idx = np.arange(len(pts))
    last = start + counts - 1
    prev = np.where(idx == start[pg], last[pg], idx - 1)
    nxt = np.where(idx == last[pg], start[pg], idx + 1)
    bend = np.linalg.norm(_cross(pts - pts[prev], pts[nxt] - pts), axis=1)
    keep = bend > tol * s["scale"]
    keep |= (np.bincount(pg, weights=keep, minlength=g) < 3)[pg]
    pts, pg = pts[keep], pg[keep]
    counts = np.bincount(pg, minlength=g)
    start = np.concatenate([[0], np.cumsum(counts)])
    idx = np.arange(len(pts))
    nxt = np.where(idx == start[1:][pg] - 1, start[:-1][pg], idx + 1)
    rel = pts - centre[pg]
    area = 0.5 * np.bincount(pg, weights=np.einsum("ij,ij->i", _cross(rel, rel[nxt]),
                                                   normal[pg]), minlength=g)
    radius = np.maximum.reduceat(np.linalg.norm(rel, axis=1), start[:-1])
    return {"points": pts, "start": start, "normal": normal,
            "offset": np.einsum("ij,ij->i", normal, centre), "area": area,
            "centroid": centre, "radius": radius}


# ----------------------------------------------------------------------------- frustum building
#: Near caps of a solid frustum: the paper's plane (eq. 2) or the planes of the front faces.
CAPS = ("eq2", "front-faces")


def _ranges(start: np.ndarray, select: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Concatenated index ranges ``start[s]:start[s+1]`` of the selected items, and the
    position (0..k-1) in ``select`` of each index."""
    counts = start[select + 1] - start[select]
    total = int(counts.sum())
    first = np.repeat(start[select] - np.concatenate([[0], np.cumsum(counts)[:-1]]), counts)
    return first + np.arange(total), np.repeat(np.arange(len(select)), counts)


def _group_sum(values: np.ndarray, group: np.ndarray, k: int) -> np.ndarray:
    """(k, 3) sums of (n, 3) rows by group."""
    return np.stack([np.bincount(group, weights=values[:, j], minlength=k) for j in range(3)],
                    axis=1)


def _oriented_side_planes(eye, a, b, inner, tol):
    """Unit planes through the eye and each edge (a[i], b[i]), inward towards inner[i];
    (e, 4) and (e,) bool of the well-defined ones."""
    n = _cross(a - eye, b - eye)
    norm = np.sqrt(np.einsum("ij,ij->i", n, n))
    ok = norm > tol
    n = n / np.where(ok, norm, 1.0)[:, None]
    d = -(n @ eye)
    side = np.einsum("ij,ij->i", n, inner) + d
    ok &= side != 0
    flip = np.where(side < 0, -1.0, 1.0)
    return np.concatenate([n * flip[:, None], (d * flip)[:, None]], axis=1), ok


@dataclass(frozen=True)
class _Planes:
    """Frusta of one frame: planes grouped by frustum, and what made them."""

    planes: np.ndarray  # (P, 4), margin applied
    owner: np.ndarray  # (P,) frustum 0..k-1, ascending
    item: np.ndarray  # (k,) solid or polygon index
    edges: np.ndarray  # (E, 2, 3) silhouette / polygon edges
    edge_owner: np.ndarray  # (E,) frustum of each edge, ascending
    near: np.ndarray  # (k, 3)

    @staticmethod
    def empty() -> _Planes:
        z = np.zeros(0, dtype=np.int64)
        return _Planes(np.zeros((0, 4)), z, z, np.zeros((0, 2, 3)), z, np.zeros((0, 3)))

    def __len__(self) -> int:
        return len(self.item)

    def frusta(self, eye: np.ndarray, kind: str) -> list[Frustum]:
        ps = np.split(self.planes, np.flatnonzero(np.diff(self.owner)) + 1)
        es = np.split(self.edges, np.flatnonzero(np.diff(self.edge_owner)) + 1)
        return [Frustum(planes=p, eye=eye, silhouette=e, near_point=n, kind=kind)
                for p, e, n in zip(ps, es, self.near, strict=True)] if len(self) else []


def _assemble(groups: list[tuple[np.ndarray, np.ndarray]], valid: np.ndarray,
              margin: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Planes of the valid groups, sorted by group; returns planes, owner 0..k'-1 and the
    old-to-new group map."""
    planes = np.vstack([g[0] for g in groups])
    group = np.concatenate([g[1] for g in groups])
    keep = valid[group]
    planes, group = planes[keep], group[keep]
    order = np.argsort(group, kind="stable")
    planes, group = planes[order], group[order]
    remap = np.cumsum(valid) - 1
    planes = planes.copy()
    planes[:, 3] -= margin
    return planes, remap[group], remap


class _SolidSet:
    """Convex solids concatenated, for vectorised silhouettes over a selection."""

    def __init__(self, solids: list[dict]) -> None:
        self.count = len(solids)
        nv = np.cumsum([0] + [len(s["vertices"]) for s in solids])
        nf = np.cumsum([0] + [len(s["faces"]) for s in solids])
        self.face_start = nf
        self.edge_start = 3 * nf  # three directed edges per triangle
        cat = np.concatenate
        self.vertices = np.vstack([s["vertices"] for s in solids]) if solids else np.zeros((0, 3))
        self.normals = np.vstack([s["normals"] for s in solids]) if solids else np.zeros((0, 3))
        self.offset = cat([s["offset"] for s in solids]) if solids else np.zeros(0)
        if solids:
            self.edge_a = cat([s["edge_a"] + nv[i] for i, s in enumerate(solids)])
            self.edge_b = cat([s["edge_b"] + nv[i] for i, s in enumerate(solids)])
            self.edge_face = cat([s["edge_face"] + nf[i] for i, s in enumerate(solids)])
            self.twin_face = cat([s["twin_face"] + nf[i] for i, s in enumerate(solids)])
        self.centroid = np.array([s["centroid"] for s in solids]).reshape(-1, 3)
        self.volume = np.array([s["volume"] for s in solids], dtype=np.float64)
        self.radius = np.array([s["radius"] for s in solids], dtype=np.float64)

    def eye_inside(self, eye: np.ndarray, select: np.ndarray) -> np.ndarray:
        """(k,) bool: the eye is inside or on the selected solids (no face seen from front)."""
        fidx, fgrp = _ranges(self.face_start, select)
        front = (self.normals[fidx] @ eye - self.offset[fidx]) > 0
        return np.bincount(fgrp[front], minlength=len(select)) == 0

    def planes(self, eye: np.ndarray, select: np.ndarray, cap: str, scale: float) -> _Planes:
        """Frusta of the selected solids; ``scale`` is the frame's length scale."""
        margin, tol = MARGIN_RELATIVE * scale, _DEGENERATE_RELATIVE * scale * scale
        k = len(select)
        if k == 0:
            return _Planes.empty()
        fidx, fgrp = _ranges(self.face_start, select)
        front_sel = (self.normals[fidx] @ eye - self.offset[fidx]) > 0
        front = np.zeros(len(self.normals), dtype=bool)
        front[fidx] = front_sel
        eidx, egrp = _ranges(self.edge_start, select)
        sil = front[self.edge_face[eidx]] & ~front[self.twin_face[eidx]]  # eq. 1
        e, g = eidx[sil], egrp[sil]
        a, b = self.vertices[self.edge_a[e]], self.vertices[self.edge_b[e]]
        side, ok = _oriented_side_planes(eye, a, b, self.centroid[select[g]], tol)
        n_sil = np.bincount(g, minlength=k)
        valid = (n_sil > 0) & (np.bincount(g, weights=~ok, minlength=k) == 0)
        # eq. 2: mean direction between the silhouette points and the eye (each
        # silhouette vertex starts one edge of the oriented outline loop); the
        # inward normal points away from the eye
        m = _group_sum(a - eye, g, k)
        mn = np.linalg.norm(m, axis=1)
        valid &= mn > 0
        m = m / np.where(mn > 0, mn, 1.0)[:, None]
        along = np.einsum("ij,ij->i", a, m[g])
        order = np.lexsort((along, g))  # by group, then along the cap normal
        last = order[np.r_[np.flatnonzero(np.diff(g[order])), len(order) - 1]] \
            if len(order) else np.zeros(0, np.int64)
        far = np.zeros((k, 3))
        far[g[last]] = a[last]
        if cap == "eq2":
            caps = (np.concatenate([m, -np.einsum("ij,ij->i", m, far)[:, None]], axis=1),
                    np.arange(k))
        else:  # the planes of the front faces, facing away from the eye
            fi, fg = fidx[front_sel], fgrp[front_sel]
            caps = (np.concatenate([-self.normals[fi], self.offset[fi][:, None]], axis=1), fg)
        planes, owner, remap = _assemble([(side, g), caps], valid, margin)
        keep_e = valid[g]
        return _Planes(planes=planes, owner=owner, item=select[valid],
                       edges=np.stack([a, b], axis=1)[keep_e], edge_owner=remap[g[keep_e]],
                       near=far[valid])


class _PolygonSet:
    """Convex polygons concatenated, for vectorised frusta over a selection."""

    def __init__(self, points: np.ndarray, start: np.ndarray, normal: np.ndarray,
                 offset: np.ndarray, area: np.ndarray, centroid: np.ndarray,
                 radius: np.ndarray) -> None:
        self.count = len(start) - 1
        self.start, self.points = start, points
        nxt = np.arange(len(points)) + 1
        if self.count:
            nxt[start[1:] - 1] = start[:-1]  # the closing edge of each loop
        self.next = nxt
        self.normal, self.offset, self.area = normal, offset, area
        self.centroid, self.radius = centroid, radius

    @classmethod
    def concat(cls, parts: list[dict]) -> _PolygonSet:
        """From dicts of polygon arrays (:func:`_face_polygons` or one polygon each)."""
        if not parts:
            return cls(np.zeros((0, 3)), np.zeros(1, np.int64), np.zeros((0, 3)), np.zeros(0),
                       np.zeros(0), np.zeros((0, 3)), np.zeros(0))
        sizes = [len(p["points"]) for p in parts]
        shift = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        start = np.concatenate([p["start"][:-1] + o for p, o in zip(parts, shift, strict=True)]
                               + [[int(np.sum(sizes))]])
        cat = np.concatenate
        return cls(np.vstack([p["points"] for p in parts]), start.astype(np.int64),
                   np.vstack([p["normal"] for p in parts]), cat([p["offset"] for p in parts]),
                   cat([p["area"] for p in parts]), np.vstack([p["centroid"] for p in parts]),
                   cat([p["radius"] for p in parts]))

    def planes(self, eye: np.ndarray, select: np.ndarray, scale: float) -> _Planes:
        """Frusta of the selected polygons; ``scale`` is the frame's length scale."""
        margin, tol = MARGIN_RELATIVE * scale, _DEGENERATE_RELATIVE * scale
        k = len(select)
        if k == 0:
            return _Planes.empty()
        h = self.normal[select] @ eye - self.offset[select]  # eye height over each plane
        valid = np.abs(h) > tol
        eidx, g = _ranges(self.start, select)
        a, b = self.points[eidx], self.points[self.next[eidx]]
        side, ok = _oriented_side_planes(eye, a, b, self.centroid[select[g]],
                                         tol * scale)
        valid &= np.bincount(g, weights=~ok, minlength=k) == 0
        sign = np.where(h > 0, -1.0, 1.0)  # inward: the far side of the plane from the eye
        caps = (np.concatenate([sign[:, None] * self.normal[select],
                                (-sign * self.offset[select])[:, None]], axis=1), np.arange(k))
        planes, owner, remap = _assemble([(side, g), caps], valid, margin)
        keep_e = valid[g]
        return _Planes(planes=planes, owner=owner, item=select[valid],
                       edges=np.stack([a, b], axis=1)[keep_e], edge_owner=remap[g[keep_e]],
                       near=self.points[self.start[select]][valid])


def _frame_scale(eye: np.ndarray, center: np.ndarray, diagonal: float) -> float:
    """Length scale of a frame: eye distance to the occluders' centre plus their size."""
    return float(np.linalg.norm(eye - center)) + diagonal


def solid_frustum(vertices: npt.ArrayLike, faces: npt.ArrayLike, eye: npt.ArrayLike, *,
                  cap: str = "eq2") -> Frustum | None:
    """Shadow frustum of a convex solid seen from ``eye`` (Papaioannou et al. 2006, sec. 2).

    Parameters
    ----------
    vertices : (v, 3) float
        World units.
    faces : (f, 3) int
        Triangles of a closed, outward-facing (counter-clockwise seen from
        outside) convex solid.
    eye : (3,) float
        Viewpoint, world units.
    cap : {'eq2', 'front-faces'}, optional
        'eq2' (default): one near cap, the plane of eq. 2 of [1]_ through
        the furthest silhouette point. 'front-faces': the planes of the
        triangles the eye sees, each facing away from it; the exact shadow of
        the solid, which contains the eq. 2 frustum and every face's planar
        frustum.

    Returns
    -------
    Frustum or None
        None when the eye is inside the solid or on its surface, or on the
        line of a silhouette edge (no safe frustum exists).

    Raises
    ------
    InputError
        If the solid is not closed, consistently oriented, convex, or has no
        volume; ``eye`` is not a finite 3-vector; or ``cap`` is unknown.

    Notes
    -----
    Silhouette edges (eq. 1 of [1]_) are the edges between a triangle the eye
    sees strictly from the front and one it does not (edge-on triangles count
    as back-facing); oriented as in their front triangle they form the outline
    loop. Every side plane through the eye and a silhouette edge supports the
    solid, so their intersection is the cone of rays that hit the solid.

    'eq2' cap: the normal of eq. 2 (the mean of ``S_i - C``; inward means away
    from the eye) through the silhouette point furthest *along that normal*
    (the point furthest in distance could leave other silhouette points
    beyond the plane). Guarantee: in any plane through the eye the visible
    part of the solid's outline lies in the triangle of the eye and the two
    tangent points, so the whole visible surface lies in the convex hull of
    the eye and the silhouette, on the eye's side of the cap; a point behind
    the cap inside the cone is at or beyond the visible surface along its ray.

    'front-faces' caps: a ray in the cone enters the solid through a front
    triangle, after crossing the planes of all front triangles; so a point of
    the cone beyond all of them is beyond the entry point, and conversely.

    References
    ----------
    .. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient
       Occlusion Culling using Solid Occluders". WSCG 2006, ISBN 80-86943-03-8.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box()
    >>> fr = solid_frustum(box.vertices, box.faces, (0, 0, -3))
    >>> fr.planes.shape        # four side planes (one face seen) and the cap
    (5, 4)
    >>> solid_frustum(box.vertices, box.faces, (0, 0, 0)) is None   # eye inside
    True
    """
    if cap not in CAPS:
        raise InputError(f"cap: expected one of {', '.join(CAPS)}, got {cap!r}")
    s = _solid_arrays(vertices, faces, 0)
    e = as_vector(eye, "eye")
    scale = _frame_scale(e, s["centroid"], s["scale"])
    planes = _SolidSet([s]).planes(e, np.array([0]), cap, scale)
    fr = planes.frusta(e, "solid")
    return fr[0] if fr else None


def polygon_frustum(polygon: npt.ArrayLike, eye: npt.ArrayLike) -> Frustum | None:
    """Shadow frustum of a convex planar polygon (Hudson et al. 1997).

    Parameters
    ----------
    polygon : (m, 3) float
        A convex planar loop, m >= 3, world units (either orientation; the
        polygon occludes from both sides).
    eye : (3,) float

    Returns
    -------
    Frustum or None
        Side planes through the eye and each edge, the polygon's plane as the
        near cap; None when the eye lies in the polygon's plane (or on the line
        of an edge).

    Raises
    ------
    InputError
        If the polygon is not planar and convex, or has no area.

    Examples
    --------
    >>> sq = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]
    >>> fr = polygon_frustum(sq, (0, 0, 2))
    >>> fr.planes.shape, float(fr.cap[2])    # cap: the square's plane, facing away
    ((5, 4), -1.0)
    """
    q = _polygon_arrays(polygon, 0)
    e = as_vector(eye, "eye")
    scale = _frame_scale(e, q["centroid"][0], q["scale"])
    planes = _PolygonSet.concat([q]).planes(e, np.array([0]), scale)
    fr = planes.frusta(e, "planar")
    return fr[0] if fr else None


# ----------------------------------------------------------------------------- box tests
def _as_boxes(lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """Box corners ``lo``, ``hi`` (n, 3) float64, validated (also for the depth buffer)."""
    lo = as_points(lower, "lower", allow_empty=True)
    hi = as_points(upper, "upper", allow_empty=True)
    if lo.shape != hi.shape:
        raise InputError(f"lower and upper: shapes differ ({lo.shape} vs {hi.shape})")
    if (lo > hi).any():
        raise InputError("lower and upper: a lower corner exceeds its upper corner")
    return lo, hi


def _inside_any(planes: np.ndarray, owner: np.ndarray, lo: np.ndarray,
                hi: np.ndarray) -> np.ndarray:
    """(n,) bool: box wholly inside at least one frustum. ``owner`` sorted, (P,).

    The box corner deepest outside plane (n, d) gives n.c + d - |n|.h (c the
    box centre, h its half extents): the box is inside the plane iff that is
    >= 0: one (n, 7) x (7, P) product and one minimum per frustum.
    """
    n = len(lo)
    if n == 0 or len(planes) == 0:
        return np.zeros(n, dtype=bool)
    boxes = np.concatenate([0.5 * (lo + hi), 0.5 * (hi - lo), np.ones((n, 1))], axis=1)
    rows = np.concatenate([planes[:, :3], -np.abs(planes[:, :3]), planes[:, 3:]], axis=1)
    worst = boxes @ rows.T
    starts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
    return (np.minimum.reduceat(worst, starts, axis=1) >= 0).any(axis=1)  # type: ignore[return-value]


def _fast_boxes(lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """``lo``, ``hi`` (n, 3) float64 C-ordered, for
    :meth:`viscore.culling.frustum_culler.FrustumCuller.cull`: the shape is checked here,
    finiteness and order by the box kernel (which then calls for :func:`_as_boxes`
    and its messages); anything else goes through :func:`_as_boxes`."""
    lo, hi = lower, upper
    if not (isinstance(lo, np.ndarray) and isinstance(hi, np.ndarray)
            and lo.dtype == np.float64 and hi.dtype == np.float64 and lo.ndim == 2
            and lo.shape[1:] == (3,) and lo.shape == hi.shape):
        lo, hi = _as_boxes(lower, upper)
    return np.ascontiguousarray(lo), np.ascontiguousarray(hi)


def boxes_in_frustum(frustum: Frustum, lower: npt.ArrayLike,
                     upper: npt.ArrayLike) -> np.ndarray:
    """Which axis-aligned boxes lie wholly inside a frustum (all 8 corners inside all planes).

    Parameters
    ----------
    frustum : Frustum
    lower, upper : (n, 3) float
        Box corners, world units, ``lower <= upper``.

    Returns
    -------
    inside : (n,) bool
        True when the box is hidden by the frustum's occluder (culled).

    Raises
    ------
    InputError
        On shapes other than (n, 3), non-finite values or inverted corners.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box()
    >>> fr = solid_frustum(box.vertices, box.faces, (0, 0, -3))
    >>> boxes_in_frustum(fr, [[-0.1, -0.1, 2], [-2, -2, 2]], [[0.1, 0.1, 3], [2, 2, 3]]).tolist()
    [True, False]
    """
    return boxes_in_frusta([frustum], lower, upper)


def boxes_in_frusta(frusta: list[Frustum], lower: npt.ArrayLike,
                    upper: npt.ArrayLike) -> np.ndarray:
    """Which boxes lie wholly inside at least one of the frusta; vectorised over both.

    Parameters
    ----------
    frusta : list of Frustum
    lower, upper : (n, 3) float

    Returns
    -------
    inside : (n,) bool

    Raises
    ------
    InputError
        As :func:`boxes_in_frustum`.
    """
    lo, hi = _as_boxes(lower, upper)
    if not frusta:
        return np.zeros(len(lo), dtype=bool)
    planes = np.vstack([f.planes for f in frusta])
    owner = np.repeat(np.arange(len(frusta)), [len(f.planes) for f in frusta])
    return _inside_any(planes, owner, lo, hi)


# ----------------------------------------------------------------------------- ranking
def rank_solids(volumes: npt.ArrayLike, centers: npt.ArrayLike, eye: npt.ArrayLike) -> np.ndarray:
    """Importance of solid occluders, ``f_solid = Vol / |V|^3`` (Papaioannou et al. 2006, eq. 4).

    Parameters
    ----------
    volumes : (s,) float
        Solid volumes, world units^3.
    centers : (s, 3) float
        Solid centres; V is the vector from the eye to each.
    eye : (3,) float

    Returns
    -------
    rank : (s,) float64
        Larger is better; ``inf`` for a solid centred on the eye.

    Examples
    --------
    >>> rank_solids([8.0, 8.0], [[0, 0, 2], [0, 0, 4]], (0, 0, 0)).tolist()
    [1.0, 0.125]
    """
    vol = np.asarray(volumes, dtype=np.float64).reshape(-1)
    c = as_points(centers, "centers", allow_empty=True)
    e = as_vector(eye, "eye")
    dist = np.linalg.norm(c - e, axis=1)
    with np.errstate(divide="ignore"):
        return vol / dist**3


def rank_planar(areas: npt.ArrayLike, normals: npt.ArrayLike, centers: npt.ArrayLike,
                eye: npt.ArrayLike, *, two_sided: bool = False) -> np.ndarray:
    """Importance of planar occluders, ``-A N.V / |V|^2`` (eq. 3, after Coorg and Teller).

    Parameters
    ----------
    areas : (s,) float
        Polygon areas, world units^2.
    normals : (s, 3) float
        Unit normals (outward for the faces of a solid).
    centers : (s, 3) float
        Polygon centres; V is the vector from the eye to each.
    eye : (3,) float
    two_sided : bool, optional
        Rank by ``|A N.V| / |V|^2`` (a polygon that occludes from both sides).
        Default False: eq. 3 as printed, negative for a polygon facing away.

    Returns
    -------
    rank : (s,) float64

    Examples
    --------
    >>> rank_planar([4.0], [[0, 0, -1]], [[0, 0, 2]], (0, 0, 0)).tolist()
    [2.0]
    """
    a = np.asarray(areas, dtype=np.float64).reshape(-1)
    n = as_points(normals, "normals", allow_empty=True)
    c = as_points(centers, "centers", allow_empty=True)
    v = c - as_vector(eye, "eye")
    with np.errstate(divide="ignore", invalid="ignore"):
        f = -a * np.einsum("ij,ij->i", n, v) / np.einsum("ij,ij->i", v, v)
    return np.abs(f) if two_sided else f
