"""Occluder files of other tools on the command line: compare, cull, generate, evaluate.

``compare --occluder-files NAME=PATH`` (a row NAME assessed like a generated
method, keyed by the file's content), ``cull --occluder-files PATH`` (a runtime
``depth-buffer:<stem>``), ``generate -o .tres/.tscn/.glb`` (Godot's formats)
and ``evaluate``/``validate`` reading any occluder file.
"""

import json
import sqlite3
import struct

import numpy as np
import pytest
import trimesh

from viscore import OccluderInstance, load_mesh, load_occluder, tres_text, tscn_text
from viscore.cli.main import main
from viscore.exchange.mesh_io import mesh_bytes
from viscore.generators import generate
from viscore.generators.levels.occluders import file_occluder

#: Tiny study settings (as tests/test_cli_compare.py's).
TINY = ["--views", "4", "--quads", "300", "--res", "32", "--rays", "1000", "--no-culling"]


def _box_tres(path, bounds):
    box = trimesh.creation.box(bounds=bounds)
    path.write_text(tres_text(box.vertices, box.faces.ravel()))
    return path


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


@pytest.fixture
def torus_box(tmp_path):
    """A .tres ArrayOccluder3D: the bounding box of fat-torus (its bbox occluder)."""
    return _box_tres(tmp_path / "box.tres", load_mesh("fat-torus").bounds)


# --------------------------------------------------------------------------- compare
def test_compare_occluder_file_row_as_evaluate_assesses_it(tmp_path, capsys, torus_box):
    out = tmp_path / "study"
    assert main(["compare", "fat-torus", "--methods", "bbox", *TINY, "--versus", "bbox",
                 "--occluder-files", f"ext={torus_box}", "--out", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    rows = {r["method"]: r for r in doc["rows"]}
    assert list(rows) == ["bbox", "ext"]
    ext = rows["ext"]
    assert ext["triangles"] == 12 and ext["budget"] is None
    assert ext["info"]["conservative_guaranteed"] is False
    assert ext["occluder_source"] == str(torus_box)
    assert main(["evaluate", "fat-torus", str(torus_box), "--views", "4", "--quads", "300",
                 "--res", "32", "--json"]) == 0
    ev = json.loads(capsys.readouterr().out)
    assert ev["precision"] < 1  # a box over a torus covers more than it
    for key in ("precision", "recall", "precision_ci", "recall_ci"):
        assert ext[key] == ev[key], key
    assert [p["method"] for p in doc["paired"]] == ["ext"]  # paired like a method
    assert (out / "occluders" / ext["occluder_file"]).is_file()
    assert "<td>ext</td>" in (out / "report.html").read_text()
    assert "| ext |" in (out / "results.md").read_text()


def test_compare_occluder_folder_per_mesh_and_per_budget(tmp_path, capsys):
    cube = tmp_path / "cube.ply"
    cube.write_bytes(mesh_bytes(trimesh.creation.box(), "ply"))
    ball = tmp_path / "ball.ply"
    ball.write_bytes(mesh_bytes(trimesh.creation.icosphere(subdivisions=2), "ply"))
    folder = tmp_path / "theirs"
    folder.mkdir()
    _box_tres(folder / "cube.tres", [[-0.5] * 3, [0.5] * 3])
    _box_tres(folder / "ball.32.tres", [[-0.4] * 3, [0.4] * 3])
    low = trimesh.creation.icosphere(subdivisions=1)
    (folder / "ball.64.glb").write_bytes(mesh_bytes(low, "glb"))
    (folder / "other.tres").write_text("not looked at")  # no mesh of that name
    assert main(["compare", str(cube), str(ball), "--methods", "bbox", *TINY,
                 "--occluder-files", f"theirs={folder}", "--out", str(tmp_path / "s"),
                 "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    got = [(r["mesh"], r["method"], r["budget"], r["triangles"]) for r in rows]
    assert got == [(str(cube), "bbox", None, 12), (str(cube), "theirs", None, 12),
                   (str(ball), "bbox", None, 12), (str(ball), "theirs", 32, 12),
                   (str(ball), "theirs", 64, 80)]
    by = {(r["mesh"], r["budget"]): r for r in rows if r["method"] == "theirs"}
    assert by[str(ball), 64]["info"]["over_budget"] is True  # 80 triangles > 64
    assert by[str(ball), 32]["recall"] < 1  # the smaller box misses the ball's rim


@pytest.mark.parametrize("spec, expected", [
    ("bbox={file}", "bbox is a registered method"),
    ("qem={file}", "qem is a registered method"),
    ("ext={missing}", "no such file or folder"),
    ("ext={folder}", "no occluder file for mesh fat-torus; looked for {folder}/fat-torus.<ext>"),
    ("ext", "expected NAME=PATH"),
    ("a:b={file}", "NAME must be"),
])
def test_compare_occluder_files_refused_in_one_line_before_the_folder(tmp_path, capsys,
                                                                      torus_box, spec,
                                                                      expected):
    folder = tmp_path / "empty"
    folder.mkdir()
    (folder / "bunny.tres").write_text("another mesh's")
    fill = {"file": torus_box, "missing": tmp_path / "nope.tres", "folder": folder}
    out = tmp_path / "study"
    assert main(["compare", "fat-torus", "--methods", "bbox", *TINY, "--occluder-files",
                 spec.format(**fill), "--out", str(out)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert expected.format(**fill) in line and "--occluder-files" in line
    assert not out.exists()


def test_compare_bad_occluder_file_refused_before_the_folder(tmp_path, capsys):
    bad = tmp_path / "bad.tres"
    bad.write_text('[gd_resource type="ArrayOccluder3D" format=3]\n[resource]\nvertices = ')
    out = tmp_path / "study"
    assert main(["compare", "fat-torus", "--methods", "bbox", *TINY, "--occluder-files",
                 f"ext={bad}", "--out", str(out)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "ext" in line and str(bad) in line
    assert not out.exists()


def _store_rows(out):
    with sqlite3.connect(out / "results.sqlite") as db:
        return {k: json.loads(r) for k, r in db.execute("SELECT key, row FROM results")}


def test_compare_resume_reassesses_a_changed_occluder_file(tmp_path, capsys, torus_box):
    out = tmp_path / "study"
    argv = ["compare", "fat-torus", "--methods", "bbox", *TINY, "--occluder-files",
            f"ext={torus_box}", "--out", str(out), "--json"]
    assert main(argv) == 0
    first = {r["method"]: r for r in json.loads(capsys.readouterr().out)["rows"]}
    assert len(_store_rows(out)) == 2
    assert main(argv) == 0  # unchanged: both rows reused, timings and all
    again = {r["method"]: r for r in json.loads(capsys.readouterr().out)["rows"]}
    assert again == first and len(_store_rows(out)) == 2
    bounds = load_mesh("fat-torus").bounds
    _box_tres(torus_box, [bounds[0] * 0.5, bounds[1] * 0.5])  # same name, new content
    assert main(argv) == 0
    third = {r["method"]: r for r in json.loads(capsys.readouterr().out)["rows"]}
    assert third["bbox"] == first["bbox"]
    assert third["ext"]["key"] != first["ext"]["key"]
    assert third["ext"]["recall"] < first["ext"]["recall"]  # the smaller box, assessed
    assert len(_store_rows(out)) == 3


# --------------------------------------------------------------------------- cull
@pytest.fixture
def street(tmp_path):
    """A GLB: a wall and a box hidden behind it (tests/test_cli_cull.py's, trees aside)."""
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(bounds=[[-5, 0, -0.5], [5, 6, 0.5]]),
                       geom_name="wall", node_name="wall")
    scene.add_geometry(trimesh.creation.box(bounds=[[-0.5, 0, 4.5], [0.5, 1, 5.5]]),
                       geom_name="box", node_name="box")
    path = tmp_path / "street.glb"
    path.write_bytes(scene.export(file_type="glb"))
    cameras = tmp_path / "cameras.json"
    cameras.write_text(json.dumps([{"position": [0, 1.5, -10], "forward": [0, 0, 1]}]))
    return path, cameras


def _wall_tscn(path, matrix=None):
    matrix = np.eye(4) if matrix is None else matrix
    wall = trimesh.creation.box(bounds=[[-5, 0, -0.5], [5, 6, 0.5]])
    path.write_text(tscn_text([OccluderInstance("wall", "w", matrix)],
                              {"w": (wall.vertices, wall.faces.ravel())}))
    return path


CULL = ["--occluders", "wall", "--methods", "bbox", "--frusta-method", "bbox", "--width",
        "256", "--height", "144"]


def test_cull_occluder_file_is_a_depth_buffer_runtime(tmp_path, capsys, street):
    scene, cameras = street
    bake = _wall_tscn(tmp_path / "node_3d.tscn")
    out = tmp_path / "out"
    assert main(["cull", str(scene), "--path", str(cameras), *CULL, "--occluder-files",
                 str(bake), "--out", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert list(doc["totals"])[-2:] == ["depth-buffer:bbox", "depth-buffer:node_3d"]
    info = doc["runtimes"]["depth-buffer:node_3d"]
    assert info["conservative"] is False and info["triangles"] == 12
    assert info["file"] == str(bake)
    total = doc["totals"]["depth-buffer:node_3d"]
    assert total["conservative"] is False
    assert doc["frames"][0]["depth-buffer:node_3d"]["culled"] == 1  # the box behind the wall
    assert total["false_culls"] == 0
    assert json.loads((out / "cull.json").read_text())["runtimes"] == doc["runtimes"]


def test_cull_occlude_folder_reads_each_tscn_and_its_manifest(tmp_path, capsys, street):
    scene, cameras = street
    folder = tmp_path / "occ"
    folder.mkdir()
    _wall_tscn(folder / "sure.tscn")
    _wall_tscn(folder / "unsure.tscn")
    (folder / "sure.glb").write_bytes(b"not read: only the folder's .tscn files are")
    (folder / "occlude.json").write_text(json.dumps({
        "to_godot": np.eye(4).tolist(),
        "methods": {"sure": {"files": ["sure.tscn", "sure.glb"],
                             "conservative_guaranteed": True},
                    "unsure": {"files": ["unsure.tscn"], "conservative_guaranteed": False}}}))
    assert main(["cull", str(scene), "--path", str(cameras), *CULL, "--occluder-files",
                 str(folder), "--out", str(tmp_path / "out"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["runtimes"]["depth-buffer:sure"]["conservative"] is True
    assert doc["runtimes"]["depth-buffer:unsure"]["conservative"] is False
    assert doc["frames"][0]["depth-buffer:sure"]["culled"] == 1


def test_file_occluder_undoes_the_manifest_frame(tmp_path):
    # a +Z-up level: viscore occlude writes Godot's +Y-up frame and records to_godot
    to_godot = np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]])
    folder = tmp_path / "occ"
    folder.mkdir()
    _wall_tscn(folder / "bbox.tscn", to_godot)
    (folder / "occlude.json").write_text(json.dumps({
        "to_godot": to_godot.tolist(), "methods": {"bbox": {"files": ["bbox.tscn"]}}}))
    occ = file_occluder(folder / "bbox.tscn")
    np.testing.assert_allclose(occ.mesh.bounds, [[-5, 0, -0.5], [5, 6, 0.5]], atol=1e-6)
    assert occ.info["from_godot_frame"] and occ.info["conservative_guaranteed"] is False
    plain = file_occluder(_wall_tscn(tmp_path / "loose.tscn", to_godot))  # no manifest
    np.testing.assert_allclose(plain.mesh.bounds, [[-5, -0.5, -6], [5, 0.5, 0]], atol=1e-6)


@pytest.mark.parametrize("make, expected", [
    ("clash", "also the runtime of --methods bbox"),
    ("twice", "both name the runtime depth-buffer:wall"),
    ("empty-folder", "without *.tscn"),
    ("missing", "no such file"),
])
def test_cull_occluder_files_refused_in_one_line(tmp_path, capsys, street, make, expected):
    scene, cameras = street
    if make == "clash":
        paths = [_wall_tscn(tmp_path / "bbox.tscn")]
    elif make == "twice":
        (tmp_path / "a").mkdir()
        paths = [_wall_tscn(tmp_path / "wall.tscn"), _wall_tscn(tmp_path / "a" / "wall.tscn")]
    elif make == "empty-folder":
        (tmp_path / "none").mkdir()
        paths = [tmp_path / "none"]
    else:
        paths = [tmp_path / "nope.occ"]
    out = tmp_path / "out"
    assert main(["cull", str(scene), "--path", str(cameras), *CULL, "--occluder-files",
                 ",".join(map(str, paths)), "--out", str(out)]) == 2
    assert expected in _one_line(capsys.readouterr().err)
    assert not out.exists()


# --------------------------------------------------------------------------- generate
@pytest.mark.parametrize("fmt, source, names", [
    ("tres", "godot-tres", ["occ"]),
    ("tscn", "godot-tscn", ["fat-torus"]),
    ("glb", "glb-occonly", ["fat-torus-occonly"]),
])
def test_generate_godot_outputs_round_trip_float32(tmp_path, capsys, fmt, source, names):
    out = tmp_path / f"occ.{fmt}"
    assert main(["generate", "qem", "fat-torus", "--budget", "64", "-o", str(out)]) == 0
    back = load_occluder(out)
    assert back.metadata["source_format"] == source
    assert back.metadata["object_names"] == names
    made = generate("qem", load_mesh("fat-torus"), budget=64, seed=0).mesh
    want = np.asarray(made.vertices, dtype=np.float32)[made.faces]
    got = np.asarray(back.vertices)[back.faces]
    assert got.dtype == np.float64
    np.testing.assert_array_equal(got, want.astype(np.float64))
    assert not list(tmp_path.glob(".*"))  # written atomically: no temporary file left


def _glb_parts(data: bytes):
    n = struct.unpack("<I", data[12:16])[0]
    return json.loads(data[20:20 + n]), data[20 + n:]


def test_generate_glb_differs_from_the_mesh_glb_by_its_node_name_only(tmp_path, capsys):
    out = tmp_path / "occ.glb"
    assert main(["generate", "qem", "fat-torus", "--budget", "64", "-o", str(out)]) == 0
    made = generate("qem", load_mesh("fat-torus"), budget=64, seed=0).mesh
    plain_json, plain_bin = _glb_parts(mesh_bytes(made, "glb"))
    ours_json, ours_bin = _glb_parts(out.read_bytes())
    assert ours_bin == plain_bin
    assert [n["name"] for n in ours_json["nodes"]] == ["fat-torus-occonly"]
    plain_json["nodes"][0]["name"] = "fat-torus-occonly"
    assert ours_json == plain_json
    assert len(load_mesh(out).faces) == len(made.faces)  # a plain mesh reader still reads it


def test_generate_refuses_an_unknown_suffix_before_work(tmp_path, capsys):
    assert main(["generate", "bbox", "fat-torus", "-o", str(tmp_path / "occ.xyz")]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "-o" in line and ".tres" in line and ".tscn" in line


def test_generate_godot_output_refuses_what_float32_cannot_hold(tmp_path, capsys):
    far = trimesh.creation.box()
    far.apply_translation([1e6 + 0.1, 0, 0])  # float32 steps of 1/16 there
    mesh = tmp_path / "far.ply"
    mesh.write_bytes(mesh_bytes(far, "ply"))
    out = tmp_path / "occ.tres"
    assert main(["generate", "original", str(mesh), "-o", str(out)]) == 2
    assert "float32" in _one_line(capsys.readouterr().err)
    assert not out.exists()


# --------------------------------------------------------------------------- evaluate
def test_evaluate_and_validate_read_godot_occluders(tmp_path, capsys, torus_box):
    settings = ["--views", "4", "--quads", "300", "--res", "32", "--json"]
    ply = tmp_path / "box.ply"
    ply.write_bytes(mesh_bytes(load_occluder(torus_box), "ply"))  # the same float32 box
    results = []
    for occ in (torus_box, ply):
        assert main(["evaluate", "fat-torus", str(occ), *settings]) == 0
        results.append(json.loads(capsys.readouterr().out))
    assert results[0]["triangles"] == 12
    assert results[0]["precision"] == results[1]["precision"] < 1
    tscn = tmp_path / "box.tscn"
    box = load_occluder(torus_box)
    tscn.write_text(tscn_text([OccluderInstance("box", "b")],
                              {"b": (box.vertices, box.faces.ravel())}))
    # the bounding box hits rays before the torus: not conservative, exit 1 (a check)
    assert main(["validate", "fat-torus", str(tscn), "--rays", "1000", "--json"]) == 1
    assert json.loads(capsys.readouterr().out)["violations"] > 0


def test_uncertainty_reads_an_occluder_file_as_evaluate_does(tmp_path, capsys, torus_box):
    # the same box as a .tres and as a .ply: the same views, the same figures
    ply = tmp_path / "box.ply"
    trimesh.creation.box(bounds=load_mesh("fat-torus").bounds).export(ply)
    figures = []
    for occ in (torus_box, ply):
        assert main(["uncertainty", "fat-torus", str(occ), "--views", "4", "--quads", "300",
                     "--res", "32", "--directions", "4", "--steps", "200",
                     "--out", str(tmp_path / occ.suffix[1:]), "--json"]) == 0
        doc = json.loads(capsys.readouterr().out)
        figures.append([doc[k] for k in ("precision", "recall", "precision_ci", "recall_ci")])
    assert figures[0] == figures[1]
    assert figures[0][1] == 1.0 and figures[0][0] < 1.0  # a box over a torus covers more
