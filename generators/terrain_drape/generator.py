"""Terrain drape: a few triangles just under an open height field (terrain, a floor, a street).

For the open sheets that planar sections (sec. 4 of the planar-sections paper
[1]_) cannot slice; beyond the papers.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (sec. 4, Table 1's TERRAIN row)
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np
import trimesh
from scipy import ndimage

from viscore._validate import as_positive_int
from viscore.level.ground import UP_AXES, guess_up

from .._precision_check import DEFAULT_MIN_PRECISION, check_score, check_views, passes
from ..occluder import Occluder
from ._envelope import hidden_floor
from ._fit import fit_drape
from ._heights import lowest_surface
from ._line_check import escaping_lines

__all__ = ["generate_terrain_drape", "DEFAULT_BUDGET", "RESOLUTION", "MARGIN", "INSETS", "SHAPES"]

_log = logging.getLogger(__name__)

#: Triangles when no budget is given.
DEFAULT_BUDGET = 64
#: Grid points along each side of a square footprint (about RESOLUTION^2 over any).
RESOLUTION = 192
#: Shell margin at both bounds, in grid spacings (world units: MARGIN x spacing).
MARGIN = 0.02
#: Insets of the drape's rectangle from the footprint's bounding box, as
#: fractions of its sides: the shell pinches to nothing at the rim.
INSETS = (0.005, 0.01, 0.02, 0.035, 0.05, 0.075, 0.1, 0.15)
#: Quad grids tried per inset (the largest counts within the budget, closest
#: to the footprint's shape first).
SHAPES = 3
#: Fewest height samples per quad of a grid (a larger budget than the samples can check
#: gets fewer quads).
SAMPLES_PER_QUAD = 16


def _empty() -> trimesh.Trimesh:
    return trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), process=False)


def _shapes(quads: int, aspect: float, count: int) -> list[tuple[int, int]]:
    """Quad grids (nx, ny) of at most ``quads`` quads, fullest and best-shaped first.

    >>> _shapes(11, 1.0, 3)
    [(2, 5), (5, 2), (3, 3)]
    """
    if quads < 1:
        return []
    pairs = {(nx, quads // nx) for nx in range(1, quads + 1)}  # the fullest ny for each nx
    pairs |= {(ny, nx) for nx, ny in pairs}

    def misfit(p):
        return abs(math.log(p[0] / p[1]) - math.log(aspect))

    ordered = sorted(pairs, key=lambda p: (-p[0] * p[1], misfit(p), p))
    good = [p for p in ordered if misfit(p) <= math.log(2.5)]
    return (good or ordered)[:count]


class _Footprint:
    """The footprint's bounding box in grid coordinates and the drapes fitted over it,
    by quad grid and per-side insets (indices into :data:`INSETS`: -x, +x, -y, +y)."""

    def __init__(self, grid, low, high, budget: int) -> None:
        ii, jj = np.nonzero(grid.mask)
        self.lo = np.array([ii.min(), jj.min()], float)
        self.hi = np.array([ii.max(), jj.max()], float)
        self.side = np.maximum(self.hi - self.lo, 1.0)
        # two triangles per quad, and at least SAMPLES_PER_QUAD samples under each quad
        quads = min(budget // 2, int(grid.mask.sum()) // SAMPLES_PER_QUAD)
        self.shapes = _shapes(quads, float(self.side[0] / self.side[1]), SHAPES)
        self.low, self.high = low, high
        self._fits: dict = {}

    def fit(self, shape: tuple[int, int], insets: tuple[int, int, int, int]):
        """The drape of ``shape`` over the rectangle of ``insets``, or None (cached)."""
        key = (shape, insets)
        if key not in self._fits:
            f = np.array([INSETS[k] for k in insets])
            lo = self.lo + f[[0, 2]] * self.side
            hi = self.hi - f[[1, 3]] * self.side
            self._fits[key] = fit_drape(self.low, self.high, lo, hi, *shape)
        return self._fits[key]


def _mesh(grid, drape, faces=None) -> trimesh.Trimesh:
    out = trimesh.Trimesh(grid.points(drape.corners, drape.heights),
                          drape.triangles if faces is None else faces, process=False)
    out.remove_unreferenced_vertices()
    return out


def generate_terrain_drape(mesh: trimesh.Trimesh, *, budget: int | None = None, seed: int = 0,
                           mode: str = "measured", min_precision: float = DEFAULT_MIN_PRECISION,
                           up: str = "auto", resolution: int = RESOLUTION,
                           reach: int = 3) -> Occluder:
    """A drape of at most ``budget`` triangles under an open height field (module docstring).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        A terrain sheet, a floor, a level's ground: open, seen once from below.
    budget : int, optional
        Most triangles (default :data:`DEFAULT_BUDGET`).
    seed : int
        Seeds the check views (``measured``) or the line check (``hidden``).
    mode : {'measured', 'hidden'}
        Keep the drape of best check recall at ``min_precision``, or only
        what every line through it shows covered (module docstring, step 3).
    min_precision : float
        The check's floor in ``measured`` mode.
    up : {'auto', 'x', 'y', 'z'}
        The up axis; ``auto`` guesses it (:func:`viscore.level.ground.guess_up`).
    resolution : int
        Height samples along each side of a square footprint (about
        ``resolution^2`` over any footprint).
    reach : int
        Lattice directions of the hidden floor (``max(|a|, |b|) <= reach``).

    Returns
    -------
    Occluder
        Double-sided triangles; ``info``: ``up``, ``grid`` (quads and inset of
        the one kept), ``held`` (its share of the footprint's samples);
        ``measured``: ``check`` (its check precision, standard error and
        recall) and ``tried`` (candidates scored); ``hidden``: ``shell``
        (share of the footprint with room above the hidden floor) and
        ``escaping`` (lines that met nothing, per dropped triangle);
        ``reason`` when the occluder is empty.

    Examples
    --------
    >>> from viscore import load_mesh
    >>> occ = generate_terrain_drape(load_mesh("terrain"), budget=23)  # doctest: +SKIP
    >>> occ.triangles, occ.info["check"]["precision"] >= 0.995  # doctest: +SKIP
    (20, True)
    """
    start = time.perf_counter()
    budget = DEFAULT_BUDGET if budget is None else as_positive_int(budget, "budget")
    params = {"mode": mode, "min_precision": min_precision, "up": up,
              "resolution": resolution, "reach": reach}
    up_name = guess_up(mesh, level=True)[0] if up == "auto" else up
    grid = lowest_surface(mesh, UP_AXES.index(up_name), resolution)
    info: dict = {"up": up_name}

    def done(out: trimesh.Trimesh, reason: str | None = None) -> Occluder:
        if reason:
            info["reason"] = reason  # the caller says it (generate's error line, the manifest)
        return Occluder(out, "terrain-drape", params, True, time.perf_counter() - start,
                        info=info)

    if grid.mask.sum() < 4:
        return done(_empty(), "no surface seen from below along " + up_name)
    h = np.where(grid.mask, grid.heights, -np.inf)
    high = ndimage.minimum_filter(h, size=3, mode="constant", cval=-np.inf) \
        - MARGIN * grid.spacing
    if mode == "hidden":
        g = hidden_floor(np.nan_to_num(grid.heights), grid.mask, reach=reach)
        low = ndimage.maximum_filter(np.where(grid.mask, g, np.inf), size=3,
                                     mode="constant", cval=np.inf) + MARGIN * grid.spacing
        info["shell"] = float((grid.mask & (low < high)).sum() / grid.mask.sum())
    else:
        low = np.full(h.shape, -np.inf)
    foot = _Footprint(grid, low, high, budget)
    if not foot.shapes:
        return done(_empty(), f"the footprint has too few height samples "
                    f"({int(grid.mask.sum())}) for a grid of quads")
    if mode == "hidden":
        found = [(d, shape, INSETS[k]) for shape in foot.shapes for k in range(len(INSETS))
                 if (d := foot.fit(shape, (k,) * 4)) is not None]
        if not found:
            return done(_empty(), "the shell above the hidden floor holds no triangle")
        drape, shape, inset = max(found, key=lambda c: c[0].samples)
        vertices = grid.points(drape.corners, drape.heights)
        escaping = escaping_lines(mesh, vertices[drape.triangles], seed=seed)
        info.update(grid={"quads": list(shape), "inset": inset},
                    held=float(drape.samples / grid.mask.sum()),
                    escaping=[int(e) for e in escaping[escaping > 0]])
        if (escaping > 0).any():
            _log.info("terrain-drape: %d of %d triangles dropped: lines through them miss "
                      "the mesh", int((escaping > 0).sum()), len(escaping))
        return done(_mesh(grid, drape, drape.triangles[escaping == 0]))
    views = check_views(mesh, seed)
    tried: list[dict] = []

    def score(shape, insets):
        drape = foot.fit(shape, insets)
        if drape is None:
            return None
        out = _mesh(grid, drape)
        sc = check_score(views, out)
        tried.append({"quads": list(shape), "insets": [INSETS[k] for k in insets],
                      "triangles": len(out.faces), **{k: round(v, 5) for k, v in sc.items()}})
        return (sc, out, drape, shape, insets) if passes(sc, min_precision) else None

    good = []
    for shape in foot.shapes:
        # recall falls and precision rises with the inset: the first that passes is the
        # shape's best of the uniform insets
        for k in range(len(INSETS)):
            if (hit := score(shape, (k,) * 4)) is not None:
                good.append(hit)
                break
    if good:
        best = max(good, key=lambda c: (c[0]["recall"], -len(c[1].faces)))
        # then each side of the winner's rectangle moves out while the check passes
        insets = list(best[4])
        for side in range(4):
            while insets[side] > 0:
                trial = list(insets)
                trial[side] -= 1
                hit = score(best[3], tuple(trial))
                if hit is None or hit[0]["recall"] <= best[0]["recall"]:
                    break
                best, insets = hit, trial
    info["tried"] = tried
    if not tried:
        return done(_empty(), "no grid of quads holds a triangle: every height sample lies "
                    "within one sample of the footprint's rim or of a hole")
    if not good:
        top = max(t["precision"] for t in tried)
        return done(_empty(), f"no drape reaches the precision floor {min_precision} on the "
                    f"check views (best {top:.4f})")
    sc, out, drape, shape, insets = best
    info.update(grid={"quads": list(shape), "insets": [INSETS[k] for k in insets]},
                held=float(drape.samples / grid.mask.sum()), check=sc)
    return done(out)
