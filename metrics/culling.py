"""Scene culling simulation: objects culled per frame along a camera path, against ray-cast truth.

Occluders exist to cull objects. This module walks a camera along a path
through a scene of objects (:class:`viscore.level.scene_graph.SceneObjects`) and, at
every frame, asks each culling *runtime* which objects' bounding boxes it
hides, as a scene-graph renderer does (Papaioannou et al. 2006 [1]_, sec. 4,
Tables 1-2 and Figures 5-6: primitives rendered per frame along pre-recorded
viewpoint paths; Hudson et al. 1997 [2]_ for the shadow frusta). The truth is
a full-resolution ray-cast object-id image (one ray per pixel centre, the
first hit's triangle mapped to its object): an object with at least one pixel
is visible, and culling it is a *false cull*. The depth-buffer runtime of the
occluder-skins paper [3]_ (sec. 5-6: occluders drawn into a reduced depth
buffer, each occludee's screen rectangle tested at its nearest depth) is one
of the runtimes.

Per frame and runtime the simulation reports the objects culled (beyond view
frustum culling), the false culls, the triangles sent to render and the
runtime's own time (overhead). View-frustum culling is applied first and
identically for every runtime, the ``none`` runtime included: each runtime
sees only the boxes that intersect the view frustum.

The runtimes (:func:`no_culling`, :func:`frusta_runtime`,
:func:`depth_buffer_runtime`) and the view-frustum test are in
:mod:`viscore.metrics.culling_runtimes`, the camera paths
(:func:`camera_path`, :func:`read_camera_path`) in
:mod:`viscore.metrics.camera_paths`, the figure (:func:`culling_plot`) in
:mod:`viscore.metrics.plots`; their names import from here too, as they
always did. This module never imports :mod:`viscore.generators`.

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
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from viscore import InputError
from viscore._validate import as_positive_int, check_memory
from viscore.constants import RAY_STEP_RELATIVE

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
           "visible_objects",
           "DEFAULT_WIDTH", "DEFAULT_HEIGHT",
           # kept for old import paths (defined in .camera_paths, .culling_runtimes, .plots)
           "PathCamera", "camera_path", "read_camera_path", "camera_path_json",
           "check_camera_path", "DEFAULT_FOV", "Runtime", "no_culling", "frusta_runtime",
           "depth_buffer_runtime", "view_frustum_mask", "culling_plot"]

_log = logging.getLogger(__name__)


#: Ground-truth image size, pixels (the issue's default: 1280 x 720).
DEFAULT_WIDTH, DEFAULT_HEIGHT = 1280, 720

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
    stances: tuple = ()

    def totals(self) -> dict[str, dict]:
        """Per runtime: totals over the path (see :meth:`to_json`)."""
        out = {}
        in_view = int(self.in_view.sum())
        frames = max(1, len(self.cameras))
        for name, rf in self.runtimes.items():
            culled = int(rf.culled.sum())
            out[name] = {
                "culled": culled,
                "culled_share": culled / in_view if in_view else 0.0,
                "false_culls": int(rf.false_culls.sum()),
                "frames_with_false_culls": int((rf.false_culls > 0).sum()),
                "triangles_rendered": int(rf.triangles_rendered.sum()),
                "triangles_rendered_per_frame": float(rf.triangles_rendered.sum()) / frames,
                "overhead_ms": float(rf.overhead_ms.mean()) if len(rf.overhead_ms) else 0.0,
                "overhead_ms_max": float(rf.overhead_ms.max()) if len(rf.overhead_ms) else 0.0,
                "conservative": bool(rf.conservative),
            }
        return out

    def to_json(self) -> dict:
        """The JSON document: ``frames``, ``totals``, ``ground_truth`` and ``settings``.

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
        ``conservative``. ``ground_truth`` holds the same sums for an exact
        culler (only the visible objects rendered).
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
        return {
            "settings": {"frames": len(self.cameras), "width": self.width, "height": self.height,
                         "objects": self.objects, "triangles": self.triangles},
            "frames": frames,
            "totals": self.totals(),
            "ground_truth": {
                "in_view": in_view, "visible": int(self.visible.sum()),
                "hidden_share": hidden / in_view if in_view else 0.0,
                "triangles_in_view": int(self.in_view_triangles.sum()),
                "triangles_visible": int(self.visible_triangles.sum()),
            },
        }


def _check_bounds(bounds, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``bounds`` of :func:`simulate_culling` as arrays, checked: one line on a mismatch."""
    try:
        lower, upper, owner = bounds
    except (TypeError, ValueError):
        raise InputError("bounds: expected (lower, upper, owner)") from None
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
                     stances: Sequence | None = None) -> CullingResult:
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
        Default: each object's own box.
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
    scene, triangle_object = objects.combined
    n = len(objects)
    lower, upper, tris = objects.lower, objects.upper, objects.triangles
    if bounds is not None:
        b_lower, b_upper, owner = _check_bounds(bounds, n)
    names = list(runtimes)
    count = len(cameras)
    in_view_n = np.zeros(count, np.int64)
    in_view_t = np.zeros(count, np.int64)
    visible_n = np.zeros(count, np.int64)
    visible_t = np.zeros(count, np.int64)
    per = {k: {"culled": np.zeros(count, np.int64), "false": np.zeros(count, np.int64),
               "tris": np.zeros(count, np.int64), "ms": np.zeros(count), "names": []}
           for k in names}
    for f, pose in enumerate(cameras):
        camera = pose.camera(width, height)
        origins, directions = camera.rays()
        visible = visible_objects(scene, triangle_object, objects.see_through, origins,
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
        in_view_n[f], in_view_t[f] = len(idx), int(tris[idx].sum())
        visible_n[f], visible_t[f] = int(visible.sum()), int(tris[visible].sum())
        for name in names:
            if f == 0:  # warm-up, untimed: compiling the kernels is not a frame's overhead
                runtimes[name].cull(camera, lo, hi)
            start = time.perf_counter()
            mask = np.asarray(runtimes[name].cull(camera, lo, hi), dtype=bool)
            elapsed = time.perf_counter() - start
            if mask.shape != (len(lo),):
                raise ValueError(f"runtime {name!r}: cull returned shape {mask.shape}, "
                                 f"expected ({len(lo)},)")
            if starts is not None:  # an object is culled when all its boxes are
                mask = np.logical_and.reduceat(mask, starts) if len(mask) else mask
            culled = idx[mask]
            false = culled[visible[culled]]
            rendered = tris[idx].sum() - tris[culled].sum()
            rec = per[name]
            rec["culled"][f], rec["false"][f] = len(culled), len(false)
            rec["tris"][f], rec["ms"][f] = int(rendered), 1e3 * elapsed
            rec["names"].append(tuple(objects.names[i] for i in false[:10]))
            if len(false) and runtimes[name].conservative:
                _log.warning("frame %d: %s culled %d visible object(s), e.g. %s", f, name,
                             len(false), objects.names[int(false[0])])
        if progress is not None:
            progress(1)
    results = {k: RuntimeFrames(culled=per[k]["culled"], false_culls=per[k]["false"],
                                triangles_rendered=per[k]["tris"], overhead_ms=per[k]["ms"],
                                conservative=runtimes[k].conservative,
                                false_cull_names=tuple(per[k]["names"])) for k in names}
    return CullingResult(cameras=cameras, width=width, height=height, objects=n,
                         triangles=objects.total_triangles, in_view=in_view_n,
                         in_view_triangles=in_view_t, visible=visible_n,
                         visible_triangles=visible_t, runtimes=results, stances=stances)
