"""Pictures of a level by ray casting: object-id and normal images, tinted per object.

One first-hit ray per pixel centre (as :mod:`viscore.ray.images`) gives each
pixel the object it sees and the normal of the triangle hit. A picture is then
a colour per object (what happened to it in a culling frame, say), shaded by
how squarely the surface faces the ray (a head light: Lambert's cosine law
with the light at the eye), each object a little lighter or darker than its
neighbour by its id, and outlined where the object, the surface's plane or the
depth changes from one pixel to the next. No rasterizer: a perspective frame
and a plan seen from above are the same cast with different cameras.
:func:`overlay` draws a second cast (occluders, objects hidden behind others)
over a picture, translucent, with its outlines.

References
----------
.. [1] Lambert, J. H. "Photometria, sive de mensura et gradibus luminis,
   colorum et umbrae". Augsburg, 1760 (the cosine law of diffuse reflection).
.. [2] Saito, T., Takahashi, T. "Comprehensible Rendering of 3-D Shapes".
   Proceedings of SIGGRAPH 1990, Computer Graphics 24(4), pp. 197-206.
   :DOI:`10.1145/97880.97901` (outlines from discontinuities of depth and
   normal in image buffers).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt

from .._validate import InputError
from ..constants import RAY_STEP_RELATIVE
from .cameras import OrthoCamera, PerspectiveCamera
from .embree_scene import Scene

__all__ = ["ObjectImage", "object_image", "shade", "overlay", "MAX_PASSED_LAYERS"]

#: Most surfaces of passed objects (``skip``) a ray goes through before it stops
#: seeing nothing more: glass panes, a sky dome's two sides, water layers.
MAX_PASSED_LAYERS = 16

#: Share of a pixel's brightness that does not depend on the surface's facing
#: (ambient light): a wall seen edge-on is still drawn, not black.
AMBIENT = 0.45

#: Objects are drawn between this fraction of their colour and full colour, by
#: their id (a golden-ratio sequence), so that neighbours of one state differ.
ID_SHADE_LOW = 0.82

#: Neighbouring pixels whose normals differ by more than this angle, degrees, are a
#: crease and get an outline (30 degrees: the edges of boxes and steps, not the
#: facets of a finely tessellated curve).
CREASE_DEGREES = 30.0

#: Neighbouring pixels whose depths differ by more than this fraction of the
#: nearer one are a depth edge (an object in front of another of the same id).
DEPTH_EDGE_RELATIVE = 0.08

#: Colour of the outlines and of pixels that see nothing, RGB in [0, 1].
OUTLINE_RGB = (0.12, 0.12, 0.14)
BACKGROUND_RGB = (0.97, 0.97, 0.98)

_GOLDEN = 0.6180339887498949


@dataclass(frozen=True, eq=False)
class ObjectImage:
    """What each pixel's ray hits: the object, the surface's normal, the distance.

    Attributes
    ----------
    object : (H, W) int64
        Object of the first hit, ``-1`` where the ray misses.
    triangle : (H, W) int64
        Triangle of the scene hit, ``-1`` on a miss.
    normal : (H, W, 3) float32
        Unit normal of the triangle hit, turned towards the ray's origin;
        zero on a miss.
    facing : (H, W) float32
        ``|cos|`` of the angle between the ray and that normal, in [0, 1];
        0 on a miss.
    depth : (H, W) float64
        Distance along the ray to the hit, world units; ``inf`` on a miss.
    """

    object: np.ndarray
    triangle: np.ndarray
    normal: np.ndarray
    facing: np.ndarray
    depth: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W), pixels."""
        return self.object.shape

    @property
    def hit(self) -> np.ndarray:
        """(H, W) bool: pixels whose ray hits something."""
        return self.object >= 0

    @cached_property
    def outline(self) -> np.ndarray:
        """(H, W) bool: pixels on an outline, where the object, the surface's plane (a
        crease over :data:`CREASE_DEGREES`) or the depth (a jump over
        :data:`DEPTH_EDGE_RELATIVE`) changes to the next pixel right or below (both
        pixels marked); computed once."""
        return _edges(self)


def _triangle_normals(scene: Scene, triangles: np.ndarray) -> np.ndarray:
    """(k, 3) unit normals of some triangles of ``scene`` (zero for a degenerate one),
    each distinct triangle computed once (a picture's pixels share few triangles)."""
    distinct, where = np.unique(triangles, return_inverse=True)
    v = scene.vertices[scene.faces[distinct]]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    length = np.sqrt(np.einsum("ij,ij->i", n, n))[:, None]
    return (n / np.where(length > 0, length, 1.0))[where.reshape(-1)]


def object_image(scene: Scene, triangle_object: npt.ArrayLike,
                 camera: OrthoCamera | PerspectiveCamera, *,
                 skip: npt.ArrayLike | None = None,
                 start: ObjectImage | None = None) -> ObjectImage:
    """Cast one ray per pixel centre and keep the object, normal and depth of each hit.

    Parameters
    ----------
    scene : Scene
        Every object's triangles in one Embree scene (for a level,
        ``SceneObjects.combined``).
    triangle_object : (F,) int
        Object of each triangle of ``scene``.
    camera : OrthoCamera or PerspectiveCamera
        The view; the image is ``camera.shape``.
    skip : (n,) bool, optional
        Objects the rays pass through (a sky dome over a plan, see-through
        glass): a ray hitting one goes on ``RAY_STEP_RELATIVE`` x the scene's
        diagonal past it, through at most :data:`MAX_PASSED_LAYERS` of them,
        then sees nothing. Default: none passed.
    start : ObjectImage, optional
        An earlier cast of the same scene from the same camera: its first
        hits are taken as this cast's, so that a cast passing ``skip`` (the
        objects hidden behind the visible ones, say) costs only the rays
        that pass. Default: cast from the eye.

    Returns
    -------
    ObjectImage

    Raises
    ------
    InputError
        If ``triangle_object`` does not have one entry per triangle of
        ``scene``, or ``skip`` is not one flag per object.

    Notes
    -----
    One batched first-hit query (and one more per layer of passed objects);
    no Python work per pixel. Deterministic.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box(extents=(2, 2, 2))
    >>> cam = OrthoCamera((0, 0, -1), (0, 0, 0), 4.0, 4)
    >>> img = object_image(Scene(box), np.zeros(12, dtype=int), cam)
    >>> img.object.tolist()[1], float(img.facing[1, 1])
    ([-1, 0, 0, -1], 1.0)
    """
    owner = np.asarray(triangle_object)
    if owner.shape != (len(scene.faces),) or not np.issubdtype(owner.dtype, np.integer):
        raise InputError(f"triangle_object: expected ({len(scene.faces)},) integer object ids, "
                         f"got {owner.shape} {owner.dtype}")
    passed = None
    if skip is not None:
        count = int(owner.max()) + 1 if len(owner) else 0
        passed = np.asarray(skip, dtype=bool).reshape(-1)
        if len(passed) < count:
            raise InputError(f"skip: expected one flag per object (at least {count}), got "
                             f"{len(passed)}")
    origins, directions = camera.rays()
    if start is None:
        t, tri = scene.first_hit(origins, directions)
    else:
        if start.shape != camera.shape:
            raise InputError(f"start: expected an image of {camera.shape}, got {start.shape}")
        t, tri = start.depth.reshape(-1).copy(), start.triangle.reshape(-1).copy()
    if passed is not None and passed.any():
        step = RAY_STEP_RELATIVE * scene.diagonal
        live = np.flatnonzero(tri >= 0)
        live = live[passed[owner[tri[live]]]]
        for _ in range(MAX_PASSED_LAYERS):
            if len(live) == 0:
                break
            start = t[live] + step
            t2, tri2 = scene.first_hit(origins[live] + directions[live] * start[:, None],
                                       directions[live])
            t[live], tri[live] = start + t2, tri2
            live = live[tri2 >= 0]
            live = live[passed[owner[tri[live]]]]
        t[live], tri[live] = np.inf, -1  # still passing: sees nothing more
    hit = tri >= 0
    obj = np.full(len(tri), -1, dtype=np.int64)
    obj[hit] = owner[tri[hit]]
    normal = np.zeros((len(tri), 3), dtype=np.float64)
    normal[hit] = _triangle_normals(scene, tri[hit])
    cos = np.einsum("ij,ij->i", normal, directions)
    normal[cos > 0] *= -1.0  # towards the eye
    shape = camera.shape
    return ObjectImage(object=obj.reshape(shape), triangle=tri.reshape(shape),
                       normal=normal.astype(np.float32).reshape(*shape, 3),
                       facing=np.abs(cos).astype(np.float32).reshape(shape),
                       depth=np.where(hit, t, np.inf).reshape(shape))


def _edges(image: ObjectImage) -> np.ndarray:
    """(H, W) bool: pixels on an outline (a change of object, crease or depth jump with
    the pixel to the right or below, either side marked)."""
    obj, n, d = image.object, image.normal, image.depth
    edge = np.zeros(obj.shape, dtype=bool)
    cos_crease = np.cos(np.radians(CREASE_DEGREES))
    for axis in (0, 1):
        a = [slice(None)] * 2
        b = [slice(None)] * 2
        a[axis], b[axis] = slice(None, -1), slice(1, None)
        a, b = tuple(a), tuple(b)
        both = (obj[a] >= 0) & (obj[b] >= 0)
        with np.errstate(invalid="ignore"):
            near = np.minimum(d[a], d[b])
            jump = np.abs(d[a] - d[b]) > DEPTH_EDGE_RELATIVE * near
        crease = np.einsum("ijk,ijk->ij", n[a], n[b]) < cos_crease
        change = (obj[a] != obj[b]) | (both & (crease | jump))
        edge[a] |= change
        edge[b] |= change
    return edge


def _as_colors(colors: npt.ArrayLike, count: int) -> np.ndarray:
    c = np.asarray(colors, dtype=np.float64)
    if c.ndim != 2 or c.shape[1] != 3 or len(c) < count or not np.isfinite(c).all():
        raise InputError(f"colors: expected (n, 3) RGB in [0, 1] with n >= {count}, got "
                         f"shape {c.shape}")
    return np.clip(c, 0.0, 1.0)


def shade(image: ObjectImage, colors: npt.ArrayLike, *,
          background: npt.ArrayLike = BACKGROUND_RGB) -> np.ndarray:
    """A picture of an object image: each object in its colour, shaded, outlined.

    Parameters
    ----------
    image : ObjectImage
        From :func:`object_image`.
    colors : (n, 3) float
        RGB in [0, 1] of each object (for example by what happened to it in a
        culling frame); at least one row per object id in ``image``.
    background : (3,) float, optional
        RGB of pixels that see nothing (default :data:`BACKGROUND_RGB`).

    Returns
    -------
    rgb : (H, W, 3) uint8

    Raises
    ------
    InputError
        If ``colors`` is not (n, 3) with a row for every object seen.

    Notes
    -----
    A pixel's colour is its object's times ``AMBIENT + (1 - AMBIENT) *
    facing`` (Lambert's law, light at the eye) times a factor in
    [``ID_SHADE_LOW``, 1] set by the object's id; outlines (object changes,
    creases over :data:`CREASE_DEGREES`, depth jumps) are :data:`OUTLINE_RGB`.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box(extents=(2, 2, 2))
    >>> cam = OrthoCamera((0, 0, -1), (0, 0, 0), 4.0, 8)
    >>> rgb = shade(object_image(Scene(box), np.zeros(12, dtype=int), cam), [[1.0, 0, 0]])
    >>> rgb.shape, rgb[4, 4].tolist(), rgb[0, 0].tolist()
    ((8, 8, 3), [255, 0, 0], [247, 247, 250])
    """
    obj = image.object
    hit = obj >= 0
    c = _as_colors(colors, int(obj.max()) + 1 if hit.any() else 0)
    n = len(c)
    # one palette row per object and one for the background; every pixel at once
    palette = np.vstack([c, np.asarray(background, dtype=np.float64).reshape(1, 3)])
    tone = 1.0 - (1.0 - ID_SHADE_LOW) * ((np.arange(n) * _GOLDEN) % 1.0)  # object 0: 1
    tone = np.append(tone, 1.0).astype(np.float32)
    idx = np.where(hit, obj, n)
    light = np.where(hit, AMBIENT + (1.0 - AMBIENT) * image.facing, 1.0).astype(np.float32)
    rgb = palette.astype(np.float32)[idx] * (light * tone[idx])[..., None]
    rgb[image.outline] = OUTLINE_RGB
    return np.round(rgb * 255).astype(np.uint8)


def overlay(rgb: npt.ArrayLike, image: ObjectImage, color: npt.ArrayLike | None = None, *,
            colors: npt.ArrayLike | None = None, alpha: float = 0.35,
            outline: bool = True) -> np.ndarray:
    """Draw a second cast over a picture: translucent fill, opaque outlines.

    Parameters
    ----------
    rgb : (H, W, 3) uint8
        The picture (:func:`shade`), not modified.
    image : ObjectImage
        What is drawn over it, cast from the same camera (occluders, or the
        objects hidden behind the visible ones).
    color : (3,) float, optional
        RGB in [0, 1] of everything in ``image``.
    colors : (n, 3) float, optional
        Or one RGB per object of ``image``.
    alpha : float, optional
        Opacity of the fill, in [0, 1] (default 0.35), shaded by facing.
    outline : bool, optional
        Draw the outlines of ``image`` in its colours, opaque (default True).

    Returns
    -------
    rgb : (H, W, 3) uint8
        A new picture.

    Raises
    ------
    InputError
        Shapes that differ, neither or both of ``color`` and ``colors``, or an
        ``alpha`` outside [0, 1].

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box(extents=(2, 2, 2))
    >>> cam = OrthoCamera((0, 0, -1), (0, 0, 0), 4.0, 8)
    >>> img = object_image(Scene(box), np.zeros(12, dtype=int), cam)
    >>> out = overlay(np.zeros((8, 8, 3), np.uint8), img, (0.0, 0.0, 1.0), alpha=0.5)
    >>> out[4, 4].tolist(), out[0, 0].tolist()
    ([0, 0, 128], [0, 0, 0])
    """
    base = np.asarray(rgb)
    if base.shape != (*image.shape, 3):
        raise InputError(f"rgb: expected shape {(*image.shape, 3)}, got {base.shape}")
    if (color is None) == (colors is None):
        raise InputError("overlay: give color or colors, not both")
    alpha = float(alpha)
    if not 0.0 <= alpha <= 1.0:
        raise InputError(f"alpha: expected a value in [0, 1], got {alpha}")
    hit = image.hit
    if color is not None:
        per = np.clip(np.asarray(color, dtype=np.float64).reshape(1, 3), 0.0, 1.0)
        idx = np.zeros(image.shape, dtype=np.int64)
    else:
        per = _as_colors(colors, int(image.object.max()) + 1 if hit.any() else 0)  # type: ignore[arg-type]
        idx = np.maximum(image.object, 0)
    per = per.astype(np.float32)
    out = base.astype(np.float32) / np.float32(255.0)
    weight = np.where(hit, alpha, 0.0).astype(np.float32)[..., None]
    light = (AMBIENT + (1.0 - AMBIENT) * image.facing).astype(np.float32)[..., None]
    out = (1.0 - weight) * out + weight * (per[idx] * light)
    if outline:
        edge = image.outline & hit
        out[edge] = per[idx[edge]]
    return np.round(out * 255).astype(np.uint8)
