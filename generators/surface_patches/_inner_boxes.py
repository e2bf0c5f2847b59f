"""Surface patches, the boxes: aabb-skins boxes inside the input's closed parts.

The boxes of the occluder-skins method (Leone et al. [1]_, sec. 4, with the
box filling of Naaji [2]_).

References
----------
.. [1] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
   Bursztyn, A. P. M. "Implementing software occlusion culling for real-time
   applications". XVIII Congreso Argentino de Ciencias de la Computacion
   (CACIC 2012), Workshop de Computacion Grafica, Imagenes y Visualizacion,
   2012. http://sedici.unlp.edu.ar/handle/10915/23640 (sec. 4, occluder skins)
.. [2] Naaji, K. "Automatic Occluder Generation". A Graphics Diary (blog),
   15 November 2019. http://karim.naaji.fr/automatic_occluder_geneneration.html
.. [3] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 3, the occlusion measure)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import trimesh

__all__ = ["use_box_source", "closed_parts", "candidate_boxes", "unshadowed_measures",
           "box_faces", "TRIANGLES_PER_BOX"]

#: Triangles of one box occluder (two per face).
TRIANGLES_PER_BOX = 12

#: Voxels along the longest side of the closed parts' bounding box given to the box
#: source: aabb-skins' extent-based default (Leone et al. 2012, sec. 4, voxelize the
#: object's box). Finer grids for walls thinner than a voxel are not needed here: thin
#: flat walls are the patches' job, the boxes are for thick, curved parts.
BOX_VOXELS = 64

#: Pixels along the longer side of a box face's rasterization (its measure), as the
#: patches' stages are rasterized.
FACE_PIXELS = 64

#: Fewest pixels across the shorter side of that rasterization (thin faces).
FACE_MIN_ACROSS = 6

#: Largest pixel count along a side of that rasterization.
FACE_MAX_PIXELS = 512

#: The box source, aabb-skins (:func:`viscore.generators.aabb_skins.generate_aabb_skins`),
#: set by :mod:`viscore.generators.registry` (:func:`use_box_source`): aabb-skins is a
#: family of its own and this module does not import it.
_BOX_SOURCE: dict = {}


def use_box_source(generate: Callable) -> None:
    """Set the generator of the candidate boxes (called by the registry).

    ``generate(mesh, *, voxels=n, max_boxes=k) -> Occluder`` with
    ``parts["boxes"]`` ``(k, 2, 3)`` and ``info["conservative_guaranteed"]``
    and ``info["pitch"]``, as aabb-skins'.
    """
    _BOX_SOURCE["generate"] = generate


def box_source() -> Callable | None:
    """The registered box generator, or None before the registry set one."""
    return _BOX_SOURCE.get("generate")


def closed_parts(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(f,) bool``: the faces of the closed, consistently oriented connected parts.

    Vertices at equal positions are one (``-0.0`` and ``0.0`` too); parts are
    connected through shared vertices. A part is closed when each of its
    edges between two distinct positions is used as often from a to b as
    from b to a (edges of a degenerate triangle from a vertex to itself are
    left out, as :func:`viscore.voxel.winding.is_closed_oriented` leaves them); a
    part with no such edge is not.

    Examples
    --------
    >>> box = trimesh.creation.box()
    >>> sheet = trimesh.Trimesh([[3, 0, 0], [4, 0, 0], [3, 1, 0]], [[0, 1, 2]])
    >>> both = trimesh.util.concatenate([box, sheet])
    >>> int(closed_parts(both.vertices, both.faces).sum())
    12
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) == 0:
        return np.zeros(0, dtype=bool)
    v = np.asarray(vertices, dtype=np.float64) + 0.0  # -0.0 + 0.0 is 0.0
    _, ids = np.unique(v, axis=0, return_inverse=True)
    f = ids.reshape(-1)[faces]
    n = int(f.max()) + 1
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]]])
    graph = coo_matrix((np.ones(len(edges), dtype=np.int8), (edges[:, 0], edges[:, 1])),
                       shape=(n, n))
    _, label = connected_components(graph, directed=False)
    part = label[f[:, 0]]
    a = f.reshape(-1)
    b = f[:, [1, 2, 0]].reshape(-1)
    keep = a != b
    a, b = a[keep], b[keep]
    edge_part = np.repeat(part, 3)[keep]
    # signed use of each undirected edge: +1 from its lower vertex, -1 back; closed and
    # oriented is a zero sum on every edge
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key, inverse = np.unique(lo * n + hi, return_inverse=True)
    balance = np.zeros(len(key), dtype=np.int64)
    np.add.at(balance, inverse.reshape(-1), np.where(a < b, 1, -1))
    parts = int(part.max()) + 1
    has_edge = np.bincount(edge_part, minlength=parts) > 0
    open_edge = np.zeros(len(key), dtype=bool)
    open_edge[balance != 0] = True
    broken = np.zeros(parts, dtype=bool)
    broken[edge_part[open_edge[inverse.reshape(-1)]]] = True
    return (has_edge & ~broken)[part]


def candidate_boxes(vertices: np.ndarray, faces: np.ndarray, closed: np.ndarray, *,
                    max_boxes: int | None) -> tuple[np.ndarray, dict]:
    """The box source's boxes inside the union of the closed parts.

    Returns
    -------
    corners : (k, 2, 3) float64
        Lower and upper corners, world units.
    info : dict
        The source's ``info`` (``conservative_guaranteed``, ``inside``,
        ``inner_voxels``, ``pitch``, ...), or ``{}`` when it was not run.
    """
    generate = box_source()
    if generate is None or not closed.any():
        return np.zeros((0, 2, 3)), {}
    used = np.unique(faces[closed])
    remap = np.full(len(vertices), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    solid = trimesh.Trimesh(np.asarray(vertices)[used], remap[faces[closed]], process=False)
    options = {} if max_boxes is None else {"max_boxes": int(max_boxes)}
    occ = generate(solid, voxels=BOX_VOXELS, **options)
    corners = np.asarray(occ.parts.get("boxes", np.zeros((0, 2, 3))), dtype=np.float64)
    return corners.reshape(-1, 2, 3), dict(occ.info)


def box_faces(corners: np.ndarray) -> list[np.ndarray]:
    """The six faces of each box as ``(4, 3)`` loops, counter-clockwise seen from outside."""
    loops = []
    for lo, hi in np.asarray(corners, dtype=np.float64):
        for axis in range(3):
            u, w = (axis + 1) % 3, (axis + 2) % 3
            for side, c in ((-1, lo[axis]), (1, hi[axis])):
                quad = np.empty((4, 3))
                quad[:, axis] = c
                uu = [lo[u], hi[u], hi[u], lo[u]]
                ww = [lo[w], lo[w], hi[w], hi[w]]
                if side < 0:
                    uu, ww = uu[::-1], ww[::-1]
                quad[:, u], quad[:, w] = uu, ww
                loops.append(quad)
    return loops


def _face_grid(size_u: float, size_w: float) -> tuple[float, int, int]:
    """Square pixel side and the pixel counts along u and w of one face's raster."""
    pixel = min(max(size_u, size_w) / FACE_PIXELS, min(size_u, size_w) / FACE_MIN_ACROSS)
    pixel = max(pixel, max(size_u, size_w) / FACE_MAX_PIXELS)
    return pixel, max(1, int(np.ceil(size_u / pixel))), max(1, int(np.ceil(size_w / pixel)))


def unshadowed_measures(corners: np.ndarray, shadow) -> np.ndarray:
    """``(k,) float64``: each box's summed head-on occlusion measure of its faces, world
    units^3, over the pixels whose ray out of the face along its normal misses ``shadow``.

    Parameters
    ----------
    corners : (k, 2, 3) float64
    shadow : viscore.Scene or None
        The patch candidates; None shadows nothing.

    Notes
    -----
    One face's raster has square pixels (:data:`FACE_PIXELS` along its longer
    side, at least :data:`FACE_MIN_ACROSS` across), pixel centres inside the
    face covered, and one pixel of margin; its value is
    :func:`viscore.metrics.directional_occlusion_measure` of the covered
    pixels that are not shadowed. One batched first-hit query for all faces.
    """
    from viscore.metrics import directional_occlusion_measure

    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 2, 3)
    values = np.zeros(len(corners))
    rasters, origins, directions = [], [], []
    for k, (lo, hi) in enumerate(corners):
        size = hi - lo
        for axis in range(3):
            u, w = (axis + 1) % 3, (axis + 2) % 3
            pixel, nu, nw = _face_grid(float(size[u]), float(size[w]))
            cu = lo[u] + (np.arange(nu) + 0.5) * pixel
            cw = lo[w] + (np.arange(nw) + 0.5) * pixel
            inside_u, inside_w = cu < hi[u], cw < hi[w]
            gu, gw = np.meshgrid(cu[inside_u], cw[inside_w], indexing="xy")
            for side, c in ((-1.0, lo[axis]), (1.0, hi[axis])):
                pts = np.empty((gu.size, 3))
                pts[:, axis], pts[:, u], pts[:, w] = c, gu.ravel(), gw.ravel()
                d = np.zeros(3)
                d[axis] = side
                rasters.append((k, pixel, nu, nw, inside_u, inside_w, len(pts)))
                origins.append(pts)
                directions.append(np.broadcast_to(d, pts.shape))
    if not rasters:
        return values
    o = np.concatenate(origins)
    if shadow is None or len(o) == 0:
        lit = np.ones(len(o), dtype=bool)
    else:
        t, _ = shadow.first_hit(o, np.concatenate(directions))
        lit = ~np.isfinite(t)
    start = 0
    for k, pixel, nu, nw, inside_u, inside_w, count in rasters:
        img = np.zeros((nw + 2, nu + 2), dtype=bool)
        cells = np.zeros((nw, nu), dtype=bool)
        block = lit[start:start + count].reshape(int(inside_w.sum()), int(inside_u.sum()))
        cells[np.ix_(inside_w, inside_u)] = block
        img[1:-1, 1:-1] = cells
        start += count
        if img.any():
            values[k] += float(directional_occlusion_measure(img, pixel)[0])
    return values
