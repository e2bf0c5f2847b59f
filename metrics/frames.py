"""Where the evaluation protocols look from: the orbit window and the volume view positions.

The geometry both protocols share, below :class:`~viscore.metrics.ReferenceViews`
and the one-call protocols of :mod:`viscore.metrics.orbit` and
:mod:`viscore.metrics.volume` (which re-export these names):

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
"""

from __future__ import annotations

import numpy as np
import trimesh

from viscore import InputError, Scene, grid_positions, points_inside
from viscore._validate import as_positive, check_memory
from viscore.ray.enclosing_ball import minimum_enclosing_ball

__all__ = ["orbit_frame", "evaluation_box", "volume_positions"]

# Shared with the sibling modules (not user API): frusta_see_box, volume_positions_bytes.

# --------------------------------------------------------------------------- orbit
#: Extent of the orthographic window as a multiple of the enclosing sphere's
#: diameter (the orbit protocol's margin).
EXTENT_FACTOR = 1.01


def orbit_frame(mesh: trimesh.Trimesh | Scene) -> tuple[np.ndarray, float]:
    """Centre and window extent of the orbit protocol for an original mesh.

    Returns
    -------
    center : (3,) float64
        Centre of the smallest enclosing sphere of the vertices (flat and
        collinear meshes included, see :func:`viscore.ray.enclosing_ball.minimum_enclosing_ball`).
    extent : float
        Its diameter x 1.01, world units.
    """
    center, radius = minimum_enclosing_ball(mesh.vertices)
    return center, float(2 * radius * EXTENT_FACTOR)


# --------------------------------------------------------------------------- volume
#: Default view spacing as a fraction of the bounding-box diagonal (Wu et al. 2022, sec. 4.1).
SPACING_FRACTION = 0.04

#: Most grid positions of one evaluation (as :func:`viscore.grid_positions`).
MAX_GRID_POSITIONS = 50_000_000

#: Bytes per grid cell while the positions are chosen: the float64 grid, the
#: parity votes of the inside test (six rays per point) and the octree masks.
_BYTES_PER_CELL = 400


def evaluation_box(mesh: trimesh.Trimesh | Scene, *, spacing: float | None = None,
                   padding: float | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """The padded bounding box B' of the volume protocol and the view spacing dx.

    Returns
    -------
    lo, hi : (3,) float64
        The mesh's bounding box grown by ``padding`` on every side (default
        its smallest side, or dx if that is zero; Wu et al. 2022, sec. 4).
    dx : float
        ``spacing``, default 4% of the bounding-box diagonal (Wu et al. 2022, sec. 4.1).
    """
    lo, hi = np.asarray(mesh.bounds, dtype=np.float64)
    diag = float(np.linalg.norm(hi - lo))
    dx = SPACING_FRACTION * diag if spacing is None else as_positive(spacing, "spacing")
    smallest = float((hi - lo).min())
    pad = (smallest if smallest > 0 else dx) if padding is None else float(padding)
    if pad < 0 or not np.isfinite(pad):
        raise InputError(f"padding: expected a finite number >= 0, got {padding}")
    return lo - pad, hi + pad, dx


def _grid_counts(lo: np.ndarray, hi: np.ndarray, dx: float) -> np.ndarray:
    """Grid cells per axis as floats (no int64 overflow for absurd spacings)."""
    return np.maximum(1.0, np.ceil((hi - lo) / dx - 1e-9))


def volume_positions_bytes(mesh: trimesh.Trimesh, *, spacing: float | None = None,
                           padding: float | None = None) -> float:
    """Estimated peak bytes of :func:`volume_positions`; InputError past the grid limit."""
    box_lo, box_hi, dx = evaluation_box(mesh, spacing=spacing, padding=padding)
    cells = float(np.prod(_grid_counts(box_lo, box_hi, dx)))
    if not cells <= MAX_GRID_POSITIONS:
        raise InputError(f"spacing: {dx:g} gives {cells:.3g} grid positions "
                         f"(limit {MAX_GRID_POSITIONS:,}); use a larger spacing")
    return cells * _BYTES_PER_CELL


def volume_positions(mesh: trimesh.Trimesh, *, spacing: float | None = None,
                     padding: float | None = None, merge_views: bool = False,
                     scene=None, offset: np.ndarray | None = None, seed: int | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """View positions of the volume protocol and their volume weights.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The original.
    spacing : float, optional
        dx in world units; default 4% of the bounding-box diagonal.
    padding : float, optional
        Growth of the bounding box on every side, world units; default its
        smallest side (or dx if that is zero).
    merge_views : bool, optional
        Merge 2 x 2 x 2 blocks as an octree (Wu et al. 2022, sec. 3.3).
    scene : Scene, optional
        Scene of ``mesh``, to reuse.
    offset : (3,) float, optional
        Shift of the whole grid in units of dx, each in [-0.5, 0.5): a
        randomly shifted grid makes the positions an unbiased sample of the
        domain (used by the spacing ablation). Default: no shift.
    seed : int, optional
        With ``merge_views``: each merged block's position is one of its
        s^3 grid positions (all outside the mesh), drawn uniformly from
        ``default_rng([seed, 2, level])``, with weight s^3, so that the
        merged estimate is an unbiased estimate of the plain grid's answer;
        and only cells whose 26 neighbours are outside the mesh too merge
        (P_x varies most next to the mesh, where one sample per block would
        make the estimate's distribution skewed and its interval too
        narrow). None: the previous rule, one sample at the block centre (a
        midpoint rule, biased where P_x varies inside the block).

    Returns
    -------
    positions : (m, 3) float64
        World units, outside the mesh (:func:`viscore.points_inside`: signed
        crossings along six rays, the winding number where they disagree).
    weights : (m,) float64
        Block volume in grid cells (1, 8, 64, ...).
    """
    check_memory(volume_positions_bytes(mesh, spacing=spacing, padding=padding),
                 f"spacing={spacing}")
    scene = scene or Scene(mesh)
    box_lo, box_hi, dx = evaluation_box(mesh, spacing=spacing, padding=padding)
    pts = grid_positions(box_lo, box_hi, dx)
    if offset is not None:
        pts = pts + dx * np.asarray(offset, dtype=np.float64)
    counts = _grid_counts(box_lo, box_hi, dx).astype(np.int64)
    valid = ~points_inside(scene, pts).reshape(counts)
    first = pts[0]
    if not valid.any():  # no grid position outside the mesh (a needle thinner than dx, say)
        raise InputError(f"volume protocol: no view position outside the mesh at spacing "
                         f"{dx:.6g}; give a smaller spacing")
    if not merge_views:
        return pts[valid.ravel()], np.ones(int(valid.sum()))
    levels = [valid]
    if seed is not None:  # blocks keep one cell away from the mesh, where P_x varies most
        from scipy.ndimage import binary_erosion

        core = binary_erosion(valid, np.ones((3, 3, 3), bool), border_value=1)
    while True:
        child = core if len(levels) == 1 and seed is not None else levels[-1]
        half = np.array(child.shape) // 2
        if (half == 0).any():
            break
        c = child[: 2 * half[0], : 2 * half[1], : 2 * half[2]]
        parent = c.reshape(half[0], 2, half[1], 2, half[2], 2).all(axis=(1, 3, 5))
        if not parent.any():
            break
        size = 2 ** len(levels)
        idx = np.argwhere(parent)
        centres = first + (idx * size + (size - 1) / 2) * dx
        ok = ~points_inside(scene, centres)
        parent[tuple(idx[~ok].T)] = False  # type: ignore[index]
        levels.append(parent)  # type: ignore[arg-type]
    assigned = np.zeros(valid.shape, dtype=bool)
    out_pos, out_w = [], []
    for level in range(len(levels) - 1, -1, -1):
        size = 2**level
        idx = np.argwhere(levels[level])
        if len(idx) == 0:
            continue
        # a block is taken if none of its cells is taken yet (a parent's cells all are)
        lo_cell = idx * size
        taken = np.array([assigned[a:a + size, b:b + size, c:c + size].any()
                          for a, b, c in lo_cell]) if level else assigned[tuple(idx.T)]
        idx, lo_cell = idx[~taken], lo_cell[~taken]
        for a, b, c in lo_cell if level else ():
            assigned[a:a + size, b:b + size, c:c + size] = True
        if not level:
            assigned[tuple(idx.T)] = True
        if level and seed is not None:  # one of the block's grid positions, uniformly
            pick = np.random.default_rng([seed, 2, level]).integers(0, size, (len(idx), 3))
            centres = first + (lo_cell + pick) * dx
        else:
            centres = first + (lo_cell + (size - 1) / 2) * dx
        out_pos.append(centres)
        out_w.append(np.full(len(centres), float(size**3)))
    return np.concatenate(out_pos), np.concatenate(out_w)


def frusta_see_box(positions: np.ndarray, axes: np.ndarray, lo: np.ndarray, hi: np.ndarray
                    ) -> np.ndarray:
    """``(n, 6) bool``: False only where the box lies wholly outside a 90-degree frustum.

    Conservative (never False for a frustum that sees part of the box):
    the box is outside when all its corners are behind the eye or beyond one
    of the four side planes |lateral| = depth.
    """
    corners = np.array(np.meshgrid(*zip(lo, hi, strict=True), indexing="ij")).reshape(3, -1).T
    rel = corners[None, :, :] - positions[:, None, :]  # (n, 8, 3)
    out = np.ones((len(positions), len(axes)), dtype=bool)
    for f, forward in enumerate(axes):
        axis = int(np.argmax(np.abs(forward)))
        depth = np.sign(forward[axis]) * rel[:, :, axis]
        hidden = (depth <= 0).all(axis=1)
        for b in (k for k in range(3) if k != axis):
            hidden |= (rel[:, :, b] > depth).all(axis=1) | (-rel[:, :, b] > depth).all(axis=1)
        out[:, f] = ~hidden
    return out
