"""Benchmark of ``aabb-skins`` behind ``viscore bench generate aabb-skins``.

AABB skins on the benchmark meshes (:mod:`viscore.cli.bench.models`) at
diagonal / 64 and / 128, beside the figures of the C++ peer. Figures are
printed, never asserted in tests.

References
----------
.. [1] Naaji, K. "Automatic Occluder Generation". A Graphics Diary (blog),
   15 Nov 2019; and its ``melt`` library (box filling), whose figures are
   :data:`PEER_FIGURES`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from viscore import InputError, load_mesh

from .models import BUILTIN_FALLBACK, MODEL_NAMES

__all__ = ["bench_generate_aabb_skins", "PEER_FIGURES", "PEER_SECONDS_128"]

#: Figures of the C++ peer (the ``melt`` library [1]_) at voxel size =
#: diagonal / 64: mesh -> [(boxes, share of volume covered)]. It returns
#: nothing for the bunny, teapot and rocker-arm.
PEER_FIGURES = {"spot": [(7, 0.399), (93, 0.707)], "fandisk": [(4, 0.420), (38, 0.726)],
                "stanford-bunny": [], "teapot": [], "rocker-arm": []}

#: The peer's time at diagonal / 128 to 80% coverage, seconds (0.44-1.2 s).
PEER_SECONDS_128 = (0.44, 1.2)


def bench_generate_aabb_skins(models: str | os.PathLike | None = None) -> dict:
    """AABB skins on the benchmark meshes at diagonal / 64 and / 128, beside the peer.

    For each mesh: at diagonal / 64, the boxes and volume share at the
    peer's box counts (and at 16 boxes where the peer returned nothing); at
    diagonal / 128, the boxes and seconds to 80% of the inner volume.

    Parameters
    ----------
    models : str or path-like or None, optional
        Folder holding some of :data:`MODEL_NAMES` as ``NAME.obj``; the
        built-in bunny is added to them. None (default): only the built-in
        scenes :data:`BUILTIN_FALLBACK`.

    Returns
    -------
    result : dict
        ``source`` (the folder, or ``'built-in scenes'``) and ``rows`` (one
        dict per mesh and setting), ``peer_seconds_128``.

    Raises
    ------
    InputError
        If ``models`` is not a folder, or holds none of :data:`MODEL_NAMES`.
    """
    from viscore.generators import generate_aabb_skins

    if models is None:
        sources = {"bunny (pymeshlab)" if n == "bunny" else n: n for n in BUILTIN_FALLBACK}
        source = "built-in scenes"
    else:
        folder = Path(models)
        if not folder.is_dir():
            raise InputError(f"models {folder}: no such folder of benchmark meshes")
        sources = {n: folder / f"{n}.obj" for n in MODEL_NAMES if (folder / f"{n}.obj").is_file()}
        if not sources:
            raise InputError(f"models {folder}: holds none of "
                             + ", ".join(f"{n}.obj" for n in MODEL_NAMES))
        sources["bunny (pymeshlab)"] = "bunny"
        source = str(folder)
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
