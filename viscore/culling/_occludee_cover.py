"""The occludee test's cover rule: a triangle hidden in a buffer pixel by occluder triangles
it lies behind, decided exactly in the pixel's square and, where needed, in parts of it.

The occludee test of the conservative depth buffer (sec. 6 of the occluder-skins paper,
Leone et al. 2012, on an object's own triangles: :meth:`ConservativeDepthBuffer.
occluded_triangles`) compares one depth per pixel, the farthest distance of the
occluders over the pixel, with the nearest of the occludee's triangle. Two cases defeat
it though the occluders hide the triangle:

- the occluders' distance varies over the pixel by more than the triangle's distance
  behind them: a part lying just behind a curved wall, a ledge set into an adobe house,
  a prop half buried in a dune;
- the pixel is not covered whole: the triangle's projection reaches only its covered
  part (an object just below a ridge, the sky above it in the same pixel), or it lies
  where two meshes meet without a rule proving their cover.

For a pixel ``Q`` (widened by the junction rule's slack) that fails, the rule takes the
occluder triangles whose projection meets ``Q``, lying wholly in front of the eye and
not edge-on (those of the junction rule, :mod:`viscore.culling._junctions`), and keeps
the ones that the triangle's whole part in the view pyramid lies behind: past their
plane by at least the buffer's depth margin along every ray through ``Q``. When their
projections cover ``Q`` (the junction rule's exact cover test), every ray through ``Q``
meets one of them before it could reach the triangle, and the pixel passes. Otherwise
``Q`` is split into four quarters, down to :data:`LEVELS` times; a quarter that the
triangle's projection does not meet passes, one it meets must be covered the same way.
A pixel is decided when every part is; the triangle's other pixels answer the usual
test.

Why a passed part hides the triangle. Let a ray through the part meet the triangle at
``q``. The kept triangles' projections cover the part, so the ray meets one of them,
``T``, at a point of ``T``'s plane; ``q`` lies behind that plane along every ray of the
pixel (the plane's inverse depth is affine on the screen: the test is linear in ``q``
and holds at the clipped part's vertices, so on all of it), so the ray meets ``T``
first. Whatever the ray meets first is then an occluder, nearer than ``q``.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit_cached
from ._depth_kernel import (
    PYRAMID_SLACK,
    TOUCH_SLACK,
    _camera_triangle,
    _clip_to_pyramid,
    _outside_an_edge,
)
from ._junctions import MAX_COORD, ON_EDGE, _covers, _meets, _project, _widened_box

__all__ = ["cover_pairs", "frame_tiles", "LEVELS", "MAX_KEPT", "TILE"]

#: Times a pixel's square is split in four where its kept triangles do not cover it
#: whole: its parts are down to 1/2**LEVELS of a pixel's side.
LEVELS = 3

#: Kept triangles a square's cover is sought among (more: the nearest in list order).
MAX_KEPT = 48

#: Side of the tiles the frame's occluder triangles are listed in, buffer pixels.
TILE = 8

#: Widening of a pixel's square, in buffer pixels (the junction rule's).
SLACK = 1e-3

#: Farthest vertex (buffer pixels from the pixel) of a triangle kept: the junction rule's
#: :data:`~viscore.culling._junctions.MAX_COORD` in the frame of the smallest parts, whose
#: side is 1 / 2**LEVELS of a pixel's.
_FARTHEST = MAX_COORD / (1 << (LEVELS + 1))


@njit_cached()
def _tile_lists(tri2, ok, w, h, tile, count, fill, start, lst):  # pragma: no cover
    """Per tile of ``tile`` x ``tile`` buffer pixels, the triangles whose projected
    bounding box (widened by :data:`SLACK`) meets it: counted into ``count`` when
    ``fill`` is False, else listed into ``lst`` from ``start``."""
    tw = (w + tile - 1) // tile
    th = (h + tile - 1) // tile
    for t in range(len(tri2)):
        if not ok[t]:
            continue
        cmin, cmax, rmin, rmax = _widened_box(tri2, t, SLACK)
        if cmax < 0 or rmax < 0 or cmin > w or rmin > h:
            continue
        a0 = max(0, int(math.floor(rmin)) // tile)
        a1 = min(th - 1, int(math.floor(rmax)) // tile)
        b0 = max(0, int(math.floor(cmin)) // tile)
        b1 = min(tw - 1, int(math.floor(cmax)) // tile)
        for a in range(a0, a1 + 1):
            for b in range(b0, b1 + 1):
                c = a * tw + b
                if fill:
                    lst[start[c] + count[c]] = t
                count[c] += 1


def frame_tiles(vertices: np.ndarray, faces: np.ndarray, eye: np.ndarray, basis, hx: float,
                hy: float, w: int, h: int, z0: float) -> tuple:
    """The frame's occluder triangles in camera coordinates, projected, and listed per
    tile of :data:`TILE` pixels: ``(vc, faces, tri2, start, lst)`` for :func:`cover_pairs`."""
    f, r, u = basis
    rel = np.asarray(vertices, dtype=np.float64) - np.asarray(eye, dtype=np.float64)
    vc = np.ascontiguousarray(np.stack([rel @ r, rel @ u, rel @ f], axis=1))
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    tri2 = np.empty((len(faces), 3, 2))
    ok = np.empty(len(faces), dtype=bool)
    _project(vc, faces, z0, hx, hy, w, h, tri2, ok)
    tiles = -(-w // TILE) * -(-h // TILE)
    count = np.zeros(tiles, dtype=np.int64)
    start = np.zeros(tiles + 1, dtype=np.int64)
    lst = np.zeros(0, dtype=np.int64)
    _tile_lists(tri2, ok, w, h, TILE, count, False, start, lst)
    start[1:] = np.cumsum(count)
    lst = np.zeros(int(start[-1]), dtype=np.int64)
    count[:] = 0
    _tile_lists(tri2, ok, w, h, TILE, count, True, start, lst)
    return vc, faces, tri2, start, lst


@njit_cached()
def _part_meets(sc, sr, n, c0, r0, c1, r1):  # pragma: no cover
    """Whether the convex polygon ``(sc, sr)[:n]`` (screen, either orientation) may meet
    the rectangle [c0, c1] x [r0, r1]: no edge of it has the rectangle wholly outside
    (within :data:`TOUCH_SLACK`), and their bounding boxes overlap."""
    cmin = cmax = sc[0]
    rmin = rmax = sr[0]
    area = 0.0
    for m in range(n):
        e = m + 1 if m + 1 < n else 0
        cmin, cmax = min(cmin, sc[m]), max(cmax, sc[m])
        rmin, rmax = min(rmin, sr[m]), max(rmax, sr[m])
        area += sc[m] * sr[e] - sc[e] * sr[m]
    if cmax < c0 - TOUCH_SLACK or cmin > c1 + TOUCH_SLACK or rmax < r0 - TOUCH_SLACK \
            or rmin > r1 + TOUCH_SLACK:
        return False
    if abs(area) <= TOUCH_SLACK:
        return True  # a sliver seen edge-on: its box decides
    return not _outside_an_edge(sc, sr, n, 1.0 if area > 0.0 else -1.0, c0, r0, c1, r1)


@njit_cached()
def _pair_hidden(tri, k, i, j, eye, r, u, f, hx, hy, w, h, margin, vc, faces, tri2, start,
                 lst, px, py, pz, qx, qy, qz, sc, sr, loc, sub, params, live, stack
                 ):  # pragma: no cover
    """Whether triangle ``k`` of ``tri`` is hidden in buffer pixel (``i``, ``j``) by the
    rule of the module docstring."""
    _camera_triangle(tri, k, eye, r, u, f, px, py, pz)
    n = _clip_to_pyramid(hx * (1.0 + PYRAMID_SLACK), hy * (1.0 + PYRAMID_SLACK), px, py, pz,
                         qx, qy, qz, 3)
    if n == 0:
        return True
    for m in range(n):
        if not pz[m] > 0.0:
            return False
        sc[m] = (px[m] / pz[m] * (0.5 / hx) + 0.5) * w
        sr[m] = (0.5 - py[m] / pz[m] * (0.5 / hy)) * h
    c0, r0, c1, r1 = j - SLACK, i - SLACK, j + 1.0 + SLACK, i + 1.0 + SLACK
    # the widened square's corner directions (x, y, 1), for each plane's inverse depth
    xa = (c0 / w - 0.5) * 2.0 * hx
    xb = (c1 / w - 0.5) * 2.0 * hx
    ya = (0.5 - r0 / h) * 2.0 * hy
    yb = (0.5 - r1 / h) * 2.0 * hy
    tw = (w + TILE - 1) // TILE
    c = (i // TILE) * tw + j // TILE
    nk = 0
    for s in range(start[c], start[c + 1]):
        t = lst[s]
        if not _meets(tri2, t, c0, r0, c1, r1):
            continue
        a = vc[faces[t, 0]]
        b = vc[faces[t, 1]]
        e = vc[faces[t, 2]]
        b0, b1, b2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
        e0, e1, e2 = e[0] - a[0], e[1] - a[1], e[2] - a[2]
        n0, n1, n2 = b1 * e2 - b2 * e1, b2 * e0 - b0 * e2, b0 * e1 - b1 * e0
        off = n0 * a[0] + n1 * a[1] + n2 * a[2]
        scale = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2) \
            * math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
        if not abs(off) > 1e-6 * scale:
            continue  # a plane nearly through the eye
        # its inverse depth along (x, y, 1) is g = (n0 x + n1 y + n2) / off: positive
        # over the square (the plane ahead of the eye there), largest at a corner
        gmax = -np.inf
        for x in (xa, xb):
            for y in (ya, yb):
                g = (n0 * x + n1 * y + n2) / off
                gmax = max(gmax, g) if g > 0.0 else np.inf
        if not gmax < np.inf:
            continue
        behind = True
        for m in range(n):
            if not (n0 * px[m] + n1 * py[m] + n2 * pz[m]) / off >= 1.0 + margin * gmax:
                behind = False
                break
        if not behind:
            continue
        far = 0.0
        for v in range(3):
            loc[nk, v, 0] = tri2[t, v, 0] - j
            loc[nk, v, 1] = tri2[t, v, 1] - i
            far = max(far, abs(loc[nk, v, 0]), abs(loc[nk, v, 1]))
        if far > _FARTHEST:
            continue  # too far out for the cover test's precision in the smallest parts
        nk += 1
        if nk == MAX_KEPT:
            break
    if nk == 0:
        return False
    # the squares still to decide: (left, top, side), pixel-relative; the pixel first
    stack[0, 0], stack[0, 1], stack[0, 2] = 0.0, 0.0, 1.0
    top = 1
    for m in range(n):
        sc[m] -= j
        sr[m] -= i
    while top:
        top -= 1
        x0, y0, side = stack[top, 0], stack[top, 1], stack[top, 2]
        q0x, q0y = x0 - SLACK, y0 - SLACK
        q1x, q1y = x0 + side + SLACK, y0 + side + SLACK
        if not _part_meets(sc, sr, n, q0x, q0y, q1x, q1y):
            continue
        # the kept triangles meeting it, in its own frame: the square [-s, 1 + s]^2
        span = side + 2.0 * SLACK
        m2 = 0
        bigs = 1.0
        for t in range(nk):
            for v in range(3):
                sub[m2, v, 0] = (loc[t, v, 0] - q0x) / span
                sub[m2, v, 1] = (loc[t, v, 1] - q0y) / span
            if _meets(sub, m2, 0.0, 0.0, 1.0, 1.0):
                for v in range(3):
                    bigs = max(bigs, 1.0 + abs(sub[m2, v, 0]), 1.0 + abs(sub[m2, v, 1]))
                m2 += 1
        if m2 and bigs <= MAX_COORD \
                and _covers(sub, m2, 0.0, 1.0, ON_EDGE * bigs, params, live):
            continue
        if side <= 1.0 / (1 << LEVELS) * 1.000001:
            return False
        half = 0.5 * side
        for a in range(2):
            for b in range(2):
                stack[top, 0] = x0 + b * half
                stack[top, 1] = y0 + a * half
                stack[top, 2] = half
                top += 1
    return True


@njit_cached()
def cover_pairs(tri, rec, rec_start, eye, r, u, f, hx, hy, w, h, margin, vc, faces, tri2,
                start, lst, out):  # pragma: no cover
    """``out[g]`` for each group of listed pairs ``rec[rec_start[g]:rec_start[g + 1]]``, each
    (triangle, row, column): whether every pair's triangle is hidden in its pixel by the
    cover rule (module docstring); a group stops at its first pair that is not."""
    px = np.empty(8)
    py = np.empty(8)
    pz = np.empty(8)
    qx = np.empty(8)
    qy = np.empty(8)
    qz = np.empty(8)
    sc = np.empty(8)
    sr = np.empty(8)
    loc = np.empty((MAX_KEPT, 3, 2))
    sub = np.empty((MAX_KEPT, 3, 2))
    params = np.empty(2 + 2 * (4 + 3 * MAX_KEPT) + 8)
    live = np.empty(4 + 3 * MAX_KEPT, dtype=np.int64)
    stack = np.empty((3 * LEVELS + 4, 3))
    for g in range(rec_start.shape[0] - 1):
        out[g] = True
        for p in range(rec_start[g], rec_start[g + 1]):
            if not _pair_hidden(tri, rec[p, 0], rec[p, 1], rec[p, 2], eye, r, u, f, hx, hy,
                                w, h, margin, vc, faces, tri2, start, lst, px, py, pz, qx,
                                qy, qz, sc, sr, loc, sub, params, live, stack):
                out[g] = False
                break
