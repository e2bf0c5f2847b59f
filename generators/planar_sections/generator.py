"""``planar-sections``: occluders made of planar slices of the voxelized mesh.

The method of Silvennoinen et al. 2014 [1]_, sec. 4, on the ray-cast core
instead of a GPU, one module per step:

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

import logging
import math
import numbers
import time

import trimesh

from viscore import InputError, validate_mesh
from viscore._validate import as_positive, as_positive_int
from viscore.level.ground import guess_up
from viscore.voxel.wall_thickness import WALL_QUANTILE, wall_voxel_size

from .._precision_check import DEFAULT_MIN_PRECISION
from ..occluder import Occluder
from ..specs import GeneratorOption, checked_by
from ._single import BYTES_PER_CELL, MAX_VOXELS, _generate_one, _resolution
from .floor import _with_precision_floor

__all__ = ["generate_planar_sections", "screen_space_voxel_size", "DEFAULT_DIRECTION_BINS",
           "DEFAULT_DEPTH_BINS", "DEFAULT_ALPHA", "DEFAULT_VOXELS", "MAX_VOXELS"]

_log = logging.getLogger(__name__)

#: Voxels along the longest bounding-box side when neither ``voxels``, ``voxel_size``
#: nor ``pixel_error`` is given (the paper's comparison setting, sec. 6.3: 64^3).
DEFAULT_VOXELS = 64

#: Direction bins over the hemisphere of plane normals and depth bins per direction
#: (sec. 4.2). Sweep with the default chains and budget cut
#: (:func:`viscore.cli.bench.planar.bins_sweep` per mesh, ``views=128``), orbit protocol,
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

#: Field of view (degrees) and screen width (pixels) of the screen-space knob's defaults.
DEFAULT_FOV = 60.0
DEFAULT_SCREEN = 1920

#: The ground fill of a ground height given with the precision floor off (one of
#: :data:`~.floor.GROUND_FILLS`).
DEFAULT_GROUND_FILL = {"grazing": 0.0, "misses": 0.05}

_MEASURES = ("om", "area")
_REDUCTIONS = ("area", "projected-area", "om")
_CHAINS = ("optimal", "greedy")


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
    fov = _OPTION["fov"].check(fov)
    screen = as_positive_int(screen, "screen")
    return pixel_error * 2.0 * distance * math.tan(math.radians(fov) / 2.0) / screen  # type: ignore[arg-type]


def _as_ground(value: object, label: str = "ground") -> str | float | None:
    """``'auto'``, None (off) or a finite height, from an option value or its CLI text."""
    if value is None or (isinstance(value, str) and value.strip().lower() in ("off", "none")):
        return None
    if isinstance(value, str) and value.strip().lower() == "auto":
        return "auto"
    try:
        height = float(value) if not isinstance(value, bool) else math.nan  # type: ignore[arg-type]
    except (TypeError, ValueError):
        height = math.nan
    if not math.isfinite(height):
        raise InputError(f"{label}: expected 'auto', 'off' or a finite height, got {value!r}")
    return height


def _as_up(value: object, label: str = "up") -> str:
    """``'auto'`` or an axis name ``'x'``, ``'y'``, ``'z'`` (any case, ``+`` allowed)."""
    text = str(value).strip().lower().lstrip("+")
    if text not in ("auto", "x", "y", "z"):
        raise InputError(f"{label}: expected auto, x, y or z, got {value!r}")
    return text


def _as_distances(value: object, label: str = "lod_distances") -> tuple[float, ...]:
    """``lod_distances`` as a sorted tuple of positive floats (a comma string or numbers)."""
    if isinstance(value, str):
        parts = [p.strip() for p in value.split(",")]
        try:
            items = [float(p) for p in parts]
        except ValueError:
            raise InputError(f"{label}: expected comma-separated numbers, got {value!r}"
                             ) from None
    elif isinstance(value, numbers.Real) and not isinstance(value, bool):
        items = [float(value)]
    else:
        try:
            items = [float(v) for v in value]  # type: ignore[attr-defined]
        except (TypeError, ValueError):
            raise InputError(f"{label}: expected numbers, got {value!r:.80}") from None
    if not items or not all(math.isfinite(v) and v > 0 for v in items):
        raise InputError(f"{label}: expected positive finite distances, got {value!r:.80}")
    if len(items) > 16:
        raise InputError(f"{label}: at most 16 levels, got {len(items)}")
    return tuple(sorted(set(items)))


#: The options of :func:`generate_planar_sections`, declared once: the registry's spec,
#: the command line's flags and the generator's own checks (:func:`.specs.checked_by`).
#: ``ground``, ``up`` and ``lod_distances`` are read by the generator's own readers
#: (a height or a word; an axis as ``+Z``; distances as text or numbers).
OPTIONS = (
    GeneratorOption("voxels", int, None, "voxels along the longest bounding-box side",
                    low=1, high=MAX_VOXELS, nullable=True,
                    default_text="64 unless --voxel-size or --pixel-error"),
    GeneratorOption("voxel_size", float, None,
                    "voxel side in world units (instead of --voxels)",
                    low=0, low_open=True, nullable=True),
    GeneratorOption("direction_bins", int, DEFAULT_DIRECTION_BINS,
                    "bins of plane normals over the hemisphere", low=1, high=256),
    GeneratorOption("depth_bins", int, DEFAULT_DEPTH_BINS,
                    "bins of plane depths per direction", low=1, high=64),
    GeneratorOption("alpha", float, DEFAULT_ALPHA,
                    "alpha-completeness of the greedy search, percent", low=0),
    GeneratorOption("measure", str, "om",
                    "selection measure: occlusion measure or projected area",
                    choices=_MEASURES),
    GeneratorOption("reduce", str, "om",
                    "budget cut keeps the cut of largest occlusion measure, "
                    "surface area (the paper) or projected area",
                    choices=_REDUCTIONS),
    GeneratorOption("rdp_tolerance", float, RDP_TOLERANCE,
                    "Ramer-Douglas-Peucker tolerance of the edge loops, voxels",
                    low=0, low_open=True),
    GeneratorOption("chain", str, "optimal",
                    "simplification chains: the paper's greedy smallest-ear "
                    "collapse, or with its stages of at most 12 triangles the "
                    "largest inscribed polygons",
                    choices=_CHAINS),
    GeneratorOption("conservative", bool, False,
                    "slice only through voxels wholly inside the mesh, so that no "
                    "ray sees the occluder before a closed mesh"),
    GeneratorOption("pixel_error", float, None,
                    "screen-space error in pixels that sets the voxel size "
                    "(with --distance or --lod-distances)",
                    low=0, low_open=True, nullable=True),
    GeneratorOption("distance", float, None,
                    "viewer distance of --pixel-error, world units",
                    low=0, low_open=True, nullable=True),
    GeneratorOption("fov", float, DEFAULT_FOV, "that viewer's field of view, degrees",
                    low=0, low_open=True, high=180, high_open=True),
    GeneratorOption("screen", int, DEFAULT_SCREEN, "that viewer's screen width, pixels",
                    low=1),
    GeneratorOption("lod_distances", str, None,
                    "levels of detail: comma-separated viewer distances, one "
                    "occluder each (with --pixel-error)", nullable=True,
                    convert=_as_distances),
    GeneratorOption("hierarchy", bool, False,
                    "occluder hierarchy over the mesh's parts, with a tree cut per "
                    "camera (sec. 5); writes the tree beside the output"),
    GeneratorOption("jobs", int, 1,
                    "processes building the hierarchy's nodes (with --hierarchy; "
                    "the same tree with any number)", low=1, high=256),
    GeneratorOption("dilate", int, 0,
                    "dilation steps of the voxel solid (sec. 5's gluing step)", low=0,
                    high=8),
    GeneratorOption("close", int, None,
                    "close openings up to about 2 x this many voxels wide before the "
                    "flood fill (scans with holes, buildings with open windows)",
                    low=0, high=8, nullable=True,
                    default_text="0, or with the precision floor on and a voxel "
                    "solid without interior (or that closing grows by 10%+) the "
                    "best of 0, 2, 3, 4 on the check views"),
    GeneratorOption("min_precision", float, None,
                    "precision floor: refine the voxels (x sqrt 2, twice at most) "
                    "while the 95% lower bound of the occluder's precision on 64 "
                    "orbit views is under it (coarser while it holds, with the "
                    "default size); 0 turns it off", low=0, high=1, nullable=True,
                    default_text="0.995 unless --voxels, --voxel-size, "
                    "--pixel-error, --conservative or --lod-distances"),
    GeneratorOption("ground", str, "auto",
                    "a ground plane under the mesh: 'auto', 'off' or its height "
                    "along --up (world units); the space between it and the surface "
                    "joins the solid where the mesh hides it (terrain, open-bottomed "
                    "buildings)",
                    default_text="auto: the mesh's lowest point, tried beside the "
                    "closings and kept when it passes the precision floor with "
                    "more recall", convert=_as_ground),
    GeneratorOption("up", str, "auto", "the up axis of --ground",
                    choices=("auto", "x", "y", "z"), convert=_as_up),
)
_OPTION = {option.name: option for option in OPTIONS}


#: The hierarchy generator (sec. 5) that ``hierarchy=True`` hands the work to, set by
#: :mod:`viscore.generators.registry` (:func:`use_hierarchy`): the hierarchy is a
#: family of its own and this module does not import it.
_HIERARCHY = None


def use_hierarchy(build) -> None:
    """Set the generator ``hierarchy=True`` delegates to (called by the registry)."""
    global _HIERARCHY
    _HIERARCHY = build


def _hierarchy_builder():
    """:func:`viscore.generators.planar_hierarchy.generate_planar_hierarchy`, or None."""
    return _HIERARCHY


@checked_by(OPTIONS)
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
                             min_precision: float | None = None, ground: object = "auto",
                             up: str = "auto", jobs: int = 1) -> Occluder:
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
        with either is an error. With ``conservative`` the default is 64 or
        finer where the walls would not hold a 3 x 3 x 3 block of inside voxels,
        within the memory guard and
        :data:`viscore.voxel.wall_thickness.AUTO_MAX_CELLS` cells, as aabb-skins'
        ``voxel_sizing="auto"`` (:func:`viscore.voxel.wall_thickness.wall_voxel_size`;
        ``info["wall_sizing"]``).
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
        (:mod:`viscore.generators._polygon_chain.optimal`; same constraint, not myopic).
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
        :func:`._slices.closed_solid`; beyond the paper), 0 to 8. For
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
    ground : {'auto', 'off'} or float, optional
        A ground plane under the mesh (beyond the paper; not with
        ``conservative``): the space between it and the surface above
        (:func:`viscore.level.ground.ground_fill`: under a height field, inside an
        open-bottomed building) joins the voxel solid where the mesh hides
        it: a plane slices a voxel of it when all but a share of the line
        directions that see the plane are covered there
        (:func:`viscore.voxel.coverage_hull.exposure`, :class:`._slices.GroundFill`),
        each of :data:`~.floor.GROUND_FILLS` tried under the precision
        floor. A number is the plane's height along ``up`` (world units;
        with the floor off, :data:`DEFAULT_GROUND_FILL`). ``'auto'``
        (default): the mesh's lowest point, tried beside the closings, on a
        mesh whose closings are tried and whose surface covers at least
        :data:`~.floor.GROUND_SHARE` of its footprint from above, kept only
        when it passes the floor with more check recall; nothing without the
        floor. ``'off'``: never. At 64 triangles (orbit, 256 views) the
        built-in warehouse goes from R 0.344 to 0.907 (P 0.9969), the terrain
        from 0.009 to 0.493 (P 0.9987).
    jobs : int, optional
        With ``hierarchy``, processes building its nodes (1 to 256, default
        1; the same tree with any number); without, must be 1.
    up : {'auto', 'x', 'y', 'z'}, optional
        The up axis of ``ground``. Default ``'auto'``:
        :func:`viscore.level.ground.guess_up` of an object (``info["up"]``).

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
        ``closings`` (one step each); ``ground`` (the fill used:
        ``height``, ``misses``, ``grazing``; or None), ``up``, ``footprint_share``.

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
    # each option is checked by OPTIONS: lod_distances comes as a sorted tuple, ground as
    # 'auto', None (off) or a height; here the rules across options, the mesh last
    if not isinstance(mesh, trimesh.Trimesh) and not hierarchy:
        raise InputError("mesh: expected a trimesh.Trimesh")
    distances = lod_distances
    given = _check_rules(voxels=voxels, voxel_size=voxel_size, pixel_error=pixel_error,
                         distance=distance, distances=distances, min_precision=min_precision,
                         conservative=conservative, close=close, ground=ground,
                         hierarchy=hierarchy, jobs=jobs)
    params = {"budget": budget, "seed": seed, "voxels": voxels, "voxel_size": voxel_size,
              "direction_bins": direction_bins, "depth_bins": depth_bins, "alpha": alpha,
              "measure": measure, "reduce": reduce, "rdp_tolerance": rdp_tolerance,
              "chain": chain, "conservative": bool(conservative),
              "pixel_error": pixel_error, "distance": distance, "fov": fov, "screen": screen,
              "lod_distances": None if distances is None else list(distances),
              "hierarchy": bool(hierarchy), "dilate": int(dilate),
              "close": None if close is None else int(close), "min_precision": min_precision,
              "ground": "off" if ground is None else ground, "up": up, "jobs": jobs}
    if hierarchy:  # sec. 5: a BVH over the objects, this generator at every node
        build = _hierarchy_builder()
        return build(mesh, **{k: v for k, v in params.items() if k != "hierarchy"})
    mesh = validate_mesh(mesh)
    if up == "auto":
        up, up_reason = guess_up(mesh, level=False)
    else:
        up_reason = "given"
    ground_plane = _ground_plane(mesh, ground, up=up, conservative=conservative)

    options = dict(budget=budget, direction_bins=direction_bins, depth_bins=depth_bins,
                   alpha=alpha, measure=measure, reduce=reduce,
                   rdp_tolerance=rdp_tolerance, chain=chain, conservative=bool(conservative),
                   dilate=int(dilate), close=int(close or 0), up=up)
    wall_sizing = None
    if distances is None:
        size, wall_sizing = _voxel_size(mesh, voxels=voxels, voxel_size=voxel_size,
                                        pixel_error=pixel_error, distance=distance, fov=fov,
                                        screen=screen, conservative=conservative)
        floor = min_precision
        if floor is None and not given and not conservative:
            floor = DEFAULT_MIN_PRECISION
        params["min_precision"] = floor
        if floor:
            out_mesh, polygons, info = _with_precision_floor(
                mesh, size, floor, seed, options,
                auto_close=close is None and not conservative, coarsen=not given,
                ground=ground_plane)
        else:
            fill = None if ground_plane is None or ground_plane["auto"] else {
                "height": ground_plane["height"], **DEFAULT_GROUND_FILL}
            out_mesh, polygons, info = _generate_one(mesh, size, ground=fill, **options)  # type: ignore[arg-type]
        parts = {"polygons": polygons}
    else:
        out_mesh, polygons, info, lods = _levels_of_detail(
            mesh, distances, pixel_error=pixel_error, fov=fov, screen=screen, options=options)  # type: ignore[arg-type]
        parts = {"polygons": polygons, "lods": lods}
    info = {"close": options["close"], **info, "up": up, "up_reason": up_reason,
            "triangles_single_sided": 2 * len(out_mesh.faces)}
    if wall_sizing is not None:
        info["wall_sizing"] = wall_sizing
    return Occluder(mesh=out_mesh, method="planar-sections", params=params, double_sided=True,
                    seconds=time.perf_counter() - start, parts=parts, info=info)


def _check_rules(*, voxels, voxel_size, pixel_error, distance, distances, min_precision,
                 conservative, close, ground, hierarchy, jobs) -> list[str]:
    """The rules across options (each option checked already); returns the ways of sizing
    the voxels given (``voxels``, ``voxel_size``, ``pixel_error``: one at most)."""
    if close and conservative:
        raise InputError("close: not with conservative (closing adds voxels outside the mesh)")
    if ground is not None and ground != "auto" and conservative:
        raise InputError("ground: not with conservative (the ground fill adds voxels outside "
                         "the mesh)")
    if jobs != 1 and not hierarchy:
        raise InputError("jobs: only with hierarchy (one occluder is built in one process)")
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
    if min_precision is not None and distances is not None and min_precision > 0:
        raise InputError("min_precision: not with lod_distances (each level's voxel size "
                         "is set by its distance)")
    if hierarchy and _hierarchy_builder() is None:
        raise InputError("hierarchy: not available yet (planar_hierarchy is not installed)")
    return given


def _ground_plane(mesh: trimesh.Trimesh, ground, *, up: str, conservative: bool) -> dict | None:
    """The ground plane under the mesh: its height along ``up`` and whether it was guessed
    (``ground='auto'``: the mesh's lowest point, none when conservative), or None (off)."""
    if ground == "auto":
        return None if conservative else {
            "height": float(mesh.bounds[0]["xyz".index(up)]), "auto": True}
    if ground is None:
        return None
    return {"height": float(ground), "auto": False}


def _voxel_size(mesh: trimesh.Trimesh, *, voxels, voxel_size, pixel_error, distance, fov,
                screen, conservative) -> tuple:
    """The voxel grid's size (:func:`._single._resolution`) by the one sizing given, and
    the wall sizing's info when the walls set it (conservative, no size given), else None."""
    if pixel_error is not None:
        return _resolution(mesh, None, screen_space_voxel_size(
            pixel_error, distance, fov=fov, screen=screen),
            f"pixel_error={pixel_error:g} at distance={distance:g}"), None
    if voxel_size is not None:
        return _resolution(mesh, None, voxel_size, f"voxel_size={voxel_size:g}"), None
    if conservative and voxels is None:
        # the solid is the inside voxels eroded once by the 3^3 cube: size the voxels
        # so that the walls hold 3 x 3 x 3 blocks of inside voxels
        sized = wall_voxel_size(mesh, bytes_per_cell=BYTES_PER_CELL,
                                resolution=DEFAULT_VOXELS, quantile=WALL_QUANTILE,
                                max_resolution=MAX_VOXELS, what="planar-sections",
                                finer="voxel-size", block=3)
        _log.log(sized.log_level, "%s", sized.reason)
        return _resolution(mesh, None, sized.pitch,
                           f"voxel_size={sized.pitch:g} (auto)"), sized.info
    n = DEFAULT_VOXELS if voxels is None else voxels
    return _resolution(mesh, n, None, f"voxels={n}"), None


def _levels_of_detail(mesh: trimesh.Trimesh, distances: tuple[float, ...], *,
                      pixel_error: float, fov: float, screen: int, options: dict) -> tuple:
    """One occluder per viewer distance, nearest first: the nearest's mesh, polygons and
    info, and every level's entry of ``parts["lods"]``."""
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
    return out_mesh, polygons, info, lods


