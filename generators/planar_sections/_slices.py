"""Planar sections, steps 4.1 and 4.2: the voxel solid and its maximal-area slices.

Silvennoinen et al. 2014 [1]_, secs. 4.1-4.2.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 4.1, 4.2)
.. [2] Jacobson, A., Kavan, L., Sorkine-Hornung, O. "Robust Inside-Outside
   Segmentation using Generalized Winding Numbers". ACM Transactions on
   Graphics 32(4), 2013. :DOI:`10.1145/2461912.2461916`
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import trimesh
from scipy import ndimage

from viscore import Scene, camera_basis, directions_fibonacci, voxelize
from viscore._content_cache import ContentCache, content_key
from viscore._jit import njit_cached
from viscore.level.ground import ground_fill, ground_share
from viscore.voxel.coverage_hull import exposed_count, exposure, hull_directions
from viscore.voxel.grid import VoxelGrid, Voxelization, inside_voxels_winding
from viscore.voxel.winding import is_closed_oriented

__all__ = ["SectionSolid", "GroundFill", "Slice", "VoxelBase", "voxel_base", "section_solid",
           "closed_solid",
           "slice_directions", "best_slices", "make_slice", "slice_image", "solid_key",
           "PIXELS_PER_VOXEL"]

#: Pixels per voxel side of the slice images (sec. 4.2: every voxel covers >= 1 pixel).
PIXELS_PER_VOXEL = 1

#: Depth samples per voxel along a direction when searching a bin exhaustively.
DEPTH_SAMPLES_PER_VOXEL = 1

#: Directions sampled per direction bin (plus the three axes, which voxel solids favour).
DIRECTIONS_PER_BIN = 4

#: Empty pixels around each slice image, so that its border is background.
_MARGIN = 1

#: Solids kept per :class:`SectionSolid` by :meth:`SectionSolid.solid_along` (one per
#: sampled normal: the default 16 bins x 4 samples + 3 axes).
_ALONG_KEPT = 128


@dataclass(frozen=True, eq=False)
class SectionSolid:
    """The voxel solid that is sliced.

    Attributes
    ----------
    solid : grid.shape bool
        Solid voxels (flood-fill solid, or the eroded inside voxels).
    grid : VoxelGrid
    closed_oriented : bool
        The mesh is closed and consistently oriented (winding numbers exact).
    surface_voxels, solid_voxels : int
    interior_voxels : int
        Solid voxels whose six face neighbours are solid too (a one-voxel
        erosion): few for open sheets and thin-walled shells.
    footprint_share : float
        Share of its footprint across the up axis that the surface covers
        from above (:func:`viscore.level.ground.ground_share`): near 1 for a
        height field or a building, low for a pole or a strand.
    """

    solid: np.ndarray
    grid: VoxelGrid
    closed_oriented: bool
    surface_voxels: int
    solid_voxels: int
    interior_voxels: int = 0
    footprint_share: float = 0.0
    fill: GroundFill | None = None
    _along: dict = field(default_factory=dict, repr=False, compare=False)
    _along_lock: threading.Lock = field(default_factory=threading.Lock, repr=False,
                                        compare=False)

    def solid_along(self, normal: np.ndarray) -> np.ndarray:
        """The solid a plane of unit normal ``normal`` is sliced through.

        Without a ground fill, :attr:`solid`. With one, the solid without the
        fill plus the fill's voxels that the mesh covers from every line
        direction the plane is not grazed by (:meth:`GroundFill.allowed`);
        kept per normal (the depth sweep and the slice images ask for the same
        normals; not to be written to).
        """
        if self.fill is None or len(self.fill.cells) == 0:
            return self.solid
        normal = np.asarray(normal, np.float64)
        key = normal.tobytes()
        with self._along_lock:
            kept = self._along.get(key)
        if kept is not None:
            return kept
        out = self.solid.copy()
        cells = self.fill.cells[~self.fill.allowed(normal)]
        out[tuple(cells.T)] = False
        with self._along_lock:
            if len(self._along) >= _ALONG_KEPT:
                self._along.clear()
            self._along[key] = out
        return out

    @cached_property
    def solid_box(self) -> tuple[np.ndarray, np.ndarray]:
        """World corners ``(3,)`` low and high of the solid voxels' bounding box (every
        slice frame is laid over it)."""
        idx = np.argwhere(self.solid)
        return self.grid.corner(idx.min(axis=0)), self.grid.corner(idx.max(axis=0) + 1)


@dataclass(frozen=True, eq=False)
class GroundFill:
    """The voxels a ground plane adds to a solid, and the directions that expose each.

    Attributes
    ----------
    cells : (m, 3) int
        Voxels between the ground and the surface above
        (:func:`viscore.level.ground.ground_fill`), not in the flood-fill solid.
    exposure : (m, ceil(k / 8)) uint8
        :func:`viscore.voxel.coverage_hull.exposure` of each, over ``directions``.
    directions : (k, 3) float
        The coverage hull's line directions.
    misses : float
        Share of the directions that see a plane (below) that may expose a
        cell sliced by it.
    grazing : float
        A direction sees a plane of normal n when ``|d . n| >=`` this: under
        it, the plane's polygons are seen nearly edge-on and cover almost
        nothing in that view.
    """

    cells: np.ndarray
    exposure: np.ndarray
    directions: np.ndarray
    misses: float
    grazing: float = 0.0

    def allowed(self, normal: np.ndarray) -> np.ndarray:
        """``(m,) bool``: the cells that at most ``misses`` of the directions that see a
        plane of unit ``normal`` expose (counted once per distinct exposure row)."""
        seen = np.abs(self.directions @ np.asarray(normal, np.float64)) >= self.grazing
        rows, which = self._distinct_rows
        return (exposed_count(rows, seen) <= np.floor(self.misses * int(seen.sum())))[which]

    @cached_property
    def _distinct_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """The distinct rows of :attr:`exposure` and each cell's row: neighbouring cells
        of a fill are mostly hidden from the same directions (the built-in house at 64^3:
        8,268 distinct rows among 95,860 cells)."""
        bits = np.asarray(self.exposure)
        if len(bits) == 0:
            return bits, np.zeros(0, np.int64)
        order = np.lexsort(bits.T[::-1])  # rows sorted by their bytes (numpy.unique's
        ordered = bits[order]             # axis=0 sort is ten times slower)
        starts = np.concatenate([[True], np.any(ordered[1:] != ordered[:-1], axis=1)])
        which = np.empty(len(bits), np.int64)
        which[order] = np.cumsum(starts) - 1
        return ordered[starts], which


@dataclass(frozen=True)
class Slice:
    """One slicing plane in the frame of its direction.

    Attributes
    ----------
    direction : (3,) float64
        Unit plane normal f; (f, right, up) from :func:`viscore.camera_basis`.
    right, up : (3,) float64
        In-plane axes: image column j, row i run along them.
    corner : (3,) float64
        World point of pixel corner (0, 0) on the plane at depth 0.
    depth : float
        Plane offset along ``direction`` from ``corner``, world units.
    pixel : float
        Pixel side, world units.
    shape : (int, int)
        Rows and columns of the image.
    area : float
        Slice area, world units^2 (covered pixels x pixel^2).
    bin : (int, int)
        Direction bin and depth bin it represents.
    """

    direction: np.ndarray
    right: np.ndarray
    up: np.ndarray
    corner: np.ndarray
    depth: float
    pixel: float
    shape: tuple
    area: float
    bin: tuple

    def to_world(self, xy: np.ndarray) -> np.ndarray:
        """World points ``(n, 3)`` of image points ``(n, 2)`` (column, row) on the plane."""
        xy = np.asarray(xy, dtype=np.float64)
        return (self.corner + self.depth * self.direction
                + self.pixel * (xy[:, :1] * self.right + xy[:, 1:2] * self.up))


@dataclass(frozen=True, eq=False)
class VoxelBase:
    """What every solid of one mesh at one voxel size starts from.

    Attributes
    ----------
    vox : Voxelization
        :func:`viscore.voxelize` of the mesh (the only step whose cost grows
        with the triangles, with ``closed``).
    closed : bool
        :func:`viscore.voxel.winding.is_closed_oriented` of the mesh.
    """

    vox: Voxelization
    closed: bool


def voxel_base(mesh: trimesh.Trimesh, *, resolution: int | None = None,
               pitch: float | None = None, closed: bool | None = None) -> VoxelBase:
    """The mesh voxelized once at one size (and whether it is closed and oriented), for
    :func:`section_solid` to make any number of solids from (closings, ground fills);
    ``closed`` when the caller knows it already."""
    vox = voxelize(mesh, resolution=resolution, pitch=pitch)
    if closed is None:
        closed = is_closed_oriented(mesh.vertices, mesh.faces)
    return VoxelBase(vox=vox, closed=bool(closed))


def section_solid(mesh: trimesh.Trimesh, *, resolution: int | None = None,
                  pitch: float | None = None, conservative: bool = False,
                  dilate: int = 0, close: int = 0, ground: float | None = None,
                  up: str = "z", ground_misses: float = 0.0,
                  ground_grazing: float = 0.0, base: VoxelBase | None = None) -> SectionSolid:
    """Voxel solid of sec. 4.1, or its conservative (wholly inside, eroded) variant.

    ``dilate`` marks every empty voxel next to a solid one as solid that many
    times (the dilation step of sec. 5). ``close`` (beyond the paper; not with
    ``conservative``) closes openings up to about ``2 close`` voxels wide
    before the flood fill: the surface voxels are dilated ``close`` times,
    the enclosed space filled, and the filled solid eroded as many times
    (a morphological closing, united with the plain solid, so it never
    loses a voxel of it). ``ground`` (beyond the paper; not with
    ``conservative``), the height of a ground plane along ``up``: the voxels
    between it and the highest surface voxel of their column
    (:func:`viscore.level.ground.ground_fill`, the space under a height field or
    inside an open-bottomed building) join the solid where the mesh covers
    them (:func:`viscore.voxel.coverage_hull.exposure`): for each plane normal n,
    from all but ``ground_misses`` of the line directions d that see the
    plane, ``|d . n| >= ground_grazing`` (:class:`GroundFill`,
    :meth:`SectionSolid.solid_along`). Sizes as :func:`viscore.voxelize`, or
    ``base`` (:func:`voxel_base` of the same mesh at that size, made once for
    several solids).
    """
    if base is None:
        base = voxel_base(mesh, resolution=resolution, pitch=pitch)
    vox, closed = base.vox, base.closed
    if conservative:
        interior = vox.solid & ~vox.surface
        inside = inside_voxels_winding(mesh.vertices, mesh.faces, vox.grid, vox.surface,
                                       candidates=None if closed else interior, closed=closed)
        solid = ndimage.binary_erosion(inside, structure=np.ones((3, 3, 3), bool))
    else:
        solid = vox.solid
    if close:
        solid = solid | closed_solid(vox.surface, int(close))
    fill = None
    if ground is not None:
        cells = np.argwhere(ground_fill(vox.surface, vox.grid, up=up, height=ground) & ~solid)
        fill = GroundFill(cells=cells, exposure=_exposure(mesh, vox.grid, cells,
                                                          (up, float(ground))),
                          directions=hull_directions(), misses=float(ground_misses),
                          grazing=float(ground_grazing))
        solid = solid.copy()
        solid[tuple(cells.T)] = True
    if dilate:
        solid = ndimage.binary_dilation(solid, iterations=int(dilate))
    return SectionSolid(solid=np.ascontiguousarray(solid), grid=vox.grid,
                        closed_oriented=bool(closed), surface_voxels=int(vox.surface.sum()),
                        solid_voxels=int(solid.sum()),
                        interior_voxels=int(ndimage.binary_erosion(solid).sum()),
                        footprint_share=ground_share(vox.surface, up), fill=fill)


#: The last ground fills' exposures (:func:`_exposure`): the precision floor tries several
#: grazing thresholds on one voxel size, and the exposure does not depend on them.
_EXPOSED = ContentCache(2)


def _exposure(mesh: trimesh.Trimesh, grid: VoxelGrid, cells: np.ndarray, key: tuple
              ) -> np.ndarray:
    """:func:`viscore.voxel.coverage_hull.exposure` of ``cells``, kept by the content of the mesh,
    the grid, the cells and ``key`` (the fill's axis and height)."""
    parts = (np.asarray(mesh.vertices), np.asarray(mesh.faces), cells,
             tuple(np.asarray(grid.origin).tolist()), grid.pitch, tuple(grid.shape), key)
    return _EXPOSED.get(parts, lambda: exposure(Scene.shared(mesh), grid, cells))


def closed_solid(surface: np.ndarray, steps: int) -> np.ndarray:
    """Solid of the surface voxels with openings up to about ``2 steps`` voxels closed.

    Dilate the surface ``steps`` times (6-neighbourhood), fill the space the
    result encloses (6-connected background, as sec. 4.1's flood fill), erode
    ``steps`` times. The grid is padded first so that the border neither
    clips the dilation nor eats the erosion.

    Examples
    --------
    >>> shell = np.zeros((9, 9, 9), bool); shell[1:8, 1:8, 1:8] = True
    >>> shell[2:7, 2:7, 2:7] = False; shell[4, 4, 1] = False  # a box with a pinhole
    >>> bool(ndimage.binary_fill_holes(shell)[4, 4, 4]), bool(closed_solid(shell, 1)[4, 4, 4])
    (False, True)
    """
    pad = steps + 1
    grown = ndimage.binary_dilation(np.pad(surface, pad), iterations=steps)
    filled = ndimage.binary_fill_holes(grown)
    core = ndimage.binary_erosion(filled, iterations=steps, border_value=0)
    return core[pad:-pad, pad:-pad, pad:-pad]


def slice_directions(direction_bins: int, *, per_bin: int = DIRECTIONS_PER_BIN
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Sampled plane normals on the upper hemisphere and the bin of each.

    Bin centres are ``direction_bins`` Fibonacci points of the hemisphere (a
    plane's normal and its opposite give the same plane); the samples are
    ``direction_bins * per_bin`` Fibonacci points plus the three axes, each
    assigned to its nearest centre.

    Returns
    -------
    directions : (k, 3) float64
    bins : (k,) int64
    """
    centres = directions_fibonacci(2 * direction_bins)[:direction_bins]
    samples = np.concatenate([directions_fibonacci(2 * direction_bins * per_bin)
                              [:direction_bins * per_bin], np.eye(3)])
    bins = np.argmax(np.abs(samples @ centres.T), axis=1)
    return samples, bins


@njit_cached()
def _slice_counts(solid, origin, pitch, base, ex, ey, f, nx, ny, t0, dt, nt):  # pragma: no cover
    """Solid pixel centres per plane: ``(nt,) int64`` for planes t0 + k dt along f.

    Pixel (i, j) centre: base + t f + (j + 0.5) ex + (i + 0.5) ey, with ex and
    ey already scaled by the pixel side.
    """
    sx, sy, sz = solid.shape
    counts = np.zeros(nt, dtype=np.int64)
    inv = 1.0 / pitch
    for k in range(nt):
        t = t0 + k * dt
        c = 0
        for i in range(ny):
            px = (base[0] + t * f[0] + (i + 0.5) * ey[0] + 0.5 * ex[0] - origin[0]) * inv
            py = (base[1] + t * f[1] + (i + 0.5) * ey[1] + 0.5 * ex[1] - origin[1]) * inv
            pz = (base[2] + t * f[2] + (i + 0.5) * ey[2] + 0.5 * ex[2] - origin[2]) * inv
            qx, qy, qz = ex[0] * inv, ex[1] * inv, ex[2] * inv
            for j in range(nx):
                a = int(np.floor(px + j * qx))
                b = int(np.floor(py + j * qy))
                d = int(np.floor(pz + j * qz))
                if 0 <= a < sx and 0 <= b < sy and 0 <= d < sz and solid[a, b, d]:
                    c += 1
        counts[k] = c
    return counts


@njit_cached()
def _slice_pixels(solid, origin, pitch, base, ex, ey, f, nx, ny, t):  # pragma: no cover
    """``(ny, nx) bool``: the solid at the pixel centres of one plane."""
    sx, sy, sz = solid.shape
    out = np.zeros((ny, nx), dtype=np.bool_)
    inv = 1.0 / pitch
    for i in range(ny):
        for j in range(nx):
            p0 = (base[0] + t * f[0] + (i + 0.5) * ey[0] + (j + 0.5) * ex[0] - origin[0]) * inv
            p1 = (base[1] + t * f[1] + (i + 0.5) * ey[1] + (j + 0.5) * ex[1] - origin[1]) * inv
            p2 = (base[2] + t * f[2] + (i + 0.5) * ey[2] + (j + 0.5) * ex[2] - origin[2]) * inv
            a, b, d = int(np.floor(p0)), int(np.floor(p1)), int(np.floor(p2))
            if 0 <= a < sx and 0 <= b < sy and 0 <= d < sz and solid[a, b, d]:
                out[i, j] = True
    return out


def _frame(sec: SectionSolid, direction: np.ndarray):
    """Plane frame of one direction: basis, pixel corner, image shape and depth range."""
    f, r, u = camera_basis(direction)
    lo, hi = sec.solid_box
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    pixel = sec.grid.pitch / PIXELS_PER_VOXEL
    xs, ys, ts = corners @ r, corners @ u, corners @ f
    x0 = xs.min() - _MARGIN * pixel
    y0 = ys.min() - _MARGIN * pixel
    nx = int(np.ceil((xs.max() - x0) / pixel)) + _MARGIN
    ny = int(np.ceil((ys.max() - y0) / pixel)) + _MARGIN
    corner = x0 * r + y0 * u
    return f, r, u, corner, pixel, nx, ny, float(ts.min()), float(ts.max())


def best_slices(sec: SectionSolid, direction_bins: int, depth_bins: int) -> list[Slice]:
    """One slice per (direction bin, depth bin): the sampled plane of maximal area.

    Every sampled direction of a bin (:func:`slice_directions`) is swept in
    depth at :data:`DEPTH_SAMPLES_PER_VOXEL` planes per voxel over the
    solid's extent along it; depth bins split that extent in equal parts.
    Bins whose best slice is empty are left out.
    """
    if not sec.solid.any():
        return []
    directions, dbin = slice_directions(direction_bins)
    best: dict[tuple, tuple] = {}
    origin = sec.grid.origin
    for d, b in zip(directions, dbin, strict=True):
        f, r, u, corner, pixel, nx, ny, tmin, tmax = _frame(sec, d)
        dt = sec.grid.pitch / DEPTH_SAMPLES_PER_VOXEL
        nt = max(1, int(np.ceil((tmax - tmin) / dt)))
        t = tmin + (np.arange(nt) + 0.5) * (tmax - tmin) / nt
        counts = _slice_counts(sec.solid_along(f), origin, sec.grid.pitch, corner, r * pixel,
                               u * pixel, f, nx, ny, t[0], t[1] - t[0] if nt > 1 else 0.0, nt)
        zbin = np.minimum((np.arange(nt) * depth_bins) // nt, depth_bins - 1)
        for z in range(depth_bins):
            sel = np.flatnonzero(zbin == z)
            if len(sel) == 0:
                continue
            k = sel[np.argmax(counts[sel])]
            area = counts[k] * pixel * pixel
            key = (int(b), z)
            if counts[k] > 0 and (key not in best or area > best[key][0]):
                best[key] = (area, Slice(direction=f, right=r, up=u, corner=corner,
                                         depth=float(t[k]), pixel=pixel, shape=(ny, nx),
                                         area=float(area), bin=key))
    return [best[k][1] for k in sorted(best)]


def make_slice(sec: SectionSolid, direction, depth: float | None = None) -> Slice:
    """The slice of normal ``direction`` at ``depth`` (world units along it; default the
    middle of the solid's extent), with its area."""
    f, r, u, corner, pixel, nx, ny, tmin, tmax = _frame(sec, np.asarray(direction, float))
    t = 0.5 * (tmin + tmax) if depth is None else float(depth)
    count = _slice_counts(sec.solid_along(f), sec.grid.origin, sec.grid.pitch, corner,
                          r * pixel, u * pixel, f, nx, ny, t, 0.0, 1)[0]
    return Slice(direction=f, right=r, up=u, corner=corner, depth=t, pixel=pixel,
                 shape=(ny, nx), area=float(count * pixel * pixel), bin=(-1, -1))


def slice_image(sec: SectionSolid, s: Slice) -> np.ndarray:
    """``s.shape`` bool: the solid at the pixel centres of the slice's plane (row i, column j)."""
    ny, nx = s.shape
    return _slice_pixels(sec.solid_along(s.direction), sec.grid.origin, sec.grid.pitch,
                         s.corner, s.right * s.pixel, s.up * s.pixel, s.direction, nx, ny, s.depth)


def solid_key(sec: SectionSolid) -> tuple:
    """What a run's occluder depends on besides the options every run shares: the solid
    on its grid and the ground fill's cells, exposures and thresholds (none when the fill
    adds no voxel)."""
    fill = sec.fill
    parts: list = [sec.solid, np.asarray(sec.grid.origin, np.float64), float(sec.grid.pitch)]
    if fill is not None and len(fill.cells):
        parts += [fill.cells, fill.exposure, fill.directions, fill.misses, fill.grazing]
    return content_key(*parts)
