"""Culling runtimes as the simulation drives them, and the view-frustum test they share.

A runtime answers, each frame, which occludee boxes its occluders hide
(:class:`Runtime`); the runtimes wrap the library's culling code, and the
occluders they use are inputs (this module never imports
:mod:`viscore.generators`):

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

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from viscore import PerspectiveCamera
from viscore._validate import as_positive_int
from viscore.constants import DEFAULT_REDUCTION

__all__ = ["Runtime", "no_culling", "frusta_runtime", "depth_buffer_runtime",
           "view_frustum_mask"]


@dataclass(frozen=True)
class Runtime:
    """A culling runtime as the simulation drives it.

    Attributes
    ----------
    cull : callable
        ``cull(camera, lower, upper) -> (n,) bool``: the occludees hidden this
        frame, given the frame's :class:`~viscore.PerspectiveCamera` and the
        ``(n, 3)`` lower and upper corners of the boxes that survived view
        frustum culling. Its wall time is the runtime's overhead.
    conservative : bool
        True when every occluder it uses carries a conservativeness guarantee
        (see :func:`viscore.generators.levels.occluders.culling_runtimes`: the
        generator's per-mesh word, not only its registry flag); a conservative
        runtime must never cull a visible object.
    occluders : int
        Occluders (solids, polygons or meshes) it holds; 0 for ``none``.
    occluder_scene : callable, optional
        ``occluder_scene(camera) -> Scene or None``: the Embree scene of the
        occluders it draws or tests for that camera (a hierarchy's cut for the
        frame; every solid of the frusta runtimes, which use the best ranked
        of them), for pictures of the frame; None (the default) for a runtime
        without occluders.
    cull_triangles : callable, optional
        ``cull_triangles(camera, triangles, start) -> (g,) bool``: the occludees hidden
        this frame tested through their own ``(m, 3, 3)`` world triangles, occludee
        ``k`` being ``triangles[start[k]:start[k + 1]]`` (``--bounds triangles``); None
        (the default) for a runtime that tests boxes only (it then gets each
        triangle's box).
    """

    cull: Callable[[PerspectiveCamera, np.ndarray, np.ndarray], np.ndarray]
    conservative: bool = True
    occluders: int = 0
    occluder_scene: Callable[[PerspectiveCamera], object] | None = None
    cull_triangles: Callable[[PerspectiveCamera, np.ndarray, np.ndarray], np.ndarray] | None \
        = None


def _nothing(camera, lower, upper) -> np.ndarray:
    return np.zeros(len(lower), dtype=bool)


def no_culling() -> Runtime:
    """The ``none`` runtime: no occlusion culling (view frustum culling only)."""
    return Runtime(cull=_nothing, conservative=True, occluders=0)


def frusta_runtime(solids: Sequence, *, mode: str = "solid", active: int = 15,
                   polygons: Sequence | None = None, cap: str = "front-faces",
                   rank: str = "faces", conservative: bool = True) -> Runtime:
    """Shadow-frustum runtime of convex solids (Papaioannou et al. 2006).

    Parameters
    ----------
    solids : list of (vertices, faces)
        Convex solids in world units (``Occluder.parts["solids"]``).
    mode : {'solid', 'planar'}, optional
        One frustum per solid (``solid-frusta``, default) or one per face
        (``planar-frusta``): the comparison of the paper.
    active : int, optional
        Occluders ranked best each frame that make frusta (default 15, sec. 3).
    polygons : list of (m, 3) float, optional
        Extra convex planar occluders (two-sided).
    cap : {'front-faces', 'eq2'}, optional
        Near cap of the solid frusta: 'front-faces' (default), the planes of
        the faces the eye sees (the exact shadow, which holds every face's
        planar frustum), or 'eq2', the paper's single plane through the
        furthest silhouette point.
    rank : {'faces', 'eq4'}, optional
        Ranking of the solids: 'faces' (default), a solid ranks as its best
        face by eq. 3, or 'eq4', ``f_solid = Vol / |V|^3``. With 'front-faces'
        and 'faces', solid frusta cull every box the planar frusta of the same
        solids cull, every frame (:class:`viscore.culling.FrustumCuller`).
    conservative : bool, optional
        Whether the solids carry the conservativeness guarantee (default True).

    Returns
    -------
    Runtime

    Raises
    ------
    InputError
        From :class:`viscore.culling.FrustumCuller` on a solid that is not
        closed and convex, or a bad option.
    """
    from viscore.culling.frustum_culler import FrustumCuller

    solids = list(solids)
    culler = FrustumCuller(solids, polygons=polygons, mode=mode, active=active, cap=cap,
                           rank=rank)
    return Runtime(cull=culler.cull, conservative=bool(conservative), occluders=culler.count,
                   occluder_scene=_solids_scene(solids, polygons))


def _solids_scene(solids: list, polygons: Sequence | None) -> Callable:
    """``occluder_scene`` of a frusta runtime: its solids and polygons (fans) in one
    Embree scene, built on first use and kept."""
    built: list = []

    def scene(camera):
        if not built:
            import trimesh

            from viscore import Scene

            parts = [(np.asarray(v, np.float64), np.asarray(f, np.int64)) for v, f in solids]
            for p in polygons or ():
                p = np.asarray(p, np.float64)
                fan = np.stack([np.zeros(len(p) - 2, np.int64), np.arange(1, len(p) - 1),
                                np.arange(2, len(p))], axis=1)
                parts.append((p, fan))
            parts = [(v, f) for v, f in parts if len(f)]
            if not parts:
                built.append(None)
            else:
                offsets = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
                mesh = trimesh.Trimesh(np.vstack([v for v, _ in parts]),
                                       np.vstack([f + o for (_, f), o in zip(parts, offsets,
                                                                             strict=True)]),
                                       process=False)
                built.append(Scene(mesh))
        return built[0]

    return scene


def depth_buffer_runtime(occluders, *, reduction: int = DEFAULT_REDUCTION,
                         conservative: bool = True, count: int | None = None) -> Runtime:
    """Conservative reduced-resolution depth-buffer runtime (occluder skins, sec. 5-6).

    Parameters
    ----------
    occluders : list of Occluder or trimesh.Trimesh, or callable
        The occluders in world units, anything
        :class:`viscore.culling.depth_buffer.OccluderScene` accepts (prepared once
        here); or ``occluders(camera) -> OccluderScene`` called every frame
        (for example the cut of a planar-sections hierarchy for the frame's
        camera), whose time counts in the overhead.
    reduction : int, optional
        Screen pixels per buffer pixel along each side (default
        :data:`~viscore.constants.DEFAULT_REDUCTION`, 2: 640 x 360 for
        1280 x 720, a quarter of the screen's pixels, sec. 7).
    conservative : bool, optional
        Whether the occluders carry the conservativeness guarantee.
    count : int, optional
        Occluders it holds, for the report (default: ``len(occluders)`` for a
        list).

    Returns
    -------
    Runtime

    Notes
    -----
    Conservative by construction (see :mod:`viscore.culling.depth_buffer`): a buffer
    pixel holds a depth only where its whole footprint is covered, never
    farther than the occluders, so objects seen through sub-pixel gaps are
    not culled.
    """
    from viscore.culling.depth_buffer import ConservativeDepthBuffer, OccluderScene

    reduction = as_positive_int(reduction, "reduction", maximum=1024)
    if callable(occluders):
        per_frame = occluders
        n = 0 if count is None else int(count)
    else:
        items = list(occluders)
        prepared = OccluderScene(items)

        def per_frame(camera, prepared=prepared):
            return prepared
        n = len(items) if count is None else int(count)

    def buffer(camera: PerspectiveCamera) -> ConservativeDepthBuffer:
        rows, cols = camera.shape
        return ConservativeDepthBuffer.from_occluders(
            per_frame(camera), camera, width=max(1, cols // reduction),
            height=max(1, rows // reduction))

    def cull(camera: PerspectiveCamera, lower, upper) -> np.ndarray:
        return buffer(camera).occluded(lower, upper)

    def cull_triangles(camera: PerspectiveCamera, triangles, start) -> np.ndarray:
        return buffer(camera).occluded_triangles(triangles, start)

    def scene(camera: PerspectiveCamera):
        return per_frame(camera).scene

    return Runtime(cull=cull, conservative=bool(conservative), occluders=n,
                   occluder_scene=scene, cull_triangles=cull_triangles)


# --------------------------------------------------------------------------- view frustum
def view_frustum_mask(camera: PerspectiveCamera, lower: npt.ArrayLike, upper: npt.ArrayLike
                      ) -> np.ndarray:
    """Boxes that may intersect the camera's view frustum (conservative).

    A box is rejected when it lies wholly outside one of the four side planes
    through the eye and the image edges, or wholly behind the eye; every box
    holding a point that projects inside the image is kept.

    Parameters
    ----------
    camera : PerspectiveCamera
    lower, upper : (n, 3) float
        Box corners, world units.

    Returns
    -------
    in_view : (n,) bool

    Examples
    --------
    >>> from viscore import PerspectiveCamera
    >>> cam = PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 1, 0), fov=90, resolution=4)
    >>> view_frustum_mask(cam, [[-1, -1, 5], [-1, -1, -6]], [[1, 1, 6], [1, 1, -5]]).tolist()
    [True, False]
    """
    lo = np.asarray(lower, dtype=np.float64).reshape(-1, 3)
    hi = np.asarray(upper, dtype=np.float64).reshape(-1, 3)
    f, r, u = camera.basis
    hx = float(np.tan(np.radians(camera.fov) / 2))
    hy = float(np.tan(np.radians(camera.vertical_fov) / 2))
    normals = np.array([hx * f - r, hx * f + r, hy * f - u, hy * f + u, f])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    d = -(normals @ camera.position)
    # the box corner furthest along each inward normal
    far = np.where(normals[None, :, :] >= 0, hi[:, None, :], lo[:, None, :])
    reach = np.einsum("nkj,kj->nk", far, normals) + d
    return (reach >= 0).all(axis=1)
