"""Hierarchical Beta model of per-view rates (viscore.metrics.bayes)."""

import numpy as np
import pytest
from scipy import stats

from viscore import InputError
from viscore.metrics import PrecisionRecall, hierarchical_beta_model
from viscore.metrics import bayes as bayes_module


def _result(k, n, *, weight=None, protocol="orbit", seed=0):
    """A PrecisionRecall holding only the per-view tallies the model reads."""
    k = np.asarray(k, dtype=np.int64)
    n = np.asarray(n, dtype=np.int64) + np.zeros_like(k)
    pv = {"nt": k, "pf": n - k, "nf": np.zeros(len(k)), "quads_orig": n, "quads_occ": k,
          "quads_both": k, "precision": np.ones(len(k)), "recall": k / n}
    if weight is not None:
        pv["weight"] = np.asarray(weight, dtype=np.float64)
    return PrecisionRecall(precision=1.0, recall=float(k.sum() / n.sum()), precision_ci=[1, 1],
                           recall_ci=[0, 1], per_view=pv, protocol=protocol,
                           depth_aware=False, seed=seed, params={}, seconds=0.0)


def _synthetic(mu, phi, views, n, seed, **kw):
    rng = np.random.default_rng(seed)
    theta = rng.beta(mu * phi, (1 - mu) * phi, views)
    return _result(rng.binomial(n, theta), n, weight=np.ones(views), seed=seed, **kw)


def _two_groups(weight_good):
    """10 views at recall ~0.95 and 10 at ~0.6 (200 quads each); good views weigh more."""
    rng = np.random.default_rng(4)
    k = np.concatenate([rng.binomial(200, 0.95, 10), rng.binomial(200, 0.6, 10)])
    w = np.concatenate([np.full(10, weight_good), np.ones(10)])
    return _result(k, 200, weight=w, protocol="volume"), k / 200, w


def test_hierarchical_beta_model_recovers_population():
    mu, phi = 0.85, 40.0
    s = hierarchical_beta_model(_synthetic(mu, phi, 120, 2000, 3), threshold=0.8, steps=3000,
                                seed=2)
    assert s.converged and s.effective_samples > 500 and not s.weighted
    assert s.mean_ci[0] <= mu <= s.mean_ci[1]
    sd = np.sqrt(mu * (1 - mu) / (1 + phi))
    assert s.spread_ci[0] <= sd <= s.spread_ci[1]
    tail = stats.beta.cdf(0.8, mu * phi, (1 - mu) * phi)
    assert s.tail_probability_ci[0] <= tail <= s.tail_probability_ci[1]
    assert 0.15 < s.acceptance_fraction < 0.85


def test_hierarchical_beta_model_weights_pull_towards_heavy_views():
    # the pooled volume estimate weighs each view's rate by per_view["weight"];
    # so does the model: its population mean follows the weighted mean
    plain_r, rates, _ = _two_groups(1.0)
    heavy_r, _, w = _two_groups(9.0)
    plain = hierarchical_beta_model(plain_r, steps=1000, walkers=16, seed=1)
    heavy = hierarchical_beta_model(heavy_r, steps=1000, walkers=16, seed=1)
    assert heavy.weighted and not plain.weighted
    assert heavy.views_used == plain.views_used == 20
    assert abs(plain.mean - rates.mean()) < 0.03  # 0.78
    weighted_mean = float((w * rates).sum() / w.sum())  # 0.92
    assert abs(heavy.mean - weighted_mean) < 0.03
    assert heavy.mean_ci[0] > plain.mean_ci[1]


def test_hierarchical_beta_model_weight_scale_and_zero_weights():
    r1, _, _ = _two_groups(1.0)
    base = hierarchical_beta_model(r1, steps=300, walkers=8, seed=3)
    k, n = r1.per_view["quads_both"], r1.per_view["quads_orig"]
    # only relative weights matter
    scaled = hierarchical_beta_model(_result(k, n, weight=np.full(20, 5.0), protocol="volume"),
                                     steps=300, walkers=8, seed=3)
    assert scaled.mean == base.mean and scaled.spread == base.spread
    # a view of weight 0 is left out
    extra = _result(np.append(k, 3), np.append(n, 200), weight=np.append(np.ones(20), 0.0),
                    protocol="volume")
    dropped = hierarchical_beta_model(extra, steps=300, walkers=8, seed=3)
    assert dropped.views_used == 20 and dropped.mean == base.mean


def test_hierarchical_beta_model_seed_of_any_size():
    r = _synthetic(0.8, 20.0, 30, 300, 1)
    runs = [hierarchical_beta_model(r, steps=200, walkers=8, seed=s).mean
            for s in (2**32, 2**32, 2**70, 0)]
    assert runs[0] == runs[1]
    assert len({runs[0], runs[2], runs[3]}) == 3


def test_hierarchical_beta_model_warns_on_short_chain():
    s = hierarchical_beta_model(_synthetic(0.7, 20.0, 50, 500, 1), steps=40, walkers=8)
    assert not s.converged and any("too short" in w for w in s.warnings)


def test_hierarchical_beta_model_invalid_input():
    r = _synthetic(0.7, 20.0, 10, 100, 1)
    bad = [{"quantity": "accuracy"}, {"walkers": 2}, {"steps": 0}, {"burn": 10, "steps": 10},
           {"burn": 1.5}, {"threshold": 1.5}, {"seed": -5}, {"seed": None}, {"seed": 2.0}]
    for kwargs in bad:
        with pytest.raises(InputError):
            hierarchical_beta_model(r, **kwargs)
    with pytest.raises(InputError, match="'orbit', 'volume'"):
        hierarchical_beta_model(_synthetic(0.7, 20.0, 10, 100, 1, protocol="orbti"))
    k = r.per_view["quads_both"]
    for w in (None, np.full(10, np.nan), -np.ones(10), np.ones(3)):
        with pytest.raises(InputError, match="weight"):
            hierarchical_beta_model(_result(k, 100, weight=w, protocol="volume"))
    with pytest.raises(InputError, match="two views"):
        hierarchical_beta_model(_result(k, 100, weight=np.eye(10)[0], protocol="volume"))


def test_hierarchical_beta_model_refuses_what_does_not_fit_in_memory(monkeypatch):
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", "1e-9")
    with pytest.raises(InputError, match="memory"):
        hierarchical_beta_model(_synthetic(0.7, 20.0, 10, 100, 1), steps=10**6)


def test_check_model_memory_counts_walkers_steps_and_views(monkeypatch):
    bayes_module.check_model_memory(walkers=32, steps=4000, views=256)
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", "1e-9")
    with pytest.raises(InputError, match="32 walkers x 4000 steps"):
        bayes_module.check_model_memory(walkers=32, steps=4000, views=256)
