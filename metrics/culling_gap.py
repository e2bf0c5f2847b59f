"""Where a culling runtime falls short of the truth: the object-frames it keeps that the truth
hides, by cause.

The culling simulation (:func:`viscore.metrics.culling.simulate_culling`) counts, per
frame, the objects in view that the ray-cast truth does not see (hidden) and those a
runtime culls. A hidden object a guaranteed runtime keeps is a miss; this module sorts the
misses by what would have culled them, from reference runtimes run along the same walk
beside it (depth buffers fed by the level's own triangles: the ``original`` method):

``occluders``
    the level's own triangles of the occluder objects, in a buffer of the same
    resolution, cull it: the runtime's occluders lack something the level has;
``resolution``
    only those triangles at the screen's full resolution cull it;
``unchosen``
    only every object's own triangles at full resolution cull it: what hides it is
    an object that gets no occluder;
``subpixel``
    none of them does, and its box spans under :data:`SUBPIXEL_PIXELS` screen pixels:
    the truth hides it because its rays pass between pixel centres;
``unexplained``
    none of them does: it is seen through gaps no buffer pixel closes, or hidden
    by surfaces lying too close in front of it for a conservative depth (a floor
    under a ceiling, a road under terrain), or only partly by each of several.

The conservative depth buffer is that of the occluder-skins paper (Leone et al. 2012,
secs. 5-6) as :mod:`viscore.culling.depth_buffer` casts it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from viscore._validate import InputError

from .culling import CullingResult

__all__ = ["CullingGap", "culling_gap", "GAP_CAUSES", "SUBPIXEL_PIXELS"]

#: The causes of a miss, in the order they are tried (module docstring).
GAP_CAUSES = ("occluders", "resolution", "unchosen", "subpixel", "unexplained")

#: A hidden object whose box's diagonal spans fewer screen pixels than this, seen from
#: the camera at the box's nearest point, is one the truth may hide between its pixel
#: centres (a pixel is sampled at its centre only).
SUBPIXEL_PIXELS = 4.0

#: Objects named per cause, those missed on the most frames first.
_TOP = 5


@dataclass(frozen=True)
class CullingGap:
    """The object-frames the truth hides and a runtime keeps, by cause.

    Attributes
    ----------
    runtime : str
        The runtime examined.
    hidden : int
        Object-frames in view that the truth does not see.
    culled : int
        Of those, the ones the runtime culls.
    causes : dict of str -> int
        The others (``hidden - culled``) by cause, one of :data:`GAP_CAUSES` each.
    objects : dict of str -> list of [str, int]
        Per cause, the objects missed on the most frames (at most five), with their
        frame counts.
    """

    runtime: str
    hidden: int
    culled: int
    causes: dict = field(default_factory=dict)
    objects: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """The fields as JSON values, under their own names."""
        return {"runtime": self.runtime, "hidden": self.hidden, "culled": self.culled,
                "causes": dict(self.causes), "objects": {k: [list(x) for x in v]
                                                         for k, v in self.objects.items()}}


def _pixel_spans(result: CullingResult, frame: int, lower: np.ndarray,
                 upper: np.ndarray) -> np.ndarray:
    """Screen pixels spanned by each box's diagonal from frame ``frame``'s camera, at the
    box's nearest point (inf for a box holding the eye)."""
    cam = result.cameras[frame]
    eye = np.asarray(cam.position, dtype=np.float64)
    near = np.linalg.norm(np.clip(eye, lower, upper) - eye, axis=1)
    focal = 0.5 * result.width / np.tan(np.radians(0.5 * float(cam.fov)))
    diag = np.linalg.norm(upper - lower, axis=1)
    with np.errstate(divide="ignore"):
        return np.where(near > 0, diag * focal / np.where(near > 0, near, 1.0), np.inf)


def culling_gap(result: CullingResult, lower: np.ndarray, upper: np.ndarray,
                names: list[str] | tuple, runtime: str, *, own: str, own_full: str,
                every_full: str | None = None) -> CullingGap:
    """Sort the object-frames the truth hides and ``runtime`` keeps by cause.

    Parameters
    ----------
    result : CullingResult
        A simulation that kept every frame's objects (``keep_frames`` all frames).
    lower, upper : (n, 3) float64
        Each object's world box, world units.
    names : sequence of str
        (n,) each object's name.
    runtime : str
        The runtime examined (the best guaranteed one).
    own : str
        The runtime fed by the occluder objects' own triangles, at ``runtime``'s
        resolution.
    own_full : str
        The same triangles at the screen's full resolution.
    every_full : str, optional
        Every object's own triangles at full resolution; default None, when every
        object is an occluder object (``own_full`` then stands for it).

    Returns
    -------
    CullingGap

    Raises
    ------
    InputError
        A runtime not in ``result``, a frame whose objects were not kept, or boxes
        and names not one per object.

    Notes
    -----
    Deterministic given ``result``. A miss is given the first cause of
    :data:`GAP_CAUSES` that applies; the reference runtimes are never counted as
    guaranteed runtimes of the level (they are its whole mesh, not occluders).
    """
    lower = np.asarray(lower, dtype=np.float64)
    upper = np.asarray(upper, dtype=np.float64)
    if lower.shape != (result.objects, 3) or upper.shape != lower.shape \
            or len(names) != result.objects:
        raise InputError(f"culling_gap: expected {result.objects} boxes and names, got "
                         f"boxes {lower.shape}, {upper.shape} and {len(names)} names")
    refs = {"occluders": own, "resolution": own_full, "unchosen": every_full or own_full}
    for r in (runtime, *refs.values()):
        if r not in result.runtimes:
            raise InputError(f"culling_gap: no runtime {r!r} in the result (runtimes: "
                             f"{', '.join(result.runtimes)})")
    missing = [f for f in range(len(result.cameras)) if f not in result.kept]
    if missing:
        raise InputError(f"culling_gap: the objects of frame {missing[0]} were not kept "
                         "(simulate_culling keep_frames must name every frame)")
    causes = dict.fromkeys(GAP_CAUSES, 0)
    per: Mapping[str, dict] = {c: {} for c in GAP_CAUSES}
    hidden_total = culled_total = 0
    for f in range(len(result.cameras)):  # a loop over frames
        kept = result.kept[f]
        hidden = np.setdiff1d(kept.in_view, kept.visible)
        hidden_total += len(hidden)
        left = np.setdiff1d(hidden, kept.culled[runtime])
        culled_total += len(hidden) - len(left)
        cause = np.full(len(left), len(GAP_CAUSES) - 1)
        open_ = np.ones(len(left), dtype=bool)
        for k, name in enumerate(("occluders", "resolution", "unchosen")):
            hit = open_ & np.isin(left, kept.culled[refs[name]])
            cause[hit] = k
            open_ &= ~hit
        span = _pixel_spans(result, f, lower[left], upper[left])
        cause[open_ & (span < SUBPIXEL_PIXELS)] = GAP_CAUSES.index("subpixel")
        for obj, c in zip(left.tolist(), cause.tolist(), strict=True):
            name = GAP_CAUSES[c]
            causes[name] += 1
            per[name][names[obj]] = per[name].get(names[obj], 0) + 1
    top = {c: sorted(v.items(), key=lambda x: (-x[1], x[0]))[:_TOP]
           for c, v in per.items() if v}
    return CullingGap(runtime=runtime, hidden=hidden_total, culled=culled_total,
                      causes=causes, objects=top)
