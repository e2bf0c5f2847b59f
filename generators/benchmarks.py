"""Benchmarks of the metrics and generators: ``viscore bench evaluate|generate``.

Figures are printed, never asserted in tests. Each run measures its own
reference in the same run (the ray throughput of ``bench rays``), because the
machines are shared and noisy. Lives here, not in ``metrics``, because the
evaluate benchmark needs a decimated occluder (a generator) and the import
chain is viscore <- metrics <- generators.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np
from viscore.metrics import orbit_precision_recall

from viscore import load_mesh
from viscore.benchmarks import bench_rays

from .aabb_skins import generate_aabb_skins
from .baselines import generate_qem

__all__ = ["bench_evaluate", "bench_generate_aabb_skins", "PEER_FIGURES"]

_log = logging.getLogger(__name__)

#: Figures of the C++ peer (the melt library of seed 003) at voxel size =
#: diagonal / 64, from the issue: mesh -> [(boxes, share of volume covered)].
#: It returns nothing for the bunny, teapot and rocker-arm.
PEER_FIGURES = {"spot": [(7, 0.399), (93, 0.707)], "fandisk": [(4, 0.420), (38, 0.726)],
                "stanford-bunny": [], "teapot": [], "rocker-arm": []}

#: The peer's time at diagonal / 128 to 80% coverage, seconds (0.44-1.2 s).
PEER_SECONDS_128 = (0.44, 1.2)


def bench_evaluate(*, views: int = 256, quads: int = 32000, resolution: int = 256,
                   budget: int = 64, seed: int = 0) -> dict:
    """Orbit protocol of the pymeshlab bunny against a 64-triangle QEM copy.

    Returns
    -------
    result : dict
        ``seconds`` (wall), ``seconds_rays``, ``seconds_quads``, ``rays``,
        ``mrays_per_second`` of the evaluation and ``bench_rays_mrays_all``
        (the ``bench rays`` figure of this run), ``precision``, ``recall``.
        Target: under 15 s wall on 2 cores.
    """
    mesh = load_mesh("bunny")
    occ = generate_qem(mesh, budget=budget)
    start = time.perf_counter()
    r = orbit_precision_recall(mesh, occ.mesh, views=views, quads=quads,
                               resolution=resolution, seed=seed)
    wall = time.perf_counter() - start
    ref = bench_rays("bunny", rays=500_000, repeats=2, seed=seed)
    return {"views": views, "quads": quads, "resolution": resolution,
            "occluder_triangles": occ.triangles, "seconds": wall,
            "seconds_rays": r.timing["seconds_rays"], "seconds_quads": r.timing["seconds_quads"],
            "rays": r.timing["rays"], "mrays_per_second": r.timing["rays"] / r.timing[
                "seconds_rays"] / 1e6,
            "bench_rays_mrays_all": ref["scene_mrays_all"],
            "precision": r.precision, "recall": r.recall}


def bench_generate_aabb_skins(models: str | Path = "../shared/models") -> dict:
    """AABB skins on the benchmark meshes at diagonal / 64 and / 128, beside the peer.

    For each mesh: at diagonal / 64, the boxes and volume share at the
    peer's box counts (and at 16 boxes where the peer returned nothing); at
    diagonal / 128, the boxes and seconds to 80% of the inner volume.
    Meshes come from ``models`` when it exists, else the pymeshlab samples.

    Returns
    -------
    result : dict
        ``source`` and ``rows`` (one dict per mesh and setting).
    """
    folder = Path(models)
    names = ["spot", "fandisk", "rocker-arm", "stanford-bunny", "teapot"]
    if folder.is_dir():
        sources = {n: folder / f"{n}.obj" for n in names if (folder / f"{n}.obj").is_file()}
        sources["bunny (pymeshlab)"] = "bunny"
        source = str(folder)
    else:
        _log.warning("%s not found: using the pymeshlab sample meshes", folder)
        sources = {"bunny (pymeshlab)": "bunny", "cow": "cow"}
        source = "pymeshlab samples"
    rows = []
    for name, path in sources.items():
        mesh = load_mesh(path)
        diag = float(np.linalg.norm(mesh.extents))
        counts = [b for b, _ in PEER_FIGURES.get(name, [])] or [16]
        generate_aabb_skins(mesh, voxel_size=diag / 16, max_boxes=1)  # numba warm-up
        peers = dict(PEER_FIGURES.get(name, []))
        settings = [("diag/64", 64, b, 1.0) for b in counts] + [("diag/128", 128, None, 0.8)]
        for label, div, boxes, fill in settings:
            occ = generate_aabb_skins(mesh, voxel_size=diag / div, max_boxes=boxes, fill=fill)
            rows.append({"mesh": name, "voxel_size": label, "max_boxes": boxes,
                         "boxes": occ.info["boxes"], "triangles": occ.triangles,
                         "volume_share": occ.info["volume_share"], "fill": occ.info["fill"],
                         "inside": occ.info["inside"], "seconds": occ.seconds,
                         "peer_volume_share": peers.get(boxes)})
    return {"source": source, "peer_seconds_128": PEER_SECONDS_128, "rows": rows}
