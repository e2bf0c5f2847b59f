import json

import trimesh

from viscore.cli.main import main


def test_data_list_json_names_builtin_scenes(capsys):
    assert main(["data", "list", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    names = [s["name"] for s in doc["scenes"]]
    assert {"fat-torus", "sponge", "bunny"} <= set(names)
    assert [s["name"] for s in doc["culling_scenes"]] == ["city", "city-dense"]


def test_data_export_copies_a_culling_scene_as_glb(tmp_path, capsys):
    from viscore.level.scene_graph import load_scene_objects

    out = tmp_path / "city.glb"
    assert main(["data", "export", "city", "-o", str(out)]) == 0
    assert len(load_scene_objects(out).names) == len(load_scene_objects("city").names) >= 1000
    assert main(["data", "export", "city", "-o", str(tmp_path / "city.ply")]) == 2
    assert not (tmp_path / "city.ply").exists()


def test_data_export_writes_loadable_mesh(tmp_path, capsys):
    out = tmp_path / "t.ply"
    assert main(["data", "export", "fat-torus", "-o", str(out)]) == 0
    assert len(trimesh.load(out).faces) == 2304


def test_data_export_unknown_scene_exit_2_one_line(tmp_path, capsys):
    out = tmp_path / "x.ply"
    assert main(["data", "export", "nope", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nope" in err[0]
    assert not out.exists()


def test_unwritable_output_exit_2_one_line(capsys):
    assert main(["data", "export", "cow", "-o", "/proc/viscore-test/x.ply"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("viscore: error:")
