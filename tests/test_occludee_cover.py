"""The occludee test's cover rule (``viscore.culling._occludee_cover``): a triangle hidden in
a pixel that the depth test fails, by occluder triangles it lies behind covering the pixel or
every part of it the triangle reaches."""

import numpy as np
import pytest
import trimesh

from viscore import PerspectiveCamera
from viscore.culling.depth_buffer import ConservativeDepthBuffer, OccluderScene

#: A 64 x 36 camera at the origin looking along +z, y up: a 16 x 9 buffer, 90 degrees wide
#: (y / z spans [-0.5625, 0.5625]; buffer row 4 spans y / z in [-0.0625, 0.0625]).
CAM = PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 1, 0), fov=90, resolution=64, height=36)
W, H = 16, 9


def _culled(occluder, triangles, *, rule=True):
    """Whether each triangle (one group each) is culled in CAM's 16 x 9 buffer of
    ``occluder``, with the cover rule on or off."""
    tri = np.asarray(triangles, dtype=np.float64)
    occ = OccluderScene([occluder])
    occ._cover_rule = rule
    buf = ConservativeDepthBuffer.from_occluders(occ, CAM, width=W, height=H)
    return buf.occluded_triangles(tri, np.arange(len(tri) + 1))


def _first_hits(mesh, d):
    """Distance along unit rays ``d`` from the origin to ``mesh``'s nearest triangle (inf: a
    miss), exact in float64 (Moller-Trumbore over every triangle)."""
    tri = np.asarray(mesh.triangles, dtype=np.float64)
    best = np.full(len(d), np.inf)
    for a, b, c in tri:  # a loop over the few triangles of a test occluder
        t = _hits(a, b, c, d)
        best = np.minimum(best, t)
    return best


def _hits(a, b, c, d):
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = p @ e1
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = -a
        uu = (p @ s) * inv
        q = np.cross(s, e1)
        vv = (d @ q) * inv
        t = (q @ e2) * inv
    ok = (np.abs(det) > 1e-14) & (uu >= 0) & (vv >= 0) & (uu + vv <= 1) & (t > 0)
    return np.where(ok, t, np.inf)


def _rays(y0, y1, x0, x1, n):
    """Unit rays from the origin through an n x n grid of the screen window
    x / z in [x0, x1], y / z in [y0, y1]."""
    x, y = np.meshgrid(np.linspace(x0, x1, n), np.linspace(y0, y1, n))
    d = np.stack([x.ravel(), y.ravel(), np.ones(x.size)], axis=1)
    return d / np.linalg.norm(d, axis=1)[:, None]


def _wall(top):
    """A wall at z = 5 across the view, from y = -10 up to ``y = top``."""
    v = np.array([[-10, -10, 5], [10, -10, 5], [10, top, 5], [-10, top, 5]], dtype=float)
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


def _small(top, bottom, z):
    """A small upright triangle at depth ``z`` whose projection spans y / z from ``bottom``
    to ``top`` (x / z within +-0.02)."""
    return [[-0.02 * z, bottom * z, z], [0.02 * z, bottom * z, z], [0.0, top * z, z]]


def test_a_triangle_below_a_walls_edge_in_the_edges_pixel_is_culled_by_the_cover_rule():
    """The wall's top edge crosses buffer row 4 at its middle (y / z = 0): the row's
    pixels are half sky and hold no depth. A triangle behind the wall whose projection stays
    under the edge (y / z from -0.05 to -0.02) lies in the covered half only: the depth test
    keeps it, the cover rule culls it, and no ray under the edge reaches it first."""
    wall = _wall(0.0)
    tri = _small(-0.02, -0.05, 8.0)
    assert not _culled(wall, [tri], rule=False)[0]
    assert _culled(wall, [tri], rule=True)[0]
    d = _rays(-0.06, 0.06, -0.05, 0.05, 121)
    seen = _hits(*np.asarray(tri, dtype=float), d) < _first_hits(wall, d)
    assert not seen.any()


@pytest.mark.parametrize("top", [0.004, 0.02])
def test_a_triangle_reaching_above_the_walls_edge_is_kept(top):
    """The same triangle raised to reach a sliver (under an eighth of a pixel: 0.004 of
    0.125 per pixel) or more above the wall's edge, where the pixel shows sky: it is
    visible there, and the cover rule keeps it."""
    wall = _wall(0.0)
    tri = _small(top, -0.05, 8.0)
    assert not _culled(wall, [tri], rule=True)[0]
    d = _rays(-0.06, 0.06, -0.05, 0.05, 241)
    seen = _hits(*np.asarray(tri, dtype=float), d) < _first_hits(wall, d)
    assert seen.any()


def _corrugated(amplitude):
    """A ground at y = -1 from z = 2 to z = 40 in strips 0.5 deep, its height alternating
    by ``amplitude`` at the strips' edges: no two neighbouring strips coplanar."""
    z = np.arange(2.0, 40.01, 0.5)
    y = -1.0 - amplitude * (np.arange(len(z)) % 2)
    v = np.concatenate([np.stack([np.full_like(z, -40.0), y, z], axis=1),
                        np.stack([np.full_like(z, 40.0), y, z], axis=1)])
    n = len(z)
    faces = [f for k in range(n - 1)
             for f in ([k, k + 1, n + k + 1], [k, n + k + 1, n + k])]
    return trimesh.Trimesh(v, faces, process=False)


def test_a_triangle_under_a_corrugated_ground_seen_at_a_grazing_angle_is_culled():
    """A flat triangle 0.05 under a corrugated ground (strips tilted by 0.002 in turn) at
    depth 10: its pixel (row 5) sees the ground from z = 5.3 to 16, so its farthest depth is
    beyond the triangle, and twenty-odd strip planes cross it, so no single plane covers it.
    Every strip plane lies above the triangle by more than the depth margin: the cover rule
    culls it; no ray reaches it before the ground."""
    ground = _corrugated(0.001)
    tri = [[-0.2, -1.05, 9.8], [0.2, -1.05, 9.8], [0.0, -1.05, 10.2]]
    assert not _culled(ground, [tri], rule=False)[0]
    assert _culled(ground, [tri], rule=True)[0]
    d = _rays(-0.115, -0.095, -0.03, 0.03, 101)
    seen = _hits(*np.asarray(tri, dtype=float), d) < _first_hits(ground, d)
    assert not seen.any()


def test_a_triangle_touching_the_occluder_is_kept():
    """A triangle behind the wall with one edge lying on the wall's plane (attached to
    it): no part of it is behind the wall by the depth margin there, and the rule keeps
    it, as the depth test does."""
    wall = _wall(0.0)
    tri = [[-0.1, -0.3, 5.0], [0.1, -0.3, 5.0], [0.0, -0.1, 5.5]]
    assert not _culled(wall, [tri], rule=True)[0]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_cover_rule_never_culls_a_triangle_a_dense_ray_grid_sees(seed):
    """Random occluders (a dozen large triangles at depths 4-7, leaving gaps and edges
    across pixels) and 200 small triangles behind them at depths 4.5-9: every triangle
    culled is met by no ray of a 33 x 33 grid per buffer pixel over its window before the
    occluders; and the rule culls more than the depth test alone."""
    rng = np.random.default_rng(seed)
    centre = rng.uniform([-3, -2, 4], [3, 2, 7], size=(12, 1, 3))
    occ_tri = centre + rng.uniform(-2.5, 2.5, size=(12, 3, 3)) * [1, 1, 0.4]
    occluder = trimesh.Trimesh(occ_tri.reshape(-1, 3), np.arange(36).reshape(12, 3),
                               process=False)
    c = rng.uniform([-3, -1.5, 4.5], [3, 1.5, 9], size=(200, 1, 3))
    small = c + rng.uniform(-0.08, 0.08, size=(200, 3, 3))
    with_rule = _culled(occluder, small, rule=True)
    without = _culled(occluder, small, rule=False)
    assert (with_rule >= without).all()
    assert with_rule.sum() > without.sum()
    for k in np.flatnonzero(with_rule & ~without):
        t = small[k]
        x, y = t[:, 0] / t[:, 2], t[:, 1] / t[:, 2]
        d = _rays(y.min(), y.max(), x.min(), x.max(), 33)
        seen = _hits(*t, d) < _first_hits(occluder, d)
        assert not seen.any(), k
