"""Embree scene of one triangle soup: batched first-hit, any-hit and all-hits queries."""

from __future__ import annotations

import itertools
import logging
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt
import trimesh

from .._content_cache import ContentCache
from .._jit import njit_cached, pinned_kernels
from .._validate import InputError, as_points, as_positive_int, as_unit_vectors
from ..constants import MAX_HITS, MIN_RAYS_PER_TASK, RAY_STEP_RELATIVE

__all__ = ["Scene", "AllHits", "set_workers", "get_workers"]

_log = logging.getLogger(__name__)

#: Squared-norm tolerance of directions taken as unit in float32 (a few ulps).
_UNIT_TOLERANCE_F32 = 1e-6

#: Longest tfar handed to Embree, unit-frame units: ``max_distance`` is clamped
#: to it so that it stays finite in float32 (``inf`` included); every hit of the
#: unit-size scene is far nearer. Misses are told by triangle id -1, not by tfar.
_EMBREE_MISS_T = 1e30

#: Chunks per thread a large batch is cut into, at least: enough that a thread
#: slowed by other work on the machine leaves the rest to the others (the
#: chunks are claimed as the threads get free), few enough that each chunk
#: stays large (see ``_MAX_RAYS_PER_CHUNK``).
_CHUNKS_PER_WORKER = 4

#: Most rays per Embree call, rays. Each call on a chunk costs a few
#: microseconds however small the chunk, well under 1 ns a ray at this size
#: (against 80-300 ns a ray of tracing); larger chunks gain nothing and cost
#: memory: about 60 bytes a ray of per-thread buffers (float32 copies, Embree's
#: outputs), 4 MiB a thread here.
_MAX_RAYS_PER_CHUNK = 65536

#: Guided scheduling of the last chunks of a batch on several threads (see
#: :meth:`Scene._chunk_bounds`): each chunk at most this fraction of what is left
#: per thread, and no fewer rays than ``_TAIL_RAYS`` (half of
#: :data:`~viscore.constants.MIN_RAYS_PER_TASK`: some 2 ms of incoherent rays on
#: one core, where the fixed cost of a chunk is some 20 us).
_TAIL_SHARE = 2
_TAIL_RAYS = MIN_RAYS_PER_TASK // 2

#: The Scene of :meth:`Scene.shared` (one: the original mesh of the job at hand).
_SHARED = ContentCache(1)

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


#: A direction whose float32 squared norm is off 1 by more than this is looked at
#: closer (numpy decides, with ``_UNIT_TOLERANCE_F32``): a margin below the
#: tolerance, so that :func:`_unit_frame` never misses one numpy would normalise.
_NEAR_UNIT = 0.9 * _UNIT_TOLERANCE_F32

#: Flags :func:`_unit_frame` returns.
_BAD_RAY, _OFF_UNIT = 1, 2


@njit_cached(nogil=True)
def _unit_frame(o, d, offset, inverse, scale, exact_inverse, one_origin, o32, d32,
                norm2):  # pragma: no cover - compiled; run by every query
    """Map one chunk of rays to the float32 unit frame, checking them on the way.

    ``o`` and ``d`` are the chunk's float64 origins and directions as flat
    ``(3m,)`` arrays, or ``o`` the ``(3,)`` origin of every ray when
    ``one_origin``. Writes the flat float32 ``o32 = float32((o - offset) *
    inverse)`` (``/ scale`` where ``inverse`` is not exact) and ``d32 =
    float32(d)``, and ``norm2``, the float32 squared norms of ``d32`` summed
    as ``(x*x + y*y) + z*z``: each operation rounded once, as numpy rounds
    it. Returns ``_BAD_RAY`` if an origin is not finite in float32 or a
    squared norm is not finite and positive, plus ``_OFF_UNIT`` if a squared
    norm is off 1 by more than ``_NEAR_UNIT``. Branch-free loops over whole
    rows, which LLVM vectorises: one read of each ray.
    """
    m = norm2.shape[0]
    ox, oy, oz = offset[0], offset[1], offset[2]
    nonfinite = False
    if one_origin:
        if exact_inverse:
            x, y, z = (np.float32((o[0] - ox) * inverse), np.float32((o[1] - oy) * inverse),
                       np.float32((o[2] - oz) * inverse))
        else:
            x, y, z = (np.float32((o[0] - ox) / scale), np.float32((o[1] - oy) / scale),
                       np.float32((o[2] - oz) / scale))
        nonfinite = not (abs(x) < np.inf and abs(y) < np.inf and abs(z) < np.inf)
        for i in range(m):
            o32[3 * i] = x
            o32[3 * i + 1] = y
            o32[3 * i + 2] = z
    elif exact_inverse:
        for i in range(m):
            x = np.float32((o[3 * i] - ox) * inverse)
            y = np.float32((o[3 * i + 1] - oy) * inverse)
            z = np.float32((o[3 * i + 2] - oz) * inverse)
            o32[3 * i] = x
            o32[3 * i + 1] = y
            o32[3 * i + 2] = z
            nonfinite |= ((not abs(x) < np.inf) | (not abs(y) < np.inf)
                          | (not abs(z) < np.inf))
    else:
        for i in range(m):
            x = np.float32((o[3 * i] - ox) / scale)
            y = np.float32((o[3 * i + 1] - oy) / scale)
            z = np.float32((o[3 * i + 2] - oz) / scale)
            o32[3 * i] = x
            o32[3 * i + 1] = y
            o32[3 * i + 2] = z
            nonfinite |= ((not abs(x) < np.inf) | (not abs(y) < np.inf)
                          | (not abs(z) < np.inf))
    off = False
    for i in range(m):
        dx = np.float32(d[3 * i])
        dy = np.float32(d[3 * i + 1])
        dz = np.float32(d[3 * i + 2])
        d32[3 * i] = dx
        d32[3 * i + 1] = dy
        d32[3 * i + 2] = dz
        n2 = (dx * dx + dy * dy) + dz * dz
        norm2[i] = n2
        nonfinite |= (not n2 > 0) | (not n2 < np.inf)
        off |= abs(np.float64(n2) - 1.0) > _NEAR_UNIT
    return _BAD_RAY * nonfinite + _OFF_UNIT * off


@njit_cached(nogil=True)
def _unit_tfar(tfar, scale, longest, dists):  # pragma: no cover - compiled
    """``dists = float32(min(tfar / scale, longest))``: segment lengths in the unit frame."""
    for i in range(tfar.shape[0]):
        dists[i] = np.float32(min(tfar[i] / scale, longest))


@njit_cached(nogil=True)
def _store_hits(tfar, prim, scale, t, tri):  # pragma: no cover - compiled
    """World distances and int64 triangles of one chunk: ``t = tfar * scale``, inf on a miss.

    float32 -> float64 is exact, and so is the power-of-two scale.
    """
    for i in range(prim.shape[0]):
        p = prim[i]
        tri[i] = p
        t[i] = np.inf if p < 0 else np.float64(tfar[i]) * scale


def _kernel_signatures() -> dict:
    """Kernel -> the only signatures it is compiled for (see :func:`_ready_kernels`)."""
    from numba import types

    def array(dtype, ndim: int = 1, layout: str = "C", readonly: bool = False,
              aligned: bool = True):
        return types.Array(dtype, ndim, layout, readonly=readonly, aligned=aligned)  # type: ignore[call-overload]

    f64, f32 = types.float64, types.float32
    rays = array(f64, readonly=True)  # a writable array converts to it
    return {
        _unit_frame: [types.int64(rays, rays, rays, f64, f64, types.boolean, types.boolean,
                                  array(f32), array(f32), array(f32))],
        # any layout, writeability and alignment (max_distance is broadcast, read-only)
        _unit_tfar: [types.void(array(f64, 1, "A", readonly=True, aligned=False), f64, f64,
                                array(f32))],
        _store_hits: [types.void(array(f32), array(types.int32), f64, array(f64),
                                 array(types.int64))],
    }


def _flat(rows: np.ndarray) -> np.ndarray:
    """``(m, 3)`` rows as one flat C-contiguous, aligned array (a view where they are one)."""
    if not (rows.flags.c_contiguous and rows.flags.aligned):
        rows = np.array(rows, order="C")  # a copy: strided, broadcast or unaligned rows
    return rows.reshape(-1)


#: Compile (or load from numba's cache) the kernels once, for fixed signatures only:
#: each kernel has one version, which the arrays are converted to (the rays are handed
#: over flat and C-contiguous, see :func:`_flat`). The first query of a process pays
#: numba's own start-up (some 0.4 s, once, shared with viscore's other kernels).
_ready_kernels = pinned_kernels(_kernel_signatures)


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


def _raise_first_bad_ray(o: np.ndarray, o32: np.ndarray, norm2: np.ndarray,
                         first_ray: int) -> None:
    """Raise :class:`InputError` for the first bad ray of a chunk, if there is one.

    ``o`` are the chunk's float64 origins, ``o32`` their float32 unit-frame
    copies, ``norm2`` the float32 squared norms of its directions. Of one
    ray, its origin is reported before its direction. Returns when every ray
    is good.
    """
    problems = (
        (~np.isfinite(o).all(axis=1), "origins: contains NaN or infinite values"),
        (~np.isfinite(o32).all(axis=1), "origins: too far from the mesh for float32 ray "
                                        "tracing (beyond ~1e38 x its diagonal)"),
        (~np.isfinite(norm2), "directions: contains NaN or infinite values"),
        (norm2 <= 0, "directions: contains zero-length direction vectors"),
    )
    firsts = [int(np.argmax(bad)) if bad.any() else len(norm2) for bad, _ in problems]
    ray = min(firsts)
    if ray < len(norm2):
        message = problems[firsts.index(ray)][1]
        raise InputError(f"{message} (first at ray {first_ray + ray})")


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

    A query is traced in chunks of
    :data:`~viscore.constants.MIN_RAYS_PER_TASK` to ``_MAX_RAYS_PER_CHUNK``
    (65536) rays spread over ``workers`` threads; a batch smaller than two
    chunks runs on the calling thread. A ray's result does not depend on the
    batch it comes in, the chunking or the number of threads: a direction
    whose float32 squared norm is within ``_UNIT_TOLERANCE_F32`` (1e-6) of 1 is
    traced as given, any other is normalised in float64 first. Bad rays in
    :meth:`first_hit` and :meth:`any_hit` raise for the first bad ray of the
    batch, whose index the message gives.

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

    @classmethod
    def shared(cls, mesh: trimesh.Trimesh) -> Scene:
        """The Scene of ``mesh``, shared with the last caller that asked for the same content.

        One Scene is kept (by a digest of the vertices and faces, not the
        mesh's identity): the original mesh of a job, asked for by its
        generation, its checks and its scoring, is built into Embree once
        (a second on a million triangles) instead of once per caller. The
        Scene kept holds the mesh's arrays and BVH until another mesh's
        replaces it. Default workers.
        """
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            raise InputError("mesh: expected a non-empty trimesh.Trimesh")
        return _SHARED.get((np.asarray(mesh.vertices), np.asarray(mesh.faces)),
                           lambda: cls(mesh))

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
        state.pop("_packets", None)
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

    @cached_property
    def _packets(self):
        """The scene traced by packets of 16 rays (:mod:`viscore.ray._embree4`), or None.

        None where embreex's wheel holds no usable libembree4 or
        ``VISCORE_RAY_PACKETS=0`` (read when a Scene first traces): every
        query then goes through :attr:`_embree`. The same float32 unit-frame
        triangles, robust mode and build quality either way, and the same hits.
        """
        from . import _embree4

        lib = _embree4.library()
        if lib is None:
            return None
        unit = (self._vertices - self._offset) / self._scale  # power of two: exact
        try:
            return _embree4.PacketScene(lib, unit, self._faces)
        except _embree4.EmbreeError as exc:
            _log.warning("Embree packets unavailable (%s): tracing one ray at a time", exc)
            return None

    def build(self) -> Scene:
        """Build the Embree scene now rather than at the first query; returns self."""
        if self._packets is None:
            _ = self._embree
        return self

    def _first_triangles_unit(self, o32: np.ndarray, d32: np.ndarray) -> np.ndarray:
        """(m,) int32 triangle first hit by each float32 unit-frame ray (-1: miss), one call.

        ``o32``, ``d32`` are ``(m, 3)`` float32 C-contiguous rays already in
        the unit frame (unit directions): for callers that build such rays
        themselves and trace a few thousand at a time, on the calling thread,
        where :meth:`first_hit`'s checks would cost more than the rays.
        """
        packets = self._packets
        if packets is None:
            return self._embree.run(o32, d32, output=1)["primID"]
        m = len(o32)
        t = np.empty(m)
        tri = np.empty(m, dtype=np.int64)
        packets.first_hit(o32.reshape(-1), d32.reshape(-1), None, self._scale, t, tri)
        return tri.astype(np.int32)

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
        """One Embree pass over float64 world-space rays, in chunks over the pool.

        Returns (t, tri) for ``intersect`` (t = inf, tri = -1 on a miss), else a
        bool occluded array. The batch is cut into chunks (see
        :meth:`_chunk_bounds`) that the threads claim in order, each thread
        reusing its own float32 buffers; the calling thread is one of the
        workers. With ``check_values`` each chunk is checked as it is
        converted (see :meth:`_check_chunk`). A ray's result does not depend
        on the other rays of the batch, the chunking or the number of threads.
        """
        n = len(o)
        if n == 0:
            return (np.zeros(0), np.zeros(0, dtype=np.int64)) if intersect else np.zeros(0, bool)
        packets = self._packets
        scene = self._embree if packets is None else None
        _ready_kernels()
        offset, scale = self._offset, self._scale
        inverse = 1.0 / scale
        # multiplying by an exact inverse of a power of two rounds as dividing does
        exact_inverse = bool(np.isfinite(inverse) and inverse * scale == 1.0)
        if intersect:
            t_out = np.empty(n)
            tri_out = np.empty(n, dtype=np.int64)
        else:
            hit_out = np.empty(n, dtype=bool)
        workers = self.workers or get_workers()
        bounds = self._chunk_bounds(n, workers)
        n_chunks = len(bounds) - 1
        size = int(np.diff(bounds).max())  # rays in the largest chunk
        workers = min(workers, n_chunks)
        # one origin broadcast to every ray (as _prepare does it): handed over once
        one_origin = n > 1 and o.strides[0] == 0
        o_one = _flat(o[:1]) if one_origin else None
        claim = itertools.count().__next__  # atomic under the GIL: chunks go out in order
        errors: dict[int, Exception] = {}  # chunk index -> what it raised

        def work() -> None:
            # per-thread buffers, reused by every chunk the thread claims
            o32 = np.empty((size, 3), dtype=np.float32)
            d32 = np.empty((size, 3), dtype=np.float32)
            norm2 = np.empty(size, dtype=np.float32)
            dists = None if tfar is None else np.empty(size, dtype=np.float32)
            # one errstate per thread (it is per thread, and costly to enter per
            # chunk): float32 overflow to inf, and NaN from it, are refused by the checks
            with np.errstate(over="ignore", invalid="ignore"):
                while not errors:
                    k = claim()
                    if k >= n_chunks:
                        return
                    a, b = int(bounds[k]), int(bounds[k + 1])
                    m = b - a
                    try:
                        # unit frame: (o - offset) / scale in float64, then rounded once
                        # to float32; checked in the same pass
                        flags = _unit_frame(o_one if one_origin else _flat(o[a:b]),
                                            _flat(d[a:b]), offset, inverse, scale,
                                            exact_inverse, one_origin, o32[:m].reshape(-1),
                                            d32[:m].reshape(-1), norm2[:m])
                        if check_values and flags:
                            self._check_chunk(o[a:b], d[a:b], o32[:m], d32[:m], norm2[:m],
                                              flags, first_ray=a)
                        tfar32 = None
                        if tfar is not None:
                            tfar32 = dists[:m]  # type: ignore[index]
                            _unit_tfar(tfar[a:b], scale, _EMBREE_MISS_T, tfar32)
                        if packets is not None:
                            if intersect:
                                packets.first_hit(o32[:m].reshape(-1), d32[:m].reshape(-1),
                                                  tfar32, scale, t_out[a:b], tri_out[a:b])
                            else:
                                packets.occluded(o32[:m].reshape(-1), d32[:m].reshape(-1),
                                                 tfar32, hit_out[a:b])
                        elif intersect:
                            res = scene.run(o32[:m], d32[:m], dists=tfar32, output=1)  # type: ignore[union-attr]
                            _store_hits(res["tfar"], res["primID"], scale, t_out[a:b],
                                        tri_out[a:b])
                        else:
                            hit_out[a:b] = scene.run(o32[:m], d32[:m], dists=tfar32,  # type: ignore[union-attr]
                                                     query="OCCLUDED") >= 0
                    except Exception as exc:  # noqa: BLE001 - re-raised below, in chunk order
                        errors[k] = exc
                        return

        if workers == 1:
            work()
        else:
            with ThreadPoolExecutor(max_workers=workers - 1) as pool:
                helpers = [pool.submit(work) for _ in range(workers - 1)]
                work()
                for helper in helpers:
                    helper.result()
        if errors:
            # chunks are claimed in order and a claimed chunk always finishes, so
            # the lowest failed chunk holds the first bad ray of the whole batch
            raise errors[min(errors)]
        return (t_out, tri_out) if intersect else hit_out

    @staticmethod
    def _chunk_count(n: int, workers: int) -> int:
        """Chunks (Embree calls) that a batch of ``n`` rays on ``workers`` threads is cut into.

        Chunks are equal to within one ray and hold at least
        :data:`~viscore.constants.MIN_RAYS_PER_TASK` rays (a smaller batch is
        one chunk, on the calling thread) and at most ``_MAX_RAYS_PER_CHUNK``.
        Within those bounds there are ``_CHUNKS_PER_WORKER`` per thread, or,
        for a batch too small for that, a multiple of the number of threads,
        so that no thread is left with one chunk more than another.
        """
        fewest = -(-n // _MAX_RAYS_PER_CHUNK)
        most = max(1, n // MIN_RAYS_PER_TASK)
        count = min(workers * _CHUNKS_PER_WORKER, most)
        if workers <= count < workers * _CHUNKS_PER_WORKER:
            count -= count % workers
        return max(count, fewest)

    @staticmethod
    def _chunk_bounds(n: int, workers: int) -> np.ndarray:
        """Where the chunks of a batch of ``n`` rays on ``workers`` threads start (and the end).

        Guided scheduling of a batch of ``_CHUNKS_PER_WORKER`` chunks per
        thread or more: :meth:`_chunk_count`'s equal chunks until what is left
        runs short, then each chunk at most ``1 / (_TAIL_SHARE * workers)`` of
        the rays left but no fewer than ``_TAIL_RAYS`` (the last one takes what
        a smaller one would leave). The threads claim the chunks in order, so
        the last ones out are small and the threads finish within about one
        small chunk of each other, where with equal chunks one thread could be
        left tracing a whole chunk alone (on 2 threads and a million rays, one
        of 16 chunks: up to 12% of the batch's time). One thread, or a smaller
        batch: the equal chunks.
        """
        count = Scene._chunk_count(n, workers)
        if workers == 1 or count < workers * _CHUNKS_PER_WORKER:
            return (np.arange(count + 1, dtype=np.int64) * n) // count
        size = -(-n // count)
        bounds = [0]
        while bounds[-1] < n:
            left = n - bounds[-1]
            step = min(size, max(_TAIL_RAYS, -(-left // (_TAIL_SHARE * workers))))
            if left - step < _TAIL_RAYS:  # no sliver at the end: the last chunk takes it
                step = left
            bounds.append(bounds[-1] + step)
        return np.array(bounds, dtype=np.int64)

    @staticmethod
    def _check_chunk(o: np.ndarray, d: np.ndarray, o32: np.ndarray, d32: np.ndarray,
                     norm2: np.ndarray, flags: int, *, first_ray: int) -> None:
        """Check one converted chunk; normalise the directions that are not unit.

        ``o``, ``d`` are the chunk's float64 rays, ``o32``, ``d32`` their float32
        unit-frame copies (``d32`` is fixed in place), ``norm2`` the float32
        squared norms of ``d32`` and ``flags`` what :func:`_unit_frame`
        returned; ``first_ray`` is the chunk's offset in the batch. Origins must
        be finite and within float32's range of the unit frame, directions
        finite and non-zero in float32; a direction whose float32 squared norm
        is off 1 by more than ``_UNIT_TOLERANCE_F32`` is normalised in float64
        first. On bad input the :class:`InputError` names the first bad ray.
        The caller ignores float overflow and invalid-value warnings: what
        overflows is refused here.
        """
        if flags & _BAD_RAY:
            _raise_first_bad_ray(o, o32, norm2, first_ray)
        if flags & _OFF_UNIT:
            off = np.flatnonzero(np.abs(norm2 - 1.0) > _UNIT_TOLERANCE_F32)
            if len(off):
                dc = d[off]
                d32[off] = dc / np.sqrt(np.einsum("ij,ij->i", dc, dc))[:, None]

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
