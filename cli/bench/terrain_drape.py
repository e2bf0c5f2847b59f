"""Benchmark of occluders for open height fields behind ``viscore bench generate terrain-drape``."""

from __future__ import annotations

import logging
from functools import partial

import numpy as np
import trimesh

from viscore import load_mesh

from .table1 import fractal_terrain, height_field_sheet, timed_row

__all__ = ["height_fields", "area_above", "bench_terrain_drape", "terrain_drape_lines",
           "BUDGET", "METHODS"]

_log = logging.getLogger(__name__)

#: Table 1's TERRAIN budget.
BUDGET = 23
#: The methods of every row.
METHODS = ("terrain-drape", "planar-sections", "qem")
#: Height above the surface, as a share of the diagonal, from which area counts as above.
ABOVE = 0.005


def _hills(seed: int, n: int = 150) -> trimesh.Trimesh:
    """Twelve seeded Gaussian hills and hollows over 200 x 120."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, 200, n), np.linspace(0, 120, n), indexing="ij")
    z = np.zeros_like(x)
    for _ in range(12):
        cx, cy = rng.uniform(0, 200), rng.uniform(0, 120)
        r, a = rng.uniform(10, 40), rng.uniform(-15, 25)
        z += a * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / r ** 2)
    return height_field_sheet(z, 200, 120)


def height_fields(seed: int = 0) -> dict[str, tuple[trimesh.Trimesh, str]]:
    """The bench's height fields, by name: ``(mesh, up axis)``.

    Examples
    --------
    >>> sorted(height_fields())[:3]
    ['fractal-2.2', 'fractal-3', 'hills']
    """
    hills = _hills(seed + 1)
    centre = hills.triangles_center
    lake = np.hypot(centre[:, 0] - 120, centre[:, 1] - 60) > 18
    turned = _hills(seed + 2)
    turned.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
    return {"terrain": (load_mesh("terrain"), "z"),
            "hills": (hills, "z"),
            "hills-y-up": (turned, "y"),
            "hills-lake": (trimesh.Trimesh(hills.vertices, hills.faces[lake], process=False), "z"),
            "fractal-3": (fractal_terrain(beta=3.0, seed=seed + 3), "z"),
            "fractal-2.2": (fractal_terrain(seed=seed), "z")}


def area_above(mesh: trimesh.Trimesh, occluder: trimesh.Trimesh, up: str, *,
               above: float = ABOVE, samples: int = 20_000, seed: int = 0) -> float:
    """Share of ``occluder``'s area higher than ``mesh``'s surface by over ``above`` x diagonal.

    Seeded points on the occluder; a point is above the surface when the ray
    down from it meets the mesh (at a distance over the threshold) and the ray
    up does not.
    """
    from viscore import Scene

    if len(occluder.faces) == 0:
        return 0.0
    k = "xyz".index(up)
    d = np.zeros(3)
    d[k] = 1.0
    pts, _ = trimesh.sample.sample_surface(occluder, samples, seed=seed)
    scene = Scene.shared(mesh)
    t, _ = scene.first_hit(pts, np.broadcast_to(-d, pts.shape))
    free_above = ~scene.any_hit(pts, np.broadcast_to(d, pts.shape))
    limit = above * float(np.linalg.norm(mesh.extents))
    return float(np.mean(np.isfinite(t) & (t > limit) & free_above))


def bench_terrain_drape(*, budget: int = BUDGET, views: int = 256, seed: int = 0,
                        methods: tuple[str, ...] = METHODS) -> list[dict]:
    """Each height field's row: ``name``, ``triangles``, and per method ``triangles``,
    ``seconds``, ``precision``, ``recall``, their 95% intervals and ``above``."""
    from viscore.generators import generate
    from viscore.metrics import ReferenceViews

    rows = []
    for name, (mesh, up) in height_fields(seed).items():
        _log.info("terrain-drape bench: %s (%d triangles)", name, len(mesh.faces))
        ref = ReferenceViews(mesh, protocol="orbit", views=views, seed=seed)
        row = {"name": name, "triangles": len(mesh.faces)}
        for method in methods:
            occ, cells = timed_row(
                partial(generate, method, mesh, budget=budget, seed=seed), ref)
            row[method] = {**cells, "above": area_above(mesh, occ.mesh, up, seed=seed)}
        rows.append(row)
    return rows


def terrain_drape_lines(rows: list[dict], budget: int = BUDGET) -> list[str]:
    """The rows as text: per method triangles, seconds, P, R and the area above."""
    methods = [m for m in rows[0] if m not in ("name", "triangles")] if rows else []
    width = 27  # one method's cells: tris, seconds, P, R, up
    names = f"{'':<20} | " + " | ".join(f"{m:^{width}}" for m in methods)
    head = f"{'height field':<12} {'tris':>7} | " + " | ".join(
        f"{'t':>3} {'s':>5} {'P':>6} {'R':>5} {'up':>4}" for _ in methods)
    lines = [f"open height fields at {budget} triangles (Table 1's TERRAIN: P 0.999, R 0.823); "
             f"orbit, 256 views; 'up': share of the occluder's area above the surface by "
             f"> {ABOVE:.1%} of the diagonal", names, head]
    for r in rows:
        cells = []
        for m in methods:
            c = r[m]
            p = "-" if c["precision"] is None else f"{c['precision']:.4f}"
            cells.append(f"{c['triangles']:>3} {c['seconds']:>5.1f} {p:>6} "
                         f"{c['recall']:>5.3f} {c['above']:>4.2f}")
        lines.append(f"{r['name']:<12} {r['triangles']:>7,} | " + " | ".join(cells))
    return lines
