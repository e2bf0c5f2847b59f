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
import time
from pathlib import Path

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from viscore import InputError, load_mesh, load_occluder, load_scene_objects
from viscore._validate import as_positive_int, as_seed
from viscore.exchange import GODOT_DEFAULT_MASK, tscn_instances
from viscore.generators.baselines import godot_imported_surface
from viscore.metrics import match_triangles, surface_distance

from .models import MODELS_ENV

__all__ = ["bench_godot_bake", "bench_godot_bake_text", "bake_blocks", "assign_instances",
           "crop_instance", "DEMO_FOLDER", "GODOT_DEFAULT_DISTANCE"]

#: The old name of the ``.tscn`` instance reader, now
#: :func:`viscore.exchange.tscn_instances` (``match_triangles``, ``surface_distance``
#: and ``GODOT_DEFAULT_MASK`` keep their names here too, imported from their homes).
scene_instances = tscn_instances

#: The demo's folder inside the models folder.
DEMO_FOLDER = "godot-occlusion-demo"
#: ``OccluderInstance3D``'s default ``bake_simplification_distance`` (0.1 m,
#: scene/3d/occluder_instance_3d.h), used when the scene sets none.
GODOT_DEFAULT_DISTANCE = 0.1
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
        Instance-to-occluder-frame transforms (:func:`viscore.exchange.tscn_instances`).
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
    scene = tscn_instances((folder / "node_3d.tscn").read_text(encoding="utf-8"), "room.glb")
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
        iv, if_, raw_vertices = godot_imported_surface(room_path, objects.names[baked[0]])
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
