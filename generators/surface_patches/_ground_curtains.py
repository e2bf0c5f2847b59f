"""Surface patches under open ground: vertical curtains in the space a terrain seals."""

from __future__ import annotations

import numpy as np
import shapely
import trimesh
from shapely.geometry import Polygon

__all__ = ["curtain_regions", "CURTAIN_PLANES", "MIN_FOOTPRINT"]

#: Vertical planes per horizontal axis through each open part, evenly spread
#: over its extent, and horizontal ones between its base and its top (the
#: selection keeps the curtains worth their triangles).
CURTAIN_PLANES = 12

#: A part is one layer (a height field) when its triangles' projections along the up
#: axis overlap by at most this share of their summed area (float rounding of the
#: union of shared edges).
LAYER_OVERLAP = 1e-9

#: An open part gets curtains when its footprint (bounding box across the up
#: axis) is at least this share of the whole input's footprint.
MIN_FOOTPRINT = 0.01


def _open_parts(vertices: np.ndarray, faces: np.ndarray) -> tuple[list, np.ndarray, np.ndarray]:
    """``(faces of the part, its boundary vertices)`` per part (faces joined across shared
    edges) with a boundary (edges of one face), and the merged vertices and faces those
    index."""
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    mesh.merge_vertices()
    merged = np.asarray(mesh.faces, dtype=np.int64)
    labels = trimesh.graph.connected_component_labels(mesh.face_adjacency,
                                                      node_count=len(merged))
    edges = np.sort(np.concatenate([merged[:, [0, 1]], merged[:, [1, 2]], merged[:, [2, 0]]]),
                    axis=1)
    owner = np.tile(np.arange(len(merged)), 3)
    _, inverse, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
    single = counts[inverse.reshape(-1)] == 1
    out = []
    merged_v = np.asarray(mesh.vertices, dtype=np.float64)
    for part in np.unique(labels[owner[single]]):
        rim = np.unique(edges[single & (labels[owner] == part)])
        out.append((np.flatnonzero(labels == part), merged_v[rim]))
    return out, merged_v, merged


def curtain_regions(vertices: np.ndarray, faces: np.ndarray, *, up: int,
                    planes: int = CURTAIN_PLANES) -> tuple[list[tuple[np.ndarray, Polygon]], dict]:
    """Vertical planar regions inside the space each open part of the input seals.

    Parameters
    ----------
    vertices : (v, 3) float64
    faces : (f, 3) int64
    up : int
        The up axis, 0-2.
    planes : int, optional
        Vertical planes per horizontal axis and part (default :data:`CURTAIN_PLANES`).

    Returns
    -------
    regions : list of (frame, polygon)
        ``frame`` (4, 3): origin, u, v, n of the plane (u x v = n, v the up
        axis); ``polygon``: the sealed space in that plane, in (u, v)
        coordinates from the origin (exact up to float64 rounding of the
        plane-triangle intersections).
    info : dict
        ``parts`` (open parts with curtains), ``bases`` (their base heights),
        ``layered`` (open parts refused: more than one layer along the up axis).
    """
    up = int(up)
    others = [a for a in range(3) if a != up]
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    footprint = float(np.prod(hi[others] - lo[others]))
    parts, merged_v, merged_f = _open_parts(vertices, faces)
    regions: list[tuple[np.ndarray, Polygon]] = []
    bases = []
    layered = 0
    for part_faces, rim in parts:
        tri = merged_v[merged_f[part_faces]]
        plo, phi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
        if np.prod(phi[others] - plo[others]) < MIN_FOOTPRINT * footprint:
            continue
        base = float(rim[:, up].max())
        if base >= phi[up]:
            continue  # the rim is as high as the surface: nothing sealed
        if not _one_layer(tri, others):
            layered += 1  # a fold or overhang: the space under it is open at the side
            continue
        part = trimesh.Trimesh(merged_v, merged_f[part_faces], process=False)
        top = float(phi[up]) + 1.0 + (phi[up] - base)
        made = 0
        for cut in others:
            along = [a for a in others if a != cut][0]
            n = np.zeros(3)
            n[cut] = 1.0
            u = np.zeros(3)
            u[along] = 1.0
            v = np.zeros(3)
            v[up] = 1.0
            if np.cross(u, v) @ n < 0:
                n = -n
            span = phi[cut] - plo[cut]
            for k in range(planes):
                at = plo[cut] + span * (k + 0.5) / planes
                origin = np.zeros(3)
                origin[cut] = at
                segs = trimesh.intersections.mesh_plane(part, n, origin)
                if len(segs) == 0:
                    continue
                s = segs[:, :, along]
                t = segs[:, :, up]
                region = _sealed(s, t, base, top)
                if region is not None:
                    regions.append((np.stack([origin, u, v, n]), region))
                    made += 1
        # horizontal cuts: where the part's every layer lies above the height
        n = np.zeros(3)
        n[up] = 1.0
        u = np.zeros(3)
        u[others[0]] = 1.0
        v = np.cross(n, u)
        for k in range(planes):
            at = base + (phi[up] - base) * (k + 0.5) / planes
            origin = np.zeros(3)
            origin[up] = at
            region = _above(tri, at, up, u, v)
            if region is not None:
                regions.append((np.stack([origin, u, v, n]), region))
                made += 1
        if made:
            bases.append(base)
    return regions, {"parts": len(bases), "bases": bases, "layered": layered}


def _one_layer(tri: np.ndarray, others: list[int]) -> bool:
    """Whether the triangles' projections across the up axis overlap nowhere (a height field).

    Exact up to :data:`LAYER_OVERLAP`: the projected areas of the non-vertical
    triangles sum to the area of their union. Vertical triangles project to
    nothing and are not counted (cliffs and skirts seal the space beside them).
    """
    xy = tri[:, :, others]
    polys = shapely.polygons(xy)
    area = shapely.area(polys)
    flat = area > 0
    if not flat.any():
        return False
    total = float(area[flat].sum())
    union = float(shapely.union_all(polys[flat]).area)
    return total - union <= LAYER_OVERLAP * total


def _clip(tri: np.ndarray, height: np.ndarray, keep_above: bool) -> list[np.ndarray]:
    """The part of each triangle above (or below) height 0, as a polygon per triangle."""
    out = []
    for t, h in zip(tri, height, strict=True):
        pts = []
        for i in range(3):
            a, b = t[i], t[(i + 1) % 3]
            ha, hb = h[i], h[(i + 1) % 3]
            if (ha >= 0) == keep_above:
                pts.append(a)
            if (ha >= 0) != (hb >= 0):
                pts.append(a + (b - a) * (ha / (ha - hb)))
        if len(pts) >= 3:
            out.append(np.asarray(pts))
    return out


def _above(tri: np.ndarray, at: float, up: int, u: np.ndarray, v: np.ndarray
           ) -> Polygon | None:
    """In the horizontal plane at height ``at``: where every layer of the part lies above.

    The union of the part's triangles clipped to their part at or above ``at``,
    projected along the up axis, minus the union of their parts below it.
    """
    h = tri[:, :, up] - at
    above_all, below_all = (h >= 0).all(axis=1), (h < 0).all(axis=1)
    cross = ~above_all & ~below_all

    def flat(polys: list[np.ndarray]):
        if not polys:
            return shapely.Polygon()
        geoms = [shapely.Polygon(np.stack([p @ u, p @ v], axis=1)) for p in polys]
        return shapely.union_all([g for g in geoms if g.is_valid and g.area > 0])

    def whole(sel):
        if not sel.any():
            return shapely.Polygon()
        xy = np.stack([tri[sel] @ u, tri[sel] @ v], axis=2)
        polys = shapely.polygons(xy)
        return shapely.union_all(polys[shapely.area(polys) > 0])

    up_part = shapely.union(whole(above_all), flat(_clip(tri[cross], h[cross], True)))
    down_part = shapely.union(whole(below_all), flat(_clip(tri[cross], h[cross], False)))
    region = shapely.difference(up_part, down_part)
    if region.is_empty or region.area <= 0:
        return None
    return region


def _sealed(s: np.ndarray, t: np.ndarray, base: float, top: float) -> Polygon | None:
    """In one plane: the columns the segments cover, from ``base`` up to the lowest segment."""
    s0, s1 = s.min(axis=1), s.max(axis=1)
    wide = s1 > s0
    if not wide.any():
        return None
    covered = shapely.union_all(shapely.box(s0[wide], base, s1[wide], top))
    quads = np.stack([np.stack([s[:, 0], t[:, 0]], axis=1), np.stack([s[:, 1], t[:, 1]], axis=1),
                      np.stack([s[:, 1], np.full(len(s), top + 1.0)], axis=1),
                      np.stack([s[:, 0], np.full(len(s), top + 1.0)], axis=1)], axis=1)
    above = shapely.polygons(quads[wide])
    above = above[shapely.area(above) > 0]
    # vertical segments, and the areas above them, have no width: the sloped ones beside
    # them bound the region
    region = shapely.difference(covered, shapely.union_all(above))
    region = shapely.intersection(region, shapely.box(s0.min() - 1.0, base, s1.max() + 1.0,
                                                      top))
    if region.is_empty or region.area <= 0:
        return None
    return region
