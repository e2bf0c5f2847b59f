"""The report pages' pictures of a level, all by the toolkit's own ray caster.

A plan seen from above (:func:`plan_picture`) and perspective frames
(:func:`frame_picture`) are :func:`viscore.ray.render.object_image` casts,
one ray per pixel, coloured per object by what happened to it, with a second
cast of the objects hidden behind the visible ones and a third of the
occluders drawn over them (:func:`viscore.ray.render.overlay`). Pictures are
written as PNG (:func:`png_bytes`) with a palette of at most
:data:`PNG_COLORS` colours, which keeps a frame at a few tens of kilobytes.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np

from viscore import InputError, OrthoCamera, PerspectiveCamera
from viscore.ray import ObjectImage, object_image, overlay, shade

#: Pixels across a frame picture; its height follows the truth's aspect ratio.
FRAME_WIDTH = 480
#: Pixels along the plan's longer side.
PLAN_PIXELS = 720
#: Most colours of a picture's PNG palette (shading and outlines need about this many).
PNG_COLORS = 96

#: RGB in [0, 1] of the objects by what happened to them in a frame.
STATE_RGB = {
    "visible": (0.80, 0.81, 0.84),        # seen by the truth, rendered
    "false-cull": (0.86, 0.12, 0.10),     # seen by the truth, yet culled
    "culled": (0.13, 0.62, 0.30),         # hidden and culled (drawn through what hides it)
    "missed": (0.97, 0.62, 0.10),         # hidden, yet not culled
}
#: RGB of the occluders drawn over a frame or plan, and of the plan's path.
OCCLUDER_RGB = (0.10, 0.35, 0.95)
#: Opacity of the hidden objects drawn over a frame, and of the occluders.
HIDDEN_ALPHA = 0.55
OCCLUDER_ALPHA = 0.12
#: Colours of the plan: the ground (flat objects), the objects that get occluders,
#: and the others (props).
PLAN_GROUND_RGB = (0.93, 0.92, 0.87)
PLAN_OCCLUDER_OBJECT_RGB = (0.60, 0.68, 0.82)
PLAN_RGB = (0.52, 0.52, 0.55)
#: The plan's box is the level's built part grown by this fraction of its side.
PLAN_MARGIN = 0.04


def png_bytes(rgb: np.ndarray) -> bytes:
    """A picture as PNG bytes: at most :data:`PNG_COLORS` palette colours, compressed."""
    from PIL import Image

    image = Image.fromarray(np.ascontiguousarray(rgb, dtype=np.uint8), mode="RGB")
    quantised = image.quantize(colors=PNG_COLORS, method=Image.Quantize.FASTOCTREE,
                               dither=Image.Dither.NONE)
    buf = io.BytesIO()
    quantised.save(buf, format="PNG")
    return buf.getvalue()


# --------------------------------------------------------------------------- plan
def _horizontal_axes(up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(right, image-up) of a view from above: +X to the right where it is horizontal."""
    up = up / np.linalg.norm(up)
    ref = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    image_up = np.cross(up, ref)
    image_up /= np.linalg.norm(image_up)
    return np.cross(image_up, up), image_up


def _corners(box: np.ndarray) -> np.ndarray:
    """(8, 3) corners of a (2, 3) box."""
    return np.array([[box[i, 0], box[j, 1], box[k, 2]]
                     for i in (0, 1) for j in (0, 1) for k in (0, 1)])


def _plan_camera(objects, pixels: int) -> OrthoCamera:
    """The orthographic camera of a plan: down the up axis over the built part's box."""
    up = np.asarray(objects.up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    box, _ = objects.built_bounds()
    right, image_up = _horizontal_axes(up)
    corners = _corners(box)
    centre = 0.5 * (box[0] + box[1])
    across = max(float(np.ptp(corners @ right)), float(np.ptp(corners @ image_up)), 1e-9)
    top = float((_corners(objects.bounds) @ up).max() - centre @ up)  # the sky's too
    return OrthoCamera(-up, centre, across * (1 + 2 * PLAN_MARGIN), pixels, up=image_up,
                       start=max(top, 0.0) + 0.01 * across)


def _plan_colors(objects, highlight) -> np.ndarray:
    """(n, 3) RGB of a level's objects on a plan or view: ground, with occluders, others."""
    colors = np.tile(PLAN_RGB, (len(objects), 1))
    if highlight is not None and len(highlight):
        colors[np.asarray(highlight, dtype=np.int64)] = PLAN_OCCLUDER_OBJECT_RGB
    colors[objects.flat()] = PLAN_GROUND_RGB  # the ground, even with occluders
    return colors


@dataclass(frozen=True)
class Plan:
    """A plan of a level seen from above.

    Attributes
    ----------
    rgb : (R, R, 3) uint8
        The picture, row 0 at the image-up side.
    camera : OrthoCamera
        Its camera (``project`` maps world points to its pixels).
    """

    rgb: np.ndarray
    camera: OrthoCamera


def plan_picture(objects, *, pixels: int = PLAN_PIXELS, highlight=None,
                 occluders=None) -> Plan:
    """A plan of a level from above: orthographic, one ray per pixel, sky passed.

    Parameters
    ----------
    objects : SceneObjects
        The level.
    pixels : int, optional
        Side of the square picture (default :data:`PLAN_PIXELS`).
    highlight : (k,) int, optional
        Objects drawn in :data:`PLAN_OCCLUDER_OBJECT_RGB` (those with occluders);
        flat ones (ground) in :data:`PLAN_GROUND_RGB`, the others in
        :data:`PLAN_RGB`.
    occluders : Scene, optional
        Occluders drawn over the plan in :data:`OCCLUDER_RGB`.

    Notes
    -----
    The box is the level's built part
    (:meth:`~viscore.level.scene_graph.SceneObjects.built_bounds`: an outer
    ground or sea left out) grown by :data:`PLAN_MARGIN`; a sky dome or box
    (:meth:`~viscore.level.scene_graph.SceneObjects.sky`) is passed through.
    """
    camera = _plan_camera(objects, pixels)
    scene, owner = objects.combined
    image = object_image(scene, owner, camera, skip=objects.sky())
    rgb = shade(image, _plan_colors(objects, highlight))
    if occluders is not None:
        rgb = overlay(rgb, occluder_image(occluders, camera), OCCLUDER_RGB,
                      alpha=OCCLUDER_ALPHA)
    return Plan(rgb=rgb, camera=camera)


# --------------------------------------------------------------------------- frames
@dataclass(frozen=True)
class FrameCounts:
    """Objects of one frame by state, for one runtime (the picture's caption)."""

    in_view: int
    visible: int
    culled: int
    false_culls: int
    missed: int
    outside: int


class FrameRays:
    """A camera's rays, made once and cast many times (the level, the hidden objects, each
    runtime's occluders): what :func:`viscore.ray.render.object_image` asks of a camera."""

    def __init__(self, camera: PerspectiveCamera) -> None:
        self.shape = camera.shape
        self._rays = camera.rays()

    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        return self._rays


def frame_base(objects, camera: PerspectiveCamera | FrameRays, kept
               ) -> tuple[ObjectImage, ObjectImage | None]:
    """The two casts every runtime's picture of a frame shares.

    Returns
    -------
    seen : ObjectImage
        The level from the camera.
    hidden : ObjectImage or None
        The objects in view that the truth does not see, alone (each pixel its
        nearest such object); None when there are none.
    """
    scene, owner = objects.combined
    seen = object_image(scene, owner, camera)
    hidden_ids = np.setdiff1d(kept.in_view, kept.visible)
    if not len(hidden_ids):
        return seen, None
    passed = np.ones(len(objects), dtype=bool)
    passed[hidden_ids] = False
    return seen, object_image(scene, owner, camera, skip=passed, start=seen)


def frame_picture(count: int, seen: ObjectImage, hidden: ObjectImage | None, kept,
                  runtime: str, occluders: ObjectImage | None = None
                  ) -> tuple[np.ndarray, FrameCounts]:
    """One runtime's picture of a frame: each object tinted by what happened to it.

    Parameters
    ----------
    count : int
        Objects in the level.
    seen, hidden : ObjectImage
        From :func:`frame_base`.
    kept : FrameObjects
        The frame's objects (:attr:`viscore.metrics.culling.CullingResult.kept`).
    runtime : str
        A runtime of ``kept.culled``.
    occluders : ObjectImage, optional
        The runtime's occluders cast from the same camera, drawn over it.

    Returns
    -------
    rgb : (H, W, 3) uint8
    counts : FrameCounts
    """
    if runtime not in kept.culled:
        raise InputError(f"runtime: {runtime!r} is not one of the frame's runtimes")
    culled = np.zeros(count, dtype=bool)
    culled[kept.culled[runtime]] = True
    visible = np.zeros(count, dtype=bool)
    visible[kept.visible] = True
    colors = np.tile(STATE_RGB["visible"], (count, 1))
    colors[culled & visible] = STATE_RGB["false-cull"]
    rgb = shade(seen, colors)
    in_view = np.zeros(count, dtype=bool)
    in_view[kept.in_view] = True
    hidden_mask = in_view & ~visible
    if hidden is not None:
        ghost = np.tile(STATE_RGB["missed"], (count, 1))
        ghost[culled] = STATE_RGB["culled"]
        rgb = overlay(rgb, hidden, colors=ghost, alpha=HIDDEN_ALPHA)
    if occluders is not None:
        rgb = overlay(rgb, occluders, OCCLUDER_RGB, alpha=OCCLUDER_ALPHA)
    counts = FrameCounts(in_view=int(in_view.sum()), visible=int(visible.sum()),
                         culled=int(culled.sum()), false_culls=int((culled & visible).sum()),
                         missed=int((hidden_mask & ~culled).sum()),
                         outside=int(count - in_view.sum()))
    return rgb, counts


def occluder_image(scene, camera) -> ObjectImage | None:
    """The occluders of a runtime (an Embree scene, or None) cast from a camera."""
    if scene is None:
        return None
    return object_image(scene, np.zeros(len(scene.faces), dtype=np.int64), camera)


# --------------------------------------------------------------------------- level views
#: Views of a level outside a walk: azimuths around it (degrees from the plan's right),
#: their distance (level diagonals from its centre) and height (level diagonals).
VIEW_AZIMUTHS = (225.0, 45.0)
VIEW_DISTANCE = 0.75
VIEW_HEIGHT = 0.45
#: Field of view of those views, degrees, and their picture size, pixels.
VIEW_FOV = 55.0
VIEW_SIZE = (480, 320)


def level_views(objects) -> list[tuple[str, OrthoCamera | PerspectiveCamera]]:
    """A few views of a whole level: the plan from above, then oblique views from outside.

    Returns
    -------
    list of (label, camera)
        ``("above", OrthoCamera)`` (as :func:`plan_picture`, at ``VIEW_SIZE``'s
        width), then one ``PerspectiveCamera`` per :data:`VIEW_AZIMUTHS`,
        looking down at the built part's centre from :data:`VIEW_DISTANCE`
        diagonals away and :data:`VIEW_HEIGHT` diagonals up.
    """
    up = np.asarray(objects.up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    box, _ = objects.built_bounds()
    centre = 0.5 * (box[0] + box[1])
    diagonal = float(np.linalg.norm(box[1] - box[0])) or 1.0
    right, image_up = _horizontal_axes(up)
    views: list = [("above", _plan_camera(objects, VIEW_SIZE[0]))]
    for azimuth in VIEW_AZIMUTHS:
        a = np.radians(azimuth)
        eye = (centre + VIEW_DISTANCE * diagonal * (np.cos(a) * right + np.sin(a) * image_up)
               + VIEW_HEIGHT * diagonal * up)
        views.append((f"from {_compass(np.cos(a), np.sin(a))}",
                      PerspectiveCamera(eye, centre - eye, up=up, fov=VIEW_FOV,
                                        resolution=VIEW_SIZE[0], height=VIEW_SIZE[1])))
    return views


def _compass(x: float, y: float) -> str:
    """The plan's direction of (x right, y up) as a compass word (up the plan is north)."""
    names = ("east", "north-east", "north", "north-west", "west", "south-west", "south",
             "south-east")
    return names[int(np.round(np.degrees(np.arctan2(y, x)) / 45.0)) % 8]


def level_picture(objects, camera, *, highlight=None, occluders=None,
                  occluder_rgb=OCCLUDER_RGB, alpha: float = OCCLUDER_ALPHA) -> np.ndarray:
    """A level from a camera, the ground and the objects with occluders tinted as on the
    plan, with occluders (an Embree scene) drawn over it; sky passed.

    Returns
    -------
    rgb : (H, W, 3) uint8
    """
    scene, owner = objects.combined
    image = object_image(scene, owner, camera, skip=objects.sky())
    rgb = shade(image, _plan_colors(objects, highlight))
    if occluders is not None:
        rgb = overlay(rgb, occluder_image(occluders, camera), occluder_rgb, alpha=alpha)
    return rgb
