"""Scene culling simulation: objects culled per frame along a camera path, against ray-cast truth.

As Papaioannou et al. 2006 [1]_ (sec. 4, Tables 1-2, Figs. 5-6) count primitives
rendered per frame, with the shadow frusta of Hudson et al. 1997 [2]_.

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006 (Plzen), UNION Agency,
   ISBN 80-86943-03-8 (sec. 4, Tables 1-2, Figures 5-6).
.. [2] Hudson, T., Manocha, D., Cohen, J., Lin, M., Hoff, K., Zhang, H.
   "Accelerated Occlusion Culling using Shadow Frusta". 13th ACM Symposium on
   Computational Geometry, 1997, pp. 1-10.
.. [3] "Occluder Skins" (occluder generation from axis-aligned boxes for a
   hierarchical-occlusion-map culler; authors and venue not in the text we
   have), sec. 5-6 (depth buffer generation, testing the occludees).
.. [4] Politis, D. N., Romano, J. P. "A Circular Block-Resampling Procedure
   for Stationary Data". In: LePage, R., Billard, L. (eds.), Exploring the
   Limits of Bootstrap, Wiley, 1992, pp. 263-270.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from viscore import InputError, cpu_cores
from viscore._validate import as_positive_int, check_memory
from viscore.constants import RAY_STEP_RELATIVE

from .bootstrap import BOOTSTRAP_RESAMPLES, block_bootstrap_ratio, block_length

# kept for old import paths: the camera paths, the runtimes and the plot moved to
# modules of their own
from .camera_paths import (
    DEFAULT_FOV,
    PathCamera,
    camera_path,
    camera_path_json,
    check_camera_path,
    read_camera_path,
)
from .culling_runtimes import (
    Runtime,
    depth_buffer_runtime,
    frusta_runtime,
    no_culling,
    view_frustum_mask,
)
from .plots import culling_plot

if TYPE_CHECKING:  # pragma: no cover - hints only
    from viscore.level.scene_graph import SceneObjects

__all__ = ["RuntimeFrames", "CullingResult", "simulate_culling", "check_culling_memory",
           "visible_objects", "FrameObjects", "CULLING_CONFIDENCE",
           "DEFAULT_WIDTH", "DEFAULT_HEIGHT",
           # kept for old import paths (defined in .camera_paths, .culling_runtimes, .plots)
           "PathCamera", "camera_path", "read_camera_path", "camera_path_json",
           "check_camera_path", "DEFAULT_FOV", "Runtime", "no_culling", "frusta_runtime",
           "depth_buffer_runtime", "view_frustum_mask", "culling_plot"]

_log = logging.getLogger(__name__)


#: Ground-truth image size, pixels (the issue's default: 1280 x 720).
DEFAULT_WIDTH, DEFAULT_HEIGHT = 1280, 720

#: Two-sided level of the intervals on the walk's shares.
CULLING_CONFIDENCE = 0.95

#: Peak bytes per ground-truth pixel: the rays (origins and directions, float64
#: and their float32 chunks), the hit distances and triangle ids.
_BYTES_PER_PIXEL = 200


# --------------------------------------------------------------------------- simulation
def check_culling_memory(width: int, height: int) -> tuple[int, int]:
    """Check a ground-truth image size and that its rays fit in memory, before any work.

    Returns
    -------
    width, height : int

    Raises
    ------
    InputError
        A size that is not an integer in [1, 16384], or rays that do not fit
        (:func:`viscore._validate.check_memory`).
    """
    width = as_positive_int(width, "width", maximum=16384)
    height = as_positive_int(height, "height", maximum=16384)
    check_memory(float(width) * height * _BYTES_PER_PIXEL,
                 f"ground truth at {width} x {height} pixels")
    return width, height


@dataclass(frozen=True, eq=False)
class RuntimeFrames:
    """Per-frame figures of one runtime.

    Attributes
    ----------
    culled : (F,) int64
        Objects culled by the runtime, beyond view frustum culling.
    false_culls : (F,) int64
        Culled objects that the ground truth sees (>= 1 pixel).
    triangles_rendered : (F,) int64
        Triangles of the objects sent to render (in view, not culled).
    overhead_ms : (F,) float64
        Wall time of the runtime's ``cull`` call, milliseconds.
    conservative : bool
        The runtime's :attr:`Runtime.conservative`.
    false_cull_names : tuple of tuple of str
        Per frame, the names of the first (at most 10) falsely culled objects.
    """

    culled: np.ndarray
    false_culls: np.ndarray
    triangles_rendered: np.ndarray
    overhead_ms: np.ndarray
    conservative: bool
    false_cull_names: tuple = ()


@dataclass(frozen=True, eq=False)
class FrameObjects:
    """Which objects one frame had in view, the truth saw and each runtime culled.

    Kept by :func:`simulate_culling` for the frames named in ``keep_frames``
    (the frames a report draws).

    Attributes
    ----------
    in_view : (k,) int64
        Objects that survive view frustum culling, ascending.
    visible : (v,) int64
        Objects the ray-cast truth sees (at least one pixel), ascending.
    culled : dict of str -> (c,) int64
        Per runtime, the objects it culled (a subset of ``in_view``), ascending.
    """

    in_view: np.ndarray
    visible: np.ndarray
    culled: dict


@dataclass(frozen=True, eq=False)
class CullingResult:
    """The simulation's figures per frame and runtime, with the ground truth.

    Attributes
    ----------
    cameras : tuple of PathCamera
        (F,) the path.
    width, height : int
        Ground-truth image size, pixels.
    objects, triangles : int
        Objects in the scene and their triangles (instances counted each time).
    in_view : (F,) int64
        Objects that survive view frustum culling, per frame.
    in_view_triangles : (F,) int64
        Their triangles (what the ``none`` runtime renders).
    visible : (F,) int64
        Objects with at least one pixel in the ray-cast object-id image.
    visible_triangles : (F,) int64
        Their triangles (what an exact occlusion culler would render).
    runtimes : dict of str -> RuntimeFrames
        Per runtime name (``none``, ``planar-frusta``, ``solid-frusta``,
        ``depth-buffer:<method>``, ...), in the order given.
    kept : dict of int -> FrameObjects
        The objects of the frames named in ``keep_frames`` (default none).
    stances : tuple of Stance
        Where each camera stands (:func:`viscore.metrics.camera_paths.camera_stances`),
        one per camera, or empty when not given.
    """

    cameras: tuple
    width: int
    height: int
    objects: int
    triangles: int
    in_view: np.ndarray
    in_view_triangles: np.ndarray
    visible: np.ndarray
    visible_triangles: np.ndarray
    runtimes: dict = field(default_factory=dict)
    kept: dict = field(default_factory=dict)
    stances: tuple = ()

    def interval_block(self) -> int:
        """Frames per block of the intervals' bootstrap: the longest of
        :func:`~viscore.metrics.bootstrap.block_length` over the walk's shares (the
        truth's hidden share and each runtime's culled share), so that one resampling
        of the walk serves them all."""
        in_view = self.in_view.astype(np.float64)
        if (in_view > 0).sum() < 2:
            return 1
        series = [self.in_view - self.visible] + [rf.culled for rf in self.runtimes.values()]
        return max(block_length(np.asarray(x, np.float64), in_view) for x in series)

    def totals(self, *, seed: int = 0, block: int | None = None) -> dict[str, dict]:
        """Per runtime: totals over the path, with 95% intervals (see :meth:`to_json`).

        ``culled_share_ci`` and ``triangles_rendered_per_frame_ci`` are circular
        block bootstrap intervals over the frames
        (:func:`~viscore.metrics.bootstrap.block_bootstrap_ratio`), every runtime
        resampled alike (one ``seed``, one ``block``: default
        :meth:`interval_block`).
        """
        out = {}
        in_view = int(self.in_view.sum())
        frames = max(1, len(self.cameras))
        block = self.interval_block() if block is None else block
        ones = np.ones(len(self.cameras))
        for name, rf in self.runtimes.items():
            culled = int(rf.culled.sum())
            out[name] = {
                "culled": culled,
                "culled_share": culled / in_view if in_view else 0.0,
                "culled_share_ci": self._interval(rf.culled, self.in_view, seed, block),
                "false_culls": int(rf.false_culls.sum()),
                "frames_with_false_culls": int((rf.false_culls > 0).sum()),
                "triangles_rendered": int(rf.triangles_rendered.sum()),
                "triangles_rendered_per_frame": float(rf.triangles_rendered.sum()) / frames,
                "triangles_rendered_per_frame_ci": self._interval(rf.triangles_rendered, ones,
                                                                  seed, block),
                "overhead_ms": float(rf.overhead_ms.mean()) if len(rf.overhead_ms) else 0.0,
                "overhead_ms_max": float(rf.overhead_ms.max()) if len(rf.overhead_ms) else 0.0,
                "conservative": bool(rf.conservative),
            }
        return out

    @staticmethod
    def _interval(num, den, seed: int, block: int) -> list[float]:
        """[low, high] of sum(num) / sum(den) by the block bootstrap over frames."""
        num = np.asarray(num, dtype=np.float64)
        return list(block_bootstrap_ratio(num, np.asarray(den, dtype=np.float64),
                                          block=min(block, max(1, len(num))),
                                          confidence=CULLING_CONFIDENCE, seed=seed))

    def to_json(self, *, seed: int = 0) -> dict:
        """The JSON document: ``frames``, ``totals``, ``ground_truth``, ``settings``, ``intervals``.

        ``frames`` holds one entry per frame: ``frame`` (index), ``camera``
        (position, forward, up, fov), ``in_view``, ``visible`` and
        ``visible_triangles`` (ground truth), and one entry per runtime name
        with ``culled``, ``culled_share`` (of the objects in view),
        ``false_culls``, ``triangles_rendered`` and ``overhead_ms`` (and
        ``false_cull_objects``, the first names, when there are any), and
        ``stance`` (where the camera stands: :meth:`Stance.to_json`) when known.
        ``totals`` holds one entry per runtime name: ``culled`` (sum over the
        frames), ``culled_share`` (of the objects in view, over all frames),
        ``false_culls`` (sum), ``frames_with_false_culls``,
        ``triangles_rendered`` (sum) and ``triangles_rendered_per_frame``
        (mean), ``overhead_ms`` (mean per frame) and ``overhead_ms_max``, and
        ``conservative``, with ``culled_share_ci`` and
        ``triangles_rendered_per_frame_ci``. ``ground_truth`` holds the same
        sums for an exact culler (only the visible objects rendered), with
        ``hidden_share_ci``. ``intervals`` says how the intervals were made:
        ``method`` (the circular block bootstrap over frames, Politis and Romano
        1992), ``confidence``, ``block`` (frames per block, :meth:`interval_block`),
        ``resamples`` and ``seed`` (the one given here).
        """
        frames = []
        for k, cam in enumerate(self.cameras):
            entry = {"frame": k, "camera": cam.to_json(), "in_view": int(self.in_view[k]),
                     "visible": int(self.visible[k]),
                     "visible_triangles": int(self.visible_triangles[k])}
            if self.stances:
                entry["stance"] = self.stances[k].to_json()
            for name, rf in self.runtimes.items():
                n = int(self.in_view[k])
                entry[name] = {"culled": int(rf.culled[k]),
                               "culled_share": int(rf.culled[k]) / n if n else 0.0,
                               "false_culls": int(rf.false_culls[k]),
                               "triangles_rendered": int(rf.triangles_rendered[k]),
                               "overhead_ms": float(rf.overhead_ms[k])}
                if rf.false_cull_names and rf.false_cull_names[k]:
                    entry[name]["false_cull_objects"] = list(rf.false_cull_names[k])
            frames.append(entry)
        in_view = int(self.in_view.sum())
        hidden = in_view - int(self.visible.sum())
        block = self.interval_block()
        return {
            "settings": {"frames": len(self.cameras), "width": self.width, "height": self.height,
                         "objects": self.objects, "triangles": self.triangles},
            "frames": frames,
            "totals": self.totals(seed=seed, block=block),
            "ground_truth": {
                "in_view": in_view, "visible": int(self.visible.sum()),
                "hidden_share": hidden / in_view if in_view else 0.0,
                "hidden_share_ci": self._interval(self.in_view - self.visible, self.in_view,
                                                  seed, block),
                "triangles_in_view": int(self.in_view_triangles.sum()),
                "triangles_visible": int(self.visible_triangles.sum()),
            },
            "intervals": {"method": "circular block bootstrap over frames",
                          "confidence": CULLING_CONFIDENCE, "block": block,
                          "resamples": BOOTSTRAP_RESAMPLES, "seed": seed},
        }


def _check_bounds(bounds, n: int) -> tuple:
    """``bounds`` of :func:`simulate_culling` as arrays, checked: one line on a mismatch."""
    try:
        lower, upper, owner, *rest = bounds
    except (TypeError, ValueError):
        raise InputError("bounds: expected (lower, upper, owner)") from None
    if len(rest) > 1:
        raise InputError("bounds: expected (lower, upper, owner) or (lower, upper, owner, "
                         "triangles)")
    lower = np.asarray(lower, dtype=np.float64)
    upper = np.asarray(upper, dtype=np.float64)
    owner = np.asarray(owner)
    c = len(owner)
    if (lower.shape != (c, 3) or upper.shape != (c, 3) or owner.ndim != 1
            or not np.issubdtype(owner.dtype, np.integer)):
        raise InputError(f"bounds: expected (c, 3) lower and upper and (c,) integer owner, "
                         f"got {lower.shape}, {upper.shape} and {owner.shape}")
    if not np.isfinite(lower).all() or not np.isfinite(upper).all() or (lower > upper).any():
        raise InputError("bounds: boxes must be finite with lower <= upper")
    if c == 0 or owner[0] < 0 or owner[-1] >= n or (np.diff(owner) < 0).any():
        raise InputError(f"bounds: owner must be non-decreasing object indices in [0, {n})")
    if rest:
        tri = np.asarray(rest[0], dtype=np.float64)
        if tri.shape != (c, 3, 3) or not np.isfinite(tri).all():
            raise InputError(f"bounds: expected finite ({c}, 3, 3) triangles, got "
                             f"{tri.shape}")
        return lower, upper, owner.astype(np.int64), tri
    return lower, upper, owner.astype(np.int64)


#: Most see-through surfaces a truth ray passes before it stops (glass panes, water
#: layers, leaves): far more than a level stacks in front of anything.
MAX_SEE_THROUGH_LAYERS = 64


def visible_objects(scene, triangle_object: np.ndarray, see_through: np.ndarray,
                    origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Which objects the rays see: ``(n,) bool``, True for at least one ray.

    Each ray stops at its first hit on an opaque object; a see-through object
    (``see_through``: glass, water, cut-out leaves) it meets before that is
    seen and passed, the ray going on ``RAY_STEP_RELATIVE`` x the scene's
    diagonal past it, for at most :data:`MAX_SEE_THROUGH_LAYERS` such surfaces
    (a ray still going then stops, seeing nothing more). Without see-through
    objects this is one first-hit pass.

    Parameters
    ----------
    scene : Scene
        Every object in one Embree scene (``SceneObjects.combined``).
    triangle_object : (F,) int
        Object of each triangle of ``scene``.
    see_through : (n,) bool
        Objects rays pass through.
    origins, directions : (m, 3) or (1, 3) float
        The rays, world units (one origin row is broadcast).
    """
    n = len(see_through)
    visible = np.zeros(n, dtype=bool)
    t, tri = scene.first_hit(origins, directions)
    obj = np.where(tri >= 0, triangle_object[np.maximum(tri, 0)], -1)
    visible[np.unique(obj[obj >= 0])] = True
    if not see_through.any():
        return visible
    d = np.asarray(directions, dtype=np.float64)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to(np.asarray(origins, dtype=np.float64), d.shape)
    step = RAY_STEP_RELATIVE * scene.diagonal
    live = np.flatnonzero(obj >= 0)
    live = live[see_through[obj[live]]]
    travelled = t
    for _ in range(MAX_SEE_THROUGH_LAYERS):
        if len(live) == 0:
            break
        start = travelled[live] + step
        t, tri = scene.first_hit(o[live] + d[live] * start[:, None], d[live])
        hit = tri >= 0
        live, t = live[hit], start[hit] + t[hit]
        obj = triangle_object[tri[hit]]
        visible[np.unique(obj)] = True
        travelled[live] = t
        live = live[see_through[obj]]
    return visible


def simulate_culling(objects: SceneObjects, runtimes: Mapping[str, Runtime],
                     path: Sequence[PathCamera], *, width: int = DEFAULT_WIDTH,
                     height: int = DEFAULT_HEIGHT,
                     progress: Callable[[int], None] | None = None,
                     bounds: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                     keep_frames: Sequence[int] = (), jobs: int = 1,
                     scheduler=None, stances: Sequence | None = None) -> CullingResult:
    """Run every culling runtime along a camera path against the ray-cast ground truth.

    Parameters
    ----------
    objects : SceneObjects
        The scene; every object is an occludee, tested through its world box.
    runtimes : dict of str -> Runtime
        The runtimes by name (``none``: :func:`no_culling`; ``solid-frusta``,
        ``planar-frusta``: :func:`frusta_runtime`; ``depth-buffer:<method>``:
        :func:`depth_buffer_runtime`). At least one.
    path : sequence of PathCamera
        The cameras (:func:`camera_path`, :func:`read_camera_path`).
    width, height : int, optional
        Ground-truth image size, pixels (default 1280 x 720); the cameras'
        fields of view are horizontal.
    progress : callable, optional
        Called with 1 after each frame (a progress bar's ``update``).
    bounds : (lower, upper, owner), optional
        Occludee bounds tighter than each object's box: ``(c, 3)`` boxes and
        the ``(c,)`` non-decreasing object index of each, every object with at
        least one (:func:`viscore.culling.occludee_bounds.object_cluster_boxes`).
        Runtimes then get these boxes, and an object is culled when every one
        of its boxes in the view frustum is; view frustum culling keeps an
        object when its box and one of its boxes may intersect the frustum.
        ``(lower, upper, owner, triangles)`` with the ``(c, 3, 3)`` world triangle
        of each box (:func:`viscore.culling.occludee_bounds.object_triangles`): a
        runtime with ``cull_triangles`` tests those triangles instead of their boxes.
        Default: each object's own box.
    keep_frames : sequence of int, optional
        Frames whose objects (in view, visible, culled per runtime) are kept
        in :attr:`CullingResult.kept`, for pictures of them. Default none.
    jobs : int, optional
        Worker processes the frames are spread over, in as many runs of
        consecutive frames (default 1: here, frame by frame).
    scheduler : str or distributed.Client, optional
        A dask.distributed scheduler address (or client): the frames are
        spread over its workers, one run of consecutive frames per worker
        thread, instead of ``jobs``. Either way the figures are those of one
        process (only the overheads differ).
    stances : sequence of Stance, optional
        Where each camera stands (:class:`viscore.metrics.camera_paths.Walk`), one per
        camera: recorded per frame in the result.

    Returns
    -------
    CullingResult

    Raises
    ------
    InputError
        No runtime or camera, a camera too far to see the scene
        (:func:`check_camera_path`), a bad size, or an image whose rays do
        not fit in memory (checked before any work).

    Notes
    -----
    Per frame: the ground truth casts one ray per pixel centre of a ``width`` x
    ``height`` image through the scene (all objects in one Embree scene) and
    maps each first hit to its object; objects with at least one pixel are
    visible. A ray passes through see-through objects (``objects.see_through``:
    transparent glTF materials), seeing each, and stops at the first opaque one
    (:func:`visible_objects`). An object visible only between pixel centres
    (smaller than a pixel, or seen through a gap narrower than one) counts as
    hidden: that is the limit of the ground truth, and a false cull of such an
    object is not counted. View frustum culling is then applied, identically
    for every runtime (:func:`view_frustum_mask`), and each runtime gets the
    surviving boxes; its ``cull`` call is timed (``time.perf_counter``) as its
    overhead (on the first frame after one untimed call, so that compiling a
    runtime's kernels is not counted). A culled object that is visible is a
    false cull. Deterministic given the runtimes; the overheads vary from run
    to run.
    """
    if not runtimes:
        raise InputError("runtimes: expected at least one runtime")
    for name, rt in runtimes.items():
        if not isinstance(rt, Runtime):
            raise InputError(f"runtimes[{name!r}]: expected a Runtime, got {type(rt).__name__}")
    cameras = tuple(path)
    check_camera_path(objects, cameras)
    stances = () if stances is None else tuple(stances)
    if stances and len(stances) != len(cameras):
        raise InputError(f"stances: expected one per camera ({len(cameras)}), "
                         f"got {len(stances)}")
    width, height = check_culling_memory(width, height)
    jobs = as_positive_int(jobs, "jobs")
    n = len(objects)
    checked = None if bounds is None else _check_bounds(bounds, n)
    names = list(runtimes)
    count = len(cameras)
    record = _check_keep_frames(keep_frames, count)
    parts: list = []

    def commit(part: dict) -> None:
        parts.append(part)
        if progress is not None:
            progress(part["frames"])

    if scheduler is None and (jobs <= 1 or count <= 1):  # here, frame by frame
        parts.append(_walk_frames(objects, runtimes, cameras, 0, width=width, height=height,
                                  bounds=checked, record=record, progress=progress))
    else:
        from viscore._jobs import connect_scheduler, run_jobs

        with connect_scheduler(scheduler) as client:
            spread = jobs if client is None else sum(client.nthreads().values())
            edges = np.linspace(0, count, min(count, max(1, spread)) + 1).astype(int)
            # closures (a runtime's cull) and Embree scenes (rebuilt there) travel as one
            # cloudpickle of the walk's inputs, made once
            blob = _pickle_walk(objects, runtimes, checked, width, height)
            pending = [(blob, cameras[a:b], int(a), record)
                       for a, b in zip(edges[:-1], edges[1:], strict=True)]
            run_jobs(_walk_part, pending, commit, jobs=jobs, scheduler=client,
                     threads=max(1, cpu_cores() // len(pending)))
    parts.sort(key=lambda part: part["start"])
    arrays = {key: np.concatenate([part[key] for part in parts])
              for key in ("in_view", "in_view_triangles", "visible", "visible_triangles")}
    results = {}
    for k in names:
        rec = {key: np.concatenate([part["runtimes"][k][key] for part in parts])
               for key in ("culled", "false", "tris", "ms")}
        results[k] = RuntimeFrames(
            culled=rec["culled"], false_culls=rec["false"], triangles_rendered=rec["tris"],
            overhead_ms=rec["ms"], conservative=runtimes[k].conservative,
            false_cull_names=tuple(x for part in parts for x in part["runtimes"][k]["names"]))
    return CullingResult(cameras=cameras, width=width, height=height, objects=n,
                         triangles=objects.total_triangles, in_view=arrays["in_view"],
                         in_view_triangles=arrays["in_view_triangles"],
                         visible=arrays["visible"],
                         visible_triangles=arrays["visible_triangles"], runtimes=results,
                         stances=stances,
                         kept={f: kept for part in parts for f, kept in part["kept"].items()})


def _pickle_walk(objects: SceneObjects, runtimes: Mapping[str, Runtime], bounds,
                 width: int, height: int) -> bytes:
    """The inputs of :func:`_walk_frames` but the cameras, as one cloudpickle."""
    import cloudpickle

    return cloudpickle.dumps((objects, dict(runtimes), bounds, width, height))


def _walk_part(blob: bytes, cameras: Sequence[PathCamera], start: int,
               record: frozenset = frozenset()) -> dict:
    """One job of a spread walk: :func:`_walk_frames` of ``cameras`` in a worker."""
    import pickle

    objects, runtimes, bounds, width, height = pickle.loads(blob)
    return _walk_frames(objects, runtimes, cameras, start, width=width, height=height,
                        bounds=bounds, record=record)


def _walk_frames(objects: SceneObjects, runtimes: Mapping[str, Runtime],
                 cameras: Sequence[PathCamera], start: int, *, width: int, height: int,
                 bounds: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
                 record: frozenset = frozenset(),
                 progress: Callable[[int], None] | None = None) -> dict:
    """The per-frame figures of :func:`simulate_culling` for ``cameras``, frames ``start``
    on of the path: each frame depends on its camera alone, so a walk split in parts
    gives the same figures (the overheads aside; each part's first frame has its
    untimed warm-up call). The frames of the path in ``record`` keep their objects
    (``kept``, by frame of the path)."""
    scene, triangle_object = objects.combined
    lower, upper, tris = objects.lower, objects.upper, objects.triangles
    b_tri = None
    if bounds is not None:
        b_lower, b_upper, owner = bounds[:3]
        b_tri = bounds[3] if len(bounds) > 3 else None
    names = list(runtimes)
    count = len(cameras)
    kept: dict[int, FrameObjects] = {}
    in_view_n = np.zeros(count, np.int64)
    in_view_t = np.zeros(count, np.int64)
    visible_n = np.zeros(count, np.int64)
    visible_t = np.zeros(count, np.int64)
    per = {k: {"culled": np.zeros(count, np.int64), "false": np.zeros(count, np.int64),
               "tris": np.zeros(count, np.int64), "ms": np.zeros(count), "names": []}
           for k in names}
    tri_in: np.ndarray | None = None  # the in-view objects' triangles, with --bounds triangles
    groups: np.ndarray | None = None
    for f, pose in enumerate(cameras):
        camera = pose.camera(width, height)
        origins, directions = camera.rays()
        visible = visible_objects(scene, triangle_object, objects.see_through, origins,  # type: ignore[arg-type]
                                  directions)
        del origins, directions
        in_view = view_frustum_mask(camera, lower, upper)
        if bounds is None:
            idx = np.flatnonzero(in_view)
            lo, hi, starts = lower[idx], upper[idx], None
        else:
            keep = np.flatnonzero(in_view[owner])
            keep = keep[view_frustum_mask(camera, b_lower[keep], b_upper[keep])]
            idx, starts = np.unique(owner[keep], return_index=True)
            lo, hi = b_lower[keep], b_upper[keep]
            if b_tri is not None:
                tri_in, groups = b_tri[keep], np.append(starts, len(keep))
        in_view_n[f], in_view_t[f] = len(idx), int(tris[idx].sum())
        visible_n[f], visible_t[f] = int(visible.sum()), int(tris[visible].sum())
        if start + f in record:
            kept[start + f] = FrameObjects(in_view=idx.astype(np.int64),
                                   visible=np.flatnonzero(visible), culled={})
        for name in names:
            by_tri = b_tri is not None and runtimes[name].cull_triangles is not None
            # by triangles: one figure per object, its own triangles pixel by pixel
            call, args = ((runtimes[name].cull_triangles, (camera, tri_in, groups)) if by_tri
                          else (runtimes[name].cull, (camera, lo, hi)))
            assert call is not None  # by_tri only when the runtime has cull_triangles
            if f == 0:  # warm-up, untimed: compiling the kernels is not a frame's overhead
                call(*args)
            begin = time.perf_counter()
            mask = np.asarray(call(*args), dtype=bool)
            elapsed = time.perf_counter() - begin
            want = len(idx) if by_tri else len(lo)
            if mask.shape != (want,):
                raise ValueError(f"runtime {name!r}: cull returned shape {mask.shape}, "
                                 f"expected ({want},)")
            if starts is not None and not by_tri:  # culled when all its boxes are
                mask = np.logical_and.reduceat(mask, starts) if len(mask) else mask
            culled = idx[mask]
            false = culled[visible[culled]]
            rendered = tris[idx].sum() - tris[culled].sum()
            rec = per[name]
            rec["culled"][f], rec["false"][f] = len(culled), len(false)  # type: ignore[index]
            rec["tris"][f], rec["ms"][f] = int(rendered), 1e3 * elapsed  # type: ignore[index]
            rec["names"].append(tuple(objects.names[i] for i in false[:10]))  # type: ignore[attr-defined]
            if start + f in record:
                kept[start + f].culled[name] = np.sort(culled).astype(np.int64)
            if len(false) and runtimes[name].conservative:
                _log.warning("frame %d: %s culled %d visible object(s), e.g. %s", start + f,
                             name, len(false), objects.names[int(false[0])])
        if progress is not None:
            progress(1)
    return {"start": start, "frames": count, "in_view": in_view_n,
            "in_view_triangles": in_view_t, "visible": visible_n,
            "visible_triangles": visible_t, "runtimes": per, "kept": kept}


def _check_keep_frames(frames: Sequence[int], count: int) -> frozenset:
    """``keep_frames`` of :func:`simulate_culling` as a set, each a frame of the path."""
    try:
        keep = [int(k) for k in frames]
        exact = all(int(k) == k for k in frames)
    except (TypeError, ValueError):
        raise InputError("keep_frames: expected a sequence of frame numbers") from None
    if not exact or any(not 0 <= k < count for k in keep):
        raise InputError(f"keep_frames: expected frame numbers in [0, {count}), got "
                         f"{list(frames)[:5]}")
    return frozenset(keep)
