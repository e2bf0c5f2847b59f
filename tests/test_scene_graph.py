"""Scenes as objects (viscore.scene_graph): instancing, boxes, the combined scene, bad files."""

import io
import struct

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.scene_graph import (
    culling_scene_names,
    culling_scene_path,
    load_scene_objects,
)


def _instanced_scene(count=3):
    """One icosphere mesh referenced by ``count`` nodes, 3 units apart along X."""
    scene = trimesh.Scene()
    mesh = trimesh.creation.icosphere(subdivisions=1)
    scene.add_geometry(mesh, geom_name="ball", node_name="ball_0")
    for i in range(1, count):
        scene.graph.update(frame_to=f"ball_{i}", frame_from=scene.graph.base_frame,
                           matrix=trimesh.transformations.translation_matrix((3.0 * i, 0, 0)),
                           geometry="ball")
    return scene, mesh


def _glb_json(data: bytes) -> dict:
    import json

    length = struct.unpack("<I", data[12:16])[0]
    return json.loads(data[20:20 + length])


def test_load_scene_objects_instancing_glb(tmp_path):
    scene, mesh = _instanced_scene(3)
    data = scene.export(file_type="glb")
    assert len(_glb_json(data)["meshes"]) == 1  # the file itself stores the mesh once
    path = tmp_path / "three.glb"
    path.write_bytes(data)
    objects = load_scene_objects(path)
    assert len(objects) == 3
    assert len(objects.meshes) == 1  # geometry kept once
    assert objects.mesh_ids.tolist() == [0, 0, 0]
    assert objects.names == ("ball_0", "ball_1", "ball_2")
    assert objects.triangles.tolist() == [len(mesh.faces)] * 3
    np.testing.assert_allclose(objects.lower[:, 0], [-1, 2, 5], atol=1e-6)
    np.testing.assert_allclose(objects.upper[:, 0], [1, 4, 7], atol=1e-6)
    np.testing.assert_allclose(objects.up, [0, 1, 0])
    tri = objects.object_triangles(2)
    assert tri.shape == (len(mesh.faces), 3, 3)
    np.testing.assert_allclose(tri.reshape(-1, 3).mean(axis=0)[0], 6.0, atol=0.1)


def test_combined_scene_maps_triangles_to_objects():
    scene, mesh = _instanced_scene(3)
    objects = load_scene_objects(scene)
    combined, owner = objects.combined
    assert len(combined.faces) == 3 * len(mesh.faces) == len(owner)
    assert np.bincount(owner).tolist() == [len(mesh.faces)] * 3
    # a ray along -Y onto the middle ball hits object 1
    _, tri = combined.first_hit([[3.0, 5.0, 0.0]], [[0.0, -1.0, 0.0]])
    assert owner[tri[0]] == 1


def test_load_scene_objects_rotated_instance_box():
    scene = trimesh.Scene()
    box = trimesh.creation.box(extents=(4.0, 1.0, 1.0))
    scene.add_geometry(box, geom_name="bar", node_name="a")
    turn = trimesh.transformations.rotation_matrix(np.pi / 2, (0, 0, 1))
    scene.graph.update(frame_to="b", frame_from=scene.graph.base_frame, matrix=turn,
                       geometry="bar")
    objects = load_scene_objects(scene)
    np.testing.assert_allclose(objects.upper[1] - objects.lower[1], [1, 4, 1], atol=1e-9)
    mesh = objects.object_mesh(1)
    np.testing.assert_allclose(mesh.bounds, np.stack([objects.lower[1], objects.upper[1]]))


def test_load_scene_objects_single_mesh_file(tmp_path):
    path = tmp_path / "cube.ply"
    trimesh.creation.box().export(path)
    objects = load_scene_objects(path)
    assert len(objects) == 1 and objects.names == ("cube",)
    np.testing.assert_allclose(objects.up, [0, 0, 1])


def test_builtin_city_scenes():
    assert culling_scene_names() == ["city", "city-dense"]
    assert culling_scene_path("city").suffix == ".glb"
    city = load_scene_objects("city")
    kinds = {}
    for name in city.names:
        kinds[name.split("_")[0]] = kinds.get(name.split("_")[0], 0) + 1
    small = sum(kinds.get(k, 0) for k in ("car", "lamp", "bench", "tree"))
    assert small >= 1000 and kinds["building"] >= 50
    assert len(city.meshes) < 40  # instanced: few distinct meshes
    tri = {name.split("_")[0]: t for name, t in zip(city.names, city.triangles, strict=True)}
    assert 300 <= tri["car"] <= 1000 and 200 <= tri["tree"] <= 600
    assert 50 <= tri["lamp"] <= 100 and 50 <= tri["bench"] <= 150
    assert culling_scene_path("city").stat().st_size < 2_000_000


@pytest.mark.parametrize("content, match", [
    (b"", "empty"),
    (b"glTF\x02\x00\x00\x00garbage", "not a valid GLB"),
])
def test_load_scene_objects_invalid_file(tmp_path, content, match):
    path = tmp_path / "bad.glb"
    path.write_bytes(content)
    with pytest.raises(InputError, match=match):
        load_scene_objects(path)


def test_load_scene_objects_invalid_input(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_scene_objects(tmp_path / "missing.glb")
    with pytest.raises(InputError, match="not a built-in scene"):
        load_scene_objects("no-such-city")
    with pytest.raises(InputError, match="directory"):
        load_scene_objects(tmp_path)
    with pytest.raises(InputError, match="expected a file path"):
        load_scene_objects(3.5)
    scene, _ = _instanced_scene(2)
    flat = np.diag([1.0, 0.0, 1.0, 1.0])
    scene.graph.update(frame_to="ball_1", matrix=flat)
    with pytest.raises(InputError, match="singular transform"):
        load_scene_objects(scene)
    # a scale of 1e300: the determinant overflowed to inf and read as "singular"
    scene.graph.update(frame_to="ball_1", matrix=np.diag([1e300, 1e300, 1e300, 1.0]))
    with pytest.raises(InputError, match="beyond what float64 can hold"):
        load_scene_objects(scene)
    points = trimesh.Scene(trimesh.PointCloud(np.random.default_rng(0).random((10, 3))))
    buf = io.BytesIO(points.export(file_type="glb"))
    path = tmp_path / "points.glb"
    path.write_bytes(buf.getvalue())
    with pytest.raises(InputError, match="no triangles"):
        load_scene_objects(path)
