import json

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
