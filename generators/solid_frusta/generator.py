"""Solid occluders for shadow-frustum culling: a few convex solids inside the mesh.

Papaioannou et al. [1]_ (sec. 2) model their convex solid occluders by hand;
these are grown from the boxes of Leone et al. [2]_, sec. 4.

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006, Plzen, UNION Agency - Science
   Press, ISBN 80-86943-03-8.
.. [2] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
   Bursztyn, A. P. M. "Implementing software occlusion culling for real-time
   applications". XVIII Congreso Argentino de Ciencias de la Computacion
   (CACIC 2012), Workshop de Computacion Grafica, Imagenes y Visualizacion,
   2012. http://sedici.unlp.edu.ar/handle/10915/23640 (the "Occluder Skins"
   paper)
.. [3] Jacobson, A., Kavan, L., Sorkine-Hornung, O. "Robust inside-outside
   segmentation using generalized winding numbers". ACM Transactions on
   Graphics 32(4), 2013, article 33. :DOI:`10.1145/2461912.2461916`
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import trimesh

from viscore import InputError, Scene, points_inside, voxelize
from viscore._content_cache import ContentCache
from viscore._validate import as_positive_int, as_seed, check_memory
from viscore.culling.shadow_frusta import _solid_arrays
from viscore.voxel.grid import inside_voxels_winding
from viscore.voxel.wall_thickness import WALL_QUANTILE, wall_voxel_size

from .._boxes import boxes_mesh
from .._held_logs import held_records, release
from ..occluder import Occluder

__all__ = ["generate_solid_frusta", "PIECES"]

_log = logging.getLogger(__name__)

#: The box source, aabb-skins (:func:`viscore.generators.aabb_skins.generate_aabb_skins`):
#: its generator, largest ``voxels`` and peak bytes per voxel cell (``seed_voxel``
#: 'max-volume'); set by :mod:`viscore.generators.registry` (:func:`use_box_source`):
#: aabb-skins is a family of its own and this module does not import it.
_BOX_SOURCE: dict = {}


def use_box_source(generate, *, max_voxels: int, bytes_per_cell: float) -> None:
    """Set the generator of the candidate boxes (called by the registry)."""
    _BOX_SOURCE.update(generate=generate, max_voxels=max_voxels, bytes_per_cell=bytes_per_cell)


def _box_source() -> dict:
    if not _BOX_SOURCE:
        raise LookupError("solid-frusta: no box source registered (it is registered when "
                          "viscore.generators is imported)")
    return _BOX_SOURCE


#: Sources of convex pieces beside the aabb-skins boxes.
PIECES = ("voxel-hulls", "boxes-only")

#: ``voxels`` when none is given: the extent-based size, and the coarsest of
#: ``voxel_sizing="auto"``.
DEFAULT_VOXELS = 64

#: Ways of choosing the voxel size when ``voxels`` is not given (as aabb-skins').
VOXEL_SIZINGS = ("auto", "extent")


#: Convex pieces are tested widened by this many voxels: a piece is kept only
#: when it stays this far from the surface (float32 ray casting cannot see
#: the difference, and float64 rounding of the tests is far below it).
MARGIN_PITCH = 1e-3

#: At most this many hull vertices per piece (farthest-point subset: its hull
#: lies inside the full hull), so a piece has at most 2 * 32 - 4 triangles.
MAX_HULL_VERTICES = 32

#: Cluster counts tried, as multiples of ``solids`` (more, smaller clusters are
#: closer to convex and lose less when shrunk).
_CLUSTER_FACTORS = (1, 2)

#: Mesh edges clipped against a piece per batch (bounds the (edges x planes) work).
_EDGE_BATCH = 1 << 16

#: :func:`_inner_depth` takes the distance transform of the inner voxels' box (about 20
#: float64 and int32 bytes a cell, at most this many cells per inner voxel) instead of a
#: k-d tree of their rim (some 3 us a voxel): 0.01 against 0.1-0.5 s on a city building
#: (1.6 cells per inner voxel); the study's building-house (17) keeps the tree.
_EDT_CELLS_PER_VOXEL = 8

#: Inner voxel centres tested against a candidate's planes per batch (:func:`_covered`):
#: 1024 x 3 x 60 (a hull's most faces) multiply-adds stay under OpenBLAS's threading
#: threshold (2^18) and 1024 x 60 floats in cache; the CPU of ``_covered`` over the study's
#: meshes and the city's buildings fell from 4.4 to 0.7 s on 2 busy cores (batches of
#: 4096 points or all of them at once: 4 s).
_POINT_BATCH = 1024


def _farthest_subset(points: np.ndarray, k: int) -> np.ndarray:
    """Indices of ``k`` points by farthest-point sampling from the first (deterministic)."""
    if len(points) <= k:
        return np.arange(len(points))
    chosen = [0]
    dist = np.linalg.norm(points - points[0], axis=1)
    for _ in range(k - 1):  # k <= MAX_HULL_VERTICES steps
        i = int(np.argmax(dist))
        chosen.append(i)
        dist = np.minimum(dist, np.linalg.norm(points - points[i], axis=1))
    return np.array(chosen)


def _line_extremes(points: np.ndarray, pitch: float) -> np.ndarray:
    """The points of a voxel-centre set at the ends of its grid lines: per line along x the
    first and last point, then per line along y of those, then along z (in the given order).

    Each point left out lies on the segment between two points kept (the ends of its
    line), so the convex hull is the same, from a few points per line instead of every
    voxel (a thin slab of millions of voxels keeps its rim)."""
    ijk = np.rint((points - points.min(axis=0)) / pitch).astype(np.int64)
    keep = np.arange(len(points))
    for a in range(3):
        b, c = [axis for axis in range(3) if axis != a]
        sub = ijk[keep]
        order = np.lexsort((sub[:, a], sub[:, c], sub[:, b]))
        kb, kc = sub[order, b], sub[order, c]
        start = np.r_[True, (kb[1:] != kb[:-1]) | (kc[1:] != kc[:-1])]
        end = np.r_[start[1:], True]
        keep = keep[order[start | end]]
    return points[np.sort(keep)]


def _hull(points: np.ndarray) -> trimesh.Trimesh | None:
    """Convex hull with outward faces, or None when degenerate (flat, too few points, or
    not closed: every piece must be a closed convex solid for the frusta runtimes).

    Computed on the points centred and scaled to unit size (qhull's and
    trimesh's tolerances are absolute), then mapped back exactly as given.
    """
    if len(points) < 4:
        return None
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, size = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
    if not size > 0:
        return None
    # trimesh's centre of mass of a flat hull divides by its zero volume, in
    # convex_hull (its orientation check) and in .volume: not a user's concern
    with np.errstate(divide="ignore", invalid="ignore"):
        try:
            unit = trimesh.convex.convex_hull((points - centre) / size)
        except Exception:  # noqa: BLE001 - qhull on flat input: no piece
            return None
        volume = unit.volume
    if len(unit.faces) < 4 or not volume > 1e-12:
        return None
    if not (unit.is_watertight and unit.is_winding_consistent):
        return None  # trimesh drops qhull's zero-area faces: a thin hull can come back open
    return trimesh.Trimesh(centre + size * np.asarray(unit.vertices), np.asarray(unit.faces),
                           process=False)


def _runtime_solid(hull: trimesh.Trimesh) -> bool:
    """Whether the frusta runtimes take ``hull`` as a solid (closed, outward, convex within
    their tolerance: :mod:`viscore.culling.shadow_frusta`'s check of every occluder solid)."""
    try:
        _solid_arrays(np.asarray(hull.vertices), np.asarray(hull.faces), 0)
    except InputError:
        return False
    return True


def _planes(hull: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """Unit outward normals (f, 3) and offsets (f,) of a convex hull: inside n.x <= d.

    Normals from the triangles directly (trimesh zeroes those of tiny triangles).
    """
    tri = np.asarray(hull.vertices)[np.asarray(hull.faces)]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    d = np.einsum("ij,ij->i", n, tri[:, 0])
    return n, d


def _segments_meet(a: np.ndarray, b: np.ndarray, normals: np.ndarray,
                   offsets: np.ndarray) -> bool:
    """Whether any segment a[i] b[i] meets the convex region n.x <= d (closed)."""
    for s in range(0, len(a), _EDGE_BATCH):
        pa, pb = a[s:s + _EDGE_BATCH], b[s:s + _EDGE_BATCH]
        fa = pa @ normals.T - offsets  # <= 0 inside
        fb = pb @ normals.T - offsets
        # both endpoints outside one plane: the segment misses
        out = ((fa > 0) & (fb > 0)).any(axis=1)
        denom = fa - fb
        with np.errstate(divide="ignore", invalid="ignore"):
            t = fa / denom  # where the segment crosses each plane
        entering = fa > fb  # moving from outside to inside
        t_in = np.where(entering & (fa > 0), t, 0.0).max(axis=1)
        t_out = np.where(~entering & (fb > 0), t, 1.0).min(axis=1)
        if ((t_in <= t_out) & ~out).any():
            return True
    return False


class _Containment:
    """The mesh's scene, edges and inside test, shared by every piece."""

    def __init__(self, mesh: trimesh.Trimesh, pitch: float) -> None:
        self.scene = Scene(mesh)
        v = np.asarray(mesh.vertices, dtype=np.float64)
        edges = np.asarray(mesh.edges_unique)
        self.a, self.b = v[edges[:, 0]], v[edges[:, 1]]
        self.lo = np.minimum(self.a, self.b)
        self.hi = np.maximum(self.a, self.b)
        self.margin = MARGIN_PITCH * pitch

    def inside(self, hull: trimesh.Trimesh, centre: np.ndarray) -> bool:
        """Tests 1-3 of the module docstring; test 2 on ``hull`` widened by the margin.

        ``centre`` is a point known to be inside the mesh (an inner voxel's
        centre); when the hull contains it, test 1 holds for every vertex once
        tests 2-3 pass (the surface does not meet the hull), so the winding
        number is evaluated only when it does not. The cheap test 3 runs first.
        If a mesh triangle met the hull, a vertex of their intersection would
        be a triangle vertex in the hull or a triangle edge crossing its
        boundary (test 2, on the widened hull, which also covers Embree's
        float32 misses near triangle edges) or a hull edge crossing the
        triangle (test 3, Embree segment queries along the hull's own edges).
        """
        v = np.asarray(hull.vertices)
        e = np.asarray(hull.edges_unique)
        d = v[e[:, 1]] - v[e[:, 0]]
        length = np.linalg.norm(d, axis=1)
        keep = length > 0
        if self.scene.any_hit(v[e[keep, 0]], d[keep] / length[keep, None],
                              max_distance=length[keep]).any():
            return False
        normals, offsets = _planes(hull)
        if (normals @ centre - offsets).max() > 0 and not points_inside(self.scene, v).all():
            return False
        # mesh edges near the hull: bounding box, then bounding sphere
        lo, hi = v.min(axis=0) - self.margin, v.max(axis=0) + self.margin
        near = np.flatnonzero(((self.hi >= lo) & (self.lo <= hi)).all(axis=1))
        if len(near) == 0:
            return True
        c = v.mean(axis=0)
        radius = float(np.linalg.norm(v - c, axis=1).max()) + self.margin
        a, b = self.a[near], self.b[near]
        ab = b - a
        t = np.clip(np.einsum("ij,ij->i", c - a, ab) / np.maximum(
            np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
        close = np.linalg.norm(a + t[:, None] * ab - c, axis=1) <= radius
        return not _segments_meet(a[close], b[close], normals, offsets + self.margin)


def _shrink_into(hull: trimesh.Trimesh, centre: np.ndarray, test: _Containment,
                 steps: int) -> tuple[trimesh.Trimesh | None, float]:
    """Largest scale s (bisection, ``steps`` halvings) with centre + s (H - centre) inside."""
    v = np.asarray(hull.vertices)

    def scaled(s: float) -> trimesh.Trimesh:
        return trimesh.Trimesh(centre + s * (v - centre), hull.faces, process=False)

    if test.inside(hull, centre):
        return hull, 1.0
    low, high = 0.0, 1.0
    best = None
    for _ in range(steps):  # the scale halves its uncertainty each step
        mid = 0.5 * (low + high)
        candidate = scaled(mid)
        if test.inside(candidate, centre):
            low, best = mid, candidate
        else:
            high = mid
    return best, low


def _kmeans_pp(data: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
    """``(k, 3) float64``: the k-means++ seeds of ``scipy.cluster.vq.kmeans2(data, k,
    minit='++', seed=rng)`` (Arthur and Vassilvitskii 2007), drawing the same numbers.

    Each point's squared distance to its nearest seed is kept and lowered by the newest
    seed alone (the same pairwise distances and minimum as scipy's, which measures every
    point to every seed again for each new one: k^2 / 2 passes over the points).
    """
    from scipy.spatial.distance import cdist

    init = np.empty((k, data.shape[1]))
    init[0] = data[rng.integers(data.shape[0], dtype=np.int64)]
    nearest = None
    for i in range(1, k):  # one pass over the points per seed
        d2 = cdist(init[i - 1:i], data, metric="sqeuclidean")[0]
        nearest = d2 if nearest is None else np.minimum(nearest, d2)
        cumprobs = (nearest / nearest.sum()).cumsum()
        init[i] = data[int(np.searchsorted(cumprobs, rng.uniform()))]
    return init


def _voxel_hulls(centres: np.ndarray, depth: np.ndarray, pitch: float, solids: int,
                 rng: np.random.Generator, test: _Containment, steps: int) -> list[tuple]:
    """Convex pieces: hulls of k-means clusters of inner voxels, shrunk inside."""
    from scipy.cluster.vq import kmeans2

    pieces = []
    offsets = (np.array(list(np.ndindex(2, 2, 2)), dtype=np.float64) - 0.5) * pitch
    for factor in _CLUSTER_FACTORS:
        k = min(len(centres), solids * factor)
        if k < 1:
            continue
        _, label = kmeans2(centres, _kmeans_pp(centres, k, rng), minit="matrix")
        for j in range(k):  # a loop over clusters
            member = np.flatnonzero(label == j)
            if len(member) < 2:
                continue
            pts = centres[member]
            ends = _line_extremes(pts, pitch)
            first = _hull(ends) if len(ends) >= 4 else None
            base = np.asarray(first.vertices) if first is not None else ends  # flat: a layer
            cubes = (base[:, None, :] + offsets[None]).reshape(-1, 3)
            full = _hull(cubes)
            if full is None:
                continue
            hv = np.asarray(full.vertices)
            sub = _hull(hv[_farthest_subset(hv, MAX_HULL_VERTICES)])
            if sub is None:
                continue
            centre = pts[np.argmax(depth[member])]
            piece, scale = _shrink_into(sub, centre, test, steps)
            if piece is not None:
                pieces.append((piece, scale))
    return pieces


def _inner_depth(inner: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``(m,) float64``: distance (voxels) from each inner voxel ``index`` to the nearest
    voxel centre that is not inner; ``scipy.ndimage.distance_transform_edt(inner)[inner]``.

    The nearest non-inner voxel z of an inner voxel is 6-adjacent to an inner
    voxel (else z's neighbour towards it, along the axis of the largest offset,
    would be a nearer non-inner one), so a k-d tree over those rim voxels gives
    the same distances, exactly (integer coordinates), at a cost that follows the
    inner voxels and their rim rather than the whole grid (a thin-walled room at
    400 voxels: 46M cells, 1.4M inner voxels). Where the inner voxels fill most of
    their bounding box (at most :data:`_EDT_CELLS_PER_VOXEL` cells of the box grown by
    one voxel per inner voxel, as on a solid building), the exact distance transform of
    that box gives the same distances (every rim voxel lies in it; both are square roots
    of the same integers) at a twentieth of the k-d tree's CPU.
    """
    from scipy import ndimage
    from scipy.spatial import cKDTree

    lo = np.maximum(index.min(axis=0) - 1, 0)
    hi = np.minimum(index.max(axis=0) + 2, inner.shape)
    box = inner[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]
    if box.size <= _EDT_CELLS_PER_VOXEL * len(index) and not box.all():
        local = index - lo
        return ndimage.distance_transform_edt(box)[local[:, 0], local[:, 1], local[:, 2]]
    rim = np.zeros(inner.shape, dtype=bool)
    for axis in range(3):  # non-inner voxels with an inner 6-neighbour
        n = inner.shape[axis]
        lo, hi = [slice(None)] * 3, [slice(None)] * 3
        lo[axis], hi[axis] = slice(0, n - 1), slice(1, n)
        rim[tuple(lo)] |= inner[tuple(hi)]
        rim[tuple(hi)] |= inner[tuple(lo)]
    rim &= ~inner
    from viscore import get_workers

    tree = cKDTree(np.argwhere(rim).astype(np.float64))
    depth, _ = tree.query(index.astype(np.float64), k=1, workers=get_workers())
    return np.asarray(depth, dtype=np.float64)


def _covered(points: np.ndarray, hulls: list) -> np.ndarray:
    """(len(hulls), n) bool: which points lie inside each convex hull (its bounding box,
    then every plane).

    The plane products run over :data:`_POINT_BATCH` points at a time: the same
    products (a row's result does not depend on the rows beside it), in a working set
    that stays in cache and under BLAS's threading threshold (on a busy machine its
    second thread costs more CPU than it saves, and the full (n, faces) products of a
    city mesh's millions of inner voxels are hundreds of megabytes).
    """
    axes = [np.ascontiguousarray(points[:, a]) for a in range(3)]
    out = np.zeros((len(hulls), len(points)), dtype=bool)
    for row, hull in zip(out, hulls, strict=True):
        n, d = _planes(hull)
        nt = n.T
        lo, hi = hull.bounds
        box = (axes[0] >= lo[0]) & (axes[0] <= hi[0])
        for a in (1, 2):
            box &= axes[a] >= lo[a]
            box &= axes[a] <= hi[a]
        near = np.flatnonzero(box)
        for s in range(0, len(near), _POINT_BATCH):  # bounded batches of points
            at = near[s:s + _POINT_BATCH]
            row[at] = ((points[at] @ nt - d) <= 0).all(axis=1)
    return out


@dataclass(frozen=True)
class _Candidates:
    """What :func:`generate_solid_frusta` chooses from, which the budget does not change:
    the box source's records to say (``records``), its boxes (k, 2, 3) and whether the mesh
    is closed, the candidate solids (mesh, kind, scale; boxes first, ``boxes_count`` of
    them), ``cover`` (candidates, ceil(centres / 8)) uint8: each candidate's inner voxel
    centres, bit-packed along the centres, the voxel pitch, cell volume and the solid's
    volume (world units)."""

    records: list
    boxes: np.ndarray
    closed: bool
    candidates: list
    boxes_count: int
    cover: np.ndarray
    centres: int
    pitch: float
    cell_volume: float
    solid_volume: float


#: The candidates of the last mesh and options in this process (:class:`_Candidates`, the
#: inner voxels' cover bit-packed): a study's budgets of one mesh make them once.
_SOLIDS = ContentCache(1)


def _solid_candidates(mesh: trimesh.Trimesh, size: dict, box_size: dict, source: dict, *,
                      solids: int, pieces: str, shrink_steps: int, seed: int) -> _Candidates:
    """The box source's boxes and the voxel hulls, and the inner voxel centres each covers
    (:func:`generate_solid_frusta`, every step before the greedy choice)."""
    with held_records() as said:  # the box source's lines: its warning on openness is ours
        skins = source["generate"](mesh, **box_size, max_boxes=solids, fill=1.0)
    boxes = np.asarray(skins.parts["boxes"], dtype=np.float64)
    closed = bool(skins.info["closed_oriented"])
    kept = [r for r in said if closed or r.levelno < logging.WARNING]
    later: list = []
    try:
        with held_records() as later:  # said by each call, after the box source's
            vox = voxelize(mesh, **size)
            pitch = vox.grid.pitch
            inner = inside_voxels_winding(mesh.vertices, mesh.faces, vox.grid, vox.surface,
                                          closed=closed) if closed else None
            if inner is None:  # open mesh: the candidates aabb-skins used, centres inside
                inner = inside_voxels_winding(mesh.vertices, mesh.faces, vox.grid, vox.surface,
                                              candidates=vox.solid & ~vox.surface, closed=False)
            index = np.argwhere(inner)
            centres = vox.grid.centers(index)
            cell_volume = float(np.float64(pitch) ** 3)
            with np.errstate(divide="ignore", invalid="ignore"):  # trimesh's centre, flat mesh
                solid_volume = abs(float(mesh.volume)) if closed else len(index) * cell_volume

            # candidates: boxes first (as 12-triangle solids), then hulls
            box_meshes = [boxes_mesh(b[None]) for b in boxes]
            candidates = [(m, "box", 1.0) for m in box_meshes]
            # one box over every inner voxel (a slab of ground, a block): its gain, all the
            # centres, is the most any hull could have, and ties go to the boxes, so the greedy
            # below takes that box and stops; the hulls (k-means over millions of voxels on a
            # level's ground) would change nothing
            one_box = closed and len(boxes) == 1 and skins.info["covered_voxels"] == len(index)
            if pieces == "voxel-hulls" and len(index) >= 4 and not one_box:
                depth = _inner_depth(inner, index)
                test = _Containment(mesh, pitch)
                rng = np.random.default_rng(seed)
                for hull, scale in _voxel_hulls(centres, depth, pitch, solids, rng, test,
                                                shrink_steps):
                    if _runtime_solid(hull):
                        candidates.append((hull, "hull", scale))
            n_boxes = len(box_meshes)
            cover = _covered(centres, [m for m, _, _ in candidates])
    except BaseException:
        release(kept + later)
        raise
    return _Candidates(records=kept + later,
                       boxes=boxes, closed=closed, candidates=candidates,
                       boxes_count=n_boxes, cover=np.packbits(cover.astype(bool), axis=1),
                       centres=len(centres), pitch=pitch, cell_volume=cell_volume,
                       solid_volume=solid_volume)


def generate_solid_frusta(mesh: trimesh.Trimesh, *, budget: int | None = None, seed: int = 0,
                          voxels: int | None = None, solids: int = 8,
                          pieces: str = "voxel-hulls", shrink_steps: int = 6,
                          voxel_sizing: str = "auto") -> Occluder:
    """A few convex solid occluders inside the mesh, for shadow-frustum culling.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Any triangle soup; the solids are guaranteed conservative when it is
        closed and consistently oriented (as for
        :func:`viscore.generators.aabb_skins.generate_aabb_skins`).
    budget : int, optional
        Triangle budget: solids are added while their triangles fit (a box
        has 12). Default: no cap.
    seed : int, optional
        Seed of the k-means clustering. Default 0.
    voxels : int, optional
        Voxels along the longest bounding-box side, 1 to 2048. Default: by
        ``voxel_sizing``.
    solids : int, optional
        At most this many solids (default 8; [1]_ keeps one to three per
        building).
    pieces : {'voxel-hulls', 'boxes-only'}, optional
        'voxel-hulls' (default): candidates are the aabb-skins boxes and the
        convex hulls of inner-voxel clusters (k-means with ``solids`` and
        ``2 * solids`` clusters), shrunk inside. 'boxes-only': the aabb-skins
        boxes alone.
    shrink_steps : int, optional
        Bisection steps on a piece's scale factor when the full hull does not
        fit (default 6: the scale is found to 1/64).
    voxel_sizing : {'auto', 'extent'}, optional
        The voxel size when ``voxels`` is not given. 'auto': 64 voxels along
        the longest side, or finer where the walls are thinner (module
        docstring), within the memory guard; a few seconds on an open
        building instead of a fraction of a second (the inside test of an
        open mesh evaluates the winding number at a small share of the voxels
        and bounds it at the rest, and the box source's answer for the same grid
        and candidates is reused: :func:`viscore.voxel.grid.inside_voxels_winding`).
        'auto' is the default. 'extent': 64 voxels along the longest side.

    Returns
    -------
    Occluder
        ``parts["solids"]``: the chosen solids as (vertices (v, 3) float64,
        faces (f, 3) int64 outward), best first; ``parts["boxes"]``: the
        chosen aabb-skins boxes (k, 2, 3). ``mesh``: the solids' triangles;
        ``double_sided`` False. ``info``:

        - ``volume_share``: list, share of the mesh volume covered by the
          union of the first k solids, k = 1..n (estimated on the inner
          voxel centres; exact for boxes);
        - ``aabb_skins_volume_share``: the same for the first k aabb-skins
          boxes alone (as many as the solids allow);
        - ``kinds``: 'box' or 'hull' per solid; ``hull_scales``: the
          shrink factor of each hull (1 = unshrunk);
        - ``candidates``: number of boxes and hulls considered;
        - ``closed_oriented``, ``conservative_guaranteed`` (bool), ``pitch``;
        - ``voxel_sizing``: ``'voxels'``, ``'extent'`` or ``'auto'``; with
          'auto' also ``wall_sizing`` (as aabb-skins' ``info``).

    Raises
    ------
    InputError
        On a bad option, an empty mesh, or a voxel grid from ``voxels`` over
        the memory limit; checked before any work. The 'auto' size falls
        back to the finest grid that fits instead (one warning says so).

    Notes
    -----
    Deterministic given ``seed``. Conservative on closed, consistently
    oriented meshes: boxes by the aabb-skins argument, hulls by the
    containment tests of the module docstring (up to float rounding, with a
    margin of :data:`MARGIN_PITCH` voxels). On other meshes nothing is
    guaranteed (``conservative_guaranteed`` False), and one warning says so
    (the box source's own warnings on such a mesh, about the same openness,
    are not repeated). May return fewer solids than asked, or none on thin
    input.

    References
    ----------
    .. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient
       Occlusion Culling using Solid Occluders". WSCG 2006, ISBN 80-86943-03-8.

    Examples
    --------
    >>> occ = generate_solid_frusta(trimesh.creation.box(extents=(2, 1, 1)), voxels=16)
    >>> len(occ.parts["solids"]), occ.info["kinds"], occ.info["conservative_guaranteed"]
    (1, ['box'], True)
    """
    start = time.perf_counter()
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError("mesh: expected a non-empty trimesh.Trimesh")
    if pieces not in PIECES:
        raise InputError(f"pieces: expected one of {', '.join(PIECES)}, got {pieces!r}")
    if voxel_sizing not in VOXEL_SIZINGS:
        raise InputError(f"voxel_sizing: expected one of {', '.join(VOXEL_SIZINGS)}, got "
                         f"{voxel_sizing!r}")
    source = _box_source()
    if voxels is not None:
        voxels = as_positive_int(voxels, "voxels", maximum=source["max_voxels"])
    solids = as_positive_int(solids, "solids", maximum=4096)
    shrink_steps = as_positive_int(shrink_steps, "shrink_steps", maximum=52)
    seed = as_seed(seed)
    if budget is not None:
        budget = as_positive_int(budget, "budget")
        if budget < 12:
            raise InputError(f"budget: at least 12 triangles (one box), got {budget}")
    from viscore import voxel_grid

    wall_sizing = None
    if voxels is not None or voxel_sizing == "extent":
        sizing = "voxels" if voxels is not None else "extent"
        voxels = DEFAULT_VOXELS if voxels is None else voxels
        size, box_size, what = ({"resolution": voxels}, {"voxels": voxels},
                                f"voxels={voxels}")
    else:
        sizing = "auto"
        # both grids (the boxes' and the hulls') live at once: twice the bytes per cell
        sized = wall_voxel_size(mesh, bytes_per_cell=source["bytes_per_cell"] * 2,
                                resolution=DEFAULT_VOXELS, quantile=WALL_QUANTILE,
                                max_resolution=source["max_voxels"], what="solid-frusta",
                                finer="voxels")
        _log.log(sized.log_level, "%s", sized.reason)
        wall_sizing = sized.info
        size, box_size = {"pitch": sized.pitch}, {"voxel_size": sized.pitch}
        what = f"voxel_size={sized.pitch:g} (auto)"
    grid = voxel_grid(np.asarray(mesh.bounds), **size)
    cells = float(np.prod(np.array(grid.shape, dtype=np.float64)))
    check_memory(cells * source["bytes_per_cell"] * 2,
                 f"solid-frusta: {what} ({grid.shape[0]} x {grid.shape[1]} x "
                 f"{grid.shape[2]} voxels)")

    made = _SOLIDS.get((np.asarray(mesh.vertices), np.asarray(mesh.faces),
                        mesh.metadata.get("name"), tuple(sorted(size.items())),
                        tuple(sorted(box_size.items())), solids, pieces, shrink_steps, seed),
                       lambda: _solid_candidates(mesh, size, box_size, source, solids=solids,
                                                 pieces=pieces, shrink_steps=shrink_steps,
                                                 seed=seed))
    release(made.records)
    boxes, closed, candidates = made.boxes, made.closed, made.candidates
    n_boxes, n_hulls, pitch = made.boxes_count, len(candidates) - made.boxes_count, made.pitch
    cell_volume, solid_volume = made.cell_volume, made.solid_volume
    # greedy: the candidate adding the most uncovered inner voxel centres
    cover = np.unpackbits(made.cover, axis=1, count=made.centres).view(bool)
    taken = np.zeros(made.centres, dtype=bool)
    chosen: list[int] = []
    triangles = 0
    shares = []
    available = np.ones(len(candidates), dtype=bool)
    while len(chosen) < solids and available.any():  # at most ``solids`` greedy steps
        gain = np.where(available, (cover & ~taken).sum(axis=1), -1)
        best = int(np.argmax(gain))  # ties: the earlier candidate (boxes first)
        if gain[best] <= 0:
            break
        faces = len(candidates[best][0].faces)
        if budget is not None and triangles + faces > budget:
            available[best] = False
            continue
        chosen.append(best)
        available[best] = False
        triangles += faces
        taken |= cover[best]
        shares.append(float(taken.sum() * cell_volume / solid_volume) if solid_volume > 0
                      else 0.0)
    box_share = list(np.cumsum([np.prod(b[1] - b[0]) for b in boxes]) / solid_volume) \
        if solid_volume > 0 else []
    parts_solids = [(np.asarray(candidates[i][0].vertices, dtype=np.float64),
                     np.asarray(candidates[i][0].faces, dtype=np.int64)) for i in chosen]
    chosen_boxes = boxes[[i for i in chosen if i < n_boxes]].reshape(-1, 2, 3)
    if parts_solids:
        out = trimesh.util.concatenate([trimesh.Trimesh(v, f, process=False)
                                        for v, f in parts_solids])
    else:
        out = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), process=False)
    if not closed:
        _log.warning("solid-frusta: %s is not closed and consistently oriented; solids may "
                     "show through holes", mesh.metadata.get("name", "mesh"))
    return Occluder(
        mesh=out, method="solid-frusta", double_sided=False,  # type: ignore[arg-type]
        seconds=time.perf_counter() - start,
        params={"voxels": voxels, "solids": solids, "pieces": pieces,
                "shrink_steps": shrink_steps, "budget": budget, "seed": seed,
                "voxel_sizing": voxel_sizing},
        parts={"solids": parts_solids, "boxes": chosen_boxes},
        info={"volume_share": shares, "aabb_skins_volume_share": [float(x) for x in box_share],
              "kinds": [candidates[i][1] for i in chosen],
              "hull_scales": [candidates[i][2] for i in chosen if candidates[i][1] == "hull"],
              "candidates": {"boxes": n_boxes, "hulls": n_hulls},
              "closed_oriented": closed, "conservative_guaranteed": closed,
              "solids": len(chosen), "pitch": pitch, "voxel_sizing": sizing,
              **({"wall_sizing": wall_sizing} if wall_sizing is not None else {})})
