"""Surface patches, the sheets: curved open surfaces offered as the input's own triangles.

Valued per triangle by occlusion measure, as the selection of Silvennoinen et al.
[1]_, sec. 4.5, values candidates.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (secs. 3 and 4.5)
"""

from __future__ import annotations

import numpy as np

__all__ = ["sheet_chunks", "chunk_measure", "SHEET_CHUNK", "SHEET_MAX_FACES", "MAX_PLANAR_SHARE",
           "LARGE_REGION"]

#: Triangles per chunk of a sheet, about: the selection's unit. Smaller chunks fit a
#: small budget more closely; each is one more candidate to value and select.
SHEET_CHUNK = 64

#: Open faces beyond which no sheet is looked for: finding the sheets costs shapely
#: unions of their triangles (5.6 s for a 69,451-triangle scan), and at that density a
#: chunk of :data:`SHEET_CHUNK` triangles covers almost nothing of the surface.
SHEET_MAX_FACES = 100_000

#: Largest share of a height-field patch's area in large planar regions (each at least
#: :data:`LARGE_REGION` of it) that give patch candidates, for it to be offered as a
#: sheet: a level built of brushes is full of small patches of a few planes each (a
#: block's top and its bevels), which those regions' pieces cover (offered as sheets
#: too, Sauerbraten's zdm2 culled 36.7% instead of 37.7%).
MAX_PLANAR_SHARE = 0.5

#: Share of a patch's area a planar region must reach to count against it (above).
LARGE_REGION = 0.1

#: Pixels along the longer side of a chunk's rasterization (its measure).
MEASURE_PIXELS = 64


def face_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(f,)`` area of each face.

    >>> face_areas(np.eye(3), [[0, 1, 2]]).round(4).tolist()
    [0.866]
    """
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]
    return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)


def sheet_chunks(vertices: np.ndarray, faces: np.ndarray, open_faces: np.ndarray, *,
                 region: np.ndarray | None = None, chunk: int = SHEET_CHUNK,
                 area: np.ndarray | None = None) -> list[list[np.ndarray]]:
    """The sheets among ``open_faces``, each as its chunks of face indices.

    Parameters
    ----------
    vertices : (v, 3) float
    faces : (f, 3) int
    open_faces : (k,) int
        The faces that may be offered (those not in a closed part).
    region : (f,) int, optional
        Per face, the planar region that gives it patch candidates (-1:
        none). A height-field patch is not offered when more than
        :data:`MAX_PLANAR_SHARE` of its area lies in regions each at least
        :data:`LARGE_REGION` of its area (a block's top and its bevels; not a
        curved surface of many small planar quads), and the faces of a region
        are never offered outside a patch.
    chunk : int, optional
        Triangles per chunk, about (default :data:`SHEET_CHUNK`).
    area : (f,) float, optional
        Each face's area, when the caller has it (default: computed here).

    Returns
    -------
    list of list of (m_i,) int64
        Per sheet, the face indices of each chunk, each edge-connected,
        sorted, in row-major order of their cells. The height-field patches
        come first, in the order :func:`viscore.culling._creases.height_field_patches`
        numbers them; then the edge-connected sets of two or more of the faces
        in none (steep strips, a fold's triangles) and in no ``region``, each a
        sheet.

    Examples
    --------
    >>> xs, ys = np.meshgrid(np.arange(9.0), np.arange(9.0))
    >>> v = np.stack([xs.ravel(), ys.ravel(), np.sin(xs.ravel()) + ys.ravel() ** 2 / 9], 1)
    >>> q = (np.arange(8)[:, None] * 9 + np.arange(8)[None, :]).ravel()
    >>> f = np.concatenate([np.stack([q, q + 1, q + 10], 1), np.stack([q, q + 10, q + 9], 1)])
    >>> sheets = sheet_chunks(v, f, np.arange(len(f)), chunk=32)
    >>> chunks = [c for sheet in sheets for c in sheet]
    >>> sorted(np.concatenate(chunks).tolist()) == list(range(128)), len(chunks) > 2
    (True, True)
    """
    from viscore.culling._creases import height_field_patches

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    open_faces = np.asarray(open_faces, dtype=np.int64)
    if len(open_faces) == 0:
        return []
    region = np.full(len(f), -1, np.int64) if region is None else np.asarray(region, np.int64)
    area = face_areas(v, f) if area is None else np.asarray(area, dtype=np.float64)
    planar = region >= 0
    region_area = np.bincount(region[planar], weights=area[planar],
                              minlength=int(region.max()) + 1 if planar.any() else 0)
    patch, _ = height_field_patches(v, f[open_faces])
    out = []
    for p in range(int(patch.max()) + 1):
        members = open_faces[patch == p]
        total = area[members].sum()
        own = members[planar[members]]
        large = own[region_area[region[own]] >= LARGE_REGION * total]
        # mostly a few large planes (a brush's top and its bevels): their pieces cover it
        if area[large].sum() <= MAX_PLANAR_SHARE * total:
            out.append(_cut(v, f, members, chunk))
    rest = open_faces[patch < 0]
    rest = rest[~planar[rest]]
    if len(rest):  # a lone facet (one triangle alone in its plane) is no sheet
        out += [_cut(v, f, part, chunk) for part in _connected(f, rest) if len(part) >= 2]
    return out


def _cut(v: np.ndarray, f: np.ndarray, members: np.ndarray, chunk: int) -> list[np.ndarray]:
    """One sheet's faces ``members`` cut into edge-connected cells of about ``chunk``."""
    tri = v[f[members]]
    normal, u, w = _frame(tri)
    centre = tri.mean(axis=1)
    xy = np.stack([centre @ u, centre @ w], axis=1)
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    projected = 0.5 * np.abs(cross @ normal).sum()
    cells = max(1.0, len(members) / max(int(chunk), 1))
    side = np.sqrt(max(projected, 1e-300) / cells)
    cell = np.floor((xy - xy.min(axis=0)) / side).astype(np.int64)
    key = cell[:, 0] * (int(cell[:, 1].max()) + 1) + cell[:, 1]
    out = []
    for k in np.unique(key):
        out += _connected(f, members[key == k])
    return out


def _connected(f: np.ndarray, members: np.ndarray) -> list[np.ndarray]:
    """``members`` split into sets connected through edges (vertex indices) they share."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(members)
    if n == 1:
        return [members]
    e = np.sort(f[members][:, [0, 1, 1, 2, 2, 0]].reshape(-1, 3, 2), axis=2).reshape(-1, 2)
    owner = np.repeat(np.arange(n), 3)
    _, inverse = np.unique(e, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    order = np.argsort(inverse, kind="stable")
    same = inverse[order][1:] == inverse[order][:-1]
    a, b = owner[order][:-1][same], owner[order][1:][same]
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    k, label = connected_components(graph, directed=False)
    return [np.sort(members[label == c]) for c in range(k)]


def _frame(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The area-weighted mean unit normal of triangles ``(k, 3, 3)`` (either sign) and two
    unit axes across it."""
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    total = cross.sum(axis=0)
    size = np.linalg.norm(total)
    if size <= 0:  # folded onto itself: the largest triangle's normal
        total = cross[int(np.argmax(np.linalg.norm(cross, axis=1)))]
        size = max(np.linalg.norm(total), 1e-300)
    normal = total / size
    helper = np.eye(3)[int(np.argmin(np.abs(normal)))]
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    return normal, u, np.cross(normal, u)


def chunk_measure(tri: np.ndarray) -> float:
    """Occlusion measure (units^3) of triangles ``(k, 3, 3)`` seen along their mean normal.

    The triangles' projections are filled into one image of about
    :data:`MEASURE_PIXELS` pixels along its longer side and measured with
    :func:`viscore.metrics.directional_occlusion_measure` (Silvennoinen et
    al. [1]_, sec. 3, eq. 1).

    Examples
    --------
    >>> square = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0]], [[0, 0, 0], [1, 1, 0], [0, 1, 0]]])
    >>> round(chunk_measure(square.astype(float)), 2)    # 1/6 for the unit square
    0.17
    """
    from skimage.draw import polygon as fill

    from viscore.metrics import directional_occlusion_measure

    tri = np.asarray(tri, dtype=np.float64)
    _, u, w = _frame(tri)
    xy = np.stack([tri @ u, tri @ w], axis=2)  # (k, 3, 2)
    lo = xy.reshape(-1, 2).min(axis=0)
    size = np.maximum(xy.reshape(-1, 2).max(axis=0) - lo, 1e-300)
    pixel = float(size.max()) / MEASURE_PIXELS
    shape = (int(np.ceil(size[1] / pixel)) + 2, int(np.ceil(size[0] / pixel)) + 2)
    img = np.zeros(shape, dtype=bool)
    for t in xy:
        rr, cc = fill((t[:, 1] - lo[1]) / pixel + 0.5, (t[:, 0] - lo[0]) / pixel + 0.5, shape)
        img[rr, cc] = True
    if not img.any():
        return 0.0
    return float(directional_occlusion_measure(img, pixel)[0])
