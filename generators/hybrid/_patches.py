"""Patch-based candidates of the hybrid occluder generator (Wu et al. 2022, sec. 3.1.1).

The five steps of the paper's patch-based mesh simplification, on a triangle
soup (loose parts, duplicated and intersecting faces, open boundaries):

References
----------
.. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (sec. 3.1.1 and the appendix)
.. [2] Garland, M., Heckbert, P. S. "Surface Simplification Using Quadric Error
   Metrics". Proceedings of SIGGRAPH '97, 1997, pp. 209-216.
   :DOI:`10.1145/258734.258849`
.. [3] Ramer, U. "An iterative procedure for the polygonal approximation of
   plane curves". Computer Graphics and Image Processing 1(3), 1972,
   pp. 244-256. :DOI:`10.1016/S0146-664X(72)80017-0`
.. [4] Young, J. et al. "xatlas: mesh parameterization / UV unwrapping
   library", https://github.com/jpcy/xatlas (charts of ``grouping='xatlas'``)
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import trimesh

from .._convex_bands import grid_bands, polygons_of
from .._plane_regions import plane_regions
from .._polygons import triangulate_polygon
from ._holes import OPEN_REASONS, judge_holes

_log = logging.getLogger(__name__)

#: Dihedral angle (radians) below which two faces lie in one planar patch
#: (Wu et al. 2022, sec. 3.1.1 step 1).
PLANAR_ANGLE = 1e-3

#: Largest distance of a face's vertex from its plane when planar patches are
#: regrouped by plane across loose parts, as a fraction of the bounding-box
#: diagonal (surface-patches' tolerance): panels of one wall modelled apart and
#: the float32 rounding of a glTF file join; a decal lifted 1 mm off a 10 m
#: wall, or the far face of a sheet 1e-6 of the diagonal thick (the plane test
#: takes both orientations), stays apart.
COPLANAR_TOLERANCE = 1e-7

#: Ramer-Douglas-Peucker tolerance for planar patch boundaries, as a fraction
#: of the input's bounding-box diagonal. The paper gives no value; this drops
#: the collinear T-junction vertices of panelled walls and sub-millimetre
#: steps of a 10 m building, and keeps every feature a game occluder needs.
RDP_TOLERANCE = 2e-3

#: Largest share of a planar patch's area that Ramer-Douglas-Peucker may take
#: away; a patch that would lose more (narrower than the tolerance: a needle,
#: a thin trim) keeps its unsimplified outline.
RDP_MAX_AREA_LOSS = 0.1

#: Grid (fraction of the diagonal) the planar union snaps to: GEOS unions of
#: many triangles are exact only on a precision grid; 1e-7 of the diagonal is
#: far below any feature and above float64 noise of the projection.
SNAP = 1e-7

#: Share of its faces a curved patch keeps after quadric simplification. The
#: paper gives no target; with boundaries kept, smooth patches (vaults,
#: pillars, rounded roofs) reach it with little error, and the patch reduction
#: and the metric-guided step select among the results anyway.
CURVED_KEEP = 0.1

#: Planar patches are simplified largest first (by their triangles' area) while
#: that area, times this factor, reaches the area of the smallest patch the
#: reduction would keep among those made so far (the largest patches up to N_P
#: faces): a patch's pieces are no larger than its triangles' area unless hole
#: filling grows them, which this factor allows for. Saves the per-patch
#: polygon work on buildings of thousands of small panels.
PROCESS_FACTOR = 2

#: Quadric weights of the paper's appendix: a small planar weight against
#: degenerate quadrics on coplanar neighbourhoods, a large boundary weight.
PLANAR_QUADRIC_WEIGHT = 1e-3
BOUNDARY_WEIGHT = 1e3

#: Rings whose area is below this fraction of the squared diagonal are dropped
#: (slivers left by the union or by Ramer-Douglas-Peucker).
_MIN_RING_AREA = 1e-10


@dataclass(frozen=True)
class Patch:
    """One simplified patch, ready to join the candidate set.

    Attributes
    ----------
    vertices : (v, 3) float64
        World units.
    faces : (f, 3) int64
    area : float
        World units^2 (after hole filling).
    kind : {'planar', 'curved'}
    holes_filled, holes_open : int
        Holes of a planar patch filled, and kept open, by the segment test.
    open_reasons : tuple of str
        Why each open hole stays open (:data:`._holes.OPEN_REASONS`); empty
        when the test did not run.
    """

    vertices: np.ndarray
    faces: np.ndarray
    area: float
    kind: str
    holes_filled: int = 0
    holes_open: int = 0
    open_reasons: tuple = ()


@dataclass(frozen=True)
class PatchCandidates:
    """The patch-based candidate set and its bookkeeping.

    Attributes
    ----------
    mesh : trimesh.Trimesh
        The kept patches, concatenated (no vertex shared between patches).
    face_patch : (f,) int64
        The patch of each face of ``mesh`` (index into the kept patches).
    info : dict
        ``planar_patches``, ``curved_patches`` (after grouping),
        ``patches_kept``, ``planar_patches_skipped`` (too small to be
        simplified, see :data:`PROCESS_FACTOR`), ``faces_before_reduction``
        (of the patches simplified), ``holes_filled``, ``holes_open``,
        ``holes_open_why`` (open holes by reason, :data:`._holes.OPEN_REASONS`;
        all zero without the hole test),
        ``grouping``, ``coplanar``; ``groups`` counts the patches after
        grouping (planar regions across loose parts with ``coplanar``).
    """

    mesh: trimesh.Trimesh
    face_patch: np.ndarray
    info: dict = field(default_factory=dict)


def clean_soup(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Positions merged, degenerate and duplicated faces dropped; nothing else changed.

    Two faces on the same three vertices are duplicates whatever their
    winding (a double-sided panel drawn twice); the first one is kept.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Any triangle soup (validated by the caller).

    Returns
    -------
    trimesh.Trimesh
        A new mesh; vertex attributes (normals, UVs) are not carried over, so
        vertices at one position merge whatever seams they had.
    """
    out = trimesh.Trimesh(np.asarray(mesh.vertices, dtype=np.float64),
                          np.asarray(mesh.faces, dtype=np.int64), process=False)
    out.merge_vertices()
    faces = np.asarray(out.faces, dtype=np.int64)
    keep = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (
        faces[:, 0] != faces[:, 2])
    tri = np.asarray(out.vertices)[faces]
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    diag = float(np.linalg.norm(np.ptp(np.asarray(out.vertices), axis=0)))
    keep &= area2 > 1e-14 * diag * diag
    faces = faces[keep]
    _, first = np.unique(np.sort(faces, axis=1), axis=0, return_index=True)
    faces = faces[np.sort(first)]
    out = trimesh.Trimesh(np.asarray(out.vertices), faces, process=False)
    out.remove_unreferenced_vertices()
    return out


def _unit_normals(mesh: trimesh.Trimesh) -> np.ndarray:
    tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return n / np.linalg.norm(n, axis=1)[:, None]


def face_pairs(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """Every pair of faces sharing an edge, and their dihedral angle.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Merged vertices, no degenerate faces (:func:`clean_soup`).

    Returns
    -------
    pairs : (m, 2) int64
        Face indices; an edge of ``k`` faces gives all ``k (k - 1) / 2`` pairs.
    angle : (m,) float64
        Angle between the two faces' normals in radians, in [0, pi], with one
        normal flipped when the two faces run their shared edge the same way
        (inconsistent winding): coplanar faces give 0 whatever their winding.
    """
    faces = np.asarray(mesh.faces, dtype=np.int64)
    nf = len(faces)
    directed = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)
    owner = np.repeat(np.arange(nf), 3)
    key = np.sort(directed, axis=1)
    _, edge = np.unique(key, axis=0, return_inverse=True)
    edge = edge.reshape(-1)
    order = np.argsort(edge, kind="stable")
    edge_s, owner_s = edge[order], owner[order]
    forward_s = (directed[:, 0] < directed[:, 1])[order]
    firsts, seconds, same = [], [], []
    offset = 1
    while offset < len(edge_s):
        match = np.flatnonzero(edge_s[offset:] == edge_s[:-offset])
        if len(match) == 0:
            break
        firsts.append(owner_s[match])
        seconds.append(owner_s[match + offset])
        same.append(forward_s[match] == forward_s[match + offset])
        offset += 1
    if not firsts:
        return np.zeros((0, 2), dtype=np.int64), np.zeros(0)
    pairs = np.stack([np.concatenate(firsts), np.concatenate(seconds)], axis=1)
    same_way = np.concatenate(same)
    keep = pairs[:, 0] != pairs[:, 1]
    pairs, same_way = pairs[keep], same_way[keep]
    normals = _unit_normals(mesh)
    na, nb = normals[pairs[:, 0]], normals[pairs[:, 1]]
    nb = np.where(same_way[:, None], -nb, nb)
    angle = np.arctan2(np.linalg.norm(np.cross(na, nb), axis=1), np.einsum("ij,ij->i", na, nb))
    return pairs, angle


def _components(n: int, pairs: np.ndarray) -> np.ndarray:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(graph, directed=False)[1].astype(np.int64)


def planar_patch_labels(mesh: trimesh.Trimesh, *, angle: float = PLANAR_ANGLE,
                        pairs: tuple | None = None) -> np.ndarray:
    """Planar patch of each face: components of faces joined below ``angle`` (radians).

    Returns
    -------
    labels : (f,) int64
        Patch index per face, 0 .. patches - 1.
    """
    pairs, ang = face_pairs(mesh) if pairs is None else pairs
    return _components(len(mesh.faces), pairs[ang < angle])


def curved_patch_labels(mesh: trimesh.Trimesh, planar: np.ndarray, *, eps_a: float,
                        pairs: tuple | None = None) -> np.ndarray:
    """Group of each face: planar patches joined across any edge below ``eps_a`` (radians).

    Returns
    -------
    labels : (f,) int64
        Group index per face; a group of one planar patch is that planar patch.
    """
    pairs, ang = face_pairs(mesh) if pairs is None else pairs
    join = pairs[ang < eps_a]
    join = planar[join]
    join = join[join[:, 0] != join[:, 1]]
    return _components(int(planar.max()) + 1, join)[planar]


def xatlas_patch_labels(mesh: trimesh.Trimesh, planar: np.ndarray) -> np.ndarray:
    """Group of each face from xatlas's charts; faces xatlas leaves out keep their planar patch.

    Returns
    -------
    labels : (f,) int64
    """
    import xatlas

    atlas = xatlas.Atlas()
    atlas.add_mesh(np.asarray(mesh.vertices, dtype=np.float32),
                   np.asarray(mesh.faces, dtype=np.uint32))
    options = xatlas.ChartOptions()
    # charts only: packing into a texture is not needed
    pack = xatlas.PackOptions()
    atlas.generate(chart_options=options, pack_options=pack)
    labels = np.full(len(mesh.faces), -1, dtype=np.int64)
    for c in range(atlas.get_mesh_chart_count(0)):
        labels[np.asarray(atlas.get_mesh_chart(0, c).faces, dtype=np.int64)] = c
    missing = labels < 0
    if missing.any():
        _, extra = np.unique(planar[missing], return_inverse=True)
        labels[missing] = labels.max() + 1 + extra.reshape(-1)
    return np.unique(labels, return_inverse=True)[1].reshape(-1).astype(np.int64)


def _plane_frame(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(4, 3)``: origin, u, v, n of the plane of a planar patch (area-weighted)."""
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    ref = cross[np.argmax(np.linalg.norm(cross, axis=1))]
    signs = np.where(cross @ ref < 0, -1.0, 1.0)
    n = (cross * signs[:, None]).sum(axis=0)
    n /= np.linalg.norm(n)
    helper = np.eye(3)[np.argmin(np.abs(n))]
    u = np.cross(n, helper)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    origin = (tri.mean(axis=1) * area[:, None]).sum(axis=0) / area.sum()
    return np.stack([origin, u, v, n])


def _rdp_polygon(polygon, tolerance: float, min_area: float) -> list:
    """Ramer-Douglas-Peucker on every ring of a shapely polygon; valid polygons back."""
    import shapely
    from skimage.measure import approximate_polygon

    def ring(coords) -> np.ndarray | None:
        pts = approximate_polygon(np.asarray(coords, dtype=np.float64), tolerance)
        if len(pts) < 4 or abs(shapely.area(shapely.Polygon(pts))) < min_area:
            return None
        return pts

    outer = ring(polygon.exterior.coords)
    holes = [h for h in (ring(r.coords) for r in polygon.interiors) if h is not None]
    pieces = []
    if outer is not None:
        fixed = shapely.make_valid(shapely.Polygon(outer, holes))
        pieces = [g for g in polygons_of(fixed) if g.area >= min_area]
    if sum(g.area for g in pieces) < (1 - RDP_MAX_AREA_LOSS) * polygon.area:
        # a patch narrower than the tolerance: kept as it is rather than lost
        return [polygon] if polygon.area >= min_area else []
    return pieces


def _planar_patch(vertices, faces, scene, tree, *, diagonal: float, rdp: float,
                  segment_length: float, fill_holes: bool, rng,
                  bands: bool = False) -> list[Patch]:
    """Union, RDP, hole test and re-triangulation of one planar patch; one Patch per piece,
    or with ``bands`` one per convex band of a piece whose open holes remain."""
    import shapely

    frame = _plane_frame(vertices, faces)
    origin, u, v = frame[0], frame[1], frame[2]
    local = vertices - origin
    xy = np.stack([local @ u, local @ v], axis=1)
    tris = shapely.polygons(xy[faces])
    union = shapely.union_all(tris, grid_size=SNAP * diagonal)
    min_area = _MIN_RING_AREA * diagonal * diagonal
    pieces = [q for p in polygons_of(union) for q in _rdp_polygon(p, rdp, min_area)]
    out = []
    for piece in pieces:
        holes = [shapely.Polygon(r) for r in piece.interiors]
        filled = np.zeros(len(holes), dtype=bool)
        reasons: list = []
        if holes and fill_holes:
            filled, reasons = judge_holes(scene, holes, frame, segment_length=segment_length,
                                          rng=rng)
        kept = [r for r, f in zip(piece.interiors, filled, strict=True) if not f]
        poly = shapely.Polygon(piece.exterior, kept)
        tally = (int(filled.sum()), int(len(holes) - filled.sum()),
                 tuple(r for r in reasons if r is not None))
        for band in _holed_bands(poly, SNAP * diagonal) if bands else [poly]:
            v2, t = triangulate_polygon(band)
            if len(t) == 0:
                continue
            # counter-clockwise in (u, v): the patch keeps the winding of its faces
            a, b, c = v2[t[:, 0]], v2[t[:, 1]], v2[t[:, 2]]
            cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (
                c[:, 0] - a[:, 0]) < 0
            t[cw] = t[cw][:, ::-1]
            v3 = origin + v2[:, :1] * u + v2[:, 1:2] * v
            # ring vertices that are input vertices get their exact positions back
            dist, near = tree.query(v3)
            snap = dist <= SNAP * diagonal
            v3[snap] = vertices[near[snap]]
            out.append(Patch(v3, t, float(band.area), "planar", *tally))
            tally = (0, 0, ())  # the piece's holes counted once, on its first band
    return out


def _holed_bands(poly, step: float) -> list:
    """``poly`` as it is without holes, else its convex bands on a grid of ``step``."""
    import shapely.affinity

    if not poly.interiors:
        return [poly]
    return [shapely.affinity.scale(b, step, step, origin=(0, 0)) for b in grid_bands(poly, step)]


def _curved_patches(vertices, faces, labels, groups) -> list[Patch]:
    """Quadric simplification of every curved group at once, boundaries kept (pymeshlab)."""
    import pymeshlab

    from .._decimate import quadric_edge_collapse

    if len(groups) == 0:
        return []
    pick = np.isin(labels, groups)
    f = faces[pick]
    g = labels[pick]
    # one copy of each vertex per group, so that every group's outline is a boundary
    key = g[:, None] * len(vertices) + f
    uniq, inv = np.unique(key.reshape(-1), return_inverse=True)
    v = vertices[uniq % len(vertices)]
    fl = inv.reshape(-1, 3)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=v, face_matrix=fl.astype(np.int32),
                               f_scalar_array=g.astype(np.float64)))
    target = max(len(groups), int(np.ceil(CURVED_KEEP * len(fl))))
    if target < len(fl):
        quadric_edge_collapse(
            ms, targetfacenum=target, preserveboundary=True, boundaryweight=BOUNDARY_WEIGHT,
            preservetopology=True, preservenormal=True, optimalplacement=True,
            planarquadric=True, planarweight=PLANAR_QUADRIC_WEIGHT, autoclean=True)
    m = ms.current_mesh()
    ov = np.asarray(m.vertex_matrix(), dtype=np.float64)
    of = np.asarray(m.face_matrix(), dtype=np.int64)
    og = np.rint(np.asarray(m.face_scalar_array())).astype(np.int64)
    out = []
    for grp in np.unique(og):
        sel = of[og == grp]
        used, local = np.unique(sel.reshape(-1), return_inverse=True)
        pv = ov[used]
        pf = local.reshape(-1, 3)
        tri = pv[pf]
        area = 0.5 * float(np.linalg.norm(
            np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum())
        out.append(Patch(pv, pf, area, "curved"))
    return out


def coplanar_labels(vertices: np.ndarray, faces: np.ndarray, groups: np.ndarray,
                    is_planar: np.ndarray, *, tolerance: float) -> np.ndarray:
    """Groups with every planar group's faces regrouped by plane across loose parts.

    Parameters
    ----------
    vertices : (v, 3) float64
    faces : (f, 3) int64
    groups : (f,) int64
        Group of each face (planar and curved patches), 0 .. g - 1.
    is_planar : (g,) bool
        Which groups are planar patches.
    tolerance : float
        World units: largest distance of a face's vertex from its region's
        plane (:func:`viscore.generators._plane_regions.plane_regions`).

    Returns
    -------
    labels : (f,) int64
        New group of each face, 0 .. g' - 1: curved groups unchanged, the
        faces of planar groups relabelled by their plane region, faces
        facing one way only (a slab's top does not take in the bottoms of
        the walls standing on it; a face in no region, too small to fix a
        plane, keeps its planar patch).
    """
    member = np.flatnonzero(is_planar[groups])
    out = groups.copy()
    if len(member):
        regions = plane_regions(vertices, faces[member], tolerance=tolerance, both_sides=False)
        base = int(groups.max()) + 1
        for k, region in enumerate(regions):
            out[member[region.faces]] = base + k
    return np.unique(out, return_inverse=True)[1].reshape(-1).astype(np.int64)


def _smallest_kept(areas: list[float], faces: list[int], patch_faces: int) -> float:
    """Area of the smallest patch the reduction keeps among these; 0 while all fit."""
    if sum(faces) <= patch_faces:
        return 0.0
    a = np.asarray(areas)
    by_area = np.argsort(-a, kind="stable")
    over = int(np.argmax(np.cumsum(np.asarray(faces)[by_area]) > patch_faces))
    return float(a[by_area[over]])


def patch_candidates(mesh: trimesh.Trimesh, scene, *, eps_a: float, grouping: str,
                     patch_faces: int, fill_holes: bool, segment_length: float,
                     seed: int, coplanar: bool = True, bands: bool = False) -> PatchCandidates:
    """Patch-based candidate set of sec. 3.1.1 (steps 1-5 of the module docstring).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The input soup (validated by the caller).
    scene : viscore.Scene
        Embree scene of the input, for the hole test.
    eps_a : float
        Curved-patch dihedral threshold, radians.
    grouping : {'dihedral', 'xatlas'}
    patch_faces : int
        N_P of the reduction.
    fill_holes : bool
        Run the hole test (False keeps every hole open).
    segment_length : float
        l_s of the hole test, world units.
    seed : int
        Seeds the hole test's sample points.
    coplanar : bool, optional
        Regroup the planar patches by plane across loose parts
        (:func:`coplanar_labels`, default True); False keeps the paper's
        edge-connected planar patches.
    bands : bool, optional
        Cut a planar patch whose holes stay open into convex bands, each its
        own patch in the reduction (see the module docstring); default False
        keeps it whole, re-triangulated with its holes.

    Returns
    -------
    PatchCandidates
    """
    from scipy.spatial import cKDTree

    clean = clean_soup(mesh)
    vertices = np.asarray(clean.vertices, dtype=np.float64)
    faces = np.asarray(clean.faces, dtype=np.int64)
    diagonal = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    pairs = face_pairs(clean)
    planar = planar_patch_labels(clean, pairs=pairs)
    if grouping == "xatlas":
        groups = xatlas_patch_labels(clean, planar)
    else:
        groups = curved_patch_labels(clean, planar, eps_a=eps_a, pairs=pairs)
    # a group is planar when all its faces lie in one planar patch
    ng = int(groups.max()) + 1
    lo = np.full(ng, np.iinfo(np.int64).max)
    hi = np.full(ng, -1)
    np.minimum.at(lo, groups, planar)
    np.maximum.at(hi, groups, planar)
    is_planar = lo == hi
    if coplanar:
        planar_face = is_planar[groups]
        groups = coplanar_labels(vertices, faces, groups, is_planar,
                                 tolerance=COPLANAR_TOLERANCE * diagonal)
        ng = int(groups.max()) + 1
        is_planar = np.zeros(ng, dtype=bool)  # a new group holds planar faces only, or none
        is_planar[groups[planar_face]] = True
    rng = np.random.default_rng(seed)
    rdp = RDP_TOLERANCE * diagonal
    tree = cKDTree(vertices)
    patches: list[Patch] = []
    order = np.argsort(groups, kind="stable")
    starts = np.searchsorted(groups[order], np.arange(ng + 1))
    # planar patches by their triangles' area, largest first, simplified while one of their
    # pieces could still enter the reduction (PROCESS_FACTOR)
    tri = vertices[faces]
    face_area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                                     axis=1)
    raw_area = np.bincount(groups, weights=face_area, minlength=ng)
    planar_groups = np.flatnonzero(is_planar)
    planar_groups = planar_groups[np.argsort(-raw_area[planar_groups], kind="stable")]
    skipped = 0
    made_area: list[float] = []
    made_faces: list[int] = []
    for k, grp in enumerate(planar_groups):
        if PROCESS_FACTOR * raw_area[grp] < _smallest_kept(made_area, made_faces, patch_faces):
            skipped = len(planar_groups) - k
            break
        idx = order[starts[grp]:starts[grp + 1]]
        new = _planar_patch(vertices, faces[idx], scene, tree, diagonal=diagonal, rdp=rdp,
                            segment_length=segment_length, fill_holes=fill_holes, rng=rng,
                            bands=bands)
        made_area += [p.area for p in new]
        made_faces += [len(p.faces) for p in new]
        patches += new
    patches += _curved_patches(vertices, faces, groups, np.flatnonzero(~is_planar))
    counts = np.array([len(p.faces) for p in patches], dtype=np.int64)
    areas = np.array([p.area for p in patches])
    by_area = np.argsort(-areas, kind="stable")
    running = np.cumsum(counts[by_area])
    # add patches by area until the face count first exceeds N_P (that patch included)
    over = np.flatnonzero(running > patch_faces)
    keep = by_area if len(over) == 0 else by_area[:over[0] + 1]
    kept = [patches[i] for i in keep]
    info = {"grouping": grouping, "coplanar": bool(coplanar), "bands": bool(bands),
            "planar_patches": int(planar.max()) + 1,
            "groups": ng, "curved_patches": int((~is_planar).sum()),
            "patches": len(patches), "patches_kept": len(kept),
            "planar_patches_skipped": int(skipped),
            "faces_before_reduction": int(counts.sum()),
            "holes_filled": int(sum(p.holes_filled for p in patches)),
            "holes_open": int(sum(p.holes_open for p in patches)),
            "holes_open_why": {r: sum(p.open_reasons.count(r) for p in patches)
                               for r in OPEN_REASONS}}
    if not kept:
        empty = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64),
                                process=False)
        return PatchCandidates(empty, np.zeros(0, dtype=np.int64), info)
    offsets = np.cumsum([0] + [len(p.vertices) for p in kept])
    out_v = np.concatenate([p.vertices for p in kept])
    out_f = np.concatenate([p.faces + o for p, o in zip(kept, offsets, strict=False)])
    face_patch = np.repeat(np.arange(len(kept)), [len(p.faces) for p in kept])
    return PatchCandidates(trimesh.Trimesh(out_v, out_f, process=False), face_patch, info)
