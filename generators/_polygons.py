"""Shapely polygons to triangles: earcut triangulation with holes (mapbox-earcut).

Shared by the hybrid method's planar patches and hole sampling
(:mod:`viscore.generators.hybrid`) and open to the other families.
"""

from __future__ import annotations

import numpy as np

__all__ = ["triangulate_polygon"]


def triangulate_polygon(polygon) -> tuple[np.ndarray, np.ndarray]:
    """Constrained triangulation of a shapely polygon with holes (mapbox-earcut).

    Returns
    -------
    vertices : (v, 2) float64
        The ring vertices, exterior first.
    triangles : (t, 3) int64
        Indices into ``vertices``; every ring edge is a triangle edge.
    """
    import mapbox_earcut

    rings = [np.asarray(polygon.exterior.coords)[:-1]]
    rings += [np.asarray(r.coords)[:-1] for r in polygon.interiors]
    verts = np.concatenate(rings).astype(np.float64)
    ends = np.cumsum([len(r) for r in rings]).astype(np.uint32)
    tris = np.asarray(mapbox_earcut.triangulate_float64(verts, ends), dtype=np.int64)
    return verts, tris.reshape(-1, 3)
