"""Occludee bounds tighter than one box: each object's triangles split into clusters.

A runtime tests an object through its bounding volume (Papaioannou et al. 2006
[1]_, sec. 4); a big object is tested through the boxes of its clusters instead.

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006 (Plzen), UNION Agency,
   ISBN 80-86943-03-8 (sec. 4).
"""

from __future__ import annotations

import heapq
import itertools
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from .._validate import InputError, as_fraction, as_positive_int

if TYPE_CHECKING:  # pragma: no cover - hints only
    from ..level.scene_graph import SceneObjects

__all__ = ["cluster_boxes", "object_cluster_boxes", "object_triangles", "occludee_boxes",
           "parse_bounds",
           "MAX_CLUSTERS", "DEFAULT_CLUSTERS", "AUTO_MIN_SIZE", "MESHLET_TRIANGLES",
           "DEFAULT_BOUNDS"]

#: Clusters per object of ``--bounds clusters`` and ``auto`` without a count.
DEFAULT_CLUSTERS = 64

#: ``--bounds auto``: objects from this fraction of the level's diagonal are tested
#: through their clusters (chunks of the level), smaller ones through their box.
AUTO_MIN_SIZE = 0.1

#: Most clusters per object (a box test per cluster and frame).
MAX_CLUSTERS = 4096

#: Triangles per cluster of ``--bounds meshlets`` without a count.
MESHLET_TRIANGLES = 16

#: ``cull --bounds`` and ``bench walks --bounds`` by default: every object through its own
#: triangles, pixel by pixel in the depth buffer (:func:`object_triangles`;
#: :meth:`~viscore.culling.depth_buffer.ConservativeDepthBuffer.occluded_triangles`), the
#: other runtimes through their boxes (``meshlets:1`` without its cap). Measured along the
#: 20-frame walks of 34 game levels (seed 0, docs/culling.md): best guaranteed / hidden
#: never lower than with ``meshlets:1`` and 0.73 against 0.69 on average over the 27 levels
#: hiding over 20% (kyan-deathmatch 0.21 to 0.64, enari-collision-world 0.67 to 0.83), 0
#: false culls; the same cost (farm-bench, whole process, CPU triangles / meshlets:1 0.99
#: on pizza-tower-3d-level1 over 3 paired runs, 0.93 on quake-e1m1 over 1).
#:
#: ``meshlets:1``, the default before: every object through the
#: boxes of its triangles (clusters of about one triangle, at most :data:`MAX_CLUSTERS`
#: per object). The finest split of the greedy k-d tree, it refines ``box``, ``auto`` and
#: ``clusters`` (each of its boxes lies in one of theirs, and a smaller box is no harder to
#: cull), as conservatively as one box. Measured along 20-frame walks (seed 0; the objects
#: the truth hides among those whose box is in view, removed by the view frustum or culled
#: by the best guaranteed runtime, 0 false culls each): kyan-deathmatch 3/21 with ``box``,
#: 7/21 ``auto``, 5/21 ``meshlets:16``, 10/21 ``meshlets:1``; enari-collision-world 11/18,
#: 11/18, 11/18, 12/18; the same per-frame overhead (28-44 ms) on both.
DEFAULT_BOUNDS = "triangles"


def cluster_boxes(vertices: npt.ArrayLike, faces: npt.ArrayLike, clusters: int
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Boxes of at most ``clusters`` groups of a mesh's triangles, which together hold it.

    Parameters
    ----------
    vertices : (v, 3) float
    faces : (f, 3) int
    clusters : int
        Most groups (1: the mesh's own box).

    Returns
    -------
    lower, upper : (k, 3) float64
        Each group's box, ``1 <= k <= clusters`` (``k = 0`` for a mesh without
        faces). Every triangle lies inside the box of its group.

    Notes
    -----
    Greedy k-d split: while fewer than ``clusters`` groups exist, the group
    whose triangle centroids span the longest extent is split at the median
    centroid along that extent's axis. Groups of one triangle, or of
    centroids at one point, are not split. With ``clusters`` at least the
    mesh's triangles, every triangle is its own group (the split's end, at once).

    Examples
    --------
    >>> v = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [9, 0, 0], [10, 0, 0], [9, 1, 0]]
    >>> lo, hi = cluster_boxes(v, [[0, 1, 2], [3, 4, 5]], 2)
    >>> sorted(lo[:, 0].tolist()), sorted(hi[:, 0].tolist())
    ([0.0, 9.0], [1.0, 10.0])
    """
    clusters = as_positive_int(clusters, "clusters", maximum=MAX_CLUSTERS)
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(f) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3))
    tri = v[f]
    lo_t, hi_t = tri.min(axis=1), tri.max(axis=1)
    if clusters >= len(f):  # the finest split: every triangle its own box
        return lo_t, hi_t
    centre = tri.mean(axis=1)

    made = itertools.count()  # ties split in the order made: the same boxes every run

    def entry(group: np.ndarray) -> tuple:
        span = np.ptp(centre[group], axis=0) if len(group) > 1 else np.zeros(3)
        return (-float(span.max()), next(made), group, int(np.argmax(span)))

    heap = [entry(np.arange(len(f)))]
    done: list = []
    while heap and len(heap) + len(done) < clusters:
        neg, _, group, axis = heapq.heappop(heap)
        if neg == 0.0:
            done.append(group)
            continue
        order = group[np.argsort(centre[group, axis], kind="stable")]
        half = len(order) // 2
        for part in (order[:half], order[half:]):
            heapq.heappush(heap, entry(part))
    groups = done + [item[2] for item in heap]
    lower = np.array([lo_t[g].min(axis=0) for g in groups])
    upper = np.array([hi_t[g].max(axis=0) for g in groups])
    return lower, upper


def object_cluster_boxes(objects: SceneObjects, clusters: int, *,
                         min_size: float | None = None, per_cluster: int | None = None
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World boxes of every object's triangle clusters (:func:`cluster_boxes`).

    Parameters
    ----------
    objects : SceneObjects
    clusters : int
        Most clusters per object.
    min_size : float, optional
        Only objects whose bounding-box diagonal is at least this fraction of the
        level's (the box of its built part,
        :meth:`~viscore.level.SceneObjects.built_bounds`) are split; the others keep their own
        box as their one cluster. In (0, 1]; default: every object is split.
    per_cluster : int, optional
        Meshlets: each mesh of ``f`` triangles is split into ``ceil(f / per_cluster)``
        clusters (about ``per_cluster`` triangles each), at most ``clusters``.
        Default: ``clusters`` for every mesh.

    Returns
    -------
    lower, upper : (c, 3) float64
        World-space cluster boxes, grouped by object in object order: each
        local box's eight corners through the object's transform, boxed again
        (exact for translations and axis permutations, larger under other
        rotations) and cut to the object's own box, so that no cluster box
        reaches beyond it.
    owner : (c,) int64
        Object of each cluster, non-decreasing; every object with triangles
        has at least one.

    Raises
    ------
    InputError
        ``clusters`` not an integer in [1, :data:`MAX_CLUSTERS`].
    """
    clusters = as_positive_int(clusters, "clusters", maximum=MAX_CLUSTERS)
    split = np.ones(len(objects.mesh_ids), dtype=bool)
    if min_size is not None:
        min_size = as_fraction(min_size, "min_size", open_low=True)
        box = objects.built_bounds()[0]  # without an outer ground plane or a sky
        level = float(np.linalg.norm(box[1] - box[0]))
        split = np.linalg.norm(objects.upper - objects.lower, axis=1) >= min_size * level
    if per_cluster is not None:
        per_cluster = as_positive_int(per_cluster, "per_cluster")
    wanted = set(objects.mesh_ids[split].tolist())

    def count(mesh) -> int:
        if per_cluster is None:
            return clusters
        return int(min(clusters, max(1, -(-len(mesh.faces) // per_cluster))))

    local = [cluster_boxes(m.vertices, m.faces, count(m) if i in wanted else 1)
             for i, m in enumerate(objects.meshes)]
    corner = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], dtype=bool)
    lowers, uppers, owners = [], [], []
    for i, mesh_id in enumerate(objects.mesh_ids):
        lo, hi = local[int(mesh_id)]
        if len(lo) == 0:
            continue
        if not split[i]:  # its own box, as exact as the unsplit test
            lo, hi = lo.min(axis=0, keepdims=True), hi.max(axis=0, keepdims=True)
        pts = np.where(corner[None], hi[:, None, :], lo[:, None, :])  # (k, 8, 3)
        m = objects.transforms[i]
        world = pts @ m[:3, :3].T + m[:3, 3]
        # a rotated box's box can stick out of the object's own: the part outside holds
        # none of the cluster's triangles
        lowers.append(np.maximum(world.min(axis=1), objects.lower[i]))
        uppers.append(np.minimum(world.max(axis=1), objects.upper[i]))
        owners.append(np.full(len(lo), i, dtype=np.int64))
    if not owners:
        raise InputError(f"{objects.source}: no object has triangles")
    return np.concatenate(lowers), np.concatenate(uppers), np.concatenate(owners)


def object_triangles(objects: SceneObjects
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every object's own triangles in world units, with their boxes (``--bounds triangles``).

    Parameters
    ----------
    objects : SceneObjects

    Returns
    -------
    lower, upper : (m, 3) float64
        Each triangle's box, world units.
    owner : (m,) int64
        Object of each triangle, non-decreasing.
    triangles : (m, 3, 3) float64
        The triangles through their object's transform, world units.

    Raises
    ------
    InputError
        No object has triangles.

    Notes
    -----
    A runtime that can test triangles (a depth buffer,
    :meth:`~viscore.culling.depth_buffer.ConservativeDepthBuffer.occluded_triangles`)
    tests them pixel by pixel; the others test their boxes, the finest split of
    :func:`object_cluster_boxes` without its cap of :data:`MAX_CLUSTERS` per object.
    """
    tris, owners = [], []
    for i, mesh_id in enumerate(objects.mesh_ids):  # a loop over objects
        mesh = objects.meshes[int(mesh_id)]
        f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
        if len(f) == 0:
            continue
        m = objects.transforms[i]
        v = np.asarray(mesh.vertices, dtype=np.float64) @ m[:3, :3].T + m[:3, 3]
        tris.append(v[f])
        owners.append(np.full(len(f), i, dtype=np.int64))
    if not owners:
        raise InputError(f"{objects.source}: no object has triangles")
    tri = np.concatenate(tris)
    return tri.min(axis=1), tri.max(axis=1), np.concatenate(owners), tri


def occludee_boxes(objects: SceneObjects, kind: str, clusters: int
                   ) -> tuple[tuple | None, str, int]:
    """The occludee bounds of ``cull --bounds KIND:CLUSTERS``.

    Returns None (every object tested through its box) or
    :func:`object_cluster_boxes` (``kind='auto'``: only the objects from
    :data:`AUTO_MIN_SIZE` of the level's diagonal split; ``kind='meshlets'``: every
    object in clusters of about ``clusters`` triangles), for
    ``simulate_culling(..., bounds=)``; with the kind in effect (``'box'``
    when no object was split) and the number of split objects. ``kind='triangles'``
    gives :func:`object_triangles` (the boxes, owners and triangles themselves).
    """
    if kind == "triangles":
        bounds = object_triangles(objects)
        split = int(np.count_nonzero(np.bincount(bounds[2]) > 1))
        return bounds, kind, split
    if kind == "meshlets":  # every object, in clusters of about ``clusters`` triangles
        bounds = object_cluster_boxes(objects, MAX_CLUSTERS, per_cluster=clusters)
    else:
        bounds = None if clusters == 1 else object_cluster_boxes(
            objects, clusters, min_size=AUTO_MIN_SIZE if kind == "auto" else None)
    split = 0 if bounds is None else int(np.count_nonzero(np.bincount(bounds[2]) > 1))
    if bounds is None or not split:
        return None, "box", 0  # no object was split: every test is the box
    return bounds, kind, split


def parse_bounds(text: str, option: str = "--bounds") -> tuple[str, int]:
    """The kind (``box``, ``clusters``, ``auto``, ``meshlets``, ``triangles``) and its count.

    ``box``, ``triangles`` (count 1), ``clusters``, ``auto``, ``meshlets``, ``clusters:N``,
    ``auto:N`` or
    ``meshlets:T`` (N clusters per object, default :data:`DEFAULT_CLUSTERS`; T
    triangles per cluster, default :data:`MESHLET_TRIANGLES`; from 1 to
    :data:`MAX_CLUSTERS`), as ``viscore cull --bounds`` takes it (default
    :data:`DEFAULT_BOUNDS`); for :func:`occludee_boxes`.

    Raises
    ------
    InputError
        Any other text, named by ``option``.

    Examples
    --------
    >>> parse_bounds("clusters:8"), parse_bounds("box")
    (('clusters', 8), ('box', 1))
    """
    kind, _, count = str(text).strip().partition(":")
    if kind in ("box", "triangles") and not count:
        return kind, 1
    if kind in ("clusters", "auto", "meshlets"):
        if not count:
            return kind, DEFAULT_CLUSTERS if kind != "meshlets" else MESHLET_TRIANGLES
        if count.isascii() and count.isdigit():  # not '+3', '1_000' nor other scripts' digits
            return kind, as_positive_int(int(count), f"{option} {kind}:N",
                                         maximum=MAX_CLUSTERS)
    raise InputError(f"{option}: expected auto, box, clusters, meshlets, triangles, auto:N, "
                     f"clusters:N or meshlets:N (N from 1 to {MAX_CLUSTERS}), got {text!r}")
