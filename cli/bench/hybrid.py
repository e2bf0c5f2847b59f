"""Benchmark of the hybrid generator behind ``viscore bench generate hybrid``.

References
----------
.. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (the method, sec. 3; its figures, Table 2 and
   Fig. 11: 260 faces, precision 99.4%, recall 78.0% on average)
"""

from __future__ import annotations

import logging
import os
import time
from pathlib import Path

import numpy as np

from viscore import load_mesh

from ._plot import figure, save
from .models import building_sources

__all__ = ["bench_generate_hybrid", "hybrid_ablation", "PAPER_FIGURES", "HYBRID_ABLATION",
           "HYBRID_ABLATION_MESHES"]

_log = logging.getLogger(__name__)

#: The paper's averages over 77 buildings (Table 2, Fig. 11): faces, precision, recall.
PAPER_FIGURES = {"hybrid": (260, 0.994, 0.780), "simplygon": (300, 0.962, 0.743),
                 "planar-sections": (127, 0.923, 0.397)}


def bench_generate_hybrid(models: str | os.PathLike | None = None, *,
                          spacing: float = 0.08, resolution: int = 64, quads: int = 1000,
                          seed: int = 1, baselines: bool = True, fill_effect: bool = True,
                          names: tuple[str, ...] | None = None, **options) -> dict:
    """Time and score the hybrid generator on the buildings, beside qem and godot.

    Parameters
    ----------
    models : str or path-like or None, optional
        Folder holding ``kenney/*.glb`` (or ``building*.glb``); they join the
        built-in buildings. None (default): the built-in buildings only.
    spacing : float, optional
        Evaluation view spacing as a fraction of the bounding-box diagonal,
        default 0.08.
    resolution, quads : int, optional
        Evaluation pixels per frustum side and quads per frustum, default 64
        and 1,000.
    seed : int, optional
        Seed of the evaluation views (jittered grid), default 1; the hybrid
        itself runs with seed 0.
    baselines : bool, optional
        Also score ``qem`` at the hybrid's face count and ``godot``.
    fill_effect : bool, optional
        Also score the patch candidates with and without hole filling, and
        the hybrid without filling (default True; skipped when ``options``
        turn filling off or leave the patches out).
    names : tuple of str, optional
        Only these rows (mesh names as in the result). Default: all.
    **options
        Passed to :func:`viscore.generators.generate_hybrid`.

    Returns
    -------
    result : dict
        ``rows`` (one dict per mesh: ``mesh``, ``triangles_input``, ``seconds``
        and the per-stage seconds, ``faces``, ``triangles_single_sided``,
        ``faces_patch``, ``faces_voxel``, ``precision``, ``recall`` and their
        ``_ci``, ``holes_filled``, ``holes_open``, ``holes_open_why``, with
        ``baselines`` ``qem_*`` and ``godot_*`` figures, and with
        ``fill_effect`` ``patch_fill_*`` and ``patch_nofill_*`` (faces,
        precision, recall of the patch candidates) and ``nofill_*`` (the
        hybrid without filling)),
        ``means`` over the built-in buildings, ``settings`` of the evaluation,
        ``paper`` (:data:`PAPER_FIGURES`).

    Raises
    ------
    InputError
        If ``models`` is not a folder or holds no building.
    """
    from viscore.generators import generate_godot, generate_hybrid, generate_qem
    from viscore.metrics import ReferenceViews

    sources = building_sources(models)
    if names is not None:
        sources = {k: v for k, v in sources.items() if k in set(names)}
    rows = []
    settings = None
    for name, source in sources.items():
        mesh = load_mesh(source)
        diag = float(np.linalg.norm(np.ptp(np.asarray(mesh.vertices), axis=0)))
        start = time.perf_counter()
        occ = generate_hybrid(mesh, **options)
        seconds = time.perf_counter() - start
        views = ReferenceViews(mesh, protocol="volume", spacing=spacing * diag,
                               resolution=resolution, quads=quads, jitter=True, seed=seed)
        settings = views.settings
        score = views.score(occ.mesh if occ.triangles else None)
        row = {"mesh": name, "triangles_input": len(mesh.faces), "seconds": seconds,
               **{k: occ.info[k] for k in ("seconds_patch", "seconds_voxel",
                                           "seconds_enforce", "seconds_mgos", "faces",
                                           "triangles_single_sided", "faces_patch",
                                           "faces_voxel", "candidates_patch",
                                           "candidates_voxel")},
               "precision": score.precision, "recall": score.recall,
               "precision_ci": score.precision_ci, "recall_ci": score.recall_ci,
               "positions": len(views.weights)}
        patch = occ.info.get("patch", {})
        row |= {"holes_filled": patch.get("holes_filled", 0),
                "holes_open": patch.get("holes_open", 0),
                "holes_open_why": patch.get("holes_open_why", {})}
        if (fill_effect and options.get("fill_holes", True)
                and options.get("candidates", "combined") != "voxel"):
            row |= _fill_effect(mesh, views, occ.triangles, options)
        if baselines:
            qem = generate_qem(mesh, budget=max(1, occ.triangles))
            godot = generate_godot(mesh)
            for label, other in (("qem", qem), ("godot", godot)):
                s = views.score(other.mesh)
                row |= {f"{label}_faces": other.triangles, f"{label}_precision": s.precision,
                        f"{label}_recall": s.recall}
        _log.info("bench hybrid: %s %d faces P %.4f R %.4f in %.1f s", name, occ.triangles,
                  score.precision, score.recall, seconds)
        rows.append(row)
    builtin = [r for r in rows if not r["mesh"].startswith("kenney/")]
    keys = ["seconds", "faces", "precision", "recall"]
    if baselines:
        keys += ["qem_faces", "qem_precision", "qem_recall", "godot_faces", "godot_precision",
                 "godot_recall"]
    keys += ["holes_filled", "holes_open"]
    keys += [k for k in ("patch_fill_faces", "patch_fill_precision", "patch_fill_recall",
                         "patch_nofill_faces", "patch_nofill_precision", "patch_nofill_recall",
                         "nofill_faces", "nofill_precision", "nofill_recall")
             if builtin and all(k in r for r in builtin)]
    means = {k: float(np.nanmean([r[k] for r in builtin])) for k in keys} if builtin else {}
    return {"rows": rows, "means": means, "paper": PAPER_FIGURES,
            "settings": {"spacing_fraction": spacing, "resolution": resolution, "quads": quads,
                         "seed": seed, "jitter": True, "views": settings,
                         "options": dict(options)}}


def _fill_effect(mesh, views, faces: int, options: dict) -> dict:
    """Hole filling on and off: the patch candidates at N_P, the hybrid at ``faces``."""
    from viscore.generators import generate_hybrid

    out = {}
    patch_only = {**options, "candidates": "patch", "mgos": False}
    for label, fill in (("patch_fill", True), ("patch_nofill", False)):
        occ = generate_hybrid(mesh, **{**patch_only, "fill_holes": fill})
        s = views.score(occ.mesh if occ.triangles else None)
        out |= {f"{label}_faces": occ.triangles, f"{label}_precision": s.precision,
                f"{label}_recall": s.recall}
    occ = generate_hybrid(mesh, **{**options, "fill_holes": False, "budget": max(1, faces)})
    s = views.score(occ.mesh if occ.triangles else None)
    return out | {"nofill_faces": occ.triangles, "nofill_precision": s.precision,
                  "nofill_recall": s.recall}


#: The configurations of Wu et al. 2022 Fig. 11 run by ``bench generate hybrid --ablation``:
#: (label, generate_hybrid options).
HYBRID_ABLATION = (
    ("a voxel", {"candidates": "voxel", "enforce": False, "mgos": False}),
    ("b voxel + enforcement", {"candidates": "voxel", "enforce": True, "mgos": False}),
    ("c patch", {"candidates": "patch", "mgos": False}),
    ("d combined", {"candidates": "combined", "mgos": False}),
    ("e patch + MGOS", {"candidates": "patch", "mgos": True}),
    ("f combined + MGOS", {"candidates": "combined", "mgos": True}),
)

#: Buildings of the hybrid ablation.
HYBRID_ABLATION_MESHES = ("building-house", "building-tower", "building-church",
                          "building-cottage")


def hybrid_ablation(folder, seed: int) -> tuple[list[dict], list[str]]:
    """Fig. 11 of Wu et al. 2022: means over :data:`HYBRID_ABLATION_MESHES` per configuration.

    Writes ``folder/hybrid_ablation.png``; returns the rows and the lines to print.
    """
    rows = []
    for label, options in HYBRID_ABLATION:
        r = bench_generate_hybrid(None, seed=seed, baselines=False,
                                  names=HYBRID_ABLATION_MESHES, **options)
        rows.append({"config": label, "options": options, **{
            k: float(np.mean([row[k] for row in r["rows"]]))
            for k in ("faces", "precision", "recall", "seconds")}})
    fig = figure(6.0, 3.2)
    ax = fig.add_subplot(1, 1, 1)
    x = np.arange(len(rows))
    ax.bar(x - 0.2, [r["recall"] for r in rows], 0.4, label="recall")
    ax.bar(x + 0.2, [r["precision"] for r in rows], 0.4, label="precision")
    ax.set_xticks(x, [r["config"].split()[0] for r in rows])
    ax.set_ylim(0, 1.05)
    ax.set_title("hybrid ablation (Wu et al. Fig. 11), means over 4 buildings", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = Path(folder) / "hybrid_ablation.png"
    save(fig, path)
    lines = [f"{'configuration':<24} {'faces':>6} {'P':>7} {'R':>7} {'seconds':>7}"]
    lines += [f"{r['config']:<24} {r['faces']:>6.0f} {r['precision']:>7.4f} "
              f"{r['recall']:>7.4f} {r['seconds']:>7.1f}" for r in rows]
    lines.append(f"wrote {path}")
    return rows, lines
