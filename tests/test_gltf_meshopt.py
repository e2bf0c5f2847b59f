"""GLB levels compressed with EXT_meshopt_compression or holding normalized positions."""

import json
import struct

import meshoptimizer
import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.exchange.gltf_meshopt import decode_meshopt_glb
from viscore.level.scene_graph import load_scene_objects

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


def _ext(header: dict, view: int) -> dict:
    return header["bufferViews"][view]["extensions"][EXT]


@pytest.mark.parametrize("change, match", [
    (lambda h: h.update(bufferViews=5), "bufferViews must be a list"),
    (lambda h: h["bufferViews"].__setitem__(1, 7), "bufferViews must be a list"),
    (lambda h: h["bufferViews"][0].update(extensions=3), "extensions must be an object"),
    (lambda h: h["bufferViews"][0]["extensions"][EXT].update(filter="OCTAHEDRAL"),
     "needs byteStride 4 or 8"),
    (lambda h: h["bufferViews"][0]["extensions"][EXT].update(count=-1), "count must be"),
    (lambda h: _ext(h, 0).update(count=10**9), "more than the ATTRIBUTES codec can give"),
    (lambda h: _ext(h, 0).update(count=4_000_000, byteStride=256), "more than the ATTRIB"),
    (lambda h: _ext(h, 0).update(byteStride=6), "multiple of 4 up to 256, got 6"),
    (lambda h: _ext(h, 0).update(byteStride=260), "multiple of 4 up to 256, got 260"),
    (lambda h: _ext(h, 1).update(count=_ext(h, 1)["count"] - 1), "not a multiple of 3"),
    (lambda h: _ext(h, 1).update(filter="OCTAHEDRAL"), "is for ATTRIBUTES, not TRIANGLES"),
    (lambda h: _ext(h, 1).update(mode="INDICES"), "does not start with the INDICES codec"),
    (lambda h: _ext(h, 0).update(filter=["NONE"]), "unknown filter"),
    (lambda h: _ext(h, 0).update(mode=["ATTRIBUTES"]), "unknown mode"),
    (lambda h: _ext(h, 0).update(count="42"), "count must be an integer"),
    (lambda h: _ext(h, 0).update(buffer=False), "not in the GLB's binary chunk"),
    (lambda h: _ext(h, 0).update(buffer=[0]), "not in the GLB's binary chunk"),
    (lambda h: h["bufferViews"][0]["extensions"].update({EXT: [1]}), "not in the GLB's bin"),
    (lambda h: h["buffers"].__setitem__(1, 7), "buffers must be a list of objects"),
    (lambda h: h["buffers"][0].update(extensions={EXT: {"fallback": True}}),
     "must lie in the GLB's binary chunk"),
    (lambda h: h["bufferViews"][0].update(byteStride=16), "has byteStride 16 but its"),
    (lambda h: h["bufferViews"].append({"buffer": [0], "byteLength": 4}), "names no buffer"),
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


def test_views_that_decode_past_the_limit_are_refused(tmp_path, monkeypatch):
    """Each view's size is checked against what its codec can give, and all of them
    against MAX_DECODED (a few bytes of JSON pointing many views at one stream must not
    allocate gigabytes): the rock's positions (504 bytes) fit under 1,000, its indices
    (960 more) do not."""
    import viscore.exchange.gltf_meshopt as gm

    path = tmp_path / "rock.glb"
    path.write_bytes(_packed_level(trimesh.creation.icosphere(subdivisions=1)))
    assert len(load_scene_objects(path).meshes[0].faces) == 80
    monkeypatch.setattr(gm, "MAX_DECODED", 1000)
    with pytest.raises(InputError, match="decode to more than"):
        load_scene_objects(path)


def _crate(change=None) -> bytes:
    """A GLB of a crate 1 x 0.5 x 0.25 whose unsigned-short positions are normalized to
    [0, 1] (KHR_mesh_quantization) and scaled back by its node (10 x)."""
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
    if change is not None:
        change(header)
    return _glb(header, blob)


def test_normalized_positions_are_scaled_as_gltf_says(tmp_path):
    """Read to within the quantization step (trimesh alone read them as integers up to
    65535)."""
    path = tmp_path / "crate.glb"
    path.write_bytes(_crate())
    objects = load_scene_objects(path)
    np.testing.assert_allclose(objects.upper[0] - objects.lower[0], [10, 5, 2.5], atol=1e-3)


@pytest.mark.parametrize("change, match", [
    (lambda h: h["accessors"][0].update(type="VEC2"), "has type 'VEC2', not VEC3"),
    (lambda h: h["accessors"][0].update(sparse={"count": 1}), "is sparse"),
    (lambda h: h["bufferViews"][0].update(byteLength=8), "reads past its buffer view"),
    (lambda h: h["accessors"][0].update(byteOffset=10**18), "reads past its buffer view"),
    (lambda h: h["bufferViews"][0].update(byteStride=1), "byteStride must be an integer >= 6"),
    (lambda h: h["accessors"][0].update(bufferView=True), "bufferView must be an integer"),
    (lambda h: h["accessors"][0].update(bufferView=9), "not in the GLB's binary chunk"),
    (lambda h: h.pop("buffers"), "buffer views but no buffers"),
])
def test_malformed_normalized_positions_are_refused_in_one_line(tmp_path, change, match):
    path = tmp_path / "crate.glb"
    path.write_bytes(_crate(change))
    with pytest.raises(InputError, match=match):
        load_scene_objects(path)


@pytest.mark.parametrize("change", [
    lambda h: h.update(meshes=5),
    lambda h: h["meshes"][0].update(primitives=5),
    lambda h: h["meshes"][0]["primitives"][0].update(attributes=[1]),
    lambda h: h["accessors"][0].update(componentType=[5123]),
    lambda h: h.update(accessors={"0": {}}),
])
def test_the_quantization_scan_skips_json_of_another_shape(change):
    """The scan for normalized positions runs on every GLB: JSON of another shape is left
    to the reader (which says what is wrong) instead of raising TypeError here."""
    data = _crate(change)
    length = struct.unpack("<I", data[12:16])[0]
    header = json.loads(data[20:20 + length])
    plain, out = decode_meshopt_glb(data, header, 20 + length, "crate.glb")
    assert plain is data and out is header
