"""Circular block bootstrap over the frames of a walk (viscore.metrics.bootstrap)."""

import numpy as np
import pytest

from viscore import InputError
from viscore.metrics import bootstrap as bootstrap_module
from viscore.metrics.bootstrap import block_bootstrap_ratio, block_length, bootstrap_ratio


def _ar1(phi: float, n: int, seed: int) -> np.ndarray:
    """An AR(1) series x_t = phi x_(t-1) + e_t, started at its stationary law."""
    rng = np.random.default_rng(seed)
    e = rng.normal(size=n)
    x = np.empty(n)
    x[0] = e[0] / np.sqrt(1 - phi**2)
    for t in range(1, n):
        x[t] = phi * x[t - 1] + e[t]
    return x


def _ar1_block(phi: float, n: int) -> float:
    """The optimal circular-block length of an AR(1) mean, from its autocovariances.

    R(k) = s phi^|k|: G = sum |k| R(k) = 2 s phi / (1 - phi)^2 and
    g(0) = sum R(k) = s (1 + phi) / (1 - phi), so
    b = (2 G^2 / (4/3 g(0)^2))^(1/3) n^(1/3) = (3/2 (2 phi / (1 - phi^2))^2)^(1/3) n^(1/3).
    """
    return (1.5 * (2 * phi / (1 - phi**2)) ** 2) ** (1 / 3) * n ** (1 / 3)


@pytest.mark.parametrize("phi", [0.5, 0.8])
def test_block_length_matches_the_ar1_optimum(phi):
    n = 20000
    want = _ar1_block(phi, n)
    got = [block_length(_ar1(phi, n, seed)) for seed in range(3)]
    # the rule estimates G and g(0) with a flat-top window: within 25% on 20,000 frames
    assert np.median(got) == pytest.approx(want, rel=0.25)


def test_block_length_of_independent_frames_is_one():
    rng = np.random.default_rng(4)
    assert [block_length(rng.normal(size=500)) for _ in range(5)] == [1] * 5


def test_block_length_of_a_ratio_follows_its_linearisation():
    # numerators proportional to the denominators: the ratio is constant, nothing to keep
    den = np.abs(_ar1(0.9, 400, 1)) + 5.0
    assert block_length(0.3 * den, den) == 1
    assert block_length(den) > 5


def test_block_length_is_capped():
    x = np.repeat([0.0, 1.0], 50)  # one change: as correlated as 100 frames can be
    assert block_length(x) <= np.ceil(min(3 * np.sqrt(100), 100 / 3))
    assert block_length([1.0, 2.0]) == 1
    assert block_length(np.ones(30)) == 1


def test_block_bootstrap_with_blocks_of_one_is_the_plain_bootstrap():
    rng = np.random.default_rng(2)
    num = rng.integers(0, 20, 37).astype(float)
    den = num + rng.integers(1, 20, 37)
    for seed in (0, 5):
        assert block_bootstrap_ratio(num, den, block=1, seed=seed) == bootstrap_ratio(
            num, den, seed=seed)


def test_block_bootstrap_resamples_keep_n_frames(monkeypatch):
    # every resample of n frames in blocks of 4: a constant series of ones sums to n
    rng = np.random.default_rng(0)
    for n, block in ((10, 4), (12, 4), (7, 7), (5, 1)):
        sums, = bootstrap_module._resampled_block_sums(rng, n, 50, block, np.ones(n))
        assert np.all(sums == n)


def test_block_bootstrap_blocks_are_consecutive_frames():
    # frames numbered 0..n-1: a block of 3 from start s sums to 3s + 3 (mod the wrap)
    x = np.arange(10.0)
    sums = bootstrap_module._circular_sums(x, 3)
    assert sums.tolist() == [3, 6, 9, 12, 15, 18, 21, 24, 17, 10]  # 8+9+0, 9+0+1


def test_block_bootstrap_covers_a_correlated_walk_where_the_plain_one_does_not():
    # AR(1) culled counts along 120 frames: frames are not independent, so the plain
    # bootstrap's interval is far too narrow; the block bootstrap comes much nearer the
    # nominal 95% (measured over 400 walks: plain 42%, blocks 78%; blocks under-cover
    # at this length, a known finite-sample bias of block variance estimates)
    n, reps, true = 120, 100, 0.5
    plain = blocks = 0
    for rep in range(reps):
        culled = 50 + 10 * _ar1(0.8, n, 100 + rep)
        in_view = np.full(n, 100.0)
        lo, hi = bootstrap_ratio(culled, in_view, resamples=500, seed=rep)
        plain += lo <= true <= hi
        lo, hi = block_bootstrap_ratio(culled, in_view, resamples=500, seed=rep)
        blocks += lo <= true <= hi
    # P(Binomial(100, 0.42) >= 58) and P(Binomial(100, 0.78) < 64) are each under 0.2%
    assert plain < 58
    assert blocks >= 64


def test_block_bootstrap_ratio_is_reproducible_by_seed():
    x = 5 + _ar1(0.7, 80, 3)
    one = block_bootstrap_ratio(x, np.full(80, 10.0), seed=11)
    assert one == block_bootstrap_ratio(x, np.full(80, 10.0), seed=11)
    assert one != block_bootstrap_ratio(x, np.full(80, 10.0), seed=12)


def test_block_bootstrap_ratio_degenerate_cases():
    assert block_bootstrap_ratio(np.ones(6), np.full(6, 2.0), block=2) == (0.5, 0.5)
    assert np.isnan(block_bootstrap_ratio([1.0], [2.0])[0])
    assert np.isnan(block_bootstrap_ratio([1.0, 2.0, 0.0], [0.0, 0.0, 3.0])[1])


def test_block_bootstrap_ratio_invalid_input():
    for kwargs in ({"block": 0}, {"block": 4}, {"block": 1.5}, {"confidence": 0.0},
                   {"resamples": 0}, {"seed": -1}):
        with pytest.raises(InputError):
            block_bootstrap_ratio([1, 2, 3], [1, 2, 3], **kwargs)
    with pytest.raises(InputError):
        block_bootstrap_ratio([1, 2], [1, 2, 3])
    with pytest.raises(InputError):
        block_bootstrap_ratio([1, np.nan], [1, 2])


def test_block_length_invalid_input():
    with pytest.raises(InputError):
        block_length(np.ones((3, 2)))
    with pytest.raises(InputError):
        block_length([1.0, 2.0, np.inf])
    with pytest.raises(InputError):
        block_length([1.0, 2.0], [1.0])
