"""Conservative reduced-resolution depth buffer of occluders, by ray casting, and its occludee test.

The runtime of the occluder-skins paper [1]_, secs. 5-6, on rays instead of a
rasterizer: a gap narrower than a pixel never hides what lies behind it.

References
----------
.. [1] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
   Bursztyn, A. P. M. "Implementing software occlusion culling for real-time
   applications". XVIII Congreso Argentino de Ciencias de la Computacion
   (CACIC 2012), Workshop de Computacion Grafica, Imagenes y Visualizacion,
   2012. http://sedici.unlp.edu.ar/handle/10915/23640 (the "Occluder Skins"
   paper: sec. 5 depth buffer generation, sec. 6 occludee test, sec. 7 a
   buffer of a quarter of the screen's size)
.. [2] Zhang, H., Manocha, D., Hudson, T., Hoff, K. "Visibility Culling using
   Hierarchical Occlusion Maps". SIGGRAPH 1997. :DOI:`10.1145/258734.258781`
.. [3] Haines, E. "Fast Ray-Convex Polyhedron Intersection". In Arvo, J. (ed.),
   Graphics Gems II, Academic Press, 1991, pp. 247-250.
.. [4] Warnock, J. E. "A Hidden Surface Algorithm for Computer Generated
   Halftone Pictures". Technical report TR 4-15, Computer Science Department,
   University of Utah, 1969.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import trimesh

from .._validate import InputError, as_positive_int, check_memory
from ..constants import DEFAULT_REDUCTION
from ..ray.cameras import PerspectiveCamera
from ..ray.embree_scene import Scene
from ._creases import flat_pairs, height_field_patches
from ._sheets import mesh_sheets
from .shadow_frusta import _as_boxes

__all__ = ["OccluderScene", "ConservativeDepthBuffer", "DEFAULT_REDUCTION",
           "DEPTH_MARGIN_RELATIVE"]

#: Stored depths are widened by this fraction of (occluder scene diagonal +
#: distance from the eye to its centre), far beyond the float64 rounding of the
#: entry distances: a depth is never reported nearer than the occluder really is.
DEPTH_MARGIN_RELATIVE = 1e-5

#: Tolerance for coplanarity (fraction of the mesh's diagonal) and for convex unions
#: of facets (relative area).
_FACET_TOLERANCE = 1e-9

#: Whether pixels still without a depth get one from the contour rule
#: (:mod:`viscore.culling._contour`): the centre ray meets an occluder and no contour edge
#: of the occluders crosses the pixel.
CONTOUR_RULE = False

#: Whether pixels still without a depth get one from the sheet rule
#: (:mod:`viscore.culling._sheets`): the four corner rays first hit one edge-connected
#: set of triangles and no contour edge of it crosses the pixel.
SHEET_RULE = True

#: Whether pixels still without a depth get one from the junction rule
#: (:mod:`viscore.culling._junctions`): the union of the occluder triangles over the pixel,
#: from any sheets or meshes, covers its square (decided exactly).
JUNCTION_RULE = True

#: Whether :meth:`ConservativeDepthBuffer.occluded_triangles` decides the pixels where a
#: triangle fails the depth test by the cover rule (:mod:`viscore.culling._occludee_cover`):
#: occluder triangles it lies behind cover the pixel, or every part of it the triangle's
#: projection meets.
COVER_RULE = True

#: Failing pixels (of all its triangles) an occludee may leave to the cover rule; one with
#: more is kept (visible objects fail in many pixels and stop here).
COVER_PIXELS = 64

#: Side of the coarsest tiles, in buffer pixels (a power of two).
_TILE = 16

#: Widening of an occludee's screen rectangle, in buffer pixels: its corners are
#: projected in float64 (about 1e-15 relative), so a rectangle edge is never drawn
#: inside the box's true projection.
_RECT_SLACK = 1e-9

#: Peak bytes per corner of one frame (labels, the depth grid, the rays cast).
_BYTES_PER_RAY = 160

#: Below this estimate (bytes) a frame is not checked against the available memory
#: (reading it costs more than a small frame).
_CHECKED_BYTES = 1 << 26

_UNIT_BOX = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])

#: The eight corners of a box as 0/1 multipliers of its extents, (8, 3).
_CORNERS = np.array(list(np.ndindex(2, 2, 2)), dtype=np.float64)


def _merged(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Faces re-indexed onto vertices merged at equal positions."""
    _, inverse = np.unique(vertices, axis=0, return_inverse=True)
    return inverse.reshape(-1)[faces]


def _facet_labels(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(f,) int64 label per triangle: shared by the triangles of a convex planar facet,
    unique otherwise. Labels are 0..(number of labels - 1)."""
    n = len(faces)
    label = np.arange(n, dtype=np.int64)
    if n < 2:
        return label
    # trimesh's facet tolerances are absolute: work on the mesh scaled to unit size
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    size = float(np.linalg.norm(hi - lo)) or 1.0
    unit = (vertices - 0.5 * (lo + hi)) / size
    mesh = trimesh.Trimesh(unit, _merged(vertices, faces), process=False)
    tri = unit[faces]
    tol = _FACET_TOLERANCE
    for group in mesh.facets:  # a loop over facets (precomputation), not over rays
        pts = tri[group].reshape(-1, 3)
        normal = mesh.face_normals[group[0]]
        if np.abs((pts - pts[0]) @ normal).max() > tol:
            continue  # not planar within tolerance
        ax = pts[1] - pts[0] if np.linalg.norm(pts[1] - pts[0]) > 0 else pts[2] - pts[0]
        ax = ax / np.linalg.norm(ax)
        ay = np.cross(normal, ax)
        flat = np.stack([(pts - pts[0]) @ ax, (pts - pts[0]) @ ay], axis=1)
        t2 = flat.reshape(-1, 3, 2)
        e1, e2 = t2[:, 1] - t2[:, 0], t2[:, 2] - t2[:, 0]
        area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
        try:
            from scipy.spatial import ConvexHull

            hull_area = float(ConvexHull(flat).volume)
        except Exception:  # noqa: BLE001 - qhull on a degenerate facet: keep triangles apart
            continue
        if abs(hull_area - area) <= _FACET_TOLERANCE * max(hull_area, 1e-12):
            label[group] = group.min()
    _, dense = np.unique(label, return_inverse=True)
    return dense.astype(np.int64)




#: Planes of coplanar regions agree to this fraction of the scene's size (normal
#: components and offsets rounded to it): exactly coplanar up to float64 rounding, so
#: a region's triangles leave no crack between them along any ray.
_REGION_TOLERANCE = 1e-11

#: Widening of a tile, in buffer pixels, when testing whether a region's boundary
#: crosses it (the boundary is projected in float64).
_SEGMENT_SLACK = 1e-3

#: A plane of one planar facet is a region too when the facet holds at least this share
#: of the occluders' area (a wall, a floor); smaller lone facets (of curved surfaces) are
#: left to the convex-piece rule.
_LONE_FACET_SHARE = 1e-4

#: Largest distance, as a fraction of the scene's size, of a region boundary's end from
#: both planes of a crease for the boundary to count as lying on their line
#: (:func:`viscore.culling._depth_kernel.region_creases`).
_CREASE_TOLERANCE = 1e-9


def _plane_regions(tri: np.ndarray, unit: np.ndarray, twice: np.ndarray, facet: np.ndarray,
                   bounds: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Coplanar regions of occluder triangles and the boundaries of their unions.

    ``tri`` (f, 3, 3) the triangles, ``unit`` their unit normals and ``twice``
    twice their areas (as :class:`OccluderScene` has them), ``facet`` their
    planar facets, ``bounds`` (2, 3) the box of the occluders' vertices.

    Triangles lying in one plane (up to :data:`_REGION_TOLERANCE` of the scene's
    size, either orientation), whatever their connectivity or the occluder they
    come from, form a region when they span more than one planar facet, or one facet
    of at least :data:`_LONE_FACET_SHARE` of the occluders' area (so that the crease
    rule, :func:`viscore.culling._depth_kernel.region_creases`, knows its boundary). Its
    union is taken in the plane (shapely ``union_all``, exact noding) and its
    boundary (outer rings and holes) kept as 3D segments.

    Returns
    -------
    region : (f,) int64
        Region of each triangle, -1 for none.
    plane : (R, 5) float64
        Each region's unit normal, offset (n.x = offset) and slack (largest
        distance of its vertices from the plane).
    segments : (S, 2, 3) float64
        Boundary segments of the regions' unions, world units.
    start : (R + 1,) int64
        Region ``k``'s segments are ``segments[start[k]:start[k + 1]]``.
    """
    import shapely

    n_tri = len(tri)
    region = np.full(n_tri, -1, dtype=np.int64)
    empty = (region, np.zeros((0, 5)), np.zeros((0, 2, 3)), np.zeros(1, np.int64))
    if n_tri < 2:
        return empty
    lo, hi = bounds
    size = float(np.linalg.norm(hi - lo)) or 1.0
    ok = twice > 1e-24 * size * size
    normal = unit.copy()
    # one orientation per plane: the largest component positive
    big = np.argmax(np.abs(normal), axis=1)
    normal *= np.where(normal[np.arange(n_tri), big] < 0, -1.0, 1.0)[:, None]
    offset = np.einsum("ij,ij->i", normal, tri[:, 0] - lo)
    key = np.round(np.concatenate([normal, offset[:, None] / size], axis=1)
                   / _REGION_TOLERANCE).astype(np.int64)
    idx = np.flatnonzero(ok)
    if len(idx) < 2:
        return empty
    _, group = np.unique(key[idx], axis=0, return_inverse=True)
    group = group.reshape(-1)
    order = np.argsort(group, kind="stable")
    bounds = np.flatnonzero(np.r_[True, group[order][1:] != group[order][:-1], True])
    planes: list[np.ndarray]
    planes, segs, start = [], [], [0]
    large = _LONE_FACET_SHARE * float(twice[ok].sum())
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):  # a loop over planes
        members = idx[order[a:b]]
        if len(np.unique(facet[members])) < 2 and float(twice[members].sum()) < large:
            continue  # one small facet: the convex-piece rule covers it already
        seed = members[np.argmax(twice[members])]
        n = normal[seed]
        o = tri[seed, 0]
        slack = float(np.abs((tri[members] - o) @ n).max())
        helper = np.eye(3)[int(np.argmin(np.abs(n)))]
        u = np.cross(n, helper)
        u /= np.linalg.norm(u)
        w = np.cross(n, u)
        local = tri[members] - o
        xy = np.stack([local @ u, local @ w], axis=2)
        polys = shapely.polygons(xy)
        polys = polys[shapely.area(polys) > 0]
        if len(polys) < 1:
            continue
        union = shapely.union_all(polys)
        rings = []
        for poly in getattr(union, "geoms", [union]):
            if poly.is_empty or poly.geom_type != "Polygon":
                continue
            rings.append(np.asarray(poly.exterior.coords))
            rings.extend(np.asarray(r.coords) for r in poly.interiors)
        if not rings:
            continue
        pts2 = np.concatenate([np.stack([r[:-1], r[1:]], axis=1) for r in rings])
        seg = o + pts2[..., :1] * u + pts2[..., 1:] * w  # (k, 2, 3)
        region[members] = len(planes)
        planes.append(np.r_[n, n @ o, slack])
        segs.append(seg)
        start.append(start[-1] + len(seg))
    if not planes:
        return empty
    return region, np.array(planes), np.concatenate(segs), np.array(start, np.int64)


class OccluderScene:
    """Occluder triangles in one Embree scene, labelled by convex piece; reused every frame.

    Parameters
    ----------
    occluders : Occluder, trimesh.Trimesh, (vertices, faces) or a list of these
        An :class:`viscore.generators.Occluder` contributes its ``parts``:
        each of ``parts["solids"]`` is one convex piece (checked convex; a
        solid that is not falls back to its planar facets), else each of
        ``parts["boxes"]``; with neither, its ``mesh`` as a ``trimesh.Trimesh``
        is taken: each connected part that is a closed, outward-facing convex
        solid (vertices merged at equal positions; checked as the shadow frusta
        check their solids) is one convex piece, the other triangles go by planar
        facets (a level's own crates and pillars as occluders cover the pixels
        across their edges). A ``(vertices, faces)`` pair is taken as a convex
        solid.
    workers : int, optional
        Ray-casting threads (default :func:`viscore.get_workers`).

    Attributes
    ----------
    scene : Scene
        Embree scene of all occluder triangles.
    pieces : int
        Number of convex pieces (solids and facets).

    Raises
    ------
    InputError
        If no occluder triangle is given.

    Examples
    --------
    >>> box = trimesh.creation.box()
    >>> occ = OccluderScene([box, (box.vertices + 3, box.faces)])
    >>> occ.scene.faces.shape, occ.pieces    # the closed convex mesh a solid too
    ((24, 3), 2)
    >>> OccluderScene([box.subdivide_to_size(0.5)]).pieces  # one solid still
    1
    """

    def __init__(self, occluders, *, workers: int | None = None) -> None:
        from .shadow_frusta import _plane_groups, _solid_arrays

        items = occluders if isinstance(occluders, list | tuple) and not _is_pair(occluders) \
            else [occluders]
        verts: list[np.ndarray]
        solid: list[np.ndarray]
        verts, faces, facet, solid, bounds = [], [], [], [], []
        count = offset = 0  # labels and vertices so far (a running sum: thousands of pieces)

        def add(v, f, solid_piece: bool) -> None:
            nonlocal count, offset
            v = np.asarray(v, dtype=np.float64)
            f = np.asarray(f, dtype=np.int64)
            if len(f) == 0:
                return
            lab = None
            if solid_piece:
                try:  # a convex solid: its planar facets are the polytope's (convex) faces
                    lab = _plane_groups(_solid_arrays(v, f, 0))[1].astype(np.int64)
                except InputError:
                    solid_piece = False
            if lab is None:
                lab = _facet_labels(v, f)
            facet.append(lab + count)
            count += int(lab.max()) + 1
            solid.append(np.full(len(f), -1 if not solid_piece else len(solid), np.int64))
            verts.append(v)
            bounds.append(np.stack([v[f].reshape(-1, 3).min(axis=0),
                                    v[f].reshape(-1, 3).max(axis=0)]))
            faces.append(f + offset)
            offset += len(v)

        def add_mesh(v, f) -> None:
            """A mesh's closed convex parts as convex solids, the rest by planar facets."""
            v = np.asarray(v, dtype=np.float64)
            f = np.asarray(f, dtype=np.int64)
            rest = np.ones(len(f), dtype=bool)
            for cv, cf, members in _convex_parts(v, f, _solid_arrays):
                add(cv, cf, True)
                rest[members] = False
            add(v, f[rest], False)

        for item in items:
            if _is_pair(item):
                add(item[0], item[1], True)
            elif isinstance(item, trimesh.Trimesh):
                add_mesh(item.vertices, item.faces)
            elif hasattr(item, "parts") and hasattr(item, "mesh"):
                parts = item.parts
                if len(parts.get("solids", [])):
                    for v, f in parts["solids"]:
                        add(v, f, True)
                elif len(parts.get("boxes", [])):
                    for lo, hi in np.asarray(parts["boxes"], dtype=np.float64):
                        add(lo + np.asarray(_UNIT_BOX.vertices) * (hi - lo),
                            np.asarray(_UNIT_BOX.faces), True)
                else:
                    add_mesh(item.mesh.vertices, item.mesh.faces)
            else:
                raise InputError(f"occluders: expected Occluder, trimesh.Trimesh or "
                                 f"(vertices, faces), got {type(item).__name__}")
        if not faces:
            raise InputError("occluders: no occluder triangle")
        v = np.vstack(verts)
        f = np.vstack(faces)
        self.scene = Scene(trimesh.Trimesh(v, f, process=False), workers=workers)
        # curved sheets (terrain, drapes): the crease rule's patches (viscore.culling._creases)
        self._vertices, self._faces = v, f
        self._patch, self._patch_edges = height_field_patches(v, f)
        self._n_patches = int(self._patch.max()) + 1 if len(self._patch) else 0
        e = self._patch_edges
        self._patch_edges6 = np.concatenate(
            [e, np.where(e[:, 3] >= 0, e[:, 4], -1)[:, None]], axis=1)
        # creases between planar flats (a wall and the floor): pairs of flats as patches
        self._flat, self._flat_pairs, self._flat_edges = flat_pairs(v, f)
        self._n_flats = int(self._flat.max()) + 1 if len(self._flat) else 0
        # any edge-connected triangles (a house of many small ones): the sheet rule
        # (viscore.culling._sheets), tried on the pixels the others leave open
        self._sheet, self._sheet_edges = mesh_sheets(v, f)
        self._n_sheets = int(self._sheet.max()) + 1 if len(self._sheet) else 0
        #: whether the sheet rule covers pixels (off only to measure it), and whether it
        #: lets one fold of the sheet cross a pixel
        self._sheet_rule = SHEET_RULE
        #: whether the junction rule covers pixels (off only to measure it)
        self._junction_rule = JUNCTION_RULE
        #: whether the occludee test's cover rule decides the pixels a triangle fails
        #: (off only to measure it)
        self._cover_rule = COVER_RULE
        self._sheet_folds = True
        self._facet = np.concatenate(facet)
        raw_solid = np.concatenate(solid)
        # solid ids: dense, and labels offset past the facet labels
        has = raw_solid >= 0
        _, dense = np.unique(raw_solid[has], return_inverse=True)
        self._solid = np.full(len(f), -1, np.int64)
        self._solid[has] = dense.reshape(-1)
        self._n_solids = int(dense.max()) + 1 if has.any() else 0
        self._n_facets = int(self._facet.max()) + 1
        tri = v[f]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        norm = np.linalg.norm(n, axis=1)
        n = n / np.where(norm > 0, norm, 1.0)[:, None]
        offsets = np.einsum("ij,ij->i", n, tri[:, 0])
        #: per triangle: its unit normal and offset (n.x = offset; zero for a degenerate
        #: one), and twice its area (the crease rule's corner distances, near-eye test)
        self._tri_plane = np.concatenate([n, offsets[:, None]], axis=1)
        self._tri_norm = norm
        # each facet's plane: that of its largest triangle (a solid's are outward-facing)
        order = np.lexsort((-norm, self._facet))
        first = order[np.r_[True, self._facet[order][1:] != self._facet[order][:-1]]]
        # how far the facet's vertices lie off that plane (facets are planar within a
        # tolerance): distances are taken to the plane pushed that far from the eye
        off = np.abs(np.einsum("ijk,ik->ij", tri, n[first][self._facet])
                     - offsets[first][self._facet, None]).max(axis=1)
        slack = np.zeros(len(first))
        np.maximum.at(slack, self._facet, off)
        #: (facets, 5) unit normal, offset (n.x = offset) and slack of each facet's plane
        self._facet_plane = np.concatenate([n[first], offsets[first][:, None],
                                            slack[:, None]], axis=1)
        # each solid's face planes, padded: (solids, P, 5) and which are real (solids, P)
        pairs = np.unique(np.stack([self._solid[has], self._facet[has]], axis=1), axis=0)
        per = np.bincount(pairs[:, 0], minlength=self._n_solids) if len(pairs) else \
            np.zeros(0, np.int64)
        width = int(per.max()) if len(per) else 0
        slot = np.arange(len(pairs)) - np.repeat(np.cumsum(per) - per, per)
        self._solid_plane = np.zeros((self._n_solids, width, 5))
        self._solid_plane_ok = np.zeros((self._n_solids, width), dtype=bool)
        self._solid_plane[pairs[:, 0], slot] = self._facet_plane[pairs[:, 1]]
        self._solid_plane_ok[pairs[:, 0], slot] = True
        self.pieces = len(np.unique(self._facet[~has])) + self._n_solids
        self._center = 0.5 * (self.scene.bounds[0] + self.scene.bounds[1])
        #: (k, 2, 3) bounding box of each added piece: its screen rectangle
        self._bounds = np.stack(bounds)
        self._grids: dict = {}
        # coplanar regions across facets and occluders, and their unions' boundaries
        self._region, self._region_plane, self._segments, self._segment_start = \
            _plane_regions(tri, n, norm, self._facet, self.scene.bounds)
        self._segment_region = np.repeat(np.arange(len(self._region_plane)),
                                         np.diff(self._segment_start))
        #: whether pixels still open get depths from a region behind them or from two
        #: regions along their line (:func:`viscore.culling._depth_kernel.region_creases`; off
        #: only to measure those rules)
        self._region_creases = True
        #: the contour rule's edges and triangles (:func:`_contour_depths`), on first use
        self._edges: tuple[np.ndarray, np.ndarray] | None = None
        self._triangles: np.ndarray | None = None

    def _grid(self, w: int, h: int, hx: float, hy: float, cols: int, rows: int,
              tile: int) -> tuple:
        """Camera-plane coordinates of a buffer's corner columns (cols + 1,) and rows
        (rows + 1,) (``cols >= w``, ``rows >= h``: beyond the screen in the padding), and
        the top-left pixel rows and columns of the tiles of side ``tile``; cached per
        buffer size and field of view."""
        key = (w, h, hx, hy, cols, rows, tile)
        if key not in self._grids:
            if len(self._grids) > 8:
                self._grids.clear()
            xs = (np.arange(cols + 1) / w - 0.5) * (2 * hx)
            ys = (0.5 - np.arange(rows + 1) / h) * (2 * hy)
            ti, tj = (g.reshape(-1) * tile for g in np.meshgrid(
                np.arange(rows // tile), np.arange(cols // tile), indexing="ij"))
            for a in (xs, ys, ti, tj):
                a.flags.writeable = False
            self._grids[key] = (xs, ys, ti, tj)
        return self._grids[key]

    def _front_planes(self, eye: np.ndarray) -> np.ndarray:
        """(solids, P) bool: the face planes of each solid with the eye strictly outside
        (a solid with none holds the eye: its triangles fall back to their facets)."""
        if self._n_solids == 0:
            return np.zeros((0, 0), dtype=bool)
        height = self._solid_plane[..., :3] @ eye - self._solid_plane[..., 3]
        tol = 1e-12 * (self.scene.diagonal + float(np.linalg.norm(eye - self._center)))
        return self._solid_plane_ok & (height > tol)

    def _piece_of(self, tri: np.ndarray, outside: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Facet and convex-piece labels (-1 on a miss) of hit triangles ``tri`` (-1: miss);
        a solid seen from ``outside`` is labelled :attr:`_n_facets` + its index."""
        hit = tri >= 0
        t = np.maximum(tri, 0)
        fac = np.where(hit, self._facet[t], -1)
        sid = self._solid[t]
        out = hit & (sid >= 0)
        out[out] = outside[sid[out]]
        return fac, np.where(out, self._n_facets + sid, fac)

    def _screen_segments(self, eye: np.ndarray, basis, hx: float, hy: float, w: int,
                         h: int) -> tuple[np.ndarray, np.ndarray]:
        """The regions' boundary segments on the buffer this frame, and which regions may
        cover tiles.

        Returns ``(S, 4)`` float64 row, column of both ends (buffer pixels) of
        each segment clipped to the half-space ``z >= z0`` in front of the eye
        (``z0`` a millionth of the scene's size plus its distance; NaN when
        nothing is left), and ``(R,)`` bool, False for a region whose boundary
        passes within ``3 z0`` (times the padded screen's slope) of the eye: the
        part cut off could then project onto a tile.
        """
        segs = self._segments
        ok = np.ones(len(self._region_plane), dtype=bool)
        if len(segs) == 0:
            return np.zeros((0, 4)), ok
        f, r, u = basis
        rel = segs - eye
        z, x, y = rel @ f, rel @ r, rel @ u  # (S, 2) each
        z0, reach = _near_cut(self.scene.diagonal + float(np.linalg.norm(eye - self._center)),
                              hx, hy)
        d = rel[:, 1] - rel[:, 0]
        dd = np.einsum("ij,ij->i", d, d)
        t = np.clip(-np.einsum("ij,ij->i", rel[:, 0], d) / np.where(dd > 0, dd, 1.0), 0, 1)
        closest = np.linalg.norm(rel[:, 0] + t[:, None] * d, axis=1)
        ok[self._segment_region[closest <= reach]] = False
        za, zb = z[:, 0], z[:, 1]
        keep = (za >= z0) | (zb >= z0)
        with np.errstate(divide="ignore", invalid="ignore"):
            cut = (z0 - za) / (zb - za)
        cut = np.where(keep & np.isfinite(cut), cut, 0.0)
        ta = np.where(za >= z0, 0.0, cut)
        tb = np.where(zb >= z0, 1.0, cut)
        out = np.full((len(segs), 4), np.nan)
        for k, tt in enumerate((ta, tb)):
            px = x[:, 0] + tt * (x[:, 1] - x[:, 0])
            py = y[:, 0] + tt * (y[:, 1] - y[:, 0])
            pz = np.maximum(za + tt * (zb - za), z0)
            out[keep, 2 * k] = ((0.5 - py / pz * (0.5 / hy)) * h)[keep]
            out[keep, 2 * k + 1] = ((px / pz * (0.5 / hx) + 0.5) * w)[keep]
        return out, ok

    def labels(self, eye: np.ndarray) -> np.ndarray:
        """(f,) int64 convex-piece label of each triangle for this eye: the solid's label
        when the eye is strictly outside the solid, the planar facet's label otherwise."""
        outside = self._front_planes(np.asarray(eye, dtype=np.float64)).any(axis=1)
        return self._piece_of(np.arange(len(self._facet)), outside)[1]  # type: ignore[arg-type]


#: A mesh's connected part is tried as a convex solid only with at least this many
#: triangles (a tetrahedron) and at most this many (a convex part of a level: a crate, a
#: bevelled box, a pillar; a larger closed part is seldom convex, and its check costs).
_CONVEX_PART_TRIANGLES = (4, 4096)


def _convex_parts(v: np.ndarray, f: np.ndarray, solid_arrays):
    """The connected parts of a mesh that are closed, outward-facing convex solids.

    Yields ``(vertices, faces, members)``: the part on its own vertices (merged at equal
    positions, so that a part exported with split vertices is closed), and the indices
    of its triangles in ``f``. ``solid_arrays`` is the solid check of the shadow frusta
    (closed, every edge with one twin, positive volume, every vertex within tolerance on
    the inner side of every face plane); a part that fails it is not yielded.
    """
    lo_n, hi_n = _CONVEX_PART_TRIANGLES
    if len(f) < lo_n:
        return
    merged = _merged(v, f)
    mesh = trimesh.Trimesh(np.zeros((int(merged.max()) + 1, 3)), merged, process=False)
    label = trimesh.graph.connected_component_labels(mesh.face_adjacency,
                                                     node_count=len(f))
    order = np.argsort(label, kind="stable")
    cuts = np.flatnonzero(np.r_[True, label[order][1:] != label[order][:-1], True])
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):  # a loop over parts, not rays
        members = order[a:b]
        if not lo_n <= len(members) <= hi_n:
            continue
        ids, faces = np.unique(merged[members], return_inverse=True)
        faces = faces.reshape(-1, 3)
        # closed: every undirected edge in exactly two of the part's triangles
        edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        if np.unique(edges, axis=0, return_counts=True)[1].max() != 2 \
                or 2 * len(np.unique(edges, axis=0)) != len(edges):
            continue
        first = np.zeros(int(merged.max()) + 1, dtype=np.int64)
        first[merged.reshape(-1)] = f.reshape(-1)  # one source vertex per merged id
        verts = v[first[ids]]
        try:
            solid_arrays(verts, faces, 0)
        except InputError:
            continue
        yield verts, faces, members


def _is_pair(item) -> bool:
    """A (vertices, faces) pair of arrays (not a list of occluders)."""
    if not isinstance(item, tuple) or len(item) != 2:
        return False
    a, b = (np.asarray(x) if not isinstance(x, trimesh.Trimesh) else None for x in item)
    return a is not None and b is not None and a.ndim == 2 and b.ndim == 2 \
        and a.shape[-1:] == (3,) and b.shape[-1:] == (3,) and np.issubdtype(b.dtype, np.integer)



def _frame(camera: PerspectiveCamera, width, height) -> tuple:
    """Checked buffer size and the frame's geometry: w, h, eye, (f, r, u), hx, hy."""
    if not isinstance(camera, PerspectiveCamera):
        raise InputError(f"camera: expected a PerspectiveCamera, got "
                         f"{type(camera).__name__}")
    rows, cols = camera.shape
    w = max(1, cols // DEFAULT_REDUCTION) if width is None else as_positive_int(
        width, "width", maximum=16384)
    h = max(1, rows // DEFAULT_REDUCTION) if height is None else as_positive_int(
        height, "height", maximum=16384)
    return w, h, camera.position, camera.basis, camera._half, camera._half_vertical


def _screen_boxes(lo: np.ndarray, hi: np.ndarray, eye: np.ndarray, basis, hx: float,
                  hy: float, w: int, h: int) -> tuple[np.ndarray, np.ndarray]:
    """Buffer-pixel bounds of boxes' projected corners, and which lie wholly in front.

    Returns ``(n, 4)`` float ``row_min, row_max, col_min, col_max`` (pixel
    units, row 0 at the top; meaningless where not in front) and ``(n,)``
    bool: every corner strictly in front of the eye's plane.
    """
    f, r, u = basis
    base = lo - eye
    ext = hi - lo
    # camera coordinates (right, up, forward) of the 8 corners: (n, 3) @ (3, 8) each
    x, y, z = (base @ a[:, None] + ext @ (_CORNERS * a).T for a in (r, u, f))
    front = (z > 0).all(axis=1)
    zs = np.where(z > 0, z, 1.0)
    x /= zs
    y /= zs
    return np.stack([(0.5 - y.max(axis=1) * (0.5 / hy)) * h,
                     (0.5 - y.min(axis=1) * (0.5 / hy)) * h,
                     (x.min(axis=1) * (0.5 / hx) + 0.5) * w,
                     (x.max(axis=1) * (0.5 / hx) + 0.5) * w], axis=1), front


#: Rays per call under which Embree is called directly, on this thread (above,
#: :meth:`Scene.first_hit` and its thread pool).
_DIRECT_RAYS = 1 << 15


def _first_triangles(scene: Scene, eye: np.ndarray, d32: np.ndarray) -> np.ndarray:
    """(n,) triangle first hit by each ray from the eye along unit float32 ``d32`` (-1: miss).

    Small batches go to Embree directly, as :meth:`Scene.first_hit` would send
    them (same centred, power-of-two-scaled float32 frame): its per-call input
    checks cost more than a few thousand rays, and these rays are built here.
    """
    if len(d32) > _DIRECT_RAYS:
        return scene.first_hit(eye[None], d32.astype(np.float64))[1]
    o32 = np.empty((len(d32), 3), dtype=np.float32)
    o32[:] = (eye - scene._offset) / scene._scale
    return scene._first_triangles_unit(o32, d32)


def _near_cut(size: float, hx: float, hy: float) -> tuple[float, float]:
    """``(z0, reach)``: the near cut of boundary segments in front of the eye (a millionth
    of the scene's size plus its distance, ``size``) and the distance from the eye within
    which the rays of a tile of the padded buffer (within 3 hx, 3 hy of the axis) pass
    nearer than ``z0`` along the view; a region or patch reaching that near is not used."""
    z0 = 1e-6 * size
    return z0, 3 * z0 * float(np.sqrt(1 + 9 * hx * hx + 9 * hy * hy))


def _corner_hits(occ: OccluderScene, corner_tri: np.ndarray, todo: np.ndarray,
                 eye: np.ndarray, basis, xs: np.ndarray, ys: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel corner's exact distance to the plane of the triangle its ray first hit, and
    that triangle, for the corners of the pixels of ``todo`` (H, W): ``(H + 1, W + 1)``
    float64 (``inf`` elsewhere) and int64 (-1 for a miss, a corner not cast or not needed,
    or a ray grazing its triangle). ``corner_tri`` (H + 1, W + 1) is the triangle each cast
    corner ray first hit (-1 a miss, -2 not cast); ``xs``, ``ys`` the corners'
    camera-plane coordinates."""
    h, w = todo.shape
    f, r, u = basis
    need = np.zeros((h + 1, w + 1), dtype=bool)
    for a in (0, 1):
        for b in (0, 1):
            need[a:a + h, b:b + w] |= todo
    ci, cj = np.nonzero(need & (corner_tri >= 0))
    tri = corner_tri[ci, cj]
    d = f[None] + xs[cj][:, None] * r[None] + ys[ci][:, None] * u[None]
    d /= np.linalg.norm(d, axis=1)[:, None]
    # each corner's exact distance to its triangle's plane (float64)
    plane = occ._tri_plane[tri]
    facing = np.einsum("ij,ij->i", plane[:, :3], d)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (plane[:, 3] - plane[:, :3] @ eye) / facing
    # a corner ray grazing its triangle (within a millionth of a radian) gives an
    # ill-conditioned distance, and Embree's verdict there is least sure: not used
    grazing = np.abs(facing) < 1e-6
    good = np.isfinite(t) & (t > 0) & ~grazing
    grid_t = np.full((h + 1, w + 1), np.inf)
    grid_tri = np.full((h + 1, w + 1), -1, dtype=np.int64)
    grid_t[ci[good], cj[good]] = t[good]
    grid_tri[ci[good], cj[good]] = tri[good]
    return grid_t, grid_tri


def _patch_depths(occ: OccluderScene, layer: tuple, depth: np.ndarray, hits: tuple,
                  eye: np.ndarray, basis, xs: np.ndarray, ys: np.ndarray, hx: float,
                  hy: float, size: float, margin: float) -> None:
    """The crease rule (:mod:`viscore.culling._creases`) on the pixels without depth, in place, for
    one kind of patch, ``layer`` = ``(group of each triangle, edges (m, 6), groups,
    pairs, corners)``: the height-field patches (``pairs`` None: a pixel's corners on one
    patch), the planar flats (``pairs`` the sorted keys of the flats' pairs: a pixel's
    corners on the two flats of a pair), or the sheets (``pairs`` None, ``corners``
    True: the sheet rule of :mod:`viscore.culling._sheets`, whose depths add the
    distances at the corners through the triangles of the corners and the creases):
    a pixel whose four corner rays (cast by the tiles' subdivision: ``hits``, the
    corners' distances and triangles from :func:`_corner_hits` for every pixel open when
    it was called; ``xs``, ``ys`` the corners' camera-plane coordinates) first hit one
    patch, with no boundary edge of that patch across it, gets the largest of the corners'
    distances to their triangles' planes and of the crease distances in the pixel. A
    crease between two triangles splits the tiles across it down to pixels, so its pixels'
    corners are cast; no ray is cast here."""
    from ._creases import patch_frame

    h, w = depth.shape
    f, r, u = basis
    grid_t, grid_tri = hits
    group, edges, n_groups, pairs, at_corners = layer
    # the open pixels only (a few per cent of the buffer): their corners' patches
    ii, jj = np.nonzero(~np.isfinite(depth))
    corners = np.stack([grid_tri[ii, jj], grid_tri[ii, jj + 1], grid_tri[ii + 1, jj],
                        grid_tri[ii + 1, jj + 1]])
    corners = np.where(corners >= 0, group[np.maximum(corners, 0)], -1)
    # each pixel's patch: its corners' one patch, or the two flats of a pair
    pa, pb = corners.min(axis=0), corners.max(axis=0)
    two = ((corners == pa) | (corners == pb)).all(axis=0) & (pa >= 0)
    if pairs is None:  # height-field patches and sheets: one patch
        two &= pa == pb
    else:  # flats: two of them, a pair
        key = pa * n_groups + pb  # the flats' layer is used only when it has a pair
        at = np.clip(np.searchsorted(pairs, key), 0, len(pairs) - 1)
        two &= (pa != pb) & (pairs[at] == key)
    if not two.any():
        return
    ii, jj, pa, pb = ii[two], jj[two], pa[two], pb[two]
    # only the edges of the pixels' patches: another's could only block a pixel or raise
    # its depth
    seen = np.zeros(n_groups + 1, dtype=bool)
    seen[pa] = True
    seen[pb] = True
    edges = edges[seen[edges[:, 4]] | seen[edges[:, 5]]]  # -1 lands on the extra last entry
    grid_pa = np.full((h, w), -1, dtype=np.int64)
    grid_pb = np.full((h, w), -1, dtype=np.int64)
    grid_pa[ii, jj] = pa
    grid_pb[ii, jj] = pb
    blocked = np.zeros((h, w), dtype=bool)
    crease = np.zeros((h, w))
    disabled = np.zeros(n_groups, dtype=bool)
    folds = np.zeros((h, w), dtype=np.int64)
    fold_end = np.zeros((h, w), dtype=bool)
    z0, reach = _near_cut(size, hx, hy)
    patch_frame(occ._vertices, edges, np.asarray(eye, dtype=np.float64), r, u, f,
                hx, hy, w, h, z0, reach, _SEGMENT_SLACK, grid_pa, grid_pb, blocked, crease,
                disabled, at_corners, folds, fold_end)
    if at_corners:  # the sheet rule: one fold across the pixel, from side to side, at most
        blocked |= (folds > (1 if occ._sheet_folds else 0)) | fold_end
    # a patch passing within reach of the eye inside a triangle (not at an edge): the cut
    # of that triangle at z0 could bound its image on the screen; not used either
    disabled[_near_patches(occ, group, eye, reach)] = True
    one = ~blocked[ii, jj] & ~disabled[pa] & ~disabled[pb]
    ii, jj = ii[one], jj[one]
    if not len(ii):
        return
    far = np.maximum(np.maximum(grid_t[ii, jj], grid_t[ii, jj + 1]),
                     np.maximum(grid_t[ii + 1, jj], grid_t[ii + 1, jj + 1]))
    if at_corners:
        from ._sheets import corner_triangle_depths

        todo = np.zeros((h, w), dtype=bool)
        todo[ii, jj] = True
        corner_triangle_depths(occ._vertices, occ._faces, grid_tri, todo,
                               np.asarray(eye, dtype=np.float64), r, u, f, hx, hy, crease)
    depth[ii, jj] = np.maximum(far, crease[ii, jj]) + margin


def _junction_fill(occ: OccluderScene, corner_tri: np.ndarray, depth: np.ndarray,
                   eye: np.ndarray, basis, hx: float, hy: float, size: float,
                   margin: float) -> None:
    """The junction rule (:mod:`viscore.culling._junctions`) on the pixels without depth
    whose four corner rays hit an occluder (``corner_tri`` (H + 1, W + 1), the triangle
    each cast corner ray first hit, -1 a miss, -2 not cast), in place."""
    from ._junctions import junction_depths

    hit = corner_tri >= 0
    todo = ~np.isfinite(depth) & hit[:-1, :-1] & hit[:-1, 1:] & hit[1:, :-1] & hit[1:, 1:]
    if not todo.any():
        return
    z0, _ = _near_cut(size, hx, hy)
    found = junction_depths(occ._vertices, occ._faces, todo, np.asarray(eye, dtype=np.float64),
                            basis, hx, hy, z0, _SEGMENT_SLACK)  # todo's pixels, row-major
    new = np.isfinite(found)
    ii, jj = np.nonzero(todo)
    depth[ii[new], jj[new]] = found[new] + margin


def _near_patches(occ: OccluderScene, patch: np.ndarray, eye: np.ndarray, reach: float
                  ) -> np.ndarray:
    """Patches with a triangle whose interior lies within ``reach`` of the eye (the foot
    of the eye on the triangle's plane inside the triangle, the plane that near)."""
    plane = occ._tri_plane
    height = plane[:, :3] @ eye - plane[:, 3]  # signed distance to each plane (unit normal)
    k = np.flatnonzero((np.abs(height) <= reach) & (occ._tri_norm > 0) & (patch >= 0))
    if len(k) == 0:  # no plane that near: then the foot of the eye on the triangle
        return np.zeros(0, dtype=np.int64)
    v = occ._vertices[occ._faces[k]]
    e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
    n = plane[k, :3]
    foot = (eye - v[:, 0]) - height[k, None] * n
    # barycentric coordinates of the foot (twice the triangle's area is the norm)
    a = np.einsum("ij,ij->i", np.cross(foot, e2), n) / occ._tri_norm[k]
    b = np.einsum("ij,ij->i", np.cross(e1, foot), n) / occ._tri_norm[k]
    near = (a >= 0) & (b >= 0) & (a + b <= 1)
    return np.unique(patch[k[near]])


def _full_corner_depth(occ: OccluderScene, camera: PerspectiveCamera, width: int,
                       height: int) -> np.ndarray:
    """(H, W) the one-ray-per-pixel-corner buffer (the reference of the tests): a pixel
    holds the largest entry distance of its four corner rays when they first hit the same
    convex piece."""
    w, h, eye, basis, hx, hy = _frame(camera, width, height)
    f, r, u = basis
    xs = (np.arange(w + 1) / w - 0.5) * (2 * hx)
    ys = (0.5 - np.arange(h + 1) / h) * (2 * hy)
    d = f + xs[None, :, None] * r + ys[:, None, None] * u
    d = (d / np.linalg.norm(d, axis=2)[..., None]).reshape(-1, 3)
    t, tri = occ.scene.first_hit(eye[None], d)
    label = occ._piece_of(tri, occ._front_planes(eye).any(axis=1))[1].reshape(h + 1, w + 1)  # type: ignore[arg-type]
    t = t.reshape(h + 1, w + 1)
    lab = label[:-1, :-1]
    same = ((lab >= 0) & (lab == label[:-1, 1:]) & (lab == label[1:, :-1])
            & (lab == label[1:, 1:]))
    far = np.maximum(np.maximum(t[:-1, :-1], t[:-1, 1:]), np.maximum(t[1:, :-1], t[1:, 1:]))
    margin = DEPTH_MARGIN_RELATIVE * (occ.scene.diagonal
                                      + float(np.linalg.norm(eye - occ._center)))
    return np.where(same, far + margin, np.inf)


def _contour_depths(occ: OccluderScene, eye: np.ndarray, basis, hx: float, hy: float,
                    depth: np.ndarray, margin: float) -> int:
    """The contour rule (:mod:`viscore.culling._contour`) on the pixels of ``depth`` (H, W)
    still without a depth, in place: where the centre ray meets an occluder and no contour
    edge of the occluders (taken as one mesh) crosses the pixel, the farthest distance of
    the triangles whose projections may touch the pixel, widened by ``margin``. Returns
    the number of pixels it covered."""
    from ._contour import contour_pixels, edge_topology, farthest_touching

    h, w = depth.shape
    if occ._edges is None:  # built on first use: the rule is off for most callers' scenes
        occ._edges = edge_topology(occ._vertices, occ._faces)
        occ._triangles = occ._vertices[occ._faces]
    f, r, u = basis
    edges, opposite = occ._edges
    crossed = np.zeros((h, w), dtype=bool)
    contour_pixels(occ._vertices, edges, opposite, eye, r, u, f, hx, hy, crossed)
    ii, jj = np.nonzero(~np.isfinite(depth) & ~crossed)
    if not len(ii):
        return 0
    x = ((jj + 0.5) / w - 0.5) * 2.0 * hx
    y = (0.5 - (ii + 0.5) / h) * 2.0 * hy
    d = x[:, None] * r + y[:, None] * u + f
    t, tri = occ.scene.first_hit(eye[None], d / np.linalg.norm(d, axis=1)[:, None])
    far = np.full((h, w), -np.inf)
    farthest_touching(occ._triangles, eye, r, u, f, hx, hy, far)
    bound = far[ii, jj] + margin
    ok = (tri >= 0) & np.isfinite(bound) & (bound >= t)
    depth[ii[ok], jj[ok]] = bound[ok]
    return int(ok.sum())


@dataclass(frozen=True, eq=False)
class ConservativeDepthBuffer:
    """A conservative occluder depth buffer for one frame, and its occludee test.

    Build with :meth:`from_occluders`.

    Attributes
    ----------
    depth : (H, W) float64
        Per buffer pixel, an upper bound on the distance (world units, from
        the eye) at which every ray through the pixel meets an occluder;
        ``inf`` where the occluders are not proven to cover the whole pixel.
        Row 0 is the top edge (towards the camera's up), column 0 the left.
    camera : PerspectiveCamera
        The screen camera; the buffer spans its field of view.
    hits : int
        Rays cast for this frame that hit an occluder.
    rays : int
        Rays cast for this frame (tile and pixel corners; at most
        ``(W + 1) * (H + 1)`` plus those of tiles straddling the buffer's
        right and bottom edges).
    plane : (H, W, 4) float64 or None
        Per pixel covered by one plane (a planar facet or coplanar region covering
        it whole), that plane as ``(a, b, c, threshold)``: a point ``q`` in the
        pixel's pyramid, in camera coordinates (along the camera's right, up and
        forward axes from the eye), lies at least the depth margin behind the plane
        when ``a q_r + b q_u + c q_f >= threshold`` (``inf`` threshold: no such
        plane). :meth:`occluded_triangles` culls a triangle lying behind it in a pixel
        whose depth alone does not (a floor or road under the ground seen at a grazing
        angle, where the plane's farthest depth over the pixel is far). None: no
        planes (a buffer made from depths alone).
    cover : tuple or None
        For the cover rule of :meth:`occluded_triangles`: the occluders' vertices (V, 3),
        triangles (T, 3) and the near cut in front of the eye (world units) that a
        triangle must lie beyond to be used; None: no rule (a buffer made from depths
        alone, or an :class:`OccluderScene` with the rule off). Arrays only, so that a
        buffer kept does not keep the occluders' Embree scene alive.
    margin : float
        The depth margin its depths carry, world units (the cover rule's too).
    """

    depth: np.ndarray
    camera: PerspectiveCamera
    hits: int
    rays: int = 0
    plane: np.ndarray | None = None
    cover: tuple | None = None
    margin: float = 0.0

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) buffer pixels."""
        return self.depth.shape

    @property
    def covered(self) -> np.ndarray:
        """(H, W) bool: pixels that hold a depth."""
        return np.isfinite(self.depth)

    @classmethod
    def from_occluders(cls, occluders, camera: PerspectiveCamera, *, width: int | None = None,
                       height: int | None = None) -> ConservativeDepthBuffer:
        """Cast tile corner rays of a W x H buffer, split where needed, keep covered pixels.

        Parameters
        ----------
        occluders : OccluderScene, or anything :class:`OccluderScene` accepts
            Prepare an :class:`OccluderScene` once and pass it every frame:
            building one costs an Embree scene and the facet labelling.
        camera : PerspectiveCamera
            The screen camera (e.g. 1280 x 720).
        width, height : int, optional
            Buffer pixels; default a quarter of the camera's columns and rows
            (:data:`DEFAULT_REDUCTION`), at least 1. The buffer covers the
            camera's field of view whatever its aspect.

        Returns
        -------
        ConservativeDepthBuffer

        Raises
        ------
        InputError
            On a camera that is not a :class:`PerspectiveCamera`, a bad size,
            or a buffer whose rays do not fit in memory.

        Examples
        --------
        >>> wall = trimesh.creation.box(extents=(10, 1, 10))
        >>> cam = PerspectiveCamera((0, -5, 0), (0, 1, 0), fov=60, resolution=64, height=36)
        >>> buf = ConservativeDepthBuffer.from_occluders(wall, cam)
        >>> buf.shape, bool(buf.covered.all()), buf.rays   # 2 x 2 tiles of 16 x 16: 9 rays
        ((18, 32), True, 9)
        """
        from ._depth_kernel import (
            region_creases,
            settle_tiles,
            store_hits,
            thin_rectangles,
            tile_corners,
        )

        w, h, eye, basis, hx, hy = _frame(camera, width, height)
        tile = min(_TILE, 1 << int(np.ceil(np.log2(max(w, h)))))
        cols, rows = -(-w // tile) * tile, -(-h // tile) * tile  # padded to whole tiles
        nbytes = (cols + 1) * (rows + 1) * _BYTES_PER_RAY
        if nbytes > _CHECKED_BYTES:
            check_memory(nbytes, f"depth buffer {w} x {h}")
        occ = occluders if isinstance(occluders, OccluderScene) else OccluderScene(occluders)
        f, r, u = basis
        eye = np.asarray(eye, dtype=np.float64)
        size = occ.scene.diagonal + float(np.linalg.norm(eye - occ._center))
        tol, margin = 1e-12 * size, DEPTH_MARGIN_RELATIVE * size
        xs, ys, ti, tj = occ._grid(w, h, hx, hy, cols, rows, tile)
        ti, tj = ti.copy(), tj.copy()  # writeable, as the later levels' lists: one
        # compiled version of tile_corners and settle_tiles (about 3 s on a fresh install)
        stride = cols + 1
        facet = np.full((rows + 1) * stride, -2, dtype=np.int64)  # -2: not cast, -1: miss
        corner_tri = np.full_like(facet, -2)  # the triangle each cast corner ray first hit
        piece = np.empty_like(facet)
        region = np.empty_like(facet)
        segments, region_ok = occ._screen_segments(eye, basis, hx, hy, w, h)
        outside = np.full(occ._n_solids, -1, dtype=np.int8)
        depth = np.full((h, w), np.inf)
        plane = np.full((h, w, 4), np.inf)
        corner = np.empty((tile + 1, tile + 1))
        coef = np.empty((max(1, occ._solid_plane.shape[1]), 3))
        thin = np.empty((len(occ._bounds), 5))
        thin = thin[:thin_rectangles(occ._bounds[:, 0], occ._bounds[:, 1], eye, r, u, f, hx, hy,
                                     w, h, thin)]
        rays = hits = 0
        s = tile
        while len(ti):  # a loop over the log2(tile) + 1 tile sizes
            need = np.empty(4 * len(ti), dtype=np.int64)
            d32 = np.empty((4 * len(ti), 3), dtype=np.float32)
            n = tile_corners(ti, tj, s, stride, facet, xs, ys, r, u, f, need, d32)
            if n:
                tri = _first_triangles(occ.scene, eye, d32[:n])
                corner_tri[need[:n]] = tri
                hits += store_hits(need[:n], tri, occ._facet, occ._solid, occ._region,
                                   occ._n_facets, occ._solid_plane, occ._solid_plane_ok, eye,
                                   tol, outside, facet, piece, region)
                rays += n
            child_i = np.empty(4 * len(ti), dtype=np.int64)
            child_j = np.empty(4 * len(ti), dtype=np.int64)
            n, _ = settle_tiles(ti, tj, s, stride, facet, piece, region, occ._n_facets,
                                occ._facet_plane, occ._solid_plane, occ._solid_plane_ok,
                                occ._region_plane, segments, occ._segment_start, region_ok,
                                _SEGMENT_SLACK, eye, r, u, f, tol, xs, ys, margin, thin, depth,
                                corner, coef, child_i, child_j, plane)
            ti, tj = child_i[:n], child_j[:n]
            s //= 2
        layers = ([(occ._patch, occ._patch_edges6, occ._n_patches, None, False)]
                  if occ._n_patches else []) \
            + ([(occ._flat, occ._flat_edges, occ._n_flats, occ._flat_pairs, False)]
               if len(occ._flat_pairs) else [])
        at_corners = None  # the open pixels' corner distances, for the crease and sheet rules
        if layers or (occ._n_sheets and occ._sheet_rule):
            at_corners = _corner_hits(occ, corner_tri.reshape(rows + 1, stride)[:h + 1, :w + 1],
                                      ~np.isfinite(depth), eye, basis, xs, ys)
        for layer in layers:
            if np.isfinite(depth).all():
                break
            assert at_corners is not None  # made above whenever there is a layer
            _patch_depths(occ, layer, depth, at_corners, eye, basis, xs, ys, hx, hy, size,
                          margin)
        if occ._region_creases and len(occ._region_plane) \
                and not np.isfinite(depth).all():
            region_creases(depth, facet, region, stride, occ._region_plane, region_ok,
                           segments, occ._segment_start, occ._segments, xs, ys, hx, hy, eye,
                           r, u, f, tol, _CREASE_TOLERANCE * size, margin, _SEGMENT_SLACK)
        # last: the sheet rule's depths are looser than the region rules' where both apply
        if occ._n_sheets and occ._sheet_rule and not np.isfinite(depth).all():
            assert at_corners is not None  # made above whenever there are sheets
            _patch_depths(occ, (occ._sheet, occ._sheet_edges, occ._n_sheets, None, True), depth,
                          at_corners, eye, basis, xs, ys, hx, hy, size, margin)
        # last: pixels where separate meshes meet, covered by their triangles together
        if occ._junction_rule and not np.isfinite(depth).all():
            _junction_fill(occ, corner_tri.reshape(rows + 1, stride)[:h + 1, :w + 1], depth,
                           eye, basis, hx, hy, size, margin)
        if CONTOUR_RULE and not np.isfinite(depth).all():
            _contour_depths(occ, eye, basis, hx, hy, depth, margin)
        return cls(depth=depth, camera=camera, hits=hits, rays=rays, plane=plane,
                   cover=((occ._vertices, occ._faces, _near_cut(size, hx, hy)[0])
                          if occ._cover_rule and len(occ._faces) else None),
                   margin=margin)

    def screen_rectangles(self, lower: npt.ArrayLike, upper: npt.ArrayLike
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Buffer-pixel rectangles of boxes, their nearest distances, and which are testable.

        Parameters
        ----------
        lower, upper : (n, 3) float
            Box corners, world units.

        Returns
        -------
        rect : (n, 4) int64
            ``row0, row1, col0, col1`` inclusive, clipped to the buffer; of the
            part in the view pyramid for a box crossing the eye's plane or
            reaching beyond the screen's edge.
        nearest : (n,) float64
            Distance from the eye to the nearest point of the box (0 when the
            box contains the eye); for a box crossing the eye's plane or the
            screen's edge, the least forward depth of its part in the view
            pyramid (a lower bound of that part's distance).
        testable : (n,) bool
            The box (or its part in the view pyramid) strictly in front of the
            eye's plane, the eye outside it, and the clipped rectangle not
            empty; only these can be culled.

        Notes
        -----
        :meth:`occluded` compares each pixel of ``rect`` with the larger of the
        box's distance and a least forward depth (the box's, or for a box
        crossing the eye's plane or the screen's edge its part's,
        ``nearest``) times the secant of the pixel's ray nearest the view axis.
        """
        lo, hi = _as_boxes(lower, upper)
        cam = self.camera
        eye = cam.position
        h, w = self.depth.shape
        bounds, front = _screen_boxes(lo, hi, eye, cam.basis, cam._half, cam._half_vertical,  # type: ignore[arg-type]
                                      w, h)
        gap = np.maximum(lo - eye, 0) + np.maximum(eye - hi, 0)
        nearest = np.sqrt(np.einsum("ij,ij->i", gap, gap))
        with np.errstate(invalid="ignore"):
            beyond = front & ((bounds[:, 0] < 0) | (bounds[:, 1] > h) | (bounds[:, 2] < 0)
                              | (bounds[:, 3] > w))
        across = np.flatnonzero((~front | beyond) & (nearest > 0))
        if len(across):  # the part of each in the view pyramid, at its least forward depth
            from ._depth_kernel import clipped_rectangles

            f, r, u = cam.basis
            part = np.empty((len(across), 4))
            zmin = np.empty(len(across))
            ok = np.empty(len(across), dtype=bool)
            clipped_rectangles(lo[across], hi[across], np.asarray(eye, dtype=np.float64), r, u,
                               f, cam._half, cam._half_vertical, w, h, part, zmin, ok)
            bounds[across[ok]] = part[ok]
            nearest[across[ok]] = zmin[ok]
            front = front.copy()
            front[across] = ok
        with np.errstate(invalid="ignore"):
            r0, r1, c0, c1 = np.floor(bounds + [-_RECT_SLACK, _RECT_SLACK, -_RECT_SLACK,
                                                 _RECT_SLACK]).T
        on = front & (c1 >= 0) & (c0 <= w - 1) & (r1 >= 0) & (r0 <= h - 1)
        rect = np.stack([np.clip(r0, 0, h - 1), np.clip(r1, 0, h - 1),
                         np.clip(c0, 0, w - 1), np.clip(c1, 0, w - 1)], axis=1)
        rect = np.where(on[:, None], rect, 0).astype(np.int64)
        return rect, nearest, on & (nearest > 0)

    def occluded(self, lower: npt.ArrayLike, upper: npt.ArrayLike) -> np.ndarray:
        """Which boxes are hidden: every buffer pixel their rectangle touches is nearer.

        Parameters
        ----------
        lower, upper : (n, 3) float
            Occludee bounding boxes, world units.

        Returns
        -------
        culled : (n,) bool
            False for boxes behind the eye's plane, containing the eye, with
            no part in the view pyramid, or wholly off the screen. A box
            crossing the eye's plane is tested by its part in the view pyramid.

        Raises
        ------
        InputError
            On shapes other than (n, 3), non-finite values or inverted corners.

        Examples
        --------
        >>> wall = trimesh.creation.box(extents=(10, 1, 10))
        >>> cam = PerspectiveCamera((0, -5, 0), (0, 1, 0), fov=60, resolution=64, height=36)
        >>> buf = ConservativeDepthBuffer.from_occluders(wall, cam)
        >>> buf.occluded([[-1, 3, -1], [-1, -3, -1]], [[1, 4, 1], [1, -2, 1]]).tolist()
        [True, False]
        """
        from ._depth_kernel import occluded_boxes

        lo, hi = _as_boxes(lower, upper)
        cam = self.camera
        f, r, u = cam.basis
        out = np.zeros(len(lo), dtype=bool)
        occluded_boxes(lo, hi, np.asarray(cam.position, dtype=np.float64), r, u, f, cam._half,
                       cam._half_vertical, _RECT_SLACK, self.depth, out)
        return out

    def occluded_triangles(self, triangles: npt.ArrayLike, start: npt.ArrayLike
                           ) -> np.ndarray:
        """Which groups of triangles are hidden: each triangle, pixel by pixel, behind the buffer.

        The occludee test of :meth:`occluded` on an object's own triangles instead of
        boxes around them: each triangle is clipped to the view pyramid, its projection
        conservatively rasterised into the buffer's pixels (every pixel it may touch),
        and each such pixel compared with a lower bound of the triangle's distance over
        the pixel (its plane's nearest depth over the pixel's square, never farther than
        the triangle really is there, times the secant of the pixel's ray nearest the
        view axis). A group is hidden when every triangle is: outside the view pyramid,
        or behind a nearer depth in every pixel it may touch (sec. 6 of [1]_ with the
        triangle in place of the bounding box), or, in a pixel covered by one occluder
        plane (:attr:`plane`), wholly behind that plane by the depth margin.

        Parameters
        ----------
        triangles : (m, 3, 3) float
            Triangles, world units.
        start : (g + 1,) int
            Group ``k`` is ``triangles[start[k]:start[k + 1]]``; non-decreasing, from 0
            to ``m``.

        Returns
        -------
        culled : (g,) bool
            False for a group with a triangle that reaches the eye, or that a pixel
            without a nearer depth may show.

        Raises
        ------
        InputError
            On shapes other than (m, 3, 3), non-finite values or bad group starts.

        Examples
        --------
        >>> wall = trimesh.creation.box(extents=(10, 1, 10))
        >>> cam = PerspectiveCamera((0, -5, 0), (0, 1, 0), fov=60, resolution=64, height=36)
        >>> buf = ConservativeDepthBuffer.from_occluders(wall, cam)
        >>> tri = [[[-1, 3, -1], [1, 3, -1], [0, 3, 1]], [[-1, -3, -1], [1, -3, -1], [0, -3, 1]]]
        >>> buf.occluded_triangles(tri, [0, 1, 2]).tolist()
        [True, False]
        """
        from ._depth_kernel import occluded_triangles

        tri = np.asarray(triangles, dtype=np.float64)
        if tri.ndim != 3 or tri.shape[1:] != (3, 3) or not np.isfinite(tri).all():
            raise InputError(f"triangles: expected finite (m, 3, 3) values, got shape "
                             f"{tri.shape}")
        start = np.asarray(start)
        if (start.ndim != 1 or len(start) < 1 or not np.issubdtype(start.dtype, np.integer)
                or start[0] != 0 or start[-1] != len(tri) or (np.diff(start) < 0).any()):
            raise InputError(f"start: expected non-decreasing group starts from 0 to "
                             f"{len(tri)}, got {start[:5]!r}")
        cam = self.camera
        f, r, u = cam.basis
        out = np.zeros(len(start) - 1, dtype=bool)
        plane = self.plane if self.plane is not None else np.full((*self.shape, 4), np.inf)
        eye = np.asarray(cam.position, dtype=np.float64)
        groups = len(start) - 1
        rule = self.cover is not None
        rec = np.zeros((COVER_PIXELS * groups if rule else 0, 3), dtype=np.int64)
        rec_start = np.zeros(groups + 1, dtype=np.int64)
        occluded_triangles(tri, start.astype(np.int64), eye, r, u, f, cam._half,
                           cam._half_vertical, self.depth, plane, out, rec, rec_start)
        if rule and rec_start[-1]:
            out &= self._cover_rule(tri, rec, rec_start)
        return out

    def _cover_rule(self, tri: np.ndarray, rec: np.ndarray, rec_start: np.ndarray
                    ) -> np.ndarray:
        """(g,) bool: whether each group's listed (triangle, pixel) pairs all pass the cover
        rule (:mod:`viscore.culling._occludee_cover`); True for a group with none."""
        from ._occludee_cover import cover_pairs, frame_tiles

        assert self.cover is not None  # checked by the caller
        vertices, faces, z0 = self.cover
        cam = self.camera
        f, r, u = cam.basis
        h, w = self.depth.shape
        eye = np.asarray(cam.position, dtype=np.float64)
        vc, faces, tri2, tile_start, tiles = frame_tiles(
            vertices, faces, eye, cam.basis, cam._half, cam._half_vertical, w, h, z0)
        ok = np.empty(len(rec_start) - 1, dtype=bool)
        cover_pairs(tri, rec, rec_start, eye, r, u, f, cam._half, cam._half_vertical, w, h,
                    self.margin, vc, faces, tri2, tile_start, tiles, ok)
        return ok
