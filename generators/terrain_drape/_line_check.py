"""Monte-Carlo check that every line through an occluder meets the mesh."""

from __future__ import annotations

import numpy as np
import trimesh

from viscore.ray.embree_scene import Scene
from viscore.ray.samplers import directions_uniform, stream_seed

__all__ = ["escaping_lines"]


def escaping_lines(mesh: trimesh.Trimesh, triangles: np.ndarray, *, points: int = 64,
                   lines: int = 32, seed: int = 0) -> np.ndarray:
    """Per triangle, how many of its sampled lines miss ``mesh`` both ways.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The mesh that must hide the occluder.
    triangles : (t, 3, 3) float
        The occluder's triangles, world units.
    points : int, optional
        Points per triangle (uniform in its area, seeded).
    lines : int, optional
        Lines per point, uniform directions (seeded).
    seed : int, optional

    Returns
    -------
    (t,) int64
        Escaping lines per triangle.

    Examples
    --------
    A square inside a closed box is hidden along every line; one beside it is not.

    >>> box = trimesh.creation.box(extents=(2, 2, 2))
    >>> inside = np.array([[[-.5, -.5, 0], [.5, -.5, 0], [.5, .5, 0]]])
    >>> escaping_lines(box, inside).tolist(), int(escaping_lines(box, inside + 3)[0]) > 0
    ([0], True)
    """
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    if len(tri) == 0:
        return np.zeros(0, np.int64)
    rng = np.random.default_rng(stream_seed(seed, "terrain-drape lines"))
    r1 = np.sqrt(rng.random((len(tri), points)))
    r2 = rng.random((len(tri), points))
    w = np.stack([1 - r1, r1 * (1 - r2), r1 * r2], -1)  # uniform in the triangle
    at = np.einsum("tpk,tkc->tpc", w, tri).reshape(-1, 3)
    d = directions_uniform(len(at) * lines, seed=stream_seed(seed, "terrain-drape dirs"))
    o = np.repeat(at, lines, axis=0)
    scene = Scene.shared(mesh)
    hit = scene.any_hit(o, d) | scene.any_hit(o, -d)
    return (~hit).reshape(len(tri), -1).sum(axis=1).astype(np.int64)
