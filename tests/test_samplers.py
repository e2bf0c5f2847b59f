import numpy as np
import pytest

from viscore import (
    InputError,
    directions_fibonacci,
    directions_uniform,
    grid_positions,
    rays_between,
)


def test_directions_uniform_same_seed_identical_and_unbiased():
    a = directions_uniform(50000, seed=7)
    np.testing.assert_array_equal(a, directions_uniform(50000, seed=7))
    assert not np.array_equal(a, directions_uniform(50000, seed=8))
    np.testing.assert_allclose(np.linalg.norm(a, axis=1), 1)
    # mean of a uniform unit vector is 0 with s.e. sqrt(1/3 / n) per axis
    assert np.abs(a.mean(axis=0)).max() < 5 * np.sqrt(1 / 3 / len(a))
    # E[z^2] = 1/3
    assert (a[:, 2] ** 2).mean() == pytest.approx(1 / 3, abs=5 * np.sqrt(4 / 45 / len(a)))


def test_directions_fibonacci_deterministic_and_balanced():
    d = directions_fibonacci(1000)
    np.testing.assert_array_equal(d, directions_fibonacci(1000))
    assert np.abs(d.mean(axis=0)).max() < 1e-2
    r = directions_fibonacci(1000, seed=3)
    np.testing.assert_allclose(np.linalg.norm(r, axis=1), 1)
    np.testing.assert_array_equal(r, directions_fibonacci(1000, seed=3))


def test_grid_positions_spacing_and_centre():
    p = grid_positions((0, 0, 0), (1, 2, 0.5), 0.5)
    assert p.shape == (2 * 4 * 1, 3)
    np.testing.assert_allclose(p.mean(axis=0), [0.5, 1.0, 0.25])
    assert np.unique(np.round(np.diff(np.unique(p[:, 1])), 12)).tolist() == [0.5]


def test_rays_between_reproducible_and_ends_in_box():
    a = np.array([[0, 0, 0], [1, 1, 1.0]])
    b = np.array([[5, 5, 5], [6, 6, 6.0]])
    o, d, n = rays_between(a, b, 1000, seed=2)
    o2, d2, n2 = rays_between(a, b, 1000, seed=2)
    np.testing.assert_array_equal(o, o2)
    end = o + d * n[:, None]
    assert ((end >= 5 - 1e-9) & (end <= 6 + 1e-9)).all()
    assert ((o >= 0) & (o <= 1)).all()


def test_samplers_invalid_input():
    with pytest.raises(InputError):
        directions_uniform(0)
    with pytest.raises(InputError):
        grid_positions((0, 0, 0), (-1, 1, 1), 0.5)
    with pytest.raises(InputError):
        grid_positions((0, 0, 0), (1, 1, 1), 0.0)
    with pytest.raises(InputError):
        rays_between(np.zeros((2, 2)), np.zeros((2, 3)), 5)
