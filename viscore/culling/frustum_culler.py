"""Per-frame shadow-frustum occlusion culling with an active set of the best occluders.

The runtime of Papaioannou et al. 2006 [1]_ (secs. 2-3: the active occluders
ranked by eqs. 3-4) on the shadow frusta of Hudson et al. 1997 [2]_.

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

import numpy as np
import numpy.typing as npt

from .._validate import InputError, as_positive_int, as_vector
from .shadow_frusta import (
    _DEGENERATE_RELATIVE,
    CAPS,
    MARGIN_RELATIVE,
    SHAPE_TOLERANCE,
    Frustum,
    _as_boxes,
    _cross,
    _face_polygons,
    _fast_boxes,
    _frame_scale,
    _Planes,
    _polygon_arrays,
    _PolygonSet,
    _ranges,
    _solid_arrays,
    _SolidSet,
)

__all__ = ["FrustumCuller", "ACTIVE_OCCLUDERS"]

#: Size of the per-frame active occluder set (Papaioannou et al. 2006, sec. 3:
#: "a set of 15 active occluders").
ACTIVE_OCCLUDERS = 15


def _convex_pieces(polygon, index: int) -> list[np.ndarray]:
    """A planar polygon as convex pieces: itself when convex, else its triangles
    (mapbox-earcut); [] when it is not planar or has no area."""
    try:
        _polygon_arrays(polygon, index)
        return [np.asarray(polygon, dtype=np.float64)]
    except InputError:
        pass
    p = np.asarray(polygon, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) < 3 or not np.isfinite(p).all():
        return []
    c = p.mean(axis=0)
    normal = _cross(p - c, np.roll(p, -1, axis=0) - c).sum(axis=0)
    size = float(np.linalg.norm(p.max(axis=0) - p.min(axis=0)))
    norm = float(np.linalg.norm(normal))
    if not norm > SHAPE_TOLERANCE * size * size:
        return []
    normal = normal / norm
    if np.abs((p - c) @ normal).max() > SHAPE_TOLERANCE * size:
        return []
    ax = p[np.argmax(np.linalg.norm(p - c, axis=1))] - c
    ax /= np.linalg.norm(ax)
    ay = np.cross(normal, ax)
    import mapbox_earcut

    flat = np.stack([(p - c) @ ax, (p - c) @ ay], axis=1)
    tri = mapbox_earcut.triangulate_float64(flat, np.array([len(p)], dtype=np.uint32))
    pieces = []
    for t in tri.reshape(-1, 3):  # a loop over the polygon's triangles (construction)
        try:
            _polygon_arrays(p[t], index)
        except InputError:
            continue  # a sliver
        pieces.append(p[t])
    return pieces


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
        'solid' (default): each solid gives one solid frustum, beside the
        polygons (one unified ranking, [1]_ sec. 3). 'planar': every face of
        every solid is its own planar occluder (coplanar triangles merged, see
        :func:`~viscore.culling.solid_faces_as_polygons`), ranked by eq. 3 as printed (faces
        turned away rank last): the planar-frusta runtime [1]_ compares with.
    active : int, optional
        Occluders that make frusta each frame: the ``active`` best-ranked among
        those that may lie in the view (default 15, [1]_ sec. 3).
    cap : {'eq2', 'front-faces'}, optional
        Near cap of the solid frusta (see :func:`~viscore.culling.solid_frustum`). 'eq2'
        (default): the paper's single plane. 'front-faces': the exact shadow.
    rank : {'eq4', 'faces'}, optional
        Ranking of the solids in 'solid' mode. 'eq4' (default):
        ``f_solid = Vol / |V|^3`` ([1]_ eq. 4), polygons by eq. 3. 'faces': a solid ranks
        as its best face by eq. 3 (the planar mode's score of that face).

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
    :func:`~viscore.culling.solid_frustum`); with occluders inside the scene's geometry, no
    culled box is visible. An occluder is selected only when its bounding
    sphere (a face's, for 'faces' ranking: any face's) may meet the camera's
    view. In 'solid' mode a selected solid that holds the eye gives its faces'
    planar frusta instead (from inside, every face hides what lies beyond it).
    All frusta of a frame share one margin
    (:data:`~viscore.culling.MARGIN_RELATIVE` of the eye's distance to the
    occluders' centre plus their extent).

    **Solid at least as good as planar, every frame.** With ``cap='front-faces'``
    and ``rank='faces'`` (and the same ``active`` and occluders), 'solid' culls
    every box 'planar' culls: a face's planar frustum lies inside its solid's
    exact shadow, and the owners of the ``active`` best faces are among the
    ``active`` best solids ranked by their best face. The defaults follow the
    paper (eq. 2 cap, eq. 4 ranking), which gives no such guarantee: an eq. 2
    cap through the far top corner of a tall building tilts up and spares what
    stands right behind it, where the front face's plane culls (its Fig. 4).

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
                 active: int = ACTIVE_OCCLUDERS, cap: str = "eq2", rank: str = "eq4") -> None:
        if mode not in ("solid", "planar"):
            raise InputError(f"mode: expected 'solid' or 'planar', got {mode!r}")
        if cap not in CAPS:
            raise InputError(f"cap: expected one of {', '.join(CAPS)}, got {cap!r}")
        if rank not in ("eq4", "faces"):
            raise InputError(f"rank: expected 'eq4' or 'faces', got {rank!r}")
        self.mode, self.cap, self.rank = mode, cap, rank
        self.active = as_positive_int(active, "active")
        solids = list(solids) if solids is not None else []
        polygons = list(polygons) if polygons is not None else []
        arrays = [_solid_arrays(v, f, i) for i, (v, f) in enumerate(solids)]
        extra = [_polygon_arrays(p, i) for i, p in enumerate(polygons)]
        # every solid's faces as polygons: the planar mode's occluders, the 'faces'
        # ranking, and the frusta of a solid that holds the eye
        faces = [_face_polygons(a) for a in arrays]  # a loop over occluders, at construction
        per_solid = np.array([len(p["start"]) - 1 for p in faces], dtype=np.int64)
        self._solids = _SolidSet(arrays if mode == "solid" else [])
        self._faces = _PolygonSet.concat(faces)
        self._face_owner = np.repeat(np.arange(len(arrays)), per_solid)
        self._face_start = np.concatenate([[0], np.cumsum(per_solid)]).astype(np.int64)
        self._extra = _PolygonSet.concat(extra)
        points = [s["vertices"] for s in arrays] + [q["points"] for q in extra]
        if points:
            allp = np.vstack(points)
            lo, hi = allp.min(axis=0), allp.max(axis=0)
            self._center, self._diagonal = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
        else:
            self._center, self._diagonal = np.zeros(3), 0.0
        self.count = (len(arrays) if mode == "solid" else self._faces.count) + len(extra)
        self._prepare_frame_arrays()

    def _prepare_frame_arrays(self) -> None:
        """Per-frame constants: ranking terms, and the flat arrays of the compiled path
        (:mod:`viscore.culling._culler_kernel`), which compiles (or loads from its cache) here,
        not in the first frame."""
        from ._culler_kernel import boxes_inside_any, frame_planes, select_occluders

        fc, ex, sv = self._faces, self._extra, self._solids
        z3, zi = np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
        self._none = zi
        self._rank_kind = 2 if self.mode == "planar" else 1 if self.rank == "faces" else 0
        rank = (sv.volume, sv.centroid, -sv.radius, -fc.area, fc.normal, fc.centroid,
                -fc.radius, self._face_start, -ex.area, ex.normal, ex.centroid, -ex.radius)
        self._rank_arrays = tuple(np.ascontiguousarray(a) for a in rank)
        solid = (sv.vertices, sv.normals, sv.offset, sv.face_start.astype(np.int64),
                 getattr(sv, "edge_a", zi), getattr(sv, "edge_b", zi),
                 getattr(sv, "edge_face", zi), getattr(sv, "twin_face", zi), sv.centroid,
                 self._face_start)
        # faces then extra polygons, one polygon set (extra polygon i is polygon faces + i)
        shift = len(fc.points)
        poly = (np.vstack([fc.points, ex.points]),
                np.concatenate([fc.start[:-1], ex.start + shift]).astype(np.int64),
                np.concatenate([fc.next, ex.next + shift]).astype(np.int64),
                np.vstack([fc.normal, ex.normal]), np.concatenate([fc.offset, ex.offset]),
                np.vstack([fc.centroid, ex.centroid]))
        self._kernel_arrays = tuple(np.ascontiguousarray(a) for a in solid + poly)
        self._frame_planes, self._boxes_inside_any = frame_planes, boxes_inside_any
        self._select_occluders = select_occluders
        # compile (or load) the kernels now, with the argument types of every frame
        self._select(self._view(np.zeros(3)))
        planes, start = frame_planes(np.zeros(3), zi, zi, *self._kernel_arrays,
                                     self.cap == "front-faces", 0.0, 0.0, 0.0)
        boxes_inside_any(planes, start, z3, z3, np.zeros(0, dtype=bool))

    @classmethod
    def from_occluders(cls, occluders, *, mode: str = "solid", active: int = ACTIVE_OCCLUDERS,
                       cap: str = "eq2", rank: str = "eq4") -> FrustumCuller:
        """Culler from generator outputs: their ``parts`` solids, boxes and polygons.

        Parameters
        ----------
        occluders : iterable of Occluder
            ``parts["solids"]`` are taken as they are; ``parts["boxes"]``
            become 12-triangle box solids when the occluder has no solids;
            ``parts["polygons"]`` become planar occluders: convex ones as
            they are, non-convex planar ones as their ear-clipping triangles
            (each triangle its own frustum); non-planar or degenerate loops are
            skipped.
        mode, active, cap, rank
            As the constructor.

        Returns
        -------
        FrustumCuller
        """
        import trimesh

        solids: list[tuple[np.ndarray, np.ndarray]]
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
                polygons.extend(_convex_pieces(p, i))
        return cls(solids, polygons=polygons, mode=mode, active=active, cap=cap, rank=rank)

    # ------------------------------------------------------------------ per frame
    def _view(self, camera_or_eye) -> tuple:
        """The eye (3,) and the view of the frame (a camera's basis and the tangents of
        its half angles), as :func:`viscore.culling._culler_kernel.select_occluders` takes them."""
        from ..ray.cameras import PerspectiveCamera

        if isinstance(camera_or_eye, PerspectiveCamera):
            f, r, u = camera_or_eye.basis
            return (np.ascontiguousarray(camera_or_eye.position), True, f, r, u,
                    camera_or_eye._half, camera_or_eye._half_vertical)
        z = np.zeros(3)
        return np.ascontiguousarray(as_vector(camera_or_eye, "eye")), False, z, z, z, 0.0, 0.0

    def _select(self, view: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Chosen solids, solid faces (planar mode) and extra polygons, best first:
        the ``active`` best ranks among the occluders whose bounding sphere may meet
        the view (ranks of :func:`~viscore.culling.rank_solids` and
        :func:`~viscore.culling.rank_planar`)."""
        first, extra = self._select_occluders(*view, self._rank_kind, self.active,
                                              *self._rank_arrays)
        if self.mode == "planar":
            return self._none, first, extra
        return first, self._none, extra

    def _frame(self, camera_or_eye) -> tuple[np.ndarray, list[tuple[_Planes, str]]]:
        view = self._view(camera_or_eye)
        eye = view[0]
        sel_solids, sel_faces, sel_extra = self._select(view)
        scale = _frame_scale(eye, self._center, self._diagonal)
        if len(sel_solids):
            inside = self._solids.eye_inside(eye, sel_solids)
            if inside.any():  # from inside a solid, its faces hide what lies beyond them
                held, _ = _ranges(self._face_start, sel_solids[inside])
                sel_faces = np.concatenate([sel_faces, held])
                sel_solids = sel_solids[~inside]
        out = [(self._solids.planes(eye, sel_solids, self.cap, scale), "solid"),
               (self._faces.planes(eye, sel_faces, scale), "planar"),
               (self._extra.planes(eye, sel_extra, scale), "planar")]
        return eye, [(p, k) for p, k in out if len(p)]

    def frusta(self, camera_or_eye) -> list[Frustum]:
        """The frame's active frusta.

        Parameters
        ----------
        camera_or_eye : PerspectiveCamera or (3,) float
            With a camera, occluders outside its view are not selected.

        Returns
        -------
        list of Frustum
            One per active occluder the eye is outside of (a solid holding the
            eye gives one per face).
        """
        eye, parts = self._frame(camera_or_eye)
        return [f for p, kind in parts for f in p.frusta(eye, kind)]

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
        lo, hi = _fast_boxes(lower, upper)
        view = self._view(camera_or_eye)
        eye = view[0]
        sel_solids, sel_faces, sel_extra = self._select(view)
        if len(sel_extra):
            sel_faces = np.concatenate([sel_faces, sel_extra + self._faces.count])
        scale = _frame_scale(eye, self._center, self._diagonal)
        planes, start = self._frame_planes(
            eye, sel_solids, sel_faces, *self._kernel_arrays, self.cap == "front-faces",
            MARGIN_RELATIVE * scale, _DEGENERATE_RELATIVE * scale * scale,
            _DEGENERATE_RELATIVE * scale)
        out = np.zeros(len(lo), dtype=bool)
        if not self._boxes_inside_any(planes, start, lo, hi, out):
            _as_boxes(lower, upper)  # raises on the bad box
        return out
