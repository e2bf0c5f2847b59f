import numpy as np
import pytest
import trimesh

from viscore import InputError, load_mesh, scene_names, validate_mesh


def test_load_mesh_builtin_scenes_all_load():
    for name in scene_names():
        mesh = load_mesh(name)
        assert len(mesh.faces) > 0 and np.isfinite(mesh.vertices).all(), name


def test_load_mesh_missing_file_names_it(tmp_path):
    with pytest.raises(InputError, match="nothere.obj"):
        load_mesh(tmp_path / "nothere.obj")


def test_load_mesh_empty_file(tmp_path):
    p = tmp_path / "empty.obj"
    p.write_text("")
    with pytest.raises(InputError, match="empty"):
        load_mesh(p)


def test_load_mesh_malformed_file(tmp_path):
    p = tmp_path / "junk.ply"
    p.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 99\nend_header\n\x00")
    with pytest.raises(InputError, match="junk.ply"):
        load_mesh(p)


def test_load_mesh_obj_without_faces(tmp_path):
    p = tmp_path / "points.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(InputError, match="no triangles|empty"):
        load_mesh(p)


def test_load_mesh_nan_coordinates(tmp_path):
    p = tmp_path / "nan.obj"
    p.write_text("v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(InputError, match="NaN"):
        load_mesh(p)


def test_validate_mesh_coordinates_beyond_float32():
    m = trimesh.Trimesh([[0, 0, 0], [1e300, 0, 0], [0, 1, 0]], [[0, 1, 2]], process=False)
    with pytest.raises(InputError, match="float32"):
        validate_mesh(m)


def test_validate_mesh_zero_extent():
    m = trimesh.Trimesh(np.zeros((3, 3)), [[0, 1, 2]], process=False)
    with pytest.raises(InputError, match="zero extent"):
        validate_mesh(m)


def test_validate_mesh_drops_degenerate_faces_and_keeps_the_rest(caplog):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], float)
    f = np.array([[0, 1, 2], [0, 1, 3], [1, 1, 2], [0, 1, 2]])  # collinear, repeated, duplicate
    with caplog.at_level("INFO"):
        out = validate_mesh(trimesh.Trimesh(v, f, process=False), name="soup")
    assert len(out.faces) == 2  # the duplicated face is kept: soups are normal input
    assert out.metadata["dropped_degenerate_faces"] == 2
    assert "dropped 2 degenerate" in caplog.text


def test_load_mesh_glb_scene_concatenated(tmp_path):
    a = trimesh.creation.box()
    b = trimesh.creation.box()
    b.apply_translation([3, 0, 0])
    p = tmp_path / "two.glb"
    trimesh.Scene([a, b]).export(p)
    assert len(load_mesh(p).faces) == 24


@pytest.mark.slow
def test_wheel_ships_every_procedural_scene(tmp_path):
    import subprocess
    import sys
    import zipfile
    from pathlib import Path

    from viscore.builtin_scenes import _PROCEDURAL

    root = Path(__file__).resolve().parent.parent
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w",
                    str(tmp_path), str(root)], check=True)
    names = zipfile.ZipFile(next(tmp_path.glob("viscore-*.whl"))).namelist()
    for file, _ in _PROCEDURAL.values():
        assert f"viscore/_scenes/{file}" in names
    assert not any(n.startswith("data/") for n in names)  # never an import package "data"
    for package in ("metrics", "generators", "cli"):  # installed under viscore only
        assert f"viscore/{package}/__init__.py" in names
        assert not any(n.startswith(f"{package}/") for n in names)
