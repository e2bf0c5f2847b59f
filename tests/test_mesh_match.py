"""metrics/mesh_match.py: exact triangle matches and point-to-surface distances, on
hand-built squares and grids with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from viscore import InputError
from viscore.metrics import match_triangles, surface_distance

SQUARE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
SQUARE_F = np.array([[0, 1, 2], [0, 2, 3]])


def test_match_triangles_ignores_order_and_orientation():
    perm = np.array([2, 0, 3, 1])  # new vertex k is old vertex perm[k]
    where = np.argsort(perm)
    v = SQUARE_V[perm]
    f = where[SQUARE_F][::-1][:, [2, 1, 0]]  # triangles swapped and flipped
    a, b = match_triangles(v, f, SQUARE_V, SQUARE_F, 1e-4)
    assert a.all() and b.all()
    # the other diagonal covers the same square with other triangles: no match
    a, b = match_triangles(SQUARE_V, np.array([[0, 1, 3], [1, 2, 3]]), SQUARE_V, SQUARE_F, 1e-4)
    assert not a.any() and not b.any()


def test_match_triangles_tolerance_and_duplicates():
    moved = SQUARE_V.copy()
    moved = np.vstack([moved, moved[[0]] + [0, 0, 1e-2]])  # a copy of vertex 0, lifted
    f = np.array([[0, 1, 2], [4, 2, 3]])
    a, b = match_triangles(moved, f, SQUARE_V, SQUARE_F, 1e-4)
    assert a.tolist() == [True, False] and b.tolist() == [True, False]
    moved[4] = SQUARE_V[0] + [0, 1e-5, 0]  # within the tolerance
    a, b = match_triangles(moved, f, SQUARE_V, SQUARE_F, 1e-4)
    assert a.all() and b.all()
    twice = np.array([[0, 1, 2], [2, 1, 0]])  # the same triangle twice against once
    a, b = match_triangles(SQUARE_V, twice, SQUARE_V, SQUARE_F, 1e-4)
    assert a.sum() == 1 == b.sum() and b.tolist() == [True, False]


# ----------------------------------------------------------------------------- distances


def test_surface_distance_is_exact_on_a_square():
    rng = np.random.default_rng(1)
    inside = np.column_stack([rng.uniform(0, 1, 50), rng.uniform(0, 1, 50),
                              rng.uniform(-2, 2, 50)])
    np.testing.assert_allclose(surface_distance(inside, SQUARE_V, SQUARE_F),
                               np.abs(inside[:, 2]), atol=1e-12)
    beside = np.column_stack([1 + rng.uniform(0.1, 1, 50), rng.uniform(0, 1, 50),
                              rng.uniform(-1, 1, 50)])
    np.testing.assert_allclose(surface_distance(beside, SQUARE_V, SQUARE_F),
                               np.hypot(beside[:, 0] - 1, beside[:, 2]), atol=1e-12)
    corner = np.array([[2.0, 3.0, 1.0]])
    np.testing.assert_allclose(surface_distance(corner, SQUARE_V, SQUARE_F), [np.sqrt(6.0)])
    # one candidate per point suffices for the estimate's nearest triangle
    np.testing.assert_allclose(surface_distance(inside, SQUARE_V, SQUARE_F, candidates=1),
                               np.abs(inside[:, 2]), atol=1e-12)


def test_surface_distance_far_from_the_origin_picks_the_right_triangle():
    # a fine grid a million units out: squared distances there lose ~1e-3, more than the
    # 1e-2 cells' spread; centred coordinates keep the estimate's nearest triangle right
    n, cell = 20, 0.01
    x, y = np.meshgrid(np.arange(n + 1) * cell, np.arange(n + 1) * cell, indexing="ij")
    shift = np.array([1e6, -2e6, 1.5e6])
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)]) + shift
    k = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    f = np.concatenate([np.column_stack([k, k + n + 1, k + n + 2]),
                        np.column_stack([k, k + n + 2, k + 1])])
    rng = np.random.default_rng(2)
    points = np.column_stack([rng.uniform(0, n * cell, 40), rng.uniform(0, n * cell, 40),
                              np.full(40, 1e-6)]) + shift
    np.testing.assert_allclose(surface_distance(points, v, f, candidates=1), 1e-6, rtol=1e-3)




def test_match_triangles_empty_sides_match_nothing():
    a, b = match_triangles(SQUARE_V, np.zeros((0, 3), int), SQUARE_V, SQUARE_F, 1e-4)
    assert a.shape == (0,) and b.tolist() == [False, False]


@pytest.mark.parametrize("args, match", [
    ((SQUARE_V, SQUARE_F, SQUARE_V, SQUARE_F, 0.0), "tolerance"),
    ((SQUARE_V, SQUARE_F, SQUARE_V, SQUARE_F, float("nan")), "tolerance"),
    ((SQUARE_V, SQUARE_F + 2, SQUARE_V, SQUARE_F, 1e-4), "a_faces"),
    ((SQUARE_V, SQUARE_F, SQUARE_V[:, :2], SQUARE_F, 1e-4), "b_vertices"),
    ((SQUARE_V, SQUARE_F * 0.5, SQUARE_V, SQUARE_F, 1e-4), "a_faces"),
    ((np.where(SQUARE_V == 1, np.inf, SQUARE_V), SQUARE_F, SQUARE_V, SQUARE_F, 1e-4),
     "a_vertices"),
])
def test_match_triangles_invalid_input(args, match):
    with pytest.raises(InputError, match=match):
        match_triangles(*args)


@pytest.mark.parametrize("kwargs, match", [
    ({"faces": np.zeros((0, 3), int)}, "no triangles"),
    ({"faces": SQUARE_F - 1}, "faces"),
    ({"points": [[0.0, 0.0]]}, "points"),
    ({"points": [[0.0, np.nan, 0.0]]}, "points"),
    ({"candidates": 0}, "candidates"),
    ({"pairs_per_pass": 0}, "pairs_per_pass"),
])
def test_surface_distance_invalid_input(kwargs, match):
    args = {"points": [[0.0, 0.0, 1.0]], "vertices": SQUARE_V, "faces": SQUARE_F, **kwargs}
    with pytest.raises(InputError, match=match):
        surface_distance(args.pop("points"), args.pop("vertices"), args.pop("faces"), **args)
