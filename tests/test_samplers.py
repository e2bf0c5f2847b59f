import numpy as np
import pytest
import trimesh

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


# ------------------------------------------------- the conservativeness check's ray samplers
#: Rays of each sampler test: the empirical distribution is compared with the exact one
#: within the Kolmogorov-Smirnov bound below.
SAMPLER_RAYS = 200_000
#: Kolmogorov-Smirnov bound at a false-alarm probability of 1e-6 (two-sided, asymptotic):
#: sqrt(ln(2 / 1e-6) / (2 n)), about 0.006 at 200,000 rays.
KS_ALPHA = 1e-6


def _ks_bound(n: int) -> float:
    return float(np.sqrt(np.log(2 / KS_ALPHA) / (2 * n)))


def _ks_distance(sample: np.ndarray, cdf) -> float:
    """Kolmogorov-Smirnov distance between a sample and a continuous distribution."""
    x = np.sort(sample)
    f = cdf(x)
    n = len(x)
    return float(max((np.arange(1, n + 1) / n - f).max(), (f - np.arange(n) / n).max()))


def test_orbit_rays_of_the_check_follow_their_distribution():
    """The check's orbit rays start uniform on the frame's sphere (radius R) and aim at a
    point uniform in its ball. Then the line of a ray passes within s R of the centre
    with probability F(s) = 1 - (1 - s^2)^2 (the ball's share inside the cone of
    half-angle asin(s) from the origin, whose apex is on the sphere: 1 - cos^4), e.g.
    7/16 at s = 1/2; targets uniform in radius instead of in volume give 71%."""
    from viscore import Scene
    from viscore.metrics.conservativeness import _domain_rays

    center, extent = np.array([1.0, -2.0, 0.5]), 6.0
    radius = extent / 2
    scene = Scene(trimesh.creation.box())
    o, d = _domain_rays("orbit", (center, extent), scene, SAMPLER_RAYS,
                        np.random.default_rng(7))
    np.testing.assert_allclose(np.linalg.norm(o - center, axis=1), radius, rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, rtol=1e-12)
    # origins uniform on the sphere: each coordinate of (o - c) / R uniform on [-1, 1]
    unit = (o - center) / radius
    bound = _ks_bound(SAMPLER_RAYS)
    for axis in range(3):
        assert _ks_distance(unit[:, axis], lambda x: (x + 1) / 2) < bound
    # each ray aims into the ball: at its origin, the direction points inward
    assert (np.einsum("ij,ij->i", d, center - o) > 0).all()
    # distance of each ray's line from the centre, in units of R
    rel = center - o
    s = np.linalg.norm(rel - np.einsum("ij,ij->i", rel, d)[:, None] * d, axis=1) / radius
    assert _ks_distance(s, lambda x: 1 - (1 - x**2) ** 2) < bound
    half = float((s < 0.5).mean())
    assert half == pytest.approx(7 / 16, abs=5 * np.sqrt(7 / 16 * 9 / 16 / SAMPLER_RAYS))


def test_volume_rays_of_the_check_follow_their_distribution():
    """The check's volume rays start uniform in the box outside the mesh and go in a
    uniform direction. For a closed mesh of volume V centred in a box of volume B whose
    inscribed ball has radius a, an origin lies within rho of the centre (rho between
    the mesh's outer radius and a) with probability (4/3 pi rho^3 - V) / (B - V); no
    origin is inside the mesh; directions are uniform on the sphere."""
    from viscore import Scene
    from viscore.metrics.conservativeness import _domain_rays

    ball = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    half_side = 2.0
    lo, hi = np.full(3, -half_side), np.full(3, half_side)
    o, d = _domain_rays("volume", (lo, hi), Scene(ball), SAMPLER_RAYS,
                        np.random.default_rng(11))
    assert ((o >= lo) & (o <= hi)).all()
    r = np.linalg.norm(o, axis=1)
    # no origin inside the mesh (its faces lie at least 0.98 from its centre)
    assert r.min() > 0.98, f"an origin inside the mesh, {r.min():.3g} from its centre"
    volume, box = float(ball.volume), float((2 * half_side) ** 3)

    def cdf(rho):  # within the inscribed ball, beyond the sphere's vertices (radius 1)
        return (4 / 3 * np.pi * rho**3 - volume) / (box - volume)

    inner = r[(r >= 1.0) & (r <= half_side)]
    share = len(inner) / SAMPLER_RAYS
    assert share == pytest.approx(cdf(half_side) - cdf(1.0),
                                  abs=5 * np.sqrt(0.5 * 0.5 / SAMPLER_RAYS))
    # conditioned on lying in that shell, the radius follows the shell's own law
    lo_cdf, hi_cdf = cdf(1.0), cdf(half_side)
    assert _ks_distance(inner, lambda x: (cdf(x) - lo_cdf) / (hi_cdf - lo_cdf)) < \
        _ks_bound(len(inner))
    # by symmetry each octant holds an eighth of the origins
    octant = (o[:, 0] > 0) * 4 + (o[:, 1] > 0) * 2 + (o[:, 2] > 0)
    counts = np.bincount(octant, minlength=8) / SAMPLER_RAYS
    np.testing.assert_allclose(counts, 1 / 8, atol=5 * np.sqrt(1 / 8 * 7 / 8 / SAMPLER_RAYS))
    # directions uniform on the sphere: each coordinate uniform on [-1, 1]
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, rtol=1e-12)
    bound = _ks_bound(SAMPLER_RAYS)
    for axis in range(3):
        assert _ks_distance(d[:, axis], lambda x: (x + 1) / 2) < bound
