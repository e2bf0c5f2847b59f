"""Planar sections, step 4.3: edge loops of a slice bitmap, holes bridged, RDP.

Silvennoinen et al. 2014 [1]_, sec. 4.3. The covered pixels of a slice are
unit squares; the edge loops are the boundary of their union, along pixel
edges. We form that union with shapely (GEOS) from one rectangle per run of
covered pixels in a row: GEOS returns each connected part as a polygon with
its outer loop and its hole loops, and handles loops that meet at pixel
corners (two squares touching at a corner are two polygons; a hole touching
its outer loop at a corner stays a hole touching at one point). Each polygon
is then simplified by Ramer-Douglas-Peucker [2]_ with the tolerance of the
paper, one voxel (``shapely``'s topology-preserving variant of it: loops
never cross each other or themselves, which plain RDP can make them do on
parts one or two voxels wide), and its holes are bridged to the enclosing
loop: each hole, in order of its leftmost vertex, is joined by the shortest
segment from one of its vertices to a vertex of the loop built so far that
stays inside the polygon, giving one weakly simple loop (the bridge is
walked twice) per connected part.

The paper bridges before simplifying; simplifying the loops first and
bridging the simplified loops gives the same loops without having to keep
the bridge's four end vertices out of RDP.

All coordinates are in pixels (column, row), integers: RDP keeps a subset of
the pixel corners, so the simplification chain (:mod:`._section_simplify`)
runs on exact integer geometry.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 4.3)
.. [2] Douglas, D. H., Peucker, T. K. "Algorithms for the Reduction of the
   Number of Points Required to Represent a Digitized Line or its
   Caricature". Cartographica 10(2), 1973, pp. 112-122.
   :DOI:`10.3138/FM57-6770-U75U-7727`
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon
from shapely.geometry.polygon import orient

__all__ = ["CandidatePolygon", "pixel_region", "slice_polygons", "bridge_holes"]

#: Connected parts smaller than this many pixels are dropped (they cannot
#: occlude a beam wider than a voxel).
MIN_POLYGON_PIXELS = 4.0


@dataclass(frozen=True, eq=False)
class CandidatePolygon:
    """One connected part of a slice, simplified, holes bridged.

    Attributes
    ----------
    ring : (n, 2) float64
        Weakly simple loop, counter-clockwise in (column, row), integer
        pixel-corner coordinates; holes are walked clockwise via their
        bridges. No closing duplicate of the first vertex.
    polygon : shapely.Polygon
        The same region as a valid polygon with holes (the "original
        candidate" of sec. 4.4).
    holes : int
        Hole loops bridged into ``ring``.
    """

    ring: np.ndarray
    polygon: Polygon
    holes: int


def pixel_region(image: np.ndarray):
    """Union of the covered pixel squares: shapely Polygon or MultiPolygon (or empty).

    Pixel (i, j) is the square [j, j+1] x [i, i+1] in (column, row).
    """
    img = np.asarray(image, dtype=bool)
    padded = np.zeros((img.shape[0], img.shape[1] + 2), dtype=np.int8)
    padded[:, 1:-1] = img
    d = np.diff(padded, axis=1)
    si, sj = np.nonzero(d == 1)
    ei, ej = np.nonzero(d == -1)  # same row order: runs pair up
    if len(si) == 0:
        return Polygon()
    boxes = shapely.box(sj.astype(np.float64), si.astype(np.float64),
                        ej.astype(np.float64), ei + 1.0)
    return shapely.union_all(boxes)


def _parts(geom) -> list[Polygon]:
    if geom.is_empty:
        return []
    if isinstance(geom, Polygon):
        return [geom]
    return [g for g in getattr(geom, "geoms", []) if isinstance(g, Polygon) and not g.is_empty]


def _ring_array(ring) -> np.ndarray:
    xy = np.asarray(ring.coords, dtype=np.float64)[:-1]
    keep = np.any(xy != np.roll(xy, 1, axis=0), axis=1)
    return xy[keep] if keep.any() else xy[:1]


def _dedupe(xy: np.ndarray) -> np.ndarray:
    """Drop consecutive duplicate vertices (cyclically)."""
    while len(xy) > 1:
        keep = np.any(xy != np.roll(xy, 1, axis=0), axis=1)
        if keep.all():
            break
        xy = xy[keep]
    return xy


def bridge_holes(polygon: Polygon) -> np.ndarray:
    """One weakly simple counter-clockwise loop: the outer loop with every hole bridged in.

    Holes are taken in order of their leftmost vertex; each joins the loop
    built so far by the shortest segment between one of its vertices and a
    vertex of that loop (used once so far) that lies inside the polygon and
    crosses no earlier bridge.

    Returns
    -------
    ring : (n, 2) float64
    """
    poly = orient(polygon, sign=1.0)  # outer counter-clockwise, holes clockwise
    ring = _ring_array(poly.exterior)
    holes = [_ring_array(h) for h in poly.interiors]
    holes.sort(key=lambda h: float(h[:, 0].min()))
    bridges: list[LineString] = []
    prepared = shapely.prepared.prep(poly.buffer(1e-9))
    for hole in holes:
        # vertices of the loop used once (a duplicate would need its wedge to pick the copy)
        _, inv, cnt = np.unique(ring, axis=0, return_inverse=True, return_counts=True)
        usable = np.flatnonzero(cnt[inv.ravel()] == 1)
        d2 = ((hole[:, None, :] - ring[None, usable, :]) ** 2).sum(axis=2)
        order = np.argsort(d2, axis=None, kind="stable")
        chosen = None
        for flat in order:
            hi, vi = divmod(int(flat), len(usable))
            a, b = hole[hi], ring[usable[vi]]
            if d2[hi, vi] == 0:
                chosen = (hi, usable[vi])
                break
            seg = LineString([a, b])
            if prepared.contains(seg) and not any(seg.crosses(br) for br in bridges):
                chosen = (hi, usable[vi])
                bridges.append(seg)
                break
        if chosen is None:  # cannot happen for a valid polygon; keep the hole out
            continue
        hi, vi = chosen
        walk = np.concatenate([hole[hi:], hole[:hi], hole[hi:hi + 1]])
        ring = np.concatenate([ring[:vi + 1], walk, ring[vi:vi + 1], ring[vi + 1:]])
    return _dedupe(ring)


def slice_polygons(image: np.ndarray, *, tolerance: float | None = 1.0,
                   min_pixels: float = MIN_POLYGON_PIXELS) -> list[CandidatePolygon]:
    """Candidate polygons of one slice bitmap (sec. 4.3).

    Parameters
    ----------
    image : (H, W) bool
        Covered pixels of the slice.
    tolerance : float or None, optional
        RDP tolerance in pixels (default 1, one voxel); None keeps the pixel
        loops (only collinear vertices are removed), as the conservative
        variant does.
    min_pixels : float, optional
        Parts with a smaller area (pixels) are dropped. Default 4.

    Returns
    -------
    list of CandidatePolygon
        Largest first.

    Examples
    --------
    >>> img = np.zeros((6, 6), bool); img[1:3, 1:3] = True; img[3:5, 3:5] = True
    >>> [len(c.ring) for c in slice_polygons(img, tolerance=None)]
    [4, 4]
    """
    region = pixel_region(image)
    out = []
    for part in _parts(region):
        if part.area < min_pixels:
            continue
        simple = part.simplify(0.0 if tolerance is None else float(tolerance),
                               preserve_topology=True)
        for p in _parts(simple):
            if p.area < min_pixels or not p.is_valid:
                continue
            p = orient(p, sign=1.0)
            ring = bridge_holes(p)
            if len(ring) >= 3:
                out.append(CandidatePolygon(ring=ring, polygon=p, holes=len(p.interiors)))
    out.sort(key=lambda c: -c.polygon.area)
    return out
