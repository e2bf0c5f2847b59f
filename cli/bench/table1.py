"""Table 1 of the planar-sections paper as one command: its five rows beside ours.

Silvennoinen et al. 2014 [1]_, Table 1.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (Table 1, sec. 6.1)
"""

from __future__ import annotations

import logging
import time
from functools import partial

import numpy as np
import trimesh

from viscore import load_mesh

__all__ = ["PAPER_TABLE1", "table1_meshes", "machine_assembly", "fractal_terrain",
           "height_field_sheet", "bench_table1", "table1_lines"]

_log = logging.getLogger(__name__)

#: The paper's rows: name, triangles, budget, seconds, precision, recall.
PAPER_TABLE1 = (
    ("BUNNY", 4968, 53, 18.0, 0.999, 0.835),
    ("DRAGON", 871306, 36, 11.0, 0.999, 0.478),
    ("TERRAIN", 60160, 23, 11.0, 0.999, 0.823),
    ("MACHINE", 394452, 36, 8.0, 0.998, 0.564),
    ("BUDDHA", 1087474, 30, 10.0, 0.999, 0.602),
)


def _subdivided(mesh: trimesh.Trimesh, times: int) -> trimesh.Trimesh:
    """``mesh`` with every triangle split in four ``times`` times (same surface)."""
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    for _ in range(times):
        v, f = trimesh.remesh.subdivide(v, f)
    return trimesh.Trimesh(v, f, process=False)


def fractal_terrain(n: int = 174, *, size: float = 100.0, height: float = 33.0,
                    beta: float = 2.2, seed: int = 0) -> trimesh.Trimesh:
    """An open fractal height field: ``2 (n - 1)^2`` triangles over ``size`` x ``size``.

    Heights by spectral synthesis: Gaussian noise in the Fourier domain with
    amplitude ``1 / f^beta``, transformed back and scaled to [0, ``height``].

    Examples
    --------
    >>> t = fractal_terrain(20, seed=1)
    >>> len(t.faces), bool(np.isclose(np.ptp(t.vertices[:, 2]), 33.0))
    (722, True)
    """
    rng = np.random.default_rng(seed)
    k = np.hypot(*np.meshgrid(np.fft.fftfreq(n), np.fft.fftfreq(n), indexing="ij"))
    k[0, 0] = np.inf
    spectrum = (rng.normal(size=(n, n)) + 1j * rng.normal(size=(n, n))) / k ** beta
    z = np.real(np.fft.ifft2(spectrum))
    z = (z - z.min()) / np.ptp(z) * height
    return height_field_sheet(z, size, size)


def height_field_sheet(z: np.ndarray, sx: float, sy: float) -> trimesh.Trimesh:
    """The heights ``z`` (nx, ny) on a regular grid over [0, sx] x [0, sy] as an open
    sheet of ``2 (nx - 1)(ny - 1)`` triangles, z up.

    Examples
    --------
    >>> len(height_field_sheet(np.zeros((3, 4)), 2.0, 3.0).faces)
    12
    """
    nx, ny = z.shape
    x, y = np.meshgrid(np.linspace(0, sx, nx), np.linspace(0, sy, ny), indexing="ij")
    idx = np.arange(nx * ny).reshape(nx, ny)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return trimesh.Trimesh(np.stack([x.ravel(), y.ravel(), np.ravel(z)], 1), faces,
                           process=False)


def _gear(teeth: int, radius: float, depth: float, width: float) -> trimesh.Trimesh:
    """A spur gear: a star polygon of ``teeth`` teeth extruded by ``width``."""
    angles = np.arange(4 * teeth) * (2 * np.pi / (4 * teeth))
    r = np.where((np.arange(4 * teeth) // 2) % 2 == 0, radius, radius - depth)
    from shapely.geometry import Polygon

    ring = Polygon(np.stack([r * np.cos(angles), r * np.sin(angles)], 1))
    return trimesh.creation.extrude_polygon(ring, width)


def machine_assembly(seed: int = 0) -> trimesh.Trimesh:
    """A mechanical assembly of many loose parts, about 400,000 triangles.

    A base plate, 12 upright shafts (cylinders of 2,048 sides) each with a gear
    of 96 teeth, 4 cross beams, and 216 bolts (cylinders of 320 sides with hex
    heads) in rows on the plate: 461 parts that touch and intersect, as CAD
    assemblies exported as one soup do.

    Examples
    --------
    >>> m = machine_assembly()
    >>> 350_000 < len(m.faces) < 450_000
    True
    """
    rng = np.random.default_rng(seed)
    t = trimesh.transformations.translation_matrix
    parts = [trimesh.creation.box(extents=(100, 60, 5), transform=t((0, 0, -2.5)))]
    for i in range(12):
        x, y = -40 + (i % 6) * 16, -15 + (i // 6) * 30
        h = float(rng.uniform(25, 45))
        parts.append(trimesh.creation.cylinder(radius=2.5, height=h, sections=2048,
                                               transform=t((x, y, h / 2))))
        gear = _gear(96, float(rng.uniform(6, 8)), 1.0, 3.0)
        gear.apply_translation((x, y, float(rng.uniform(8, h - 4))))
        parts.append(gear)
    for j in range(4):
        parts.append(trimesh.creation.box(extents=(96, 3, 3),
                                          transform=t((0, -21 + 14 * j, 46 + 2 * j))))
    for i in range(216):
        x, y = -48 + (i % 36) * 96 / 35, -28 + (i // 36) * 56 / 5
        parts.append(trimesh.creation.cylinder(radius=0.6, height=4, sections=320,
                                               transform=t((x, y, 2))))
        parts.append(trimesh.creation.cylinder(radius=1.1, height=1, sections=6,
                                               transform=t((x, y, 4.5))))
    return trimesh.util.concatenate(parts)


def table1_meshes(seed: int = 0) -> dict[str, trimesh.Trimesh]:
    """The five stand-ins, by the paper's row names (see the module docstring)."""
    bunny = load_mesh("bunny")
    return {"BUNNY": bunny, "DRAGON": _subdivided(bunny, 2),
            "TERRAIN": fractal_terrain(seed=seed), "MACHINE": machine_assembly(seed),
            "BUDDHA": _subdivided(load_mesh("cow"), 4)}


def _scored(result) -> dict:
    return {"precision": float(result.precision), "recall": float(result.recall),
            "precision_ci": [float(x) for x in result.precision_ci],
            "recall_ci": [float(x) for x in result.recall_ci]}


def timed_row(make, ref) -> tuple:
    """``make()``'s occluder, timed, and its row: ``triangles``, ``seconds`` (wall) and the
    scores on ``ref`` (a :class:`viscore.metrics.ReferenceViews`) with their intervals;
    precision None for an empty occluder, and ``(None, None)`` when ``make`` gives None."""
    t0 = time.perf_counter()
    occ = make()
    took = time.perf_counter() - t0
    if occ is None:
        return None, None
    scored = (_scored(ref.score(occ.mesh)) if occ.triangles else
              {"precision": None, "recall": 0.0, "precision_ci": None, "recall_ci": [0.0, 0.0]})
    return occ, {"triangles": occ.triangles, "seconds": took, **scored}


def bench_table1(*, views: int = 256, seed: int = 0, rows: tuple[str, ...] | None = None
                 ) -> list[dict]:
    """Table 1's rows: the paper's figures beside planar sections, qem and godot here.

    Returns
    -------
    list of dict
        One per row: ``name``, ``triangles`` (the stand-in's), ``budget``,
        ``paper`` (``triangles``, ``seconds``, ``precision``, ``recall``), and
        for ``planar-sections``, ``qem`` and ``godot``: ``triangles``,
        ``seconds`` (generation, wall), ``precision``, ``recall`` and their
        95% intervals (None for godot when no bake gets that small).
    """
    from viscore.generators import generate
    from viscore.metrics import ReferenceViews

    from .planar import godot_within

    meshes = table1_meshes(seed)
    out = []
    for name, tris, budget, seconds, precision, recall in PAPER_TABLE1:
        if rows is not None and name not in rows:
            continue
        mesh = meshes[name]
        _log.info("table 1: %s (%d triangles) at %d", name, len(mesh.faces), budget)
        ref = ReferenceViews(mesh, protocol="orbit", views=views, seed=seed)
        row = {"name": name, "triangles": len(mesh.faces), "budget": budget,
               "paper": {"triangles": tris, "seconds": seconds, "precision": precision,
                         "recall": recall}}
        for method in ("planar-sections", "qem", "godot"):
            row[method] = timed_row(
                partial(godot_within, mesh, budget) if method == "godot" else
                partial(generate, method, mesh, budget=budget, seed=seed), ref)[1]
        out.append(row)
    return out


def table1_lines(rows: list[dict]) -> list[str]:
    """The table as text: the paper's figures, then ours, qem's and godot's."""
    lines = ["Table 1 (Silvennoinen et al. 2014) beside planar-sections, qem and godot here "
             "(orbit, stand-ins; seconds are wall time on this machine, the paper's on a GPU)",
             f"{'row':<8} {'tris':>9} {'budget':>6} | {'paper P':>7} {'R':>6} {'s':>4} | "
             f"{'planar tris':>11} {'P':>7} {'R [95%]':>19} {'s':>6} | {'qem R':>6} {'s':>5} | "
             f"{'godot tris':>10} {'R':>6}"]
    for r in rows:
        p, ps, q, g = r["paper"], r["planar-sections"], r["qem"], r["godot"]
        ci = f"{ps['recall']:.3f} [{ps['recall_ci'][0]:.3f}, {ps['recall_ci'][1]:.3f}]"
        godot = "-" if g is None else f"{g['triangles']:>10} {g['recall']:6.3f}"
        lines.append(
            f"{r['name']:<8} {r['triangles']:>9} {r['budget']:>6} | {p['precision']:7.3f} "
            f"{p['recall']:6.3f} {p['seconds']:4.0f} | {ps['triangles']:>11} "
            f"{ps['precision']:7.4f} {ci:>19} {ps['seconds']:6.1f} | {q['recall']:6.3f} "
            f"{q['seconds']:5.1f} | {godot}")
    return lines
