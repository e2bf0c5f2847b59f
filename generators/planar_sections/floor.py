"""The precision floor of planar sections: voxel sizes checked on orbit views."""

from __future__ import annotations

import logging
import math
import threading
import time

import numpy as np
import trimesh

from viscore import InputError, get_workers
from viscore._content_cache import ContentCache, content_key
from viscore.metrics.frames import orbit_frame

from .._held_logs import held_records, release
from .._precision_check import (
    CHECK_SEED_OFFSET,
    CHECK_VIEWS,
    check_score,
    check_views,
    passes,
)
from ._single import _generate_one, _no_interior, _resolution, _section
from ._slices import VoxelBase, section_solid, solid_key, voxel_base

_log = logging.getLogger(__name__)

# The precision floor of the default sizing (``min_precision``) is DEFAULT_MIN_PRECISION of
# .._precision_check: the precision the occluder must reach on FLOOR_VIEWS orbit views of
# the mesh before the voxels are refined. The check passes when the one-sided 95% lower
# bound of the precision, P - 1.645 SE, is at or over the floor (.._precision_check.passes).

#: Orbit views of the precision floor's check (the metric's own resolution and quads),
#: drawn with a seed of their own (:data:`FLOOR_SEED_OFFSET` added to the generator's).
#: The standard error takes the views as the units: over-occlusion through the openings
#: of a building comes from a few views, and 32 views read the closed tower at P 0.9963
#: +- 0.0013 where 128 views of three other seeds read 0.990-0.992.
FLOOR_VIEWS = CHECK_VIEWS
FLOOR_SEED_OFFSET = CHECK_SEED_OFFSET

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

#: Ground fills tried under the precision floor (``ground``; :class:`._slices.GroundFill`):
#: a voxel of the fill is sliced by a plane when at most ``misses`` of the line directions
#: that see the plane expose it, a direction d seeing a plane of normal n when ``|d . n|``
#: reaches ``grazing`` (0.2: lines within 11.5 degrees of the plane, along which its
#: polygons are seen almost edge-on, are not counted). At 64^3 and 64 triangles (64 orbit
#: check views, precision and its one-sided 95% bound / recall): the warehouse with
#: grazing 0 and misses 0.05, 0.9967 (0.9956) / 0.911, with 0.2, 0.9959 (0.9945) / 0.908;
#: the terrain at 23 triangles 0.9993 / 0.417 with 0.2 and 0.05, 0.9988 / 0.408 with 0;
#: the tower passes with none (0.9954 +- 0.0021 / 0.579 at 0.2 and 0.05): its doors and
#: stair well let a few views straight through.
#: Tried in this order; a fill is skipped when the one before it with the same
#: ``grazing`` fails the floor.
GROUND_FILLS = ({"grazing": 0.0, "misses": 0.05}, {"grazing": 0.0, "misses": 0.1},
                {"grazing": 0.2, "misses": 0.05}, {"grazing": 0.2, "misses": 0.1})

#: ``ground='auto'`` tries the ground fill only on a mesh whose surface covers at least
#: this share of its footprint from above (:func:`viscore.level.ground.ground_share`: the
#: built-in terrain 1.0; a building's roof its plan) and whose voxel solid would also
#: have its closings tried (no interior, or closing grows it by :data:`AUTO_CLOSE_GAIN`).
GROUND_SHARE = 0.8

#: Voxel solids (:func:`._single._section`) a process keeps, by the mesh's content and
#: the solid's options: each budget of a mesh runs the precision floor again, on the same
#: solids (about ten a mesh: closings, ground fills, coarser and finer voxels; 64^3 bits
#: and their counts: 80 MiB for the eleven of building-house).
SOLIDS_KEPT = 12

_SOLIDS = ContentCache(SOLIDS_KEPT)


def _with_precision_floor(mesh: trimesh.Trimesh, size: dict, floor: float, seed: int,
                          options: dict, *, auto_close: bool = False, coarsen: bool = False,
                          ground: dict | None = None):
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

    ``ground`` (``{"height", "auto"}``): the ground fill is tried with each of
    :data:`GROUND_FILLS` beside the closings, and kept on the same rule;
    with ``auto``, only where the closings are tried and the footprint
    share reaches :data:`GROUND_SHARE`; without, always and alone (the plain
    solid is not a candidate).
    """
    views = check_views(mesh, seed, FLOOR_VIEWS)
    mesh_key = content_key(np.asarray(mesh.vertices), np.asarray(mesh.faces))[0]
    extent = float(np.max(mesh.extents))
    # every step's selection frame, computed once: the check views' own orbit frame (the
    # same function of the same mesh; a smallest enclosing ball over every vertex)
    orbit = (views.center, views.extent) if hasattr(views, "center") else orbit_frame(mesh)
    bases = _VoxelBases(mesh)  # each voxel size's voxelization, made once
    by_solid: dict = {}  # the runs made, by their solid: the same solid gives the same run
    by_solid_lock = threading.Lock()

    def run(size: dict, close: int, kind: dict | None = None):
        t0 = time.perf_counter()
        fill = None if kind is None else {"height": ground["height"], **kind}  # type: ignore[index]
        opts = {**options, "close": close}
        sec = _SOLIDS.get(
            (mesh_key, repr(sorted(size.items())), opts["conservative"], opts["dilate"], close,
             None if fill is None else repr(sorted(fill.items())), opts["up"]),
            lambda: _section(mesh, size, conservative=opts["conservative"],
                             dilate=opts["dilate"], close=close, ground=fill, up=opts["up"],
                             base=bases.get(size)))
        key = solid_key(sec)
        with by_solid_lock:
            earlier = by_solid.get(key)
        if earlier is not None:  # a closing or fill that adds nothing: the run made already
            (out_mesh, polygons, info), score = earlier
            result = out_mesh, polygons, {**info, "ground": None if fill is None else dict(fill)}
        else:
            result = _generate_one(mesh, size, **opts, ground=fill, sec=sec,
                                   warn_interior=not auto_close and ground is None, orbit=orbit)
            score = check_score(views, result[0])
            with by_solid_lock:
                by_solid[key] = result, score
        step = {"voxels": result[2]["voxels"], "close": close, "ground": kind,
                "triangles": len(result[0].faces), **score,
                "seconds": time.perf_counter() - t0}
        return result, step

    threads = get_workers()

    def side_by_side(calls: list[tuple]) -> list:
        """Each call's ``run(*call)`` made ahead, on up to :func:`viscore.get_workers`
        threads, as ``(result, held log records, exception)`` for :func:`use`."""
        from concurrent.futures import ThreadPoolExecutor

        def held(call: tuple):
            with held_records() as records:
                try:
                    return run(*call), records, None
                except Exception as exc:  # noqa: BLE001 - raised by use(), if it is used
                    return None, records, exc

        with ThreadPoolExecutor(max_workers=max(1, min(threads, len(calls))),
                                thread_name_prefix="viscore-floor") as pool:
            return list(pool.map(held, calls))

    def use(made: tuple):
        """A run made ahead, as if made now: its log records said, its error raised."""
        result, records, exc = made
        release(records)
        if exc is not None:
            raise exc
        return result

    def runs(calls: list[tuple]) -> list:
        """``run(*call)`` of each call, side by side on several threads."""
        if threads <= 1 or len(calls) <= 1:
            return [run(*call) for call in calls]
        return [use(made) for made in side_by_side(calls)]

    def fills(size: dict, close: int, before: tuple = ()) -> list:
        """The runs of ``before`` ((size, close, kind) calls), then the ground fills of
        :data:`GROUND_FILLS`, a fill skipped when the one before it with the same
        ``grazing`` (fewer misses: a subset of its voxels) fails the floor. On several
        threads every fill is made ahead, side by side with the others, and the rule
        then applied: the same runs are kept."""
        calls = list(before) + [(size, close, kind) for kind in GROUND_FILLS]
        ahead = side_by_side(calls) if threads > 1 else None
        out, failed = [], set()
        for i, call in enumerate(calls):
            if call[2] is not None and call[2]["grazing"] in failed:
                continue
            out.append(run(*call) if ahead is None else use(ahead[i]))
            if call[2] is not None and not passes(out[-1][1], floor):
                failed.add(call[2]["grazing"])
        return out

    close, kind = options["close"], None
    forced = ground is not None and not ground["auto"]
    if forced:
        tried = fills(size, close)
        result, step = _best(tried, floor)
    else:
        result, step = run(size, close)
        tried = [(result, step)]
    steps, results = [step], [result]
    closings = None
    gain = None
    if auto_close:
        solid = result[2]["solid_voxels"]
        closed = _SOLIDS.get(
            (mesh_key, repr(sorted(size.items())), "closed", options["dilate"],
             max(AUTO_CLOSINGS)),
            lambda: section_solid(mesh, dilate=options["dilate"], close=max(AUTO_CLOSINGS),
                                  base=bases.get(size), **size)).solid_voxels
        gain = closed / solid - 1.0 if solid else math.inf
    if gain is not None and (gain >= AUTO_CLOSE_GAIN or _no_interior(result[2])):
        closings = [(size, k, None) for k in AUTO_CLOSINGS]
        if ground is not None and not forced and result[2]["footprint_share"] >= GROUND_SHARE:
            tried += fills(size, 0, before=closings)  # type: ignore[arg-type, operator]
        else:
            tried += runs(closings)
        result, step = _best(tried, floor)
        closings = [t[1] for t in tried]
        _log.debug("planar-sections: closing adds %.0f%% to the voxel solid at %d voxels; "
                  "closings %s (ground fills %s) give check recall %s at precision %s: "
                  "close=%d, ground fill %s", 100 * gain, step["voxels"],
                  [t["close"] for t in closings], [t["ground"] for t in closings],  # type: ignore[call-overload]
                  [round(t["recall"], 3) for t in closings],  # type: ignore[arg-type, call-overload]
                  [round(t["precision"], 4) for t in closings], step["close"],  # type: ignore[arg-type, call-overload]
                  step["ground"])
        if step["close"] == 0 and step["ground"] is None and _no_interior(result[2]):
            # the plain solid kept: either no closing (nor fill) passes the floor, or
            # none that passes recalls more (a flat sheet's closings are the same solid)
            others = [t[1] for t in tried if t[1]["close"] or t[1]["ground"] is not None]
            _log.warning("planar-sections: the voxel solid has (almost) no interior at %d "
                         "voxels and no closing up to %d%s %s, so the slices are thin "
                         "strips", step["voxels"], max(AUTO_CLOSINGS),
                         "" if ground is None else " nor ground fill",
                         "recalls more than none in the precision check"
                         if any(passes(t, floor) for t in others)
                         else "passes the precision floor")
        steps, results = [step], [result]
    elif forced:
        closings = [t[1] for t in tried]
    close, kind = step["close"], step["ground"]
    if coarsen and passes(steps[-1], floor):  # spare precision: coarser voxels recall more
        # on several threads the coarser sizes are run side by side, each from the size
        # before it as predicted; a run is used only where the prediction held
        ahead, n = [], steps[-1]["voxels"]
        for _ in range(FLOOR_COARSER_STEPS if threads > 1 else 0):
            n = int(round(n / FLOOR_STEP))
            if n < FLOOR_MIN_VOXELS:
                break
            ahead.append(n)
        early = dict(zip(ahead, side_by_side(
            [(_resolution(mesh, c, None, f"voxels={c}"), close, kind) for c in ahead]),
            strict=True)) if len(ahead) > 1 else {}  # a run not used is not said
        for _ in range(FLOOR_COARSER_STEPS):
            n = steps[-1]["voxels"]
            coarser = int(round(n / FLOOR_STEP))
            if coarser < FLOOR_MIN_VOXELS:
                break
            if coarser in early:
                result, step = use(early.pop(coarser))
            else:
                result, step = run(_resolution(mesh, coarser, None, f"voxels={coarser}"),
                                   close, kind)
            steps.append(step)
            results.append(result)
            if not passes(step, floor):
                break
    for _ in range(FLOOR_MAX_STEPS):
        if any(passes(t, floor) for t in steps):
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
        result, step = run(size, close, kind)
        steps.append(step)
        results.append(result)
    ok = [i for i, t in enumerate(steps) if passes(t, floor)]
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


class _VoxelBases:
    """A mesh's :func:`._slices.voxel_base` per voxel size, each made once (from several
    threads too); whether the mesh is closed and oriented is found once."""

    def __init__(self, mesh: trimesh.Trimesh) -> None:
        self.mesh = mesh
        self._kept: dict = {}
        self._lock = threading.Lock()
        self._closed: bool | None = None

    def get(self, size: dict) -> VoxelBase:
        key = tuple(sorted(size.items()))
        with self._lock:
            kept = self._kept.get(key)
            if kept is None:
                kept = self._kept[key] = {"event": threading.Event(), "base": None}
                mine = True
            else:
                mine = False
        if mine:
            try:
                kept["base"] = voxel_base(self.mesh, closed=self._closed, **size)
                self._closed = kept["base"].closed
            finally:
                kept["event"].set()
        else:
            kept["event"].wait()
        if kept["base"] is None:  # its maker failed: make it here (and raise what it raised)
            return voxel_base(self.mesh, closed=self._closed, **size)
        return kept["base"]


def _best(tried: list, floor: float) -> tuple:
    """The (result, step) of largest check recall among those that pass, else the first."""
    ok = [t for t in tried if passes(t[1], floor)]
    return max(ok, key=lambda t: t[1]["recall"]) if ok else tried[0]


