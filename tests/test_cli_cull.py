"""``viscore cull``: a small run end to end, and bad input -> exit 2 with one line."""

import json

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.cli import cull_cmd
from viscore.cli import main as cli_main


@pytest.fixture
def run(monkeypatch):
    """``viscore`` with the cull subcommand (until cli/main.py lists it)."""
    if cull_cmd not in cli_main._COMMANDS:
        monkeypatch.setattr(cli_main, "_COMMANDS", [*cli_main._COMMANDS, cull_cmd])

    def call(*argv):
        return cli_main.main(["cull", *map(str, argv)])
    return call


@pytest.fixture
def street(tmp_path):
    """A GLB: a wall, a box hidden behind it, and one tree mesh instanced twice beside."""
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(bounds=[[-5, 0, -0.5], [5, 6, 0.5]]),
                       geom_name="wall", node_name="wall")
    scene.add_geometry(trimesh.creation.box(bounds=[[-0.5, 0, 4.5], [0.5, 1, 5.5]]),
                       geom_name="box", node_name="box")
    tree = trimesh.creation.icosphere(subdivisions=1, radius=0.5)
    for i, x in enumerate((8.0, 10.0)):
        matrix = trimesh.transformations.translation_matrix((x, 0.5, 5))
        if i == 0:
            scene.add_geometry(tree, geom_name="tree", node_name="tree_0", transform=matrix)
        else:
            scene.graph.update(frame_to="tree_1", frame_from=scene.graph.base_frame,
                               matrix=matrix, geometry="tree")
    path = tmp_path / "street.glb"
    path.write_bytes(scene.export(file_type="glb"))
    cameras = tmp_path / "cameras.json"
    cameras.write_text(json.dumps([
        {"position": [0, 1.5, -10], "forward": [0, 0, 1]},
        {"position": [20, 1.5, 5], "forward": [-1, 0, 0], "fov": 60}]))
    return path, cameras


def test_cull_small_scene_json(run, street, tmp_path, capsys):
    scene, cameras = street
    out = tmp_path / "out"
    code = run(scene, "--path", cameras, "--occluders", "wall", "--methods", "aabb-skins",
               "--frusta-method", "aabb-skins", "--width", 64, "--height", 36, "--out", out,
               "--json")
    captured = capsys.readouterr()
    assert code == 0, captured.err
    doc = json.loads(captured.out)
    assert set(doc["totals"]) == {"none", "planar-frusta", "solid-frusta",
                                  "depth-buffer:aabb-skins"}
    assert len(doc["frames"]) == 2 and doc["occluder_objects"] == 1
    assert doc["settings"]["objects"] == 4
    for name, total in doc["totals"].items():
        assert total["conservative"] is True
        assert total["false_culls"] == 0, name
    assert doc["frames"][0]["solid-frusta"]["culled"] == 1  # the box behind the wall
    assert doc["frames"][1]["visible"] == 4
    assert json.loads((out / "cull.json").read_text())["totals"] == doc["totals"]
    assert len(json.loads((out / "cameras.json").read_text())) == 2
    assert (out / "triangles.png").stat().st_size > 0


def test_cull_text_table(run, street, tmp_path, capsys):
    scene, cameras = street
    # the paper's box test: the box behind the wall reaches the pixels of the wall's lower
    # edge, half empty at this size (the triangle test's cover rule culls it)
    code = run(scene, "--path", cameras, "--frames", 1, "--occluders", "wall", "--methods",
               "bbox", "--frusta-method", "bbox", "--width", 32, "--height", 18, "--out",
               tmp_path / "o", "--quiet", "--bounds", "box")
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "depth-buffer:bbox" in captured.out and "ray-cast truth" in captured.out
    rows = {line.split()[0]: line for line in captured.out.splitlines()[2:6]}
    totals = json.loads((tmp_path / "o" / "cull.json").read_text())["totals"]
    assert totals["depth-buffer:bbox"]["conservative"] is False  # bbox is not conservative
    # issue 23: it culled nothing in this frame, so the table reads '-', not 'no'
    assert totals["depth-buffer:bbox"]["culled"] == 0
    assert rows["depth-buffer:bbox"].endswith("-")
    assert rows["solid-frusta"].endswith("no")  # its box as a solid: not conservative
    assert rows["none"].endswith("-")  # culls nothing by definition


@pytest.mark.parametrize("make, args, match", [
    (None, ["missing.glb"], "no such file"),
    ("bad.glb", ["bad.glb"], "not a valid GLB"),
    ("empty.glb", ["empty.glb"], "empty"),
    (None, ["no-such-scene"], "not a built-in scene"),
])
def test_cull_bad_scene_exit_2(run, tmp_path, capsys, monkeypatch, make, args, match):
    monkeypatch.chdir(tmp_path)
    if make == "bad.glb":
        (tmp_path / make).write_bytes(b"glTF\x02\x00\x00\x00garbage")
    elif make:
        (tmp_path / make).write_bytes(b"")
    assert run(*args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and match in err
    assert not (tmp_path / "viscore-cull").exists()


@pytest.mark.parametrize("content, extra, match", [
    (None, [], "no such file"),
    ("not json", [], "not a valid JSON"),
    ('[{"position": [0, 1, 0]}]', [], "missing forward"),
    ("[]", [], "non-empty JSON list"),
    ('[{"position": [0, 1, 0], "forward": [0, 0, 1]}]', ["--methods", "nope"], "--methods"),
    ('[{"position": [0, 1, 0], "forward": [0, 0, 1]}]', ["--width", "0"], "--width"),
    ('[{"position": [0, 1, 0], "forward": [0, 0, 1]}]', ["--occluders", "nope"],
     "no object named"),
    ('[{"position": [0, 1, 0], "forward": [0, 0, 1]}]', ["--size-threshold", "-1"],
     "--size-threshold"),
    ('[{"position": [0, 1, 0], "forward": [0, 0, 1]}]', ["--buffer-scale", "100"],
     "--buffer-scale"),
    ('[{"position": [0, 1, 0], "forward": [0, 0, 1]}]', ["--out", "a/b/c"], "does not exist"),
    ('[{"position": [0, 1, 0], "forward": [0, 0, 1]}]', ["--frusta-method", "nope"],
     "--frusta-method: unknown method 'nope'"),
    # these crashed (exit 3) or ran: an integer beyond float64, JSON nested too deeply,
    # booleans and a nested list as a vector
    ('[{"position": [1' + "0" * 400 + ', 0, 0], "forward": [0, 0, 1]}]', [],
     "beyond float64"),
    ("[" * 100_000 + "]" * 100_000, [], "nested too deeply"),
    ('[{"position": [true, false, true], "forward": [0, 0, 1]}]', [], "list of 3 numbers"),
    ('[{"position": [[0, 1, 0]], "forward": [0, 0, 1]}]', [], "list of 3 numbers"),
    # a camera too far to see the scene: refused before the occluders are made
    ('[{"position": [1e300, 0, 0], "forward": [0, 0, 1]}]', [], "cannot see the scene"),
    ('[{"position": [0, 1, 0], "forward": [0, 0, 1]}]', ["--out", "/proc/viscore-cull"],
     "cannot write"),
])
def test_cull_bad_path_and_options_exit_2(run, street, tmp_path, capsys, monkeypatch, content,
                                          extra, match):
    monkeypatch.chdir(tmp_path)
    scene, _ = street
    cameras = tmp_path / "path.json"
    if content is not None:
        cameras.write_text(content)
    assert run(scene, "--path", cameras, "--width", 32, "--height", 18, *extra) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and match in err, err
    assert not (tmp_path / "viscore-cull").exists()


def test_bench_cull_and_culling_column_on_a_small_scene(street):
    from viscore.cli.bench.cull import bench_cull, bench_cull_text
    from viscore.generators.levels import culling_column

    scene, _ = street
    r = bench_cull(scene=str(scene), frames=3, repeats=1, method="aabb-skins")
    assert r["occludees"] == 4 and r["workers"] == 1 and r["frames"] == 3
    for key in ("frusta", "depth_buffer"):
        assert r[key]["median_ms"] > 0 and isinstance(r[key]["meets_target"], bool)
    assert "depth buffer 320 x 180" in bench_cull_text(r)
    column = culling_column(["aabb-skins", "bbox"], scene=str(scene), frames=3, width=64,
                            height=36)
    assert set(column) == {"aabb-skins", "bbox"}
    assert column["aabb-skins"]["false_culls"] == 0 and column["aabb-skins"]["conservative"]
    assert 0 <= column["bbox"]["culled_share"] <= 1


def test_culling_column_from_its_pieces_is_the_column_made_alone(tmp_path, monkeypatch):
    """compare's pool makes the column's occluders piece by piece (a method on a distinct
    mesh; a joined method at once): handed in, nothing is generated again and the column
    is the one made in one call."""
    from viscore.generators.levels import (
        column_piece,
        column_pieces,
        culling_column,
        occluders,
        runtimes,
    )
    from viscore.level import load_scene_objects

    # a town of 4 x 4 blocks, two meshes (a tower instanced 8 times, a hall 8 times), and
    # crates
    town = trimesh.Scene()
    tower = trimesh.creation.box(bounds=[[0, 0, 0], [4, 12, 4]])
    hall = trimesh.creation.box(bounds=[[0, 0, 0], [5, 6, 3]])
    for k in range(16):
        mesh, name = (tower, "tower") if (k + k // 4) % 2 else (hall, "hall")
        matrix = trimesh.transformations.translation_matrix((10.0 * (k % 4), 0, 10.0 * (k // 4)))
        town.add_geometry(mesh, geom_name=name, node_name=f"{name}_{k}", transform=matrix)
    crate = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    for k in range(20):  # the small things between them, hidden behind the blocks
        matrix = trimesh.transformations.translation_matrix((7.0 + 10 * (k % 4), 0,
                                                             7.0 + 8 * (k // 4)))
        town.add_geometry(crate, geom_name="crate", node_name=f"crate_{k}", transform=matrix)
    scene = tmp_path / "town.glb"
    scene.write_bytes(town.export(file_type="glb"))
    methods = ["aabb-skins", "bbox", "surface-patches"]
    pieces = column_pieces(methods, scene=str(scene))
    meshes = load_scene_objects(scene).meshes
    assert sorted((m, tuple(meshes[i].metadata["name"].split(":")[-1] for i in ids))
                  for m, ids in pieces) == [
        ("aabb-skins", ("hall",)), ("aabb-skins", ("tower",)), ("bbox", ("hall",)),
        ("bbox", ("tower",)), ("surface-patches", ())]
    made: dict = {}
    for method, ids in pieces:
        made.setdefault(method, {}).update(column_piece(method, ids, scene=str(scene)))
    alone = culling_column(methods, scene=str(scene), frames=6, width=64, height=36)

    def again(*args, **kwargs):
        raise AssertionError("generated again")

    for module in (runtimes, occluders):
        monkeypatch.setattr(module, "generate_held", again)
    monkeypatch.setattr(runtimes, "joined_occluder", again)
    given = culling_column(methods, scene=str(scene), frames=6, width=64, height=36, made=made)
    keys = ("culled_share", "false_culls", "conservative")
    assert {m: [given[m][k] for k in keys] for m in methods} == {
        m: [alone[m][k] for k in keys] for m in methods}
    assert alone["bbox"]["culled_share"] > 0  # blocks hide blocks: the column measured


def test_culling_column_tests_objects_as_cull_does_by_default(street, monkeypatch):
    """compare's culling column splits the level's chunks as `cull --bounds auto` does: the
    street's wall (0.66 of its diagonal) is tested through its clusters, the box and the
    trees (under 0.1) through their boxes; bounds='box' tests every object by its box."""
    from viscore.generators.levels import culling_column
    from viscore.level.scene_graph import load_scene_objects
    from viscore.metrics import culling

    scene, _ = street
    seen = []
    real = culling.simulate_culling

    def spy(*args, bounds=None, **kwargs):
        seen.append(bounds)
        return real(*args, bounds=bounds, **kwargs)

    monkeypatch.setattr(culling, "simulate_culling", spy)
    auto = culling_column(["bbox"], scene=str(scene), frames=2, width=32, height=18)
    box = culling_column(["bbox"], scene=str(scene), frames=2, width=32, height=18,
                         bounds="box")
    names = load_scene_objects(scene).names
    owners = dict(zip(names, np.bincount(seen[0][2], minlength=len(names)), strict=True))
    assert owners.pop("wall") > 1 and set(owners.values()) == {1}, owners
    assert seen[1] is None
    assert 0 <= auto["bbox"]["culled_share"] <= 1 and 0 <= box["bbox"]["culled_share"] <= 1
    with pytest.raises(InputError, match="bounds"):
        culling_column(["bbox"], scene=str(scene), frames=2, bounds="clusters")


def test_cull_default_chooses_objects_as_occlude_does(run, tmp_path, capsys, monkeypatch):
    """Three equal boxes (none 2.5 x the median, the former default's refusal) all get
    occluders: each is over 2% of the level's diagonal."""
    monkeypatch.chdir(tmp_path)
    scene = trimesh.Scene()
    for k in range(3):
        scene.add_geometry(trimesh.creation.box(), geom_name=f"b{k}", node_name=f"b{k}",
                           transform=trimesh.transformations.translation_matrix((3 * k, 0, 0)))
    (tmp_path / "same.glb").write_bytes(scene.export(file_type="glb"))
    assert run("same.glb", "--frames", 3, "--width", 32, "--height", 18, "--methods",
               "aabb-skins", "--json") == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["occluder_objects"] == 3 and doc["settings"]["objects"] == 3


def test_cull_splits_a_level_of_one_mesh(run, tmp_path, capsys, monkeypatch):
    """A glTF holding one mesh (a map exported whole) and the same level as a PLY: split
    into its parts, a floor, a wall and the box hidden behind it, which the wall's occluder
    culls from a camera in front of the wall (the PLY's up axis guessed: the floor's)."""
    monkeypatch.chdir(tmp_path)
    floor = trimesh.creation.box(bounds=[[-12, -0.2, -12], [12, 0, 12]])
    wall = trimesh.creation.box(bounds=[[-5, 0, -0.5], [5, 6, 0.5]])
    box = trimesh.creation.box(bounds=[[-0.5, 0, 4.5], [0.5, 1, 5.5]])
    level = trimesh.util.concatenate([floor, wall, box])
    scene = trimesh.Scene()
    scene.add_geometry(level, geom_name="map", node_name="map")
    (tmp_path / "map.glb").write_bytes(scene.export(file_type="glb"))
    level.export(tmp_path / "map.ply")
    cameras = tmp_path / "cameras.json"
    cameras.write_text(json.dumps([{"position": [0, 1.5, -10], "forward": [0, 0, 1]}]))
    for name in ("map.glb", "map.ply"):
        code = run(name, "--path", cameras, "--methods", "aabb-skins", "--frusta-method",
                   "aabb-skins", "--width", 256, "--height", 144, "--json", "--out",
                   f"o-{name}")
        captured = capsys.readouterr()
        assert code == 0, captured.err
        doc = json.loads(captured.out)
        assert doc["settings"]["objects"] == 3 and doc["occluder_objects"] == 3
        assert doc["ground_truth"]["visible"] == 2
        assert doc["totals"]["depth-buffer:aabb-skins"]["culled"] == 1
        assert doc["totals"]["depth-buffer:aabb-skins"]["false_culls"] == 0


@pytest.mark.parametrize("fail", [KeyboardInterrupt, OSError(28, "No space left on device")])
def test_cull_interrupted_while_writing_leaves_nothing(run, street, tmp_path, capsys,
                                                       monkeypatch, fail):
    def broken_plot(*args, **kwargs):
        raise fail

    monkeypatch.setattr(cull_cmd, "culling_plot", broken_plot)
    scene, cameras = street
    out = tmp_path / "out"
    code = run(scene, "--path", cameras, "--occluders", "wall", "--methods", "bbox",
               "--frusta-method", "bbox", "--width", 32, "--height", 18, "--out", out, "--quiet")
    assert code == (130 if fail is KeyboardInterrupt else 2)
    assert capsys.readouterr().err.count("\n") == 1
    assert not out.exists()
    out.mkdir()  # an existing folder: no file, no temporary file left in it
    assert run(scene, "--path", cameras, "--occluders", "wall", "--methods", "bbox",
               "--frusta-method", "bbox", "--width", 32, "--height", 18, "--out", out,
               "--quiet") == code
    assert list(out.iterdir()) == []


# --------------------------------------------------------------------------- issue 23
_SMALL = ["--occluders", "wall", "--methods", "bbox", "--frusta-method", "bbox", "--width", 32,
          "--height", 18, "--quiet"]


def _one_line(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err


def test_cull_path_over_the_frame_cap_refused_before_reading_cameras(run, street, tmp_path,
                                                                     capsys, monkeypatch):
    """--frames was capped at 100,000 while a --path of 10^6 cameras ran (1.25 GB in 35 s)."""

    from viscore.metrics import camera_paths

    monkeypatch.chdir(tmp_path)
    scene, _ = street
    big = tmp_path / "big.json"
    big.write_text(json.dumps([{"position": [0, 1.5, -10], "forward": [0, 0, 1]}]
                              * (cull_cmd.MAX_FRAMES + 1)))

    def no_pose(*a, **k):
        raise AssertionError("no camera may be checked past the cap")

    monkeypatch.setattr(camera_paths, "_pose", no_pose)
    assert run(scene, "--path", big, *_SMALL) == 2
    err = _one_line(capsys)
    assert "100,001 cameras" in err and "100,000" in err and str(big) in err, err
    assert not (tmp_path / "viscore-cull").exists()


def test_cull_frames_and_path_share_the_memory_estimate(run, street, tmp_path, capsys,
                                                        monkeypatch):
    from viscore._validate import available_memory

    monkeypatch.chdir(tmp_path)
    scene, _ = street
    # a 1 MB limit: a 32 x 18 ground truth fits, 1,000 frames (about 10 MB) do not
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", str(1e6 / available_memory()))
    many = tmp_path / "many.json"
    many.write_text(json.dumps([{"position": [0, 1.5, -10], "forward": [0, 0, 1]}] * 1000))
    assert run(scene, "--path", many, *_SMALL) == 2
    err = _one_line(capsys)
    assert f"--path {many} (1,000 cameras): needs about" in err, err
    assert run(scene, "--frames", 1000, *_SMALL) == 2
    assert "--frames 1000: needs about" in _one_line(capsys)
    # --frames keeps the first N of a path: within the limit (raised to 1 GB: report.html's
    # pictures need about 170 MB whatever the frames)
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", str(1e9 / available_memory()))
    assert run(scene, "--path", many, "--frames", 2, *_SMALL) == 0, capsys.readouterr().err


@pytest.mark.parametrize("fov, ok", [(1e-300, False), (0.05, False), (0.1, True), (179, True),
                                     (179.5, False), (180, False)])
def test_read_camera_path_fov_range(tmp_path, fov, ok):
    from viscore import InputError
    from viscore.metrics.camera_paths import MAX_FOV, MIN_FOV, read_camera_path

    assert (MIN_FOV, MAX_FOV) == (0.1, 179.0)
    path = tmp_path / "p.json"
    path.write_text(json.dumps([{"position": [0, 1, 0], "forward": [0, 0, 1]},
                                {"position": [0, 1, 0], "forward": [0, 0, 1], "fov": fov}]))
    if ok:
        assert read_camera_path(path)[1].fov == fov
    else:
        with pytest.raises(InputError, match=r"camera 1\.fov: expected degrees in \[0.1, 179\]"):
            read_camera_path(path)


def test_cull_tiny_fov_refused_naming_the_camera(run, street, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scene, _ = street
    path = tmp_path / "p.json"
    path.write_text(json.dumps([{"position": [0, 1.5, -10], "forward": [0, 0, 1]},
                                {"position": [0, 1.5, -10], "forward": [0, 0, 1],
                                 "fov": 1e-300}]))
    assert run(scene, "--path", path, *_SMALL) == 2
    assert f"{path}: camera 1.fov: expected degrees in [0.1, 179], got 1e-300" in _one_line(capsys)


def test_cull_a_second_run_on_a_locked_folder_is_refused(run, street, tmp_path, capsys):
    """Two cull --out D at once both exited 0, their renames interleaved."""
    import fcntl
    import os

    scene, cameras = street
    out = tmp_path / "out"
    out.mkdir()
    fd = os.open(out, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)  # another cull holds the folder
        assert run(scene, "--path", cameras, *_SMALL, "--out", out) == 2
        assert "another cull is writing" in _one_line(capsys)
        assert list(out.iterdir()) == []
    finally:
        os.close(fd)
    assert run(scene, "--path", cameras, *_SMALL, "--out", out) == 0  # released: it runs
    assert sorted(p.name for p in out.iterdir()) == sorted(cull_cmd._OUTPUTS)


def _set_of(out) -> tuple:
    doc = json.loads((out / "cull.json").read_text())
    cameras = json.loads((out / "cameras.json").read_text())
    assert len(doc["frames"]) == len(cameras)  # one run's set
    return len(cameras), (out / "triangles.png").stat().st_ino


def test_cull_killed_before_the_swap_keeps_the_old_set_and_the_next_run_sweeps(
        run, street, tmp_path, capsys, monkeypatch):
    """A killed run left a new triangles.png beside an old cull.json, and temp files for good."""
    scene, cameras = street
    out = tmp_path / "out"
    one = tmp_path / "one.json"
    one.write_text(json.dumps(json.loads(cameras.read_text())[:1]))
    assert run(scene, "--path", cameras, *_SMALL, "--out", out) == 0
    assert _set_of(out)[0] == 2
    (out / "notes.txt").write_text("mine")  # a file of the user's stays
    # what earlier versions and a SIGKILL leave: temporary files inside, a set beside
    (out / ".cull.abc123.json").write_text("{")
    (out / ".cameras.abc123.json").write_text("[")

    def killed(new, target):  # SIGKILL just before the swap: nothing cleans up
        raise KeyboardInterrupt

    from viscore import _atomic

    with pytest.MonkeyPatch.context() as kill:
        kill.setattr(_atomic, "swap_folder", killed)
        kill.setattr(_atomic.LockedFolder, "_settle", lambda self, folder: None)
        assert run(scene, "--path", one, *_SMALL, "--out", out) == 130
    capsys.readouterr()
    assert _set_of(out)[0] == 2  # the old set, whole
    assert len(list(tmp_path.glob(".out.cull-*.tmp"))) == 1
    assert run(scene, "--path", one, *_SMALL, "--out", out) == 0, capsys.readouterr().err
    assert _set_of(out)[0] == 1  # the new set, whole
    assert sorted(p.name for p in out.iterdir()) == sorted([*cull_cmd._OUTPUTS, "notes.txt"])
    assert (out / "notes.txt").read_text() == "mine"
    assert list(tmp_path.glob(".out.*.tmp")) == []


@pytest.mark.parametrize("exchange", [True, False])
def test_swap_folder_replaces_a_set_in_one_step(tmp_path, monkeypatch, exchange):
    from viscore import _atomic

    if not exchange:  # the two-rename fallback of systems without RENAME_EXCHANGE
        monkeypatch.setattr(_atomic, "_exchange", lambda a, b: False)
    target, new = tmp_path / "out", tmp_path / ".out.new"
    target.mkdir()
    new.mkdir()
    (target / "a").write_text("old")
    (new / "a").write_text("new")
    (new / "b").write_text("new")
    _atomic.swap_folder(new, target)
    assert {p.name: p.read_text() for p in target.iterdir()} == {"a": "new", "b": "new"}
    assert {p.name: p.read_text() for p in new.iterdir()} == {"a": "old"}
    assert sorted(p.name for p in tmp_path.iterdir()) == [".out.new", "out"]


def test_cull_long_run_says_how_long(run, street, tmp_path, capsys, monkeypatch):
    """A cull of hours started with a bare bar; the estimate comes from a timed first batch."""
    from viscore.cli import _common

    monkeypatch.setattr(_common, "ESTIMATE_WARN_SECONDS", 0.0)  # every run is "long"
    monkeypatch.setattr(_common.RateEstimate, "FIRST_SECONDS", 0.0)
    scene, cameras = street
    out = tmp_path / "out"
    assert run(scene, "--frames", 4, *_SMALL[:-1], "--out", out, "--json") == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["settings"]["frames"] == 4  # stdout: the document alone
    # the first frame (warm-up) is not timed: the rate is that of the second
    assert "cull: 4 frames: estimated" in captured.err
    assert "2 frames to go" in captured.err and "measured on 1 after the first" in captured.err


def test_rate_estimate_leaves_the_warm_up_out():
    """A first step of 60 s (numba compiling), then steps of 2 s and 1 s: 100 steps to go
    at 1.5 s take 150 s, not the 2,100 s that the mean of all three steps would give."""
    from viscore.cli._common import RateEstimate

    now = [0.0]
    seen = []
    tick = RateEstimate("x", 103, "steps", seen.append, clock=lambda: now[0])
    for seconds in (60.0, 2.0, 1.0):  # said once the steps after the first took 3 s
        now[0] += seconds
        tick()
    assert tick.estimate == 100 * 1.5 and seen == [1, 1, 1]
    now[0] += 50.0
    tick()  # said once only
    assert tick.estimate == 150.0


def test_cull_table_conservative_cell():
    assert cull_cmd._conservative_cell({"culled": 0, "conservative": False}) == "-"
    assert cull_cmd._conservative_cell({"culled": 0, "conservative": True}) == "-"
    assert cull_cmd._conservative_cell({"culled": 3, "conservative": False}) == "no"
    assert cull_cmd._conservative_cell({"culled": 3, "conservative": True}) == "yes"


def test_cull_out_may_not_be_the_working_directory(run, street, tmp_path, capsys, monkeypatch):
    """The set is swapped in as a folder: swapping the working directory away is refused."""
    scene, _ = street
    work = tmp_path / "work"
    work.mkdir()
    (work / "keep.txt").write_text("mine")
    monkeypatch.chdir(work)
    for out in (".", str(tmp_path)):
        assert run(scene, "--out", out, *_SMALL) == 2
        assert "--out" in _one_line(capsys)
    assert sorted(p.name for p in work.iterdir()) == ["keep.txt"]


def test_cull_takes_the_up_axis_of_a_single_mesh_level(run, tmp_path, capsys, monkeypatch):
    """--up as occlude takes it: a PLY level lying along z is walked with z up when told
    (the guess would pick the floor's axis anyway; told otherwise, the walk follows), and a
    glTF, +Y up by the specification, takes another axis when told."""
    monkeypatch.chdir(tmp_path)
    floor = trimesh.creation.box(bounds=[[-12, -12, -0.2], [12, 12, 0]])
    wall = trimesh.creation.box(bounds=[[-5, -0.5, 0], [5, 0.5, 6]])
    trimesh.util.concatenate([floor, wall]).export(tmp_path / "map.ply")
    code = run("map.ply", "--up", "z", "--frames", 4, "--methods", "bbox", "--width", 64,
               "--height", 36, "--json", "--out", "o-z")
    captured = capsys.readouterr()
    assert code == 0, captured.err
    cams = json.loads((tmp_path / "o-z" / "cameras.json").read_text())
    assert all(abs(c["up"][2]) == 1.0 for c in cams)
    scene = trimesh.Scene()
    scene.add_geometry(floor, geom_name="floor", node_name="floor")
    (tmp_path / "map.glb").write_bytes(scene.export(file_type="glb"))
    # a glTF written +Z up (the floor lies in z): told so, it is walked z up too
    assert run("map.glb", "--up", "z", "--frames", 4, "--methods", "bbox", "--width", 64,
               "--height", 36, "--json", "--out", "o-g") == 0
    cams = json.loads((tmp_path / "o-g" / "cameras.json").read_text())
    assert all(abs(c["up"][2]) == 1.0 for c in cams)
    assert run("map.glb", "--frames", 4, "--methods", "bbox", "--width", 64, "--height", 36,
               "--json", "--out", "o-y") == 0  # and +Y by default, as the specification says
    cams = json.loads((tmp_path / "o-y" / "cameras.json").read_text())
    assert all(abs(c["up"][1]) == 1.0 for c in cams)


def test_cull_table_suggests_split_bounds_only_when_the_box_leaves_most_hidden_objects():
    def doc(kind, hidden, best, conservative=True):
        return {"bounds": {"kind": kind}, "ground_truth": {"hidden_share": hidden},
                "totals": {"none": {"culled_share": 0.0, "conservative": True},
                           "depth-buffer:x": {"culled_share": best,
                                              "conservative": conservative}}}
    assert "--bounds triangles (the default)" in cull_cmd._bounds_hint(doc("box", 0.41, 0.062))
    assert "--bounds triangles" in cull_cmd._bounds_hint(doc("auto", 0.41, 0.062))
    assert cull_cmd._bounds_hint(doc("box", 0.41, 0.21)) is None  # half of it culled
    assert cull_cmd._bounds_hint(doc("box", 0.15, 0.0)) is None  # the truth hides little
    assert cull_cmd._bounds_hint(doc("clusters", 0.41, 0.062)) is None
    assert cull_cmd._bounds_hint(doc("meshlets", 0.41, 0.062)) is None
    assert cull_cmd._bounds_hint(doc("triangles", 0.41, 0.062)) is None
    # a runtime without the guarantee does not count
    assert "--bounds triangles" in cull_cmd._bounds_hint(doc("box", 0.41, 0.3, False))


def test_cull_single_mesh_of_one_part_says_so(run, tmp_path, capsys):
    # a map whose components all join into one part: one object, nothing to cull behind it
    mesh = trimesh.util.concatenate([trimesh.creation.box(bounds=[[0, 0, 0], [10, 1, 10]]),
                                     trimesh.creation.box(bounds=[[2, 1, 2], [2.1, 1.1, 2.1]])])
    path = tmp_path / "map.obj"
    mesh.export(path)
    assert run(path, "--frames", 2, "--methods", "bbox", "--frusta-method", "bbox", "--width",
               32, "--height", 18, "--out", tmp_path / "out") == 0
    err = capsys.readouterr().err
    assert "stays one object (its 2 connected components join into one part)" in err
    # stderr is not a terminal here: no progress bars redrawn into it
    assert "frames:" not in err and "occluders:" not in err and "\r" not in err


def _figures(doc):
    """The document without what varies from run to run: times and provenance."""
    if isinstance(doc, dict):
        return {k: _figures(v) for k, v in doc.items()
                if k != "provenance" and "overhead" not in k and not k.startswith("seconds")}
    if isinstance(doc, list):
        return [_figures(v) for v in doc]
    return doc


def _cull_json(run, scene, out, capsys, *extra):
    code = run(scene, "--frames", 5, "--occluders", "wall", "--methods", "aabb-skins",
               "--frusta-method", "aabb-skins", "--width", 64, "--height", 36, "--out", out,
               "--json", *extra)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return json.loads(captured.out)


def test_cull_jobs_spread_frames_same_json_as_one_process(run, street, tmp_path, capsys):
    scene, _ = street
    one = _cull_json(run, scene, tmp_path / "one", capsys)
    two = _cull_json(run, scene, tmp_path / "two", capsys, "--jobs", 2)
    assert len(one["frames"]) == 5
    assert _figures(two) == _figures(one)
    assert [f["frame"] for f in two["frames"]] == list(range(5))


def test_cull_scheduler_spreads_frames_same_json_as_one_process(run, street, tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    scene, _ = street
    one = _cull_json(run, scene, tmp_path / "one", capsys)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        dask = _cull_json(run, scene, tmp_path / "dask", capsys, "--scheduler",
                          cluster.scheduler_address)
    assert _figures(dask) == _figures(one)


def test_cull_jobs_and_scheduler_refused_together(run, street, tmp_path, capsys):
    scene, _ = street
    assert run(scene, "--jobs", 2, "--scheduler", "tcp://127.0.0.1:1", "--out",
               tmp_path / "o") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--scheduler" in err[0] and "--jobs" in err[0]
    assert not (tmp_path / "o").exists()


def test_cull_scheduler_refused_before_any_work(run, street, tmp_path, capsys, monkeypatch):
    import viscore.cli.cull_cmd as cc

    def no_level(*args, **kwargs):
        raise AssertionError("the level was read before the address was refused")

    monkeypatch.setattr(cc, "level_objects", no_level)
    scene, _ = street
    assert run(scene, "--scheduler", "tcp://127.0.0.1:1", "--out", tmp_path / "o") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "connection refused" in err[0]
    assert not (tmp_path / "o").exists()
