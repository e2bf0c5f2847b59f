"""Shadow-frustum occlusion culling with convex solid and planar occluders.

The runtime of Papaioannou et al. 2006 [1]_ on top of the shadow frusta of
Hudson et al. 1997 [2]_. Each occluder seen from the eye spans a convex
semi-infinite frustum: an occludee whose axis-aligned bounding box lies wholly
inside one frustum is hidden by that occluder and culled.

- A **convex solid** (sec. 2 of [1]_) gives one frustum: its silhouette edges
  from the eye are the edges shared by a front- and a back-facing triangle
  (eq. 1); one side plane passes through the eye and each silhouette edge; the
  near cap passes through the silhouette point furthest from the eye, with the
  averaged direction of eq. 2 as its normal.
- A **convex planar polygon** (the planar occluders of [2]_) gives one
  frustum: side planes through the eye and each edge, capped by the polygon's
  own plane.
- Each frame, occluders are ranked by f_solid = Vol / |V|^3 (eq. 4) and
  f_planar = -A N.V / |V|^2 (eq. 3), V the vector from the eye to the
  occluder's centre, and only the ``active`` best (default 15, sec. 3) make
  frusta.

Planes are stored *inward-positive*: a point ``x`` is inside plane
``(a, b, c, d)`` when ``a x + b y + c z + d >= 0``; normals are unit. A frustum
is the intersection of its planes; the near cap is the last row.

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

from ._validate import InputError, as_points, as_positive_int, as_vector

__all__ = ["Frustum", "solid_frustum", "polygon_frustum", "boxes_in_frustum",
           "boxes_in_frusta", "rank_solids", "rank_planar", "FrustumCuller",
           "solid_faces_as_polygons", "ACTIVE_OCCLUDERS"]

#: Size of the per-frame active occluder set (Papaioannou et al. 2006, sec. 3:
#: "a set of 15 active occluders").
ACTIVE_OCCLUDERS = 15

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
        inside when ``n . x + d >= 0``. Rows ``0..k-2`` are the side planes,
        each through the eye and one silhouette edge; row ``k-1`` is the near
        cap. ``d`` already includes the safety margin (see :data:`MARGIN_RELATIVE`):
        a point is culled only when it is inside by more than the margin.
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
        """``(4,)`` the near cap plane (inward-positive: away from the eye)."""
        return self.planes[-1]


# ----------------------------------------------------------------------------- occluder sets
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
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
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
    area_vec = 0.5 * np.cross(p - c, np.roll(p, -1, axis=0) - c).sum(axis=0)
    area = float(np.linalg.norm(area_vec))
    scale = float(np.linalg.norm(p.max(axis=0) - p.min(axis=0)))
    if not area > SHAPE_TOLERANCE * scale**2:
        raise InputError(f"{what}: zero area")
    normal = area_vec / area
    if np.abs((p - c) @ normal).max() > SHAPE_TOLERANCE * scale:
        raise InputError(f"{what}: not planar")
    e = np.roll(p, -1, axis=0) - p
    turn = np.cross(e, np.roll(e, -1, axis=0)) @ normal
    if turn.min() < -SHAPE_TOLERANCE * scale**2:
        raise InputError(f"{what}: not convex (or not a simple loop)")
    centroid = c  # the vertex mean: inside a convex polygon, enough for ranking
    return {"points": p, "normal": normal, "offset": float(normal @ c), "area": area,
            "centroid": centroid, "radius": float(np.linalg.norm(p - c, axis=1).max()),
            "scale": scale}


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
    s = _solid_arrays(vertices, faces, 0)
    v, n, off = s["vertices"], s["normals"], s["offset"]
    tol = SHAPE_TOLERANCE * s["scale"]
    # group faces by plane: same normal (dot ~ 1) and same offset
    groups = np.full(len(n), -1)
    planes = []
    for i in range(len(n)):  # loop over the solid's faces (a handful), not over rays
        if groups[i] >= 0:
            continue
        same = (n @ n[i] > 1 - 1e-9) & (np.abs(off - off[i]) <= tol) & (groups < 0)
        groups[same] = len(planes)
        planes.append(i)
    polygons = []
    for g, i in enumerate(planes):
        idx = np.unique(s["faces"][groups == g])
        pts = v[idx]
        normal = n[i]
        c = pts.mean(axis=0)
        # in-plane frame, angular order counter-clockwise about the outward normal
        ref = pts - c
        ax = ref[np.argmax(np.linalg.norm(ref, axis=1))]
        ax = ax / np.linalg.norm(ax)
        ay = np.cross(normal, ax)
        ang = np.arctan2(ref @ ay, ref @ ax)
        loop = pts[np.argsort(ang)]
        # drop vertices in the middle of an edge (collinear)
        e0 = loop - np.roll(loop, 1, axis=0)
        e1 = np.roll(loop, -1, axis=0) - loop
        keep = np.linalg.norm(np.cross(e0, e1), axis=1) > tol * s["scale"]
        polygons.append(loop[keep] if keep.sum() >= 3 else loop)
    return polygons


# ----------------------------------------------------------------------------- frustum building
def _side_planes(eye, a, b, inner, scale_ref):
    """Unit inward planes through ``eye`` and each edge (a[i], b[i]), oriented so that
    ``inner[i]`` is inside. Returns planes (e, 4) and a (e,) bool of valid ones."""
    n = np.cross(a - eye, b - eye)
    norm = np.linalg.norm(n, axis=1)
    ok = norm > _DEGENERATE_RELATIVE * scale_ref**2
    n = n / np.where(ok, norm, 1.0)[:, None]
    d = -(n @ eye)
    side = np.einsum("ij,ij->i", n, inner) + d
    flip = np.where(side < 0, -1.0, 1.0)
    ok &= np.abs(side) > 0
    return np.concatenate([n * flip[:, None], (d * flip)[:, None]], axis=1), ok


def _solid_frusta(solids: list[dict], eye: np.ndarray, select: np.ndarray | None = None):
    """Frusta of the chosen solids: (planes (P, 4), owner (P,) sorted, kept solid ids,
    per-frustum silhouette edge lists and near points)."""
    chosen = range(len(solids)) if select is None else select
    planes, owners, kept, sil, near = [], [], [], [], []
    for k in chosen:  # loop over the (at most ``active``) occluders of the frame
        s = solids[k]
        front = (s["normals"] @ eye - s["offset"]) > 0  # eye strictly in front of the face
        if not front.any():
            continue  # the eye is inside (or on) the solid
        silhouette = front[s["edge_face"]] & ~front[s["twin_face"]]  # eq. 1
        if not silhouette.any():
            continue
        v = s["vertices"]
        a, b = v[s["edge_a"][silhouette]], v[s["edge_b"][silhouette]]
        dist_ref = float(np.linalg.norm(eye - s["centroid"])) + s["scale"]
        side, ok = _side_planes(eye, a, b, np.broadcast_to(s["centroid"], a.shape), dist_ref)
        if not ok.all():
            continue  # the eye on the line of a silhouette edge: no safe frustum
        # eq. 2: the cap normal is the mean direction from the silhouette points
        # to the eye; our inward normal points the other way, away from the eye.
        points = a  # each silhouette vertex starts one edge of the (oriented) loop
        m = (points - eye).sum(axis=0)
        mn = np.linalg.norm(m)
        if not mn > 0:
            continue
        m = m / mn
        far = points[np.argmax(points @ m)]
        cap = np.concatenate([m, [-(m @ far)]])
        p = np.vstack([side, cap])
        p[:, 3] -= MARGIN_RELATIVE * dist_ref
        planes.append(p)
        owners.append(np.full(len(p), len(kept)))
        kept.append(k)
        sil.append(np.stack([a, b], axis=1))
        near.append(far)
    return planes, owners, kept, sil, near


def _polygon_frusta(polys: list[dict], eye: np.ndarray, select=None):
    """Frusta of the chosen convex polygons; as :func:`_solid_frusta`."""
    chosen = range(len(polys)) if select is None else select
    planes, owners, kept, sil, near = [], [], [], [], []
    for k in chosen:
        q = polys[k]
        h = float(q["normal"] @ eye - q["offset"])  # eye height over the polygon's plane
        dist_ref = float(np.linalg.norm(eye - q["centroid"])) + q["scale"]
        if abs(h) <= _DEGENERATE_RELATIVE * dist_ref:
            continue  # the eye in the polygon's plane
        p = q["points"]
        a, b = p, np.roll(p, -1, axis=0)
        side, ok = _side_planes(eye, a, b, np.broadcast_to(q["centroid"], a.shape), dist_ref)
        if not ok.all():
            continue
        sign = -1.0 if h > 0 else 1.0  # inward: the far side of the plane from the eye
        cap = np.concatenate([sign * q["normal"], [-sign * q["offset"]]])
        rows = np.vstack([side, cap])
        rows[:, 3] -= MARGIN_RELATIVE * dist_ref
        planes.append(rows)
        owners.append(np.full(len(rows), len(kept)))
        kept.append(k)
        sil.append(np.stack([a, b], axis=1))
        near.append(p[0])
    return planes, owners, kept, sil, near


def solid_frustum(vertices: npt.ArrayLike, faces: npt.ArrayLike,
                  eye: npt.ArrayLike) -> Frustum | None:
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

    Returns
    -------
    Frustum or None
        None when the eye is inside the solid or on its surface, or on the
        line of a silhouette edge (no safe frustum exists).

    Raises
    ------
    InputError
        If the solid is not closed, consistently oriented, convex, or has no
        volume; or ``eye`` is not a finite 3-vector.

    Notes
    -----
    Silhouette edges (eq. 1 of [1]_) are the edges between a triangle the eye
    sees strictly from the front and one it does not (edge-on triangles count
    as back-facing); oriented as in their front triangle they form the outline
    loop. Every side plane through the eye and a silhouette edge supports the
    solid, so their intersection is the cone of rays that hit the solid. The
    near cap has the normal of eq. 2 (the mean of ``S_i - C`` here: inward
    means away from the eye) and passes through the silhouette point furthest
    along it. Guarantee: every point inside all planes is hidden by the solid.
    In any plane through the eye the visible part of the solid's outline lies in
    the triangle of the eye and the two tangent points, so the whole visible
    surface lies in the convex hull of the eye and the silhouette, on the eye's
    side of the cap; a point behind the cap inside the cone is therefore at or
    beyond the visible surface along its ray from the eye.

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
    s = _solid_arrays(vertices, faces, 0)
    e = as_vector(eye, "eye")
    planes, _, kept, sil, near = _solid_frusta([s], e)
    if not kept:
        return None
    return Frustum(planes=planes[0], eye=e, silhouette=sil[0], near_point=near[0], kind="solid")


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
    planes, _, kept, sil, near = _polygon_frusta([q], e)
    if not kept:
        return None
    return Frustum(planes=planes[0], eye=e, silhouette=sil[0], near_point=near[0],
                   kind="planar")


# ----------------------------------------------------------------------------- box tests
def _as_boxes(lower, upper) -> tuple[np.ndarray, np.ndarray]:
    lo = as_points(lower, "lower", allow_empty=True)
    hi = as_points(upper, "upper", allow_empty=True)
    if lo.shape != hi.shape:
        raise InputError(f"lower and upper: shapes differ ({lo.shape} vs {hi.shape})")
    if (lo > hi).any():
        raise InputError("lower and upper: a lower corner exceeds its upper corner")
    return lo, hi


def _inside_any(planes: np.ndarray, owner: np.ndarray, lo: np.ndarray,
                hi: np.ndarray) -> np.ndarray:
    """(n,) bool: box wholly inside at least one frustum. ``owner`` sorted, (P,)."""
    n = len(lo)
    if n == 0 or len(planes) == 0:
        return np.zeros(n, dtype=bool)
    center = 0.5 * (lo + hi)
    half = 0.5 * (hi - lo)
    normals = planes[:, :3]
    # the box corner deepest outside each plane: n.c + d - |n|.h
    worst = center @ normals.T - half @ np.abs(normals).T + planes[:, 3]
    starts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
    per_frustum = np.minimum.reduceat(worst, starts, axis=1)
    return (per_frustum >= 0).any(axis=1)


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
    """Importance of solid occluders, f_solid = Vol / |V|^3 (Papaioannou et al. 2006, eq. 4).

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
    """Importance of planar occluders, f_planar = -A N.V / |V|^2 (eq. 3, after Coorg and Teller).

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


# ----------------------------------------------------------------------------- runtime
def _view_planes(camera) -> tuple[np.ndarray, np.ndarray]:
    """Four inward side planes of a perspective camera (unit normals, through the eye)."""
    f, r, u = camera.basis
    hx = camera._half
    hy = camera._half_vertical
    n = np.array([hx * f - r, hx * f + r, hy * f - u, hy * f + u])
    n /= np.linalg.norm(n, axis=1)[:, None]
    return n, -(n @ camera.position)


class FrustumCuller:
    """Per-frame shadow-frustum culling with an active set of the best occluders.

    Parameters
    ----------
    solids : list of (vertices, faces)
        Convex solid occluders: ``(v, 3)`` float vertices and ``(f, 3)`` int
        outward triangles each (``Occluder.parts["solids"]``).
    polygons : list of (m, 3) float, optional
        Extra convex planar occluders, two-sided. Default none.
    mode : {'solid', 'planar'}, optional
        'solid' (default): each solid gives one solid frustum, ranked by eq. 4,
        beside the polygons ranked by eq. 3 (one unified ranking, as [1]_
        sec. 3). 'planar': every face of every solid is its own planar
        occluder (coplanar triangles merged, see
        :func:`solid_faces_as_polygons`), ranked by eq. 3 as printed (faces
        turned away rank last): the planar-frusta runtime [1]_ compares with.
    active : int, optional
        Frusta built per frame: the ``active`` best-ranked occluders among those
        that may lie in the view (default 15, [1]_ sec. 3).

    Attributes
    ----------
    count : int
        Number of occluders (solids and polygons in 'solid' mode, polygons in
        'planar' mode).

    Raises
    ------
    InputError
        On a solid that is not closed, oriented and convex, a polygon that is
        not convex and planar, or a bad option.

    Notes
    -----
    Conservative: a box is culled only when it lies inside one frustum by more
    than the margin, and every frustum lies in its occluder's shadow (see
    :func:`solid_frustum`); with occluders inside the scene's geometry, no
    culled box is visible. Occluders whose bounding sphere is outside the
    camera's view are never selected (they could only cull boxes outside the
    view). Ranking and selection are recomputed every frame.

    References
    ----------
    .. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient
       Occlusion Culling using Solid Occluders". WSCG 2006, ISBN 80-86943-03-8.

    Examples
    --------
    >>> import trimesh
    >>> from viscore import PerspectiveCamera
    >>> wall = trimesh.creation.box(extents=(4, 1, 4))
    >>> culler = FrustumCuller([(wall.vertices, wall.faces)])
    >>> cam = PerspectiveCamera((0, -5, 0), (0, 1, 0), fov=90, resolution=64)
    >>> culler.cull(cam, [[-0.5, 3, -0.5], [5, 3, 0]], [[0.5, 4, 0.5], [6, 4, 1]]).tolist()
    [True, False]
    """

    def __init__(self, solids, *, polygons=None, mode: str = "solid",
                 active: int = ACTIVE_OCCLUDERS) -> None:
        if mode not in ("solid", "planar"):
            raise InputError(f"mode: expected 'solid' or 'planar', got {mode!r}")
        self.mode = mode
        self.active = as_positive_int(active, "active")
        solids = list(solids) if solids is not None else []
        polygons = list(polygons) if polygons is not None else []
        if mode == "planar":
            faces = []
            for v, f in solids:
                faces.extend(solid_faces_as_polygons(v, f))
            self._solids: list[dict] = []
            self._polys = [_polygon_arrays(p, i) for i, p in enumerate(faces + polygons)]
            self._two_sided = np.array([False] * len(faces) + [True] * len(polygons))
        else:
            self._solids = [_solid_arrays(v, f, i) for i, (v, f) in enumerate(solids)]
            self._polys = [_polygon_arrays(p, i) for i, p in enumerate(polygons)]
            self._two_sided = np.ones(len(polygons), dtype=bool)
        self._s_vol = np.array([s["volume"] for s in self._solids], dtype=np.float64)
        self._s_center = np.array([s["centroid"] for s in self._solids]).reshape(-1, 3)
        self._s_radius = np.array([s["radius"] for s in self._solids], dtype=np.float64)
        self._p_area = np.array([p["area"] for p in self._polys], dtype=np.float64)
        self._p_normal = np.array([p["normal"] for p in self._polys]).reshape(-1, 3)
        self._p_center = np.array([p["centroid"] for p in self._polys]).reshape(-1, 3)
        self._p_radius = np.array([p["radius"] for p in self._polys], dtype=np.float64)
        self.count = len(self._solids) + len(self._polys)

    @classmethod
    def from_occluders(cls, occluders, *, mode: str = "solid",
                       active: int = ACTIVE_OCCLUDERS) -> FrustumCuller:
        """Culler from generator outputs: their ``parts`` solids, boxes and polygons.

        Parameters
        ----------
        occluders : iterable of Occluder
            ``parts["solids"]`` are taken as they are; ``parts["boxes"]``
            become 12-triangle box solids when the occluder has no solids;
            ``parts["polygons"]`` become planar occluders when convex (others
            are skipped: a non-convex polygon has no convex frustum).
        mode, active
            As the constructor.

        Returns
        -------
        FrustumCuller
        """
        import trimesh

        solids, polygons = [], []
        unit = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
        for occ in occluders:
            parts = occ.parts
            if "solids" in parts and len(parts["solids"]):
                solids.extend((np.asarray(v), np.asarray(f)) for v, f in parts["solids"])
            elif "boxes" in parts:
                for lo, hi in np.asarray(parts["boxes"], dtype=np.float64):
                    solids.append((lo + np.asarray(unit.vertices) * (hi - lo),
                                   np.asarray(unit.faces)))
            for i, p in enumerate(parts.get("polygons", [])):
                try:
                    _polygon_arrays(p, i)
                except InputError:
                    continue
                polygons.append(np.asarray(p, dtype=np.float64))
        return cls(solids, polygons=polygons, mode=mode, active=active)

    def _select(self, camera_or_eye) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Eye, chosen solid ids and chosen polygon ids (best ranked first)."""
        from .cameras import PerspectiveCamera

        if isinstance(camera_or_eye, PerspectiveCamera):
            eye = camera_or_eye.position
            vn, vd = _view_planes(camera_or_eye)
        else:
            eye = as_vector(camera_or_eye, "eye")
            vn = None
        rank = np.concatenate([rank_solids(self._s_vol, self._s_center, eye),
                               np.where(self._two_sided,
                                        np.abs(rank_planar(self._p_area, self._p_normal,
                                                           self._p_center, eye)),
                                        rank_planar(self._p_area, self._p_normal,
                                                    self._p_center, eye))])
        rank = np.nan_to_num(rank, nan=-np.inf)
        if vn is not None:
            centers = np.vstack([self._s_center, self._p_center])
            radii = np.concatenate([self._s_radius, self._p_radius])
            in_view = ((centers @ vn.T + vd) >= -radii[:, None]).all(axis=1)
            rank = np.where(in_view, rank, -np.inf)
        order = np.argsort(-rank, kind="stable")[:self.active]
        order = order[rank[order] > -np.inf]
        ns = len(self._solids)
        return eye, order[order < ns], order[order >= ns] - ns

    def _planes(self, camera_or_eye):
        eye, sel_s, sel_p = self._select(camera_or_eye)
        ps, os_, ks, ss, ns = _solid_frusta(self._solids, eye, sel_s)
        pp, op, kp, sp, np_ = _polygon_frusta(self._polys, eye, sel_p)
        return eye, ps + pp, ks, kp, ss + sp, ns + np_

    def frusta(self, camera_or_eye) -> list[Frustum]:
        """The frame's active frusta.

        Parameters
        ----------
        camera_or_eye : PerspectiveCamera or (3,) float
            With a camera, occluders outside its view are not selected.

        Returns
        -------
        list of Frustum
            At most ``active``; occluders the eye is inside of give none.
        """
        eye, planes, ks, kp, sil, near = self._planes(camera_or_eye)
        kinds = ["solid"] * len(ks) + ["planar"] * len(kp)
        return [Frustum(planes=p, eye=eye, silhouette=s, near_point=n, kind=k)
                for p, s, n, k in zip(planes, sil, near, kinds, strict=True)]

    def cull(self, camera_or_eye, lower: npt.ArrayLike, upper: npt.ArrayLike) -> np.ndarray:
        """Occludees hidden this frame: boxes wholly inside one active frustum.

        Parameters
        ----------
        camera_or_eye : PerspectiveCamera or (3,) float
            The frame's camera (its position is the eye).
        lower, upper : (n, 3) float
            Occludee bounding boxes, world units.

        Returns
        -------
        culled : (n,) bool

        Raises
        ------
        InputError
            On bad boxes or eye.
        """
        lo, hi = _as_boxes(lower, upper)
        _, planes, _, _, _, _ = self._planes(camera_or_eye)
        if not planes:
            return np.zeros(len(lo), dtype=bool)
        owner = np.repeat(np.arange(len(planes)), [len(p) for p in planes])
        return _inside_any(np.vstack(planes), owner, lo, hi)
