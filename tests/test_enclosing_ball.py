import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.ray.enclosing_ball import minimum_enclosing_ball


def test_minimum_enclosing_ball_unit_square_is_its_circumcircle():
    c, r = minimum_enclosing_ball([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    np.testing.assert_allclose(c, [0.5, 0.5, 0.0], atol=1e-12)
    assert r == pytest.approx(np.sqrt(0.5), rel=1e-12)


def test_minimum_enclosing_ball_obtuse_triangle_is_on_its_longest_edge():
    # the circumcircle of an obtuse triangle is not the smallest enclosing circle
    c, r = minimum_enclosing_ball([[0, 0, 5], [4, 0, 5], [2, 0.1, 5]])
    np.testing.assert_allclose(c, [2, 0, 5], atol=1e-12)
    assert r == pytest.approx(2.0, rel=1e-12)


def test_minimum_enclosing_ball_collinear_and_single_points():
    c, r = minimum_enclosing_ball([[0, 0, 0], [1, 1, 1], [0.3, 0.3, 0.3]])
    np.testing.assert_allclose(c, [0.5, 0.5, 0.5], atol=1e-12)
    assert r == pytest.approx(np.sqrt(3) / 2, rel=1e-12)
    c, r = minimum_enclosing_ball([[2, 3, 4]] * 3)
    np.testing.assert_allclose(c, [2, 3, 4])
    assert r == 0.0


@pytest.mark.parametrize("scale", [1e-30, 1e-12, 1.0, 1e12, 1e17])
def test_minimum_enclosing_ball_flat_square_at_any_scale(scale):
    rot = trimesh.transformations.rotation_matrix(0.7, [1, 2, 3])[:3, :3]
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float) @ rot.T * scale
    c, r = minimum_enclosing_ball(square)
    np.testing.assert_allclose(c, square.mean(axis=0), atol=1e-9 * scale)
    assert r == pytest.approx(np.sqrt(0.5) * scale, rel=1e-9)


def test_minimum_enclosing_ball_random_planar_sets_are_minimal():
    from scipy.optimize import minimize

    rng = np.random.default_rng(7)
    for _ in range(20):
        n = int(rng.integers(3, 40))
        basis = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        pts = np.c_[rng.normal(size=(n, 2)), np.zeros(n)] @ basis + rng.normal(size=3)
        c, r = minimum_enclosing_ball(pts)
        assert np.all(np.linalg.norm(pts - c, axis=1) <= r * (1 + 1e-9))
        worst = minimize(lambda x, p=pts: np.max(np.linalg.norm(p - x, axis=1)), pts.mean(0),
                         method="Nelder-Mead",
                         options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 20000}).fun
        assert r <= worst * (1 + 1e-6)


def test_minimum_enclosing_ball_solid_matches_trimesh(unit_sphere):
    c, r = minimum_enclosing_ball(unit_sphere.vertices)
    c0, r0 = trimesh.nsphere.minimum_nsphere(unit_sphere)
    np.testing.assert_array_equal(c, c0)
    assert r == r0


def test_minimum_enclosing_ball_invalid_input():
    with pytest.raises(InputError):
        minimum_enclosing_ball(np.zeros((0, 3)))
    with pytest.raises(InputError):
        minimum_enclosing_ball([[0, 0, np.nan]])


def test_enclosing_ball_kept_by_content_returns_fresh_centres():
    """A second call on equal points gives an equal ball whose centre is a new array (the
    caller may edit it); moved points give the new ball."""
    from viscore.ray.enclosing_ball import minimum_enclosing_ball

    pts = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2]])
    c1, r1 = minimum_enclosing_ball(pts)
    c1 += 100.0
    c2, r2 = minimum_enclosing_ball(pts.copy())
    assert r2 == r1 and np.all(np.abs(c2) < 2)
    pts[1, 0] = 10.0
    assert minimum_enclosing_ball(pts)[1] > r1 + 3
