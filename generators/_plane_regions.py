"""The input's faces grouped by plane, across loose parts.

After the planar-patch grouping of Wu et al. 2022 [1]_ (sec. 3.1.1, step 1),
joined by plane across loose parts.

Shared by the surface-patches generator (its step 1) and the hybrid
generator's planar patches (a panelled wall becomes one patch, so that its
openings and recesses are holes the hole test can judge).

References
----------
.. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (sec. 3.1.1)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from viscore.constants import DEGENERATE_AREA_RELATIVE

__all__ = ["PlaneRegion", "plane_regions", "NORMAL_ANGLE"]

#: Largest angle (radians) between a face's normal and its region's, either sign:
#: the planar threshold of Wu et al. 2022, sec. 3.1.1. It keeps slivers that lie in
#: the slab but stand across it out of a region; the slab test alone decides the
#: guarantee.
NORMAL_ANGLE = 1e-3


@dataclass(frozen=True, eq=False)
class PlaneRegion:
    """The faces of one plane and the plane's frame.

    Attributes
    ----------
    faces : (k,) int64
        Indices of the input faces in the region.
    origin : (3,) float64
        The seed face's first vertex, world units.
    normal : (3,) float64
        The seed face's unit normal.
    area : float
        Sum of the faces' areas, world units^2 (overlaps counted twice).
    """

    faces: np.ndarray
    origin: np.ndarray
    normal: np.ndarray
    area: float

    @property
    def frame(self) -> np.ndarray:
        """``(4, 3)`` origin, in-plane unit axes u and v, normal n (u x v = n); an
        axis-aligned normal gives axis-aligned u and v exactly."""
        n = self.normal
        helper = np.eye(3)[int(np.argmin(np.abs(n)))]
        u = np.cross(n, helper)
        u /= np.linalg.norm(u)
        v = np.cross(n, u)
        return np.stack([self.origin, u, v, n])


def plane_regions(vertices: np.ndarray, faces: np.ndarray, *, tolerance: float,
                  both_sides: bool = True) -> list[PlaneRegion]:
    """Group faces by plane within ``tolerance`` (world units), largest region seed first.

    Parameters
    ----------
    vertices : (v, 3) float64
    faces : (f, 3) int64
    tolerance : float
        Largest distance, world units, of a region face's vertex from the
        region's plane.
    both_sides : bool, optional
        True (default): both orientations of a plane are one plane; False:
        a face joins only faces that face its way (a slab's top and the
        bottoms of the walls standing on it stay apart).

    Returns
    -------
    list of PlaneRegion
        In order of their seed faces (largest first). Degenerate faces (area
        below :data:`viscore.constants.DEGENERATE_AREA_RELATIVE` x diagonal^2)
        belong to none; every other face to exactly one (a face alone in its
        plane is a region of one face: curved surfaces give such regions).
    """
    from scipy.spatial import cKDTree

    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    twice = np.linalg.norm(cross, axis=1)
    diag = float(np.linalg.norm(np.ptp(vertices, axis=0))) if len(vertices) else 0.0
    good = twice > 2 * DEGENERATE_AREA_RELATIVE * diag * diag
    idx = np.flatnonzero(good)
    if len(idx) == 0 or diag == 0:
        return []
    normals = cross[idx] / twice[idx, None]
    centre = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
    offsets = np.einsum("ij,ij->i", normals, tri[idx, 0] - centre)
    # a k-d tree over (n, offset / diag): a face of the seed's plane is within
    # NORMAL_ANGLE in n and (tolerance + NORMAL_ANGLE x diag) in offset
    points = np.concatenate([normals, offsets[:, None] / diag], axis=1)
    tree = cKDTree(points)
    radius = float(np.hypot(NORMAL_ANGLE, tolerance / diag + NORMAL_ANGLE)) * 1.01
    cos_max = np.cos(NORMAL_ANGLE)
    order = np.argsort(-twice[idx], kind="stable")
    taken = np.zeros(len(idx), dtype=bool)
    # a seed's neighbours in plane space, both signs, asked for when it seeds a region:
    # asked for every face up front, the lists held sum(m^2) indices over planes of m
    # faces (3.6 GB on the city's joined buildings, 56 GB on the city tiled 2 x 2)
    regions = []
    for s in order:
        if taken[s]:
            continue
        n = normals[s]
        origin = tri[idx[s], 0]
        near = tree.query_ball_point(points[s], radius)
        if both_sides:
            near = near + tree.query_ball_point(-points[s], radius)
        cand = np.asarray(near, dtype=np.int64)
        cand = cand[~taken[cand]]
        if len(cand) > 1:
            dist = np.abs((tri[idx[cand]] - origin) @ n).max(axis=1)
            facing = normals[cand] @ n
            members = cand[((np.abs(facing) if both_sides else facing) >= cos_max)
                           & (dist <= tolerance)]
            members = np.sort(np.append(members[members != s], s))  # the seed joins always
        else:  # a face alone near its plane (curved surfaces, mostly)
            members = np.array([s], dtype=np.int64)
        taken[members] = True
        regions.append(PlaneRegion(faces=idx[members], origin=origin, normal=n,
                                   area=0.5 * float(twice[idx[members]].sum())))
    return regions
