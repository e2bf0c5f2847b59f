"""``viscore generate``: methods, flags and checks built from the registry alone."""

import json
import os

import numpy as np
import pytest
import trimesh

from viscore.cli import generate_cmd
from viscore.cli.main import main
from viscore.generators import REGISTRY, GeneratorOption, GeneratorSpec, Occluder


def _err_lines(capsys) -> list[str]:
    return capsys.readouterr().err.strip().splitlines()


def _scene_for(name: str) -> tuple[str, np.ndarray]:
    """The built-in scene a method is run on here, and the box its occluder stays in:
    the fat torus (R = 1, r = 0.6), or the terrain for methods of height fields."""
    if REGISTRY[name].inputs == "height-fields":
        from viscore.builtin_scenes import scene_path
        from viscore.exchange.mesh_io import load_mesh

        return "terrain", np.asarray(load_mesh(scene_path("terrain")).bounds)
    return "fat-torus", np.array([[-1.6, -1.6, -0.6], [1.6, 1.6, 0.6]])


@pytest.mark.parametrize("name", list(REGISTRY))
def test_generate_every_registered_method_writes_the_reported_mesh(name, tmp_path, capsys):
    out = tmp_path / f"{name}.ply"
    scene, box = _scene_for(name)
    assert main(["generate", name, scene, "-o", str(out), "--json", "--quiet"]) == 0
    captured = capsys.readouterr()
    doc = json.loads(captured.out)
    assert captured.err == ""
    assert doc["method"] == name and doc["triangles"] > 0
    written = trimesh.load(out, force="mesh", process=False)
    assert len(written.faces) == doc["triangles"]
    # the occluder stays near the input: inside its box grown by 5% of the diagonal
    # (decimation and simplification may bulge a little)
    slack = 0.05 * np.linalg.norm(box[1] - box[0])
    assert (written.bounds[0] >= box[0] - slack).all()
    assert (written.bounds[1] <= box[1] + slack).all()


@pytest.mark.parametrize("name", list(REGISTRY))
def test_generate_budget_reported_for_every_method(name, tmp_path, capsys):
    out = tmp_path / "o.ply"
    scene = "terrain" if REGISTRY[name].inputs == "height-fields" else "cow"
    assert main(["generate", name, scene, "-o", str(out), "--budget", "64", "--json"]) == 0
    captured = capsys.readouterr()
    doc = json.loads(captured.out)
    assert doc["over_budget"] == (doc["triangles"] > 64)
    warned = [line for line in captured.err.splitlines() if "budget" in line]
    assert len(warned) == int(doc["over_budget"])
    if REGISTRY[name].budgeted:
        assert not doc["over_budget"]


def test_generate_bbox_under_budget_warns_once(tmp_path, capsys):
    out = tmp_path / "b.ply"
    assert main(["generate", "bbox", "cow", "-o", str(out), "--budget", "5", "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["over_budget"] is True
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and "12 triangles exceed the budget of 5" in err[0]


def test_generate_help_lists_methods_and_their_options(capsys):
    assert main(["generate", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for name, spec in REGISTRY.items():
        assert name in text and " ".join(spec.description.split()) in text
    for name, spec in REGISTRY.items():
        assert main(["generate", name, "--help"]) == 0
        text = capsys.readouterr().out
        for option in (*spec.options, ):
            assert option.flag in text
        assert "--budget" in text and "--seed" in text


def _cube_of_side(mesh, *, side=1.0, budget=None, seed=0):
    box = trimesh.creation.box(extents=(side, side, side))
    return Occluder(mesh=box, method="dummy", params={"side": side}, double_sided=False,
                    seconds=0.0, info={"seed_seen": seed})


def test_generate_dummy_spec_joins_the_cli_without_other_change(monkeypatch, tmp_path, capsys):
    spec = GeneratorSpec("dummy", _cube_of_side, "a cube of the given side", options=(
        GeneratorOption("side", float, 1.0, "cube side, world units", low=0, low_open=True),),
        budgeted=False)
    monkeypatch.setitem(REGISTRY, "dummy", spec)
    assert main(["generate", "--help"]) == 0
    assert "a cube of the given side" in capsys.readouterr().out
    assert main(["generate", "dummy", "--help"]) == 0
    assert "--side" in capsys.readouterr().out
    out = tmp_path / "d.obj"
    assert main(["generate", "dummy", "cow", "-o", str(out), "--side", "2.5", "--seed", "7",
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["params"] == {"side": 2.5} and doc["seed_seen"] == 7 and doc["triangles"] == 12
    np.testing.assert_allclose(trimesh.load(out, force="mesh").extents, [2.5] * 3)
    assert main(["generate", "dummy", "cow", "-o", str(out), "--side", "0"]) == 2
    err = _err_lines(capsys)
    assert len(err) == 1 and "--side" in err[0] and "> 0" in err[0]


def test_generate_bad_option_refused_before_loading(monkeypatch, tmp_path, capsys):
    def no_load(*a, **k):
        raise AssertionError("the mesh must not be loaded")

    monkeypatch.setattr(generate_cmd, "load_mesh", no_load)
    out = tmp_path / "a.ply"
    for argv in (["aabb-skins", "--voxels", "0"], ["aabb-skins", "--fill", "nan"],
                 ["aabb-skins", "--seed-voxel", "random"], ["godot", "--distance", "-1"],
                 ["qem", "--budget", "0"], ["qem", "--seed", "-5"], ["qem", "--voxels", "8"],
                 ["bbox", "-o", str(tmp_path / "x.xyz")]):
        assert main(["generate", argv[0], "cow", "-o", str(out), *argv[1:]]) == 2, argv
        err = _err_lines(capsys)
        assert len(err) == 1 and err[0].startswith("viscore: error:"), (argv, err)
        assert argv[1].split("-o")[-1] in err[0] or "x.xyz" in err[0]
    assert not out.exists()


def test_generate_seed_rule_any_size(tmp_path, capsys):
    out = tmp_path / "q.ply"
    big = 2**70
    assert main(["generate", "qem", "cow", "-o", str(out), "--budget", "32", "--seed", str(big),
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["seed"] == big


def test_generate_nullable_option_none(tmp_path, capsys):
    out = tmp_path / "a.ply"
    assert main(["generate", "aabb-skins", "fat-torus", "-o", str(out), "--voxels", "16",
                 "--max-boxes", "none", "--fill", "0.2", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["fill"] >= 0.2 and doc["triangles"] == 12 * doc["boxes"]


def _boxes_with_parts(mesh, *, budget=None, seed=0):
    """A generator whose occluder carries a hierarchy and two levels of detail."""
    from viscore.generators.planar_hierarchy import build_hierarchy

    boxes = [trimesh.creation.box(bounds=[[2.0 * i, 0, 0], [2.0 * i + 1, 1, 1]])
             for i in range(3)]
    root = build_hierarchy(boxes, node_occluder="qem", budget=12, voxels=4)
    lods = [{"distance": d, "voxels": v, "mesh": trimesh.creation.box(extents=(s, s, s))}
            for d, v, s in ((10.0, 64, 1.0), (40.0, 16, 2.0))]
    return Occluder(mesh=root["occluder"], method="parts", params={}, double_sided=True,
                    seconds=0.0, parts={"hierarchy": root, "lods": lods})


def test_generate_writes_hierarchy_and_lods_beside_the_output(monkeypatch, tmp_path, capsys):
    from viscore.generators.planar_hierarchy import hierarchy_from_json

    monkeypatch.setitem(REGISTRY, "parts", GeneratorSpec("parts", _boxes_with_parts,
                                                         "boxes with parts", budgeted=False))
    out = tmp_path / "occ.ply"
    assert main(["generate", "parts", "cow", "-o", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    tree = doc["hierarchy"]
    assert tree["file"] == str(tmp_path / "occ.hierarchy.json") and tree["nodes"] == 5
    assert sorted(tree["meshes"]) == sorted(str(p) for p in tmp_path.glob("occ.node*.ply"))
    root = hierarchy_from_json(tree["file"])
    assert len(root["children"]) == 2 and sorted(root["objects"].tolist()) == [0, 1, 2]
    assert [lod["file"] for lod in doc["lods"]] == [str(tmp_path / f"occ.lod{i}.ply")
                                                    for i in range(2)]
    assert [lod["distance"] for lod in doc["lods"]] == [10.0, 40.0]
    for lod, side in zip(doc["lods"], (1.0, 2.0), strict=True):
        written = trimesh.load(lod["file"], force="mesh", process=False)
        assert len(written.faces) == lod["triangles"] == 12
        np.testing.assert_allclose(written.extents, [side] * 3)
    assert len(trimesh.load(out, force="mesh", process=False).faces) == doc["triangles"]
    assert not list(tmp_path.glob(".*.tmp"))
    # text mode names the files too
    assert main(["generate", "parts", "cow", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "occ.hierarchy.json + 5 node meshes" in text and "occ.lod1.ply" in text


@pytest.mark.parametrize("failing", [5, "last"])
def test_generate_writes_the_output_and_its_parts_all_or_none(failing, monkeypatch, tmp_path,
                                                              capfd):
    """Issue 23: a failure on the 5th file, or on OUT after its parts, leaves no partial set.

    A set written before (a previous run's) keeps its content.
    """
    from viscore._atomic import FileSet

    monkeypatch.setitem(REGISTRY, "parts", GeneratorSpec("parts", _boxes_with_parts,
                                                         "boxes with parts", budgeted=False))
    out = tmp_path / "occ.ply"
    assert main(["generate", "parts", "cow", "-o", str(out)]) == 0
    capfd.readouterr()
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert len(before) == 9  # 5 node meshes, the tree JSON, 2 levels of detail, OUT
    for p in tmp_path.iterdir():
        p.unlink()
    (tmp_path / "occ.node0000.ply").write_bytes(b"an older node")
    (tmp_path / "notes.txt").write_bytes(b"the user's")
    kept = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    real = FileSet.write
    calls = []

    def write(self, name, data):
        calls.append(name)
        if len(calls) == (len(before) if failing == "last" else failing):
            raise OSError(28, "No space left on device", str(self.folder / name))
        return real(self, name, data)

    monkeypatch.setattr(FileSet, "write", write)
    assert main(["generate", "parts", "cow", "-o", str(out)]) == 2
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("viscore: error: No space left"), err
    assert calls[-1] == ("occ.ply" if failing == "last" else calls[4])
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == kept  # hidden files too


def _warning_tree(mesh, *, budget=None, seed=0):
    """A hierarchy whose node builder warns at every node and refuses the leaves."""
    import logging

    from viscore import InputError
    from viscore.generators.planar_hierarchy import build_hierarchy

    def builder(part, *, budget, seed):
        logging.getLogger("viscore.generators.test_builder").warning("this node is open")
        if part.extents.max() < 1.5:
            raise InputError("nothing inside")
        return trimesh.creation.box(bounds=part.bounds)

    boxes = [trimesh.creation.box(bounds=[[2.0 * i, 0, 0], [2.0 * i + 1, 1, 1]])
             for i in range(3)]
    root = build_hierarchy(boxes, node_occluder=builder, voxels=4)
    return Occluder(mesh=root["occluder"], method="tree", params={}, double_sided=True,
                    seconds=0.0, parts={"hierarchy": root})


def test_generate_hierarchy_says_each_node_warning_once(monkeypatch, tmp_path, capfd):
    """Issue 23: the same warning printed once per node (29 lines on city-block)."""
    monkeypatch.setitem(REGISTRY, "tree", GeneratorSpec("tree", _warning_tree, "a tree",
                                                        budgeted=False))
    assert main(["generate", "tree", "cow", "-o", str(tmp_path / "t.ply")]) == 0
    err = capfd.readouterr().err.strip().splitlines()
    assert err == ["viscore: hierarchy: 5 of 5 nodes: this node is open",
                   "viscore: hierarchy: 3 of 5 nodes: no occluder: nothing inside"]


def test_generate_solid_frusta_open_mesh_warns_once(tmp_path, capfd):
    """Issue 23: "not closed" printed twice for one generate (aabb-skins', then its own)."""
    assert main(["generate", "solid-frusta", "building-cottage", "-o", str(tmp_path / "s.ply"),
                 "--voxels", "32"]) == 0
    err = capfd.readouterr().err
    assert err.count("not closed") == 1, err
    assert "solid-frusta: building-cottage is not closed" in err, err


def test_generate_without_parts_writes_only_the_output(tmp_path, capsys):
    out = tmp_path / "b.ply"
    assert main(["generate", "bbox", "cow", "-o", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert "hierarchy" not in doc and "lods" not in doc
    assert [p.name for p in tmp_path.iterdir()] == ["b.ply"]


@pytest.mark.slow
def test_generate_planar_sections_hierarchy_writes_the_tree(tmp_path, capsys):
    from viscore.generators.planar_hierarchy import cut_hierarchy, hierarchy_from_json

    pair = trimesh.util.concatenate([trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]]),
                                     trimesh.creation.box(bounds=[[1.5, 0, 0], [2.5, 1, 1]])])
    src, out = tmp_path / "pair.ply", tmp_path / "occ.ply"
    pair.export(src)
    assert main(["generate", "planar-sections", str(src), "-o", str(out), "--hierarchy",
                 "--voxels", "12", "--budget", "16", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["nodes"] == 3 and doc["objects"] == 2 and doc["hierarchy"]["nodes"] == 3
    root = hierarchy_from_json(doc["hierarchy"]["file"])
    written = trimesh.load(out, force="mesh", process=False)
    np.testing.assert_array_equal(written.faces, root["occluder"].faces)
    assert len(cut_hierarchy(root, (1e6, 0, 0))) == 1
    assert len(cut_hierarchy(root, (1.25, 0.5, 0.5))) == 2  # between the boxes: both leaves


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs a read-only /proc")
@pytest.mark.parametrize("method", ["bbox", "parts"])
def test_generate_unwritable_output_folder_refused_before_any_work(monkeypatch, capsys,
                                                                   method):
    """Issue 23: a read-only folder ran the whole generation before exit 2, without naming -o.

    The probe covers the parts written beside OUT (a hierarchy's JSON and node meshes):
    they go to OUT's folder.
    """
    def no_work(*a, **k):
        raise AssertionError("nothing may be loaded or generated before -o is checked")

    monkeypatch.setitem(REGISTRY, "parts", GeneratorSpec("parts", _boxes_with_parts,
                                                         "boxes with parts", budgeted=False))
    monkeypatch.setattr(generate_cmd, "load_mesh", no_work)
    monkeypatch.setattr(generate_cmd, "generate", no_work)
    assert main(["generate", method, "cow", "-o", "/proc/o.ply"]) == 2
    err = _err_lines(capsys)
    assert len(err) == 1 and err[0].startswith("viscore: error: -o /proc/o.ply: cannot write"), err


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes in a read-only folder")
def test_generate_read_only_folder_refused_naming_the_option(monkeypatch, tmp_path, capsys):
    def no_work(*a, **k):
        raise AssertionError("nothing may be generated before -o is checked")

    monkeypatch.setattr(generate_cmd, "generate", no_work)
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        assert main(["generate", "bbox", "cow", "-o", str(folder / "o.ply")]) == 2
    finally:
        folder.chmod(0o755)
    err = _err_lines(capsys)
    assert len(err) == 1 and f"-o {folder / 'o.ply'}: cannot write" in err[0], err
    assert list(folder.iterdir()) == []


def test_generate_missing_output_folder_names_the_option(tmp_path, capsys):
    assert main(["generate", "bbox", "cow", "-o", str(tmp_path / "no" / "o.ply")]) == 2
    err = _err_lines(capsys)
    assert len(err) == 1 and f"-o {tmp_path / 'no' / 'o.ply'}: the folder" in err[0], err
