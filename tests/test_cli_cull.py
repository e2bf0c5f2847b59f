"""``viscore cull``: a small run end to end, and bad input -> exit 2 with one line."""

import json

import pytest
import trimesh
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
    code = run(scene, "--path", cameras, "--frames", 1, "--occluders", "wall", "--methods",
               "bbox", "--frusta-method", "bbox", "--width", 32, "--height", 18, "--out",
               tmp_path / "o", "--quiet")
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "depth-buffer:bbox" in captured.out and "ray-cast truth" in captured.out
    rows = {line.split()[0]: line for line in captured.out.splitlines()[2:6]}
    assert rows["depth-buffer:bbox"].endswith("no")  # bbox is not conservative
    assert rows["solid-frusta"].endswith("no")  # its box as a solid: not conservative


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
    from viscore.cli.bench.cull import bench_cull, bench_cull_text, culling_column

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


def test_cull_default_threshold_names_the_options(run, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scene = trimesh.Scene()
    for k in range(3):  # equal objects: none is 2.5 x the median
        scene.add_geometry(trimesh.creation.box(), geom_name=f"b{k}", node_name=f"b{k}",
                           transform=trimesh.transformations.translation_matrix((3 * k, 0, 0)))
    (tmp_path / "same.glb").write_bytes(scene.export(file_type="glb"))
    assert run("same.glb", "--frames", 3, "--width", 32, "--height", 18) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--size-threshold or --occluders" in err


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
