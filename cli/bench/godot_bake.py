"""``viscore bench godot-bake``: our ``godot`` baseline against Godot's bake, triangle for triangle.

References
----------
.. [1] Godot Engine contributors. ``OccluderInstance3D::bake_scene``,
   ``_bake_node`` and ``_bake_surface``, scene/3d/occluder_instance_3d.cpp;
   ``SurfaceTool::strip_mesh_arrays``, scene/resources/surface_tool.cpp;
   Godot Engine 4, https://github.com/godotengine/godot
.. [2] Godot Engine contributors. Occlusion culling and mesh LOD demo,
   ``3d/occlusion_culling_mesh_lod``,
   https://github.com/godotengine/godot-demo-projects (MIT)
.. [3] Kapoulkine, A. "meshoptimizer", https://github.com/zeux/meshoptimizer
   (``meshopt_simplify``, used by both bakes)
"""

from __future__ import annotations

import os
import re
import time
from pathlib import Path

import numpy as np
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from viscore import InputError, load_mesh, load_occluder, load_scene_objects
from viscore._validate import as_positive_int, as_seed
from viscore.exchange.godot_text import text_sections, text_transform

from .models import MODELS_ENV

__all__ = ["bench_godot_bake", "bench_godot_bake_text", "scene_instances", "bake_blocks",
           "assign_instances", "crop_instance", "match_triangles", "surface_distance",
           "DEMO_FOLDER", "GODOT_DEFAULT_DISTANCE"]

#: The demo's folder inside the models folder.
DEMO_FOLDER = "godot-occlusion-demo"
#: ``OccluderInstance3D``'s default ``bake_simplification_distance`` (0.1 m,
#: scene/3d/occluder_instance_3d.h), used when the scene sets none.
GODOT_DEFAULT_DISTANCE = 0.1
#: Godot's default ``bake_mask`` (every layer).
GODOT_DEFAULT_MASK = 0xFFFFFFFF
#: Vertex tolerance of an exact triangle match and of "lies on", as a share of
#: the room's bounding-box diagonal.
TOLERANCE_SHARE = 1e-4
#: Growth of an instance's box, as a share of its diagonal, for the crops.
GROW = 0.01
#: Points sampled per occluder surface for the Hausdorff distance and overlaps.
SAMPLES = 20_000
#: Orbit views of the precision/recall evaluation.
VIEWS = 128
#: Distances of the bake-distance sweep (world units).
SWEEP = (0.01, 0.05, 0.1, 0.2, 0.5, 1.0)

_EXT_REF = re.compile(r'^ExtResource\(\s*"?([^")]*)"?\s*\)$')


def scene_instances(text: str, resource: str) -> dict:
    """Instances of one packed scene in a Godot 4 text scene, and its occluder nodes' settings.

    Parameters
    ----------
    text : str
        The ``.tscn`` text (``[node ...]`` sections whose ``parent`` paths
        start from the root, as Godot writes them).
    resource : str
        File name of the instanced scene (``room.glb``): nodes with
        ``instance=ExtResource(id)`` of an ``ext_resource`` whose path ends so.

    Returns
    -------
    dict
        ``names`` (list of str) and ``transforms`` ((n, 4, 4) float64, world
        transforms of the instances relative to the first
        ``OccluderInstance3D``, the frame its bake is in: Godot's ``_bake_node``
        uses ``get_global_transform().affine_inverse() *
        mi->get_global_transform()``); ``occluder`` (its node name,
        ``bake_mask`` and ``bake_simplification_distance``, None when unset)
        or None; ``mesh_nodes``: every ``MeshInstance3D`` section (name,
        parent, ``layers``, whether ``layers & bake_mask`` lets the bake take
        it).

    Raises
    ------
    InputError
        On a node whose parent is not in the file (a node inside an instanced
        scene placing children of its own is fine: ``Rooms/Room/RedSphere``),
        or a malformed transform.
    """
    sections = text_sections(text.encode("utf-8"), "scene")
    ext_ids = {attrs.get("id", "") for tag, attrs, _ in sections if tag == "ext_resource"
               and attrs.get("path", "").endswith(resource)}
    local: dict[str, np.ndarray] = {}
    parent_of: dict[str, str | None] = {}
    order = []
    for tag, attrs, body in sections:
        if tag != "node":
            continue
        name, parent = attrs.get("name", ""), attrs.get("parent")
        path = "." if parent is None else name if parent == "." else f"{parent}/{name}"
        value = body.get("transform")
        local[path] = np.eye(4) if value is None else text_transform(value, "scene", path)
        parent_of[path] = None if parent is None else parent
        order.append((path, attrs, body))
    world: dict[str, np.ndarray] = {}

    def world_of(path: str) -> np.ndarray:
        if path not in world:
            parent = parent_of.get(path)
            if path not in local:
                raise InputError(f"scene: node {path!r} is not in the file")
            world[path] = local[path] if parent is None else world_of(parent) @ local[path]
        return world[path]

    occluder, base = None, np.eye(4)
    for path, attrs, body in order:
        if attrs.get("type") == "OccluderInstance3D" and occluder is None:
            mask = body.get("bake_mask")
            dist = body.get("bake_simplification_distance")
            try:
                distance = None if dist is None else float(dist)
                if mask is not None and not mask.isdigit():
                    raise ValueError(mask)
            except ValueError:
                raise InputError(f"scene: node {path!r}: bake_mask {mask!r} or "
                                 f"bake_simplification_distance {dist!r} is not a number"
                                 ) from None
            occluder = {"name": attrs.get("name", ""),
                        "bake_mask": GODOT_DEFAULT_MASK if mask is None else int(mask),
                        "bake_mask_set": mask is not None,
                        "bake_simplification_distance": distance}
            base = np.linalg.inv(world_of(path))
    mask = GODOT_DEFAULT_MASK if occluder is None else occluder["bake_mask"]
    names, mats, mesh_nodes = [], [], []
    for path, attrs, body in order:
        ref = _EXT_REF.match(attrs.get("instance", ""))
        if ref and ref.group(1) in ext_ids:
            names.append(attrs.get("name", ""))
            mats.append(base @ world_of(path))
        if attrs.get("type") == "MeshInstance3D":
            layers = body.get("layers")
            if layers is not None and not layers.isdigit():
                raise InputError(f"scene: node {path!r}: layers {layers!r} is not a number")
            layers = 1 if layers is None else int(layers)
            mesh_nodes.append({"name": attrs.get("name", ""), "parent": attrs.get("parent"),
                               "layers": layers, "in_bake_mask": bool(layers & mask)})
    return {"names": names, "transforms": np.array(mats).reshape(-1, 4, 4),
            "occluder": occluder, "mesh_nodes": mesh_nodes}


def bake_blocks(faces: np.ndarray) -> np.ndarray:
    """Block id of each triangle of a bake: runs of triangles using a vertex range of their own.

    Godot's ``_bake_surface`` strips each surface's unused vertices, appends
    the rest to the occluder's vertex array and its triangles, offset by the
    vertices before them, to the index array, so surface k's triangles
    index only vertices after those of surfaces before k. A cut falls
    between triangles i-1 and i wherever every index before it is smaller
    than every index from it on. A surface whose parts happen to use disjoint
    ranges may split into several blocks; one block never spans two surfaces.

    Parameters
    ----------
    faces : (f, 3) int

    Returns
    -------
    (f,) int64
        0 for the first run, counting up.
    """
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(faces) == 0:
        return np.zeros(0, dtype=np.int64)
    before = np.maximum.accumulate(faces.max(axis=1))[:-1]
    after = np.minimum.accumulate(faces.min(axis=1)[::-1])[::-1][1:]
    return np.concatenate([[0], np.cumsum(before < after)]).astype(np.int64)


def _box_distance(points: np.ndarray, inverse: np.ndarray, lower: np.ndarray,
                  upper: np.ndarray, pad: float) -> np.ndarray:
    """(p, n) distance of world points to n instances' boxes grown by ``pad``.

    In units of the grown half-extents along each axis of the instance's frame
    (Chebyshev): at most 1 inside the grown box, 0 at its centre.
    """
    centre, half = (lower + upper) / 2, (upper - lower) / 2 + pad
    local = np.einsum("nij,pj->pni", inverse[:, :3, :3], points) + inverse[None, :, :3, 3]
    return (np.abs(local - centre) / half).max(axis=2)


def assign_instances(vertices: np.ndarray, faces: np.ndarray, transforms: np.ndarray,
                     lower: np.ndarray, upper: np.ndarray, *, grow: float = GROW,
                     chunk: int = 256) -> np.ndarray:
    """Instance of each bake triangle, by the surface block it belongs to.

    Each block of :func:`bake_blocks` goes to the instance whose local box
    ``[lower, upper]`` (brought to the world by the instance's transform) is
    nearest its vertices' mean (in units of the grown box's half-extents,
    Chebyshev), if every vertex of the block lies in that box grown by
    ``grow`` of its diagonal on every side. Triangles of a block that fails (one surface spanning
    instances) are assigned one by one, by centroid, the same way.

    Parameters
    ----------
    vertices : (v, 3) float
        The bake's vertices, in the occluder's frame.
    faces : (f, 3) int
    transforms : (n, 4, 4) float
        Instance-to-occluder-frame transforms (:func:`scene_instances`).
    lower, upper : (3,) float
        The instanced mesh's bounding box in its own frame.
    grow : float, optional
        Growth of the box, share of its diagonal (default :data:`GROW`).
    chunk : int, optional
        Instances per vectorised pass (memory: points x chunk x 3 floats).

    Returns
    -------
    (f,) int64
        Index into ``transforms``, or -1 where no instance's grown box holds
        the triangle's centroid.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    inverse = np.linalg.inv(np.asarray(transforms, dtype=np.float64))
    pad = max(grow * float(np.linalg.norm(upper - lower)), 1e-300)

    def nearest(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        best = np.full(len(points), np.inf)
        which = np.full(len(points), -1, dtype=np.int64)
        for s in range(0, len(inverse), chunk):
            d = _box_distance(points, inverse[s:s + chunk], lower, upper, pad)
            k = d.argmin(axis=1)
            dk = d[np.arange(len(points)), k]
            better = dk < best
            best[better], which[better] = dk[better], k[better] + s
        return which, best

    out = np.full(len(faces), -1, dtype=np.int64)
    if len(faces) == 0 or len(inverse) == 0:
        return out
    block = bake_blocks(faces)
    nblocks = int(block[-1]) + 1
    corner_block = np.repeat(block, 3)
    sums = np.zeros((nblocks, 3))
    np.add.at(sums, corner_block, vertices[faces.reshape(-1)])
    means = sums / np.bincount(corner_block, minlength=nblocks)[:, None]
    owner, _ = nearest(means)
    corners = vertices[faces.reshape(-1)]
    inv = inverse[owner[corner_block]]
    local = np.einsum("pij,pj->pi", inv[:, :3, :3], corners) + inv[:, :3, 3]
    centre, half = (lower + upper) / 2, (upper - lower) / 2 + pad
    inside_corner = (np.abs(local - centre) / half).max(axis=1) <= 1
    block_ok = np.ones(nblocks, dtype=bool)
    np.logical_and.at(block_ok, corner_block, inside_corner)
    ok = block_ok[block]
    out[ok] = owner[block[ok]]
    if not ok.all():
        rest = np.flatnonzero(~ok)
        which, best = nearest(vertices[faces[rest]].mean(axis=1))
        out[rest] = np.where(best <= 1, which, -1)
    return out


def crop_instance(vertices: np.ndarray, faces: np.ndarray, transform: np.ndarray,
                  lower: np.ndarray, upper: np.ndarray, *, grow: float = GROW
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bake triangles whose centroids fall in one instance's box, in the instance's frame.

    Parameters
    ----------
    vertices : (v, 3) float
        The bake's vertices (occluder frame).
    faces : (f, 3) int
    transform : (4, 4) float
        The instance's transform (instance frame to occluder frame).
    lower, upper : (3,) float
        The instanced mesh's box in its own frame, grown by ``grow`` of its
        diagonal on every side.

    Returns
    -------
    local_vertices : (m, 3) float64
        The referenced vertices, through the inverse transform.
    local_faces : (g, 3) int64
        The kept triangles, indexing ``local_vertices``.
    kept : (f,) bool
        Which bake triangles were kept.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    inverse = np.linalg.inv(np.asarray(transform, dtype=np.float64))
    pad = grow * float(np.linalg.norm(upper - lower))
    local = vertices @ inverse[:3, :3].T + inverse[:3, 3]
    centroids = local[faces].mean(axis=1)
    kept = np.all((centroids >= lower - pad) & (centroids <= upper + pad), axis=1)
    used, inverse_index = np.unique(faces[kept].reshape(-1), return_inverse=True)
    return local[used], inverse_index.reshape(-1, 3).astype(np.int64), kept


def _vertex_labels(vertices: np.ndarray, tolerance: float) -> np.ndarray:
    """Cluster label of each vertex: vertices within ``tolerance`` (chained) share one."""
    tree = cKDTree(vertices)
    pairs = tree.query_pairs(tolerance, output_type="ndarray")
    n = len(vertices)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(graph, directed=False)[1].astype(np.int64)


def _occurrence(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Group id of each row of ``keys`` and its rank among equal rows (0, 1, ...)."""
    _, group = np.unique(keys, axis=0, return_inverse=True)
    group = group.reshape(-1)
    order = np.argsort(group, kind="stable")
    starts = np.r_[0, np.flatnonzero(np.diff(group[order])) + 1]
    rank = np.empty(len(group), dtype=np.int64)
    rank[order] = np.arange(len(group)) - np.repeat(starts, np.diff(np.r_[starts, len(group)]))
    return group, rank


def match_triangles(a_vertices: np.ndarray, a_faces: np.ndarray, b_vertices: np.ndarray,
                    b_faces: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """Which triangles of A have an equal triangle in B, one to one.

    Two triangles are equal when their corners coincide, up to ``tolerance``,
    as sets: any vertex order and either orientation. B's vertices within
    ``tolerance`` of each other (chained) count as one point; an A vertex is
    the point of its nearest B vertex within ``tolerance``, else a point of
    its own. Repeated triangles match as many times as both sides hold them.

    Parameters
    ----------
    a_vertices, b_vertices : (n, 3) float
    a_faces, b_faces : (f, 3) int
    tolerance : float
        World units, > 0.

    Returns
    -------
    a_matched : (len(a_faces),) bool
    b_matched : (len(b_faces),) bool
        ``a_matched.sum() == b_matched.sum()``.
    """
    a_vertices = np.asarray(a_vertices, dtype=np.float64).reshape(-1, 3)
    b_vertices = np.asarray(b_vertices, dtype=np.float64).reshape(-1, 3)
    a_faces = np.asarray(a_faces, dtype=np.int64).reshape(-1, 3)
    b_faces = np.asarray(b_faces, dtype=np.int64).reshape(-1, 3)
    if not tolerance > 0:
        raise InputError(f"tolerance: expected a number > 0, got {tolerance!r}")
    if len(a_faces) == 0 or len(b_faces) == 0:
        return np.zeros(len(a_faces), dtype=bool), np.zeros(len(b_faces), dtype=bool)
    b_label = _vertex_labels(b_vertices, tolerance)
    dist, nearest = cKDTree(b_vertices).query(a_vertices, distance_upper_bound=tolerance)
    found = np.isfinite(dist)
    a_label = np.where(found, b_label[np.minimum(nearest, len(b_vertices) - 1)],
                       -1 - np.arange(len(a_vertices)))
    a_keys = np.sort(a_label[a_faces], axis=1)
    b_keys = np.sort(b_label[b_faces], axis=1)
    group, rank = _occurrence(np.concatenate([a_keys, b_keys]))
    side = np.r_[np.zeros(len(a_keys), dtype=np.int64), np.ones(len(b_keys), dtype=np.int64)]
    groups = int(group.max()) + 1
    count_a = np.bincount(group[side == 0], minlength=groups)
    count_b = np.bincount(group[side == 1], minlength=groups)
    both = np.minimum(count_a, count_b)
    # ranks count both sides together: A's rows come first within a group
    a_rank = rank[:len(a_keys)]
    b_rank = rank[len(a_keys):] - count_a[group[len(a_keys):]]
    return (a_rank < both[group[:len(a_keys)]], b_rank < both[group[len(a_keys):]])


def _pair_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Exact distance from each point ``p[i]`` to triangle ``(a[i], b[i], c[i])``.

    Inside the prism over the triangle the distance is that to its plane;
    elsewhere the nearest point is on its border, the nearest of its three
    edges (degenerate triangles: their edges only).
    """
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    inside = nn > 0
    for v0, v1 in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v1 - v0, p - v0), n) >= 0
    plane = np.abs(np.einsum("ij,ij->i", p - a, n)) / np.sqrt(np.where(inside, nn, 1.0))
    edges = np.full(len(p), np.inf)
    for v0, v1 in ((a, b), (b, c), (c, a)):
        d = v1 - v0
        dd = np.einsum("ij,ij->i", d, d)
        t = np.clip(np.einsum("ij,ij->i", p - v0, d) / np.where(dd > 0, dd, 1.0), 0, 1)
        edges = np.minimum(edges, np.linalg.norm(p - (v0 + t[:, None] * d), axis=1))
    return np.where(inside, plane, edges)


def surface_distance(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray, *,
                     candidates: int = 8, pairs_per_pass: int = 1_000_000) -> np.ndarray:
    """Exact distance from each point to the nearest triangle of a triangle set.

    Every point-triangle distance is first estimated with dot products done
    as matrix products (squared distances, whose cancellation costs about
    1e-7 of the coordinates), then the ``candidates`` nearest triangles by
    that estimate are measured exactly (:func:`_pair_distance`) and the
    smallest counts. Coordinates are taken relative to the vertices' mean.

    Parameters
    ----------
    points : (p, 3) float
    vertices : (v, 3) float
    faces : (f, 3) int, f >= 1
    candidates : int, optional
        Triangles measured exactly per point (default 8).
    pairs_per_pass : int, optional
        Point-triangle pairs per vectorised pass (memory: a few float64 arrays
        of this size).

    Returns
    -------
    (p,) float64
    """
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    origin = vertices.mean(axis=0) if len(vertices) else np.zeros(3)
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3) - origin
    tri = (vertices - origin)[np.asarray(faces, dtype=np.int64).reshape(-1, 3)]
    if len(tri) == 0:
        raise InputError("surface_distance: no triangles")
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    unit = n / np.sqrt(np.where(nn > 0, nn, 1.0))[:, None]
    edges = []
    for v0, v1 in ((a, b), (b, c), (c, a)):
        e, m = v1 - v0, np.cross(n, v1 - v0)  # m: in-plane normal pointing into the triangle
        edges.append((v0, e, np.einsum("ij,ij->i", e, e), np.einsum("ij,ij->i", v0, e),
                      np.einsum("ij,ij->i", v0, v0), m, np.einsum("ij,ij->i", v0, m)))
    offset = np.einsum("ij,ij->i", a, unit)
    k = min(candidates, len(tri))
    out = np.empty(len(points))
    step = max(1, pairs_per_pass // len(tri))
    for s in range(0, len(points), step):
        p = points[s:s + step]
        pp = np.einsum("ij,ij->i", p, p)[:, None]
        inside = np.broadcast_to(nn > 0, (len(p), len(tri))).copy()
        best = np.full((len(p), len(tri)), np.inf)
        for v0, e, ee, v0e, v0v0, m, v0m in edges:
            inside &= p @ m.T - v0m >= 0
            along = p @ e.T - v0e
            t = np.clip(along / np.where(ee > 0, ee, 1.0), 0, 1)
            best = np.minimum(best, pp - 2 * (p @ v0.T) + v0v0 - 2 * t * along + t * t * ee)
        plane = p @ unit.T - offset
        estimate = np.where(inside, plane * plane, best)
        near = np.argpartition(estimate, k - 1, axis=1)[:, :k] if k < len(tri) else \
            np.broadcast_to(np.arange(len(tri)), (len(p), len(tri)))
        flat = near.reshape(-1)
        exact = _pair_distance(np.repeat(p, k, axis=0), a[flat], b[flat], c[flat])
        out[s:s + step] = exact.reshape(len(p), k).min(axis=1)
    return out


# ----------------------------------------------------------------------------- the bench


def _demo_folder(models_dir: str | os.PathLike | None) -> Path:
    """The demo folder: ``models_dir`` itself or its ``godot-occlusion-demo/``.

    ``models_dir`` None: ``$VISCORE_MODELS``, else ``../shared/models`` beside
    the repository.
    """
    if models_dir is None or str(models_dir) == "":
        env = os.environ.get(MODELS_ENV)
        models_dir = env if env else Path(__file__).resolve().parents[3] / "shared" / "models"
    base = Path(models_dir).expanduser()
    for folder in (base, base / DEMO_FOLDER):
        if all((folder / f).is_file() for f in ("room.glb", "node_3d.tscn", "node_3d.occ")):
            return folder
    raise InputError(f"godot-bake: no room.glb, node_3d.tscn and node_3d.occ in {base} or "
                     f"{base / DEMO_FOLDER}")


def _welded(vertices: np.ndarray, faces: np.ndarray) -> tuple[int, int]:
    """Vertices and triangles after Godot's ``strip_mesh_arrays``: equal positions welded,
    repeated and collapsed triangles dropped."""
    v32 = np.asarray(vertices, dtype=np.float32)
    used = np.unique(np.asarray(faces).reshape(-1))
    _, label = np.unique(v32, axis=0, return_inverse=True)
    label = label.reshape(-1)
    tri = np.sort(label[np.asarray(faces, dtype=np.int64)], axis=1)
    tri = tri[(tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2])]
    return int(len(np.unique(label[used]))), int(len(np.unique(tri, axis=0)))


def _sample(vertices: np.ndarray, faces: np.ndarray, count: int, seed: int) -> np.ndarray:
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    return np.asarray(trimesh.sample.sample_surface(mesh, count, seed=seed)[0])


def _compare(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray],
             tolerance: float, diagonal: float, seed: int, samples: int) -> dict:
    """Triangle-for-triangle figures of occluder A (ours) against B (Godot's file)."""
    (av, af), (bv, bf) = a, b
    am, bm = match_triangles(av, af, bv, bf, tolerance)
    a_area = trimesh.triangles.area(av[af])
    b_area = trimesh.triangles.area(bv[bf])
    sa, sb = _sample(av, af, samples, seed), _sample(bv, bf, samples, seed + 1)
    da, db = surface_distance(sa, bv, bf), surface_distance(sb, av, af)
    va = surface_distance(av[np.unique(af)], bv, bf)
    vb = surface_distance(bv[np.unique(bf)], av, af)
    a_to_b, b_to_a = max(da.max(), va.max()), max(db.max(), vb.max())
    return {"triangles": [len(af), len(bf)], "matched": int(am.sum()),
            "matched_share": [float(am.mean()), float(bm.mean())],
            "hausdorff": float(max(a_to_b, b_to_a) / diagonal),
            "hausdorff_directed": [float(a_to_b / diagonal), float(b_to_a / diagonal)],
            "mean_distance": [float(da.mean() / diagonal), float(db.mean() / diagonal)],
            "area": [float(a_area.sum()), float(b_area.sum())],
            "matched_area": float(a_area[am].sum()),
            "area_on_other": [float(a_area.sum() * np.mean(da <= tolerance)),
                              float(b_area.sum() * np.mean(db <= tolerance))]}


def _occluder_row(vertices: np.ndarray, faces: np.ndarray, views, **extra) -> dict:
    welded_vertices, welded_triangles = _welded(vertices, faces)
    pr = views.score(trimesh.Trimesh(vertices, faces, process=False))
    return {"triangles": int(len(faces)), "vertices": int(len(np.unique(faces))),
            "welded_vertices": welded_vertices, "welded_triangles": welded_triangles,
            "precision": float(pr.precision), "precision_ci": [float(x) for x in pr.precision_ci],
            "recall": float(pr.recall), "recall_ci": [float(x) for x in pr.recall_ci], **extra}


def _godot_import(path: Path, node: str) -> tuple[np.ndarray, np.ndarray, int]:
    """One glTF node's surface as Godot's importer gives it to the bake.

    Each triangle's second and third corners swapped (glTF is
    counter-clockwise, Godot clockwise: ``GLTFDocument::_parse_meshes``),
    then vertices equal in position, normal and UV (bit for bit) merged, in
    the order of their first use (``SurfaceTool::create_from_triangle_arrays``
    and ``SurfaceTool::index``). Returns vertices (in the room's frame),
    faces and the file's vertex count.
    """
    scene = trimesh.load(path, force="scene", process=False)
    transform, name = scene.graph[node]
    geometry = scene.geometry[name]
    faces = np.asarray(geometry.faces, dtype=np.int64)[:, [0, 2, 1]]
    attributes = [np.asarray(geometry.vertices, dtype=np.float32)]
    if "vertex_normals" in geometry._cache.cache:  # normals read from the file
        attributes.append(np.asarray(geometry.vertex_normals, dtype=np.float32))
    uv = getattr(geometry.visual, "uv", None)
    if uv is not None:
        attributes.append(np.asarray(uv, dtype=np.float32))
    key = np.ascontiguousarray(np.hstack(attributes)).view(np.int32)
    corners = faces.reshape(-1)
    _, first, label = np.unique(key[corners], axis=0, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first)] = np.arange(len(first))
    vertices = trimesh.transform_points(geometry.vertices, transform)[corners[np.sort(first)]]
    return vertices, rank[label.reshape(-1)].reshape(-1, 3), len(geometry.vertices)


def _counts(values: np.ndarray) -> dict:
    values = np.asarray(values)
    kinds, times = np.unique(values, return_counts=True)
    return {"min": int(values.min()), "median": float(np.median(values)),
            "max": int(values.max()), "counts": {str(int(k)): int(t) for k, t in
                                                 zip(kinds, times, strict=True)}}


def bench_godot_bake(models_dir: str | os.PathLike | None = None, *, seed: int = 0,
                     views: int = VIEWS, samples: int = SAMPLES) -> dict:
    """Our ``godot`` baseline against Godot's real bake of its occlusion demo.

    Parameters
    ----------
    models_dir : str or path-like, optional
        The demo folder, or the models folder holding ``godot-occlusion-demo/``.
        Default ``$VISCORE_MODELS``, else ``../shared/models`` beside the
        repository.
    seed : int, optional
        Seed of the surface samples and of the orbit views.
    views : int, optional
        Orbit views of the precision/recall evaluation (default :data:`VIEWS`).
    samples : int, optional
        Points sampled on each occluder for the Hausdorff distance and the
        areas on the other (default :data:`SAMPLES`).

    Returns
    -------
    dict
        ``source``, ``settings``, ``scene`` (instances, the occluder node's
        settings, mesh nodes and the bake mask), ``bake`` (Godot's file: its
        size, blocks, per-instance triangle counts, the crops of the chosen
        instance), ``surfaces`` (room.glb's surfaces and how many of Godot's
        vertices lie on each), ``occluders`` (per occluder: triangles,
        vertices raw and welded, orbit precision and recall with 95%
        intervals, settings), ``comparisons`` (per variant of ours against
        Godot's file, see the module doc), ``per_instance`` (our bake at
        every instance's place against Godot's triangles there),
        ``distance_sweep`` and ``seconds``. Lengths in world units, distances
        also as shares of the room's diagonal.

    Raises
    ------
    InputError
        When the folder lacks the demo's three files.
    """
    from viscore.generators import generate
    from viscore.metrics import ReferenceViews

    start = time.perf_counter()
    seed = as_seed(seed)
    views = as_positive_int(views, "views", maximum=100_000)
    samples = as_positive_int(samples, "samples", maximum=10_000_000)
    folder = _demo_folder(models_dir)
    room_path = folder / "room.glb"
    room = load_mesh(room_path)
    lower, upper = np.asarray(room.bounds[0]), np.asarray(room.bounds[1])
    diagonal = float(np.linalg.norm(upper - lower))
    tolerance = TOLERANCE_SHARE * diagonal
    scene = scene_instances((folder / "node_3d.tscn").read_text(encoding="utf-8"), "room.glb")
    if not scene["names"]:
        raise InputError(f"godot-bake: {folder / 'node_3d.tscn'} instances no room.glb")
    bake = load_occluder(folder / "node_3d.occ")
    bv, bf = np.asarray(bake.vertices, dtype=np.float64), np.asarray(bake.faces, dtype=np.int64)
    mats = scene["transforms"]

    # 1. Godot's triangles of each instance; the one nearest the origin, in its own frame
    owner = assign_instances(bv, bf, mats, lower, upper)
    per_room = np.bincount(owner[owner >= 0], minlength=len(mats))
    chosen = int(np.argmin(np.linalg.norm(mats[:, :3, 3], axis=1)))
    inverse = np.linalg.inv(mats[chosen])
    mine = bf[owner == chosen]
    used, index = np.unique(mine.reshape(-1), return_inverse=True)
    godot = (bv[used] @ inverse[:3, :3].T + inverse[:3, 3], index.reshape(-1, 3))
    crop_v, crop_f, _ = crop_instance(bv, bf, mats[chosen], lower, upper)
    crop_in_blocks = int(match_triangles(crop_v, crop_f, *godot, tolerance)[0].sum())

    # the room's surfaces and which of them Godot's file holds
    objects = load_scene_objects(room_path)
    gtree = cKDTree(godot[0])
    surfaces = []
    for i, name in enumerate(objects.names):
        mesh = objects.object_mesh(i)
        near = gtree.query_ball_point(np.asarray(mesh.vertices), tolerance)
        on = len(set().union(*near)) if len(near) else 0
        surfaces.append({"name": name, "triangles": int(len(mesh.faces)),
                         "vertices": int(len(mesh.vertices)), "godot_vertices_on_it": on})
    baked = [i for i, s in enumerate(surfaces) if s["godot_vertices_on_it"] > 0]
    if baked:
        parts = [objects.object_mesh(i) for i in baked]
        shell = parts[0] if len(parts) == 1 else trimesh.Scene(parts)
    else:
        shell = room
    occ = scene["occluder"] or {}
    distance = occ.get("bake_simplification_distance")
    distance = GODOT_DEFAULT_DISTANCE if distance is None else distance

    # 2. our baseline in the room's frame
    variants = {
        "ours-default": (room, {}, "room.glb as one mesh (viscore generate), default distance"),
        "ours-godot-settings": (shell, {"distance": distance},
                                "the surfaces Godot's file holds, Godot's distance"),
    }
    if len(baked) == 1:
        iv, if_, raw_vertices = _godot_import(room_path, objects.names[baked[0]])
        variants["ours-godot-import"] = (
            trimesh.Trimesh(iv, if_, process=False), {"distance": distance},
            f"that surface as Godot's importer indexes it ({raw_vertices} -> {len(iv)} "
            "vertices, clockwise), Godot's distance")
    reference = ReferenceViews(room, protocol="orbit", views=views, seed=seed)
    occluders = {"godot-file": _occluder_row(*godot, reference, what=f"Godot's node_3d.occ, "
                                             f"{scene['names'][chosen]}'s triangles")}
    comparisons, ours = {}, {}
    for key, (mesh, params, what) in variants.items():
        result = generate("godot", mesh, **params)
        ov = np.asarray(result.mesh.vertices, dtype=np.float64)
        of = np.asarray(result.mesh.faces, dtype=np.int64)
        ours[key] = (ov, of)
        occluders[key] = _occluder_row(ov, of, reference, what=what,
                                       distance=float(result.params["distance"]),
                                       surfaces=int(result.info["surfaces"]))
        comparisons[key] = _compare((ov, of), godot, tolerance, diagonal, seed, samples)

    # 4. our bake at every instance's place, against Godot's triangles there
    start_instances = time.perf_counter()
    plain = shell if isinstance(shell, trimesh.Trimesh) else None
    per_instance = None
    if plain is not None:
        counts, matched = np.zeros(len(mats), dtype=np.int64), np.zeros(len(mats), np.int64)
        pv, pf = np.asarray(plain.vertices, dtype=np.float64), np.asarray(plain.faces)
        for k, mat in enumerate(mats):
            world = trimesh.Trimesh(pv @ mat[:3, :3].T + mat[:3, 3], pf, process=False)
            r = generate("godot", world, distance=distance)
            used_k, index_k = np.unique(bf[owner == k].reshape(-1), return_inverse=True)
            counts[k] = len(r.mesh.faces)
            matched[k] = match_triangles(np.asarray(r.mesh.vertices), np.asarray(r.mesh.faces),
                                         bv[used_k], index_k.reshape(-1, 3), tolerance)[0].sum()
        share = matched / np.maximum(per_room, 1)
        per_instance = {"ours": _counts(counts), "godot": _counts(per_room),
                        "same_count": int((counts == per_room).sum()),
                        "matched": _counts(matched),
                        "matched_share": {"min": float(share.min()),
                                          "median": float(np.median(share)),
                                          "max": float(share.max())},
                        "identical": int(((matched == per_room) & (counts == per_room)).sum())}
    seconds_instances = time.perf_counter() - start_instances
    sweep = [{"distance": d, "triangles": int(len(generate("godot", shell, distance=d).mesh.faces))}
             for d in SWEEP]

    return {
        "source": str(folder),
        "settings": {"tolerance_share": TOLERANCE_SHARE, "grow": GROW, "samples": samples,
                     "views": views, "protocol": "orbit", "seed": seed,
                     "godot_distance": distance,
                     "godot_distance_from": "scene" if occ.get("bake_simplification_distance")
                     is not None else "Godot's default"},
        "scene": {"instances": len(mats), "instance": scene["names"][chosen],
                  "instance_origin": [float(x) for x in mats[chosen][:3, 3]],
                  "occluder": occ or None, "mesh_nodes": scene["mesh_nodes"]},
        "bake": {"triangles": int(len(bf)), "vertices": int(len(bv)),
                 "blocks": int(bake_blocks(bf)[-1]) + 1 if len(bf) else 0,
                 "unassigned": int((owner < 0).sum()), "per_instance": _counts(per_room),
                 "instance_triangles": int(len(godot[1])),
                 "instance_vertices": int(len(godot[0])),
                 "centroid_crop_triangles": int(len(crop_f)),
                 "centroid_crop_in_instance": crop_in_blocks},
        "room": {"triangles": int(len(room.faces)), "diagonal": diagonal,
                 "lower": [float(x) for x in lower], "upper": [float(x) for x in upper]},
        "surfaces": surfaces,
        "occluders": occluders,
        "comparisons": comparisons,
        "per_instance": per_instance,
        "distance_sweep": sweep,
        "seconds": time.perf_counter() - start,
        "seconds_per_instance_bakes": seconds_instances,
    }


def _ci(row: dict, key: str) -> str:
    lo, hi = row[f"{key}_ci"]
    return f"{row[key]:.4f} [{lo:.4f}, {hi:.4f}]"


def bench_godot_bake_text(r: dict) -> str:
    """The human-readable report of :func:`bench_godot_bake`."""
    b, s, sc = r["bake"], r["settings"], r["scene"]
    occ = sc["occluder"] or {}
    mask = occ.get("bake_mask", GODOT_DEFAULT_MASK)
    pi = b["per_instance"]
    missing = [x["name"] for x in r["surfaces"] if not x["godot_vertices_on_it"]]
    lines = [
        f"Godot's occlusion demo ({r['source']}): node_3d.occ holds {b['triangles']:,} "
        f"triangles, {b['vertices']:,} vertices in {b['blocks']:,} surface blocks for "
        f"{sc['instances']:,} room instances ({b['unassigned']} triangles unassigned)",
        f"  {occ.get('name', 'no OccluderInstance3D')}: bake_mask 0x{mask:08X}"
        f"{'' if occ.get('bake_mask_set') else ' (default)'}, bake_simplification_distance "
        f"{s['godot_distance']:g} ({s['godot_distance_from']}); mesh nodes of the scene: "
        + ", ".join(f"{m['name']} (layers {m['layers']}, "
                    f"{'in the mask' if m['in_bake_mask'] else 'masked out'})"
                    for m in sc["mesh_nodes"]),
        f"  Godot's triangles per room: {pi['min']} / {pi['median']:g} / {pi['max']} "
        f"(min / median / max); " + ", ".join(f"{t} rooms x {k}"
                                               for k, t in pi["counts"].items()),
        f"  {sc['instance']} at ({', '.join(f'{x:g}' for x in sc['instance_origin'])}): "
        f"{b['instance_triangles']} triangles, {b['instance_vertices']} vertices by surface "
        f"block; the centroid crop of its box grown by {s['grow']:.0%} of the diagonal takes "
        f"{b['centroid_crop_triangles']} ({b['centroid_crop_in_instance']} of them its own: "
        "neighbours' walls share its wall planes)",
        "  room.glb's surfaces in Godot's file: " + ", ".join(
            f"{x['name']} ({x['triangles']} triangles): {x['godot_vertices_on_it']} of Godot's "
            "vertices" for x in r["surfaces"] if x["godot_vertices_on_it"])
        + f"; not there: {len(missing)} surfaces"
        + (f" ({', '.join(missing)})" if len(missing) <= 3 else
           f" ({missing[0]}, ..., {missing[-1]})" if missing else ""),
        f"  orbit protocol, {s['views']} views, seed {s['seed']}, against room.glb "
        f"({r['room']['triangles']:,} triangles, diagonal {r['room']['diagonal']:.3f}); "
        f"matches up to {s['tolerance_share']:g} of the diagonal",
        f"  {'occluder':<20} {'tris':>5} {'verts':>6} {'welded':>6} {'precision [95%]':>25} "
        f"{'recall [95%]':>25}  what"]
    for key, row in r["occluders"].items():
        lines.append(f"  {key:<20} {row['triangles']:>5} {row['vertices']:>6} "
                     f"{row['welded_vertices']:>6} {_ci(row, 'precision'):>25} "
                     f"{_ci(row, 'recall'):>25}  {row['what']}"
                     + (f" ({row['distance']:g})" if "distance" in row else ""))
    lines.append(f"  {'vs godot-file':<20} {'triangles':>11} {'exact matches':>16} "
                 f"{'Hausdorff':>9} {'ours->godot':>11} {'godot->ours':>11} "
                 f"{'area ours/godot':>15} {'matched area':>12} {'on the other':>15}")
    for key, c in r["comparisons"].items():
        ta, tb = c["triangles"]
        ma, mb = c["matched_share"]
        da, db = c["hausdorff_directed"]
        aa, ab = c["area"]
        oa, ob = c["area_on_other"]
        lines.append(f"  {key:<20} {f'{ta}/{tb}':>11} {c['matched']:>4} "
                     f"{f'({ma:.0%}/{mb:.0%})':>11} {c['hausdorff']:>9.2e} {da:>11.2e} "
                     f"{db:>11.2e} {f'{aa:.1f}/{ab:.1f}':>15} {c['matched_area']:>12.1f} "
                     f"{f'{oa:.1f}/{ob:.1f}':>15}")
    lines.append("  (Hausdorff: sampled, symmetric, and each way, as shares of the diagonal; "
                 "areas in square world units; 'on the other': sampled area within the "
                 "tolerance of the other occluder)")
    p = r["per_instance"]
    if p:
        o, g = p["ours"], p["godot"]
        lines.append(
            f"  ours-godot-settings baked at every instance's place: {o['min']} / "
            f"{o['median']:g} / {o['max']} triangles vs Godot's {g['min']} / {g['median']:g} / "
            f"{g['max']}; same count in {p['same_count']} of {r['scene']['instances']} rooms, "
            f"exact matches {p['matched']['min']} / {p['matched']['median']:g} / "
            f"{p['matched']['max']} (share {p['matched_share']['min']:.0%} / "
            f"{p['matched_share']['median']:.0%} / {p['matched_share']['max']:.0%}), "
            f"identical rooms {p['identical']}")
    lines.append("  bake distance sweep (ours, Godot's surfaces): " + ", ".join(
        f"{x['distance']:g}: {x['triangles']}" for x in r["distance_sweep"]))
    lines.append(f"  {r['seconds']:.1f} s")
    return "\n".join(lines)
