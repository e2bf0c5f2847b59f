"""AABB skins: conservative occluders made of axis-aligned boxes inside the mesh.

The occluder-skins method of Leone et al. [1]_, sec. 4, with the box filling of
Naaji [2]_.

References
----------
.. [1] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
   Bursztyn, A. P. M. "Implementing software occlusion culling for real-time
   applications". XVIII Congreso Argentino de Ciencias de la Computacion
   (CACIC 2012), Workshop de Computacion Grafica, Imagenes y Visualizacion,
   2012. http://sedici.unlp.edu.ar/handle/10915/23640
.. [2] Naaji, K. "Automatic Occluder Generation". A Graphics Diary (blog),
   15 November 2019. http://karim.naaji.fr/automatic_occluder_geneneration.html
   (the ``melt`` library: https://github.com/karimnaaji/melt)
.. [3] Jacobson, A., Kavan, L., Sorkine-Hornung, O. "Robust inside-outside
   segmentation using generalized winding numbers". ACM Transactions on
   Graphics 32(4), 2013, article 33. :DOI:`10.1145/2461912.2461916`
"""

from __future__ import annotations

import logging
import time

import numpy as np
import trimesh

from viscore import InputError, Scene, inside_voxels_parity, voxel_grid, voxelize
from viscore._validate import as_fraction, as_positive, as_positive_int, check_memory
from viscore.voxel.grid import inside_voxels_winding
from viscore.voxel.wall_thickness import WALL_QUANTILE, wall_voxel_size
from viscore.voxel.winding import is_closed_oriented

from .._boxes import boxes_mesh
from ..occluder import Occluder
from ._growth import grow_boxes, grow_boxes_from_seeds

__all__ = ["generate_aabb_skins", "boxes_mesh"]

_log = logging.getLogger(__name__)

#: Triangles per box (12 outward faces).
TRIANGLES_PER_BOX = 12

#: Largest ``voxels`` accepted (the memory check refuses most grids below it); also
#: the most voxels along the longest side that ``voxel_sizing="auto"`` chooses.
MAX_VOXELS = 2048

#: ``voxels`` when none is given: the extent-based size, and the coarsest of
#: ``voxel_sizing="auto"``.
DEFAULT_VOXELS = 64

#: Ways of choosing the voxel size when neither ``voxels`` nor ``voxel_size`` is
#: given: from the thinnest walls that matter within the memory guard, or
#: from the extent alone (``DEFAULT_VOXELS`` along the longest side, as before).
VOXEL_SIZINGS = ("auto", "extent")


#: Peak bytes of working memory per voxel cell of :func:`generate_aabb_skins`,
#: by ``seed_voxel``, measured (peak resident set over the mesh and numba's
#: compiled code) on a closed and an open mesh at 256 and 384 voxels, with a
#: margin; the memory check multiplies it by the cell count before any work.
BYTES_PER_CELL = {"max-volume": 40, "densest": 64}


def _six_direction_distance(surface: np.ndarray) -> np.ndarray:
    """Mean over +-X, +-Y, +-Z of the distance (voxels) to the first surface voxel.

    Infinite-free: every direction that meets no surface voxel counts the
    distance to the grid border. ``surface.shape`` float32 (sums of at most
    six grid sizes over 6: exact enough to order voxels).
    """
    total = np.zeros(surface.shape, dtype=np.int32)
    for axis in range(3):
        n = surface.shape[axis]
        shape = [1, 1, 1]
        shape[axis] = n
        index = np.arange(n, dtype=np.int32).reshape(shape)
        # distance back to the last surface index at or before, plus on to the next at or after
        before = np.maximum.accumulate(np.where(surface, index, np.int32(-1)), axis=axis)
        total -= before
        del before
        after = np.flip(np.minimum.accumulate(
            np.flip(np.where(surface, index, np.int32(n)), axis), axis=axis), axis)
        total += after
        del after
    return total.astype(np.float32) / np.float32(6)


def _densest_order(enclosed: np.ndarray, surface: np.ndarray) -> np.ndarray:
    """Inner voxels ``(m, 3) int32``, deepest first: by distance to the nearest surface voxel,
    then by the six-direction mean distance, then by index."""
    from scipy import ndimage

    # scipy's distance transform holds (3,) + shape int32 features and a float64 result:
    # run it first, before the other per-cell arrays exist
    depth = ndimage.distance_transform_edt(~surface)[enclosed]
    mean6 = _six_direction_distance(surface)[enclosed]
    flat = np.flatnonzero(enclosed)[np.lexsort((-mean6, -depth))]
    del depth, mean6
    _, ny, nz = enclosed.shape
    order = np.empty((len(flat), 3), dtype=np.int32)
    order[:, 0] = flat // (ny * nz)
    order[:, 1] = flat // nz % ny
    order[:, 2] = flat % nz
    return order


def generate_aabb_skins(mesh: trimesh.Trimesh, *, voxels: int | None = None,
                        voxel_size: float | None = None, max_boxes: int | None = 16,
                        budget: int | None = None, fill: float = 0.9,
                        min_volume: float = 0.0, seed: int = 0,
                        seed_voxel: str = "max-volume",
                        voxel_sizing: str = "auto") -> Occluder:
    """Box occluder by greedy maximal-box growth, conservative on closed meshes.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Any triangle soup; the boxes are guaranteed conservative when it is
        closed and consistently oriented (see Notes).
    voxels : int, optional
        Voxels along the longest bounding-box side, 1 to 2048. Default: by
        ``voxel_sizing``.
    voxel_size : float, optional
        Voxel side in world units; overrides ``voxels`` (as the melt library does).
    max_boxes : int, optional
        Threshold 1 of Leone et al. [1]_: at most this many boxes (default 16).
    budget : int, optional
        Triangle budget; caps the boxes at ``budget // 12``.
    fill : float, optional
        Stop once the boxes cover this fraction of the inner voxels
        (Naaji [2]_), in (0, 1]. Default 0.9.
    min_volume : float, optional
        Threshold 2 of [1]_: stop at the first box smaller than this,
        world units^3, >= 0. Default 0.
    seed : int, optional
        Unused (deterministic); accepted for the common signature.
    seed_voxel : {'max-volume', 'densest'}, optional
        'max-volume' (default): each step takes the largest box over all
        inner voxels ([2]_). 'densest': grow from the densest untaken
        voxel ([1]_).
    voxel_sizing : {'auto', 'extent'}, optional
        The voxel size when neither ``voxels`` nor ``voxel_size`` is given.
        'auto': 64 voxels along the longest side, or finer where the walls
        are thinner (module docstring), within the memory guard; a few
        seconds on an open building instead of a fraction of a second (the
        inside test of open meshes evaluates the winding number at 0.5-11% of
        the voxels and bounds it at the rest,
        :func:`viscore.voxel.grid.inside_voxels_winding`).
        'auto' is the default. 'extent': 64 voxels along the longest side.

    Returns
    -------
    Occluder
        ``parts["boxes"]``: ``(k, 2, 3)`` world-space corners. ``info``:

        - ``inside``: where the inner voxels come from: ``'winding-number'``
          (closed, consistently oriented mesh), else the candidates tested by
          the winding number at their centres, ``'flood-fill'`` or
          ``'ray-parity'`` (the fill leaks through holes);
        - ``closed_oriented`` (bool): the mesh is closed and consistently
          oriented (:func:`viscore.voxel.winding.is_closed_oriented`);
        - ``conservative_guaranteed`` (bool): see Notes; equal to
          ``closed_oriented``;
        - ``inner_voxels``, ``covered_voxels``: counts;
        - ``cavity_voxels``: enclosed voxels (flood-fill interior, or the
          ray-parity inside) that the winding number puts outside the mesh:
          cavities, sealed by the voxelization or not, and kept box-free;
        - ``fill``: covered share of the inner voxels;
        - ``volume_share``: box volume / mesh volume (/ inner-voxel volume
          when the mesh is not closed);
        - ``boxes``, ``pitch`` (world units);
        - ``voxel_sizing``: how the pitch was chosen: ``'voxel_size'``,
          ``'voxels'``, ``'extent'`` or ``'auto'``; with 'auto' also
          ``wall_sizing``: ``wall_quantile`` (the 20% area quantile of the
          wall thickness, world units, None when no wall), ``wall_pitch``
          (the voxel those walls ask for), ``extent_pitch``,
          ``wall_share`` (area share whose inward ray found a wall),
          ``resolved_share`` (share of the wall area that surely holds inner
          voxels at ``pitch``) and ``limited`` (the memory guard made the
          voxels coarser than the walls ask).

    Raises
    ------
    InputError
        On bad thresholds, an empty mesh, or a voxel grid from ``voxels`` or
        ``voxel_size`` whose estimated memory (:data:`BYTES_PER_CELL` per
        cell) exceeds the limit of :func:`viscore._validate.check_memory`;
        checked before any work. The 'auto' size falls back to the finest
        grid that fits instead (one warning says so).

    Notes
    -----
    Deterministic. May end with fewer boxes than allowed, or none when the
    mesh has no inner voxel at this resolution (thin or flat input, walls
    thinner than the memory guard lets the voxels be).

    ``conservative_guaranteed`` is True exactly when the mesh is closed and
    consistently oriented: after merging vertices at equal positions, every
    edge is used as often in one direction as in the other (watertight in
    the oriented sense; edges shared by four faces and self-intersections
    are allowed). Then the winding number is an integer, constant on every
    connected region off the surface; each box is a union of voxels that no
    triangle touches (closed-cube overlap test, touching counts) lying in a
    region of non-zero winding number. A segment from any point outside the
    mesh (winding number 0: the outside, a cavity, a room behind a door
    narrower than a voxel) to a box therefore crosses a triangle first: no
    ray from outside the mesh hits a box before the mesh, up to float
    rounding (the overlap test widens voxels by 1e-9 of the pitch; Embree
    traces in float32). For any other mesh nothing is guaranteed.

    References
    ----------
    .. [1] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
       Bursztyn, A. P. M. "Implementing software occlusion culling for
       real-time applications". CACIC 2012, WCGIV, 2012.
       http://sedici.unlp.edu.ar/handle/10915/23640
    .. [2] Naaji, K. "Automatic Occluder Generation". A Graphics Diary, 2019.
       http://karim.naaji.fr/automatic_occluder_geneneration.html

    Examples
    --------
    >>> occ = generate_aabb_skins(trimesh.creation.box(extents=(2, 1, 1)), voxels=16)
    >>> occ.info["boxes"], occ.triangles, occ.info["conservative_guaranteed"]
    (1, 12, True)
    """
    start = time.perf_counter()
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError("mesh: expected a non-empty trimesh.Trimesh")
    if seed_voxel not in ("max-volume", "densest"):
        raise InputError(f"seed_voxel: expected 'max-volume' or 'densest', got {seed_voxel!r}")
    fill = as_fraction(fill, "fill", open_low=True)
    try:
        min_volume = float(min_volume)
    except (TypeError, ValueError) as exc:
        raise InputError(f"min_volume: expected a number >= 0, got {min_volume!r}") from exc
    if not np.isfinite(min_volume) or min_volume < 0:
        raise InputError(f"min_volume: expected a finite number >= 0, got {min_volume}")
    cap = 10**9 if max_boxes is None else as_positive_int(max_boxes, "max_boxes")
    if budget is not None:
        budget = as_positive_int(budget, "budget")
        if budget < TRIANGLES_PER_BOX:
            raise InputError(f"budget: at least {TRIANGLES_PER_BOX} triangles (one box), "
                             f"got {budget}")
        cap = min(cap, budget // TRIANGLES_PER_BOX)
    if voxel_sizing not in VOXEL_SIZINGS:
        raise InputError(f"voxel_sizing: expected one of {', '.join(VOXEL_SIZINGS)}, got "
                         f"{voxel_sizing!r}")
    wall_sizing = None
    if voxel_size is not None:
        voxel_size = as_positive(voxel_size, "voxel_size")
        size, what, sizing = {"pitch": voxel_size}, f"voxel_size={voxel_size:g}", "voxel_size"
    elif voxels is not None or voxel_sizing == "extent":
        sizing = "voxels" if voxels is not None else "extent"
        voxels = as_positive_int(DEFAULT_VOXELS if voxels is None else voxels, "voxels",
                                 maximum=MAX_VOXELS)
        size, what = {"resolution": voxels}, f"voxels={voxels}"
    else:
        sizing = "auto"
        chosen = wall_voxel_size(mesh, bytes_per_cell=BYTES_PER_CELL[seed_voxel],
                                 resolution=DEFAULT_VOXELS, quantile=WALL_QUANTILE,
                                 max_resolution=MAX_VOXELS, what="aabb-skins",
                                 finer="voxel-size")
        _log.log(chosen.log_level, "%s", chosen.reason)
        wall_sizing = chosen.info
        size, what = {"pitch": chosen.pitch}, f"voxel_size={chosen.pitch:g} (auto)"
    grid = voxel_grid(np.asarray(mesh.bounds), **size)
    cells = float(np.prod(np.array(grid.shape, dtype=np.float64)))
    check_memory(cells * BYTES_PER_CELL[seed_voxel], f"aabb-skins: {what} "
                 f"({grid.shape[0]} x {grid.shape[1]} x {grid.shape[2]} voxels)")

    closed = is_closed_oriented(mesh.vertices, mesh.faces)
    vox = voxelize(mesh, **size)
    flood = vox.solid & ~vox.surface  # the flood fill's interior, cavities included
    if closed:
        inside = "winding-number"
        enclosed = inside_voxels_winding(mesh.vertices, mesh.faces, vox.grid, vox.surface,
                                         closed=True)
        candidates = flood
    else:
        inside, candidates = "flood-fill", flood
        if vox.leaks or not mesh.is_watertight:
            parity = inside_voxels_parity(Scene(mesh), vox.grid) & ~vox.surface
            if parity.sum() > candidates.sum():
                inside, candidates = "ray-parity", parity
                _log.info("aabb-skins: the inner voxels leak (open mesh); taking candidates "
                          "from ray-parity votes")
        enclosed = inside_voxels_winding(mesh.vertices, mesh.faces, vox.grid, vox.surface,
                                         candidates=candidates, closed=False)
        _log.warning("aabb-skins: %s is not closed and consistently oriented; boxes may show "
                     "through holes or gaps narrower than a voxel (run 'viscore validate')",
                     mesh.metadata.get("name", "mesh"))
    cavity = int((candidates & ~enclosed).sum())
    del flood, candidates
    inner = int(enclosed.sum())
    pitch = vox.grid.pitch
    # at least one box for any fill > 0 (fill * inner rounds to 0 below 1 / inner)
    target = max(1, int(np.ceil(fill * inner - 1e-9))) if inner else 0
    cap = min(cap, inner)  # never more boxes than inner voxels
    with np.errstate(over="ignore", under="ignore"):  # a huge pitch: inf, and no inner voxel
        cell_volume = float(np.float64(pitch) ** 3)
    # in voxels, capped at inner + 1 (no box can reach it) so that numba gets an int64
    with np.errstate(divide="ignore"):
        ratio = float(np.float64(min_volume) / cell_volume) if min_volume > 0 else 0.0
    min_voxels = 1 if ratio <= 1 else int(min(np.ceil(ratio - 1e-9), inner + 1))
    if not cap:
        raw = np.zeros((0, 6), np.int64)
    elif seed_voxel == "densest":
        raw = grow_boxes_from_seeds(enclosed, _densest_order(enclosed, vox.surface), cap,
                                    min_voxels, target)
    else:
        raw = grow_boxes(enclosed, cap, min_voxels, target)
    corners = np.stack([vox.grid.corner(raw[:, :3]), vox.grid.corner(raw[:, 3:])], axis=1)
    covered = int(np.prod(raw[:, 3:] - raw[:, :3], axis=1).sum())
    out = boxes_mesh(corners)
    # share of the mesh volume; of the inner-voxel volume when the mesh has no volume
    with np.errstate(divide="ignore", invalid="ignore"):  # trimesh's centre of a flat mesh
        solid_volume = abs(float(mesh.volume)) if closed else inner * cell_volume
    volume_share = (float(covered * cell_volume / solid_volume)
                    if covered and solid_volume > 0 else 0.0)
    return Occluder(
        mesh=out, method="aabb-skins", double_sided=False, seconds=time.perf_counter() - start,
        params={"voxels": voxels if voxel_size is None else None, "voxel_size": voxel_size,
                "max_boxes": max_boxes, "budget": budget, "fill": fill,
                "min_volume": min_volume, "seed_voxel": seed_voxel,
                "voxel_sizing": voxel_sizing},
        parts={"boxes": corners},
        info={"inside": inside, "closed_oriented": closed, "conservative_guaranteed": closed,
              "inner_voxels": inner, "covered_voxels": covered, "cavity_voxels": cavity,
              "fill": covered / inner if inner else 0.0, "volume_share": volume_share,
              "boxes": len(raw), "pitch": pitch, "voxel_sizing": sizing,
              **({"wall_sizing": wall_sizing} if wall_sizing is not None else {})})
