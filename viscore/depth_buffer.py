"""Conservative reduced-resolution depth buffer of occluders, by ray casting, and its occludee test.

The runtime of the occluder-skins paper [1]_, sec. 5-6, on rays instead of a
rasterizer: the occluders' depth at a reduced resolution (default a quarter
of the screen per side, after [1]_ sec. 7), then each occludee's screen
rectangle at its nearest depth tested against the buffer. Unlike a buffer
sampled at pixel centres, this one is conservative: a pixel holds a depth only
where the occluders cover its whole footprint, and that depth is never nearer
than the occluders anywhere in the pixel; so an object seen through a gap
narrower than a pixel is never culled (a point-sampled culler's false culls,
reported against Godot's ray-cast occlusion culler, godot issue 53288).

How a pixel gets a depth
------------------------
One ray through each pixel *corner* ((W+1) x (H+1) rays per frame, shared by
neighbouring pixels; only those inside the screen rectangle of some occluder
piece's bounding box are cast, the others miss). Occluder triangles are
labelled by *convex piece*: the surface of a convex solid (the ``solids``
and ``boxes`` parts of an occluder), or a convex planar facet (coplanar
adjacent triangles whose union is convex), or the triangle alone. A pixel
holds the largest of its four corner distances when the four corner rays
first hit the same convex piece, else nothing (``inf``). Why that is safe:

- *Planar convex piece P* (a triangle, or a convex facet): the four hit
  points lie in P; the pixel's pyramid of rays meets P's plane in the convex
  quadrilateral of those four points (a central projection maps the pixel's
  convex footprint to a convex set with the corner images as vertices), which
  lies in P by convexity. So every ray of the pixel hits P, at a distance no
  larger than the largest corner distance (the distance from the eye is a
  convex function, largest at a vertex of the quadrilateral).
- *Convex solid K seen from outside*: the four corner directions lie in K's
  projection, which is convex, so the whole pixel does: every ray of the pixel
  hits K. In any plane through the eye the visible part of K's outline lies in
  the triangle of the eye and any two of its points, so along a pixel edge the
  entry distance is bounded by the larger corner distance, and across the
  pixel by the largest of the four. When the eye is inside (or on) a solid, the
  solid's triangles fall back to their planar facets for that frame (from
  inside, a corner ray can see an edge farther than the corners).

Other occluders in front only make the true depth nearer: the stored depth
bounds the occluders' distance from above everywhere in the pixel. Depths are
Euclidean distances from the eye along the ray, widened by
:data:`DEPTH_MARGIN_RELATIVE` for Embree's float32 arithmetic.

Occludee test ([1]_ sec. 6)
---------------------------
The box's eight corners are projected; the buffer pixels its screen rectangle
touches (clipped to the screen) are compared with the box's nearest distance
to the eye. The box is culled iff every one of those pixels holds a depth
nearer than that distance: then every ray from the eye through the box meets
an occluder before the box. Boxes with a corner on or behind the eye's plane,
boxes containing the eye, and boxes wholly off the screen are never culled
(view-frustum culling is the caller's). One range-maximum query per box (a
sparse table along rows), no loop over boxes or pixels.

References
----------
.. [1] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
   Bursztyn, A. P. M. "Implementing software occlusion culling for real-time
   applications". XVIII Congreso Argentino de Ciencias de la Computacion
   (CACIC 2012), Workshop de Computacion Grafica, Imagenes y Visualizacion,
   2012. http://sedici.unlp.edu.ar/handle/10915/23640 (the "Occluder Skins"
   paper: sec. 5 depth buffer generation, sec. 6 occludee test, sec. 7 a
   quarter-size buffer)
.. [2] Zhang, H., Manocha, D., Hudson, T., Hoff, K. "Visibility Culling using
   Hierarchical Occlusion Maps". SIGGRAPH 1997. :DOI:`10.1145/258734.258781`
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import trimesh

from ._validate import InputError, as_positive_int, check_memory
from .cameras import PerspectiveCamera
from .frusta import _as_boxes
from .scene import Scene

__all__ = ["OccluderScene", "ConservativeDepthBuffer", "DEFAULT_REDUCTION",
           "DEPTH_MARGIN_RELATIVE"]

#: The buffer has 1/4 of the screen's pixels per side by default (1280 x 720 ->
#: 320 x 180): the quarter-size buffer of the occluder-skins paper, sec. 7.
DEFAULT_REDUCTION = 4

#: Stored depths are widened by this fraction of (occluder scene diagonal +
#: distance from the eye to its centre): Embree traces in float32 (about 1e-6
#: relative), so a depth is never reported nearer than the occluder really is.
DEPTH_MARGIN_RELATIVE = 1e-5

#: Tolerance for coplanarity (fraction of the mesh's diagonal) and for convex unions
#: of facets (relative area).
_FACET_TOLERANCE = 1e-9

#: Peak bytes per corner ray of one frame (origins, directions, float32 copies,
#: hits, labels).
_BYTES_PER_RAY = 160

_UNIT_BOX = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])


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


class OccluderScene:
    """Occluder triangles in one Embree scene, labelled by convex piece; reused every frame.

    Parameters
    ----------
    occluders : Occluder, trimesh.Trimesh, (vertices, faces) or a list of these
        An :class:`viscore.generators.Occluder` contributes its ``parts``:
        each of ``parts["solids"]`` is one convex piece (checked convex; a
        solid that is not falls back to its planar facets), else each of
        ``parts["boxes"]``; with neither, its ``mesh`` by planar facets. A
        ``trimesh.Trimesh`` contributes its triangles by planar facets. A
        ``(vertices, faces)`` pair is taken as a convex solid.
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
    >>> occ.scene.faces.shape, occ.pieces    # 6 quads of the mesh, 1 solid
    ((24, 3), 7)
    """

    def __init__(self, occluders, *, workers: int | None = None) -> None:
        from .frusta import _plane_groups, _solid_arrays

        items = occluders if isinstance(occluders, list | tuple) and not _is_pair(occluders) \
            else [occluders]
        verts, faces, facet, solid, bounds = [], [], [], [], []
        count = 0

        def add(v, f, solid_piece: bool) -> None:
            nonlocal count
            v = np.asarray(v, dtype=np.float64)
            f = np.asarray(f, dtype=np.int64)
            if len(f) == 0:
                return
            offset = sum(len(x) for x in verts)
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

        for item in items:
            if _is_pair(item):
                add(item[0], item[1], True)
            elif isinstance(item, trimesh.Trimesh):
                add(item.vertices, item.faces, False)
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
                    add(item.mesh.vertices, item.mesh.faces, False)
            else:
                raise InputError(f"occluders: expected Occluder, trimesh.Trimesh or "
                                 f"(vertices, faces), got {type(item).__name__}")
        if not faces:
            raise InputError("occluders: no occluder triangle")
        v = np.vstack(verts)
        f = np.vstack(faces)
        self.scene = Scene(trimesh.Trimesh(v, f, process=False), workers=workers)
        self._facet = np.concatenate(facet)
        raw_solid = np.concatenate(solid)
        # solid ids: dense, and labels offset past the facet labels
        has = raw_solid >= 0
        _, dense = np.unique(raw_solid[has], return_inverse=True)
        self._solid = np.full(len(f), -1, np.int64)
        self._solid[has] = dense
        self._n_solids = int(dense.max()) + 1 if has.any() else 0
        tri = v[f]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        norm = np.linalg.norm(n, axis=1)
        n = n / np.where(norm > 0, norm, 1.0)[:, None]
        self._normal = n
        self._offset = np.einsum("ij,ij->i", n, tri[:, 0])
        self.pieces = len(np.unique(self._facet[~has])) + self._n_solids
        self._center = 0.5 * (self.scene.bounds[0] + self.scene.bounds[1])
        #: (k, 2, 3) bounding box of each added piece: rays outside their screen
        #: rectangles are not cast
        self._bounds = np.stack(bounds)
        self._grids: dict = {}

    def _corner_directions(self, w: int, h: int, hx: float, hy: float) -> np.ndarray:
        """((h+1)(w+1), 3) unit directions through the buffer's pixel corners, in camera
        coordinates (right, up, forward); cached per buffer size and field of view."""
        key = (w, h, hx, hy)
        if key not in self._grids:
            if len(self._grids) > 8:
                self._grids.clear()
            xs = (np.arange(w + 1) / w - 0.5) * (2 * hx)
            ys = (0.5 - np.arange(h + 1) / h) * (2 * hy)
            d = np.empty((h + 1, w + 1, 3))
            d[..., 0] = xs[None, :]
            d[..., 1] = ys[:, None]
            d[..., 2] = 1.0
            d = d.reshape(-1, 3)
            d /= np.sqrt(np.einsum("ij,ij->i", d, d))[:, None]
            d.flags.writeable = False
            self._grids[key] = d
        return self._grids[key]

    def labels(self, eye: np.ndarray) -> np.ndarray:
        """(f,) int64 convex-piece label of each triangle for this eye: the solid's label
        when the eye is strictly outside the solid, the planar facet's label otherwise."""
        label = self._facet.copy()
        if self._n_solids == 0:
            return label
        has = self._solid >= 0
        height = self._normal[has] @ eye - self._offset[has]
        tol = 1e-12 * (self.scene.diagonal + float(np.linalg.norm(eye - self._center)))
        outside = np.zeros(self._n_solids, dtype=bool)
        np.logical_or.at(outside, self._solid[has], height > tol)
        use = np.zeros(len(label), dtype=bool)
        use[has] = outside[self._solid[has]]
        base = int(self._facet.max()) + 1
        label[use] = base + self._solid[use]
        return label


def _is_pair(item) -> bool:
    """A (vertices, faces) pair of arrays (not a list of occluders)."""
    if not isinstance(item, tuple) or len(item) != 2:
        return False
    a, b = (np.asarray(x) if not isinstance(x, trimesh.Trimesh) else None for x in item)
    return a is not None and b is not None and a.ndim == 2 and b.ndim == 2 \
        and a.shape[-1:] == (3,) and b.shape[-1:] == (3,) and np.issubdtype(b.dtype, np.integer)


def _corners_to_cast(bounds: np.ndarray, eye: np.ndarray, basis, hx: float, hy: float,
                     w: int, h: int) -> np.ndarray:
    """(h + 1, w + 1) bool: corner rays that may hit an occluder piece.

    A ray can hit a piece only inside the screen rectangle of the piece's
    bounding box (the hull of its 8 projected corners), widened by one corner
    each side; a box reaching the eye's plane or behind it needs every ray.
    """
    f, r, u = basis
    corners = np.stack([np.where(np.array(m, bool), bounds[:, 1], bounds[:, 0])
                        for m in np.ndindex(2, 2, 2)], axis=1) - eye
    z = corners @ f
    if (z <= 0).any(axis=1).any():
        return np.ones((h + 1, w + 1), dtype=bool)
    col = ((corners @ r) / z / (2 * hx) + 0.5) * w
    row = (0.5 - (corners @ u) / z / (2 * hy)) * h
    c0 = np.clip(np.floor(col.min(axis=1)) - 1, 0, w + 1).astype(np.int64)
    c1 = np.clip(np.ceil(col.max(axis=1)) + 2, 0, w + 1).astype(np.int64)  # exclusive
    r0 = np.clip(np.floor(row.min(axis=1)) - 1, 0, h + 1).astype(np.int64)
    r1 = np.clip(np.ceil(row.max(axis=1)) + 2, 0, h + 1).astype(np.int64)
    ok = (c1 > c0) & (r1 > r0)
    diff = np.zeros((h + 2, w + 2), dtype=np.int64)
    np.add.at(diff, (r0[ok], c0[ok]), 1)
    np.add.at(diff, (r0[ok], c1[ok]), -1)
    np.add.at(diff, (r1[ok], c0[ok]), -1)
    np.add.at(diff, (r1[ok], c1[ok]), 1)
    return (diff.cumsum(axis=0).cumsum(axis=1) > 0)[:h + 1, :w + 1]


@dataclass(frozen=True, eq=False)
class ConservativeDepthBuffer:
    """A conservative occluder depth buffer for one frame, and its occludee test.

    Build with :meth:`from_occluders`.

    Attributes
    ----------
    depth : (H, W) float64
        Per buffer pixel, an upper bound on the distance (world units, from
        the eye) at which every ray through the pixel meets an occluder;
        ``inf`` where the occluders do not provably cover the whole pixel.
        Row 0 is the top edge (towards the camera's up), column 0 the left.
    camera : PerspectiveCamera
        The screen camera; the buffer spans its field of view.
    hits : int
        Corner rays that hit an occluder.
    """

    depth: np.ndarray
    camera: PerspectiveCamera
    hits: int
    _levels: list = field(repr=False)

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) buffer pixels."""
        return self.depth.shape

    def _level(self, k: int) -> np.ndarray:
        """Sparse-table level k (max over 2^k consecutive columns), built on demand."""
        while len(self._levels) <= k:
            prev = self._levels[-1]
            half = 1 << (len(self._levels) - 1)
            self._levels.append(np.maximum(prev[:, :prev.shape[1] - half], prev[:, half:]))
        return self._levels[k]

    @property
    def covered(self) -> np.ndarray:
        """(H, W) bool: pixels that hold a depth."""
        return np.isfinite(self.depth)

    @classmethod
    def from_occluders(cls, occluders, camera: PerspectiveCamera, *, width: int | None = None,
                       height: int | None = None) -> ConservativeDepthBuffer:
        """Cast the corner rays of a W x H buffer and keep the provably covered pixels.

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
        >>> buf.shape, bool(buf.covered.all())
        ((9, 16), True)
        """
        if not isinstance(camera, PerspectiveCamera):
            raise InputError(f"camera: expected a PerspectiveCamera, got "
                             f"{type(camera).__name__}")
        rows, cols = camera.shape
        w = max(1, cols // DEFAULT_REDUCTION) if width is None else as_positive_int(
            width, "width", maximum=16384)
        h = max(1, rows // DEFAULT_REDUCTION) if height is None else as_positive_int(
            height, "height", maximum=16384)
        check_memory((w + 1) * (h + 1) * _BYTES_PER_RAY, f"depth buffer {w} x {h}")
        occ = occluders if isinstance(occluders, OccluderScene) else OccluderScene(occluders)
        eye = camera.position
        f, r, u = camera.basis
        hx = float(np.tan(np.radians(camera.fov) / 2))
        hy = hx * rows / cols
        # unit corner directions in camera coordinates (right, up, forward), rotated
        d = occ._corner_directions(w, h, hx, hy) @ np.stack([r, u, f])
        cast = _corners_to_cast(occ._bounds, eye, (f, r, u), hx, hy, w, h).reshape(-1)
        t = np.full(len(d), np.inf)
        tri = np.full(len(d), -1, dtype=np.int64)
        if cast.any():
            t[cast], tri[cast] = occ.scene.first_hit(eye[None], d[cast])
        label = np.where(tri >= 0, occ.labels(eye)[np.maximum(tri, 0)], -1)
        label = label.reshape(h + 1, w + 1)
        t = t.reshape(h + 1, w + 1)
        lab = label[:-1, :-1]
        same = ((lab >= 0) & (lab == label[:-1, 1:]) & (lab == label[1:, :-1])
                & (lab == label[1:, 1:]))
        far = np.maximum(np.maximum(t[:-1, :-1], t[:-1, 1:]), np.maximum(t[1:, :-1], t[1:, 1:]))
        margin = DEPTH_MARGIN_RELATIVE * (occ.scene.diagonal
                                          + float(np.linalg.norm(eye - occ._center)))
        depth = np.where(same, far + margin, np.inf)
        return cls(depth=depth, camera=camera, hits=int((tri >= 0).sum()),
                   _levels=[depth])

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
            ``row0, row1, col0, col1`` inclusive, clipped to the buffer.
        nearest : (n,) float64
            Distance from the eye to the nearest point of the box (0 when the
            box contains the eye).
        testable : (n,) bool
            Every corner strictly in front of the eye's plane and the clipped
            rectangle not empty; only these can be culled.
        """
        lo, hi = _as_boxes(lower, upper)
        cam = self.camera
        eye = cam.position
        f, r, u = cam.basis
        h, w = self.depth.shape
        rows, cols = cam.shape
        hx = float(np.tan(np.radians(cam.fov) / 2))
        hy = hx * rows / cols
        corners = np.stack([np.where(np.array(m, bool), hi, lo)
                            for m in np.ndindex(2, 2, 2)], axis=1)
        p = corners - eye
        z = p @ f
        front = (z > 0).all(axis=1)
        zs = np.where(z > 0, z, 1.0)
        col = ((p @ r) / zs / (2 * hx) + 0.5) * w
        row = (0.5 - (p @ u) / zs / (2 * hy)) * h
        with np.errstate(invalid="ignore"):
            c0 = np.floor(col.min(axis=1))
            c1 = np.floor(col.max(axis=1))
            r0 = np.floor(row.min(axis=1))
            r1 = np.floor(row.max(axis=1))
        on = front & (c1 >= 0) & (c0 <= w - 1) & (r1 >= 0) & (r0 <= h - 1)
        rect = np.stack([np.clip(r0, 0, h - 1), np.clip(r1, 0, h - 1),
                         np.clip(c0, 0, w - 1), np.clip(c1, 0, w - 1)], axis=1)
        rect = np.where(on[:, None], rect, 0).astype(np.int64)
        nearest = np.linalg.norm(np.clip(eye, lo, hi) - eye, axis=1)
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
            False for boxes crossing or behind the eye's plane, containing the
            eye, or wholly off the screen.

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
        rect, nearest, ok = self.screen_rectangles(lower, upper)
        out = np.zeros(len(rect), dtype=bool)
        idx = np.flatnonzero(ok)
        if len(idx) == 0:
            return out
        r0, r1, c0, c1 = rect[idx].T
        width = c1 - c0 + 1
        level = np.floor(np.log2(width)).astype(np.int64)
        best = np.empty(len(idx))
        for k in np.unique(level):  # at most log2(W) + 1 levels
            sel = np.flatnonzero(level == k)
            table = self._level(int(k))
            heights = r1[sel] - r0[sel] + 1
            starts = np.concatenate([[0], np.cumsum(heights)[:-1]])
            row = np.repeat(r0[sel] - starts, heights) + np.arange(heights.sum())
            left = np.repeat(c0[sel], heights)
            right = np.repeat(c1[sel] - (1 << int(k)) + 1, heights)
            m = np.maximum(table[row, left], table[row, right])
            best[sel] = np.maximum.reduceat(m, starts)
        out[idx] = best < nearest[idx]
        return out
