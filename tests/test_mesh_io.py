import logging

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


def test_validate_mesh_coordinates_beyond_float64_areas():
    m = trimesh.Trimesh([[0, 0, 0], [1e300, 0, 0], [0, 1, 0]], [[0, 1, 2]], process=False)
    with pytest.raises(InputError, match="exceed 1e\\+90"):
        validate_mesh(m)


def test_validate_mesh_zero_extent():
    m = trimesh.Trimesh(np.zeros((3, 3)), [[0, 1, 2]], process=False)
    with pytest.raises(InputError, match="zero extent"):
        validate_mesh(m)


def test_validate_mesh_drops_degenerate_faces_and_keeps_the_rest(caplog):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], float)
    f = np.array([[0, 1, 2], [0, 1, 3], [1, 1, 2], [0, 1, 2]])  # collinear, repeated, duplicate
    with caplog.at_level("DEBUG", logger="viscore"):
        out = validate_mesh(trimesh.Trimesh(v, f, process=False), name="soup")
    assert len(out.faces) == 2  # the duplicated face is kept: soups are normal input
    assert out.metadata["dropped_degenerate_faces"] == 2
    # DEBUG, not INFO: a later error must stay the only stderr line; the CLI
    # reports the count after success
    assert [r.levelname for r in caplog.records if "dropped 2" in r.message] == ["DEBUG"]


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


# --------------------------------------------------------------------------- hostile files
_TRI_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


def _write_obj(path, vertices, faces):
    """OBJ with full float64 digits (trimesh's exporter writes 8 decimals)."""
    lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture
def no_charset_normalizer(monkeypatch):
    """Make ``import charset_normalizer`` fail, as in an install without it."""
    import sys

    monkeypatch.setitem(sys.modules, "charset_normalizer", None)


@pytest.mark.parametrize("without_detector", [False, True])
def test_load_mesh_latin1_comment_and_utf16(tmp_path, request, without_detector):
    if without_detector:
        request.getfixturevalue("no_charset_normalizer")
    latin = tmp_path / "latin.obj"
    latin.write_bytes(b"# caf\xe9\n" + _TRI_OBJ.encode())
    utf16 = tmp_path / "utf16.obj"
    utf16.write_text("# café\n" + _TRI_OBJ, encoding="utf-16")  # with a BOM
    utf16_off = tmp_path / "utf16.off"
    utf16_off.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", encoding="utf-16")
    for p in (latin, utf16, utf16_off):
        mesh = load_mesh(p)
        assert mesh.faces.tolist() == [[0, 1, 2]], p
        assert mesh.area == pytest.approx(0.5)


def test_load_mesh_bomless_utf16le(tmp_path):
    p = tmp_path / "le.obj"
    p.write_bytes(("# café\n" + _TRI_OBJ).encode("utf-16-le"))
    assert len(load_mesh(p).faces) == 1


@pytest.mark.parametrize("without_detector", [False, True])
@pytest.mark.parametrize("ext", ["stl", "obj", "off", "ply", "glb", "gltf", "zip"])
def test_load_mesh_garbage_one_clear_error(tmp_path, request, ext, without_detector):
    if without_detector:
        request.getfixturevalue("no_charset_normalizer")
    p = tmp_path / f"garbage.{ext}"
    p.write_bytes(np.random.default_rng(5).integers(0, 256, 3000, dtype=np.uint8).tobytes())
    with pytest.raises(InputError) as info:
        load_mesh(p)
    message = str(info.value)
    assert message.startswith(str(p)) and "\n" not in message
    assert "ModuleNotFoundError" not in message and "charset" not in message


def test_load_mesh_fifo_is_named_and_never_read(tmp_path):
    import os
    import signal

    p = tmp_path / "pipe.obj"
    os.mkfifo(p)
    signal.alarm(20)  # a read of the FIFO would block forever
    try:
        with pytest.raises(InputError, match="named pipe"):
            load_mesh(p)
    finally:
        signal.alarm(0)


@pytest.mark.parametrize("path, what", [("/dev/urandom", "character device"),
                                        ("/dev/null", "character device"),
                                        ("/proc/self/status", "no extension")])
def test_load_mesh_special_files_say_what_they_are(path, what):
    from pathlib import Path

    if not Path(path).exists():
        pytest.skip(f"{path} not on this system")
    with pytest.raises(InputError, match=what):
        load_mesh(path)


def test_load_mesh_directory_dangling_link_and_file_as_folder(tmp_path):
    (tmp_path / "d.obj").mkdir()
    (tmp_path / "link.obj").symlink_to(tmp_path / "gone.obj")
    (tmp_path / "f.ply").write_text("x")
    for name, what in (("d.obj", "directory"), ("link.obj", "broken symbolic link"),
                       ("f.ply/x.ply", "is a file, not a folder")):
        with pytest.raises(InputError, match=what):
            load_mesh(tmp_path / name)


def test_load_mesh_obj_index_zero_refused(tmp_path):
    p = tmp_path / "zero.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 0 1 2\n")
    with pytest.raises(InputError, match="index 0"):
        load_mesh(p)
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/0 2/0 3/0\n")
    with pytest.raises(InputError, match="index 0"):
        load_mesh(p)
    p.write_text("v 0 0 0\nv 10 0 0\nv 0 10 0\nf 1 2 3\nf -3 -2 -1\n")  # relative: valid
    assert len(load_mesh(p).faces) == 2


def test_load_mesh_point_cloud_and_lines_have_no_triangles(tmp_path):
    cloud = tmp_path / "cloud.ply"
    cloud.write_bytes(trimesh.PointCloud(np.eye(3)).export(file_type="ply"))
    lines = tmp_path / "lines.obj"
    lines.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n")
    for p in (cloud, lines):
        with pytest.raises(InputError, match="no triangles"):
            load_mesh(p)


def test_load_mesh_quads_and_ngons_triangulated(tmp_path):
    # unit square (quad) and a regular hexagon of circumradius 1 beside it
    ang = np.arange(6) * np.pi / 3
    hexagon = np.column_stack([3 + np.cos(ang), np.sin(ang), np.zeros(6)])
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    v = np.vstack([square, hexagon])
    obj = tmp_path / "polys.obj"
    obj.write_text("".join(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in v)
                   + "f 1 2 3 4\nf 5 6 7 8 9 10\n")
    off = tmp_path / "polys.off"
    off.write_text(f"OFF\n{len(v)} 2 0\n"
                   + "".join(f"{float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in v)
                   + "4 0 1 2 3\n6 4 5 6 7 8 9\n")
    for p in (obj, off):
        mesh = load_mesh(p)
        assert len(mesh.faces) == 2 + 4, p
        assert mesh.area == pytest.approx(1 + 1.5 * np.sqrt(3), rel=1e-12)


def test_load_mesh_glb_instancing_honoured(tmp_path):
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(), geom_name="box", node_name="n0")
    for i in range(1, 200):
        scene.graph.update(frame_to=f"n{i}", frame_from=scene.graph.base_frame, geometry="box",
                           matrix=trimesh.transformations.translation_matrix([3.0 * i, 0, 0]))
    p = tmp_path / "instanced.glb"
    scene.export(p)
    assert len(trimesh.load_scene(p).geometry) == 1  # one mesh, 200 instances
    mesh = load_mesh(p)
    assert len(mesh.faces) == 200 * 12
    np.testing.assert_allclose(mesh.bounds, [[-0.5, -0.5, -0.5], [597.5, 0.5, 0.5]])


def test_load_mesh_gltf_missing_external_buffer(tmp_path):
    files = trimesh.Scene([trimesh.creation.box()]).export(file_type="gltf")
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    assert len(load_mesh(tmp_path / "model.gltf").faces) == 12
    for name in files:
        if name.endswith(".bin"):
            (tmp_path / name).unlink()
    with pytest.raises(InputError, match="references is missing") as info:
        load_mesh(tmp_path / "model.gltf")
    assert "\n" not in str(info.value)


def test_load_mesh_zip_of_meshes(tmp_path):
    import zipfile

    p = tmp_path / "meshes.zip"
    with zipfile.ZipFile(p, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("a.obj", _TRI_OBJ)
        z.writestr("readme.txt", "not a mesh")
    assert load_mesh(p).faces.tolist() == [[0, 1, 2]]


def test_load_mesh_zip_bomb_refused_before_inflating(tmp_path, monkeypatch):
    import zipfile

    from viscore._validate import available_memory

    p = tmp_path / "bomb.zip"
    body = _TRI_OBJ + "# " + "x" * (8 << 20) + "\n"  # 8 MiB, compresses to a few KiB
    with zipfile.ZipFile(p, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("big.obj", body)
    assert p.stat().st_size < 100_000
    # a limit of 64 MiB: the file passes, its 8 MiB member x the parse factor does not
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", str((64 << 20) / available_memory()))

    def no_inflating(*args, **kwargs):
        raise AssertionError("inflated before the size check")

    monkeypatch.setattr(zipfile.ZipFile, "read", no_inflating)
    monkeypatch.setattr(zipfile.ZipFile, "open", no_inflating)
    with pytest.raises(InputError, match=r"inflates to 8\.0 MiB.*needs about"):
        load_mesh(p)


def test_load_mesh_file_too_big_for_memory(tmp_path, monkeypatch):
    from viscore._validate import available_memory

    p = tmp_path / "tri.obj"
    p.write_text(_TRI_OBJ + "#" * 100_000)
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", str(100_000 / available_memory()))
    with pytest.raises(InputError, match="needs about"):
        load_mesh(p)


@pytest.mark.parametrize("scale", [1e-60, 1e-30, 1e-12, 1.0, 1e12, 1e17, 1e30, 1e60])
def test_load_mesh_any_scale_float32_can_hold(tmp_path, scale):
    box = trimesh.creation.box()
    mesh = load_mesh(_write_obj(tmp_path / "box.obj", box.vertices * scale, box.faces))
    assert len(mesh.faces) == 12
    assert mesh.area == pytest.approx(6 * scale**2, rel=1e-12)


@pytest.mark.parametrize("vertices, what", [
    ([[0, 0, 0], [1, 0, np.inf], [0, 1, 0]], "NaN or infinite"),
    ([[0, 0, 0], [1e95, 0, 0], [0, 1e95, 0]], "exceed 1e\\+90"),
    ([[0, 0, 0], [1e-95, 0, 0], [0, 1e-95, 0]], "below 1e-90"),
    ([[0, 0, 0], [5e-320, 0, 0], [0, 5e-320, 0]], "subnormal"),
    ([[1e12, 0, 0], [1e12 + 1, 0, 0], [1e12, 1, 0]], "from the origin"),
])
def test_validate_mesh_refuses_what_float32_cannot_hold(vertices, what):
    with pytest.raises(InputError, match=what):
        validate_mesh(trimesh.Trimesh(vertices, [[0, 1, 2]], process=False))


def test_validate_mesh_far_outlier_vertex_refused_not_collapsed(tmp_path):
    box = trimesh.creation.box()
    v = np.vstack([box.vertices, [[1e30, 0, 0]]])
    f = np.vstack([box.faces, [[0, 1, 8]]])
    with pytest.raises(InputError, match="13 of 13 faces are smaller than float32"):
        load_mesh(_write_obj(tmp_path / "outlier.obj", v, f))


def test_validate_mesh_few_slivers_dropped():
    sphere = trimesh.creation.icosphere(subdivisions=3)  # 1280 faces, diagonal 2 sqrt(3)
    n = len(sphere.vertices)
    # one sliver: sides ~1e-15 and ~1, area ~1e-15 < 1e-14 x diagonal^2: below float32
    v = np.vstack([sphere.vertices, [[1, 0, 0], [1 + 1e-15, 1e-15, 0]]])
    f = np.vstack([sphere.faces, [[n, n + 1, 0]]])
    out = validate_mesh(trimesh.Trimesh(v, f, process=False))
    assert len(out.faces) == 1280 and out.metadata["dropped_degenerate_faces"] == 1


def test_validate_mesh_needles_of_a_game_map_dropped_with_a_warning(caplog):
    # a map of 1280 faces with 40 needles (3%: long, 1e-14 high), as exported game maps
    # carry: dropped, said once; the map is not refused
    sphere = trimesh.creation.icosphere(subdivisions=3)
    n = len(sphere.vertices)
    x = np.linspace(-0.5, 0.5, 40)
    needles = np.stack([np.c_[x, 0 * x, 0 * x], np.c_[x + 1, 0 * x, 0 * x],
                        np.c_[x + 0.5, 0 * x + 1e-14, 0 * x]], axis=1).reshape(-1, 3)
    v = np.vstack([sphere.vertices, needles])
    f = np.vstack([sphere.faces, n + np.arange(120).reshape(40, 3)])
    with caplog.at_level(logging.WARNING, logger="viscore.exchange.mesh_validation"):
        out = validate_mesh(trimesh.Trimesh(v, f, process=False), name="map")
    assert len(out.faces) == 1280 and out.metadata["dropped_degenerate_faces"] == 40
    assert "map: dropped 40 of 1320 faces as smaller than float32 resolves" in caplog.text


# ---------------------------------------------------------------- save_mesh


def _odd_mesh():
    """A mesh whose coordinates need all of float64 (not multiples of a power of two)."""
    rng = np.random.default_rng(3)
    return trimesh.Trimesh(rng.random((40, 3)) * 7.3 + 0.1, rng.integers(0, 40, (30, 3)),
                           process=False)


@pytest.mark.parametrize("fmt", ["ply", "obj", "off", "stl", "glb"])
def test_save_mesh_round_trip(tmp_path, fmt):
    from viscore.exchange.mesh_io import save_mesh

    box = trimesh.creation.box(extents=(1.0, 2.0, 0.5))
    path = tmp_path / f"box.{fmt}"
    save_mesh(box, path)
    back = load_mesh(path)
    assert len(back.faces) == len(box.faces)
    # the same triangles, as sets of corner coordinates (STL and GLB may reindex)
    got = np.sort(np.sort(back.vertices[back.faces].reshape(-1, 9), axis=1), axis=0)
    want = np.sort(np.sort(box.vertices[box.faces].reshape(-1, 9), axis=1), axis=0)
    assert np.array_equal(got, want)


@pytest.mark.parametrize("fmt", ["ply", "obj", "off"])
def test_save_mesh_float64_formats_keep_every_bit(tmp_path, fmt):
    from viscore.exchange.mesh_io import save_mesh

    mesh = _odd_mesh()
    path = tmp_path / f"odd.{fmt}"
    save_mesh(mesh, path)
    back = trimesh.load(path, force="mesh", process=False)
    assert back.vertices.dtype == np.float64
    # every corner of every triangle exactly (a reader may drop unused vertices)
    assert np.array_equal(back.vertices[back.faces], mesh.vertices[mesh.faces])


def test_save_mesh_file_object_same_bytes_as_path(tmp_path):
    import io

    from viscore.exchange.mesh_io import mesh_bytes, save_mesh

    mesh = _odd_mesh()
    for fmt in ("ply", "obj", "off", "stl", "glb"):
        buf = io.BytesIO()
        save_mesh(mesh, buf, format=fmt)
        save_mesh(mesh, tmp_path / f"m.{fmt}")
        assert buf.getvalue() == (tmp_path / f"m.{fmt}").read_bytes() == mesh_bytes(mesh, fmt)


def test_save_mesh_invalid_input(tmp_path):
    import io

    from viscore.exchange.mesh_io import save_mesh

    box = trimesh.creation.box()
    with pytest.raises(InputError, match="unknown mesh format '.xyz'"):
        save_mesh(box, tmp_path / "box.xyz")
    with pytest.raises(InputError, match="format: needed"):
        save_mesh(box, io.BytesIO())
    with pytest.raises(InputError, match="does not exist"):
        save_mesh(box, tmp_path / "missing" / "box.ply")
    far = box.copy()
    far.vertices[:] = far.vertices * 1e-4 + 1e6  # tiny extent far from the origin
    with pytest.raises(InputError, match="float32"):
        save_mesh(far, tmp_path / "far.stl")
    assert not (tmp_path / "far.stl").exists()
