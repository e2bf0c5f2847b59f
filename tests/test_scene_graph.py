"""Scenes as objects (viscore.level.scene_graph): instancing, boxes, bad files."""

import io
import struct

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.level.scene_graph import (
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


# --------------------------------------------------------------------------- glTF hierarchy
def _box_buffer():
    """Vertices (8, 3) float32 and faces (12, 3) uint32 of a unit box, as one buffer."""
    box = trimesh.creation.box()
    v = np.asarray(box.vertices, dtype=np.float32)
    f = np.asarray(box.faces, dtype=np.uint32)
    return v, f, v.tobytes() + f.tobytes()


def _gltf(nodes, roots, *, primitives=1, buffer_uri=None, **extra):
    """glTF JSON (dict) of ``nodes`` with scene roots ``roots``; mesh 0 is a unit box."""
    v, f, blob = _box_buffer()
    prim = {"attributes": {"POSITION": 0}, "indices": 1}
    gltf = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(roots)}],
        "nodes": nodes, "meshes": [{"name": "box", "primitives": [prim] * primitives}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(v), "type": "VEC3",
             "min": v.min(axis=0).tolist(), "max": v.max(axis=0).tolist()},
            {"bufferView": 1, "componentType": 5125, "count": f.size, "type": "SCALAR"}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": v.nbytes},
                        {"buffer": 0, "byteOffset": v.nbytes, "byteLength": f.nbytes}],
        "buffers": [{"byteLength": len(blob)}],
    }
    if buffer_uri is not None:
        gltf["buffers"][0]["uri"] = buffer_uri
    gltf.update(extra)
    return gltf


def _glb(nodes, roots, **kwargs):
    """GLB bytes: the JSON of :func:`_gltf` and the box buffer as its BIN chunk."""
    import json

    text = json.dumps(_gltf(nodes, roots, **kwargs)).encode()
    text += b" " * (-len(text) % 4)
    blob = _box_buffer()[2]
    blob += b"\0" * (-len(blob) % 4)
    body = (struct.pack("<I4s", len(text), b"JSON") + text
            + struct.pack("<I4s", len(blob), b"BIN\0") + blob)
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def _write(tmp_path, name, data):
    path = tmp_path / name
    path.write_bytes(data)
    return path


def _chain(depth, *, mesh_every_level=False):
    """Nodes n0 -> n1 -> ... of ``depth`` levels, each translating by (1, 0, 0)."""
    nodes = [{"name": f"n{i}", "translation": [1.0, 0.0, 0.0], "children": [i + 1]}
             for i in range(depth)]
    del nodes[-1]["children"]
    for node in nodes if mesh_every_level else nodes[-1:]:
        node["mesh"] = 0
    return nodes


def test_load_scene_objects_trs_matrix_nested_instancing(tmp_path):
    tf = trimesh.transformations
    quat = [0.1, 0.2, 0.3, 0.9]  # XYZW, not unit: glTF readers normalise it
    matrix = tf.rotation_matrix(0.4, (1, 1, 0)) @ tf.scale_matrix(2.0)
    matrix[:3, 3] = (3.0, 4.0, 5.0)
    nodes = [
        {"name": "trs", "mesh": 0, "translation": [1.5, -2.25, 3.0], "rotation": quat,
         "scale": [2.0, 0.5, 1.25]},
        {"name": "mat", "mesh": 0, "matrix": matrix.T.reshape(-1).tolist(), "children": [2]},
        {"name": "kid", "mesh": 0, "translation": [0.0, 1.0, 0.0], "children": [3]},
        {"name": "grandkid", "mesh": 0, "scale": [3.0, 3.0, 3.0]},
    ]
    objects = load_scene_objects(_write(tmp_path, "nested.glb", _glb(nodes, [0, 1])))
    assert objects.names == ("grandkid", "kid", "mat", "trs")
    assert len(objects.meshes) == 1 and objects.mesh_ids.tolist() == [0, 0, 0, 0]
    t = tf.translation_matrix([1.5, -2.25, 3.0])
    r = tf.quaternion_matrix([quat[3], quat[0], quat[1], quat[2]])
    s = np.diag([2.0, 0.5, 1.25, 1.0])
    kid = matrix @ tf.translation_matrix([0.0, 1.0, 0.0])  # world = parent world x local
    expected = {"trs": t @ r @ s, "mat": matrix, "kid": kid,
                "grandkid": kid @ np.diag([3.0, 3.0, 3.0, 1.0])}
    for name, m in zip(objects.names, objects.transforms, strict=True):
        np.testing.assert_array_equal(m, expected[name], err_msg=name)


def test_load_scene_objects_node_cycle(tmp_path):
    two = [{"name": "a", "children": [1], "mesh": 0}, {"name": "b", "children": [0]}]
    with pytest.raises(InputError, match=r"node 0 \('a'\) is its own descendant: .*cycle "
                                         r"\(0 -> 1 -> 0\)"):
        load_scene_objects(_write(tmp_path, "cycle.glb", _glb(two, [0])))
    # a cycle below a proper root (what trimesh looped on: "Iteration limit exceeded")
    below = [{"name": "r", "children": [1]}, {"name": "x", "children": [2], "mesh": 0},
             {"name": "y", "children": [1]}]
    with pytest.raises(InputError, match=r"cycle3\.glb: node 1 \('x'\) is its own descendant"):
        load_scene_objects(_write(tmp_path, "cycle3.glb", _glb(below, [0])))
    with pytest.raises(InputError, match=r"node 0 \('self'\).*cycle \(0 -> 0\)"):
        load_scene_objects(_write(tmp_path, "self.glb",
                                  _glb([{"name": "self", "children": [0], "mesh": 0}], [0])))


def test_load_scene_objects_two_parents(tmp_path):
    nodes = [{"name": "p1", "children": [2], "translation": [10.0, 0, 0]},
             {"name": "p2", "children": [2], "translation": [20.0, 0, 0]},
             {"name": "c", "mesh": 0}]
    with pytest.raises(InputError, match=r"node 2 \('c'\) has two parents, node 0 \('p1'\) "
                                         r"and node 1 \('p2'\)"):
        load_scene_objects(_write(tmp_path, "dag.glb", _glb(nodes, [0, 1])))
    # a scene root that is also a child is the same fault
    nodes = [{"name": "p", "children": [1]}, {"name": "c", "mesh": 0}]
    with pytest.raises(InputError, match=r"node 1 \('c'\) is a root of scene 0 and a child "
                                         r"of node 0 \('p'\)"):
        load_scene_objects(_write(tmp_path, "root.glb", _glb(nodes, [0, 1])))
    # one parent listing a child twice is still one parent: one instance
    nodes = [{"name": "p", "children": [1, 1], "translation": [0, 5.0, 0]},
             {"name": "c", "mesh": 0}]
    objects = load_scene_objects(_write(tmp_path, "twice.glb", _glb(nodes, [0])))
    assert objects.names == ("c",)
    np.testing.assert_array_equal(objects.transforms[0][:3, 3], [0, 5.0, 0])


def test_load_scene_objects_depth_limit(tmp_path):
    from viscore.level.scene_graph import _MAX_NODE_DEPTH

    limit = _MAX_NODE_DEPTH
    path = _write(tmp_path, "deep.glb", _glb(_chain(limit + 1), [0]))
    with pytest.raises(InputError, match=rf"deep\.glb: the node hierarchy is {limit + 1:,} "
                                         rf"levels deep \(at node {limit} \('n{limit}'\)\), "
                                         rf"deeper than the {limit:,} levels"):
        load_scene_objects(path)
    objects = load_scene_objects(_write(tmp_path, "limit.glb", _glb(_chain(limit), [0])))
    assert objects.names == (f"n{limit - 1}",)
    np.testing.assert_array_equal(objects.transforms[0],
                                  trimesh.transformations.translation_matrix((limit, 0, 0)))


def test_load_scene_objects_deep_chain_exact(tmp_path):
    depth = 900
    path = _write(tmp_path, "chain.glb", _glb(_chain(depth, mesh_every_level=True), [0]))
    objects = load_scene_objects(path)
    assert len(objects) == depth and len(objects.meshes) == 1
    level = {name: int(name[1:]) + 1 for name in objects.names}
    for name, m in zip(objects.names, objects.transforms, strict=True):
        np.testing.assert_array_equal(
            m, trimesh.transformations.translation_matrix((level[name], 0, 0)), err_msg=name)


def test_load_scene_objects_multi_primitive_names(tmp_path):
    path = _write(tmp_path, "two.glb", _glb([{"name": "a", "mesh": 0}], [0], primitives=2))
    first, second = load_scene_objects(path), load_scene_objects(path)
    assert first.names == second.names == ("a_0", "a_1")  # trimesh gave random suffixes
    assert first.mesh_names == second.mesh_names
    # the two primitives are the same box: stored once, under the first one's name
    assert len(first.meshes) == 1 and first.mesh_ids.tolist() == [0, 0]


def test_copies_exported_without_instancing_are_stored_once(tmp_path):
    """A level whose every copy of a room is its own glTF mesh (no instancing) keeps one
    geometry per distinct shape, placed by each node's transform; a copy that differs in
    one vertex, or only in its face order, stays a mesh of its own."""
    box = trimesh.creation.box(extents=(1, 2, 3))
    moved = box.copy()
    moved.vertices[0] += [0, 0, 1e-3]  # glTF stores float32
    flipped = trimesh.Trimesh(box.vertices, box.faces[::-1], process=False)
    scene = trimesh.Scene()
    for k in range(4):
        scene.add_geometry(box.copy(), geom_name=f"room{k}", node_name=f"n{k}",
                           transform=trimesh.transformations.translation_matrix((5 * k, 0, 0)))
    scene.add_geometry(moved, geom_name="moved", node_name="n8")
    scene.add_geometry(flipped, geom_name="flipped", node_name="n9")
    path = tmp_path / "copies.glb"
    scene.export(path)
    objects = load_scene_objects(path)
    assert len(objects) == 6 and len(objects.meshes) == 3
    ids = dict(zip(objects.names, objects.mesh_ids.tolist(), strict=True))
    assert len({ids[f"n{k}"] for k in range(4)}) == 1
    assert len({ids["n0"], ids["n8"], ids["n9"]}) == 3
    # each copy is still where its node puts it
    np.testing.assert_allclose(objects.lower[:4, 0], [-0.5, 4.5, 9.5, 14.5])


def test_load_scene_objects_camera_node(tmp_path):
    # trimesh dropped the first camera node's mesh and cut its children off the scene
    nodes = [{"name": "cam", "camera": 0, "mesh": 0, "translation": [5.0, 0, 0],
              "children": [1]},
             {"name": "kid", "mesh": 0, "translation": [1.0, 0, 0]}]
    cameras = [{"type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.1}}]
    objects = load_scene_objects(_write(tmp_path, "cam.glb", _glb(nodes, [0], cameras=cameras)))
    assert objects.names == ("cam", "kid")
    np.testing.assert_array_equal(objects.transforms[:, 0, 3], [5.0, 6.0])


@pytest.mark.parametrize("nodes, roots, extra, match", [
    ([{"name": "p", "children": [7]}], [0], {}, r"node 0 \('p'\) 'children' lists 7, not an "
                                                 r"index below 1"),
    ([{"mesh": 3}], [0], {}, r"node 0 \(no name\) refers to mesh 3, but the file has 1 meshes"),
    ([{"name": "a", "mesh": 0}], [0], {"scene": 2}, r"'scene' is 2, not an index below 1"),
    ([{"name": "a", "mesh": 0}], [1], {}, r"scene 0 'nodes' lists 1, not an index below 1"),
    ([{"name": "a", "mesh": 0, "translation": [1, 2]}], [0], {},
     r"node 0 \('a'\): 'translation' must be a list of 3 numbers"),
    ([{"name": "a", "mesh": 0, "scale": [1, True, 1]}], [0], {},
     r"node 0 \('a'\): 'scale' must be a list of 3 numbers"),
    ([{"name": "a", "mesh": 0, "children": "0"}], [0], {},
     r"node 0 \('a'\) 'children' must be a list of indices"),
])
def test_load_scene_objects_invalid_hierarchy(tmp_path, nodes, roots, extra, match):
    with pytest.raises(InputError, match=match):
        load_scene_objects(_write(tmp_path, "bad.glb", _glb(nodes, roots, **extra)))


def _spy_opens(monkeypatch):
    """Record every path opened through ``open``, ``io.open`` and ``os.open``."""
    import builtins
    import os

    opened = []
    real_open, real_os_open = builtins.open, os.open

    def spy(file, *args, **kwargs):
        opened.append(os.path.realpath(file) if isinstance(file, (str, os.PathLike)) else file)
        return real_open(file, *args, **kwargs)

    def os_spy(file, *args, **kwargs):
        opened.append(os.path.realpath(file))
        return real_os_open(file, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", spy)
    monkeypatch.setattr(io, "open", spy)
    monkeypatch.setattr(os, "open", os_spy)
    return opened


def test_load_scene_objects_uri_outside_folder(tmp_path, monkeypatch):
    import json
    import os

    secret = tmp_path / "secret.bin"
    secret.write_bytes(_box_buffer()[2])  # a valid buffer: only the rule can refuse it
    sub = tmp_path / "sub"
    sub.mkdir()
    path = sub / "scene.gltf"
    path.write_text(json.dumps(_gltf([{"name": "a", "mesh": 0}], [0],
                                     buffer_uri="../secret.bin")))
    opened = _spy_opens(monkeypatch)
    with pytest.raises(InputError) as info:
        load_scene_objects(path)
    message = str(info.value)
    assert message.startswith(f"{path}: buffer URI '../secret.bin' points outside the folder")
    assert "must stay inside that folder" in message and "FilePathResolver" not in message
    assert str(path) in [str(p) for p in opened]  # the spy works ...
    assert os.path.realpath(secret) not in opened  # ... and the buffer was never read
    # the same buffer inside the folder loads
    (sub / "secret.bin").write_bytes(secret.read_bytes())
    path.write_text(json.dumps(_gltf([{"name": "a", "mesh": 0}], [0], buffer_uri="secret.bin")))
    assert load_scene_objects(path).names == ("a",)


def test_load_scene_objects_image_uri_outside_folder(tmp_path, monkeypatch, caplog):
    import json
    import logging
    import os

    (tmp_path / "tex.png").write_bytes(b"not read")
    sub = tmp_path / "sub"
    sub.mkdir()
    (sub / "box.bin").write_bytes(_box_buffer()[2])
    gltf = _gltf([{"name": "a", "mesh": 0}], [0], buffer_uri="box.bin",
                 images=[{"uri": "../tex.png"}], textures=[{"source": 0}],
                 materials=[{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}])
    gltf["meshes"][0]["primitives"][0]["material"] = 0
    path = sub / "scene.gltf"
    path.write_text(json.dumps(gltf))
    opened = _spy_opens(monkeypatch)
    with caplog.at_level(logging.WARNING, logger="viscore.level.scene_graph"):
        objects = load_scene_objects(path)
    assert objects.names == ("a",)  # geometry does not need the texture
    assert os.path.realpath(tmp_path / "tex.png") not in opened
    assert any("image URI '../tex.png' points outside the folder" in r.getMessage()
               and str(path) in r.getMessage() for r in caplog.records)


def test_cull_cli_node_cycle_exits_2(tmp_path, capsys):
    from viscore.cli.main import main

    nodes = [{"name": "a", "children": [1], "mesh": 0}, {"name": "b", "children": [0]}]
    path = _write(tmp_path, "cycle.glb", _glb(nodes, [0]))
    assert main(["cull", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err
    assert err.startswith("viscore: error: ") and "node 0 ('a') is its own descendant" in err


def test_compressed_geometry_is_refused_by_name(tmp_path):
    """A glTF that requires Draco decoding, or meshopt decoding outside a GLB (a GLB's is
    decoded: tests/test_gltf_meshopt.py), is refused with one line naming the extension
    (trimesh's reader failed with "list index out of range")."""
    import json

    nodes = [{"name": "box", "mesh": 0}]
    draco = "KHR_draco_mesh_compression"
    path = _write(tmp_path, "packed.glb", _glb(nodes, [0], extensionsUsed=[draco],
                                               extensionsRequired=[draco]))
    with pytest.raises(InputError, match=f"compressed with {draco}"):
        load_scene_objects(path)
    # used but not required (the file holds plain geometry too): read as usual
    path = _write(tmp_path, "plain.glb", _glb(nodes, [0], extensionsUsed=[draco]))
    assert load_scene_objects(path).names == ("box",)
    meshopt = "EXT_meshopt_compression"
    _write(tmp_path, "box.bin", _box_buffer()[2])
    path = _write(tmp_path, "packed.gltf", json.dumps(_gltf(
        nodes, [0], buffer_uri="box.bin", extensionsUsed=[meshopt],
        extensionsRequired=[meshopt])).encode())
    with pytest.raises(InputError, match=f"compressed with {meshopt}"):
        load_scene_objects(path)
