"""Colour-coded silhouettes of an occluder over its original (seed 000, Figure 7).

Silvennoinen et al. 2014, sec. 6 (seeds/000): "The original geometry is
rendered in black, the intersection of the original geometry and the
generated occluder is yellow. Over-occluded parts are coded in blue." The
images are orthographic coverage images of the orbit protocol's frame.
"""

from __future__ import annotations

import numpy as np
import trimesh

from viscore import OrthoCamera, coverage_image

from ._views import scene_of
from .orbit import orbit_frame

__all__ = ["silhouette_image", "SILHOUETTE_COLOURS"]

#: RGB of each class: background, original only, both, occluder only.
SILHOUETTE_COLOURS = {"background": (255, 255, 255), "original": (0, 0, 0),
                      "both": (240, 200, 0), "occluder": (30, 90, 230)}


def silhouette_image(mesh: trimesh.Trimesh, occluder: trimesh.Trimesh | None,
                     direction, *, resolution: int = 256) -> np.ndarray:
    """RGB image: original only black, overlap yellow, over-occlusion blue.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The original; sets the orbit frame.
    occluder : trimesh.Trimesh or None
    direction : (3,) float
        Viewing direction.
    resolution : int, optional
        Default 256.

    Returns
    -------
    image : (R, R, 3) uint8

    Examples
    --------
    >>> box = trimesh.creation.box()
    >>> img = silhouette_image(box, box, (0, 0, 1), resolution=8)
    >>> tuple(int(c) for c in img[4, 4])
    (240, 200, 0)
    """
    center, extent = orbit_frame(mesh)
    cam = OrthoCamera(direction, center, extent, resolution)
    orig = coverage_image(scene_of(mesh, "mesh"), cam)
    other = scene_of(occluder, "occluder")
    occ = coverage_image(other, cam) if other is not None else np.zeros_like(orig)
    image = np.empty(orig.shape + (3,), dtype=np.uint8)
    image[:] = SILHOUETTE_COLOURS["background"]
    image[orig & ~occ] = SILHOUETTE_COLOURS["original"]
    image[orig & occ] = SILHOUETTE_COLOURS["both"]
    image[~orig & occ] = SILHOUETTE_COLOURS["occluder"]
    return image
