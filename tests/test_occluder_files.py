"""Tests of viscore.exchange.occluder_files: Godot 4 occluders and -occonly glTF, in and out."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.exchange.godot_text import _float_texts
from viscore.exchange.occluder_files import (
    OccluderInstance,
    load_occluder,
    occonly_glb_bytes,
    tres_text,
    tscn_text,
    write_occluders,
)

DEMO = Path(__file__).resolve().parents[2] / "shared" / "models" / "godot-occlusion-demo"

QUAD_V = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], dtype=np.float64)
QUAD_I = np.array([0, 1, 2, 0, 2, 3])
TRI_V = np.array([(0.1, 0.2, 0.3), (1.5, -2.25, 1e-3), (-7.0, 3.0, 1e5)], dtype=np.float64)
TRI_I = np.array([0, 1, 2])


def _raises_one_line(func, *args, match: str | None = None) -> str:
    with pytest.raises(InputError, match=match) as info:
        func(*args)
    message = str(info.value)
    assert message and "\n" not in message
    return message


# ----------------------------------------------------------------------------- a hand-built .occ


def _ustr(text: str, end: str = "<") -> bytes:
    raw = text.encode() + b"\0"
    return struct.pack(end + "I", len(raw)) + raw


def occ_file(vertices, indices, *, kind: str = "ArrayOccluder3D", double: bool = False,
             big_endian: bool = False, vertex_count: int | None = None,
             string_count: int | None = None, main_offset: int | None = None) -> bytes:
    """A Godot 4 binary resource as ``ResourceFormatSaverBinaryInstance::save`` lays it out."""
    e = ">" if big_endian else "<"

    def u32(value: int) -> bytes:
        return struct.pack(e + "I", value)

    def u64(value: int) -> bytes:
        return struct.pack(e + "Q", value)

    strings = ["resource_local_to_scene", "resource_name", "vertices", "indices"]
    flags = 1 | 2 | (4 if double else 0)
    head = (b"RSRC" + u32(int(big_endian)) + u32(0) + u32(4) + u32(4) + u32(6)
            + _ustr(kind, e) + u64(0) + u32(flags) + u64(0x1234) + u32(0) * 11)
    head += u32(len(strings) if string_count is None else string_count)
    head += b"".join(_ustr(s, e) for s in strings)
    head += u32(0)  # external resources
    head += u32(1) + _ustr("res://test.occ", e)
    offset = len(head) + 8
    head += u64(offset if main_offset is None else main_offset)
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    i = np.asarray(indices, dtype=np.int64).reshape(-1)
    body = _ustr(kind, e) + u32(4)
    body += u32(0) + u32(2) + u32(0)  # resource_local_to_scene = false (BOOL)
    body += u32(1) + u32(5) + _ustr("wall", e)  # resource_name = "wall" (STRING)
    body += u32(2) + u32(35) + u32(len(v) if vertex_count is None else vertex_count)
    body += v.astype(e + ("f8" if double else "f4")).tobytes()
    body += u32(3) + u32(32) + u32(len(i)) + i.astype(e + "i4").tobytes()
    return head + body + b"RSRC"


def test_load_occluder_binary_exact(tmp_path):
    path = tmp_path / "wall.occ"
    path.write_bytes(occ_file(TRI_V, TRI_I))
    mesh = load_occluder(path)
    np.testing.assert_array_equal(mesh.vertices, TRI_V.astype(np.float32).astype(np.float64))
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2]])
    assert mesh.vertices.dtype == np.float64 and mesh.faces.dtype == np.int64
    assert mesh.metadata["source_format"] == "godot-occ"


def test_load_occluder_binary_double_big_endian(tmp_path):
    path = tmp_path / "wall.occ"
    path.write_bytes(occ_file(TRI_V, TRI_I, double=True, big_endian=True))
    mesh = load_occluder(path)
    np.testing.assert_array_equal(mesh.vertices, TRI_V)  # real_t double: no float32 rounding


def test_load_occluder_binary_other_type(tmp_path):
    path = tmp_path / "box.occ"
    path.write_bytes(occ_file(TRI_V, TRI_I, kind="BoxOccluder3D"))
    message = _raises_one_line(load_occluder, path)
    assert "BoxOccluder3D" in message and str(path) in message


def test_load_occluder_binary_truncated(tmp_path):
    data = occ_file(QUAD_V, QUAD_I)
    path = tmp_path / "cut.occ"
    loaded = []
    for cut in range(1, len(data) - 4):  # the trailing magic is not needed, all else is
        path.write_bytes(data[:cut])
        try:
            load_occluder(path)
        except InputError as exc:
            assert "\n" not in str(exc) and str(path) in str(exc)
        else:
            loaded.append(cut)
    assert loaded == []
    path.write_bytes(data[:-4])
    assert len(load_occluder(path).faces) == 2


def test_load_occluder_binary_counts_beyond_length(tmp_path):
    path = tmp_path / "bogus.occ"
    for kwargs in ({"vertex_count": 0x7FFFFFFF}, {"string_count": 0xFFFFFFFF},
                   {"main_offset": 10**12}):
        path.write_bytes(occ_file(QUAD_V, QUAD_I, **kwargs))
        message = _raises_one_line(load_occluder, path)
        assert "exceed" in message or "beyond" in message


def test_load_occluder_binary_flipped_bytes_never_crash(tmp_path):
    data = bytearray(occ_file(QUAD_V, QUAD_I))
    rng = np.random.default_rng(7)
    path = tmp_path / "flipped.occ"
    refused = 0
    for _ in range(300):
        bad = bytearray(data)
        for k in rng.integers(0, len(bad), size=3):
            bad[k] = int(rng.integers(0, 256))
        path.write_bytes(bytes(bad))
        try:
            mesh = load_occluder(path)
        except InputError as exc:
            assert "\n" not in str(exc)
            refused += 1
        else:
            assert np.isfinite(mesh.vertices).all() and mesh.faces.max() < len(mesh.vertices)
    assert refused > 0


@pytest.mark.skipif(not (DEMO / "node_3d.occ").exists(), reason="Godot demo files not present")
def test_load_occluder_godot_baked_file():
    mesh = load_occluder(DEMO / "node_3d.occ")
    assert mesh.vertices.shape == (91543, 3) and mesh.faces.shape == (191278, 3)
    scene = load_occluder(DEMO / "node_3d.tscn")  # its OccluderInstance3D uses that file
    np.testing.assert_array_equal(scene.vertices, mesh.vertices)
    assert scene.metadata["object_names"] == ["OccluderInstance3D"]


# ----------------------------------------------------------------------------- text round trips


def _rotation_y90() -> np.ndarray:
    mat = np.eye(4)
    mat[:3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]
    return mat


def _scene_input():
    rng = np.random.default_rng(3)
    rough = rng.normal(size=(30, 3)) * [3.0, 0.5, 100.0]
    rough_i = rng.integers(0, 30, size=(20, 3))
    moved = _rotation_y90() * 2.0
    moved[3, 3] = 1.0
    moved[:3, 3] = (10.5, -1.0, 0.25)
    arbitrary = trimesh.transformations.rotation_matrix(0.3, (1, 2, 3), point=(1, 0, 0))
    instances = [OccluderInstance("wall.001", "quad"),
                 OccluderInstance("wall.001", "quad", moved),
                 OccluderInstance("rock", "rough", arbitrary)]
    return instances, {"quad": (QUAD_V, QUAD_I), "rough": (rough, rough_i)}


def _expected_world(instances, meshes):
    parts_v, parts_f, offset = [], [], 0
    for inst in instances:
        v, i = meshes[inst.mesh_key]
        v = np.asarray(v).astype(np.float32).astype(np.float64)
        mat = inst.transform.astype(np.float32).astype(np.float64)
        parts_v.append(v @ mat[:3, :3].T + mat[:3, 3])
        parts_f.append(np.asarray(i).reshape(-1, 3) + offset)
        offset += len(v)
    return np.concatenate(parts_v), np.concatenate(parts_f)


def test_tres_text_round_trip(tmp_path):
    rng = np.random.default_rng(1)
    vertices = rng.normal(size=(50, 3)) * np.array([1e-3, 1.0, 1e4])
    indices = rng.integers(0, 50, size=(40, 3))
    path = tmp_path / "occ.tres"
    path.write_text(tres_text(vertices, indices))
    mesh = load_occluder(path)
    np.testing.assert_array_equal(mesh.vertices, vertices.astype(np.float32))
    np.testing.assert_array_equal(mesh.faces, indices)


def test_tscn_text_round_trip_world_space(tmp_path):
    instances, meshes = _scene_input()
    path = tmp_path / "occluders.tscn"
    path.write_text(tscn_text(instances, meshes))
    mesh = load_occluder(path)
    vertices, faces = _expected_world(instances, meshes)
    np.testing.assert_allclose(mesh.vertices, vertices, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(mesh.faces, faces)
    # the exactly representable transform (90 degrees, scale 2) lands exactly
    np.testing.assert_array_equal(mesh.vertices[4:8], [(10.5, -1, 0.25), (10.5, -1, -1.75),
                                                       (10.5, 1, -1.75), (10.5, 1, 0.25)])
    assert mesh.metadata["object_names"] == ["wall_001", "wall_001_2", "rock"]


def test_tscn_text_instancing():
    instances, meshes = _scene_input()
    text = tscn_text(instances, meshes)
    assert text.startswith("[gd_scene format=3]\n")
    assert text.count('[sub_resource type="ArrayOccluder3D"') == 2
    quad_id = text.split('[sub_resource type="ArrayOccluder3D" id="')[1].split('"')[0]
    assert quad_id.startswith("ArrayOccluder3D_")
    assert text.count(f'occluder = SubResource("{quad_id}")') == 2
    assert text.count('type="OccluderInstance3D" parent="."') == 3
    assert "load_steps" not in text
    assert text == tscn_text(instances, meshes)  # deterministic ids


def test_load_occluder_tscn_transform_is_basis_rows(tmp_path):
    # Godot writes Transform3D as the basis rows then the origin: B @ (1, 0, 0) is B's
    # first column (0, 0, -1) here; read as columns it would give (0, 0, 1).
    path = tmp_path / "rows.tscn"
    path.write_text(
        '[gd_scene format=3 uid="uid://abc"]\n\n'
        '[sub_resource type="ArrayOccluder3D" id="ArrayOccluder3D_a1b2c"]\n'
        "vertices = PackedVector3Array(1, 0, 0, 0, 1, 0, 0, 0, 1)\n"
        "indices = PackedInt32Array(0, 1, 2)\n\n"
        '[node name="Root" type="Node3D"]\n\n'
        '[node name="Occ" type="OccluderInstance3D" parent="."]\n'
        "transform = Transform3D(0, 0, 1, 0, 1, 0, -1, 0, 0, 10, 0, 0)\n"
        'occluder = SubResource("ArrayOccluder3D_a1b2c")\n')
    mesh = load_occluder(path)
    np.testing.assert_array_equal(mesh.vertices, [(10, 0, -1), (10, 1, 0), (11, 0, 0)])


def test_load_occluder_tscn_node_paths_compose(tmp_path):
    path = tmp_path / "nested.tscn"
    path.write_text(
        "[gd_scene format=3]\n\n"
        '[sub_resource type="ArrayOccluder3D" id="tri"]\n'
        "vertices = PackedVector3Array(0, 0, 0, 1, 0, 0, 0, 1, 0)\n"
        "indices = PackedInt32Array(0, 1, 2)\n\n"
        '[node name="Root" type="Node3D"]\n'
        "transform = Transform3D(1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 100, 0)\n\n"
        '[node name="A" type="Node3D" parent="."]\n'
        "transform = Transform3D(1, 0, 0, 0, 1, 0, 0, 0, 1, 5, 0, 0)\n\n"
        '[node name="B" type="Node3D" parent="A"]\n'
        "transform = Transform3D(2, 0, 0, 0, 2, 0, 0, 0, 2, 0, 0, 0)\n\n"
        '[node name="Occ" type="OccluderInstance3D" parent="A/B"]\n'
        "transform = Transform3D(1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 1)\n"
        'occluder = SubResource("tri")\n\n'
        '[node name="Plain" type="Node" parent="A"]\n\n'
        '[node name="Free" type="OccluderInstance3D" parent="A/Plain"]\n'
        'occluder = SubResource("tri")\n\n'
        '[node name="Top" type="OccluderInstance3D" parent="A/B"]\n'
        "top_level = true\n"
        'occluder = SubResource("tri")\n')
    mesh = load_occluder(path)
    assert mesh.metadata["object_names"] == ["A/B/Occ", "A/Plain/Free", "A/B/Top"]
    # Root (0, 100, 0) then A (+5 x) then B (scale 2) then Occ (+1 z, scaled to +2)
    np.testing.assert_array_equal(mesh.vertices[:3], [(5, 100, 2), (7, 100, 2), (5, 102, 2)])
    np.testing.assert_array_equal(mesh.vertices[3:6], [(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    np.testing.assert_array_equal(mesh.vertices[6:], [(0, 0, 0), (1, 0, 0), (0, 1, 0)])


def test_load_occluder_tscn_missing_sub_resource(tmp_path):
    path = tmp_path / "missing.tscn"
    path.write_text('[gd_scene format=3]\n\n[node name="Root" type="Node3D"]\n\n'
                    '[node name="Wall" type="OccluderInstance3D" parent="."]\n'
                    'occluder = SubResource("ArrayOccluder3D_nope1")\n')
    message = _raises_one_line(load_occluder, path)
    assert "'Wall'" in message and "ArrayOccluder3D_nope1" in message


def _ext_scene(path: Path, ref: str) -> None:
    path.write_text(
        "[gd_scene format=3]\n\n"
        f'[ext_resource type="ArrayOccluder3D" path="{ref}" id="1_occ"]\n\n'
        '[node name="Root" type="Node3D"]\n\n'
        '[node name="Baked" type="OccluderInstance3D" parent="."]\n'
        "transform = Transform3D(1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 3)\n"
        'occluder = ExtResource("1_occ")\n')


def test_load_occluder_tscn_external_occluder(tmp_path):
    (tmp_path / "baked.occ").write_bytes(occ_file(TRI_V, TRI_I))
    _ext_scene(tmp_path / "scene.tscn", "res://baked.occ")
    mesh = load_occluder(tmp_path / "scene.tscn")
    np.testing.assert_array_equal(mesh.vertices, TRI_V.astype(np.float32) + [0, 0, 3])


def test_load_occluder_tscn_external_outside_folder_refused(tmp_path):
    (tmp_path / "outside.occ").write_bytes(occ_file(TRI_V, TRI_I))
    (tmp_path / "level").mkdir()
    for ref in ("res://../outside.occ", "../outside.occ", str(tmp_path / "outside.occ")):
        _ext_scene(tmp_path / "level" / "scene.tscn", ref)
        message = _raises_one_line(load_occluder, tmp_path / "level" / "scene.tscn")
        assert "'Baked'" in message and ref in message


# ----------------------------------------------------------------------------- glTF


def _glb_json(data: bytes) -> dict:
    size = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + size])


def test_occonly_glb_round_trip(tmp_path):
    instances, meshes = _scene_input()
    data = occonly_glb_bytes(instances, meshes)
    doc = _glb_json(data)
    assert len(doc["meshes"]) == 2 and len(doc["nodes"]) == 3  # instancing
    assert sorted(n["name"] for n in doc["nodes"]) == ["rock-occonly", "wall.001-occonly",
                                                       "wall.001-occonly_2"]
    path = tmp_path / "occ.glb"
    path.write_bytes(data)
    mesh = load_occluder(path)
    assert mesh.metadata["source_format"] == "glb-occonly"
    order = {name: k for k, name in enumerate(["wall.001-occonly", "wall.001-occonly_2",
                                               "rock-occonly"])}
    assert sorted(mesh.metadata["object_names"], key=order.get) == list(order)
    vertices, faces = _expected_world(instances, meshes)
    # nodes come back sorted by name: rock first, then the two quads
    np.testing.assert_allclose(mesh.vertices[:30], vertices[8:], rtol=0, atol=1e-5)
    np.testing.assert_array_equal(mesh.vertices[30:], vertices[:8])
    np.testing.assert_array_equal(mesh.faces[:20], faces[4:] - 8)


def _two_node_glb(tmp_path: Path, names: tuple[str, str]) -> Path:
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.Trimesh(QUAD_V, QUAD_I.reshape(-1, 3), process=False),
                       geom_name="quad", node_name=names[0])
    scene.add_geometry(trimesh.creation.box(), geom_name="box", node_name=names[1],
                       transform=trimesh.transformations.translation_matrix((0, 0, 5)))
    path = tmp_path / "level.glb"
    path.write_bytes(trimesh.exchange.gltf.export_glb(scene))
    return path


def test_load_occluder_gltf_suffix_selects_nodes(tmp_path):
    mesh = load_occluder(_two_node_glb(tmp_path, ("wall-occ.001", "statue")))
    assert mesh.metadata["object_names"] == ["wall-occ.001"] and len(mesh.faces) == 2
    mesh = load_occluder(_two_node_glb(tmp_path, ("wall", "statue")))  # none marked: all
    assert sorted(mesh.metadata["object_names"]) == ["statue", "wall"]
    assert len(mesh.faces) == 14 and mesh.bounds[1, 2] == 5.5


def test_load_occluder_gltf_uri_outside_folder_refused(tmp_path):
    (tmp_path / "secret.bin").write_bytes(bytes(48))
    (tmp_path / "level").mkdir()
    (tmp_path / "level" / "secret.bin").write_bytes(bytes(48))  # the basename fallback trap
    for uri in ("../secret.bin", "%2E%2E/secret.bin", str(tmp_path / "secret.bin"),
                "file:///etc/passwd"):
        doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
               "nodes": [{"name": "wall-occonly", "mesh": 0}],
               "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
               "buffers": [{"byteLength": 36, "uri": uri}],
               "bufferViews": [{"buffer": 0, "byteLength": 36}],
               "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3,
                              "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 1]}]}
        path = tmp_path / "level" / "level.gltf"
        path.write_text(json.dumps(doc))
        message = _raises_one_line(load_occluder, path)
        assert str(path) in message and "outside" in message and uri in message


# ----------------------------------------------------------------------------- hostile input


def test_load_occluder_garbage_bytes(tmp_path):
    rng = np.random.default_rng(11)
    garbage = rng.integers(0, 256, size=4096, dtype=np.uint8).tobytes()
    for suffix in (".occ", ".res", ".tres", ".tscn", ".glb", ".gltf", ".obj"):
        path = tmp_path / f"garbage{suffix}"
        path.write_bytes(garbage)
        assert str(path) in _raises_one_line(load_occluder, path)
        path.write_bytes(b"")
        assert "empty" in _raises_one_line(load_occluder, path)


@pytest.mark.parametrize("text, needle", [
    ('[gd_resource type="BoxOccluder3D" format=3]\n\n[resource]\nsize = Vector3(1, 1, 1)\n',
     "BoxOccluder3D"),
    ('[gd_resource type="ArrayOccluder3D" format=3]\n\n[resource]\n'
     "vertices = PackedVector3Array(0, 0, nan, 1, 0, 0, 0, 1, 0)\n"
     "indices = PackedInt32Array(0, 1, 2)\n", "NaN"),
    ('[gd_resource type="ArrayOccluder3D" format=3]\n\n[resource]\n'
     "vertices = PackedVector3Array(0, 0, 0, 1, 0, 0, 0, 1, 0)\n"
     "indices = PackedInt32Array(0, 1, 3)\n", "outside"),
    ('[gd_resource type="ArrayOccluder3D" format=3]\n\n[resource]\n'
     "vertices = PackedVector3Array(0, 0, 0, 1, 0, 0, 0, 1)\n", "multiple of 3"),
    ('[gd_resource type="ArrayOccluder3D" format=3]\n\n[resource]\n'
     "vertices = PackedVector3Array(0, 0, 0, 1, 0\n", "unclosed"),
    ('[gd_resource type="ArrayOccluder3D" format=3]\n\n[resource]\n', "no triangles"),
    ('[gd_resource type="ArrayOccluder3D" format=2]\n\n[resource]\n', "format=2"),
    ("just some words\n", "expected 'name = value'"),
])
def test_load_occluder_tres_invalid_input(tmp_path, text, needle):
    path = tmp_path / "bad.tres"
    path.write_text(text)
    assert needle in _raises_one_line(load_occluder, path)


def test_load_occluder_invalid_input(tmp_path):
    assert "no such file" in _raises_one_line(load_occluder, tmp_path / "nope.occ")
    assert "directory" in _raises_one_line(load_occluder, tmp_path)
    _raises_one_line(load_occluder, 42)
    scene = tmp_path / "empty.tscn"
    scene.write_text('[gd_scene format=3]\n\n[node name="Root" type="Node3D"]\n')
    assert "no OccluderInstance3D" in _raises_one_line(load_occluder, scene)


def test_load_occluder_mesh_file_delegates(tmp_path):
    path = tmp_path / "quad.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n")
    mesh = load_occluder(path)
    assert len(mesh.faces) == 2 and mesh.metadata["source_format"] == "mesh"


# ----------------------------------------------------------------------------- writers


def test_write_occluders_formats_agree(tmp_path):
    instances, meshes = _scene_input()
    vertices, _ = _expected_world(instances, meshes)
    for suffix in (".tscn", ".glb", ".tres"):
        path = tmp_path / f"occluders{suffix}"
        write_occluders(path, instances, meshes)
        mesh = load_occluder(path)
        assert len(mesh.faces) == 2 + 2 + 20
        np.testing.assert_allclose(np.sort(mesh.vertices, axis=0), np.sort(vertices, axis=0),
                                   rtol=0, atol=1e-5)


def test_float_texts_round_trip_float32():
    rng = np.random.default_rng(5)
    info = np.finfo(np.float32)
    values = np.concatenate([rng.normal(size=2000) * 10.0 ** rng.integers(-30, 30, 2000),
                             [0.0, -0.0, 1.0, -3.0, 1e7, info.max, -info.max, info.tiny,
                              info.tiny / 8, 0.1, 1 / 3]]).astype(np.float32)
    texts = _float_texts(values)
    assert texts[-11:-6] == ["0", "0", "1", "-3", "1e+07"]  # no ".0", no "-0"
    np.testing.assert_array_equal(np.array(texts, dtype=np.float64).astype(np.float32), values)


def test_occluder_instance_invalid_input():
    for transform in (np.eye(3), np.full((4, 4), np.nan), np.ones((4, 4)), "x"):
        assert "transform" in _raises_one_line(OccluderInstance, "a", "m", transform)
    assert "name" in _raises_one_line(OccluderInstance, "", "m")
    assert "mesh_key" in _raises_one_line(OccluderInstance, "a", 3)
    inst = OccluderInstance("a", "m")
    assert not inst.transform.flags.writeable


def test_writers_invalid_input(tmp_path):
    inst = [OccluderInstance("a", "quad")]
    for func in (tscn_text, occonly_glb_bytes):
        assert "'quad'" in _raises_one_line(func, inst, {})
        _raises_one_line(func, [], {"quad": (QUAD_V, QUAD_I)})
        _raises_one_line(func, inst, {"quad": (QUAD_V, [0, 1])})
        _raises_one_line(func, inst, {"quad": (QUAD_V, [0, 1, 9])})
        _raises_one_line(func, inst, {"quad": (QUAD_V * np.nan, QUAD_I)})
    _raises_one_line(tres_text, QUAD_V * 1e39, QUAD_I)
    _raises_one_line(tres_text, QUAD_V[:, :2], QUAD_I)
    _raises_one_line(tres_text, QUAD_V, [0.5, 1, 2])
    _raises_one_line(write_occluders, tmp_path / "x.obj", inst, {"quad": (QUAD_V, QUAD_I)})
    _raises_one_line(write_occluders, tmp_path / "no" / "x.tscn", inst,
                     {"quad": (QUAD_V, QUAD_I)})
