"""Bootstrap intervals over views (viscore.metrics.bootstrap)."""

import numpy as np
import pytest
from scipy import stats

from viscore import InputError
from viscore.metrics import bootstrap as bootstrap_module
from viscore.metrics import bootstrap_ratio

#: Resamples of the BCa comparison: the Monte-Carlo s.d. of one end point is
#: then 0.0006-0.0012 on the skewed case below (measured over seeds).
_B = 20000
_SEEDS = range(4)
#: Allowed |ours - scipy| of the seed-averaged end points: about 4.5 s.d. of that
#: difference; flipping the sign of the acceleration moves them by ~0.017.
_TOL = 0.004


def _skewed_views(n=30, seed=7):
    """Per-view lognormal numerators and denominators: a right-skewed ratio of sums."""
    rng = np.random.default_rng(seed)
    num = rng.lognormal(0.0, 1.2, n)
    return num, num + rng.lognormal(0.0, 0.5, n)


def _scipy_bca(num, den, seed):
    def ratio_of_sums(i, axis=-1):
        return num[i].sum(axis=axis) / den[i].sum(axis=axis)

    res = stats.bootstrap((np.arange(len(num)),), ratio_of_sums, method="BCa",
                          n_resamples=_B, random_state=seed, vectorized=True)
    return res.confidence_interval.low, res.confidence_interval.high


def _bca_gap(num, den):
    ours = np.mean([bootstrap_ratio(num, den, method="bca", resamples=_B, seed=s)
                    for s in _SEEDS], axis=0)
    ref = np.mean([_scipy_bca(num, den, s) for s in _SEEDS], axis=0)
    return ours, ref


def test_bootstrap_ratio_bca_matches_scipy_on_skewed_ratio():
    num, den = _skewed_views()
    ours, ref = _bca_gap(num, den)
    assert np.abs(ours - ref).max() < _TOL
    # the case is skewed enough for BCa to differ from the percentile interval
    perc = np.mean([bootstrap_ratio(num, den, resamples=_B, seed=s) for s in _SEEDS], axis=0)
    assert np.abs(ours - perc).min() > 3 * _TOL


def test_bootstrap_ratio_bca_comparison_catches_flipped_acceleration(monkeypatch):
    # the test above fails when the acceleration's sign is wrong
    num, den = _skewed_views()
    right = bootstrap_module._jackknife_acceleration
    monkeypatch.setattr(bootstrap_module, "_jackknife_acceleration",
                        lambda n, d: -right(n, d))
    ours, ref = _bca_gap(num, den)
    assert np.abs(ours - ref).min() > 3 * _TOL


def test_jackknife_acceleration_of_a_mean_is_the_skewness_formula():
    # jackknife of a mean: theta_(.) - theta_(i) = (x_i - mean) / (n - 1), so
    # a = sum d^3 / (6 (sum d^2)^1.5) with d = x - mean; > 0 for right skew
    x = np.random.default_rng(3).exponential(1.0, 50)
    d = x - x.mean()
    expected = (d**3).sum() / (6 * ((d**2).sum()) ** 1.5)
    got = bootstrap_module._jackknife_acceleration(x, np.ones_like(x))
    assert expected > 0 and got == pytest.approx(expected, rel=1e-9)
    assert bootstrap_module._jackknife_acceleration(-x, np.ones_like(x)) == pytest.approx(
        -expected, rel=1e-9)


@pytest.mark.parametrize("method", ["percentile", "bca"])
def test_bootstrap_ratio_covers_true_mean(method):
    rng = np.random.default_rng(0)
    covered = 0
    for rep in range(100):
        x = rng.exponential(2.0, 60)  # skewed: true mean 2
        lo, hi = bootstrap_ratio(x, np.ones_like(x), method=method, resamples=1000, seed=rep)
        covered += lo <= 2.0 <= hi
    # nominal 95%; P(Binomial(100, 0.95) < 87) is about 0.1%
    assert covered >= 87


def test_bootstrap_ratio_blocks_draw_the_same_resamples(monkeypatch):
    num, den = _skewed_views(n=13)
    whole = bootstrap_ratio(num, den, method="bca", resamples=500, seed=9)
    monkeypatch.setattr(bootstrap_module, "_BLOCK_ELEMENTS", 40)  # 3 resamples per block
    assert bootstrap_ratio(num, den, method="bca", resamples=500, seed=9) == whole


def test_bootstrap_ratio_seed_of_any_size():
    num, den = _skewed_views()
    big = bootstrap_ratio(num, den, seed=2**70)
    assert big == bootstrap_ratio(num, den, seed=2**70)
    assert big != bootstrap_ratio(num, den, seed=2**70 + 1)


def test_bootstrap_ratio_degenerate_cases():
    assert bootstrap_ratio(np.ones(5), np.ones(5)) == (1.0, 1.0)
    assert np.isnan(bootstrap_ratio([1.0], [2.0])[0])
    assert np.isnan(bootstrap_ratio([1.0, 2.0, 0.0], [0.0, 0.0, 3.0])[1])


def test_bootstrap_ratio_invalid_input():
    for kwargs in ({"method": "magic"}, {"confidence": 0.0}, {"confidence": float("nan")},
                   {"resamples": 0}, {"seed": -5}, {"seed": None}, {"seed": 1.5}):
        with pytest.raises(InputError):
            bootstrap_ratio([1, 2], [1, 2], **kwargs)
    with pytest.raises(InputError, match="percentile, bca"):
        bootstrap_ratio([1, 2], [1, 2], method="BCa ")
    with pytest.raises(InputError):
        bootstrap_ratio([1, 2], [1, 2, 3])


def test_bootstrap_ratio_refuses_what_does_not_fit_in_memory(monkeypatch):
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", "1e-9")
    with pytest.raises(InputError, match="memory"):
        bootstrap_ratio(np.ones(100), np.ones(100), resamples=10**6)
