"""Planar sections' cost against the triangle count: an open scan at 1x and 16x, beside qem.

Silvennoinen et al. 2014 [1]_ voxelize the input first (sec. 4.1), so the cost
should follow the voxel grid, not the triangles.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 4.1, Table 1)
"""

from __future__ import annotations

import logging
from functools import partial

import numpy as np
import trimesh

from viscore import load_mesh

from .table1 import _subdivided, timed_row

__all__ = ["open_scan", "bench_scale", "scale_lines", "OPEN_BASE"]

_log = logging.getLogger(__name__)

#: Share of the height, from the bottom, whose faces :func:`open_scan` removes.
OPEN_BASE = 0.05


def open_scan(subdivisions: int = 0) -> trimesh.Trimesh:
    """The pymeshlab bunny with the faces of its lowest :data:`OPEN_BASE` of height
    (along z, its up axis) removed, subdivided ``subdivisions`` times.

    Examples
    --------
    >>> scan = open_scan()
    >>> len(scan.faces) < len(load_mesh("bunny").faces), scan.is_watertight
    (True, False)
    """
    bunny = load_mesh("bunny")
    z = bunny.triangles_center[:, 2]
    low, high = bunny.bounds[:, 2]
    keep = z > low + OPEN_BASE * (high - low)
    scan = trimesh.Trimesh(bunny.vertices, np.asarray(bunny.faces)[keep], process=False)
    scan.remove_unreferenced_vertices()
    return _subdivided(scan, subdivisions) if subdivisions else scan


def bench_scale(*, budget: int = 64, views: int = 128, seed: int = 0,
                subdivisions: tuple[int, ...] = (0, 2)) -> list[dict]:
    """Planar sections (defaults) and qem at ``budget`` on :func:`open_scan` at each
    number of subdivisions, in one run, after an untimed warm-up generation of each.

    Returns
    -------
    list of dict
        One per size: ``subdivisions``, ``triangles``, and for
        ``planar-sections`` and ``qem``: ``seconds`` (generation, wall),
        ``triangles``, ``precision``, ``recall`` and their 95% intervals;
        planar sections' row also ``generations`` (the precision floor's runs).
    """
    from viscore.generators import generate
    from viscore.metrics import ReferenceViews

    out = []
    # one untimed generation first: numba compiles its kernels on their first use after an
    # install (or in every process where it finds no cache folder), and the first row would
    # carry that cost
    _log.info("scale: a warm-up generation on the open scan at %d subdivisions",
              min(subdivisions))
    warm = open_scan(min(subdivisions))
    for method in ("planar-sections", "qem"):
        generate(method, warm, budget=budget, seed=seed)
    for k in subdivisions:
        mesh = open_scan(k)
        _log.info("scale: the open scan at %d triangles", len(mesh.faces))
        ref = ReferenceViews(mesh, protocol="orbit", views=views, seed=seed)
        row = {"subdivisions": k, "triangles": len(mesh.faces)}
        for method in ("planar-sections", "qem"):
            occ, row[method] = timed_row(
                partial(generate, method, mesh, budget=budget, seed=seed), ref)
            floor = occ.info.get("precision_floor")
            if floor is not None:
                row[method]["generations"] = len(floor.get("closings", [])) + len(
                    floor["steps"]) - (1 if floor.get("closings") else 0)
        out.append(row)
    return out


def scale_lines(rows: list[dict]) -> list[str]:
    """The rows as text, with the ratios the issue's targets are about."""
    lines = ["planar sections against the triangle count: the open scan stand-in (pymeshlab "
             "bunny, base cut open), defaults, budget as qem's; seconds are wall time, "
             "after a warm-up run",
             f"{'triangles':>10} | {'planar s':>8} {'runs':>4} {'P':>7} {'R':>6} | "
             f"{'qem s':>6} {'P':>7} {'R':>6} | {'planar/qem':>10}"]
    for r in rows:
        p, q = r["planar-sections"], r["qem"]
        lines.append(f"{r['triangles']:>10,} | {p['seconds']:>8.1f} {p.get('generations', 1):>4} "
                     f"{p['precision']:>7.4f} {p['recall']:>6.3f} | {q['seconds']:>6.1f} "
                     f"{q['precision']:>7.4f} {q['recall']:>6.3f} | "
                     f"{p['seconds'] / max(q['seconds'], 1e-9):>10.2f}")
    if len(rows) > 1:
        first, last = rows[0], rows[-1]
        grown = last["planar-sections"]["seconds"] / max(
            first["planar-sections"]["seconds"], 1e-9)
        lines.append(f"planar sections at {last['triangles']:,} over {first['triangles']:,} "
                     f"triangles: {grown:.2f}x the time for "
                     f"{last['triangles'] / first['triangles']:.1f}x the triangles")
    return lines
