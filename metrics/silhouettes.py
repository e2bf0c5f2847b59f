"""Colour-coded silhouettes of an occluder over its original (Silvennoinen et al. 2014, Fig. 7).

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
"""

from __future__ import annotations

import numpy as np
import trimesh

from viscore import InputError, OrthoCamera, Scene
from viscore._validate import as_positive_int, check_memory

from ._views import scene_of
from .erosion import _MAX_RESOLUTION, _RAYS_PER_BATCH, _coverage, _ray_inside
from .frames import orbit_frame

__all__ = ["silhouette_image", "SILHOUETTE_COLOURS"]

#: RGB of each class: background, original only, both, occluder only.
SILHOUETTE_COLOURS = {"background": (255, 255, 255), "original": (0, 0, 0),
                      "both": (240, 200, 0), "occluder": (30, 90, 230)}


def silhouette_image(mesh: trimesh.Trimesh | Scene, occluder: trimesh.Trimesh | Scene | None,
                     direction, *, resolution: int = 256,
                     frame: tuple | None = None) -> np.ndarray:
    """RGB image: original only black, overlap yellow, over-occlusion blue.

    Parameters
    ----------
    mesh : trimesh.Trimesh or Scene
        The original; its mesh sets the orbit frame. A prebuilt
        :class:`viscore.Scene` (with ``frame``) is cast as it is, so that many
        images of one mesh share one Embree scene.
    occluder : trimesh.Trimesh, Scene or None
    direction : (3,) float
        Viewing direction.
    resolution : int, optional
        At most 8192. Default 256.
    frame : (center, extent), optional
        The original's :func:`~viscore.metrics.orbit_frame`; required when
        ``mesh`` is a Scene, computed from the mesh otherwise.

    Returns
    -------
    image : (R, R, 3) uint8

    Raises
    ------
    InputError
        On an empty original, a zero direction or a bad resolution.

    References
    ----------
    .. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
       Simplification using Planar Sections". Computer Graphics Forum 33(1),
       2014, pp. 235-245. :DOI:`10.1111/cgf.12271`

    Examples
    --------
    >>> box = trimesh.creation.box()
    >>> img = silhouette_image(box, box, (0, 0, 1), resolution=8)
    >>> tuple(int(c) for c in img[4, 4])
    (240, 200, 0)
    """
    resolution = as_positive_int(resolution, "resolution", maximum=_MAX_RESOLUTION)
    # two coverage images and the RGB image; rays are cast a batch at a time
    check_memory(5.0 * resolution**2 + 96.0 * _RAYS_PER_BATCH, f"resolution={resolution}")
    if frame is None and isinstance(mesh, Scene):
        raise InputError("frame: required when the original is given as a Scene")
    original = scene_of(mesh, "mesh")
    other = scene_of(occluder, "occluder")
    center, extent = orbit_frame(mesh) if frame is None else frame
    cam = OrthoCamera(direction, center, extent, resolution)
    orig = _coverage(_ray_inside(original, cam), resolution)  # type: ignore[arg-type]
    occ = (_coverage(_ray_inside(other, cam), resolution) if other is not None
           else np.zeros_like(orig))
    image = np.empty(orig.shape + (3,), dtype=np.uint8)
    image[:] = SILHOUETTE_COLOURS["background"]
    image[orig & ~occ] = SILHOUETTE_COLOURS["original"]
    image[orig & occ] = SILHOUETTE_COLOURS["both"]
    image[~orig & occ] = SILHOUETTE_COLOURS["occluder"]
    return image
