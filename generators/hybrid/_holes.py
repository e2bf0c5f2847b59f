"""Hole test of the hybrid generator's planar patches (Wu et al. 2022, sec. 3.1.1, Fig. 6).

References
----------
.. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (sec. 3.1.1, hole filling; Fig. 6; sec. 4.2, l_s)
"""

from __future__ import annotations

import numpy as np

from .._polygons import triangulate_polygon

__all__ = ["holes_to_fill", "judge_holes", "sample_polygon", "SEGMENT_LENGTH", "OPEN_REASONS"]

#: Why a hole stays open (:func:`judge_holes`): rays through it leave the input
#: (an opening to the outside: a window, a door); the segments miss but full rays
#: meet the input beyond ``l_s`` (a hollow: a room behind a doorway, a deep
#: niche); or some segments hit and some miss (partly backed: a decoration that
#: covers part of the hole, a frame's slot).
OPEN_REASONS = ("opening", "hollow", "partly backed")

#: l_s as a fraction of the input's bounding-box diagonal (Wu et al. 2022, sec. 4.2).
SEGMENT_LENGTH = 0.01

#: Sample points per hole: one per (l_s / 2)^2 of hole area, within these bounds.
MIN_SAMPLES = 16
MAX_SAMPLES = 1024

#: Margin kept from the hole's rim, as a fraction of l_s.
RIM_MARGIN = 0.05


def sample_polygon(polygon, count: int, rng: np.random.Generator) -> np.ndarray:
    """``(count, 2) float64`` points uniform over a shapely polygon (by its triangles).

    A polygon of no area gives its representative point ``count`` times.
    """
    verts, tris = triangulate_polygon(polygon) if polygon.area > 0 else (None, [])
    if len(tris) == 0:  # type: ignore[arg-type]
        p = polygon.representative_point()
        return np.repeat([[p.x, p.y]], count, axis=0)
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]  # type: ignore[index]
    ab, ac = b - a, c - a
    area = 0.5 * np.abs(ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0])
    pick = rng.choice(len(tris), size=count, p=area / area.sum())  # type: ignore[arg-type]
    r1, r2 = rng.random(count), rng.random(count)
    s = np.sqrt(r1)
    w0, w1, w2 = 1 - s, s * (1 - r2), s * r2
    return w0[:, None] * a[pick] + w1[:, None] * b[pick] + w2[:, None] * c[pick]


def holes_to_fill(scene, holes: list, frame: np.ndarray, *, segment_length: float,
                  rng: np.random.Generator) -> np.ndarray:
    """Which holes of one planar patch the segment test fills (:func:`judge_holes`'s mask)."""
    return judge_holes(scene, holes, frame, segment_length=segment_length, rng=rng)[0]


def judge_holes(scene, holes: list, frame: np.ndarray, *, segment_length: float,
                rng: np.random.Generator) -> tuple[np.ndarray, list]:
    """Which holes of one planar patch the segment test fills, and why the others stay open.

    Parameters
    ----------
    scene : viscore.Scene
        Embree scene of the input mesh.
    holes : list of shapely.Polygon
        The holes, in the plane coordinates of ``frame``.
    frame : (4, 3) float64
        Origin, u, v, n of the plane: a plane point ``(x, y)`` is
        ``origin + x u + y v`` in world units; ``n`` is the unit normal.
    segment_length : float
        l_s, world units: each test segment reaches this far from its sample
        point along ``+n`` and along ``-n``.
    rng : numpy.random.Generator
        Draws the sample points.

    Returns
    -------
    fill : (k,) bool
        True where every segment of the hole hits the input.
    reasons : list of str or None
        Per hole: None when filled, else one of :data:`OPEN_REASONS`: a
        majority of its sample points see out of the input along ``+n`` or
        ``-n`` (unbounded rays that meet nothing): "opening"; else a majority
        of its segments miss: "hollow"; else "partly backed".
    """
    origin, u, v, n = frame
    points, owner = [], []
    for k, hole in enumerate(holes):
        inner = hole.buffer(-RIM_MARGIN * segment_length)
        if inner.is_empty or inner.area <= 0:
            inner = hole
        count = int(np.clip(np.ceil(inner.area / (0.5 * segment_length) ** 2),
                            MIN_SAMPLES, MAX_SAMPLES))
        points.append(sample_polygon(inner, count, rng))
        owner.append(np.full(count, k))
    if not points:
        return np.zeros(0, dtype=bool), []
    xy = np.concatenate(points)
    owner = np.concatenate(owner)
    world = origin + xy[:, :1] * u + xy[:, 1:2] * v
    hit = scene.any_hit(world, np.broadcast_to(n, world.shape), max_distance=segment_length)
    hit |= scene.any_hit(world, np.broadcast_to(-n, world.shape), max_distance=segment_length)
    k = len(holes)
    samples = np.bincount(owner, minlength=k)
    missed = np.bincount(owner, weights=~hit, minlength=k)
    fill = missed == 0
    reasons: list = [None] * k
    open_points = ~fill[owner]
    if open_points.any():
        pts = world[open_points]
        # unbounded rays both ways: a point that meets nothing along one of them sees out
        out = ~scene.any_hit(pts, np.broadcast_to(n, pts.shape))
        out |= ~scene.any_hit(pts, np.broadcast_to(-n, pts.shape))
        escaped = np.bincount(owner[open_points], weights=out, minlength=k)
        for i in np.flatnonzero(~fill):
            if escaped[i] > 0.5 * samples[i]:
                reasons[i] = OPEN_REASONS[0]
            elif missed[i] > 0.5 * samples[i]:
                reasons[i] = OPEN_REASONS[1]
            else:
                reasons[i] = OPEN_REASONS[2]
    return fill, reasons
