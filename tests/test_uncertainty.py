import json

import numpy as np
import pytest
from scipy import stats
from viscore.cli.main import main
from viscore.metrics import (
    PrecisionRecall,
    bootstrap_ratio,
    convergence_ablation,
    hierarchical_beta_model,
    orbit_precision_recall,
    paired_difference,
)

from viscore import InputError, load_mesh


def _scaled(mesh, factor):
    out = mesh.copy()
    out.apply_scale(factor)
    return out


# ---------------------------------------------------------------- bootstrap
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


def test_bootstrap_ratio_degenerate_and_invalid():
    assert bootstrap_ratio(np.ones(5), np.ones(5)) == (1.0, 1.0)
    assert np.isnan(bootstrap_ratio([1.0], [2.0])[0])
    with pytest.raises(InputError):
        bootstrap_ratio([1, 2], [1, 2], method="magic")
    with pytest.raises(InputError):
        bootstrap_ratio([1, 2], [1, 2, 3])


# ---------------------------------------------------------------- paired
def test_paired_difference_identical_is_zero_and_shrunk_is_worse(unit_sphere):
    kw = dict(views=12, quads=1000, resolution=32, seed=5)
    same = orbit_precision_recall(unit_sphere, unit_sphere, **kw)
    small = orbit_precision_recall(unit_sphere, _scaled(unit_sphere, 0.8), **kw)
    d0 = paired_difference(same, same)
    assert d0.recall_diff == 0 and d0.recall_diff_ci == [0.0, 0.0]
    assert d0.prob_a_better_recall == 0.5
    d = paired_difference(same, small)
    assert d.recall_diff > 0 and d.recall_diff_ci[0] > 0 and d.prob_a_better_recall == 1.0


def test_paired_difference_refuses_different_views(unit_sphere):
    a = orbit_precision_recall(unit_sphere, unit_sphere, views=4, quads=200, resolution=16)
    b = orbit_precision_recall(unit_sphere, unit_sphere, views=4, quads=200, resolution=16,
                               seed=1)
    with pytest.raises(InputError, match="views"):
        paired_difference(a, b)


# ---------------------------------------------------------------- Bayesian model
def _synthetic(mu, phi, views, n, seed):
    rng = np.random.default_rng(seed)
    theta = rng.beta(mu * phi, (1 - mu) * phi, views)
    k = rng.binomial(n, theta)
    pv = {"nt": k, "pf": n - k, "nf": np.zeros(views), "quads_orig": np.full(views, n),
          "quads_occ": k, "quads_both": k, "weight": np.ones(views)}
    return PrecisionRecall(precision=1.0, recall=float(k.sum() / (n * views)),
                           precision_ci=[1, 1], recall_ci=[0, 1], per_view=pv,
                           protocol="orbit", depth_aware=False, seed=seed, params={},
                           seconds=0.0)


def test_hierarchical_beta_model_recovers_population():
    mu, phi = 0.85, 40.0
    s = hierarchical_beta_model(_synthetic(mu, phi, 300, 2000, 3), threshold=0.8, seed=2)
    assert s.converged and s.effective_samples > 500
    assert s.mean_ci[0] <= mu <= s.mean_ci[1]
    sd = np.sqrt(mu * (1 - mu) / (1 + phi))
    assert s.spread_ci[0] <= sd <= s.spread_ci[1]
    tail = stats.beta.cdf(0.8, mu * phi, (1 - mu) * phi)
    assert s.tail_probability_ci[0] <= tail <= s.tail_probability_ci[1]
    assert 0.15 < s.acceptance_fraction < 0.85


def test_hierarchical_beta_model_warns_on_short_chain():
    s = hierarchical_beta_model(_synthetic(0.7, 20.0, 50, 500, 1), steps=40, walkers=8)
    assert not s.converged and any("too short" in w for w in s.warnings)


def test_hierarchical_beta_model_invalid_input():
    r = _synthetic(0.7, 20.0, 10, 100, 1)
    with pytest.raises(InputError):
        hierarchical_beta_model(r, quantity="accuracy")
    with pytest.raises(InputError):
        hierarchical_beta_model(r, walkers=2)


# ---------------------------------------------------------------- ablation
def test_ablation_spread_shrinks_with_quads():
    mesh = load_mesh("cow")
    res = convergence_ablation(mesh, _scaled(mesh, 0.95), factors=("quads",),
                               quads_list=(100, 10000), repeats=6, views=16, resolution=64)
    sd = {r["value"]: r["recall_sd"] for r in res.rows}
    assert sd[100] > 2 * sd[10000]  # variance ~ 1/Q: expected ratio 10


# ---------------------------------------------------------------- calibration
def _calibration(repeats, views, truth_views=3000):
    mesh = load_mesh("buildings")
    occ = _scaled(mesh, 0.9)
    kw = dict(quads=300, resolution=24)
    truth = orbit_precision_recall(mesh, occ, views=truth_views, seed=10**6, **kw).recall
    covered = 0
    for rep in range(repeats):
        r = orbit_precision_recall(mesh, occ, views=views, seed=rep, **kw)
        covered += r.recall_ci[0] <= truth <= r.recall_ci[1]
    return covered


def test_calibration_recall_interval_fast():
    # 30 repeats; P(Binomial(30, 0.95) < 25) is about 1.6%
    assert _calibration(30, 48) >= 25


@pytest.mark.slow
def test_calibration_recall_interval_full():
    assert _calibration(100, 64, truth_views=20000) >= 90


# ---------------------------------------------------------------- CLI
def test_cli_uncertainty_json(tmp_path, capsys):
    assert main(["uncertainty", "fat-torus", "fat-torus", "--views", "8", "--quads", "500",
                 "--res", "32", "--directions", "4", "--steps", "300",
                 "--out", str(tmp_path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["recall"] == 1.0 and doc["recall_ci_bca"] == [1.0, 1.0]
    assert {"recall", "precision"} == set(doc["bayes"])
    assert (tmp_path / "per_view.png").is_file() and (tmp_path / "uncertainty.json").is_file()


def test_cli_uncertainty_usage_error(capsys):
    assert main(["uncertainty", "cow"]) == 2


def test_cli_uncertainty_ablation_writes_table_and_plot(tmp_path, capsys):
    assert main(["uncertainty", "ablation", "cow", "fat-torus", "--factors", "quads",
                 "--quads-list", "100,3000", "--repeats", "3", "--out", str(tmp_path),
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [r["value"] for r in doc["rows"]] == [100, 3000]
    assert all(r["repeats"] == 3 for r in doc["rows"])
    lines = (tmp_path / "ablation.csv").read_text().splitlines()
    assert lines[0].startswith("factor,value") and len(lines) == 3
    assert (tmp_path / "ablation.png").stat().st_size > 1000
    assert main(["uncertainty", "ablation", "cow", "cow", "--spacings", "x"]) == 2
