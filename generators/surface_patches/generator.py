"""Surface patches: conservative occluders cut from the input's own planar surface.

After the planar patches of Wu et al. [1]_ (sec. 3.1.1) and the simplification
chain and selection of Silvennoinen et al. [2]_ (secs. 4.4-4.5).

For thin, open game geometry (walls thinner than a voxel, loose panels,
single-sided sheets, open rooms) where the volume methods find no inside:

References
----------
.. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (sec. 3.1.1, the planar patches)
.. [2] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 3, the occlusion
   measure; sec. 4.4, the simplification chain; sec. 4.5, the selection)
.. [3] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
   Bursztyn, A. P. M. "Implementing software occlusion culling for real-time
   applications". XVIII Congreso Argentino de Ciencias de la Computacion
   (CACIC 2012), Workshop de Computacion Grafica, Imagenes y Visualizacion,
   2012. http://sedici.unlp.edu.ar/handle/10915/23640 (sec. 4, occluder
   skins: boxes inside the solid)
.. [4] Naaji, K. "Automatic Occluder Generation". A Graphics Diary (blog),
   15 November 2019. http://karim.naaji.fr/automatic_occluder_geneneration.html
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import shapely
import trimesh
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient

from viscore import InputError, Scene
from viscore._content_cache import ContentCache
from viscore.constants import CONSERVATIVE_EPS_RELATIVE
from viscore.level.ground import UP_AXES, guess_up

from .._boxes import boxes_mesh
from .._convex_bands import grid_bands
from .._plane_regions import plane_regions
from .._polygon_chain import refine_chain, simplification_chain
from ..occluder import Occluder
from ..specs import GeneratorOption, checked_by
from ._crease_weld import crease_lines, weld_points, welded_ring
from ._ground_curtains import curtain_regions
from ._inner_boxes import (
    TRIANGLES_PER_BOX,
    box_faces,
    box_source,
    candidate_boxes,
    closed_parts,
    unshadowed_measures,
    use_box_source,
)
from ._overlap import candidate_bitmaps, select_with_overlap
from ._sheets import SHEET_MAX_FACES, chunk_measure, face_areas, sheet_chunks

__all__ = ["generate_surface_patches", "use_box_source", "DEFAULT_BUDGET", "PLANE_TOLERANCE",
           "GRID", "EROSION", "MIN_AREA", "BOXES", "SHEETS", "OPTIONS"]

_log = logging.getLogger(__name__)

#: Default triangle budget: the hybrid method's average (Wu et al. 2022, sec. 4).
DEFAULT_BUDGET = 260

#: Default coplanarity tolerance, fraction of the bounding-box diagonal: largest
#: distance of a region face's vertex from the region's plane. A hundredth of the
#: conservativeness check's eps (CONSERVATIVE_EPS_RELATIVE, 1e-5): float32 rounding
#: of exactly coplanar walls in a glTF file (the Godot demo room: up to 2e-8) is
#: taken, modelled steps of 1 mm on a 10 m building are not.
PLANE_TOLERANCE = 1e-7

#: Integer grid of the in-plane coordinates, fraction of the diagonal: the
#: simplification chain's ear tests are exact on integers (coordinates up to 1e6,
#: products up to 1e12, exact in float64).
GRID = 1e-6

#: Inward erosion of each region's union before snapping, fraction of the
#: diagonal: four grid steps, so that snapping (under one step) stays inside the
#: union, and a ray meeting the occluder passes at least ~3 grid steps inside the
#: input's triangles, beyond float32 rounding of the hit point (Embree). Under the
#: check's eps (1e-5), so the gaps it opens at a region's rim block almost nothing.
EROSION = 4 * GRID

#: Fewest faces of a region used: a face alone in its plane is a facet of a curved
#: surface (or a lone triangle), and curved regions contribute nothing.
MIN_FACES = 2

#: Default smallest region or piece kept, fraction of the input's total face area.
MIN_AREA = 1e-4

#: A triangle of the output whose doubled area is under this times its longest edge
#: squared is dropped: its corners are collinear to float64 rounding (the sine of its
#: largest angle under 1e-12), so it covers no pixel and engines refuse it.
_COLLINEAR = 1e-12

#: Choices of ``boxes``: aabb-skins boxes in the closed parts where they fit, or none.
BOXES = ("auto", "off")

#: Choices of ``sheets``: the curved open sheets' own triangles in chunks, or none.
SHEETS = ("auto", "off")

#: Values of ``ground``: curtains under open ground, or none.
GROUNDS = ("off", "auto")

#: Choices of ``weld``: patches moved onto the input's creases, or left eroded.
WELDS = ("auto", "off")

#: Choices of ``selection``: values discounted by the soup's overlap, or taken one by one.
SELECTIONS = ("overlap", "separate")

#: Candidate pieces kept for the chains and the selection, largest first, at least; a
#: larger budget keeps as many pieces as it has triangles (:func:`_candidate_cap`).
MAX_CANDIDATES = 400

#: Pieces, largest first, whose low stages are searched (``chain='optimal'``); the
#: others keep the greedy chain (the search dominates the run time).
MAX_SEARCH = 120

#: Pixels along the longer side of a stage's in-plane rasterization (its measure).
MEASURE_PIXELS = 64

#: Fewest pixels across the shorter side of that rasterization (thin strips).
MEASURE_MIN_ACROSS = 6

#: Largest pixel count along a side of that rasterization.
MEASURE_MAX_PIXELS = 512

#: The options of :func:`generate_surface_patches`, declared once: the registry's spec,
#: the command line's flags and the generator's own checks (:func:`.specs.checked_by`).
OPTIONS = (
    GeneratorOption("plane_tolerance", float, PLANE_TOLERANCE,
                    "coplanarity tolerance: largest distance of a region face's vertex from "
                    "its plane, fraction of the bounding-box diagonal",
                    low=0, low_open=True, high=CONSERVATIVE_EPS_RELATIVE),
    GeneratorOption("min_area", float, MIN_AREA,
                    "skip regions and pieces under this fraction of the input's face area",
                    low=0, high=1),
    GeneratorOption("chain", str, "optimal",
                    "stages of at most 12 triangles: largest inscribed polygons or the paper's "
                    "greedy chain", choices=("optimal", "greedy")),
    GeneratorOption("boxes", str, "auto",
                    "also offer aabb-skins boxes inside the closed parts (curved solids) to the "
                    "selection, 12 triangles each, or patches only", choices=BOXES),
    GeneratorOption("ground", str, "off",
                    "also offer vertical curtains in the space open ground seals (hills, "
                    "terrain sheets): guaranteed for viewpoints not under the ground nor below "
                    "its rim", choices=GROUNDS),
    GeneratorOption("up", str, "auto", "the up axis of --ground", choices=("auto", *UP_AXES)),
    GeneratorOption("selection", str, "overlap",
                    "value each candidate by what it adds to the chosen ones' projections (the "
                    "paper's soup measure) or by its own measure alone", choices=SELECTIONS),
    GeneratorOption("sheets", str, "auto",
                    "also offer curved open sheets (terrain, vaults) as their own triangles, in "
                    "chunks of about 64", choices=SHEETS),
    GeneratorOption("weld", str, "auto",
                    "move patch vertices the erosion left beside a crease of the input onto the "
                    "line of its two planes, so that the depth buffer covers the crease",
                    choices=WELDS),
)


def _region_pieces(union, *, erosion: float, grid: float, floor: float) -> list[Polygon] | None:
    """Hole-free convex pieces (grid units) of an exact region, eroded inward by ``erosion``
    (mitred) and snapped to the grid; those under ``floor`` (world units^2) are left out.
    None when the erosion leaves nothing. ``union`` is prepared for the final covers test."""
    with np.errstate(divide="ignore", invalid="ignore"):  # GEOS on slivers
        eroded = shapely.buffer(union, -erosion, join_style="mitre")
    if eroded.is_empty:
        return None
    shapely.prepare(union)
    return [piece for piece in grid_bands(eroded, grid)
            if piece.area * grid * grid >= max(floor, 0.0) and piece.area > 0]


def _loop(piece: Polygon) -> np.ndarray:
    """Counter-clockwise exterior ``(n, 2)`` without closing duplicate or repeated vertices."""
    xy = np.asarray(orient(piece, sign=1.0).exterior.coords, dtype=np.float64)[:-1]
    keep = np.any(xy != np.roll(xy, 1, axis=0), axis=1)
    return xy[keep]


def _stage_measure(ring: np.ndarray) -> float:
    """Head-on occlusion measure (units^3) of a simple loop in grid units, rasterized."""
    from skimage.draw import polygon as fill

    from viscore.metrics import directional_occlusion_measure

    lo, hi = ring.min(axis=0), ring.max(axis=0)
    size = np.maximum(hi - lo, 1e-12)
    pixel = min(size.max() / MEASURE_PIXELS, size.min() / MEASURE_MIN_ACROSS)
    pixel = max(pixel, size.max() / MEASURE_MAX_PIXELS)
    shape = (int(np.ceil(size[1] / pixel)) + 2, int(np.ceil(size[0] / pixel)) + 2)
    rows = (ring[:, 1] - lo[1]) / pixel + 1.0 - 0.5
    cols = (ring[:, 0] - lo[0]) / pixel + 1.0 - 0.5
    img = np.zeros(shape, dtype=bool)
    rr, cc = fill(rows, cols, shape)
    img[rr, cc] = True
    if not img.any():
        return 0.0
    return float(directional_occlusion_measure(img, float(pixel))[0])


def _select(values: list[np.ndarray], counts: list[np.ndarray], budget: int) -> np.ndarray:
    """Greedy multiple-choice knapsack: stage per candidate (-1: none), at most ``budget``
    triangles, raising at each step the candidate whose stage adds the most value per
    added triangle (values taken as given; ties to the lower index)."""
    k = len(values)
    stage = np.full(k, -1, dtype=np.int64)
    if k == 0:
        return stage
    owner = np.repeat(np.arange(k), [len(c) for c in counts])
    flat_c = np.concatenate(counts).astype(np.int64)
    flat_v = np.concatenate(values).astype(np.float64)
    first = np.concatenate([[0], np.cumsum([len(c) for c in counts])[:-1]])
    cur_v = np.zeros(k)
    cur_c = np.zeros(k, dtype=np.int64)
    left = int(budget)
    while True:
        dc = flat_c - cur_c[owner]
        dv = flat_v - cur_v[owner]
        ok = (dc > 0) & (dc <= left) & (dv > 0)
        if not ok.any():
            return stage
        ratio = np.where(ok, dv / np.maximum(dc, 1), -np.inf)
        j = int(np.argmax(ratio))
        i = int(owner[j])
        left -= int(dc[j])
        stage[i] = j - first[i]
        cur_v[i] = flat_v[j]
        cur_c[i] = flat_c[j]


@checked_by(OPTIONS)
def generate_surface_patches(mesh: trimesh.Trimesh, *, budget: int | None = DEFAULT_BUDGET,
                             seed: int = 0, plane_tolerance: float = PLANE_TOLERANCE,
                             min_area: float = MIN_AREA, chain: str = "optimal",
                             boxes: str = "auto", ground: str = "off",
                             up: str = "auto", selection: str = "overlap",
                             sheets: str = "auto", weld: str = "auto") -> Occluder:
    """Double-sided occluder in the input's own planar surface, conservative on any input.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Any triangle soup: open, single-sided, self-intersecting,
        non-manifold, loose parts.
    budget : int, optional
        Largest triangle count, >= 1 (default :data:`DEFAULT_BUDGET`, 260);
        None keeps every piece whole.
    seed : int, optional
        Unused (the method is deterministic); accepted for the common
        signature. A non-negative integer, default 0.
    plane_tolerance : float, optional
        Coplanarity tolerance, fraction of the bounding-box diagonal, in
        (0, 1e-5]: the largest distance of a region face's vertex from the
        region's plane (default :data:`PLANE_TOLERANCE`, 1e-7). Capped at
        the conservativeness check's eps (Notes).
    min_area : float, optional
        Regions and pieces with less area than this fraction of the input's
        total face area are skipped, in [0, 1] (default :data:`MIN_AREA`,
        1e-4).
    chain : {'optimal', 'greedy'}, optional
        Stages of at most 12 triangles are the largest inscribed polygons
        (``'optimal'``, default, for the :data:`MAX_SEARCH` largest pieces)
        or the paper's greedy ones.
    boxes : {'auto', 'off'}, optional
        ``'auto'`` (default): where the input has closed, consistently
        oriented parts, also offer the aabb-skins boxes inside them
        (Leone et al. [3]_, sec. 4; module docstring, step 5) to the same
        selection, 12 triangles each, so that curved solids (a sphere, a
        column) get an occluder; needs a budget of at least 12 (or None).
        ``'off'``: patches only.
    ground : {'off', 'auto'}, optional
        ``'auto'``: also offer vertical curtains in the space each open part
        of the input seals between its surface and the height of its rim
        (:mod:`._ground_curtains`: a hill, a terrain sheet, an open-bottomed
        shell without openings), so that curved open ground gets an
        occluder; guaranteed for viewpoints neither under such a part's
        surface nor below its rim's height (``info["guarantee"]``). Default
        ``'off'``: the guarantee holds for every viewpoint.
    up : {'auto', 'x', 'y', 'z'}, optional
        The up axis of ``ground='auto'``; ``'auto'`` (default) guesses it
        from the geometry (:func:`viscore.level.ground.guess_up`, as one object).
    selection : {'overlap', 'separate'}, optional
        ``'overlap'`` (default): each candidate's value is scaled by what it
        adds to the chosen candidates' projections (module docstring, step
        4); ``'separate'``: the values are taken one by one. The geometry of
        each candidate, and so the guarantee, is the same either way.
    sheets : {'auto', 'off'}, optional
        ``'auto'`` (default): also offer the curved sheets of the input's
        open parts (height-field patches: a terrain, a vault, a curved wall)
        as their own triangles, in chunks (:mod:`._sheets`; module
        docstring, step 7), when the open parts have at most
        :data:`._sheets.SHEET_MAX_FACES` faces. ``'off'``: none.
    weld : {'auto', 'off'}, optional
        ``'auto'`` (default): a patch vertex that the erosion left beside a
        crease of the input (an edge the region shares with a face of
        another plane) is moved onto the line of the two planes
        (:mod:`._crease_weld`; module docstring, step 8), so that the
        patches on either side meet and the conservative depth buffer
        covers the crease. ``'off'``: patches keep the erosion's seams.

    Returns
    -------
    Occluder
        ``double_sided`` True; ``parts["polygons"]``: the kept stages as
        ``(m, 3)`` world loops, then the six faces of each kept box as
        ``(4, 3)`` loops (the boxes are in the mesh and the polygons, never
        under ``parts["boxes"]``, which runtimes take as the whole
        occluder). ``info``: ``conservative_guaranteed`` (True, and with
        boxes kept only while the box source says its boxes are),
        ``regions`` (planar regions found), ``regions_used`` (at least
        ``min_area`` and two faces),
        ``candidates`` (hole-free pieces), ``polygons`` (patch polygons kept),
        ``area_kept`` (the patches' area over the input's total face area),
        ``dropped_triangles`` (chain triangles the final containment check
        refused; expected 0), ``plane_tolerance``, ``erosion``, ``grid`` and
        ``eps`` in world units; ``closed_faces`` (input faces in closed
        parts), ``box_candidates`` (boxes offered), ``boxes`` (kept),
        ``boxes_guaranteed`` (the box source's ``conservative_guaranteed``,
        None when it did not run), ``box_pitch`` (its voxel side, world
        units, or None), ``empty_reason`` (why there is no triangle, or
        None); ``curtain_candidates`` and ``curtains`` (offered and kept,
        with ``ground='auto'``), ``ground_parts`` (open parts that sealed a
        space), ``ground_parts_layered`` (open parts refused for folds or
        overhangs: more than one layer along the up axis), ``up``,
        ``guarantee`` (``'every viewpoint'``, or with a curtain kept
        ``'viewpoints not under the surface of an open part nor below its
        rim'``); ``sheet_candidates`` and ``sheets`` (chunks offered and
        kept), ``sheet_faces`` (input faces kept as they are),
        ``sheets_skipped`` (why no sheet was looked for, or None);
        ``whole_input`` (True when the budget held the whole input, kept as
        it is); ``welded`` (patches moved onto creases); ``seconds_steps``.

    Raises
    ------
    InputError
        On an empty mesh or a bad option (checked by :data:`OPTIONS`), before
        any work.

    Notes
    -----
    Deterministic. Curved regions give no patch: a face that shares its
    plane with no other face (a facet of a curved surface, or a lone
    triangle) is skipped (:data:`MIN_FACES`); a flat facet of two or more
    faces (a cylinder's quads) is a region like any other. Curved open
    sheets are offered as their own triangles instead (``sheets``). Holes in a region (windows,
    doors) stay open; nothing is filled. Curved solids are covered by the
    boxes instead (``boxes='auto'``), where a closed part holds inner voxels
    at the box source's resolution (64 voxels along the longest side of the
    closed parts' bounding box): a curved open surface (a sphere with a hole,
    a dome) gets neither. May end under the budget, or empty (no planar
    region large enough and no box); an empty result logs one warning line
    saying why (``info["empty_reason"]``). A ``budget`` that holds every
    non-degenerate triangle of the input gets them as they are
    (``info["whole_input"]`` True): nothing within the surface covers more.

    The guarantee. Every occluder triangle lies in the plane of a region,
    inside the union of the region's triangles projected into that plane,
    at least :data:`EROSION` minus one and a half :data:`GRID` steps (2.5e-6
    of the diagonal) from its rim: the union is eroded by a mitred negative
    buffer (a subset of the erosion), snapped by under one grid step, the
    bands' cuts (snapped by half a step more) and the chain's stages only
    remove area, and a last shapely ``covers`` test
    against the exact union drops any triangle that would leave it. The
    occluder point p where a ray meets the occluder therefore lies over a
    point q of an input triangle of the region with ``|p - q| <= tol`` along
    the normal (tol = ``plane_tolerance`` x diagonal), and when the region's
    faces lie exactly in its plane (axis-aligned walls in float32 or float64
    files; every region of the built-in buildings, to 3e-19 of the diagonal)
    q = p: the ray meets the input there, so it never meets the occluder
    first, whatever the input (open, single-sided, self-intersecting,
    non-manifold). Float rounding: the plane passes through its seed face's
    first vertex exactly and axis-aligned planes get axis-aligned in-plane
    axes, so their occluder vertices keep the input's coordinate exactly;
    The sheets' triangles are input triangles, vertex for vertex (the same
    float64 coordinates): a ray meets the input wherever it meets them.
    Embree's float32 hit points are off by ~1e-7 of the coordinates, far
    under the 2.5e-6 margin and the check's eps (1e-5 of the diagonal,
    :func:`viscore.metrics.check_conservative`). When a region face lies off
    the plane by d <= tol, a ray meeting the occluder first by more than eps
    must be within arccos(d / eps) of grazing the plane: with the default
    (d / eps <= 0.01) at most 1e-4 of the (cosine-weighted) rays meeting such
    a face, and only where it deviates by the whole tolerance. That is why
    ``plane_tolerance`` is capped at eps; ``info["conservative_guaranteed"]``
    is True on every input in this sense.

    The boxes' guarantee is aabb-skins' own on a closed input: they are
    grown in the union of the closed, consistently oriented parts alone
    (a closed input by construction, whatever else the input holds), inside
    it by the winding number and touching none of its triangles, so a ray
    from a point outside those parts crosses one of their triangles (an
    input triangle) before any box. The claim is the box source's
    ``conservative_guaranteed`` on that union, and ``info`` keeps it.
    Points outside the whole input (the volume domain: generalized winding
    number under 1/2) are outside its closed parts unless open parts wrap
    a closed one with the opposite orientation (their own winding number at
    least 1/2 there); the guarantee does not cover that case.

    References
    ----------
    .. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for
       Buildings in Digital Games". Computer Graphics Forum 41(7), 2022,
       pp. 205-214. :DOI:`10.1111/cgf.14669` (sec. 3.1.1)
    .. [2] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J.
       "Occluder Simplification Using Planar Sections". Computer Graphics
       Forum 33(1), 2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (secs. 3, 4.4,
       4.5)
    .. [3] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
       Bursztyn, A. P. M. "Implementing software occlusion culling for
       real-time applications". CACIC 2012, WCGIV, 2012.
       http://sedici.unlp.edu.ar/handle/10915/23640 (sec. 4)
    .. [4] Naaji, K. "Automatic Occluder Generation". A Graphics Diary, 2019.
       http://karim.naaji.fr/automatic_occluder_geneneration.html

    Examples
    --------
    >>> quad = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]],
    ...                        [[0, 1, 2], [0, 2, 3]])
    >>> occ = generate_surface_patches(quad)
    >>> occ.triangles, round(float(occ.mesh.area), 4), occ.info["conservative_guaranteed"]
    (2, 1.0, True)
    >>> ball = generate_surface_patches(trimesh.creation.icosphere(subdivisions=2), budget=24)
    >>> ball.info["polygons"], ball.info["boxes"], ball.triangles
    (0, 2, 24)
    """
    start = time.perf_counter()
    # the options are checked (OPTIONS); the mesh last: a check-only call ends at it
    vertices, faces, diag = _mesh_arrays(mesh)
    params = {"budget": budget, "seed": seed, "plane_tolerance": plane_tolerance,
              "min_area": min_area, "chain": chain, "boxes": boxes, "ground": ground,
              "up": up, "selection": selection, "sheets": sheets, "weld": weld}
    timing = {}
    area = face_areas(vertices, faces)
    if budget is not None:
        whole = _whole_input(vertices, faces, area, budget, params, diag, start)
        if whole is not None:
            return whole

    t0 = time.perf_counter()
    regions = _REGIONS.get((vertices, faces, plane_tolerance * diag, plane_regions),
                           lambda: _read_only(plane_regions(vertices, faces,
                                                            tolerance=plane_tolerance * diag)))
    timing["regions"] = time.perf_counter() - t0
    total = float(sum(r.area for r in regions))
    floor = min_area * total
    grid = GRID * diag

    t0 = time.perf_counter()
    cands, sources, cand_region, region_of, used = _planar_candidates(
        vertices, faces, regions, diag=diag, grid=grid, floor=floor)
    timing["pieces"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    planar_cands = len(cands)
    ground_info: dict = {"parts": 0}
    if ground == "auto":
        ground_info = _add_curtains(mesh, vertices, faces, cands, sources, cand_region, up=up,
                                    diag=diag, grid=grid, floor=floor)
    curtain_cands = len(cands) - planar_cands
    is_curtain = np.arange(len(cands)) >= planar_cands
    timing["curtains"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    found = len(cands)
    cap = _candidate_cap(budget)
    if len(cands) > cap:  # the largest pieces; crumbs cost time only
        keep = np.sort(np.argsort([-p.area for _, _, p in cands], kind="stable")[:cap])
        cands = [cands[i] for i in keep]
        sources = [sources[i] for i in keep]
        cand_region = [cand_region[i] for i in keep]
        is_curtain = is_curtain[keep]
    chains, values, counts = _candidate_chains(cands, chain=chain, grid=grid)
    timing["chains"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    closed = closed_parts(vertices, faces)
    corners, box_values, box_info, box_reason = _box_candidates(
        vertices, faces, closed, cands, chains, grid, boxes=boxes, budget=budget)
    for value in box_values:  # one stage of 12 triangles each, after the patches (ties)
        values.append(np.array([value]))
        counts.append(np.array([TRIANGLES_PER_BOX], dtype=np.int64))
    timing["boxes"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    chunks, sheets_skipped = _sheet_candidates(vertices, faces, area, closed, region_of,
                                               sheets=sheets, floor=floor, budget=budget)
    sheet_tris = [vertices[faces[members]] for members in chunks]
    for tri in sheet_tris:  # one stage each: the chunk's own triangles, after the boxes
        values.append(np.array([chunk_measure(tri)]))
        counts.append(np.array([len(tri)], dtype=np.int64))
    timing["sheets"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    stages = _selected_stages(mesh, cands, chains, values, counts, corners, sheet_tris,
                              budget=budget, selection=selection, grid=grid)
    timing["selection"] = time.perf_counter() - t0
    kept_boxes = corners[stages[len(cands):len(cands) + len(corners)] >= 0]
    kept_chunks = [m for m, s in zip(chunks, stages[len(cands) + len(corners):], strict=True)
                   if s >= 0]
    stages = stages[:len(cands)]
    sheet_faces = np.concatenate(kept_chunks) if kept_chunks else np.zeros(0, dtype=np.int64)
    # a planar stage inside a region whose faces the kept sheets hold as they are would lie
    # on them: a second layer, which keeps the depth buffer's corner rays off one patch
    in_sheets = np.zeros(len(faces), dtype=bool)
    in_sheets[sheet_faces] = True
    doubled = np.array([src is not None and s >= 0 and bool(in_sheets[src].all())
                        for src, s in zip(sources, stages, strict=True)], dtype=bool)
    stages = np.where(doubled, -1, stages)

    t0 = time.perf_counter()
    out = _kept_output(vertices, faces, regions, cands, chains, stages, is_curtain, cand_region,
                       kept_boxes, sheet_faces, grid=grid, diag=diag, weld=weld)
    timing["output"] = time.perf_counter() - t0  # the kept stages placed, welded, joined
    if out.dropped:
        _log.warning("surface-patches: %d chain triangles left their region and were dropped",
                     out.dropped)
    boxes_claim = box_info.get("conservative_guaranteed") if box_info else None
    empty_reason = None
    if not len(out.mesh.faces):
        empty_reason = _empty_reason(
            found=found, box_reason=box_reason, curtains=curtain_cands, chunks=len(chunks),
            sheets_skipped=sheets_skipped, budget=budget, min_area=min_area, ground=ground,
            sheets=sheets)
        _log.warning("surface-patches: no occluder for %s: %s",
                     mesh.metadata.get("name", "the mesh"), empty_reason)
    info = {"conservative_guaranteed": bool(not len(kept_boxes) or boxes_claim is True),
            "whole_input": False, "regions": len(regions), "regions_used": used,
            "candidates": found, "polygons": out.patch_polygons,
            "area_kept": out.area / total if total > 0 else 0.0,
            "dropped_triangles": out.dropped,
            "plane_tolerance": plane_tolerance * diag, "erosion": EROSION * diag,
            "grid": grid, "eps": CONSERVATIVE_EPS_RELATIVE * diag,
            "closed_faces": int(box_info.get("closed_faces", 0)),
            "box_candidates": len(corners), "boxes": len(kept_boxes),
            "boxes_guaranteed": None if boxes_claim is None else bool(boxes_claim),
            "box_pitch": box_info.get("pitch"), "empty_reason": empty_reason,
            "curtain_candidates": curtain_cands, "curtains": out.curtains_kept,
            "ground_parts": ground_info["parts"],
            "ground_parts_layered": ground_info.get("layered", 0), "up": ground_info.get("up"),
            "guarantee": ("viewpoints not under the surface of an open part nor below its rim"
                          if out.curtains_kept else "every viewpoint"),
            "sheet_candidates": len(chunks), "sheets": len(kept_chunks),
            "sheet_faces": int(len(sheet_faces)), "sheets_skipped": sheets_skipped,
            "welded": out.welded, "seconds_steps": timing}
    return Occluder(mesh=out.mesh, method="surface-patches", params=params, double_sided=True,
                    seconds=time.perf_counter() - start, parts={"polygons": out.polygons},
                    info=info)


def _selected_stages(mesh: trimesh.Trimesh, cands: list, chains: list, values: list,
                     counts: list, corners: np.ndarray, sheet_tris: list, *,
                     budget: int | None, selection: str, grid: float) -> np.ndarray:
    """Step 4: the stage kept per candidate (patches, then boxes, then sheet chunks; -1:
    none): without a budget each whole candidate that has a measure, else the greedy
    knapsack on the values, discounted by the overlap (``selection='overlap'``) or not."""
    if budget is None:
        return np.array([0 if int(c[0]) > 0 and float(x[0]) > 0 else -1
                         for c, x in zip(counts, values, strict=True)], dtype=np.int64)
    if selection == "overlap":
        rings = [frame[0] + loop[:, :1] * frame[1] + loop[:, 1:2] * frame[2]
                 for (frame, _, _), ch in zip(cands, chains, strict=True)
                 for loop in [ch.stage_ring(0) * grid]]
        return select_with_overlap(values, counts,
                                   candidate_bitmaps(mesh, rings, box_faces(corners),
                                                     sheet_tris),
                                   budget)
    return _select(values, counts, budget)


def _empty_reason(*, found: int, box_reason: str, curtains: int, chunks: int,
                  sheets_skipped: str | None, budget: int | None, min_area: float,
                  ground: str, sheets: str) -> str:
    """Why the occluder has no triangle: one line, each kind of candidate's reason."""
    planar = (f"no planar region of two or more faces and at least {min_area:g} of the "
              "face area (curved regions contribute nothing)" if not found else
              "no patch keeps a triangle inside its region" if budget is None else
              f"no patch fits a budget of {budget}")
    reason = f"{planar}, and {box_reason}"
    if ground == "auto" and not curtains:
        reason += "; no open part seals a space under its surface above its rim (ground)"
    if sheets == "auto":
        reason += ("; " + sheets_skipped if sheets_skipped else
                   "; no curved open sheet" if not chunks else
                   "; no sheet chunk has a measure" if budget is None else
                   f"; no sheet chunk fits a budget of {budget}")
    return reason


def _mesh_arrays(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray, float]:
    """The mesh's ``(v, 3) float64`` vertices, ``(f, 3) int64`` faces and bounding-box
    diagonal; :class:`InputError` on an empty mesh, non-finite vertices or zero extent."""
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError("mesh: expected a non-empty trimesh.Trimesh")
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if not np.isfinite(vertices).all():
        raise InputError("mesh: contains NaN or infinite vertices")
    diag = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    if diag == 0:
        raise InputError("mesh: zero extent")
    return vertices, faces, diag


def _planar_candidates(vertices: np.ndarray, faces: np.ndarray, regions: list, *, diag: float,
                       grid: float, floor: float) -> tuple[list, list, list, np.ndarray, int]:
    """Steps 1-2: the hole-free pieces of the planar regions of at least ``floor`` area and
    :data:`MIN_FACES` faces. Returns the candidates ``(frame, exact union, piece in grid
    units)``, per candidate its region's faces and index in ``regions``, each input face's
    rank among the regions that gave pieces (-1: none) and the count of those regions."""
    cands = []  # (frame, exact union, hole-free piece in grid units)
    region_of = np.full(len(faces), -1, dtype=np.int64)  # faces of regions giving pieces
    sources = []  # per candidate, the input faces of its planar region (None: a curtain)
    cand_region = []  # per candidate, its region's index in regions (-1: a curtain)
    used = 0
    for k, reg in enumerate(regions):
        if reg.area < floor or reg.area <= 0 or len(reg.faces) < MIN_FACES:
            continue
        frame = reg.frame
        o, u, v = frame[0], frame[1], frame[2]
        local = vertices[faces[reg.faces]] - o
        xy = np.stack([local @ u, local @ v], axis=2)
        tris = shapely.polygons(xy)
        tris = tris[shapely.area(tris) > 0]
        if len(tris) == 0:
            continue
        union = shapely.union_all(tris)
        pieces = _region_pieces(union, erosion=EROSION * diag, grid=grid, floor=floor)
        if pieces is None:
            continue
        region_of[reg.faces] = used
        used += 1
        cands += [(frame, union, piece) for piece in pieces]
        sources += [reg.faces] * len(pieces)
        cand_region += [k] * len(pieces)
    return cands, sources, cand_region, region_of, used


def _add_curtains(mesh: trimesh.Trimesh, vertices: np.ndarray, faces: np.ndarray, cands: list,
                  sources: list, cand_region: list, *, up: str, diag: float, grid: float,
                  floor: float) -> dict:
    """Step 6: the pieces of the curtains under open ground appended to the candidates (no
    source faces, region -1); returns :func:`._ground_curtains.curtain_regions`' info with
    the up axis used."""
    up_name = guess_up(mesh, level=False)[0] if up == "auto" else up
    curtains, ground_info = curtain_regions(vertices, faces, up=UP_AXES.index(up_name))
    ground_info["up"] = up_name
    for frame, region in curtains:
        pieces = _region_pieces(region, erosion=EROSION * diag, grid=grid, floor=floor)
        cands += [(frame, region, piece) for piece in pieces or ()]
        sources += [None] * len(pieces or ())
        cand_region += [-1] * len(pieces or ())
    return ground_info


def _candidate_chains(cands: list, *, chain: str, grid: float
                      ) -> tuple[list, list[np.ndarray], list[np.ndarray]]:
    """Step 3: each candidate's simplification chain, its stages' values (occlusion measure,
    world units^3) and triangle counts."""
    chains, values, counts = [], [], []
    search_from = np.sort([-p.area for _, _, p in cands])[:MAX_SEARCH]
    search_from = -search_from[-1] if len(search_from) else 0.0
    for _, _, piece in cands:
        ring = _loop(piece)
        ch = refine_chain(simplification_chain(ring, loose=False), piece,
                          search=chain == "optimal" and piece.area >= search_from)
        chains.append(ch)
        # the full stage measured; the others scaled as a similar shape's (M ~ area^1.5)
        full = _stage_measure(ch.stage_ring(0)) if ch.areas[0] > 0 else 0.0
        share = np.asarray(ch.areas, dtype=np.float64) / max(float(ch.areas[0]), 1e-300)
        values.append(full * grid**3 * share**1.5)
        counts.append(np.asarray(ch.counts, dtype=np.int64))
    return chains, values, counts


@dataclass(frozen=True)
class _Output:
    """The kept stages, boxes and sheet triangles joined into the occluder (step 8 done)."""

    mesh: trimesh.Trimesh
    polygons: list
    patch_polygons: int
    area: float
    dropped: int
    curtains_kept: int
    welded: int


def _kept_output(vertices: np.ndarray, faces: np.ndarray, regions: list, cands: list,
                 chains: list, stages: np.ndarray, is_curtain: np.ndarray, cand_region: list,
                 kept_boxes: np.ndarray, sheet_faces: np.ndarray, *, grid: float, diag: float,
                 weld: str) -> _Output:
    """The occluder: each kept stage's triangles that the exact union covers, in world
    space (welded onto the input's creases with ``weld='auto'``), then the kept boxes'
    triangles, then the kept sheets' input triangles."""
    wanted = np.unique(np.array([k for k, s in zip(cand_region, stages, strict=True)
                                 if s >= 0 and k >= 0], dtype=np.int64))
    creases, planes = ({}, None) if weld == "off" or not len(wanted) else \
        _region_creases(vertices, faces, regions, grid, wanted)
    reach = EROSION * diag + 2 * grid  # a vertex of the erosion's rim, snapped
    lines: dict = {}  # each crease's line, found once for every weld below
    out_v, out_f, polygons = [], [], []
    offset = dropped = curtains_kept = welded = 0
    area = 0.0
    for (frame, union, _), ch, s, curtain, k in zip(cands, chains, stages, is_curtain,
                                                    cand_region, strict=True):
        if s < 0:
            continue
        curtains_kept += int(curtain)
        tri = ch.stage_triangles(int(s))
        if len(tri) == 0:
            continue
        xy = ch.ring * grid
        inside = shapely.covers(union, shapely.polygons(xy[tri]))
        dropped += int((~inside).sum())
        tri = tri[inside]
        if len(tri) == 0:
            continue
        used_v, inv = np.unique(tri, return_inverse=True)
        o, u, v = frame[0], frame[1], frame[2]
        pts = xy[used_v]
        world = o + pts[:, :1] * u + pts[:, 1:2] * v
        loop = ch.stage_ring(int(s)) * grid
        ring = o + loop[:, :1] * u + loop[:, 1:2] * v
        if k >= 0 and k in creases:  # onto the creases the erosion left (._crease_weld)
            moved = weld_points(world, k, creases, planes, reach=reach,  # type: ignore[arg-type]
                                lines=lines)
            moved_xy = np.stack([(moved - o) @ u, (moved - o) @ v], axis=1)
            if welded_ring(pts, moved_xy, inv.reshape(-1, 3), union, tolerance=grid):
                world, pts = moved, moved_xy
                ring = weld_points(ring, k, creases, planes, reach=reach,  # type: ignore[arg-type]
                                   lines=lines)
                welded += 1
        out_v.append(world)
        out_f.append(inv.reshape(-1, 3) + offset)
        offset += len(used_v)
        polygons.append(ring)
        area += float(shapely.area(shapely.polygons(pts[inv.reshape(-1, 3)])).sum())
    patch_polygons = len(polygons)
    if len(kept_boxes):
        box_mesh = boxes_mesh(kept_boxes)
        out_v.append(np.asarray(box_mesh.vertices))
        out_f.append(np.asarray(box_mesh.faces) + offset)
        polygons.extend(box_faces(kept_boxes))
        offset += len(box_mesh.vertices)
    if len(sheet_faces):  # the input's own triangles, its float64 vertices as they are
        used_v, inv = np.unique(faces[sheet_faces], return_inverse=True)
        out_v.append(vertices[used_v])
        out_f.append(inv.reshape(-1, 3) + offset)
        offset += len(used_v)
        polygons.extend(vertices[faces[sheet_faces]])
    if out_f:
        all_v, all_f = np.concatenate(out_v), np.concatenate(out_f)
        # no zero-area triangle (three collinear corners, which a polygon's triangulation
        # leaves along a straight edge): it covers nothing, and engines reject them
        corner = all_v[all_f]
        cross = np.linalg.norm(np.cross(corner[:, 1] - corner[:, 0],
                                        corner[:, 2] - corner[:, 0]), axis=1)
        longest = np.max(np.linalg.norm(corner - np.roll(corner, 1, axis=1), axis=2), axis=1)
        all_f = all_f[cross > _COLLINEAR * longest**2]
        occ_mesh = trimesh.Trimesh(all_v, all_f, process=False)
    else:
        occ_mesh = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64),
                                   process=False)
    return _Output(mesh=occ_mesh, polygons=polygons, patch_polygons=patch_polygons, area=area,
                   dropped=dropped, curtains_kept=curtains_kept, welded=welded)


#: The plane regions of the last mesh in this process (by content, tolerance and the
#: grouping function, so that a test's stand-in is called): a study's budgets of one
#: mesh group its faces once (the budget does not change them).
_REGIONS = ContentCache(1)


def _read_only(regions: list) -> list:
    """``regions`` with their face arrays made read-only: kept results are shared."""
    for reg in regions:
        reg.faces.flags.writeable = False
        reg.origin.flags.writeable = False
        reg.normal.flags.writeable = False
    return regions

def _whole_input(vertices: np.ndarray, faces: np.ndarray, area: np.ndarray, budget: int,
                 params: dict, diag: float, start: float) -> Occluder | None:
    """The input's own triangles when the budget holds every one of them, else None.

    No occluder within the input's surface covers more than the surface itself, and its
    own triangles are conservative from every viewpoint; so a budget of at least the
    input's (non-degenerate) triangles is spent on them as they are. A low-poly game level
    under a per-object budget is the usual case: Quake's E1M1, 14,743 triangles over 96
    occluder objects at 260 each.
    """
    keep = np.flatnonzero(area > 0)
    if len(keep) == 0 or len(keep) > budget:
        return None
    tri = vertices[faces[keep]]
    mesh = trimesh.Trimesh(vertices, faces[keep], process=False)
    mesh.remove_unreferenced_vertices()
    info = {"conservative_guaranteed": True, "whole_input": True, "regions": 0,
            "regions_used": 0, "candidates": 0, "polygons": 0, "area_kept": 1.0,
            "dropped_triangles": 0, "plane_tolerance": params["plane_tolerance"] * diag,
            "erosion": 0.0, "grid": GRID * diag, "eps": CONSERVATIVE_EPS_RELATIVE * diag,
            "closed_faces": 0, "box_candidates": 0, "boxes": 0, "boxes_guaranteed": None,
            "box_pitch": None, "empty_reason": None, "curtain_candidates": 0, "curtains": 0,
            "ground_parts": 0, "ground_parts_layered": 0, "up": None,
            "guarantee": "every viewpoint", "sheet_candidates": 0, "sheets": 0,
            "sheet_faces": int(len(keep)),
            "sheets_skipped": f"the budget {budget} holds the input's {len(keep)} triangles",
            "welded": 0, "seconds_steps": {}}
    return Occluder(mesh=mesh, method="surface-patches", params=params, double_sided=True,
                    seconds=time.perf_counter() - start, parts={"polygons": list(tri)},
                    info=info)


def _candidate_cap(budget: int | None) -> int:
    """Candidates of one kind kept, the largest first: :data:`MAX_CANDIDATES`, or the budget
    when it is larger. Every kept candidate costs a triangle at least, so a budget never
    holds more; a level's joined occluder (260 triangles per object) otherwise left most of
    its budget unspent (dust's 23 objects: 1,868 of 5,980 triangles, 400 pieces)."""
    return MAX_CANDIDATES if budget is None else max(MAX_CANDIDATES, int(budget))


def _region_creases(vertices: np.ndarray, faces: np.ndarray, regions: list, grid: float,
                    wanted: np.ndarray) -> tuple[dict, np.ndarray]:
    """The ``wanted`` regions' creases (:func:`._crease_weld.crease_lines`) and every
    region's plane ``(r, 4)``: unit normal and offset, through the region's origin."""
    face_region = np.full(len(faces), -1, dtype=np.int64)
    for k, reg in enumerate(regions):  # a loop over regions, each face in one
        face_region[reg.faces] = k
    planes = np.array([[*reg.normal, float(reg.normal @ reg.origin)] for reg in regions],
                      dtype=np.float64).reshape(-1, 4)
    return crease_lines(vertices, faces, face_region, planes, grid=grid,
                        wanted=wanted), planes


def _sheet_candidates(vertices: np.ndarray, faces: np.ndarray, area: np.ndarray,
                      closed: np.ndarray, region: np.ndarray, *, sheets: str, floor: float,
                      budget: int | None) -> tuple[list[np.ndarray], str | None]:
    """Step 7: the sheet chunks offered (face indices): those of the sheets of at least
    ``floor`` area, with no more triangles than ``budget``, the largest
    :func:`_candidate_cap` of them; and why none was looked for, or None. ``area``: each
    face's area."""
    if sheets == "off":
        return [], None
    open_faces = np.flatnonzero(~closed)
    if len(open_faces) > SHEET_MAX_FACES:
        return [], (f"sheets: its open parts have {len(open_faces):,} faces, over the "
                    f"{SHEET_MAX_FACES:,} sheets are looked for in")
    chunks = [m for sheet in sheet_chunks(vertices, faces, open_faces, region=region,
                                          area=area)
              if sum(area[m].sum() for m in sheet) >= max(floor, 1e-300)
              for m in sheet if budget is None or len(m) <= budget]
    cap = _candidate_cap(budget)
    if len(chunks) > cap:  # the largest; crumbs cost time only
        size = np.array([area[m].sum() for m in chunks])
        chunks = [chunks[i] for i in np.sort(np.argsort(-size, kind="stable")[:cap])]
    return chunks, None


def _box_candidates(vertices: np.ndarray, faces: np.ndarray, closed: np.ndarray, cands: list,
                    chains: list, grid: float, *, boxes: str, budget: int | None
                    ) -> tuple[np.ndarray, np.ndarray, dict, str]:
    """Step 5: the boxes offered to the selection, their values, the source's info (with
    ``closed_faces``) and, when there is none, why (one clause for the empty-output line).
    ``closed``: the faces of the input's closed parts (:func:`._inner_boxes.closed_parts`)."""
    none = np.zeros((0, 2, 3))
    if boxes == "off":
        return none, np.zeros(0), {}, "boxes are off"
    if budget is not None and budget < TRIANGLES_PER_BOX:
        return none, np.zeros(0), {}, f"a budget of {budget} holds no box (12 triangles)"
    counted = {"closed_faces": int(closed.sum())}
    if not closed.any():
        why = "no part of it is closed and consistently oriented (boxes need one)"
        return none, np.zeros(0), counted, why
    if box_source() is None:
        _log.warning("surface-patches: no box source registered (the registry registers "
                     "aabb-skins when viscore.generators is imported); patches only")
        return none, np.zeros(0), counted, "no box source is registered"
    max_boxes = None if budget is None else budget // TRIANGLES_PER_BOX
    corners, info = candidate_boxes(vertices, faces, closed, max_boxes=max_boxes)
    info["closed_faces"] = int(closed.sum())
    if not len(corners):
        return none, np.zeros(0), info, (f"its closed parts have no inner voxel at a pitch of "
                                         f"{info.get('pitch', float('nan')):.3g}")
    # the patch candidates, whole (stage 0), shadow the box faces behind them
    tri_v = []
    for (frame, _, _), ch in zip(cands, chains, strict=True):
        tri = ch.stage_triangles(0)
        if len(tri):
            xy = ch.ring[tri].reshape(-1, 2) * grid
            tri_v.append(frame[0] + xy[:, :1] * frame[1] + xy[:, 1:2] * frame[2])
    shadow = None
    if tri_v:
        pts = np.concatenate(tri_v)
        shadow = Scene(trimesh.Trimesh(pts, np.arange(len(pts)).reshape(-1, 3),
                                       process=False))
    return corners, unshadowed_measures(corners, shadow), info, "no box"
