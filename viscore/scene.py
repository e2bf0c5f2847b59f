"""Embree scene of one triangle soup: batched first-hit, any-hit and all-hits queries.

The one place that holds an Embree handle (DESIGN.md, "The core"). The scene
is built once, in robust mode so that rays through shared edges are not lost,
from the mesh translated to its bounding-box centre (float32 keeps more digits
near the origin); queries take and return float64 in world units. Batches are
split over a thread pool, one worker per core by default: embreex releases the
GIL inside ``EmbreeScene.run``.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt
import trimesh

from ._validate import InputError, as_points, as_positive_int, as_unit_vectors
from .constants import MAX_HITS, MIN_RAYS_PER_TASK, RAY_STEP_RELATIVE

__all__ = ["Scene", "AllHits", "set_workers", "get_workers"]

#: Squared-norm tolerance of directions taken as unit in float32 (a few ulps).
_UNIT_TOLERANCE_F32 = 1e-6

#: Embree reports a miss as this tfar (its initial "infinite" distance).
_EMBREE_MISS_T = 1e30

_workers: int | None = None


def set_workers(workers: int | None) -> None:
    """Set the default number of ray-casting threads (``None``: one per core).

    The command line's global ``--workers N`` calls this.
    """
    global _workers
    _workers = None if workers is None else as_positive_int(workers, "workers")


def get_workers() -> int:
    """The default number of ray-casting threads: as set, else one per CPU core."""
    if _workers is not None:
        return _workers
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


@dataclass(frozen=True)
class AllHits:
    """Every intersection along a batch of rays, sorted by ray, then distance.

    Attributes
    ----------
    ray : (m,) int64
        Index of the ray of each hit.
    t : (m,) float64
        Distance from the ray origin, world units.
    triangle : (m,) int64
        Index of the hit triangle.
    count : (n,) int64
        Number of hits of each ray (``np.bincount(ray, minlength=n)``).
    truncated : bool
        True if some ray reached ``max_hits`` and may have more hits.
    """

    ray: np.ndarray
    t: np.ndarray
    triangle: np.ndarray
    count: np.ndarray
    truncated: bool


class Scene:
    """Embree scene of one triangle soup, built once and queried many times.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Any triangle soup (open, non-manifold, many components). Use
        :func:`viscore.load_mesh` for files; the mesh is not modified.
    workers : int, optional
        Threads per query. Default: :func:`get_workers` at query time.

    Notes
    -----
    Back faces count: a ray hits a triangle from either side. Distances are
    exact up to Embree's float32 arithmetic (relative error about 1e-6 of
    the bounding-box diagonal). Not picklable: the Embree handle is rebuilt
    from the stored arrays after unpickling.

    Examples
    --------
    >>> import trimesh
    >>> scene = Scene(trimesh.creation.box(extents=(2, 2, 2)))
    >>> t, tri = scene.first_hit([[0, 0, -5]], [[0, 0, 1]])
    >>> round(float(t[0]), 5)   # Embree traces in float32: a few ulps of 4.0
    4.0
    """

    def __init__(self, mesh: trimesh.Trimesh, *, workers: int | None = None) -> None:
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            raise InputError("mesh: expected a non-empty trimesh.Trimesh")
        self.vertices = np.array(mesh.vertices, dtype=np.float64)
        self.faces = np.array(mesh.faces, dtype=np.int64)
        if not np.isfinite(self.vertices).all():
            raise InputError("mesh: vertex coordinates contain NaN or infinite values")
        self.workers = None if workers is None else as_positive_int(workers, "workers")
        lo, hi = self.vertices.min(axis=0), self.vertices.max(axis=0)
        self.bounds = np.stack([lo, hi])
        self.diagonal = float(np.linalg.norm(hi - lo))
        self._offset = 0.5 * (lo + hi)

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state.pop("_embree", None)
        return state

    @cached_property
    def _embree(self):
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        scene = rtcore_scene.EmbreeScene(robust=True)
        TriangleMesh(scene, np.ascontiguousarray(self.vertices - self._offset, dtype=np.float32),
                     np.ascontiguousarray(self.faces, dtype=np.int32))
        return scene

    def build(self) -> Scene:
        """Build the Embree scene now rather than at the first query; returns self."""
        _ = self._embree
        return self

    # ------------------------------------------------------------------ internals
    def _prepare(self, origins, directions, *, check_values: bool = True):
        """Coerce to float64 (n, 3) pairs; with ``check_values`` also finite and unit.

        ``first_hit`` and ``any_hit`` pass ``check_values=False`` and let
        :meth:`_cast` check each cache-sized chunk instead (same checks, one
        pass less over memory).
        """
        if check_values:
            o = as_points(origins, "origins", allow_empty=True)
            d = as_unit_vectors(directions, "directions")
        else:
            o = as_points(origins, "origins", allow_empty=True, finite=False)
            d = as_points(directions, "directions", allow_empty=True, finite=False)
        if len(o) != len(d):
            if len(o) == 1:
                o = np.broadcast_to(o, d.shape)
            else:
                raise InputError(f"origins and directions: lengths differ ({len(o)} vs {len(d)})")
        return o, d

    def _cast(self, o: np.ndarray, d: np.ndarray, tfar: np.ndarray | None, intersect: bool,
              check_values: bool = False):
        """One Embree pass over float64 world-space rays; chunks over the pool.

        Returns (t, tri) for ``intersect`` (t = inf, tri = -1 on a miss), else a
        bool occluded array.
        """
        n = len(o)
        if n == 0:
            return (np.zeros(0), np.zeros(0, dtype=np.int64)) if intersect else np.zeros(0, bool)
        scene = self._embree
        offset = self._offset
        if intersect:
            t_out = np.empty(n)
            tri_out = np.empty(n, dtype=np.int64)
        else:
            hit_out = np.empty(n, dtype=bool)

        def run(sl: slice) -> None:
            # checks and conversion happen per chunk, in cache, and on the pool too
            o32 = np.ascontiguousarray(o[sl] - offset, dtype=np.float32)
            d32 = np.ascontiguousarray(d[sl], dtype=np.float32)
            if check_values:
                if not np.isfinite(o32).all():  # also coordinates beyond float32's range
                    raise InputError("origins: contains NaN or infinite values")
                norm2 = np.einsum("ij,ij->i", d32, d32)
                if not np.isfinite(norm2).all():
                    raise InputError("directions: contains NaN or infinite values")
                if norm2.min() <= 0:
                    raise InputError("directions: contains zero-length direction vectors")
                if np.abs(norm2 - 1.0).max() > _UNIT_TOLERANCE_F32:
                    dc = d[sl]
                    d32 = np.ascontiguousarray(
                        dc / np.sqrt(np.einsum("ij,ij->i", dc, dc))[:, None], dtype=np.float32)
            dists = None if tfar is None else np.ascontiguousarray(
                np.minimum(tfar[sl], _EMBREE_MISS_T), dtype=np.float32)
            if intersect:
                res = scene.run(o32, d32, dists=dists, output=1)
                tri, t = res["primID"], res["tfar"]
                t[tri < 0] = np.inf
                tri_out[sl] = tri
                t_out[sl] = t
            else:
                hit_out[sl] = scene.run(o32, d32, dists=dists, query="OCCLUDED") >= 0

        workers = self.workers or get_workers()
        # cache-sized chunks: the float32 conversion of one chunk stays in cache
        tasks = max(1, n // MIN_RAYS_PER_TASK)
        bounds = np.linspace(0, n, tasks + 1).astype(int)
        slices = [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
        if workers == 1 or tasks == 1:
            for sl in slices:
                run(sl)
        else:
            with ThreadPoolExecutor(max_workers=workers) as pool:
                list(pool.map(run, slices))
        return (t_out, tri_out) if intersect else hit_out

    # ------------------------------------------------------------------ queries
    def first_hit(self, origins: npt.ArrayLike, directions: npt.ArrayLike, *,
                  max_distance: npt.ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Nearest intersection of each ray.

        Parameters
        ----------
        origins : (n, 3) float
            Ray origins, world units; one row is broadcast to all directions.
        directions : (n, 3) float
            Ray directions; normalised here, so distances are in world units.
        max_distance : float or (n,) float, optional
            Hits beyond this distance are ignored. Default: none.

        Returns
        -------
        t : (n,) float64
            Distance to the nearest hit, ``inf`` on a miss.
        triangle : (n,) int64
            Index of the hit triangle, ``-1`` on a miss.

        Raises
        ------
        InputError
            On shapes other than (n, 3), NaN/inf values or zero directions.
        """
        o, d = self._prepare(origins, directions, check_values=False)
        tfar = None if max_distance is None else np.broadcast_to(
            np.asarray(max_distance, dtype=np.float64), (len(o),))
        return self._cast(o, d, tfar, intersect=True, check_values=True)

    def any_hit(self, origins: npt.ArrayLike, directions: npt.ArrayLike, *,
                max_distance: npt.ArrayLike | None = None) -> np.ndarray:
        """Whether each ray hits anything within ``max_distance``.

        Parameters
        ----------
        origins, directions : (n, 3) float
            As in :meth:`first_hit`.
        max_distance : float or (n,) float, optional
            Segment length, world units. Default: unbounded.

        Returns
        -------
        occluded : (n,) bool
        """
        o, d = self._prepare(origins, directions, check_values=False)
        tfar = None if max_distance is None else np.broadcast_to(
            np.asarray(max_distance, dtype=np.float64), (len(o),))
        return self._cast(o, d, tfar, intersect=False, check_values=True)

    def all_hits(self, origins: npt.ArrayLike, directions: npt.ArrayLike, *,
                 max_hits: int = MAX_HITS) -> AllHits:
        """Every intersection along each ray, by repeating first-hit past the last hit.

        Parameters
        ----------
        origins, directions : (n, 3) float
            As in :meth:`first_hit`.
        max_hits : int, optional
            Bound on hits per ray (default :data:`viscore.constants.MAX_HITS`).

        Returns
        -------
        AllHits
            Hits sorted by ray then distance; ``count`` gives the depth
            complexity and ``count % 2`` the parity of each ray.

        Notes
        -----
        After each hit the ray restarts ``RAY_STEP_RELATIVE`` x diagonal past
        it, so a ray through an edge shared by two triangles counts one hit,
        and two surfaces closer together than that step count as one.
        """
        max_hits = as_positive_int(max_hits, "max_hits")
        o, d = self._prepare(origins, directions)
        step = RAY_STEP_RELATIVE * self.diagonal
        n = len(o)
        live = np.arange(n)
        travelled = np.zeros(n)
        rays, ts, tris = [], [], []
        truncated = False
        for k in range(max_hits):
            t, tri = self._cast(o[live] + d[live] * travelled[live, None], d[live], None, True)
            hit = tri >= 0
            live = live[hit]
            if len(live) == 0:
                break
            total = travelled[live] + t[hit]
            rays.append(live)
            ts.append(total)
            tris.append(tri[hit])
            travelled[live] = total + step
            if k == max_hits - 1:
                truncated = True
        if rays:
            ray = np.concatenate(rays)
            t_all = np.concatenate(ts)
            tri_all = np.concatenate(tris)
            order = np.lexsort((t_all, ray))
            ray, t_all, tri_all = ray[order], t_all[order], tri_all[order]
        else:
            ray, t_all, tri_all = (np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64))
        return AllHits(ray=ray, t=t_all, triangle=tri_all,
                       count=np.bincount(ray, minlength=n).astype(np.int64), truncated=truncated)
