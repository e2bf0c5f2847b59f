"""Coverage and depth images of a scene seen by a camera, by ray casting.

One batched Embree first-hit query per image, one ray per pixel centre (the
orbit protocol of Silvennoinen et al. 2014 [1]_, sec. 6.1, and the frusta of
Wu et al. 2022 [2]_, sec. 3.2, without a rasterizer).

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
"""

from __future__ import annotations

import numpy as np

from .cameras import OrthoCamera, PerspectiveCamera
from .embree_scene import Scene

__all__ = ["depth_image", "coverage_image"]


def depth_image(scene: Scene, camera: OrthoCamera | PerspectiveCamera) -> np.ndarray:
    """Distance from each pixel's ray origin to the first hit.

    Parameters
    ----------
    scene : Scene
        Embree scene of the mesh.
    camera : OrthoCamera or PerspectiveCamera
        Resolution R.

    Returns
    -------
    depth : (H, W) float64
        ``camera.shape``: (R, R), or (height, R) for a non-square
        :class:`PerspectiveCamera`. World units along the ray; ``inf`` where
        the ray misses. Row 0 is the top edge (towards the camera's up),
        column 0 the left edge.

    Examples
    --------
    >>> import trimesh
    >>> cam = OrthoCamera((0, 0, 1), (0, 0, 0), 4.0, 4, start=5.0)
    >>> d = depth_image(Scene(trimesh.creation.box(extents=(2, 2, 2))), cam)
    >>> round(float(d[1, 1]), 5), float(d[0, 0])   # float32 traces: a few ulps of 4.0
    (4.0, inf)
    """
    origins, directions = camera.rays()
    t, _ = scene.first_hit(origins, directions)
    return t.reshape(camera.shape)


def coverage_image(scene: Scene, camera: OrthoCamera | PerspectiveCamera) -> np.ndarray:
    """Which pixels' rays hit the mesh.

    Returns
    -------
    covered : (H, W) bool
        True where the pixel-centre ray hits any triangle (either side).

    Examples
    --------
    >>> import trimesh
    >>> cam = OrthoCamera((0, 0, 1), (0, 0, 0), 4.0, 4)
    >>> int(coverage_image(Scene(trimesh.creation.box(extents=(2, 2, 2))), cam).sum())
    4
    """
    return np.isfinite(depth_image(scene, camera))
