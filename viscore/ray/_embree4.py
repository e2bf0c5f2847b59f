"""Embree 4's ray packets (``rtcIntersect16``, ``rtcOccluded16``) from embreex's own library.

The one module behind this binding: :class:`viscore.Scene` asks :func:`library`
for it and falls back to embreex's per-ray ``EmbreeScene.run`` where it
answers None. Nothing is compiled at install: the ``libembree4`` that the
embreex wheel installs beside itself (``embreex.libs/`` on Linux,
``embreex/.dylibs/`` on macOS) is opened with :mod:`ctypes`, the scene is
built through it once, and compiled numba loops (``nogil``) fill packets of
16 rays in buffers this module owns and call the packet entry points by
address, so a thread holds the GIL only to start a chunk of rays.

The scene is built as embreex builds it (default device, robust mode,
medium build quality, one triangle geometry, vertices padded to 16 bytes),
except that the vertex and index buffers are shared with Python
(``rtcSetSharedGeometryBuffer``) rather than copied: the
:class:`PacketScene` keeps them alive as long as Embree may read them.

The hits are embreex's, bit for bit. A packet gives each ray the same
distances to each triangle as a single ray does, but where two triangles
are hit at the same distance (or, in Embree's frustum traversal of coherent
packets, a float32 ulp apart) which one it reports depends on the order it
meets them, and packets do not meet them in a single ray's order. Those
rays are traced again alone with ``rtcIntersect1``, as embreex traces
them: a hit at an edge or corner of its triangle (``_TIE_BARYCENTRIC``),
and a hit on a triangle that overlaps another in its plane
(:func:`_stacked_triangles`, found when the scene is built).

Struct layouts, enum values and calls follow Embree 4's public headers
(``include/embree4/rtcore_ray.h``, ``rtcore_scene.h``, ``rtcore_geometry.h``,
``rtcore_device.h``, ``rtcore_common.h``): ``RTCRayHit16`` is a
structure of arrays of 16 lanes, 64-byte aligned, the ray's twelve rows
(``org_x, org_y, org_z, tnear, dir_x, dir_y, dir_z, time, tfar, mask, id,
flags``) then the hit's (``Ng_x, Ng_y, Ng_z, u, v, primID, geomID,
instID[...]``); a lane is traced where its ``valid`` entry is -1.

Set the environment variable ``VISCORE_RAY_PACKETS=0`` to make every
:class:`~viscore.Scene` built afterwards use embreex alone (to compare the
two paths, or to step around a broken library).

References
----------
.. [1] Wald, I., Woop, S., Benthin, C., Johnson, G. S., Ernst, M. "Embree: A
   Kernel Framework for Efficient CPU Ray Tracing". ACM Transactions on
   Graphics 33(4), 2014, article 143. :DOI:`10.1145/2601097.2601199`
"""

from __future__ import annotations

import ctypes
import glob
import logging
import math
import os
import threading
from dataclasses import dataclass
from importlib import util as importlib_util

import numpy as np
from numba import types
from numba.extending import intrinsic

from .._jit import njit_cached, pinned_kernels

__all__ = ["PacketScene", "library", "packets_enabled", "PACKETS_ENV"]

_log = logging.getLogger(__name__)

#: Environment variable that turns the packet path off where it is ``0``
#: (also ``false``, ``no``, ``off``): every Scene built afterwards uses embreex.
PACKETS_ENV = "VISCORE_RAY_PACKETS"

#: Where embreex's wheels put their libembree4, relative to the folder holding
#: the ``embreex`` package (auditwheel, delocate, delvewheel), and its names.
_LIBRARY_FOLDERS = ("embreex.libs", os.path.join("embreex", ".dylibs"), "embreex")
_LIBRARY_PATTERNS = ("libembree4*.so*", "libembree4*.dylib", "embree4*.dll")

#: Symbols the packet path needs; a library without one of them is not used.
_SYMBOLS = ("rtcNewDevice", "rtcReleaseDevice", "rtcGetDeviceError", "rtcNewScene",
            "rtcReleaseScene", "rtcSetSceneFlags", "rtcSetSceneBuildQuality",
            "rtcCommitScene", "rtcNewGeometry", "rtcReleaseGeometry",
            "rtcSetSharedGeometryBuffer", "rtcCommitGeometry", "rtcAttachGeometry",
            "rtcGetDeviceProperty", "rtcIntersect1", "rtcIntersect16", "rtcOccluded16")

# enum values of Embree 4's headers
_RTC_SCENE_FLAG_ROBUST = 1 << 2             # rtcore_scene.h, RTCSceneFlags
_RTC_BUILD_QUALITY_MEDIUM = 1               # rtcore_common.h, RTCBuildQuality (the default)
_RTC_GEOMETRY_TYPE_TRIANGLE = 0             # rtcore_geometry.h, RTCGeometryType
_RTC_BUFFER_TYPE_INDEX = 0                  # rtcore_buffer.h, RTCBufferType
_RTC_BUFFER_TYPE_VERTEX = 1
_RTC_FORMAT_UINT3 = 0x5003                  # rtcore_common.h, RTCFormat
_RTC_FORMAT_FLOAT3 = 0x9003
_RTC_DEVICE_PROPERTY_VERSION_MAJOR = 1      # rtcore_device.h, RTCDeviceProperty
_RTC_DEVICE_PROPERTY_VERSION = 0
_RTC_RAY_QUERY_FLAG_INCOHERENT = 0          # rtcore_common.h, RTCRayQueryFlags
_RTC_RAY_QUERY_FLAG_COHERENT = 1 << 16
_RTC_FEATURE_FLAG_ALL = -1                  # 0xffffffff as an int32

#: Lanes of a packet (``RTCRayHit16``) and the alignment Embree requires of it, bytes.
PACKET = 16
_ALIGN = 64

#: Rows of the ``RTCRayHit16`` buffer: the ray's twelve, the hit's seven, and
#: room for up to six instance levels of ``instID`` and ``instPrimID`` (the
#: release builds have one): Embree may write them, viscore never reads them.
_ROWS = 12 + 7 + 2 * 6
_ORG_X, _TNEAR, _DIR_X, _TIME, _TFAR, _MASK, _ID, _FLAGS = 0, 3, 4, 7, 8, 9, 10, 11
_U, _V, _PRIM_ID, _GEOM_ID, _INST_ID = 15, 16, 17, 18, 19

#: Words of one ``RTCRayHit`` (``rtcIntersect1``): the same fields, one lane
#: each, in the same order (the hit starts at word 12), with the same room.
_WORDS = _ROWS

#: A first hit whose barycentric coordinates (u, v, 1 - u - v) come within this
#: of an edge is traced again alone, by ``rtcIntersect1`` as embreex traces it.
#: There a neighbour sharing the edge or vertex may be hit at exactly the same
#: distance (two coplanar triangles: the diagonal of a cube's face), and which
#: of the two Embree reports depends on the order it meets them, which differs
#: between packet and single-ray traversal (in a leaf of four triangles, the
#: single ray keeps the first of equal hits, a packet the last). Embree's edge
#: test lets a neighbour hit within about 1.2e-7 (float32's epsilon) of its
#: own (U + V + W), so 1e-3 covers neighbours up to thousands of times larger
#: than the triangle hit; about 0.6% of hits are traced twice.
_TIE_BARYCENTRIC = 1e-3

#: ``tfar`` of a ray without ``max_distance``: the value embreex's ``run`` sets,
#: so that both paths trace the same segment.
_DEFAULT_TFAR = np.float32(1e37)

#: A packet of 16 rays is traced with Embree's coherent flag where every
#: direction is within ``_COHERENT_DIRECTIONS2`` of the first (squared distance
#: of unit vectors: about 0.2 rad) and every origin within
#: ``_COHERENT_ORIGINS2`` of the first (squared, in the unit frame, where the
#: mesh's diagonal is 0.5 to 1): a row of an orthographic view of 256 pixels
#: or more, a perspective view's neighbours. The flag selects Embree's frustum
#: traversal, which on the bunny traces such packets 1.3x (256 px) to 2.5x
#: (1024 px) faster than without it, but parallel rays from scattered origins,
#: or scattered rays, 2-3x slower; either way each ray gets its nearest hit.
_COHERENT_DIRECTIONS2 = 0.04
_COHERENT_ORIGINS2 = 1e-3


@intrinsic
def _call_packet(typingctx, fn, valid, scene, rays, args):
    """``fn(valid, scene, rays, args)``: call Embree's packet function at address ``fn``.

    Every argument is an address (``intp``); numba calls the C function
    ``void (const int*, RTCScene, void*, void*)`` through a pointer, so no
    ctypes object is baked into the compiled code (which numba could not cache).
    """
    from llvmlite import ir  # type: ignore[import-untyped]

    sig = types.void(types.intp, types.intp, types.intp, types.intp, types.intp)

    def codegen(context, builder, signature, llargs):
        pointer = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [pointer] * 4)
        callee = builder.inttoptr(llargs[0], fnty.as_pointer())
        builder.call(callee, [builder.inttoptr(a, pointer) for a in llargs[1:]])
        return context.get_dummy_value()

    return sig, codegen


@njit_cached(nogil=True)
def _fill_packet(o32, d32, tfar32, has_tfar, a, k, rf, ri, valid):  # pragma: no cover - compiled
    """Load rays ``a .. a+k-1`` (flat float32 ``o32``, ``d32``) into packet lanes ``0 .. k-1``.

    Lanes ``k .. 15`` repeat the last ray and are marked invalid (0), the
    others valid (-1). ``rf`` and ``ri`` are the float32 and int32 views of one
    ``RTCRayHit16``. Returns whether the packet is coherent (see
    ``_COHERENT_DIRECTIONS2``).
    """
    x0, y0, z0 = d32[3 * a], d32[3 * a + 1], d32[3 * a + 2]
    p0, q0, r0 = o32[3 * a], o32[3 * a + 1], o32[3 * a + 2]
    directions = np.float32(0.0)
    origins = np.float32(0.0)
    for j in range(PACKET):
        i = a + min(j, k - 1)
        dx, dy, dz = d32[3 * i], d32[3 * i + 1], d32[3 * i + 2]
        ox, oy, oz = o32[3 * i], o32[3 * i + 1], o32[3 * i + 2]
        rf[_ORG_X, j] = ox
        rf[_ORG_X + 1, j] = oy
        rf[_ORG_X + 2, j] = oz
        rf[_TNEAR, j] = 0.0
        rf[_DIR_X, j] = dx
        rf[_DIR_X + 1, j] = dy
        rf[_DIR_X + 2, j] = dz
        rf[_TIME, j] = 0.0
        rf[_TFAR, j] = tfar32[i] if has_tfar else _DEFAULT_TFAR
        ri[_MASK, j] = -1
        ri[_ID, j] = 0
        ri[_FLAGS, j] = 0
        ri[_PRIM_ID, j] = -1
        ri[_GEOM_ID, j] = -1
        ri[_INST_ID, j] = -1
        valid[j] = -1 if j < k else 0
        ex, ey, ez = dx - x0, dy - y0, dz - z0
        directions = max(directions, (ex * ex + ey * ey) + ez * ez)
        ex, ey, ez = ox - p0, oy - q0, oz - r0
        origins = max(origins, (ex * ex + ey * ey) + ez * ez)
    return directions <= _COHERENT_DIRECTIONS2 and origins <= _COHERENT_ORIGINS2


@intrinsic
def _call_single(typingctx, fn, scene, rayhit, args):
    """``fn(scene, rayhit, args)``: call ``rtcIntersect1`` at address ``fn`` (all addresses)."""
    from llvmlite import ir

    sig = types.void(types.intp, types.intp, types.intp, types.intp)

    def codegen(context, builder, signature, llargs):
        pointer = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [pointer] * 3)
        callee = builder.inttoptr(llargs[0], fnty.as_pointer())
        builder.call(callee, [builder.inttoptr(a, pointer) for a in llargs[1:]])
        return context.get_dummy_value()

    return sig, codegen


@njit_cached(nogil=True)
def _intersect_one(fn1, scene, o32, d32, tfar32, has_tfar, i, sf, si):  # pragma: no cover
    """Trace ray ``i`` alone with ``rtcIntersect1``, as embreex's ``run`` does; returns primID.

    ``sf``, ``si``: float32 and int32 views of one ``RTCRayHit``; its ``tfar``
    is left in ``sf[_TFAR]``. The arguments are NULL (Embree's defaults), as
    embreex passes them.
    """
    sf[_ORG_X] = o32[3 * i]
    sf[_ORG_X + 1] = o32[3 * i + 1]
    sf[_ORG_X + 2] = o32[3 * i + 2]
    sf[_TNEAR] = 0.0
    sf[_DIR_X] = d32[3 * i]
    sf[_DIR_X + 1] = d32[3 * i + 1]
    sf[_DIR_X + 2] = d32[3 * i + 2]
    sf[_TIME] = 0.0
    sf[_TFAR] = tfar32[i] if has_tfar else _DEFAULT_TFAR
    si[_MASK] = -1
    si[_ID] = 0
    si[_FLAGS] = 0
    si[_PRIM_ID] = -1
    si[_GEOM_ID] = -1
    si[_INST_ID] = -1
    _call_single(fn1, scene, sf.ctypes.data, 0)
    return si[_PRIM_ID]


@njit_cached(nogil=True)
def _intersect_chunk(fn, fn1, scene, o32, d32, tfar32, has_tfar, scale, t, tri, rf, ri, valid,
                     args, sf, si, stacked):  # pragma: no cover - compiled
    """Nearest hits of one chunk of float32 unit-frame rays, by packets of 16.

    Writes ``t = float64(tfar) * scale`` (``inf`` on a miss) and ``tri`` (the
    triangle, -1 on a miss) for each ray, as ``viscore.scene._store_hits``
    does for embreex's results. ``args`` is an ``RTCIntersectArguments``
    (int32 words); its flags are set per packet. A hit at an edge or a vertex
    of its triangle, or on a triangle that ``stacked`` marks (one overlapping
    another in the same plane: see :func:`_stacked_triangles`), is traced again
    alone (``fn1``, ``rtcIntersect1``: see ``_TIE_BARYCENTRIC``) in
    ``sf``/``si``. Returns how many were.
    """
    m = t.shape[0]
    again = 0
    for a in range(0, m, PACKET):
        k = min(PACKET, m - a)
        coherent = _fill_packet(o32, d32, tfar32, has_tfar, a, k, rf, ri, valid)
        args[0] = _RTC_RAY_QUERY_FLAG_COHERENT if coherent else _RTC_RAY_QUERY_FLAG_INCOHERENT
        _call_packet(fn, valid.ctypes.data, scene, rf.ctypes.data, args.ctypes.data)
        for j in range(k):
            p = ri[_PRIM_ID, j]
            tfar = rf[_TFAR, j]
            if p >= 0:
                u, v = rf[_U, j], rf[_V, j]
                if stacked[p] or min(u, v, np.float32(1.0) - u - v) < _TIE_BARYCENTRIC:
                    p = _intersect_one(fn1, scene, o32, d32, tfar32, has_tfar, a + j, sf, si)
                    tfar = sf[_TFAR]
                    again += 1
            tri[a + j] = p
            t[a + j] = np.inf if p < 0 else np.float64(tfar) * scale
    return again


@njit_cached(nogil=True)
def _occluded_chunk(fn, scene, o32, d32, tfar32, has_tfar, hit, rf, ri, valid,
                    args):  # pragma: no cover - compiled
    """Whether each ray of one chunk hits anything, by packets of 16 (``rtcOccluded16``).

    Embree marks an occluded ray by setting its ``tfar`` to ``-inf``.
    """
    m = hit.shape[0]
    for a in range(0, m, PACKET):
        k = min(PACKET, m - a)
        coherent = _fill_packet(o32, d32, tfar32, has_tfar, a, k, rf, ri, valid)
        args[0] = _RTC_RAY_QUERY_FLAG_COHERENT if coherent else _RTC_RAY_QUERY_FLAG_INCOHERENT
        _call_packet(fn, valid.ctypes.data, scene, rf.ctypes.data, args.ctypes.data)
        for j in range(k):
            hit[a + j] = rf[_TFAR, j] < 0


#: Two triangles are "stacked" where each one's corners lie within this of the
#: other's plane (unit frame, where the mesh's diagonal is 0.5 to 1: some ten
#: float32 ulps of a distance of 1) and their interiors overlap.
_STACKED_PLANE = 1e-5

#: Width of the bins of unit normals that candidate pairs share (the canonical
#: normal's components, rounded to multiples of it).
_NORMAL_BIN = 1e-2


@njit_cached(nogil=True)
def _separated(ax, ay, bx, by, eps):  # pragma: no cover - compiled
    """Whether two 2D triangles (corner coordinates ``ax``, ``ay`` and ``bx``, ``by``)
    have interiors that do not overlap (a separating edge normal; touching counts as
    separated, within ``eps``)."""
    for which in range(2):
        px, py = (ax, ay) if which == 0 else (bx, by)
        for e in range(3):
            nx = -(py[(e + 1) % 3] - py[e])
            ny = px[(e + 1) % 3] - px[e]
            length = np.sqrt(nx * nx + ny * ny)
            if length == 0.0:
                continue
            nx, ny = nx / length, ny / length
            lo_a = hi_a = ax[0] * nx + ay[0] * ny
            lo_b = hi_b = bx[0] * nx + by[0] * ny
            for c in range(1, 3):
                pa = ax[c] * nx + ay[c] * ny
                pb = bx[c] * nx + by[c] * ny
                lo_a, hi_a = min(lo_a, pa), max(hi_a, pa)
                lo_b, hi_b = min(lo_b, pb), max(hi_b, pb)
            if hi_a <= lo_b + eps or hi_b <= lo_a + eps:
                return True
    return False


#: Triangles of one group (one normal bin, plane and projection) up to which
#: :func:`_mark_stacked` sweeps along ``u``; larger groups go on grids.
_SWEEP_GROUP = 64

#: Levels of a group's grids (cells four times wider at each), and most cells
#: along a side of the finest (its cells are at least the group's extent over
#: this): cell indices take 21 bits, levels the bits above them.
_GRID_LEVELS = 11
_GRID_SIDE_MAX = 1 << 20

#: Percentile of a group's triangle sizes (the larger side of each one's box in
#: the plane) that the cells of its finest grid are: three in four triangles
#: then lie in at most four of its cells.
_GRID_CELL_QUANTILE = 75.0

#: Triangles whose normals, planes and boxes are computed at once by
#: :func:`_stacked_triangles` (float64 temporaries of some 200 bytes each).
_STACKED_CHUNK = 1 << 18


@njit_cached(nogil=True)
def _stacked_pair(v, faces, normals, offsets, uv, box, order, r, q, tolerance, ax, ay, bx,
                  by):  # pragma: no cover - compiled
    """Whether the triangles at sorted positions ``r`` and ``q`` of one group overlap in
    their plane (the test of :func:`_mark_stacked`; ``ax`` .. ``by`` are scratch).

    Their boxes overlap in ``u`` (the later one in the sort by least ``u`` starts before
    the earlier one ends) and strictly in ``v``; their offsets differ by at most two
    tolerances; each one's corners lie within ``tolerance`` of the other's plane; no
    edge normal of either separates them in the plane.
    """
    if q < r:
        r, q = q, r
    if box[q, 0] >= box[r, 1]:
        return False
    if min(box[r, 3], box[q, 3]) <= max(box[r, 2], box[q, 2]):
        return False
    i, j = order[r], order[q]
    if abs(offsets[j] - offsets[i]) > 2 * tolerance:
        return False
    for c in range(3):  # each one's corners near the other's plane
        pi, pj = faces[i, c], faces[j, c]
        di = (np.float64(v[pj, 0]) * normals[i, 0] + np.float64(v[pj, 1]) * normals[i, 1]
              + np.float64(v[pj, 2]) * normals[i, 2]) - offsets[i]
        dj = (np.float64(v[pi, 0]) * normals[j, 0] + np.float64(v[pi, 1]) * normals[j, 1]
              + np.float64(v[pi, 2]) * normals[j, 2]) - offsets[j]
        if abs(di) > tolerance or abs(dj) > tolerance:
            return False
    u, w = uv[i, 0], uv[i, 1]
    for c in range(3):
        ax[c], ay[c] = v[faces[i, c], u], v[faces[i, c], w]
        bx[c], by[c] = v[faces[j, c], u], v[faces[j, c], w]
    return not _separated(ax, ay, bx, by, tolerance)


@njit_cached(nogil=True)
def _cell(x, origin, side):  # pragma: no cover - compiled
    """Index of the grid cell of side ``side`` holding coordinate ``x`` (from ``origin``)."""
    return np.int64((x - origin) / side)


@njit_cached(nogil=True)
def _slot(table, key):  # pragma: no cover - compiled
    """The slot of ``key`` in an open-addressing table of keys (-1: empty), by linear probing."""
    mask = table.shape[0] - 1
    s = (key * np.int64(-7046029254386353131)) >> 20 & mask  # a multiplicative hash
    while table[s] != -1 and table[s] != key:
        s = (s + 1) & mask
    return s



def _cell_quantiles(box: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """The ``_GRID_CELL_QUANTILE`` percentile of each group's triangle sizes (the larger
    side of each one's box in the plane), for the groups :func:`_mark_stacked` puts on
    grids (more than ``_SWEEP_GROUP`` triangles; 0 for the others).

    Linear between the closest ranks, as ``np.percentile`` computes it: all
    groups at once, here rather than in the kernel, where ``np.percentile``
    took some 5 s of numba's compilation on a fresh install.
    """
    counts = np.diff(starts)
    quantiles = np.zeros(len(counts))
    big = counts > _SWEEP_GROUP
    if not big.any():
        return quantiles
    rows = np.flatnonzero(np.repeat(big, counts))
    size = np.maximum(box[rows, 1] - box[rows, 0], box[rows, 3] - box[rows, 2])
    group = np.repeat(np.arange(len(counts)), counts)[rows]
    size = size[np.lexsort((size, group))]  # each group's sizes ascending, groups in order
    n = counts[big]
    first = np.cumsum(n) - n
    rank = 1 + (n - 1) * (_GRID_CELL_QUANTILE / 100.0)
    whole = np.floor(rank)
    part = rank - whole
    k = first + whole.astype(np.int64) - 1
    quantiles[big] = size[k] * (1 - part) + size[k + 1] * part
    return quantiles


@njit_cached(nogil=True)
def _mark_stacked(v, faces, normals, offsets, uv, box, order, starts, quantiles, tolerance,
                  stacked):  # pragma: no cover - compiled
    """Mark in ``stacked`` the triangles of each group that overlap another of it.

    ``v`` ``(V, 3+)`` float32 vertices and ``faces`` ``(f, 3)`` their indices;
    ``normals`` the triangles' unit normals, ``offsets`` their planes' offsets,
    ``uv`` ``(f, 2)`` the two axes their plane projects on and ``box`` ``(f, 4)``
    the extents on them of the triangles as ``order`` lists them (least and most
    ``u``, least and most ``v``). ``order`` lists the triangles group by group
    (same normal bin and projection, offsets chained within ``2 * tolerance``),
    by least ``u`` within a group; ``starts`` is where each group begins (and
    the end).

    A group of up to ``_SWEEP_GROUP`` triangles is swept along ``u`` (only
    pairs whose ``u`` ranges overlap are looked at). A larger one (a level's
    ground, a wall of many tiles) goes into a hierarchy of grids: cells of
    side ``base * 4**l`` at level ``l``, ``base`` the
    ``_GRID_CELL_QUANTILE`` percentile of its triangles' sizes (the larger
    side of each one's box; ``quantiles``, one per group, from
    :func:`_cell_quantiles`), each triangle in the cells of the first level
    whose cells are as large as it (two by two at most), found by a hash of
    (level, cell). A triangle is looked at with those of its own level that
    share a cell, and with those of every coarser level in the cells it
    covers there; a pair only in the cell (of the coarser level) holding the
    least corner of their boxes' overlap, so once. Either way every pair
    whose boxes overlap is looked at, in time that grows with the triangles
    and those pairs (not with the square of a plane's triangles, nor with a
    large triangle times all), and the test is the same (:func:`_stacked_pair`).
    """
    ax, ay = np.empty(3), np.empty(3)
    bx, by = np.empty(3), np.empty(3)
    for g in range(starts.shape[0] - 1):
        lo, hi = starts[g], starts[g + 1]
        if hi - lo <= _SWEEP_GROUP:
            for r in range(lo, hi):
                u_end = box[r, 1]
                for q in range(r + 1, hi):
                    if box[q, 0] >= u_end:  # sorted by least u: no later one overlaps r
                        break
                    if _stacked_pair(v, faces, normals, offsets, uv, box, order, r, q,
                                     tolerance, ax, ay, bx, by):
                        stacked[order[r]] = True
                        stacked[order[q]] = True
            continue
        n = hi - lo
        size = np.empty(n)
        u0, v0 = box[lo, 0], box[lo, 2]
        u1, v1 = box[lo, 1], box[lo, 3]
        for r in range(lo, hi):
            size[r - lo] = max(box[r, 1] - box[r, 0], box[r, 3] - box[r, 2])
            u0, u1 = min(u0, box[r, 0]), max(u1, box[r, 1])
            v0, v1 = min(v0, box[r, 2]), max(v1, box[r, 3])
        base = max(quantiles[g], max(u1 - u0, v1 - v0) / _GRID_SIDE_MAX)
        if not base > 0.0:
            base = 1.0
        side = np.empty(_GRID_LEVELS)
        side[0] = base
        for lv in range(1, _GRID_LEVELS):
            side[lv] = side[lv - 1] * 4.0
        level = np.empty(n, np.int64)
        used = np.zeros(_GRID_LEVELS, np.bool_)
        entries = 0
        for r in range(lo, hi):
            lv = 0
            while lv < _GRID_LEVELS - 1 and size[r - lo] > side[lv]:
                lv += 1
            level[r - lo] = lv
            used[lv] = True
            s = side[lv]
            entries += ((_cell(box[r, 1], u0, s) - _cell(box[r, 0], u0, s) + 1)
                        * (_cell(box[r, 3], v0, s) - _cell(box[r, 2], v0, s) + 1))
        capacity = 1
        while capacity < 2 * entries:
            capacity *= 2
        table = np.full(capacity, -1, np.int64)
        head = np.full(capacity, -1, np.int64)
        nxt = np.empty(entries, np.int64)
        who = np.empty(entries, np.int64)
        e = 0
        for r in range(lo, hi):
            lv = level[r - lo]
            s = side[lv]
            for a in range(_cell(box[r, 0], u0, s), _cell(box[r, 1], u0, s) + 1):
                for b in range(_cell(box[r, 2], v0, s), _cell(box[r, 3], v0, s) + 1):
                    key = (lv << 42) | (a << 21) | b
                    at = _slot(table, key)
                    table[at] = key
                    who[e] = r
                    nxt[e] = head[at]
                    head[at] = e
                    e += 1
        for r in range(lo, hi):
            own = level[r - lo]
            for lv in range(own, _GRID_LEVELS):
                if not used[lv]:
                    continue
                s = side[lv]
                for a in range(_cell(box[r, 0], u0, s), _cell(box[r, 1], u0, s) + 1):
                    for b in range(_cell(box[r, 2], v0, s), _cell(box[r, 3], v0, s) + 1):
                        at = _slot(table, (lv << 42) | (a << 21) | b)
                        x = head[at]
                        while x != -1:
                            q = who[x]
                            x = nxt[x]
                            # pairs of one level once (the later-listed of the two);
                            # every pair in the cell of the least corner of the overlap
                            if (lv == own and q <= r) or (
                                    _cell(max(box[r, 0], box[q, 0]), u0, s) != a
                                    or _cell(max(box[r, 2], box[q, 2]), v0, s) != b):
                                continue
                            if _stacked_pair(v, faces, normals, offsets, uv, box, order, r,
                                             q, tolerance, ax, ay, bx, by):
                                stacked[order[r]] = True
                                stacked[order[q]] = True


def _stacked_triangles(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(f,) bool``: the triangles whose interior overlaps another triangle in (nearly) its plane.

    Such a pair (a duplicated face, a decal on a wall, the stacked walls of a
    game-kit building) is hit by a ray at the same distance, or within a few
    float32 ulps of it, and which of the two Embree reports depends on the
    order its traversal meets them: packets and single rays do not meet them
    in the same order, and Embree's frustum traversal of coherent packets may
    even step past the nearer of two hits a ulp apart. A first hit on a
    marked triangle is traced again alone. ``vertices`` are the float32
    vertices Embree holds (``(v, 3)`` or padded ``(v, 4)``), ``faces`` their
    indices.

    Candidates share a bin of their canonical unit normal (``_NORMAL_BIN``)
    and lie within ``_STACKED_PLANE`` of each other's plane; their interiors
    then overlap where no edge normal of either separates them in the plane
    (a separating-axis test). Two normals on either side of a bin's edge are
    not compared: a pair so close to coplanar yet in two bins is left unmarked.
    The pairs looked at are those whose boxes in the plane overlap
    (:func:`_mark_stacked`): the time grows with the triangles, not with the
    square of a plane's. The per-triangle planes are computed in chunks of
    ``_STACKED_CHUNK``, so a scene of millions of triangles holds no float64
    copy of its corners.
    """
    v32 = np.asarray(vertices)
    faces = np.asarray(faces)
    f = len(faces)
    normals = np.empty((f, 3))
    offsets = np.empty(f)
    good = np.empty(f, dtype=bool)
    # the sort keys: each normal's bins (|n / _NORMAL_BIN| <= 100 fits int8) and the
    # axis its plane drops; int64 keys and their sorted copy took 64 of the some 200
    # bytes a triangle (1.3 GB at 7.5M triangles)
    keys = np.empty((f, 4), dtype=np.int8)
    corners = np.empty((f, 4))  # least and most coordinate along each projection axis
    for a in range(0, f, _STACKED_CHUNK):
        b = min(f, a + _STACKED_CHUNK)
        tris = np.asarray(v32[:, :3][np.asarray(faces[a:b], dtype=np.int64)], dtype=np.float64)
        n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        length = np.linalg.norm(n, axis=1)
        ok = length > 0
        n[ok] /= length[ok, None]
        # canonical sign: the component of largest magnitude positive; the plane
        # projects on the other two axes
        d = np.abs(n).argmax(axis=1)
        rows = np.arange(len(n))
        n *= np.where(n[rows, d] < 0, -1.0, 1.0)[:, None]
        normals[a:b], good[a:b] = n, ok
        keys[a:b, :3], keys[a:b, 3] = np.round(n / _NORMAL_BIN), d
        offsets[a:b] = np.einsum("ij,ij->i", n, tris[:, 0])
        for k, axis in enumerate(((d + 1) % 3, (d + 2) % 3)):
            c = tris[rows, :, axis]
            corners[a:b, 2 * k], corners[a:b, 2 * k + 1] = c.min(1), c.max(1)
    drop = keys[:, 3].astype(np.int64)
    uv = np.stack([(drop + 1) % 3, (drop + 2) % 3], axis=1)
    del drop
    order = np.lexsort((offsets, *keys.T[::-1]))
    order = order[good[order]]
    # groups: same bin and projection, offsets chained within 2 tolerances
    k, off = keys[order], offsets[order]
    new = np.ones(len(order), dtype=bool)
    new[1:] = (k[1:] != k[:-1]).any(axis=1) | (np.diff(off) > 2 * _STACKED_PLANE)
    del keys, k, off
    group = np.cumsum(new)
    order = order[np.lexsort((corners[order, 0], group))].astype(np.int64, copy=False)
    del group
    starts = np.concatenate([np.flatnonzero(new), [len(order)]]).astype(np.int64)
    del new
    stacked = np.zeros(f, dtype=np.bool_)
    if len(order):
        box = np.ascontiguousarray(corners[order])
        del corners
        _mark_stacked(v32, faces, normals, offsets, uv, box, order, starts,
                      _cell_quantiles(box, starts), _STACKED_PLANE, stacked)
    return stacked


def _kernel_signatures() -> dict:
    """Kernel -> the only signature it is compiled for (as ``viscore.scene`` pins its own)."""

    def array(dtype, ndim: int = 1):
        return types.Array(dtype, ndim, "C")

    f32, i32, i64, f64 = types.float32, types.int32, types.int64, types.float64
    ptr = types.intp
    rays = array(f32)
    packet = (array(f32, 2), array(i32, 2), array(i32), array(i32))
    return {
        _intersect_chunk: [i64(ptr, ptr, ptr, rays, rays, rays, types.boolean, f64,
                               array(f64), array(i64), *packet, array(f32), array(i32),
                               array(types.boolean))],
        _occluded_chunk: [types.void(ptr, ptr, rays, rays, rays, types.boolean,
                                     array(types.boolean), *packet)],
    }


#: Compile (or load from numba's cache) the two packet loops once, one signature each.
_ready_kernels = pinned_kernels(_kernel_signatures)


def packets_enabled() -> bool:
    """False where ``VISCORE_RAY_PACKETS`` says ``0``, ``false``, ``no`` or ``off``."""
    return os.environ.get(PACKETS_ENV, "1").strip().lower() not in ("0", "false", "no", "off")


def _library_candidates() -> list[str]:
    """Paths of the libembree4 files embreex's wheel installed, best first (may be empty)."""
    spec = importlib_util.find_spec("embreex")
    if spec is None or not spec.submodule_search_locations:
        return []
    package = list(spec.submodule_search_locations)[0]
    root = os.path.dirname(package)
    found = []
    for folder in _LIBRARY_FOLDERS:
        for pattern in _LIBRARY_PATTERNS:
            found.extend(sorted(glob.glob(os.path.join(root, folder, pattern))))
    return found


@dataclass(frozen=True)
class Library:
    """An opened libembree4 that has every symbol the packet path calls.

    Attributes
    ----------
    path : str
        The library file.
    cdll : ctypes.CDLL
        Its handle, with ``argtypes`` and ``restype`` set on the calls used.
    intersect1, intersect16, occluded16 : int
        Addresses of ``rtcIntersect1``, ``rtcIntersect16`` and ``rtcOccluded16``.
    version : int
        Embree's version as ``major * 10000 + minor * 100 + patch``.
    """

    path: str
    cdll: ctypes.CDLL
    intersect1: int
    intersect16: int
    occluded16: int
    version: int


def _declare(cdll: ctypes.CDLL) -> None:
    """Set the C signatures (rtcore_*.h) of the calls made through ctypes."""
    p, u, z = ctypes.c_void_p, ctypes.c_uint, ctypes.c_size_t
    i = ctypes.c_int
    calls = {
        "rtcNewDevice": (p, [ctypes.c_char_p]),
        "rtcReleaseDevice": (None, [p]),
        "rtcGetDeviceError": (i, [p]),
        "rtcGetDeviceProperty": (ctypes.c_ssize_t, [p, i]),
        "rtcNewScene": (p, [p]),
        "rtcReleaseScene": (None, [p]),
        "rtcSetSceneFlags": (None, [p, i]),
        "rtcSetSceneBuildQuality": (None, [p, i]),
        "rtcCommitScene": (None, [p]),
        "rtcNewGeometry": (p, [p, i]),
        "rtcReleaseGeometry": (None, [p]),
        "rtcSetSharedGeometryBuffer": (None, [p, i, u, i, p, z, z, z]),
        "rtcCommitGeometry": (None, [p]),
        "rtcAttachGeometry": (u, [p, p]),
    }
    for name, (restype, argtypes) in calls.items():
        fn = getattr(cdll, name)
        fn.restype = restype
        fn.argtypes = argtypes


def _open(path: str) -> Library | None:
    """The library at ``path`` if it opens, has every symbol and is Embree 4; else None."""
    try:
        cdll = ctypes.CDLL(path)
    except OSError as exc:
        _log.debug("libembree4 at %s does not open: %s", path, exc)
        return None
    missing = [name for name in _SYMBOLS if not hasattr(cdll, name)]
    if missing:
        _log.debug("libembree4 at %s lacks %s", path, ", ".join(missing))
        return None
    _declare(cdll)
    device = cdll.rtcNewDevice(None)
    if not device:
        return None
    try:
        major = cdll.rtcGetDeviceProperty(device, _RTC_DEVICE_PROPERTY_VERSION_MAJOR)
        version = cdll.rtcGetDeviceProperty(device, _RTC_DEVICE_PROPERTY_VERSION)
    finally:
        cdll.rtcReleaseDevice(device)
    if major != 4:
        _log.debug("library at %s is Embree %d, not 4", path, major)
        return None
    address = ctypes.cast
    return Library(path=path, cdll=cdll,
                   intersect1=address(cdll.rtcIntersect1, ctypes.c_void_p).value,  # type: ignore[arg-type]
                   intersect16=address(cdll.rtcIntersect16, ctypes.c_void_p).value,  # type: ignore[arg-type]
                   occluded16=address(cdll.rtcOccluded16, ctypes.c_void_p).value,  # type: ignore[arg-type]
                   version=int(version))


_library_lock = threading.Lock()
_library: list = []  # [Library | None] once looked for


def library() -> Library | None:
    """embreex's libembree4 with the packet calls, opened once; None where there is none.

    None where the packet path is turned off (``VISCORE_RAY_PACKETS=0``, read
    at each call), where numba does not compile (``NUMBA_DISABLE_JIT=1``),
    where embreex is not installed or its wheel holds no
    libembree4 (a build against a system Embree), or where that library
    lacks a symbol or is not Embree 4. :class:`viscore.Scene` then uses
    embreex's ``EmbreeScene.run`` alone.
    """
    if not packets_enabled():
        return None
    from numba.core.config import DISABLE_JIT  # type: ignore[attr-defined]

    if DISABLE_JIT:  # the packet loops call Embree from compiled code only
        return None
    with _library_lock:
        if not _library:
            found = None
            for path in _library_candidates():
                found = _open(path)
                if found is not None:
                    break
            if found is None:
                _log.debug("no usable libembree4 beside embreex: rays traced one at a time")
            _library.append(found)
        return _library[0]


def _aligned_empty(shape: tuple[int, ...], dtype) -> np.ndarray:
    """An uninitialised C-contiguous array whose data starts on a 64-byte boundary."""
    dtype = np.dtype(dtype)
    nbytes = math.prod(shape) * dtype.itemsize
    raw = np.empty(nbytes + _ALIGN, dtype=np.uint8)
    start = -raw.ctypes.data % _ALIGN
    return raw[start:start + nbytes].view(dtype).reshape(shape)


_per_thread = threading.local()


def _thread_buffers() -> tuple:
    """This thread's query buffers, made at its first query and reused by every later one.

    An ``RTCRayHit16`` (float32 and int32 views), its valid mask, the
    ``RTCIntersectArguments``/``RTCOccludedArguments`` words (room to spare;
    the pointers NULL), and one ``RTCRayHit`` (float32 and int32 views).
    Nothing in them outlives a call: each query fills what it reads.
    """
    buffers = getattr(_per_thread, "buffers", None)
    if buffers is None:
        rays = _aligned_empty((_ROWS, PACKET), np.float32)
        valid = _aligned_empty((PACKET,), np.int32)
        args = np.zeros(16, dtype=np.int32)
        args[1] = _RTC_FEATURE_FLAG_ALL
        single = _aligned_empty((_WORDS,), np.float32)
        buffers = (rays, rays.view(np.int32), valid, args, single, single.view(np.int32))
        _per_thread.buffers = buffers
    return buffers


class EmbreeError(RuntimeError):
    """Embree reported an error while a :class:`PacketScene` was built."""


class PacketScene:
    """A robust Embree 4 scene of one triangle soup, traced by packets of 16 rays.

    Parameters
    ----------
    lib : Library
        From :func:`library`.
    vertices : (v, 3) float
        Vertex positions, in the frame the rays will be given in (float32).
    faces : (f, 3) int
        Vertex indices of each triangle (``0 <= index < v``).

    Notes
    -----
    The float32 vertices (padded to four floats, as embreex lays them out)
    and uint32 indices are shared with Embree, not copied, and held here.
    Queries may run from several threads at once (Embree's queries are
    thread safe; each call has its own packet buffers).
    """

    def __init__(self, lib: Library, vertices: np.ndarray, faces: np.ndarray) -> None:
        self._lib = lib
        cdll = lib.cdll
        v = np.asarray(vertices)
        self._vertices = np.zeros((len(v), 4), dtype=np.float32)
        self._vertices[:, :3] = v
        # one spare triangle: Embree may read a buffer's last item with a 16-byte load
        self._faces = np.zeros((len(faces) + 1, 3), dtype=np.uint32)
        self._faces[:-1] = faces
        self._stacked = _stacked_triangles(self._vertices, self._faces[:-1])
        self._device = self._scene = None
        self._device = cdll.rtcNewDevice(None)
        if not self._device:
            raise EmbreeError("rtcNewDevice failed")
        self._scene = cdll.rtcNewScene(self._device)
        cdll.rtcSetSceneFlags(self._scene, _RTC_SCENE_FLAG_ROBUST)
        cdll.rtcSetSceneBuildQuality(self._scene, _RTC_BUILD_QUALITY_MEDIUM)
        geometry = cdll.rtcNewGeometry(self._device, _RTC_GEOMETRY_TYPE_TRIANGLE)
        cdll.rtcSetSharedGeometryBuffer(geometry, _RTC_BUFFER_TYPE_VERTEX, 0, _RTC_FORMAT_FLOAT3,
                                        self._vertices.ctypes.data, 0, 16, len(v))
        cdll.rtcSetSharedGeometryBuffer(geometry, _RTC_BUFFER_TYPE_INDEX, 0, _RTC_FORMAT_UINT3,
                                        self._faces.ctypes.data, 0, 12, len(faces))
        cdll.rtcCommitGeometry(geometry)
        cdll.rtcAttachGeometry(self._scene, geometry)
        cdll.rtcReleaseGeometry(geometry)
        cdll.rtcCommitScene(self._scene)
        error = cdll.rtcGetDeviceError(self._device)
        if error:
            self.close()
            raise EmbreeError(f"Embree error {error} while building the scene")

    def close(self) -> None:
        """Release the Embree scene and device (also done when the object is collected)."""
        cdll = self._lib.cdll
        if self._scene:
            cdll.rtcReleaseScene(self._scene)
            self._scene = None
        if self._device:
            cdll.rtcReleaseDevice(self._device)
            self._device = None

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001, S110 - interpreter shutdown: nothing left to do
            pass

    def first_hit(self, o32: np.ndarray, d32: np.ndarray, tfar32: np.ndarray | None,
                  scale: float, t: np.ndarray, tri: np.ndarray) -> None:
        """Nearest hit of each ray, written into ``t`` (world units) and ``tri``.

        ``o32``, ``d32`` : flat ``(3m,)`` float32 origins and unit directions,
        ``tfar32`` ``(m,)`` float32 segment lengths or None (unbounded, as
        embreex's 1e37); ``t`` ``(m,)`` float64 gets ``tfar * scale`` and
        ``inf`` on a miss, ``tri`` ``(m,)`` int64 the triangle or -1.
        """
        _ready_kernels()
        has_tfar = tfar32 is not None
        _intersect_chunk(self._lib.intersect16, self._lib.intersect1, self._scene, o32, d32,
                         tfar32 if has_tfar else d32, has_tfar, scale, t, tri,
                         *_thread_buffers(), self._stacked)

    def occluded(self, o32: np.ndarray, d32: np.ndarray, tfar32: np.ndarray | None,
                 hit: np.ndarray) -> None:
        """Whether each ray hits anything within its segment, written into ``hit`` (bool)."""
        _ready_kernels()
        has_tfar = tfar32 is not None
        _occluded_chunk(self._lib.occluded16, self._scene, o32, d32,
                        tfar32 if has_tfar else d32, has_tfar, hit, *_thread_buffers()[:4])
