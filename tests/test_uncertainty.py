"""Uncertainty report, paired comparisons and the ``uncertainty`` command.

The bootstrap and the Beta model have their own files, test_bootstrap.py and
test_bayes.py.
"""

import dataclasses
import json
import os

import pytest

from viscore import InputError, load_mesh, stream_seed
from viscore.cli import uncertainty_cmd
from viscore.cli.main import main
from viscore.metrics import (
    convergence_ablation,
    orbit_precision_recall,
    paired_difference,
    uncertainty_report,
)
from viscore.metrics import uncertainty as uncertainty_module


def _scaled(mesh, factor):
    out = mesh.copy()
    out.apply_scale(factor)
    return out


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


def test_paired_difference_invalid_input(unit_sphere):
    a = orbit_precision_recall(unit_sphere, unit_sphere, views=4, quads=200, resolution=16)
    for kwargs in ({"seed": -5}, {"seed": None}, {"resamples": 0}, {"confidence": 2.0}):
        with pytest.raises(InputError):
            paired_difference(a, a, **kwargs)
    typo = dataclasses.replace(a, protocol="orbti")
    with pytest.raises(InputError, match="orbit, volume"):
        paired_difference(typo, typo)
    with pytest.raises(InputError, match="PrecisionRecall"):
        paired_difference(a, "qem")
    big = paired_difference(a, a, seed=2**64)
    assert big.seed == 2**64 and big.recall_diff == 0


def test_paired_difference_refuses_different_views(unit_sphere):
    a = orbit_precision_recall(unit_sphere, unit_sphere, views=4, quads=200, resolution=16)
    b = orbit_precision_recall(unit_sphere, unit_sphere, views=4, quads=200, resolution=16,
                               seed=1)
    with pytest.raises(InputError, match="views"):
        paired_difference(a, b)


# ---------------------------------------------------------------- ablation
def test_ablation_spread_shrinks_with_quads():
    mesh = load_mesh("cow")
    res = convergence_ablation(mesh, _scaled(mesh, 0.95), factors=("quads",),
                               quads_list=(100, 10000), repeats=6, views=16, resolution=64)
    sd = {r["value"]: r["recall_sd"] for r in res.rows}
    assert sd[100] > 2 * sd[10000]  # variance ~ 1/Q: expected ratio 10


# ---------------------------------------------------------------- calibration
def _calibration(repeats, views, truth_views=3000):
    mesh = load_mesh("building-house")
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


# ---------------------------------------------------------------- report
def _no_evaluation(monkeypatch):
    """Make the report's evaluations fail loudly: an input check must come first."""
    calls = []

    def record(*args, **kwargs):
        calls.append(kwargs)
        raise AssertionError("evaluation ran before the input was checked")

    monkeypatch.setattr(uncertainty_module, "orbit_precision_recall", record)
    monkeypatch.setattr(uncertainty_module, "volume_precision_recall", record)
    return calls


@pytest.mark.parametrize("kwargs", [
    {"protocol": "orbti"}, {"protocol": "Volume"}, {"quads": 0}, {"views": 0},
    {"resolution": 0}, {"resolution": 10**5}, {"directions": 0}, {"threshold": 1.5},
    {"steps": 0}, {"seed": -5}, {"seed": None}, {"spacing": 0.0}, {"spacing": float("nan")}])
def test_uncertainty_report_invalid_input(monkeypatch, cube, kwargs):
    calls = _no_evaluation(monkeypatch)
    with pytest.raises(InputError) as info:
        uncertainty_report(cube, cube, **kwargs)
    assert not calls
    if "protocol" in kwargs:
        assert "'orbit', 'volume'" in str(info.value)


def test_uncertainty_report_default_quads_only_when_none(monkeypatch, cube):
    calls = _no_evaluation(monkeypatch)
    for protocol, quads in (("orbit", 32000), ("volume", 5000)):
        with pytest.raises(AssertionError):
            uncertainty_report(cube, cube, protocol=protocol)
        assert calls.pop()["quads"] == quads


def test_uncertainty_report_refuses_what_does_not_fit_in_memory(monkeypatch, cube):
    calls = _no_evaluation(monkeypatch)
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", "1e-9")
    with pytest.raises(InputError, match="memory"):
        uncertainty_report(cube, cube)
    assert not calls


# ---------------------------------------------------------------- CLI
_SMALL = ["--views", "8", "--quads", "500", "--res", "32", "--directions", "4", "--steps", "300"]


def _run(argv):
    """``main(argv)``'s exit code, also when argparse exits with SystemExit."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


def _listing(folder):
    return sorted(p.name for p in folder.iterdir()) if folder.exists() else None


def test_cli_uncertainty_json(tmp_path, capsys):
    seed = 2**32  # beyond numpy's RandomState seeds
    assert main(["uncertainty", "fat-torus", "fat-torus", *_SMALL, "--seed", str(seed),
                 "--versus", "fat-torus", "--out", str(tmp_path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["seed"] == seed
    assert doc["bayes"]["recall"]["seed"] == stream_seed(seed, "beta-model-recall")
    assert doc["recall"] == 1.0 and doc["recall_ci_bca"] == [1.0, 1.0]
    assert {"recall", "precision"} == set(doc["bayes"])
    assert doc["paired"]["recall_diff"] == 0
    assert _listing(tmp_path) == ["per_view.png", "uncertainty.json"]
    mask = os.umask(0)
    os.umask(mask)
    assert (tmp_path / "uncertainty.json").stat().st_mode & 0o777 == 0o666 & ~mask


@pytest.fixture
def garbage_ply(tmp_path):
    path = tmp_path / "garbage.ply"
    path.write_bytes(b"ply\nformat nonsense\n\x00\x01\x02")
    return path


@pytest.mark.parametrize("case", ["versus", "out-file", "out-parent", "quads", "seed-negative",
                                  "seed-text", "res", "threshold", "steps", "directions",
                                  "views", "mesh"])
def test_cli_uncertainty_bad_input_one_line_nothing_written(tmp_path, capsys, monkeypatch,
                                                            garbage_ply, case):
    calls = []
    monkeypatch.setattr(uncertainty_cmd, "uncertainty_report",
                        lambda *a, **k: calls.append(k) or pytest.fail("work started"))
    out = tmp_path / "out"
    existing = tmp_path / "existing.txt"
    existing.write_text("keep")
    extra = {"versus": ["--versus", str(garbage_ply)], "out-file": [],
             "out-parent": [], "quads": ["--quads", "0"], "seed-negative": ["--seed", "-5"],
             "seed-text": ["--seed", "x"], "res": ["--res", "100000"],
             "threshold": ["--threshold", "nan"], "steps": ["--steps", "0"],
             "directions": ["--directions", "-1"], "views": ["--views", "0"], "mesh": []}[case]
    target = {"out-file": existing, "out-parent": tmp_path / "missing" / "out"}.get(case, out)
    mesh = str(garbage_ply) if case == "mesh" else "fat-torus"
    before = _listing(tmp_path)
    code = _run(["uncertainty", "fat-torus", mesh, *extra, "--out", str(target)])
    err = capsys.readouterr().err
    assert code == 2 and not calls
    assert len(err.splitlines()) == 1 and err.startswith("viscore: error:")
    assert _listing(tmp_path) == before and existing.read_text() == "keep"


def test_cli_uncertainty_plot_failure_writes_nothing(tmp_path, capsys, monkeypatch):
    def no_space(result, models, path):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(uncertainty_cmd, "distribution_plot", no_space)
    fresh = tmp_path / "fresh"
    assert main(["uncertainty", "fat-torus", "fat-torus", *_SMALL, "--out", str(fresh)]) == 2
    err = capsys.readouterr().err.splitlines()  # the Beta models' short-chain warnings first
    assert err[-1].startswith("viscore: error:") and sum("error" in e for e in err) == 1
    assert "per_view.png" in err[-1] and ".tmp" not in err[-1]
    assert not fresh.exists()
    old = tmp_path / "old"
    old.mkdir()
    (old / "uncertainty.json").write_text("{}")
    assert main(["uncertainty", "fat-torus", "fat-torus", *_SMALL, "--out", str(old)]) == 2
    assert _listing(old) == ["uncertainty.json"] and (old / "uncertainty.json").read_text() == "{}"


def test_cli_uncertainty_usage_error(capsys):
    assert main(["uncertainty", "cow"]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1


@pytest.mark.parametrize("extra", [["--repeats", "1"], ["--versus", "cow"], ["--spacings", "x"],
                                   ["--spacings", "2"], ["--quads-list", "0"],
                                   ["--factors", "quads,pixels"], ["--seed", "-1"]])
def test_cli_uncertainty_ablation_bad_input(tmp_path, capsys, monkeypatch, extra):
    monkeypatch.setattr(uncertainty_cmd, "convergence_ablation",
                        lambda *a, **k: pytest.fail("work started"))
    out = tmp_path / "out"
    assert main(["uncertainty", "ablation", "cow", "cow", *extra, "--out", str(out)]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1 and not out.exists()


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
    assert _listing(tmp_path) == ["ablation.csv", "ablation.json", "ablation.png"]
