import json
import os
import sqlite3

import pytest

from viscore.cli.main import main


def test_compare_writes_outputs_and_resumes(tmp_path, capsys):
    out = tmp_path / "study"
    argv = ["compare", "building-house", "--methods", "original,bbox", "--views", "4", "--quads",
            "500", "--res", "32", "--rays", "2000", "--culling-frames", "2", "--out", str(out),
            "--json"]
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    # the culling column: the mesh itself never culls a visible object; the bounding box,
    # drawn for each building of the city, hides what the buildings' gaps let through
    culling = {r["method"]: r for r in doc["culling"]["rows"]}
    assert culling["original"]["false_culls"] == 0 and not culling["bbox"]["conservative"]
    assert culling["bbox"]["culled_share"] > culling["original"]["culled_share"]
    assert "false culls" in (out / "results.md").read_text()
    cached = (out / "culling.json").stat().st_mtime_ns
    rows = {r["method"]: r for r in doc["rows"]}
    assert rows["original"]["precision"] == 1.0 and rows["original"]["recall"] == 1.0
    assert rows["bbox"]["triangles"] == 12 and rows["bbox"]["recall"] == 1.0
    # every field of the assessment is in the row, under its JSON name
    from viscore.metrics import OccluderAssessment

    back = OccluderAssessment.from_json(rows["bbox"])
    assert back.method == "bbox" and back.per_view["nt"].shape == (4,)
    for name in ("results.csv", "results.json", "results.md", "recall.png", "results.sqlite",
                 "budget.png", "silhouettes_building-house.png", "report.html"):
        assert (out / name).is_file()
    # the report: a row per result, every plot inline, nothing loaded from outside
    page = (out / "report.html").read_text()
    assert page.count('<tr class="result">') == 2 and page.count('<tr class="culling">') == 2
    assert page.count("data:image/png;base64,") == 3 and "<script" not in page
    # a .glb beside each occluder: the original and the occluder, by name
    import trimesh

    glbs = sorted((out / "occluders").glob("*.glb"))
    assert [g.stem for g in glbs] == sorted(r["occluder_file"][:-4] for r in doc["rows"])
    scene = trimesh.load(out / "occluders" / (rows["bbox"]["occluder_file"][:-4] + ".glb"))
    assert len(scene.geometry["occluder"].faces) == 12
    assert len(scene.geometry["original"].faces) == len(
        trimesh.load(out / "occluders" / rows["original"]["occluder_file"]).faces)
    glbs[0].unlink()  # a resumed study gets the .glb of its earlier rows
    # a re-run resumes: the stored rows are reused unchanged, none added
    with sqlite3.connect(out / "results.sqlite") as db:
        before = db.execute("SELECT key, row FROM results ORDER BY key").fetchall()
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    with sqlite3.connect(out / "results.sqlite") as db:
        after = db.execute("SELECT key, row FROM results ORDER BY key").fetchall()
    assert before == after and len(after) == 2
    assert again["rows"] == doc["rows"]
    assert glbs[0].is_file()
    # ... and reuses the culling column of the same methods, frames and seed
    assert (out / "culling.json").stat().st_mtime_ns == cached
    assert again["culling"] == doc["culling"]


def test_compare_unknown_method_exit_2(tmp_path, capsys):
    assert main(["compare", "cow", "--methods", "magic", "--out", str(tmp_path)]) == 2
    assert "magic" in capsys.readouterr().err


TINY = ["--views", "4", "--quads", "300", "--res", "32", "--rays", "1000", "--no-culling"]


@pytest.mark.parametrize("argv, expected", [
    (["--methods", "aabb-skins,bbox", "--budget", "4"],
     "--budget: aabb-skins needs at least 12 triangles, got 4"),
    (["--budget", "0"], "--budget"),
    (["--budget", "8,x"], "--budget"),
    (["--methods", "bbox,original", "--versus", "nope"], "--versus: unknown method 'nope'"),
    (["--methods", "bbox,original", "--versus", "qem"], "--versus: qem is not among"),
    (["--methods", "bbox", "--jobs", "1000000"], "--jobs 1000000: at most"),
    (["--methods", "bbox", "--jobs", "0"], "--jobs"),
    (["--methods", "bbox", "--views", "100000000"], "memory"),
    (["--methods", "bbox", "--quads", "0"], "--quads"),
    (["--methods", "bbox", "--res", "5000"], "--res"),
    (["--methods", "bbox", "--rays", "-3"], "--rays"),
    (["--methods", "bbox", "--seed", "-5"], "--seed"),
])
def test_compare_refuses_bad_arguments_before_creating_the_study(tmp_path, capsys, argv,
                                                                  expected):
    out = tmp_path / "study"
    assert main(["compare", "cow", *TINY, *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and expected in err
    assert not out.exists()  # nothing created: the check came before any work


def test_compare_out_must_be_a_folder_whose_parent_exists(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    for out, expected in ((tmp_path / "file", "exists and is not a folder"),
                          (tmp_path / "missing" / "study", "does not exist")):
        assert main(["compare", "cow", "--methods", "bbox", *TINY, "--out", str(out)]) == 2
        assert expected in capsys.readouterr().err
    assert not (tmp_path / "missing").exists()


def test_compare_versus_defaults_to_qem_when_it_runs(tmp_path, capsys):
    common = ["compare", "fat-torus", *TINY, "--budget", "48", "--json"]
    assert main([*common, "--methods", "bbox,original", "--out", str(tmp_path / "a")]) == 0
    assert json.loads(capsys.readouterr().out)["paired"] == []  # no qem: no paired table
    assert main([*common, "--methods", "qem,bbox", "--out", str(tmp_path / "b")]) == 0
    paired = json.loads(capsys.readouterr().out)["paired"]
    assert [(p["method"], p["versus"], p["versus_budget"]) for p in paired] == [
        ("bbox", "qem", 48)]


def test_compare_budgets_run_budgeted_methods_once_per_budget(tmp_path, capsys):
    out = tmp_path / "study"
    assert main(["compare", "cow", "--methods", "qem,bbox", "--budget", "32,128", "--views",
                 "4", "--quads", "300", "--res", "32", "--rays", "1000", "--no-culling",
                 "--out", str(out),
                 "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [(r["method"], r["budget"]) for r in rows] == [("qem", 32), ("qem", 128),
                                                         ("bbox", None)]
    assert rows[0]["triangles"] <= 32 < rows[1]["triangles"] <= 128
    assert len(list((out / "occluders").glob("*.ply"))) == 3


def test_dask_cluster_gives_identical_rows(tmp_path, monkeypatch):
    from distributed import Client, LocalCluster

    from viscore.cli.study.runner import StudySettings, run_study
    from viscore.metrics import ReferenceViews

    settings = StudySettings(views=4, quads=300, resolution=24, directions=2, rays=1000,
                             budgets=(48,))
    local = run_study(["fat-torus"], ["aabb-skins", "bbox"], settings, tmp_path / "a",
                      progress=False)
    built = []  # the in-process cluster runs the tasks here: count the views built
    init = ReferenceViews.__init__
    monkeypatch.setattr(ReferenceViews, "__init__",
                        lambda self, *a, **k: built.append(k["protocol"]) or init(self, *a, **k))
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        remote = run_study(["fat-torus"], ["aabb-skins", "bbox"], settings, tmp_path / "b",
                           scheduler=client, progress=False)
    strip = lambda rows: [{k: v for k, v in r.items() if not k.startswith("seconds")}  # noqa: E731
                          for r in rows]
    assert strip(local) == strip(remote)
    assert built == ["orbit"]  # the original's views: once for both methods


def test_interrupted_study_keeps_finished_rows_and_resumes(tmp_path):
    from viscore.cli.study.runner import StudySettings, run_study

    settings = StudySettings(views=4, quads=300, resolution=24, directions=2, rays=1000,
                             budgets=(48,))
    out = tmp_path / "s"
    seen = []

    def crash(row):
        seen.append(row["method"])
        raise KeyboardInterrupt  # killed right after the first row was committed

    with pytest.raises(KeyboardInterrupt):
        run_study(["cow"], ["original", "bbox", "qem"], settings, out, progress=False,
                  on_row=crash)
    with sqlite3.connect(out / "results.sqlite") as db:  # the first row, and any other
        stored = db.execute("SELECT COUNT(*) FROM results").fetchone()[0]  # done meanwhile
    assert 1 <= stored <= 3
    assert not list(out.rglob("*.tmp"))  # no half-written file
    done = []
    rows = run_study(["cow"], ["original", "bbox", "qem"], settings, out, progress=False,
                     on_row=lambda r: done.append(r["method"]))
    assert seen[0] not in done and len(done) == 3 - stored  # only the unfinished jobs ran
    clean = run_study(["cow"], ["original", "bbox", "qem"], settings, tmp_path / "c",
                      progress=False)
    strip = lambda rs: [{k: v for k, v in r.items() if not k.startswith("seconds")}  # noqa: E731
                        for r in rs]
    assert strip(rows) == strip(clean)


def test_compare_paired_against_reference(tmp_path, capsys):
    assert main(["compare", "fat-torus", "--methods", "original,bbox", "--versus", "original",
                 "--views", "6", "--quads", "500", "--res", "32", "--rays", "1000",
                 "--no-culling", "--out", str(tmp_path), "--json"]) == 0
    paired = json.loads(capsys.readouterr().out)["paired"]
    assert len(paired) == 1 and paired[0]["method"] == "bbox"
    assert paired[0]["precision_diff"] < 0 and paired[0]["prob_better_precision"] == 0.0
    assert paired[0]["recall_diff"] == 0.0


def test_compare_keeps_occluders_in_float64(tmp_path, capsys):
    # far from the origin float32 vertices move by ~0.06: the kept file must be the occluder
    import numpy as np
    import trimesh

    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    box.apply_translation([1e6 + 0.123456789, -2e6 + 0.987654321, 0.5])
    mesh = tmp_path / "far.ply"
    box.export(mesh, encoding="ascii")
    out = tmp_path / "study"
    assert main(["compare", str(mesh), "--methods", "bbox", "--views", "2", "--quads", "20",
                 "--res", "16", "--rays", "200", "--no-culling", "--out", str(out),
                 "--quiet"]) == 0
    capsys.readouterr()
    (ply,) = (out / "occluders").glob("*.ply")
    kept = trimesh.load(ply, force="mesh", process=False)
    np.testing.assert_array_equal(kept.bounds, trimesh.load(mesh, process=False).bounds)


def test_compare_refuses_unknown_culling_methods_before_work(tmp_path, capsys):
    out = tmp_path / "study"
    assert main(["compare", "fat-torus", "--methods", "bbox", *TINY[:-1],
                 "--culling-methods", "bbox,magic", "--out", str(out)]) == 2
    assert "--culling-methods: unknown method 'magic'" in capsys.readouterr().err
    assert not out.exists()



@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs a read-only /proc")
@pytest.mark.parametrize("command", [["compare", "fat-torus", "--methods", "bbox", *TINY],
                                     ["uncertainty", "fat-torus", "fat-torus"]])
def test_an_unwritable_out_is_refused_before_any_work(command, capsys):
    # permission bits say "writable" to root on /proc: only a probe finds out
    assert main([*command, "--out", "/proc/self/viscore-study"]) == 2
    assert "cannot write in '/proc/self'" in capsys.readouterr().err


def test_views_reach_workers_once_through_a_file_and_the_folder_goes(tmp_path):
    import pickle

    from viscore import load_mesh
    from viscore.cli.study import runner
    from viscore.cli.study.runner import StudySettings, run_study, views_from_file

    settings = StudySettings(views=4, quads=300, resolution=24, directions=2, rays=1000,
                             budgets=(48,))
    stale = tmp_path / "s" / ".views-killed.tmp"  # a killed run's views folder
    stale.mkdir(parents=True)
    (stale / "0.pickle").write_bytes(b"x")
    loaded = run_study(["fat-torus"], ["bbox", "qem"], settings, tmp_path / "s", jobs=2,
                       progress=False)
    assert not stale.exists() and not list((tmp_path / "s").glob(".views-*"))
    given = run_study(["fat-torus"], ["bbox", "qem"], settings, tmp_path / "t", jobs=2,
                      progress=False, originals={"fat-torus": load_mesh("fat-torus")})
    strip = lambda rows: [{k: v for k, v in r.items() if not k.startswith("seconds")}  # noqa: E731
                          for r in rows]
    assert strip(loaded) == strip(given)
    # a worker reads each views file once and keeps one mesh's views
    views = runner.build_views("fat-torus", settings)
    path = tmp_path / "v.pickle"
    path.write_bytes(pickle.dumps(views))
    first = views_from_file(str(path))
    path.write_bytes(b"not read again")
    assert views_from_file(str(path)) is first
    assert list(runner._WORKER_VIEWS) == [str(path)]
    runner._WORKER_VIEWS.clear()


def test_compare_refused_scheduler_port_is_one_line_at_once(tmp_path, capsys, monkeypatch):
    """Issue 23: a port that refuses at once took dask's 30 s connect timeout to report.

    The refusal is found by a plain socket before dask's Client (whose connect
    timeout is for silence) is ever made: a Client made here fails the test.
    """
    import socket

    import distributed

    def no_client(*args, **kwargs):
        raise AssertionError("a refused port must be reported before a dask Client is made")

    monkeypatch.setattr(distributed, "Client", no_client)
    with socket.socket() as s:  # a loopback port nothing listens on once closed
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    out = tmp_path / "study"
    code = main(["compare", "cow", "--methods", "bbox", *TINY, "--scheduler",
                 f"tcp://127.0.0.1:{port}", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert "--scheduler" in err and "refused" in err and str(port) in err
    assert not out.exists()


def test_run_study_refused_scheduler_string_is_one_line(tmp_path):
    import socket

    from viscore import InputError
    from viscore.cli.study.runner import StudySettings, run_study

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(InputError, match="refused"):
        run_study(["cow"], ["bbox"], StudySettings(views=4, quads=300, resolution=32,
                                                   rays=1000, budgets=(64,)),
                  tmp_path / "study", scheduler=f"tcp://127.0.0.1:{port}", progress=False)


def test_compare_refuses_a_symlinked_occluders_folder(tmp_path, capsys):
    """Issue 23: STUDY/occluders -> elsewhere was followed: occluders landed outside the study."""
    out, elsewhere = tmp_path / "study", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (out / "occluders").symlink_to(elsewhere)
    assert main(["compare", "cow", "--methods", "bbox", *TINY, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "occluders" in err and "symbolic link" in err, err
    assert list(elsewhere.iterdir()) == []
    assert not (out / "results.sqlite").exists()


def test_study_folder_refuses_a_link_made_after_the_check(tmp_path):
    from viscore import InputError
    from viscore.cli.study.store import StudyFolder

    out, elsewhere = tmp_path / "study", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (out / "occluders").symlink_to(elsewhere)
    with pytest.raises(InputError, match="symbolic link"), StudyFolder(out):
        pass
    assert list(elsewhere.iterdir()) == []


@pytest.mark.parametrize("verbose", [False, True])
def test_compare_says_each_warning_once_with_its_count(tmp_path, capsys, verbose):
    """aabb-skins warns that building-house is open in each of its two budgets' jobs (held in
    the worker): one line with the count; --verbose says every job's lines as they come."""
    argv = (["--verbose"] if verbose else []) + [
        "compare", "building-house", "--methods", "aabb-skins", "--budget", "32,64",
        "--views", "2", "--quads", "100", "--res", "24", "--rays", "500", "--no-culling",
        "--out", str(tmp_path / "s"), "--json"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "building-house is not closed" in ln]
    if verbose:
        assert len(lines) == 2 and not any("(2 times)" in ln for ln in lines)
    else:
        assert len(lines) == 1 and lines[0].endswith("(2 times)")


def test_compare_culling_column_error_in_its_process_is_one_line(tmp_path, capsys,
                                                                monkeypatch):
    """The culling column runs in the study's worker processes beside the jobs: its bad
    input comes back as the one line and exit 2 it was in this process, and no results."""
    from viscore import InputError
    from viscore.generators import levels

    def broken(*args, **kwargs):
        raise InputError("culling: broken on purpose")

    monkeypatch.setattr(levels, "culling_column", broken)  # the forked workers have it too
    out = tmp_path / "s"
    argv = ["compare", "building-house", "--methods", "bbox", "--budget", "32", "--views", "2",
            "--quads", "100", "--res", "16", "--rays", "200", "--culling-frames", "2",
            "--out", str(out), "--json"]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert "culling: broken on purpose" in captured.err and "Traceback" not in captured.err
    assert captured.out == "" and not (out / "culling.json").exists()
    assert not (out / "results.json").exists()


def test_default_jobs_one_per_core_fewer_when_memory_does_not_fit(monkeypatch):
    from viscore import InputError
    from viscore.cli import compare_cmd

    monkeypatch.setattr(compare_cmd, "cpu_cores", lambda: 8)
    # the estimate grows with the jobs: 3 fit under the limit, 4 do not
    monkeypatch.setattr(compare_cmd, "study_memory", lambda settings, originals, jobs: jobs)

    def check(nbytes, what):
        if nbytes > 3:
            raise InputError("too much")

    monkeypatch.setattr(compare_cmd, "check_memory", check)
    assert compare_cmd._default_jobs(None, {}, 45) == 3
    assert compare_cmd._default_jobs(None, {}, 2) == 2  # never more than the jobs to run
    monkeypatch.setattr(compare_cmd, "cpu_cores", lambda: 2)
    assert compare_cmd._default_jobs(None, {}, 45) == 2
    monkeypatch.setattr(compare_cmd, "check_memory", lambda nbytes, what: check(9, what))
    assert compare_cmd._default_jobs(None, {}, 45) == 1  # the refusal is left to --jobs 1
