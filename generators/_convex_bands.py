"""Convex bands: a polygon with holes cut into convex pieces that meet edge to edge."""

from __future__ import annotations

import numpy as np
import shapely
import shapely.affinity
from shapely.geometry import Polygon

__all__ = ["convex_bands", "grid_bands", "polygons_of"]


def polygons_of(geometry) -> list[Polygon]:
    """The non-empty polygons of a shapely geometry."""
    if geometry.is_empty:
        return []
    if geometry.geom_type == "Polygon":
        return [geometry]
    return [p for g in getattr(geometry, "geoms", []) for p in polygons_of(g)]


def convex_bands(part: Polygon) -> list[Polygon]:
    """Convex pieces covering ``part`` (integer coordinates; holes allowed): ``part`` cut
    along the rows through every vertex, each piece then merged with the one below it whose
    union with it is convex. Snapped to the integer grid: inside ``part`` up to half a
    grid step; a part without holes is returned whole."""
    if not part.interiors:
        return [part]
    ys = np.unique(np.concatenate([np.asarray(r.coords)[:, 1]
                                   for r in (part.exterior, *part.interiors)]))
    x0, x1 = float(part.bounds[0]) - 1.0, float(part.bounds[2]) + 1.0
    below: list
    done, below = [], []
    for a, b in zip(ys[:-1], ys[1:], strict=True):  # a loop over rows, not over points
        cut = shapely.set_precision(shapely.intersection(part, shapely.box(x0, a, x1, b)), 1.0)
        row = []
        for piece in polygons_of(cut):
            if piece.interiors or piece.area <= 0:
                continue
            for k, lower in enumerate(below):
                if lower is None:
                    continue
                joined = shapely.union(lower, piece)
                if joined.geom_type == "Polygon" and not joined.interiors and \
                        joined.convex_hull.area - joined.area <= 1e-9 * joined.area:
                    piece = shapely.set_precision(joined, 1.0)
                    below[k] = None
                    break
            row.append(piece)
        done += [q for q in below if q is not None]
        below = row
    return [q for q in done + below if q.area > 0 and not q.interiors]


def grid_bands(geometry, step: float) -> list[Polygon]:
    """The convex bands of every polygon of ``geometry`` snapped to a grid of ``step``.

    ``geometry`` is scaled by ``1 / step`` and snapped to the integer grid
    (``shapely.set_precision``); the bands (:func:`convex_bands`) are in those
    grid units.
    """
    snapped = shapely.set_precision(
        shapely.affinity.scale(geometry, 1.0 / step, 1.0 / step, origin=(0, 0)), 1.0)
    return [band for part in polygons_of(snapped) for band in convex_bands(part)]
