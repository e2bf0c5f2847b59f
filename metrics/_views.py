"""Ray casting for the evaluation protocols (shared by the metrics modules)."""

from __future__ import annotations

import time

import numpy as np
import trimesh

from viscore import InputError, Scene, validate_mesh
from viscore._jit import njit_cached


def scene_of(mesh: trimesh.Trimesh | Scene | None, name: str) -> Scene | None:
    """A Scene for a mesh; None for an empty occluder (it covers nothing)."""
    if mesh is None or isinstance(mesh, Scene):
        return mesh
    if not isinstance(mesh, trimesh.Trimesh):
        raise InputError(f"{name}: expected a trimesh.Trimesh, got {type(mesh).__name__}")
    if len(mesh.faces) == 0:
        if name == "mesh":
            raise InputError("mesh: the original mesh is empty")
        return None
    checked = validate_mesh(mesh, name=name)
    # the original is scored against every occluder of a job: its BVH is built once
    return Scene.shared(checked) if name == "mesh" else Scene(checked)


def cast_depths(scene: Scene | None, origins: np.ndarray, directions: np.ndarray, images: int,
                resolution: int, timing: dict) -> np.ndarray:
    """``(images, R, R)`` depth images (inf where empty) from concatenated pixel rays."""
    if scene is None:
        return np.full((images, resolution, resolution), np.inf)
    start = time.perf_counter()
    t, _ = scene.first_hit(origins, directions)
    timing["seconds_rays"] = timing.get("seconds_rays", 0.0) + time.perf_counter() - start
    timing["rays"] = timing.get("rays", 0) + len(origins)
    return t.reshape(images, resolution, resolution)


def cast_hits(scene: Scene, origins: np.ndarray, directions: np.ndarray, timing: dict, *,
              depth: bool) -> np.ndarray:
    """``(n,)`` first-hit distances (``inf`` on a miss) with ``depth``, else hit flags."""
    start = time.perf_counter()
    if depth:
        out, _ = scene.first_hit(origins, directions)
    else:
        out = scene.any_hit(origins, directions)
    timing["seconds_rays"] = timing.get("seconds_rays", 0.0) + time.perf_counter() - start
    timing["rays"] = timing.get("rays", 0) + len(origins)
    return out


def ortho_box_rays(camera, box: tuple) -> tuple[np.ndarray, np.ndarray]:
    """The rays of ``camera.rays()`` for the pixels of ``box`` only, row-major.

    ``box`` is (row0, col0, row1, col1), exclusive ends. Computed with the
    same arithmetic as :meth:`viscore.OrthoCamera.rays` (the same operations
    on the same float64 values in the same order, one pixel at a time instead
    of one array temporary per operation), so the origins are bit for bit
    those of the whole image's rays (a test checks it).
    """
    f, r, u = (np.ascontiguousarray(a, dtype=np.float64) for a in camera.basis)
    res = camera.resolution
    c = (np.arange(res) + 0.5) / res - 0.5
    r0, c0, r1, c1 = (int(v) for v in box)
    origins = np.empty(((r1 - r0) * (c1 - c0), 3))
    _ortho_origins(c, r0, c0, r1, c1, np.asarray(camera.center, dtype=np.float64),
                   float(camera.extent), r, u, camera.start * f, origins)
    return origins, np.broadcast_to(f, origins.shape)


@njit_cached(nogil=True)
def _ortho_origins(c, r0, c0, r1, c1, center, extent, right, up, start_f, out
                   ):  # pragma: no cover
    """``out[k]`` = center + extent * (x * right + y * up) - start_f for the pixels of the
    box row-major (x = c[col], y = -c[row]), each operation as numpy evaluates
    :meth:`viscore.OrthoCamera.rays`' array expression."""
    k = 0
    for i in range(r0, r1):
        y = -c[i]
        for j in range(c0, c1):
            x = c[j]
            for a in range(3):
                out[k, a] = (center[a] + extent * (x * right[a] + y * up[a])) - start_f[a]
            k += 1
