"""Conservative enforcement of the voxel-based candidate (Wu et al. 2022, sec. 3.1.2, eqs. 1-3).

References
----------
.. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (sec. 3.1.2, conservative enforcement, eqs. 1-3)
.. [2] Barill, G., Dickson, N., Schmidt, R., Levin, D. I. W., Jacobson, A.
   "Fast Winding Numbers for Soups and Clouds". ACM Transactions on Graphics
   37(4), 2018. :DOI:`10.1145/3197517.3201337` (the sign of the distance)
.. [3] Liu, D. C., Nocedal, J. "On the limited memory BFGS method for large
   scale optimization". Mathematical Programming 45, 1989, pp. 503-528.
   :DOI:`10.1007/BF01589116`
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass

import numpy as np
import trimesh

__all__ = ["SignedDistanceGrid", "enforce_conservative", "enforcement_energy"]

#: Tolerance of the enforcement: a vertex may stay outside the isosurface by at
#: most this fraction of the grid pitch (the field's own interpolation error
#: near the surface is of this order).
TOLERANCE = 0.05

#: Penalty weight of a newly colliding point, and its multiplier each time the
#: point is found outside again (the paper's repeated terms). The springs have
#: stiffness 1 in grid units, so a weight of 10 holds a point within a tenth of
#: the spring force; the moving targets (offsets) do the rest, as multiplier
#: updates of an augmented Lagrangian would, without a stiff problem.
WEIGHT_START = 10.0
WEIGHT_GROWTH = 4.0

#: Enforcement rounds (solve, check with the exact distance, reweight).
MAX_ROUNDS = 6

#: Largest inward target of a point, in units of the grid pitch: a wall of the
#: isosurface one voxel thick has no point deeper than about half a pitch.
MAX_OFFSET = 0.5

#: L-BFGS-B iterations per round, and its projected-gradient tolerance (grid
#: units: the trilinear field has kinks at cell faces, so tighter tolerances
#: only spend iterations on them).
MAX_ITERATIONS = 200
GRADIENT_TOLERANCE = 1e-4


@contextlib.contextmanager
def _one_blas_thread():
    """Run scipy's OpenBLAS on one thread inside the block (restored after).

    L-BFGS-B's small dense steps (n ~ 100s) pay OpenBLAS's thread hand-off on
    every iteration: four to five times slower on a loaded two-core machine
    (measured). This is what ``threadpoolctl.threadpool_limits(1)`` does, for
    the one library involved; where scipy's OpenBLAS is not found it does
    nothing.
    """
    import ctypes
    from pathlib import Path

    import scipy

    lib = None
    with contextlib.suppress(OSError, AttributeError, IndexError):
        libs = sorted((Path(scipy.__file__).parent.parent / "scipy.libs").glob(
            "libscipy_openblas*.so*"))
        lib = ctypes.CDLL(str(libs[0]))
        previous = int(lib.scipy_openblas_get_num_threads())
    if lib is None:
        yield
        return
    lib.scipy_openblas_set_num_threads(1)
    try:
        yield
    finally:
        lib.scipy_openblas_set_num_threads(previous)


@dataclass(frozen=True)
class SignedDistanceGrid:
    """Signed distance to the isosurface sampled on a regular grid, trilinear in between.

    Attributes
    ----------
    origin : (3,) float64
        World position of sample (0, 0, 0).
    pitch : float
        Sample spacing, world units.
    values : (nx, ny, nz) float64
        Signed distance in units of ``pitch``, negative inside.
    """

    origin: np.ndarray
    pitch: float
    values: np.ndarray

    @classmethod
    def of_mesh(cls, vertices: np.ndarray, faces: np.ndarray, origin: np.ndarray,
                pitch: float, shape: tuple) -> SignedDistanceGrid:
        """Sample libigl's signed distance (winding-number sign) of a closed mesh on a grid."""
        import igl

        axes = [origin[i] + pitch * np.arange(shape[i]) for i in range(3)]
        pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        s = igl.signed_distance(np.ascontiguousarray(pts), np.ascontiguousarray(vertices),
                                np.ascontiguousarray(faces, dtype=np.int64),
                                sign_type=igl.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER)[0]
        return cls(np.asarray(origin, dtype=np.float64), float(pitch),
                   np.asarray(s, dtype=np.float64).reshape(shape) / pitch)

    def __call__(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Interpolated distance and its gradient at points given in pitch units.

        Parameters
        ----------
        points : (m, 3) float64
            Positions in grid units (world minus ``origin``, over ``pitch``).
            Beyond the grid: the value at the nearest grid point plus the
            distance to it.

        Returns
        -------
        phi : (m,) float64
            Pitch units.
        grad : (m, 3) float64
        """
        v = self.values
        top = np.array(v.shape, dtype=np.float64) - 1
        # beyond the grid: the distance at the nearest grid point plus the way there
        # (an upper bound of the distance whose gradient points back to the grid)
        inside = np.clip(points, 0.0, top)
        away = points - inside
        gap = np.linalg.norm(away, axis=1)
        i0 = np.minimum(np.floor(inside).astype(np.int64), v.shape[0:3] - np.array(2))
        t = inside - i0
        x, y, z = i0[:, 0], i0[:, 1], i0[:, 2]
        c = np.empty((len(points), 2, 2, 2))
        for a in (0, 1):
            for b in (0, 1):
                for d in (0, 1):
                    c[:, a, b, d] = v[x + a, y + b, z + d]
        tx, ty, tz = t[:, 0, None, None], t[:, 1, None], t[:, 2]
        # collapse x, then y, then z; gradients by the product rule of the same steps
        cx = c[:, 0] * (1 - tx) + c[:, 1] * tx          # (m, 2, 2)
        dcx = c[:, 1] - c[:, 0]
        cy = cx[:, 0] * (1 - ty) + cx[:, 1] * ty        # (m, 2)
        dcy = cx[:, 1] - cx[:, 0]
        dxy = dcx[:, 0] * (1 - ty) + dcx[:, 1] * ty     # d(cy)/dtx, (m, 2)
        phi = cy[:, 0] * (1 - tz) + cy[:, 1] * tz + gap
        grad = np.stack([dxy[:, 0] * (1 - tz) + dxy[:, 1] * tz,
                         dcy[:, 0] * (1 - tz) + dcy[:, 1] * tz,
                         cy[:, 1] - cy[:, 0]], axis=1)
        grad[away != 0] = 0.0
        outside = gap > 0
        grad[outside] += away[outside] / gap[outside, None]
        return phi, grad


def _sample_matrix(n_vertices: int, faces: np.ndarray, edges: np.ndarray, interior: bool):
    """Sparse ``(m, n)`` barycentric weights: vertices, then (``interior``) edge midpoints
    and face centroids."""
    from scipy.sparse import coo_matrix, vstack

    eye = coo_matrix((np.ones(n_vertices), (np.arange(n_vertices), np.arange(n_vertices))),
                     shape=(n_vertices, n_vertices))
    if not interior:
        return eye.tocsr()
    ne, nf = len(edges), len(faces)
    mid = coo_matrix((np.full(2 * ne, 0.5), (np.repeat(np.arange(ne), 2), edges.reshape(-1))),
                     shape=(ne, n_vertices))
    cen = coo_matrix((np.full(3 * nf, 1 / 3), (np.repeat(np.arange(nf), 3), faces.reshape(-1))),
                     shape=(nf, n_vertices))
    return vstack([eye, mid, cen]).tocsr()


def enforcement_energy(x: np.ndarray, edges: np.ndarray, rest: np.ndarray, samples,
                       field: SignedDistanceGrid, weights: np.ndarray,
                       offsets: np.ndarray) -> tuple[float, np.ndarray]:
    """Spring energy (eq. 1) plus the weighted SDF penalty (eqs. 2-3), and its gradient.

    Parameters
    ----------
    x : (3 n,) float64
        Vertex positions in grid units, flattened.
    edges : (e, 2) int64
        Springs.
    rest : (e,) float64
        Rest lengths r, grid units.
    samples : scipy.sparse matrix, (m, n)
        Barycentric weights of the penalised points.
    field : SignedDistanceGrid
    weights : (m,) float64
        Penalty weight of each point (0: not colliding).
    offsets : (m,) float64
        Inward target of each point, grid units: the penalty is
        ``w / 2 max(phi + offset, 0)^2``.

    Returns
    -------
    energy : float
    grad : (3 n,) float64
    """
    pos = x.reshape(-1, 3)
    d = pos[edges[:, 0]] - pos[edges[:, 1]]
    length = np.linalg.norm(d, axis=1)
    stretch = length - rest
    energy = 0.5 * float(stretch @ stretch)
    force = (stretch / np.maximum(length, 1e-300))[:, None] * d
    grad = np.zeros_like(pos)
    np.add.at(grad, edges[:, 0], force)
    np.subtract.at(grad, edges[:, 1], force)
    active = np.flatnonzero(weights > 0)
    if len(active):
        sub = samples[active]
        phi, g = field(sub @ pos)
        excess = np.maximum(phi + offsets[active], 0.0)
        energy += 0.5 * float(weights[active] @ (excess * excess))
        grad += sub.T @ ((weights[active] * excess)[:, None] * g)
    return energy, grad.reshape(-1)


def enforce_conservative(coarse: trimesh.Trimesh, iso: trimesh.Trimesh, *, origin: np.ndarray,
                         pitch: float, shape: tuple, tolerance: float = TOLERANCE,
                         interior_points: bool = False) -> tuple[trimesh.Trimesh, dict]:
    """Push the coarse mesh inside the isosurface (eqs. 1-3 of the module docstring).

    Parameters
    ----------
    coarse : trimesh.Trimesh
        The simplified isosurface M_coarse.
    iso : trimesh.Trimesh
        The closed, outward-oriented isosurface.
    origin : (3,) float64
        World position of the isosurface grid's first sample.
    pitch : float
        Grid spacing, world units.
    shape : tuple of 3 int
        Grid sample counts.
    tolerance : float, optional
        Allowed excess outside the isosurface, in units of ``pitch``
        (default :data:`TOLERANCE`).
    interior_points : bool, optional
        Penalise edge midpoints and face centroids too, not only vertices
        (default False: on thin-walled isosurfaces a coarse face spanning a
        window has no position with its centroid inside, and the penalty on
        it drags its vertices out of the wall).

    Returns
    -------
    enforced : trimesh.Trimesh
        Same faces, moved vertices.
    info : dict
        ``rounds``, ``iterations`` and ``evaluations`` (L-BFGS-B, summed),
        ``outside_before`` and ``outside_after`` (vertices outside
        by more than the tolerance, exact distance), ``max_sdf_before`` and
        ``max_sdf_after`` (world units), ``seconds_field``.
    """
    import time

    import igl
    from scipy.optimize import minimize

    start = time.perf_counter()
    iso_v = np.asarray(iso.vertices, dtype=np.float64)
    iso_f = np.asarray(iso.faces, dtype=np.int64)
    field = SignedDistanceGrid.of_mesh(iso_v, iso_f, origin, pitch, shape)
    seconds_field = time.perf_counter() - start
    faces = np.asarray(coarse.faces, dtype=np.int64)
    pos = (np.asarray(coarse.vertices, dtype=np.float64) - origin) / pitch
    n = len(pos)
    edges = np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]],
                                              faces[:, [2, 0]]]), axis=1), axis=0)
    rest = np.linalg.norm(pos[edges[:, 0]] - pos[edges[:, 1]], axis=1)
    samples = _sample_matrix(n, faces, edges, interior_points)
    m = samples.shape[0]
    weights = np.zeros(m)
    offsets = np.zeros(m)

    def exact(p: np.ndarray) -> np.ndarray:
        world = np.ascontiguousarray(p * pitch + origin)
        s = igl.signed_distance(world, iso_v, iso_f,
                                sign_type=igl.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER)[0]
        return np.asarray(s) / pitch

    phi_exact = exact(samples @ pos)
    before = phi_exact[:n].copy()
    best = (float(np.maximum(phi_exact, 0.0).max()), pos, phi_exact)
    rounds = iterations = evaluations = 0
    while rounds < MAX_ROUNDS:
        outside = phi_exact > tolerance
        if not outside.any():
            break
        rounds += 1
        # a new collision enters with weight 1; a repeated one counts WEIGHT_GROWTH times more
        weights[outside] = np.where(weights[outside] > 0, weights[outside] * WEIGHT_GROWTH,
                                    WEIGHT_START)
        # aim half a tolerance inside; a point found outside again aims further in by its excess
        interp = field(samples[np.flatnonzero(outside)] @ pos)[0]
        offsets[outside] += np.maximum(phi_exact[outside] - interp, 0.0) + 0.5 * tolerance
        np.minimum(offsets, MAX_OFFSET, out=offsets)
        with _one_blas_thread():
            res = minimize(enforcement_energy, pos.reshape(-1), jac=True, method="L-BFGS-B",
                           args=(edges, rest, samples, field, weights, offsets),
                           options={"maxiter": MAX_ITERATIONS, "gtol": GRADIENT_TOLERANCE})
        pos = res.x.reshape(-1, 3)
        iterations += int(res.nit)
        evaluations += int(res.nfev)
        phi_exact = exact(samples @ pos)
        excess = float(np.maximum(phi_exact, 0.0).max())
        if excess < best[0]:
            best = (excess, pos, phi_exact)
    # the round whose worst point is least outside (a penalty round can make it worse
    # where a thin wall has no room for a point's target)
    _, pos, phi_exact = best
    after = phi_exact[:n]
    out = trimesh.Trimesh(pos * pitch + origin, faces, process=False)
    info = {"rounds": rounds, "iterations": iterations, "evaluations": evaluations,
            "outside_before": int((before > tolerance).sum()),
            "outside_after": int((after > tolerance).sum()),
            "max_sdf_before": float(before.max() * pitch) if n else 0.0,
            "max_sdf_after": float(after.max() * pitch) if n else 0.0,
            "seconds_field": seconds_field}
    return out, info
