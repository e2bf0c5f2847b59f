import json

import pytest
import trimesh

from viscore.cli.main import main


def test_evaluate_json_identical_is_perfect(capsys):
    assert main(["evaluate", "fat-torus", "fat-torus", "--views", "4", "--quads", "500",
                 "--res", "32", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["precision"] == 1.0 and doc["recall"] == 1.0
    assert len(doc["per_view"]["nt"]) == 4 and len(doc["precision_ci"]) == 2
    assert doc["seed"] == 0 and "embreex" in doc["provenance"]


def test_validate_exit_codes(tmp_path, capsys):
    big = trimesh.creation.box(extents=(3, 3, 3))
    small = trimesh.creation.box(extents=(1, 1, 1))
    big.export(tmp_path / "big.ply")
    small.export(tmp_path / "small.ply")
    ok = main(["validate", str(tmp_path / "big.ply"), str(tmp_path / "small.ply"),
               "--rays", "5000", "--max-rate", "0.01"])
    bad = main(["validate", str(tmp_path / "small.ply"), str(tmp_path / "big.ply"),
                "--rays", "5000", "--max-rate", "0.01"])
    assert (ok, bad) == (0, 1)


def test_measure_bad_file_exit_2(tmp_path, capsys):
    p = tmp_path / "bad.obj"
    p.write_text("v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert main(["measure", str(p), "--json"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.strip().splitlines()) == 1


def test_generate_aabb_skins_writes_conservative_occluder(tmp_path, capsys):
    out = tmp_path / "skins.ply"
    assert main(["generate", "aabb-skins", "fat-torus", "-o", str(out), "--voxels", "32",
                 "--max-boxes", "4", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["boxes"] == 4 and doc["triangles"] == 48
    assert len(trimesh.load(out).faces) == 48
    assert main(["validate", "fat-torus", str(out), "--rays", "20000", "--max-rate", "0"]) == 0


def test_generate_option_not_taken_exit_2(tmp_path, capsys):
    out = tmp_path / "q.ply"
    assert main(["generate", "qem", "cow", "-o", str(out), "--max-boxes", "3"]) == 2
    assert not out.exists()


# --------------------------------------------------------------------------- options
def _one_error_line(capsys) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert captured.out == "" and len(lines) == 1, captured.err
    assert lines[0].startswith("viscore: error:")
    return lines[0]


@pytest.mark.parametrize("rate", ["nan", "-1", "2", "inf"])
def test_validate_max_rate_outside_unit_interval_exit_2(rate, capsys):
    assert main(["validate", "fat-torus", "fat-torus", "--rays", "100", "--max-rate", rate]) == 2
    assert "--max-rate" in _one_error_line(capsys)


@pytest.mark.parametrize("command", [["measure", "fat-torus"],
                                     ["evaluate", "fat-torus", "fat-torus"],
                                     ["validate", "fat-torus", "fat-torus"]])
def test_negative_seed_exit_2_one_line(command, capsys):
    assert main([*command, "--seed", "-5"]) == 2
    assert "--seed" in _one_error_line(capsys)


@pytest.mark.parametrize("argv, option", [
    (["evaluate", "nope.ply", "nope.ply", "--quads", str(10**12)], "--quads"),
    (["evaluate", "nope.ply", "nope.ply", "--views", str(10**9)], "--views"),
    (["measure", "nope.ply", "--directions", str(10**9)], "--directions"),
    # one image per batch at this size: 8192^2 pixels, not 8 x 4096^2 (which fits)
    (["evaluate", "nope.ply", "nope.ply", "--res", "8192", "--views", "8"], "--res 8192"),
    (["measure", "nope.ply", "--res", "8192"], "--res 8192"),
])
def test_sizes_refused_from_an_estimate_before_any_work(argv, option, capsys, monkeypatch):
    from viscore._validate import available_memory

    # a 4 GiB limit on every machine; the mesh does not exist: nothing was loaded
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", str((4 << 30) / available_memory()))
    assert main(argv) == 2
    line = _one_error_line(capsys)
    assert option in line and "needs about" in line and "nope.ply" not in line


def test_options_checked_before_meshes_are_loaded(capsys):
    assert main(["measure", "nope.ply", "--res", "0"]) == 2
    assert "--res" in _one_error_line(capsys)
    assert main(["evaluate", "nope.ply", "nope.ply", "--spacing", "0.1"]) == 2
    assert "--spacing" in _one_error_line(capsys)  # orbit takes no spacing


# --------------------------------------------------------------------------- reproducibility
#: Fields excluded from the bit-for-bit comparison: wall-clock times (``seconds``
#: and every ``timing`` key that starts with ``seconds``) and ``provenance``
#: (it records the worker count, which differs by design between the runs).
def _comparable(doc):
    if isinstance(doc, dict):
        return {k: _comparable(v) for k, v in doc.items()
                if k != "provenance" and k != "seconds" and not k.startswith("seconds_")}
    if isinstance(doc, list):
        return [_comparable(v) for v in doc]
    return doc


def _json_runs(argv, capsys):
    docs = []
    for workers in (["--workers", "1"], [], []):  # one thread, then the default twice
        rc = main([*workers, *argv, "--json", "--seed", "12345"])
        assert rc in (0, 1)
        docs.append(json.loads(capsys.readouterr().out))
    return docs


@pytest.mark.parametrize("argv", [
    ["measure", "bunny", "--directions", "4", "--res", "192"],  # > 2 chunks of rays per cast
    ["evaluate", "bunny", "fat-torus", "--views", "6", "--quads", "3000", "--res", "96"],
    ["validate", "bunny", "fat-torus", "--rays", "40000"],
], ids=["measure", "evaluate", "validate"])
def test_same_seed_bit_identical_json_across_runs_and_workers(argv, capsys):
    docs = _json_runs(argv, capsys)
    assert docs[0]["provenance"]["workers"] == 1
    first = json.dumps(_comparable(docs[0]), sort_keys=True)
    for other in docs[1:]:
        assert json.dumps(_comparable(other), sort_keys=True) == first
    assert "seconds" in docs[0]  # the exclusion list names fields that exist


def test_memory_message_reads_a_small_share_right(capsys, monkeypatch):
    """Issue 23: VISCORE_MEMORY_FRACTION=0.001 read "0% of available memory"."""
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", "0.001")
    assert main(["measure", "nope.ply", "--directions", str(10**9)]) == 2
    line = _one_error_line(capsys)
    assert "(0.1% of available memory)" in line, line
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", "0.75")
    assert main(["measure", "nope.ply", "--directions", str(10**9)]) == 2
    assert "(75% of available memory)" in _one_error_line(capsys)


def test_validate_hours_long_run_prints_an_estimate_first(capsys, monkeypatch):
    """Issue 23: --rays 1e12 started silently; the estimate comes from a timed first batch.

    (10^12 is now over the cap: the largest count accepted, hours long, shows the estimate.)
    """
    from viscore.cli import metrics_cmd

    real = metrics_cmd.check_conservative
    calls = []

    def probe_only(mesh, occ, *, rays, **kw):
        calls.append(rays)
        if rays > metrics_cmd._ETA_PROBE_RAYS:
            raise KeyboardInterrupt  # the real run would take weeks: stop it here
        return real(mesh, occ, rays=rays, **kw)

    monkeypatch.setattr(metrics_cmd, "check_conservative", probe_only)
    rays = metrics_cmd.MAX_RAYS
    argv = ["validate", "fat-torus", "fat-torus", "--rays", str(rays), "--json"]
    assert main(argv) == 130
    captured = capsys.readouterr()
    assert captured.out == ""  # --json stdout stays clean
    assert f"--rays {rays}: estimated" in captured.err, captured.err
    assert calls == [metrics_cmd._ETA_PROBE_RAYS, rays]


@pytest.mark.parametrize("rays", [10**10 + 1, 10**12, 2**70])
def test_validate_rays_over_the_cap_refused_with_its_time(rays, capfd, monkeypatch):
    """Issue 23: --rays 1e12 (39 days at the measured rate) was accepted with a warning."""
    from viscore.cli import metrics_cmd

    def no_work(*a, **k):
        raise AssertionError("nothing may be loaded or cast over the cap")

    monkeypatch.setattr(metrics_cmd, "load_mesh", no_work)
    monkeypatch.setattr(metrics_cmd, "check_conservative", no_work)
    assert metrics_cmd.MAX_RAYS == 10**10
    assert main(["validate", "fat-torus", "fat-torus", "--rays", str(rays)]) == 2
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(
        f"viscore: error: --rays {rays}: at most 10000000000 (it would take about "), err
    assert "rays/s" in err[0] and "the cap about 9.3 h" in err[0]
    assert metrics_cmd.check_rays(metrics_cmd.MAX_RAYS) == metrics_cmd.MAX_RAYS


def test_validate_short_run_has_no_probe(capsys, monkeypatch):
    from viscore.cli import metrics_cmd

    calls = []
    real = metrics_cmd.check_conservative

    def counting(mesh, occ, *, rays, **kw):
        calls.append(rays)
        return real(mesh, occ, rays=rays, **kw)

    monkeypatch.setattr(metrics_cmd, "check_conservative", counting)
    assert main(["validate", "fat-torus", "fat-torus", "--rays", "2000", "--json"]) in (0, 1)
    assert calls == [2000] and "estimated" not in capsys.readouterr().err
