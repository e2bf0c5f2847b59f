"""One planar-sections occluder at one voxel size (Silvennoinen et al. 2014, sec. 4)."""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import dataclass, field

import numpy as np
import trimesh

from viscore import InputError, voxel_grid
from viscore._content_cache import ContentCache
from viscore._validate import (
    check_memory,
)
from viscore.metrics.orbit import orbit_frame

from .._polygon_chain import refine_chain, simplification_chain
from .._soup_measure import measure_bases
from . import _slices
from ._loops import slice_polygons
from ._select import (
    MEASURE_DIRECTIONS,
    MEASURE_RESOLUTION,
    GreedySearch,
    measure_directions,
    project_candidates,
    reduce_to_budget,
)
from ._slices import best_slices, section_solid, slice_image, solid_key

_log = logging.getLogger(__name__)

#: Largest voxel count along the longest side (the memory check refuses most grids below).
MAX_VOXELS = 1024

#: Candidate polygons kept for the greedy search, largest first (its cost grows
#: with their number; a tangle such as the hairball gives thousands of small ones).
MAX_CANDIDATES = 160

#: Solids whose candidates (:class:`_Candidates`: at most 160 x 24 x 64 x 64 bits of
#: bitmaps, 16 MB, each) a process keeps: a mesh's precision floor slices up to about ten.
CANDIDATES_KEPT = 12

#: Bytes per voxel cell of the whole generation: the voxelization's working
#: memory (:data:`viscore.voxel.grid.VOXELIZE_BYTES_PER_CELL`, 24) and the solid,
#: its erosion and the winding-number labels of the conservative variant.
BYTES_PER_CELL = 40

#: A voxel solid has "no interior" when it has fewer than :data:`INTERIOR_SHARE` times
#: its surface voxels (an open sheet, or a shell with openings wider than a voxel) and
#: under :data:`ERODED_SHARE` of it survives a one-voxel erosion (at 64^3: bunny 0.86,
#: airplane 0.49, a dense tangle of strands whose surface voxels fill the ball 0.71; the
#: open-bottomed buildings 0.03-0.25, terrain 0.03).
INTERIOR_SHARE = 1.1
ERODED_SHARE = 0.5

def _no_interior(info: dict) -> bool:
    """Whether the voxel solid described by ``info`` has (almost) no interior."""
    return (info["solid_voxels"] < INTERIOR_SHARE * info["surface_voxels"]
            and info["interior_voxels"] < ERODED_SHARE * info["solid_voxels"])


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


def _section(mesh: trimesh.Trimesh, size: dict, *, conservative: bool = False,
             dilate: int = 0, close: int = 0, ground: dict | None = None, up: str = "z",
             base=None) -> _slices.SectionSolid:
    """:func:`._slices.section_solid` of one run: ``ground`` None, or ``{"height",
    "misses", "grazing"}`` for its ``ground``, ``ground_misses`` and ``ground_grazing``;
    ``base`` the mesh's :func:`._slices.voxel_base` at ``size`` when the caller has it."""
    g = {} if ground is None else {"ground": ground["height"], "ground_misses": ground["misses"],
                                   "ground_grazing": ground.get("grazing", 0.0)}
    return section_solid(mesh, conservative=conservative, dilate=dilate, close=close, up=up,
                         base=base, **g, **size)


@dataclass(frozen=True, eq=False)
class _Candidates:
    """What one solid's occluder is made from at every budget (sec. 4.2-4.4): the slices'
    candidate polygons, their simplification chains and their measure bitmaps; with the
    greedy search over them (:class:`._select.GreedySearch`) and the chains refined for
    the chosen ones, each made once and taken further as larger budgets ask."""

    slices: int
    cands: list
    chains: tuple
    bitmaps: np.ndarray
    dirs: np.ndarray
    bases: tuple
    mpixel: float
    timing: dict
    _searches: dict = field(default_factory=dict, repr=False)
    _refined: dict = field(default_factory=dict, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)
    _polygon_locks: dict = field(default_factory=dict, repr=False)

    @classmethod
    def make(cls, sec: _slices.SectionSolid, direction_bins: int, depth_bins: int,
             tolerance: float | None, conservative: bool, center: np.ndarray,
             frame: float) -> _Candidates:
        timing = {}
        t0 = time.perf_counter()
        slices = best_slices(sec, direction_bins, depth_bins)
        timing["slices"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        cands, chains = [], []
        for s in slices:
            for poly in slice_polygons(slice_image(sec, s), tolerance=tolerance):
                cands.append((s, poly))
                chains.append(simplification_chain(poly.ring, loose=not conservative))
        if len(cands) > MAX_CANDIDATES:  # the largest polygons; crumbs of tangles cost time
            keep = np.argsort([-ch.areas[0] for ch in chains], kind="stable")[:MAX_CANDIDATES]
            cands = [cands[i] for i in keep]
            chains = [chains[i] for i in keep]
        timing["polygons"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        dirs = measure_directions(MEASURE_DIRECTIONS)
        bases = measure_bases(dirs)  # the image axes of every projection below, found once
        rings = [s.to_world(p.ring) for s, p in cands]
        bitmaps = project_candidates(rings, dirs, center, frame, MEASURE_RESOLUTION,
                                     bases=bases)
        timing["projections"] = time.perf_counter() - t0
        return cls(len(slices), cands, tuple(chains), bitmaps, dirs, bases,
                   frame / MEASURE_RESOLUTION, timing)

    def greedy(self, alpha: float, measure: str) -> GreedySearch:
        """The one greedy search of these candidates with these settings."""
        with self._lock:
            key = (float(alpha), measure)
            if key not in self._searches:
                self._searches[key] = GreedySearch(self.bitmaps, self.mpixel, alpha=alpha,
                                                   measure=measure)
            return self._searches[key]

    def refined(self, i: int, search: bool):
        """:func:`refine_chain` of candidate ``i``'s chain, made once.

        One thread at a time refines a candidate: its shapely polygon is shared, and
        GEOS aborts the process when two threads prepare or query one prepared
        geometry at once (the precision floor's threads slice the same solid)."""
        with self._lock:
            kept = self._refined.get((i, search))
            lock = self._polygon_locks.setdefault(i, threading.Lock())
        if kept is None:
            with lock:
                kept = self._refined.get((i, search))
                if kept is None:
                    kept = refine_chain(self.chains[i], self.cands[i][1].polygon,
                                        search=search)
                    with self._lock:
                        self._refined[(i, search)] = kept
        return kept


#: The candidates of the last solids generated in this process (the budgets of one mesh,
#: and the precision floor's runs at each budget, slice the same solids).
_CANDIDATES = ContentCache(CANDIDATES_KEPT)


def _generate_one(mesh: trimesh.Trimesh, size: dict, *, budget, direction_bins, depth_bins,
                  alpha, measure, reduce, rdp_tolerance, chain, conservative, dilate,
                  close, ground: dict | None = None, up: str = "z",
                  warn_interior: bool = True, orbit: tuple | None = None, base=None,
                  sec: _slices.SectionSolid | None = None):
    """One level of detail: (mesh, polygons, info).

    ``ground``: None, or ``{"height", "misses", "grazing"}`` for
    :func:`._slices.section_solid`'s ``ground``, ``ground_misses`` and
    ``ground_grazing``; ``up``
    its up axis (also the axis of ``info["footprint_share"]``).

    ``orbit`` is the mesh's :func:`~viscore.metrics.orbit_frame` when the caller
    already has it (the precision floor generates up to seven times per mesh; the
    frame is a minimum enclosing ball over every vertex, seconds on a scan).
    ``base`` is the mesh's :func:`._slices.voxel_base` at ``size`` and ``sec`` the
    solid itself (:func:`_section` with these options), when the caller has them.
    """
    timing = {}
    t0 = time.perf_counter()
    if sec is None:
        sec = _section(mesh, size, conservative=conservative, dilate=dilate, close=close,
                       ground=ground, up=up, base=base)
    pitch = sec.grid.pitch
    extent = float(np.max(mesh.extents))
    info = {"voxel_size": pitch, "voxels": int(math.ceil(extent / pitch - 1e-9)),
            "grid": list(sec.grid.shape), "direction_bins": direction_bins,
            "depth_bins": depth_bins, "solid_voxels": sec.solid_voxels,
            "surface_voxels": sec.surface_voxels, "interior_voxels": sec.interior_voxels,
            "closed_oriented": sec.closed_oriented,
            "conservative_guaranteed": bool(conservative and sec.closed_oriented),
            "footprint_share": sec.footprint_share,
            "ground": None if ground is None else dict(ground)}
    if conservative and not sec.closed_oriented:
        _log.warning("planar-sections: the mesh is not closed and consistently oriented; "
                     "--conservative cannot guarantee anything (run 'viscore validate')")
    if warn_interior and not conservative and not close and ground is None and _no_interior(
            info):
        _log.warning("planar-sections: the voxel solid has (almost) no interior at %d voxels "
                     "(an open sheet, or a surface with openings), so the slices are thin "
                     "strips; for an object with holes, close them with --close 3 (or more "
                     "voxels)", info["voxels"])
    timing["voxels"] = time.perf_counter() - t0

    center, frame = orbit if orbit is not None else orbit_frame(mesh)
    tolerance = None if conservative else rdp_tolerance * _slices.PIXELS_PER_VOXEL
    key = (solid_key(sec), np.asarray(center, np.float64), float(frame), direction_bins,
           depth_bins, tolerance, bool(conservative))
    found = _CANDIDATES.get(key, lambda: _Candidates.make(
        sec, direction_bins, depth_bins, tolerance, conservative, center, frame))
    timing.update(found.timing)  # the steps' times when they were made
    cands, chains, bitmaps = found.cands, list(found.chains), found.bitmaps
    dirs, bases, mpixel = found.dirs, found.bases, found.mpixel
    info.update(slices=found.slices, candidates=len(cands))
    t0 = time.perf_counter()
    chosen, totals = found.greedy(alpha, measure).result(budget)
    timing["greedy"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    search = chain == "optimal" and budget is not None
    for i in chosen:  # stages inside the candidate; the largest ones for chain='optimal'
        chains[i] = found.refined(int(i), search)
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
                                               MEASURE_RESOLUTION, bases=bases)[0]
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
