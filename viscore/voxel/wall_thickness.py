"""Wall thickness of a triangle soup by rays along the inward normals, and voxel sizes from it.

Voxel methods (Leone et al. [1]_, Silvennoinen et al. [2]_) size voxels from the
extent; a wall thinner than two voxels then holds no inner voxel.

References
----------
.. [1] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
   Bursztyn, A. P. M. "Implementing software occlusion culling for real-time
   applications". XVIII Congreso Argentino de Ciencias de la Computacion
   (CACIC 2012), Workshop de Computacion Grafica, Imagenes y Visualizacion,
   2012. http://sedici.unlp.edu.ar/handle/10915/23640
.. [2] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from .._validate import InputError, as_fraction, as_positive, as_positive_int, as_seed, memory_limit
from ..constants import MAX_HITS, MAX_VOXEL_CELLS, RAY_STEP_RELATIVE
from ..ray.embree_scene import Scene
from .winding import is_closed_oriented

__all__ = ["WallThickness", "wall_thickness", "WallVoxelSize", "wall_voxel_size",
           "voxel_size_for_wall", "finest_fitting_pitch", "AUTO_MAX_CELLS", "MIN_WALL_SHARE"]

#: Rays cast by :func:`wall_thickness` by default: the area-weighted quantiles
#: are then within about 1% of area (one standard error at the 10% quantile is
#: sqrt(0.1 * 0.9 / 16384) = 0.23% of the area) at a few milliseconds of tracing.
SAMPLES = 16384

#: The thinnest wall that matters: :func:`wall_voxel_size` sizes the voxels so
#: that the walls above this area-weighted quantile of the wall area (80% of
#: it) hold inside voxels. Thinner walls (trim, frames, bands and decorations
#: under a fifth of the area) are not worth a finer grid: on the built-in
#: buildings the 10% quantile is 0.05-0.07 m of trim where the 20% quantile is
#: the walls proper (0.1-0.15 m), and resolving the trim costs up to 3x the cells.
WALL_QUANTILE = 0.2

#: Share of the bound ``t / (|n|_1 + |n|_inf)`` taken as the voxel size: the
#: bound is strict, the sampled quantile has its Monte-Carlo error, and the
#: surface test widens voxels by 1e-9 of the pitch.
PITCH_MARGIN = 0.9

#: The ray starts this far inside the sampled face (fraction of the bounding-box
#: diagonal; ``RAY_STEP_RELATIVE``), so that it never hits its own face again;
#: the offset is added back to the thickness.
_START_RELATIVE = RAY_STEP_RELATIVE

#: Share of the memory limit :func:`finest_fitting_pitch` plans for: the
#: available memory moves between the choice and the generator's own check
#: (:func:`viscore._validate.check_memory`), which must not then refuse the grid.
FIT_SHARE = 0.95

#: The most grid cells :func:`wall_voxel_size` chooses by default: the grid of
#: ``voxel_sizing="auto"``, the default of aabb-skins and solid-frusta, stays
#: at the cost of seconds per object. Measured (aabb-skins, one core, the
#: built-in buildings uncapped): 2.7M-7.6M cells took 1-3 s, 18.5M 6.7 s,
#: 34M 13.8 s and 67M 24 s, and a level pays it per distinct thin-walled mesh.
#: Past the cap the pitch is the finest under it and one log line says which
#: walls lose their voxels; an explicit voxel size goes finer, up to the memory
#: guard and :data:`viscore.constants.MAX_VOXEL_CELLS`.
AUTO_MAX_CELLS = 16_000_000

#: :func:`wall_voxel_size` keeps the extent-based size when the inward rays find
#: a wall for less than this share of a mesh's area: the mesh is then mostly open
#: sheets (a terrain piece, a mound or ramp open below, a fence), whose inside
#: voxels, if any, come from the flood fill or ray parity and not from walls, so
#: its thinnest walls are a minority of its surface. Measured on truck town
#: (godot-demo-projects): the four objects under it (walls on 18-27% of the
#: area) cost 12-37 s each at the finer grid, 88 of the 97 s of aabb-skins over
#: its 48 meshes; every built-in building and Godot's demo room has walls on
#: 80-100% of its area.
MIN_WALL_SHARE = 0.5

#: Bisection steps of :func:`finest_fitting_pitch` on the logarithm of the pitch
#: (the ratio of the bracket, at most 2048 x 64, is resolved to 1e-12).
_FIT_STEPS = 64


@dataclass(frozen=True, eq=False)
class WallThickness:
    """Wall thickness at points sampled uniformly by area on a mesh's faces.

    Attributes
    ----------
    thickness : (n,) float64
        Distance, world units, from each sample along the inward normal to the
        far side of its wall; ``inf`` where the ray found no wall (escaped with
        material counted: open, single-sided or inverted geometry, or more
        than ``max_hits`` surfaces).
    points : (n, 3) float64
        The samples, world units.
    directions : (n, 3) float64
        The unit inward normals the rays followed.
    faces : (n,) int64
        The triangle of each sample.
    area : float
        Total triangle area, world units^2; each sample stands for
        ``area / n`` of it.
    seed : int
    """

    thickness: np.ndarray
    points: np.ndarray
    directions: np.ndarray
    faces: np.ndarray
    area: float
    seed: int

    @property
    def samples(self) -> int:
        """Number of samples n."""
        return len(self.thickness)

    @property
    def wall_share(self) -> float:
        """Share of the area whose inward ray found a wall (0 for no sample)."""
        return float(np.isfinite(self.thickness).mean()) if self.samples else 0.0

    def quantile(self, q: float) -> float:
        """Area-weighted quantile ``q`` of the thickness over the wall area (``inf``: no wall).

        Examples
        --------
        >>> shell = trimesh.util.concatenate([trimesh.creation.box(extents=(2, 2, 2)),
        ...                                   trimesh.creation.box(extents=(1.8, 1.8, 1.8))])
        >>> shell.faces[12:] = shell.faces[12:, ::-1]  # inner box inverted: walls 0.1 thick
        >>> round(wall_thickness(shell, samples=1000).quantile(0.5), 6)
        0.1
        """
        q = as_fraction(q, "q")
        walls = self.thickness[np.isfinite(self.thickness)]
        return float(np.quantile(walls, q)) if len(walls) else float("inf")

    def resolving_pitch(self, block: int = 1) -> np.ndarray:
        """``(n,) float64``: per sample, the voxel size below which its wall holds a voxel
        (or a ``block`` x ``block`` x ``block`` cube of voxels).

        ``t / (block |n|_1 + |n|_inf)`` of the module docstring, ``inf`` where no wall.
        """
        block = as_positive_int(block, "block")
        d = np.abs(self.directions)
        return self.thickness / (block * d.sum(axis=1) + d.max(axis=1, initial=0.0))


def wall_thickness(mesh: trimesh.Trimesh, *, samples: int = SAMPLES, seed: int = 0,
                   max_hits: int = MAX_HITS, scene: Scene | None = None) -> WallThickness:
    """Wall thickness distribution by rays from face samples along the inward normal.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Any triangle soup. Outward normals are taken by the right-hand rule;
        a closed, consistently oriented mesh of negative volume (inside out)
        is measured with its normals flipped.
    samples : int, optional
        Points sampled uniformly by area (default :data:`SAMPLES`).
    seed : int, optional
        Seed of the sampling (default 0).
    max_hits : int, optional
        Surfaces a ray walks through at most (default
        :data:`viscore.constants.MAX_HITS`); a ray that needs more found no wall.
    scene : Scene, optional
        The mesh's Embree scene, when the caller has it built already.

    Returns
    -------
    WallThickness
        Per sample the thickness (``inf``: no wall); area-weighted quantiles
        by :meth:`WallThickness.quantile`.

    Raises
    ------
    InputError
        If ``mesh`` is empty or has no area, or on a bad option.

    Notes
    -----
    Deterministic given ``seed``. What is measured is the distance along the
    sample's normal: equal to the wall's thickness where its two sides are
    parallel, larger on a wedge. Samples on a thick solid measure the solid's
    width along the normal. Two surfaces closer than
    ``RAY_STEP_RELATIVE`` x diagonal (1e-6 of it) count as one: a wall
    thinner than that (coincident, double-sided faces) measures as the next
    wall behind it or as none. Geometry whose orientation is not consistent
    gives meaningless counts where it is flipped; rays through a hole of an
    open mesh can take a room for a wall (nothing tells a room of outward
    single-sided walls from a solid with a hole).

    Examples
    --------
    >>> wt = wall_thickness(trimesh.creation.box(extents=(1, 2, 4)), samples=2000)
    >>> round(wt.quantile(0.0), 6), round(wt.quantile(1.0), 6), wt.wall_share
    (1.0, 4.0, 1.0)
    >>> plane = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> wall_thickness(plane, samples=10).wall_share  # single-sided sheet: no wall
    0.0
    """
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError("mesh: expected a non-empty trimesh.Trimesh")
    samples = as_positive_int(samples, "samples")
    seed = as_seed(seed)
    max_hits = as_positive_int(max_hits, "max_hits")
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    tri = v[f]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    double_area = np.linalg.norm(cross, axis=1)
    total = float(double_area.sum())
    if not total > 0:
        raise InputError("mesh: its triangles have no area, so no wall to measure")
    if scene is None:
        scene = Scene(mesh)
    # an inside-out closed mesh: its right-hand normals point inwards
    signed_volume = float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum())
    outward = -1.0 if signed_volume < 0 and is_closed_oriented(v, f) else 1.0

    rng = np.random.default_rng(seed)
    face = rng.choice(len(f), size=samples, p=double_area / total)
    r = rng.random((samples, 2))
    flip = r.sum(axis=1) > 1  # fold the unit square onto the triangle
    r[flip] = 1.0 - r[flip]
    t3 = tri[face]
    points = t3[:, 0] + r[:, :1] * (t3[:, 1] - t3[:, 0]) + r[:, 1:] * (t3[:, 2] - t3[:, 0])
    normal = cross / np.where(double_area > 0, double_area, 1.0)[:, None]  # unit, per face
    inward = -outward * normal[face]

    start = _START_RELATIVE * scene.diagonal
    thickness = np.full(samples, np.inf)
    depth = np.ones(samples, dtype=np.int64)  # material counted along each live ray
    travelled = np.full(samples, start)
    live = np.arange(samples)
    for _ in range(max_hits):  # one surface per step, bounded
        if len(live) == 0:
            break
        t, hit_tri = scene.first_hit(points[live] + inward[live] * travelled[live, None],
                                     inward[live])
        hit = hit_tri >= 0
        live, t, hit_tri = live[hit], t[hit], hit_tri[hit]  # misses escape: no wall
        along = np.einsum("ij,ij->i", outward * normal[hit_tri], inward[live])
        depth[live] -= np.sign(along).astype(np.int64)  # leaving: -1, entering: +1
        at = travelled[live] + t
        closed = depth[live] <= 0
        thickness[live[closed]] = at[closed]
        live, at = live[~closed], at[~closed]
        travelled[live] = at + start
    return WallThickness(thickness=thickness, points=points, directions=inward, faces=face,
                         area=0.5 * total, seed=seed)


def voxel_size_for_wall(thickness: float, normal=(1.0, 0.0, 0.0), block: int = 1) -> float:
    """Largest voxel side (open bound) at which a wall surely holds an inside voxel.

    ``t / (|n|_1 + |n|_inf)``, see the module docstring: ``t / 2`` along the
    axes, ``t / sqrt(6)`` at worst; ``t / (k |n|_1 + |n|_inf)`` for a
    ``k x k x k`` block of inside voxels.

    Parameters
    ----------
    thickness : float
        Wall thickness, world units (> 0).
    normal : (3,) float, optional
        The wall's normal (normalised here). Default +X.
    block : int, optional
        Side ``k`` of the cube of inside voxels the wall must hold (default 1).

    Returns
    -------
    float
        World units.

    Raises
    ------
    InputError
        On a non-positive thickness or a zero normal.

    Examples
    --------
    >>> voxel_size_for_wall(0.05)
    0.025
    >>> round(voxel_size_for_wall(1.0, (2, 1, 1)), 4)  # the worst direction: 1 / sqrt(6)
    0.4082
    """
    thickness = as_positive(thickness, "thickness")
    n = np.asarray(normal, dtype=np.float64).reshape(-1)
    length = float(np.linalg.norm(n)) if n.shape == (3,) else 0.0
    if not (np.isfinite(length) and length > 0):
        raise InputError(f"normal: expected a non-zero 3-vector, got {normal!r}")
    a = np.abs(n) / length
    return thickness / float(as_positive_int(block, "block") * a.sum() + a.max())


def _grid_cells(extent: np.ndarray, pitch: float) -> float:
    """Cells of :func:`viscore.voxel_grid` at this pitch (padding and the extra layer)."""
    from .grid import _PADDING

    with np.errstate(over="ignore", divide="ignore"):
        counts = np.maximum(1.0, np.ceil(extent / pitch - 1e-9)) + 1 + 2 * _PADDING
    return float(np.prod(counts))


def finest_fitting_pitch(bounds, *, bytes_per_cell: float, max_resolution: int | None = None,
                         coarsest: float | None = None, max_cells: float | None = None) -> float:
    """Smallest voxel side whose grid over ``bounds`` fits the memory guard.

    Parameters
    ----------
    bounds : (2, 3) float
        The mesh's bounding box, world units.
    bytes_per_cell : float
        Peak working memory per grid cell of the computation (> 0).
    max_resolution : int, optional
        Also at most this many voxels along the longest side. Default: no cap.
    coarsest : float, optional
        Search no coarser than this (world units). Default: the longest side
        over 1.
    max_cells : float, optional
        Also at most this many grid cells. Default: no cap beyond
        :data:`viscore.constants.MAX_VOXEL_CELLS`.

    Returns
    -------
    float
        World units: a grid at this pitch has at most
        :data:`viscore.constants.MAX_VOXEL_CELLS` cells (and ``max_cells``), needs
        at most :data:`FIT_SHARE` x :func:`viscore._validate.memory_limit` bytes;
        within 1e-12 of the smallest such pitch (bisection on its logarithm). ``coarsest`` when
        even that does not fit.

    Raises
    ------
    InputError
        On bad bounds or options.

    Examples
    --------
    >>> p = finest_fitting_pitch([[0, 0, 0], [1, 1, 1]], bytes_per_cell=1,
    ...                          max_resolution=100)
    >>> round(p, 6)  # the memory of a 1-byte 100^3 grid fits: the resolution caps it
    0.01
    """
    bounds = np.asarray(bounds, dtype=np.float64)
    if bounds.shape != (2, 3) or not np.isfinite(bounds).all():
        raise InputError(f"bounds: expected finite (2, 3) corners, got shape {bounds.shape}")
    extent = bounds[1] - bounds[0]
    longest = float(extent.max())
    if not longest > 0:
        raise InputError("bounds: zero extent, cannot voxelize")
    bytes_per_cell = as_positive(bytes_per_cell, "bytes_per_cell")
    high = longest if coarsest is None else as_positive(coarsest, "coarsest")
    low = longest / (MAX_VOXEL_CELLS ** (1 / 3) * 4)  # well past any grid that fits
    if max_resolution is not None:
        low = max(low, longest / as_positive_int(max_resolution, "max_resolution"))
    cells_limit = min(float(MAX_VOXEL_CELLS), FIT_SHARE * memory_limit() / bytes_per_cell)
    if max_cells is not None:
        cells_limit = min(cells_limit, float(as_positive(max_cells, "max_cells")))

    def fits(p: float) -> bool:
        return _grid_cells(extent, p) <= cells_limit

    if low >= high or not fits(high):
        return high
    if fits(low):
        return low
    lo, hi = np.log(low), np.log(high)  # fits(exp(hi)), not fits(exp(lo))
    for _ in range(_FIT_STEPS):  # halves the bracket each step
        mid = 0.5 * (lo + hi)
        if fits(float(np.exp(mid))):
            hi = mid
        else:
            lo = mid
    return float(np.exp(hi))


@dataclass(frozen=True)
class WallVoxelSize:
    """The voxel size chosen from a mesh's walls, and why.

    Attributes
    ----------
    pitch : float
        The chosen voxel side, world units.
    extent_pitch : float
        The extent-based size: longest bounding-box side / resolution.
    wall_pitch : float
        The size the walls ask for: :data:`PITCH_MARGIN` x the
        ``quantile`` (area-weighted, over the wall area) of
        :meth:`WallThickness.resolving_pitch`; ``inf`` when no wall was found.
    fitting_pitch : float
        The finest size whose grid fits the memory guard
        (:func:`finest_fitting_pitch`).
    wall_quantile : float
        The ``quantile`` of the wall thickness itself, world units (``inf``: none).
    quantile : float
        The area quantile used.
    wall_share : float
        Share of the area whose inward ray found a wall.
    resolved_share : float
        Share of the wall area whose walls surely hold an inside voxel at ``pitch``.
    limited : bool
        True when the memory guard or the cell cap made ``pitch`` coarser than
        the walls ask.
    capped : bool
        True when it was the cell cap (``max_cells`` of :func:`wall_voxel_size`)
        and not the memory guard's own limits.
    reason : str
        One line: how the size was chosen, and, when ``limited``, which walls
        lose their inside voxels and why.
    """

    pitch: float
    extent_pitch: float
    wall_pitch: float
    fitting_pitch: float
    wall_quantile: float
    quantile: float
    wall_share: float
    resolved_share: float
    limited: bool
    reason: str
    capped: bool = False

    @property
    def info(self) -> dict:
        """The fields a generator records (``info["wall_sizing"]``), JSON-ready: None
        for the ``inf`` of no wall."""
        def finite(x: float) -> float | None:
            return float(x) if np.isfinite(x) else None

        return {"wall_quantile": finite(self.wall_quantile), "wall_pitch": finite(self.wall_pitch),
                "extent_pitch": self.extent_pitch, "wall_share": self.wall_share,
                "resolved_share": self.resolved_share, "limited": self.limited,
                "capped": self.capped}

    @property
    def log_level(self) -> int:
        """Level of the one log line of ``reason``: WARNING when the memory guard cost
        inside voxels (the object gets less occluder, or none), else DEBUG (a detail,
        said per object: the walls got their voxels, or no wall was found, which the
        generators' own warning on open meshes covers)."""
        import logging

        return logging.WARNING if self.limited else logging.DEBUG


def wall_voxel_size(mesh: trimesh.Trimesh, *, bytes_per_cell: float, resolution: int = 64,
                    quantile: float = WALL_QUANTILE, max_resolution: int | None = None,
                    samples: int = SAMPLES, seed: int = 0, what: str = "voxels",
                    walls: WallThickness | None = None,
                    max_cells: float | None = AUTO_MAX_CELLS, block: int = 1,
                    min_wall_share: float = MIN_WALL_SHARE,
                    finer: str | None = None) -> WallVoxelSize:
    """Voxel size from the thinnest wall that matters, capped by the memory guard.

    The size is the extent-based one (longest side / ``resolution``), or
    finer where the walls ask for it: :data:`PITCH_MARGIN` x the
    area-weighted ``quantile`` of the per-sample bound
    ``t / (|n|_1 + |n|_inf)`` (module docstring), so that the walls above
    that quantile hold inside voxels wherever the grid falls. When that
    grid would not fit (:func:`finest_fitting_pitch`: the memory limit,
    :data:`viscore.constants.MAX_VOXEL_CELLS`, ``max_resolution``,
    ``max_cells``), the finest size that fits is taken instead and ``reason``
    says how much of the wall area then holds no voxel. A mesh whose walls
    bound less than ``min_wall_share`` of its area (mostly open sheets) keeps
    the extent-based size.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    bytes_per_cell : float
        Peak working memory per grid cell of the voxel method.
    resolution : int, optional
        Voxels along the longest side of the extent-based size (default 64):
        the coarsest size returned.
    quantile : float, optional
        Area quantile of the walls to resolve, in [0, 1] (default
        :data:`WALL_QUANTILE`).
    max_resolution : int, optional
        At most this many voxels along the longest side. Default: no cap.
    samples, seed : int, optional
        Of :func:`wall_thickness` (defaults :data:`SAMPLES`, 0).
    what : str, optional
        Name of the method, at the start of ``reason``.
    walls : WallThickness, optional
        Measured already: used instead of measuring again.
    max_cells : float or None, optional
        At most this many grid cells (default :data:`AUTO_MAX_CELLS`, the
        cost cap of automatic sizing; None: only the memory guard's limits).
    min_wall_share : float, optional
        Keep the extent-based size when the inward rays found a wall for less
        than this share of the area (default :data:`MIN_WALL_SHARE`).
    block : int, optional
        The walls must hold a ``block`` x ``block`` x ``block`` cube of inside
        voxels (default 1; 3 for a solid eroded once by the 3 x 3 x 3 cube):
        the bound ``t / (block |n|_1 + |n|_inf)``.
    finer : str, optional
        The option of ``what`` that sets a finer voxel (``'voxel-size'``,
        ``'voxels'``), named in ``reason`` when the cap of automatic sizing held
        the voxel back. Default: none named. The reason names an option of the
        method, never a command line flag: the method's options are spelled one
        way by ``viscore generate METHOD --help`` and another in ``--methods
        METHOD:option=value`` of ``cull`` and ``occlude``, and the library does not
        know which command prints it.

    Returns
    -------
    WallVoxelSize

    Raises
    ------
    InputError
        On an empty mesh or a bad option.

    Notes
    -----
    Deterministic given ``seed``. The bound is for walls that are large
    compared with the voxel (a slab); along a wall's edges and openings the
    inside voxels stop short of the faces, as everywhere. Nothing is said
    about walls that the rays cannot see (no wall found: open or
    single-sided geometry), which hold no inside voxel at any size.

    Examples
    --------
    >>> shell = trimesh.util.concatenate([trimesh.creation.box(extents=(2, 2, 2)),
    ...                                   trimesh.creation.box(extents=(1.8, 1.8, 1.8))])
    >>> shell.faces[12:] = shell.faces[12:, ::-1]  # walls 0.1 thick: voxels under 0.05
    >>> size = wall_voxel_size(shell, bytes_per_cell=40, resolution=8, samples=1000)
    >>> round(size.pitch, 6), size.extent_pitch, size.limited  # 0.9 x 0.1 / 2
    (0.045, 0.25, False)
    >>> round(wall_voxel_size(shell, bytes_per_cell=40, samples=1000).pitch, 6)  # 2 / 64
    0.03125
    """
    resolution = as_positive_int(resolution, "resolution")
    quantile = as_fraction(quantile, "quantile")
    if walls is None:
        walls = wall_thickness(mesh, samples=samples, seed=seed)
    bounds = np.asarray(mesh.bounds, dtype=np.float64)
    extent_pitch = float((bounds[1] - bounds[0]).max()) / resolution
    need = walls.resolving_pitch(block)
    finite = need[np.isfinite(need)]
    wall_pitch = PITCH_MARGIN * float(np.quantile(finite, quantile)) if len(finite) else np.inf
    mostly_open = walls.wall_share < min_wall_share
    wanted = extent_pitch if mostly_open else min(extent_pitch, wall_pitch)
    fitting = finest_fitting_pitch(bounds, bytes_per_cell=bytes_per_cell,
                                   max_resolution=max_resolution, coarsest=extent_pitch,
                                   max_cells=max_cells)
    limited = fitting > wanted
    capped = limited and max_cells is not None and fitting > finest_fitting_pitch(
        bounds, bytes_per_cell=bytes_per_cell, max_resolution=max_resolution,
        coarsest=extent_pitch)
    pitch = max(wanted, fitting)
    resolved = float((finite > pitch).mean()) if len(finite) else 0.0
    wall_q = walls.quantile(quantile)
    lead = f"{what}: {mesh.metadata.get('name', 'mesh')}"
    if len(finite) and mostly_open:
        reason = (f"{lead}: extent-based voxel {extent_pitch:.4g}; walls bound only "
                  f"{walls.wall_share:.0%} of its area (under {min_wall_share:.0%}: mostly "
                  "open sheets, whose inside voxels come from the fill, not from walls)")
    elif not len(finite):
        reason = (f"{lead}: no wall found (the inward rays of all the area escape: open or "
                  f"single-sided geometry), so the extent-based voxel {extent_pitch:.4g}")
    elif limited:
        hint = "" if finer is None or not capped else f"; the {what} option {finer} goes finer"
        bound = f"automatic sizing's cap of {max_cells:,.0f} cells" if capped else "memory guard"
        reason = (f"{lead}: its walls of {wall_q:.4g} (the {quantile:.0%} area quantile) "
                  f"need voxels under {wall_pitch:.4g}, but the finest grid within the "
                  f"{bound} has voxels of {pitch:.4g}: {1 - resolved:.0%} of the wall "
                  f"area is too thin to surely hold an inside voxel (where the grid falls "
                  f"decides) and may get no occluder{hint}")
    elif wall_pitch < extent_pitch:
        reason = (f"{lead}: voxel {pitch:.4g} (extent-based {extent_pitch:.4g}) for its walls "
                  f"of {wall_q:.4g} (the {quantile:.0%} area quantile); {resolved:.0%} of "
                  "the wall area holds inside voxels")
    else:
        reason = (f"{lead}: extent-based voxel {pitch:.4g}; its walls ({wall_q:.4g} at the "
                  f"{quantile:.0%} area quantile) are thick enough")
    return WallVoxelSize(pitch=float(pitch), extent_pitch=extent_pitch,
                         wall_pitch=float(wall_pitch), fitting_pitch=float(fitting),
                         wall_quantile=float(wall_q), quantile=quantile,
                         wall_share=walls.wall_share, resolved_share=resolved,
                         limited=bool(limited), reason=reason, capped=bool(capped))
