"""GLB levels compressed with EXT_meshopt_compression or holding normalized positions."""

import json
import struct

import meshoptimizer
import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.gltf_meshopt import decode_meshopt_glb
from viscore.scene_graph import load_scene_objects

EXT = "EXT_meshopt_compression"


def _glb(header: dict, blob: bytes) -> bytes:
    text = json.dumps(header).encode()
    text += b" " * (-len(text) % 4)
    blob += b"\0" * (-len(blob) % 4)
    body = (struct.pack("<I4s", len(text), b"JSON") + text
            + struct.pack("<I4s", len(blob), b"BIN\0") + blob)
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def _packed_level(mesh: trimesh.Trimesh, *, mode_v="ATTRIBUTES", cut=0, source=0):
    """A GLB of ``mesh`` (node "rock", moved by (5, 0, 0)) whose position and index views
    are meshopt-encoded into the binary chunk, with an empty fallback buffer."""
    v = np.ascontiguousarray(mesh.vertices, dtype="<f4")
    f = np.ascontiguousarray(mesh.faces, dtype="<u4").reshape(-1)
    ev = meshoptimizer.encode_vertex_buffer(v, len(v), 12)
    ei = meshoptimizer.encode_index_buffer(f, len(f), len(v))
    blob = ev + b"\0" * (-len(ev) % 4) + ei
    off_i = len(ev) + (-len(ev) % 4)
    blob = blob[:len(blob) - cut]
    header = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "rock", "mesh": 0, "translation": [5.0, 0.0, 0.0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(v), "type": "VEC3",
             "min": v.min(0).tolist(), "max": v.max(0).tolist()},
            {"bufferView": 1, "componentType": 5125, "count": len(f), "type": "SCALAR"}],
        "bufferViews": [
            {"buffer": 1, "byteLength": v.nbytes, "byteStride": 12, "extensions": {EXT: {
                "buffer": source, "byteOffset": 0, "byteLength": len(ev), "byteStride": 12,
                "count": len(v), "mode": mode_v}}},
            {"buffer": 1, "byteLength": f.nbytes, "extensions": {EXT: {
                "buffer": source, "byteOffset": off_i, "byteLength": len(ei), "byteStride": 4,
                "count": len(f), "mode": "TRIANGLES"}}}],
        "buffers": [{"byteLength": len(blob) + (-len(blob) % 4)},
                    {"byteLength": v.nbytes + f.nbytes, "extensions": {EXT: {"fallback": True}}}],
        "extensionsUsed": [EXT], "extensionsRequired": [EXT],
    }
    return _glb(header, blob)


def test_a_meshopt_compressed_level_loads_as_the_plain_one(tmp_path):
    rock = trimesh.creation.icosphere(subdivisions=3)
    path = tmp_path / "packed.glb"
    path.write_bytes(_packed_level(rock))
    objects = load_scene_objects(path)
    assert objects.names == ("rock",)
    mesh = objects.meshes[0]
    np.testing.assert_array_equal(objects.object_vertices(0),
                                  rock.vertices.astype(np.float32) + [5, 0, 0])

    def turned(faces):  # the index codec may rotate a triangle (its winding kept)
        faces = np.asarray(faces)
        k = np.argmin(faces, axis=1)
        rows = np.stack([np.roll(t, -i) for t, i in zip(faces, k, strict=True)])
        return rows[np.lexsort(rows.T[::-1])]

    np.testing.assert_array_equal(turned(mesh.faces), turned(rock.faces))
    # the decoded file is a plain GLB: no extension, no fallback buffer, and read as is
    data = path.read_bytes()
    length = struct.unpack("<I", data[12:16])[0]
    header = json.loads(data[20:20 + length])
    plain, out = decode_meshopt_glb(data, header, 20 + length, "packed.glb")
    assert "extensionsRequired" not in out and len(out["buffers"]) == 1
    assert not any("extensions" in v for v in out["bufferViews"])
    again = trimesh.load_scene(file_obj=trimesh.util.wrap_as_stream(plain), file_type="glb")
    assert sum(len(g.faces) for g in again.geometry.values()) == len(rock.faces)


@pytest.mark.parametrize("change, match", [
    (lambda h: h.update(bufferViews=5), "bufferViews must be a list"),
    (lambda h: h["bufferViews"].__setitem__(1, 7), "bufferViews must be a list"),
    (lambda h: h["bufferViews"][0].update(extensions=3), "extensions must be an object"),
    (lambda h: h["bufferViews"][0]["extensions"][EXT].update(filter="OCTAHEDRAL"),
     "needs byteStride 4 or 8"),
    (lambda h: h["bufferViews"][0]["extensions"][EXT].update(count=-1), "count must be"),
    (lambda h: h["bufferViews"][0]["extensions"][EXT].update(count=10**9), "does not decode"),
    (lambda h: h["bufferViews"][0]["extensions"][EXT].update(byteStride=6), "does not decode"),
])
def test_malformed_meshopt_json_is_refused_in_one_line(tmp_path, change, match):
    data = _packed_level(trimesh.creation.icosphere(subdivisions=1))
    length = struct.unpack("<I", data[12:16])[0]
    header = json.loads(data[20:20 + length])
    change(header)
    path = tmp_path / "bad.glb"
    path.write_bytes(_glb(header, data[20 + length + 8:]))
    with pytest.raises(InputError, match=match):
        load_scene_objects(path)


@pytest.mark.parametrize("kwargs, match", [
    ({"cut": 40}, "does not decode|past the binary chunk"),
    ({"mode_v": "SPLINES"}, "unknown mode"),
    ({"source": 1}, "not in the GLB's binary chunk"),
])
def test_bad_meshopt_data_is_refused_in_one_line(tmp_path, kwargs, match):
    path = tmp_path / "bad.glb"
    path.write_bytes(_packed_level(trimesh.creation.icosphere(subdivisions=2), **kwargs))
    with pytest.raises(InputError, match=match):
        load_scene_objects(path)


def test_normalized_positions_are_scaled_as_gltf_says(tmp_path):
    """KHR_mesh_quantization: unsigned-short positions normalized to [0, 1] and scaled back
    by the node (10 x), read to within the quantization step (trimesh alone read them as
    integers up to 65535)."""
    box = trimesh.creation.box(bounds=[[0, 0, 0], [1, 0.5, 0.25]])
    q = np.round(box.vertices * 65535).astype("<u2")
    f = np.asarray(box.faces, dtype="<u2").reshape(-1)
    stride = 8  # positions padded to 4-byte rows, as the spec asks
    rows = np.zeros((len(q), 4), "<u2")
    rows[:, :3] = q
    blob = rows.tobytes() + f.tobytes()
    header = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "crate", "mesh": 0, "scale": [10.0, 10.0, 10.0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5123, "normalized": True, "count": len(q),
             "type": "VEC3", "min": q.min(0).tolist(), "max": q.max(0).tolist()},
            {"bufferView": 1, "componentType": 5123, "count": len(f), "type": "SCALAR"}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": rows.nbytes,
                         "byteStride": stride},
                        {"buffer": 0, "byteOffset": rows.nbytes, "byteLength": f.nbytes}],
        "buffers": [{"byteLength": len(blob) + (-len(blob) % 4)}],
        "extensionsUsed": ["KHR_mesh_quantization"],
        "extensionsRequired": ["KHR_mesh_quantization"],
    }
    path = tmp_path / "crate.glb"
    path.write_bytes(_glb(header, blob))
    objects = load_scene_objects(path)
    np.testing.assert_allclose(objects.upper[0] - objects.lower[0], [10, 5, 2.5], atol=1e-3)
