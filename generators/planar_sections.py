"""``planar-sections``: occluders made of planar slices of the voxelized mesh.

The method of Silvennoinen et al. 2014 [1]_, sec. 4, on the ray-cast core
instead of a GPU, one module per step:

- 4.1 voxel solid (:func:`viscore.voxelize`: exact triangle/box overlap,
  flood fill of the outside) and 4.2 interior sampling, maximal-area slice
  per bin of directions and depths: :mod:`._section_slices`;
- 4.3 edge loops along pixel boundaries, holes bridged, Ramer-Douglas-Peucker
  with the voxel size as tolerance: :mod:`._section_loops`;
- 4.4 progressive simplification chain per polygon (smallest ear first,
  nested stages, each triangulated): :mod:`._section_simplify`;
- 4.5 greedy alpha-complete selection maximizing the total occlusion
  measure of the polygon soup (sec. 3), then the budget cut one triangle at
  a time: :mod:`._section_select`.

Where the defaults depart from the paper (each with a switch back): the
chains' stages of at most 12 triangles are the largest polygons on the
candidate's vertices inside the candidate, found exactly
(:mod:`._section_optimal`; ``chain='greedy'`` is the paper's chain), and
the budget cut keeps the cut of largest occlusion measure rather than of
largest surface area (``reduce='area'`` is the paper's rule). On the bunny
(53 triangles, 64^3, 256 views) the paper's chain and cut give R 0.783, the
defaults R 0.837 with 8 direction bins, at P 0.9997 either way.

Beyond the paper: a conservative variant (slices only through voxels wholly
inside the mesh, eroded once more), a screen-space error knob that sets the
voxel size from the error a viewer would see (the paper's premise, sec. 4:
"a voxel resolution appropriate for the allowed Euclidean error"), one
occluder per viewing distance (levels of detail, sec. 4's "multiple
simplified versions"), closing of openings before the flood fill
(``close``) for scans with holes and buildings with open windows, and a
precision floor (``min_precision``): with the default voxel size the
occluder is scored on orbit views of its own, finer voxels are used while
it over-occludes (thin parts), and a solid without an interior, or one that
closing changes much, is also tried closed, keeping the closing of largest
recall that passes the floor.

Measured (orbit protocol, 256 views; ``viscore bench generate
planar-sections``): the bunny at 53 triangles and 64^3, P 0.9998 R 0.844 in
4 s (Table 1: P 0.999, R 0.835); at 64 triangles and 64^3 the fat torus R
0.902, teapot 0.944, fandisk 0.907, and with the defaults (precision floor,
closing) the bunny 0.934, fat torus 0.955, teapot 0.961, fandisk 0.956,
building-house 0.979, sponge 0.959, all at P >= 0.995. The RDP
tolerance is the paper's, one voxel (:data:`RDP_TOLERANCE`); a larger one
trades precision for recall (with the paper's chain and cut, 64 views:
bunny R 0.773 / 0.823 / 0.868 at 1 / 1.5 / 2 voxels, cow P 0.9985 / 0.9966
/ 0.9905, fat torus R 0.869 / 0.826 / 0.778). The voxel size does the same
(Fig. 9; bunny, paper's chain and cut, 256 views): P / R 0.961 / 0.970 at
16 voxels, 0.997 / 0.886 at 32, 0.9998 / 0.776 at 64, 1.0 / 0.713 at 128.
An open sheet (the terrain) or walls with openings wider than a voxel have no
interior to slice: their slices are strips one or two voxels wide.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [2] Jacobson, A., Kavan, L., Sorkine-Hornung, O. "Robust Inside-Outside
   Segmentation using Generalized Winding Numbers". ACM Transactions on
   Graphics 32(4), 2013. :DOI:`10.1145/2461912.2461916`
"""

from __future__ import annotations

import importlib.util
import logging
import math
import numbers
import time

import numpy as np
import trimesh
from viscore.metrics.orbit import orbit_frame

from viscore import InputError, validate_mesh, voxel_grid
from viscore._validate import (
    as_fraction,
    as_positive,
    as_positive_int,
    as_seed,
    check_memory,
)

from . import _section_slices
from ._section_loops import slice_polygons
from ._section_optimal import refine_chain
from ._section_select import (
    MEASURE_DIRECTIONS,
    MEASURE_RESOLUTION,
    measure_directions,
    project_candidates,
    reduce_to_budget,
    select_greedy,
)
from ._section_simplify import simplification_chain
from ._section_slices import best_slices, section_solid, slice_image
from .occluder import Occluder

__all__ = ["generate_planar_sections", "screen_space_voxel_size", "DEFAULT_DIRECTION_BINS",
           "DEFAULT_DEPTH_BINS", "DEFAULT_ALPHA", "DEFAULT_VOXELS", "MAX_VOXELS"]

_log = logging.getLogger(__name__)

#: Voxels along the longest bounding-box side when neither ``voxels``, ``voxel_size``
#: nor ``pixel_error`` is given (the paper's comparison setting, sec. 6.3: 64^3).
DEFAULT_VOXELS = 64

#: Largest voxel count along the longest side (the memory check refuses most grids below).
MAX_VOXELS = 1024

#: Direction bins over the hemisphere of plane normals and depth bins per direction
#: (sec. 4.2). Sweep with the default chains and budget cut
#: (:func:`viscore.cli.bench_planar.bins_sweep` per mesh, ``views=128``), orbit protocol,
#: mean recall over the bunny (53 triangles), fat torus, cow, bone, spot, fandisk,
#: rocker arm and Suzanne (64 triangles), 64^3: 8 x 2: 0.826, 8 x 4: 0.844, 8 x 6: 0.843,
#: 12 x 4: 0.834, 16 x 2: 0.832, 16 x 4: 0.856, 16 x 6: 0.830, 24 x 4: 0.849, 24 x 6:
#: 0.839 (2.6-4.7 s each). Single meshes swing by +-0.03 between neighbouring settings
#: (the greedy search's discrete choices), so the choice rests on the mean: 16 x 4.
DEFAULT_DIRECTION_BINS = 16
DEFAULT_DEPTH_BINS = 4

#: Ramer-Douglas-Peucker tolerance, voxels (sec. 4.3: "match the voxel resolution").
RDP_TOLERANCE = 1.0

#: Alpha-completeness of the greedy search, percent (sec. 4.5).
DEFAULT_ALPHA = 1.0

#: Candidate polygons kept for the greedy search, largest first (its cost grows
#: with their number; a tangle such as the hairball gives thousands of small ones).
MAX_CANDIDATES = 160

#: Bytes per voxel cell of the whole generation: the voxelization's working
#: memory (:data:`viscore.voxels.VOXELIZE_BYTES_PER_CELL`, 24) and the solid,
#: its erosion and the winding-number labels of the conservative variant.
BYTES_PER_CELL = 40

#: Precision floor of the default sizing (``min_precision``): the precision the occluder
#: must reach on :data:`FLOOR_VIEWS` orbit views of the mesh before the voxels are refined.
DEFAULT_MIN_PRECISION = 0.995

#: Orbit views of the precision floor's check (the metric's own resolution and quads),
#: drawn with a seed of their own (:data:`FLOOR_SEED_OFFSET` added to the generator's).
#: The standard error takes the views as the units: over-occlusion through the openings
#: of a building comes from a few views, and 32 views read the closed tower at P 0.9963
#: +- 0.0013 where 128 views of three other seeds read 0.990-0.992.
FLOOR_VIEWS = 64
FLOOR_SEED_OFFSET = 7919

#: The check passes when the one-sided 95% lower bound of the precision, ``P - 1.645
#: SE``, is at or over the floor.
FLOOR_Z = 1.645

#: A voxel solid has "no interior" when it has fewer than :data:`INTERIOR_SHARE` times
#: its surface voxels (an open sheet, or a shell with openings wider than a voxel) and
#: under :data:`ERODED_SHARE` of it survives a one-voxel erosion (at 64^3: bunny 0.86,
#: airplane 0.49, a dense tangle of strands whose surface voxels fill the ball 0.71; the
#: open-bottomed buildings 0.03-0.25, terrain 0.03).
INTERIOR_SHARE = 1.1
ERODED_SHARE = 0.5

#: Closings tried (beside none) when the voxel solid has no interior and ``close`` is left
#: to its default with the precision floor on: at 64 triangles and 64^3 (orbit, 64 views,
#: precision / recall), close 0 / 2 / 3 / 4 gives the apartment 0.9998 / 0.657, 0.9985 /
#: 0.904, 0.9963 / 0.960, 0.9963 / 0.963; the shop 0.9961 / 0.830, ..., 0.9966 / 0.971 at
#: 4; the cottage 0.9993 / 0.696 to 0.9990 / 0.850 at 4; but the tower 0.9975 / 0.334 to
#: 0.9895 / 0.968 at 3 (under the floor), and the warehouse, church and L-shaped house
#: gain nothing.
AUTO_CLOSINGS = (2, 3, 4)

#: The closings are also tried when the largest one adds at least this share of voxels to
#: a solid that has an interior (at 64^3: the sponge's tunnels 0.37, the hollow box with a
#: hole 2.1, the house 1.4; the bunny 0.016, cow 0.032, fat torus 0.002, rocker arm 0.064,
#: teapot 0.039, airplane 0.045). The sponge at 64 triangles goes from R 0.076 to 0.91
#: closed by 3 (P 0.9999): its tunnels hide what lies behind them from most views.
AUTO_CLOSE_GAIN = 0.1

#: Each refinement of the precision floor multiplies the voxels by this, at most
#: :data:`FLOOR_MAX_STEPS` times (64 -> 91 -> 128 from the default).
FLOOR_STEP = math.sqrt(2.0)
FLOOR_MAX_STEPS = 2

#: With the default voxel size and precision to spare, the voxels are also coarsened by
#: :data:`FLOOR_STEP` (64 -> 45 -> 32, never under :data:`FLOOR_MIN_VOXELS`) while the
#: check passes: at a fixed budget, coarser voxels over-occlude more but slice wider
#: (Fig. 9). At 64 triangles (orbit, 128 views, no closing) 64 / 45 / 32 voxels give the
#: bunny P 0.9997 / 0.9988 / 0.9956 and R 0.865 / 0.887 / 0.935, the fat torus R 0.902 /
#: 0.959 / 0.949, the rocker arm R 0.798 / 0.828 (P 0.9963) / 0.923 (P 0.9865).
FLOOR_COARSER_STEPS = 2
FLOOR_MIN_VOXELS = 16

#: Field of view (degrees) and screen width (pixels) of the screen-space knob's defaults.
DEFAULT_FOV = 60.0
DEFAULT_SCREEN = 1920

_MEASURES = ("om", "area")
_REDUCTIONS = ("area", "projected-area", "om")
_CHAINS = ("optimal", "greedy")


def _no_interior(info: dict) -> bool:
    """Whether the voxel solid described by ``info`` has (almost) no interior."""
    return (info["solid_voxels"] < INTERIOR_SHARE * info["surface_voxels"]
            and info["interior_voxels"] < ERODED_SHARE * info["solid_voxels"])


def screen_space_voxel_size(pixel_error: float, distance: float, *, fov: float = DEFAULT_FOV,
                            screen: int = DEFAULT_SCREEN) -> float:
    """World size of ``pixel_error`` pixels at ``distance`` in a perspective view.

    One pixel of a ``screen``-pixel-wide image with a horizontal field of view
    ``fov`` spans ``2 distance tan(fov / 2) / screen`` world units at
    ``distance``; the voxel size is ``pixel_error`` of them, so that the
    voxelization's error (at most one voxel, sec. 4.1) shows as at most
    ``pixel_error`` pixels to a viewer that far away.

    Examples
    --------
    >>> round(screen_space_voxel_size(1.0, 100.0, fov=90.0, screen=200), 6)
    1.0
    """
    pixel_error = as_positive(pixel_error, "pixel_error")
    distance = as_positive(distance, "distance")
    fov = _as_fov(fov)
    screen = as_positive_int(screen, "screen")
    return pixel_error * 2.0 * distance * math.tan(math.radians(fov) / 2.0) / screen


def _as_fov(fov: object) -> float:
    if isinstance(fov, bool) or not isinstance(fov, numbers.Real) or not (0 < fov < 180):
        raise InputError(f"fov: expected degrees in (0, 180), got {fov!r}")
    return float(fov)


def _as_distances(value: object) -> tuple[float, ...]:
    """``lod_distances`` as a sorted tuple of positive floats (a comma string or numbers)."""
    if isinstance(value, str):
        parts = [p.strip() for p in value.split(",")]
        try:
            items = [float(p) for p in parts]
        except ValueError:
            raise InputError(f"lod_distances: expected comma-separated numbers, got {value!r}"
                             ) from None
    elif isinstance(value, numbers.Real) and not isinstance(value, bool):
        items = [float(value)]
    else:
        try:
            items = [float(v) for v in value]
        except (TypeError, ValueError):
            raise InputError(f"lod_distances: expected numbers, got {value!r:.80}") from None
    if not items or not all(math.isfinite(v) and v > 0 for v in items):
        raise InputError(f"lod_distances: expected positive finite distances, got {value!r:.80}")
    if len(items) > 16:
        raise InputError(f"lod_distances: at most 16 levels, got {len(items)}")
    return tuple(sorted(set(items)))


def _resolution(mesh: trimesh.Trimesh, voxels, voxel_size, what: str) -> dict:
    """``{"resolution": n}`` or ``{"pitch": s}`` after the grid and memory checks."""
    extent = float(np.max(mesh.extents))
    if voxel_size is not None:
        n = math.ceil(extent / voxel_size - 1e-9) if np.isfinite(extent / voxel_size) else math.inf
        if n > MAX_VOXELS:
            raise InputError(f"{what}: a voxel size of {voxel_size:.4g} needs {n:.4g} voxels "
                             f"along the longest side ({extent:.4g}); the limit is {MAX_VOXELS}")
        size = {"pitch": float(voxel_size)}
    else:
        size = {"resolution": int(voxels)}
    grid = voxel_grid(np.asarray(mesh.bounds), **size)
    cells = float(np.prod(np.array(grid.shape, dtype=np.float64)))
    check_memory(cells * BYTES_PER_CELL,
                 f"{what} ({grid.shape[0]} x {grid.shape[1]} x {grid.shape[2]} voxels)")
    return size


def _hierarchy_builder():
    """:func:`viscore.generators.planar_hierarchy.generate_planar_hierarchy`, or None."""
    if importlib.util.find_spec("viscore.generators.planar_hierarchy") is None:
        return None
    from . import planar_hierarchy

    return getattr(planar_hierarchy, "generate_planar_hierarchy", None)


def generate_planar_sections(mesh: trimesh.Trimesh, *, budget: int | None = 64, seed: int = 0,
                             voxels: int | None = None, voxel_size: float | None = None,
                             direction_bins: int = DEFAULT_DIRECTION_BINS,
                             depth_bins: int = DEFAULT_DEPTH_BINS, alpha: float = DEFAULT_ALPHA,
                             measure: str = "om", reduce: str = "om",
                             rdp_tolerance: float = RDP_TOLERANCE, chain: str = "optimal",
                             conservative: bool = False, pixel_error: float | None = None,
                             distance: float | None = None, fov: float = DEFAULT_FOV,
                             screen: int = DEFAULT_SCREEN, lod_distances=None,
                             hierarchy: bool = False, dilate: int = 0,
                             close: int | None = None,
                             min_precision: float | None = None) -> Occluder:
    """Occluder of double-sided planar polygons (Silvennoinen et al. 2014, sec. 4).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Any triangle soup (validated by :func:`viscore.validate_mesh`).
    budget : int or None, optional
        Triangle budget of the occluder (default 64); None keeps the
        polygons the greedy search picks, unsimplified.
    seed : int, optional
        Unused (deterministic); accepted for the common signature.
    voxels : int, optional
        Voxels along the longest bounding-box side, 1 to 1024. Default 64
        when neither ``voxel_size`` nor ``pixel_error`` is given; giving it
        with either is an error.
    voxel_size : float, optional
        Voxel side, world units (direct control, as ``voxels``).
    direction_bins, depth_bins : int, optional
        Bins of plane normals over the hemisphere (1 to 256, default 16) and
        of depths per direction (1 to 64, default 4); one candidate slice
        per bin (sec. 4.2).
    alpha : float, optional
        Alpha-completeness of the greedy search, percent, >= 0 (default 1):
        it stops when the best addition raises the total measure by less.
    measure : {'om', 'area'}, optional
        Selection measure: the total occlusion measure (default) or the
        projected area of the soup (the paper's surface-area comparison,
        Fig. 11).
    reduce : {'area', 'projected-area', 'om'}, optional
        Budget cut, one triangle at a time: keep at each step the cut of
        largest total occlusion measure (``'om'``, default; the steps
        while the cut has over 1.25 times the budget follow the area rule,
        as they remove ears of almost no area), or of largest surface area,
        the sum of its polygons' areas (``'area'``: the paper's rule), or of
        largest projected area over the measure directions
        (``'projected-area'``: sec. 3.1's A(I_{d,0}); overlaps count once).
    rdp_tolerance : float, optional
        Ramer-Douglas-Peucker tolerance of the edge loops, voxels, > 0
        (default :data:`RDP_TOLERANCE`; see Notes).
    chain : {'optimal', 'greedy'}, optional
        Simplification chains (sec. 4.4): ``'greedy'``, the paper's greedy
        smallest-ear collapse throughout; ``'optimal'`` (default), the same
        but its stages of at most 12 triangles replaced by the largest
        polygon on the candidate's vertices inside the candidate
        (:mod:`._section_optimal`; same constraint, not myopic).
    conservative : bool, optional
        Slice only through voxels wholly inside the mesh by the generalized
        winding number [2]_, eroded by one more voxel, and skip RDP (the
        chain only cuts ears): on a closed, consistently oriented mesh no ray
        from outside meets the occluder before the mesh. Default False.
    pixel_error, distance : float, optional
        Screen-space knob: the voxel size is the world size of
        ``pixel_error`` pixels seen from ``distance`` world units
        (:func:`screen_space_voxel_size`). Both together, or with
        ``lod_distances`` instead of ``distance``.
    fov : float, optional
        Field of view of that viewer, degrees in (0, 180). Default 60.
    screen : int, optional
        Its screen width, pixels. Default 1920.
    lod_distances : str or sequence of float, optional
        Levels of detail: one occluder per distance (a comma-separated string
        such as ``"10,40,160"`` or numbers), each with the voxel size of
        ``pixel_error`` at that distance. Needs ``pixel_error``, excludes
        ``distance``.
    hierarchy : bool, optional
        Occluder hierarchy over the scene's objects (sec. 5): delegates to
        :func:`viscore.generators.planar_hierarchy.generate_planar_hierarchy`
        with these options (``mesh`` may then be a list of meshes); the tree
        is in ``parts["hierarchy"]``. Default False.
    dilate : int, optional
        Dilation steps of the voxel solid (sec. 5's gluing step), >= 0.
        Default 0.
    close : int, optional
        Close openings of the surface up to about ``2 close`` voxels wide
        before the flood fill (a morphological closing,
        :func:`._section_slices.closed_solid`; beyond the paper), 0 to 8. For
        scans with holes and buildings with open doors and windows: the
        Stanford bunny scan (open bottom) has no interior at 64^3 and gives
        R 0.001; ``close=3`` gives R 0.83 at P 0.9997 (orbit protocol, 128
        views, 53 triangles). Not with ``conservative``. Default: with the
        precision floor on, 0 when the voxel solid has an interior, else the
        one of 0 and :data:`AUTO_CLOSINGS` of largest check recall among
        those that pass the floor (``info["close"]``, and
        ``info["precision_floor"]["closings"]``); with it off, 0.
    min_precision : float, optional
        Precision floor in [0, 1] (beyond the paper): the occluder is scored
        on :data:`FLOOR_VIEWS` orbit views of the mesh (their own seed, not
        the views of a study). While the one-sided 95% lower bound of its
        precision is under the floor the voxels are refined by sqrt(2), at
        most :data:`FLOOR_MAX_STEPS` times; with the default voxel size and
        the bound at or over the floor they are coarsened by sqrt(2) while it
        holds, at most :data:`FLOOR_COARSER_STEPS` times. Of the resolutions
        that pass, the one of largest check recall is kept, else the most
        precise one (with a warning). Finer voxels over-occlude less but
        slice thinner (Fig. 9): airplane at 64 triangles P 0.970 R 0.973 at
        64^3, 0.998 / 0.874 at 128^3; bunny 0.9997 / 0.865 at 64^3, 0.9956
        / 0.935 at 32^3. Default: :data:`DEFAULT_MIN_PRECISION` when the
        voxel size is the default (no ``voxels``, ``voxel_size`` or
        ``pixel_error``) and not ``conservative`` nor levels of detail, else
        off; 0 turns it off; a value given with an explicit size starts the
        refinement there (and never coarsens).

    Returns
    -------
    Occluder
        ``double_sided=True``; ``parts["polygons"]``: the kept polygons as
        world loops (holes bridged); with ``lod_distances``, ``parts["lods"]``:
        one ``{"distance", "mesh", "voxels", "voxel_size", "triangles"}`` per
        distance, nearest first, and the occluder's own mesh is the nearest.
        ``info``: ``triangles_single_sided`` (twice the triangles: both faces
        when back faces are culled), ``voxel_size``, ``voxels``, ``grid``,
        ``direction_bins``, ``depth_bins``, ``slices``, ``candidates``,
        ``greedy_polygons``, ``polygons``, ``solid_voxels``, ``interior_voxels``,
        ``closed_oriented``, ``conservative_guaranteed``, ``seconds_steps``,
        ``close`` (the closing used); with a precision floor,
        ``precision_floor``: ``floor``, ``views``, ``seed``, ``met`` and
        ``steps`` (per resolution tried: ``voxels``,
        ``close``, ``triangles``, ``precision``, ``precision_se``, ``recall``,
        ``seconds``); with the default ``close``, ``close_gain`` (the share of
        voxels the largest closing adds) and, when closings were tried,
        ``closings`` (one step each).

    Raises
    ------
    InputError
        On a bad or conflicting parameter, an empty mesh, or a voxel grid
        over the limits (the message gives the estimate); before any work.

    Notes
    -----
    Deterministic. The occluder may end under the budget (the greedy search
    stops at alpha-completeness) and over-occludes by up to about a voxel
    (the voxelization's error, sec. 4.1) unless ``conservative``.
    ``conservative_guaranteed`` is True only for ``conservative=True`` on a
    closed, consistently oriented mesh.

    References
    ----------
    .. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
       Simplification using Planar Sections". Computer Graphics Forum 33(1),
       2014, pp. 235-245. :DOI:`10.1111/cgf.12271`
    .. [2] Jacobson, A., Kavan, L., Sorkine-Hornung, O. "Robust Inside-Outside
       Segmentation using Generalized Winding Numbers". ACM Transactions on
       Graphics 32(4), 2013. :DOI:`10.1145/2461912.2461916`

    Examples
    --------
    >>> occ = generate_planar_sections(trimesh.creation.box(extents=(2, 2, 2)), budget=4,
    ...                                voxels=16, direction_bins=4, depth_bins=1)
    >>> occ.double_sided, occ.triangles <= 4
    (True, True)
    >>> occ.info["triangles_single_sided"] == 2 * occ.triangles
    True
    """
    start = time.perf_counter()
    if not isinstance(mesh, trimesh.Trimesh) and not hierarchy:
        raise InputError("mesh: expected a trimesh.Trimesh")
    budget = None if budget is None else as_positive_int(budget, "budget")
    seed = as_seed(seed)
    direction_bins = as_positive_int(direction_bins, "direction_bins", maximum=256)
    depth_bins = as_positive_int(depth_bins, "depth_bins", maximum=64)
    if isinstance(alpha, bool) or not isinstance(alpha, numbers.Real) or not (
            math.isfinite(alpha) and alpha >= 0):
        raise InputError(f"alpha: expected a percentage >= 0, got {alpha!r}")
    alpha = float(alpha)
    if measure not in _MEASURES:
        raise InputError(f"measure: expected 'om' or 'area', got {measure!r}")
    rdp_tolerance = as_positive(rdp_tolerance, "rdp_tolerance")
    if chain not in _CHAINS:
        raise InputError(f"chain: expected 'optimal' or 'greedy', got {chain!r}")
    if reduce not in _REDUCTIONS:
        raise InputError(f"reduce: expected one of {', '.join(_REDUCTIONS)}, got {reduce!r}")
    for name, flag in (("conservative", conservative), ("hierarchy", hierarchy)):
        if not isinstance(flag, (bool, np.bool_)):
            raise InputError(f"{name}: expected True or False, got {flag!r}")
    if isinstance(dilate, bool) or not isinstance(dilate, numbers.Integral) or not (
            0 <= dilate <= 8):
        raise InputError(f"dilate: expected an integer from 0 to 8, got {dilate!r}")
    if close is not None and (isinstance(close, bool) or not isinstance(
            close, numbers.Integral) or not 0 <= close <= 8):
        raise InputError(f"close: expected an integer from 0 to 8, got {close!r}")
    if close and conservative:
        raise InputError("close: not with conservative (closing adds voxels outside the mesh)")
    fov = _as_fov(fov)
    screen = as_positive_int(screen, "screen")
    if voxels is not None:
        voxels = as_positive_int(voxels, "voxels", maximum=MAX_VOXELS)
    if voxel_size is not None:
        voxel_size = as_positive(voxel_size, "voxel_size")
    if pixel_error is not None:
        pixel_error = as_positive(pixel_error, "pixel_error")
    if distance is not None:
        distance = as_positive(distance, "distance")
    distances = None if lod_distances is None else _as_distances(lod_distances)
    given = [n for n, v in (("voxels", voxels), ("voxel_size", voxel_size),
                            ("pixel_error", pixel_error)) if v is not None]
    if len(given) > 1:
        raise InputError(f"{' and '.join(given)}: give one way of sizing the voxels")
    if pixel_error is None and (distance is not None or distances is not None):
        raise InputError("distance, lod_distances: need pixel_error (the allowed error in "
                         "pixels)")
    if pixel_error is not None and distance is None and distances is None:
        raise InputError("pixel_error: needs distance (or lod_distances)")
    if distance is not None and distances is not None:
        raise InputError("distance and lod_distances: give one (lod_distances replaces "
                         "distance)")
    if min_precision is not None:
        min_precision = as_fraction(min_precision, "min_precision")
        if distances is not None and min_precision > 0:
            raise InputError("min_precision: not with lod_distances (each level's voxel size "
                             "is set by its distance)")
    if hierarchy:
        build = _hierarchy_builder()
        if build is None:
            raise InputError("hierarchy: not available yet (planar_hierarchy is not installed)")
    params = {"budget": budget, "seed": seed, "voxels": voxels, "voxel_size": voxel_size,
              "direction_bins": direction_bins, "depth_bins": depth_bins, "alpha": alpha,
              "measure": measure, "reduce": reduce, "rdp_tolerance": rdp_tolerance,
              "chain": chain, "conservative": bool(conservative),
              "pixel_error": pixel_error, "distance": distance, "fov": fov, "screen": screen,
              "lod_distances": None if distances is None else list(distances),
              "hierarchy": bool(hierarchy), "dilate": int(dilate),
              "close": None if close is None else int(close), "min_precision": min_precision}
    if hierarchy:  # sec. 5: a BVH over the objects, this generator at every node
        return build(mesh, **{k: v for k, v in params.items() if k != "hierarchy"})
    mesh = validate_mesh(mesh)

    options = dict(budget=budget, direction_bins=direction_bins, depth_bins=depth_bins,
                   alpha=alpha, measure=measure, reduce=reduce,
                   rdp_tolerance=rdp_tolerance, chain=chain, conservative=bool(conservative),
                   dilate=int(dilate), close=int(close or 0))
    if distances is None:
        if pixel_error is not None:
            size = _resolution(mesh, None, screen_space_voxel_size(
                pixel_error, distance, fov=fov, screen=screen),
                f"pixel_error={pixel_error:g} at distance={distance:g}")
        elif voxel_size is not None:
            size = _resolution(mesh, None, voxel_size, f"voxel_size={voxel_size:g}")
        else:
            n = DEFAULT_VOXELS if voxels is None else voxels
            size = _resolution(mesh, n, None, f"voxels={n}")
        floor = min_precision
        if floor is None and not given and not conservative:
            floor = DEFAULT_MIN_PRECISION
        params["min_precision"] = floor
        if floor:
            out_mesh, polygons, info = _with_precision_floor(
                mesh, size, floor, seed, options,
                auto_close=close is None and not conservative, coarsen=not given)
        else:
            out_mesh, polygons, info = _generate_one(mesh, size, **options)
        parts = {"polygons": polygons}
    else:
        sizes = [_resolution(mesh, None, screen_space_voxel_size(
            pixel_error, d, fov=fov, screen=screen),
            f"pixel_error={pixel_error:g} at lod distance {d:g}") for d in distances]
        lods = []
        for d, size in zip(distances, sizes, strict=True):
            m, polys, inf = _generate_one(mesh, size, **options)
            lods.append({"distance": d, "mesh": m, "voxels": inf["voxels"],
                         "voxel_size": inf["voxel_size"], "triangles": len(m.faces),
                         "polygons": polys})
            if len(lods) == 1:
                out_mesh, polygons, info = m, polys, inf
        parts = {"polygons": polygons, "lods": lods}
    info = {"close": options["close"], **info,
            "triangles_single_sided": 2 * len(out_mesh.faces)}
    return Occluder(mesh=out_mesh, method="planar-sections", params=params, double_sided=True,
                    seconds=time.perf_counter() - start, parts=parts, info=info)


def _ratio_se(num: np.ndarray, den: np.ndarray) -> float:
    """Standard error of sum(num) / sum(den) with the views as units (the ratio estimator's
    linearization); 0 with fewer than two views."""
    k = len(num)
    if k < 2 or den.sum() <= 0:
        return 0.0
    ratio = num.sum() / den.sum()
    return float(np.sqrt(np.sum((num - ratio * den) ** 2) / (k * (k - 1))) / den.mean())


def _with_precision_floor(mesh: trimesh.Trimesh, size: dict, floor: float, seed: int,
                          options: dict, *, auto_close: bool = False, coarsen: bool = False):
    """:func:`_generate_one`, refined until the occluder's check precision reaches ``floor``.

    The check scores the occluder on :data:`FLOOR_VIEWS` orbit views of the
    mesh (cast once; :class:`viscore.metrics.ReferenceViews`). With
    ``auto_close``, a voxel solid without an interior, or one that closing
    grows by :data:`AUTO_CLOSE_GAIN` or more, is also tried closed by each
    of :data:`AUTO_CLOSINGS`, and the closing of largest check recall among
    those that pass the floor is kept (none if none passes). Then, with
    ``coarsen`` and while the check passes, the voxels are coarsened by
    :data:`FLOOR_STEP` up to :data:`FLOOR_COARSER_STEPS` times, or, when it
    fails, refined by it up to :data:`FLOOR_MAX_STEPS` times; of the
    resolutions that pass, the one of largest check recall is kept. A
    refinement the memory check refuses ends the search (with a warning).
    """
    from viscore.metrics.reference_views import ReferenceViews

    views = ReferenceViews(mesh, protocol="orbit", views=FLOOR_VIEWS,
                           seed=seed + FLOOR_SEED_OFFSET)
    extent = float(np.max(mesh.extents))

    def run(size: dict, close: int):
        t0 = time.perf_counter()
        result = _generate_one(mesh, size, **{**options, "close": close},
                               warn_interior=not auto_close)
        if len(result[0].faces) == 0:  # nothing to over-occlude with
            p, se, r = 1.0, 0.0, 0.0
        else:
            pr = views.score(result[0])
            p, se, r = float(pr.precision), _ratio_se(*pr.ratio_parts("precision")), float(
                pr.recall)
        step = {"voxels": result[2]["voxels"], "close": close,
                "triangles": len(result[0].faces), "precision": p, "precision_se": se,
                "recall": r, "seconds": time.perf_counter() - t0}
        return result, step

    def passes(step: dict) -> bool:
        return step["precision"] - FLOOR_Z * step["precision_se"] >= floor

    close = options["close"]
    result, step = run(size, close)
    steps, results = [step], [result]
    closings = None
    gain = None
    if auto_close:
        solid = result[2]["solid_voxels"]
        closed = section_solid(mesh, dilate=options["dilate"], close=max(AUTO_CLOSINGS),
                               **size).solid_voxels
        gain = closed / solid - 1.0 if solid else math.inf
    if gain is not None and (gain >= AUTO_CLOSE_GAIN or _no_interior(result[2])):
        tried = [(result, step)] + [run(size, k) for k in AUTO_CLOSINGS]
        ok = [t for t in tried if passes(t[1])]
        result, step = max(ok, key=lambda t: t[1]["recall"]) if ok else tried[0]
        close = step["close"]
        closings = [t[1] for t in tried]
        _log.info("planar-sections: closing adds %.0f%% to the voxel solid at %d voxels; "
                  "closings %s give check recall %s at precision %s: close=%d",
                  100 * gain, step["voxels"], [t["close"] for t in closings],
                  [round(t["recall"], 3) for t in closings],
                  [round(t["precision"], 4) for t in closings], close)
        if close == 0 and _no_interior(result[2]):
            _log.warning("planar-sections: the voxel solid has (almost) no interior at %d "
                         "voxels and no closing up to %d passes the precision floor, so the "
                         "slices are thin strips", step["voxels"], max(AUTO_CLOSINGS))
        steps, results = [step], [result]
    if coarsen and passes(steps[-1]):  # spare precision: coarser voxels recall more
        for _ in range(FLOOR_COARSER_STEPS):
            n = steps[-1]["voxels"]
            coarser = int(round(n / FLOOR_STEP))
            if coarser < FLOOR_MIN_VOXELS:
                break
            result, step = run(_resolution(mesh, coarser, None, f"voxels={coarser}"), close)
            steps.append(step)
            results.append(result)
            if not passes(step):
                break
    for _ in range(FLOOR_MAX_STEPS):
        if any(passes(t) for t in steps):
            break
        n = steps[-1]["voxels"]
        finer = max(n + 1, int(round(n * FLOOR_STEP)))
        try:
            size = _resolution(mesh, finer, None, f"voxels={finer}")
        except InputError as exc:
            _log.warning("planar-sections: precision %.4f under the floor %g at %d voxels; "
                         "not refined further: %s", steps[-1]["precision"], floor, n, exc)
            break
        _log.info("planar-sections: precision %.4f under the floor %g at %d voxels "
                  "(%d check views); refining to %d voxels", steps[-1]["precision"], floor, n,
                  FLOOR_VIEWS, finer)
        result, step = run(size, close)
        steps.append(step)
        results.append(result)
    ok = [i for i, t in enumerate(steps) if passes(t)]
    met = bool(ok)
    if met:  # the largest check recall among the resolutions that pass
        best = max(ok, key=lambda i: steps[i]["recall"])
    else:
        best = int(np.argmax([t["precision"] for t in steps]))
        _log.warning("planar-sections: precision %.4f (%d check views) stays under the floor "
                     "%g up to %d voxels (extent %.4g); kept %d voxels", max(
                         t["precision"] for t in steps), FLOOR_VIEWS, floor,
                     steps[-1]["voxels"], extent, steps[best]["voxels"])
    out_mesh, polygons, info = results[best]
    record = {"floor": floor, "views": FLOOR_VIEWS, "seed": seed + FLOOR_SEED_OFFSET,
              "met": met, "steps": steps}
    if gain is not None:
        record["close_gain"] = gain
    if closings is not None:
        record["closings"] = closings
    info = {**info, "close": close, "precision_floor": record}
    return out_mesh, polygons, info


def _generate_one(mesh: trimesh.Trimesh, size: dict, *, budget, direction_bins, depth_bins,
                  alpha, measure, reduce, rdp_tolerance, chain, conservative, dilate,
                  close, warn_interior: bool = True):
    """One level of detail: (mesh, polygons, info)."""
    timing = {}
    t0 = time.perf_counter()
    sec = section_solid(mesh, conservative=conservative, dilate=dilate, close=close, **size)
    pitch = sec.grid.pitch
    extent = float(np.max(mesh.extents))
    info = {"voxel_size": pitch, "voxels": int(math.ceil(extent / pitch - 1e-9)),
            "grid": list(sec.grid.shape), "direction_bins": direction_bins,
            "depth_bins": depth_bins, "solid_voxels": sec.solid_voxels,
            "surface_voxels": sec.surface_voxels, "interior_voxels": sec.interior_voxels,
            "closed_oriented": sec.closed_oriented,
            "conservative_guaranteed": bool(conservative and sec.closed_oriented)}
    if conservative and not sec.closed_oriented:
        _log.warning("planar-sections: the mesh is not closed and consistently oriented; "
                     "--conservative cannot guarantee anything (run 'viscore validate')")
    if warn_interior and not conservative and not close and _no_interior(info):
        _log.warning("planar-sections: the voxel solid has (almost) no interior at %d voxels "
                     "(an open sheet, or a surface with openings), so the slices are thin "
                     "strips; for an object with holes, close them with --close 3 (or more "
                     "voxels)", info["voxels"])
    timing["voxels"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    slices = best_slices(sec, direction_bins, depth_bins)
    timing["slices"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    tolerance = None if conservative else rdp_tolerance * _section_slices.PIXELS_PER_VOXEL
    cands, chains = [], []
    for s in slices:
        for poly in slice_polygons(slice_image(sec, s), tolerance=tolerance):
            cands.append((s, poly))
            chains.append(simplification_chain(poly.ring, loose=not conservative))
    if len(cands) > MAX_CANDIDATES:  # the largest polygons; crumbs of tangles cost time only
        keep = np.argsort([-ch.areas[0] for ch in chains], kind="stable")[:MAX_CANDIDATES]
        cands = [cands[i] for i in keep]
        chains = [chains[i] for i in keep]
    timing["polygons"] = time.perf_counter() - t0
    info.update(slices=len(slices), candidates=len(cands))

    t0 = time.perf_counter()
    center, frame = orbit_frame(mesh)
    dirs = measure_directions(MEASURE_DIRECTIONS)
    rings = [s.to_world(p.ring) for s, p in cands]
    bitmaps = project_candidates(rings, dirs, center, frame, MEASURE_RESOLUTION)
    mpixel = frame / MEASURE_RESOLUTION
    timing["projections"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    chosen, totals = select_greedy(bitmaps, mpixel, alpha=alpha, measure=measure,
                                   max_polygons=budget)
    timing["greedy"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    for i in chosen:  # stages inside the candidate; the largest ones for chain='optimal'
        chains[i] = refine_chain(chains[i], cands[i][1].polygon,
                                 search=chain == "optimal" and budget is not None)
    timing["chains"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    cache: dict = {}
    # a refined chain's first stage is the candidate itself unless it left the candidate
    whole = [np.array_equal(chains[c].stage_ring(0), cands[c][1].ring) for c in chosen]

    def bitmaps_of(i: int, s: int) -> np.ndarray:
        if s == 0 and whole[i]:
            return bitmaps[chosen[i]]
        if (i, s) not in cache:
            sl, _ = cands[chosen[i]]
            ring = sl.to_world(chains[chosen[i]].stage_ring(s))
            cache[(i, s)] = project_candidates([ring], dirs, center, frame,
                                               MEASURE_RESOLUTION)[0]
        return cache[(i, s)]

    stages, _ = reduce_to_budget([chains[i] for i in chosen], budget, reduce=reduce,
                                 bitmaps_of=bitmaps_of, pixel=mpixel)
    timing["budget_cut"] = time.perf_counter() - t0
    vertices, faces, polygons = [], [], []
    offset = 0
    for i, s in zip(chosen, stages, strict=True):
        if s < 0:
            continue
        sl, _ = cands[i]
        ch = chains[i]
        tri = ch.stage_triangles(int(s))
        if len(tri) == 0:
            continue
        used, inv = np.unique(tri, return_inverse=True)
        vertices.append(sl.to_world(ch.ring[used]))
        faces.append(inv.reshape(-1, 3) + offset)
        offset += len(used)
        polygons.append(sl.to_world(ch.stage_ring(int(s))))
    if faces:
        out = trimesh.Trimesh(np.concatenate(vertices), np.concatenate(faces), process=False)
    else:
        out = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), process=False)
    info.update(greedy_polygons=len(chosen), polygons=len(polygons),
                measure_totals=totals.tolist(), seconds_steps=timing)
    return out, polygons, info
