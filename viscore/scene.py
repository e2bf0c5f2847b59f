"""Embree scene of one triangle soup: batched first-hit, any-hit and all-hits queries.

The one place that holds an Embree handle (DESIGN.md, "The core"). The scene
is built once, in robust mode so that rays through shared edges are not lost,
from the mesh translated to its bounding-box centre and scaled to unit size
(by a power of two, so the scaling itself is exact): Embree computes in
float32, whose error is relative, so a mesh of size 1e-12 or 1e17 is traced
as accurately as one of size 1. Queries take and return float64 in world
units: ray origins are mapped into the unit frame, distances mapped back.
Batches are split over a thread pool, one worker per core by default:
embreex releases the GIL inside ``EmbreeScene.run``.
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


def _unit_scale(diagonal: float) -> float:
    """The power of two nearest above ``diagonal`` (1 for a zero or non-finite one).

    Dividing by a power of two is exact in binary floating point (barring
    underflow, which validated meshes never reach), so the unit-size frame
    adds no rounding of its own.
    """
    if not np.isfinite(diagonal) or diagonal <= 0:
        return 1.0
    _, exponent = np.frexp(diagonal)  # diagonal = m * 2**exponent, 0.5 <= m < 1
    return float(np.ldexp(1.0, int(exponent)))


def _as_max_distance(value: npt.ArrayLike | None, n: int) -> np.ndarray | None:
    """``(n,)`` float64 segment lengths (world units, >= 0, inf allowed) or None."""
    if value is None:
        return None
    try:
        arr = np.asarray(value, dtype=np.float64)
        arr = np.broadcast_to(arr, (n,))
    except (TypeError, ValueError) as exc:
        raise InputError(f"max_distance: expected a number or one per ray ({n}), "
                         f"got {value!r:.80}") from exc
    if np.isnan(arr).any():
        raise InputError("max_distance: contains NaN")
    if (arr < 0).any():
        raise InputError("max_distance: expected non-negative distances")
    return arr


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
    return cpu_cores()


def cpu_cores() -> int:
    """CPU cores this process may run on (its affinity set where the OS has one), >= 1."""
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

    Attributes
    ----------
    vertices : (v, 3) float64
        The mesh's vertices, world units; read-only (the Embree scene built
        from them is cached).
    faces : (f, 3) int64
        Vertex indices of each triangle; read-only.
    bounds : (2, 3) float64
        Lower and upper corner of the bounding box, world units.
    diagonal : float
        Bounding-box diagonal, world units.

    Notes
    -----
    Back faces count: a ray hits a triangle from either side. The mesh is
    traced centred and scaled to unit size by a power of two near its
    diagonal, so distances are exact up to Embree's float32 arithmetic
    relative to the mesh's own size (about 1e-6 of the diagonal), at any
    scale: ray origins and ``max_distance`` are mapped into the unit frame
    and distances back to world units. What float32 cannot hold relative to
    the mesh's size is refused by :func:`viscore.validate_mesh`. Ray origins
    farther than ~1e38 diagonals from the mesh are refused. The Embree handle
    is not pickled; it is rebuilt from the stored arrays after unpickling.

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
        vertices = np.array(mesh.vertices, dtype=np.float64)
        faces = np.array(mesh.faces, dtype=np.int64)
        if not np.isfinite(vertices).all():
            raise InputError("mesh: vertex coordinates contain NaN or infinite values")
        if faces.min() < 0 or faces.max() >= len(vertices):
            raise InputError("mesh: faces index vertices that do not exist")
        self.workers = None if workers is None else as_positive_int(workers, "workers")
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        vertices.flags.writeable = False
        faces.flags.writeable = False
        self._vertices, self._faces = vertices, faces
        self.bounds = np.stack([lo, hi])
        self.bounds.flags.writeable = False
        self._offset = 0.5 * lo + 0.5 * hi  # halves: no overflow near float64's limit
        half = 0.5 * hi - 0.5 * lo
        self.diagonal = 2.0 * float(np.linalg.norm(half))
        self._scale = _unit_scale(self.diagonal)

    @property
    def vertices(self) -> np.ndarray:
        """``(v, 3) float64`` vertices, world units (read-only)."""
        return self._vertices

    @property
    def faces(self) -> np.ndarray:
        """``(f, 3) int64`` triangles (read-only)."""
        return self._faces

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state.pop("_embree", None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        for name in ("_vertices", "_faces", "bounds"):  # unpickled arrays come back writeable
            arr = self.__dict__[name]
            if arr.flags.writeable:
                arr = arr.copy()
                arr.flags.writeable = False
                self.__dict__[name] = arr

    @cached_property
    def _embree(self):
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        scene = rtcore_scene.EmbreeScene(robust=True)
        unit = (self._vertices - self._offset) / self._scale  # power of two: exact
        TriangleMesh(scene, np.ascontiguousarray(unit, dtype=np.float32),
                     np.ascontiguousarray(self._faces, dtype=np.int32))
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
        offset, scale = self._offset, self._scale
        if intersect:
            t_out = np.empty(n)
            tri_out = np.empty(n, dtype=np.int64)
        else:
            hit_out = np.empty(n, dtype=bool)

        def run(sl: slice) -> None:
            # checks and conversion happen per chunk, in cache, and on the pool too
            with np.errstate(over="ignore", invalid="ignore"):  # checked just below
                o32 = np.ascontiguousarray((o[sl] - offset) / scale, dtype=np.float32)
            d32 = np.ascontiguousarray(d[sl], dtype=np.float32)
            if check_values:
                if not np.isfinite(o32).all():  # also origins beyond float32's range
                    if not np.isfinite(o[sl]).all():
                        raise InputError("origins: contains NaN or infinite values")
                    raise InputError("origins: too far from the mesh for float32 ray "
                                     "tracing (beyond ~1e38 x its diagonal)")
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
                np.minimum(tfar[sl] / scale, _EMBREE_MISS_T), dtype=np.float32)
            if intersect:
                res = scene.run(o32, d32, dists=dists, output=1)
                tri, t = res["primID"], res["tfar"]
                t_world = t.astype(np.float64) * scale  # power of two: exact
                t_world[tri < 0] = np.inf
                tri_out[sl] = tri
                t_out[sl] = t_world
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
            Hits beyond this distance (world units, >= 0; ``inf`` allowed) are
            ignored. Default: none.

        Returns
        -------
        t : (n,) float64
            Distance to the nearest hit, ``inf`` on a miss.
        triangle : (n,) int64
            Index of the hit triangle, ``-1`` on a miss.

        Raises
        ------
        InputError
            On shapes other than (n, 3), NaN/inf values, zero directions, or a
            NaN or negative ``max_distance``.
        """
        o, d = self._prepare(origins, directions, check_values=False)
        tfar = _as_max_distance(max_distance, len(o))
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

        Raises
        ------
        InputError
            As :meth:`first_hit`.
        """
        o, d = self._prepare(origins, directions, check_values=False)
        tfar = _as_max_distance(max_distance, len(o))
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
