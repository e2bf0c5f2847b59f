"""``viscore bench godot-bake`` and the library parts it stands on, on hand-built cases.

The ``.tscn`` reader (:func:`viscore.exchange.tscn_instances`), the emulation of
Godot's glTF importer (:func:`viscore.generators.baselines.godot_imported_surface`)
and the bench's own block, assignment and crop rules; the matchers it compares
with are tested in ``test_mesh_match.py``. Only the last test needs Godot's demo
files (``$VISCORE_MODELS`` or ``../shared/models`` beside the repository, holding
``godot-occlusion-demo/``); it is skipped without them.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.cli.bench.godot_bake import (
    DEMO_FOLDER,
    assign_instances,
    bake_blocks,
    bench_godot_bake,
    bench_godot_bake_text,
    crop_instance,
)
from viscore.exchange import GODOT_DEFAULT_MASK, tscn_instances
from viscore.generators.baselines import godot_imported_surface
from viscore.metrics import match_triangles


def _demo() -> Path:
    base = Path(os.environ.get("VISCORE_MODELS") or
                Path(__file__).resolve().parents[2] / "shared" / "models")
    return base / DEMO_FOLDER


DEMO = _demo()

#: A few triangles inside the unit box [0, 1]^3, with a shared vertex.
LOCAL_V = np.array([[0.1, 0.1, 0.1], [0.9, 0.2, 0.1], [0.5, 0.8, 0.3], [0.4, 0.5, 0.9],
                    [0.8, 0.9, 0.7]])
LOCAL_F = np.array([[0, 1, 2], [0, 2, 3], [2, 4, 3]])
LOWER, UPPER = np.zeros(3), np.ones(3)


def _transform(angle: float, axis: int, shift) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = [k for k in range(3) if k != axis]
    mat = np.eye(4)
    mat[i, i], mat[i, j], mat[j, i], mat[j, j] = c, -s, s, c
    mat[:3, 3] = shift
    return mat


def _bake(transforms, vertices=LOCAL_V, faces=LOCAL_F):
    """One copy per transform, each with its own vertex range (as Godot appends surfaces)."""
    vs, fs = [], []
    for k, mat in enumerate(transforms):
        vs.append(vertices @ mat[:3, :3].T + mat[:3, 3])
        fs.append(faces + k * len(vertices))
    return np.concatenate(vs), np.concatenate(fs)


# ----------------------------------------------------------------------------- scene


SCENE = """[gd_scene format=3 uid="uid://x"]

[ext_resource type="PackedScene" uid="uid://r" path="res://models/room.glb" id="2_room"]
[ext_resource type="PackedScene" uid="uid://o" path="res://other.glb" id="3_other"]

[node name="Root" type="Node3D"]

[node name="Occ" type="OccluderInstance3D" parent="."]
transform = Transform3D(1, 0, 0, 0, 1, 0, 0, 0, 1, 0, -2, 0)
bake_mask = 4294967293
bake_simplification_distance = 0.25

[node name="Rooms" type="Node3D" parent="."]
transform = Transform3D(1, 0, 0, 0, 1, 0, 0, 0, 1, 10, 0, 0)

[node name="Room" parent="Rooms" instance=ExtResource("2_room")]

[node name="Lamp" type="MeshInstance3D" parent="Rooms/Room"]
layers = 2

[node name="Room2" parent="Rooms" instance=ExtResource("2_room")]
transform = Transform3D(0, -1, 0, 1, 0, 0, 0, 0, 1, 0, 0, 5)

[node name="Label" type="Label" parent="."]
text = "a
[node name=\\"Fake\\" parent=\\"Rooms\\" instance=ExtResource(\\"2_room\\")]"

[node name="Other" parent="." instance=ExtResource("3_other")]

[node name="Floor" type="MeshInstance3D" parent="."]
"""


def test_tscn_instances_composes_parents_relative_to_the_occluder():
    r = tscn_instances(SCENE, "room.glb")
    assert r["names"] == ["Room", "Room2"]
    occ = np.eye(4)
    occ[1, 3] = -2
    rooms = np.eye(4)
    rooms[0, 3] = 10
    np.testing.assert_allclose(r["transforms"][0], np.linalg.inv(occ) @ rooms)
    # rows of the basis: (1, 0, 0) -> (0, 1, 0); then Rooms' shift; then into the occluder frame
    p = r["transforms"][1] @ [1.0, 0.0, 0.0, 1.0]
    np.testing.assert_allclose(p[:3], [10.0, 1.0 + 2.0, 5.0])
    assert r["occluder"] == {"name": "Occ", "bake_mask": 4294967293, "bake_mask_set": True,
                             "bake_simplification_distance": 0.25}
    nodes = {m["name"]: m for m in r["mesh_nodes"]}
    assert nodes["Lamp"]["layers"] == 2 and not nodes["Lamp"]["in_bake_mask"]
    assert nodes["Floor"]["layers"] == 1 and nodes["Floor"]["in_bake_mask"]


def test_tscn_instances_without_an_occluder_node_keeps_the_scene_frame():
    text = SCENE.replace('type="OccluderInstance3D"', 'type="Node3D"')
    r = tscn_instances(text, "room.glb")
    assert r["occluder"] is None
    np.testing.assert_allclose(r["transforms"][0][:3, 3], [10.0, 0.0, 0.0])
    assert all(m["in_bake_mask"] for m in r["mesh_nodes"])  # the default mask takes all
    assert GODOT_DEFAULT_MASK == 2**32 - 1


def test_tscn_instances_places_a_deep_chain_of_nodes():
    """Each node one unit along x under the last: the translations add up along the chain."""
    depth = 200
    lines = ['[gd_scene format=3]', '[ext_resource type="PackedScene" path="res://r.glb" id="1"]',
             '[node name="Root" type="Node3D"]']
    parent = "."
    for k in range(depth):
        lines += [f'[node name="N{k}" type="Node3D" parent="{parent}"]',
                  "transform = Transform3D(1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0, 0)"]
        parent = f"N{k}" if parent == "." else f"{parent}/N{k}"
    lines.append(f'[node name="R" parent="{parent}" instance=ExtResource("1")]')
    r = tscn_instances("\n".join(lines) + "\n", "r.glb")
    assert r["names"] == ["R"] and r["transforms"][0][0, 3] == depth


@pytest.mark.parametrize("text, match", [
    (SCENE + '\n[node name="Lost" parent="Nowhere" instance=ExtResource("2_room")]\n',
     "Nowhere"),
    (SCENE + '\n[node name="Lamp2" type="MeshInstance3D" parent="."]\nlayers = two\n',
     "layers"),
    (SCENE.replace("bake_mask = 4294967293", "bake_mask = -1"), "bake_mask"),
    (SCENE.replace("distance = 0.25", "distance = far"), "bake_simplification_distance"),
    ('[gd_scene format=3]\n[node name="unclosed\n', "unterminated"),
])
def test_tscn_instances_invalid_input(text, match):
    with pytest.raises(InputError, match=match):
        tscn_instances(text, "room.glb")


# ----------------------------------------------------------------------------- importer


def _glb_cube(path: Path, *, normals: bool) -> None:
    """A unit cube of 8 shared corners in a GLB, with or without per-vertex normals."""
    cube = trimesh.creation.box()
    if not normals:
        cube = trimesh.Trimesh(cube.vertices, cube.faces, process=False)
    scene = trimesh.Scene()
    scene.add_geometry(cube, node_name="Cube", geom_name="cube",
                       transform=trimesh.transformations.translation_matrix([5.0, 0.0, 0.0]))
    path.write_bytes(trimesh.exchange.gltf.export_glb(scene, include_normals=normals))


def test_godot_imported_surface_swaps_corners_and_merges_in_first_use_order(tmp_path):
    path = tmp_path / "cube.glb"
    _glb_cube(path, normals=False)
    cube = trimesh.creation.box()
    v, f, raw = godot_imported_surface(path, "Cube")
    assert raw == 8 and len(v) == 8 and len(f) == 12
    # clockwise: each triangle of the file with its second and third corners swapped
    np.testing.assert_allclose(v[f], cube.vertices[cube.faces[:, [0, 2, 1]]] + [5.0, 0.0, 0.0])
    # vertices numbered by first use: the corners of the first triangle are 0, 1, 2
    first_use = np.unique(f.reshape(-1), return_index=True)[1]
    assert np.all(np.diff(first_use) > 0) and f[0].tolist() == [0, 1, 2]


def test_godot_imported_surface_keeps_corners_apart_where_the_normals_differ(tmp_path):
    """A cube whose file holds a normal per corner and face: 24 vertices, not 8."""
    path = tmp_path / "cube.glb"
    box = trimesh.creation.box()
    split = trimesh.Trimesh(box.triangles.reshape(-1, 3), np.arange(36).reshape(-1, 3),
                            process=False)
    split.vertex_normals = np.repeat(box.face_normals, 3, axis=0)
    scene = trimesh.Scene()
    scene.add_geometry(split, node_name="Cube", geom_name="cube")
    path.write_bytes(trimesh.exchange.gltf.export_glb(scene, include_normals=True))
    v, f, raw = godot_imported_surface(path, "Cube")
    assert raw == 36 and len(v) == 24 and len(f) == 12  # 6 faces x 4 corners


def test_godot_imported_surface_invalid_input(tmp_path):
    path = tmp_path / "cube.glb"
    _glb_cube(path, normals=False)
    with pytest.raises(InputError, match="Nowhere"):
        godot_imported_surface(path, "Nowhere")
    (tmp_path / "bad.glb").write_bytes(b"not a glb")
    with pytest.raises(InputError, match="bad.glb"):
        godot_imported_surface(tmp_path / "bad.glb", "Cube")


# ----------------------------------------------------------------------------- crops


def test_crop_brings_one_instance_back_to_its_frame():
    mats = [_transform(0.7, 2, [10.0, 0.0, 0.0]), _transform(-1.1, 0, [-10.0, 5.0, 3.0])]
    bv, bf = _bake(mats)
    tol = 1e-9
    for k, mat in enumerate(mats):
        lv, lf, kept = crop_instance(bv, bf, mat, LOWER, UPPER)
        assert kept.sum() == len(LOCAL_F)
        assert np.array_equal(np.flatnonzero(kept), np.arange(3) + 3 * k)
        np.testing.assert_allclose(np.sort(lv, axis=0), np.sort(LOCAL_V, axis=0), atol=1e-12)
        a, b = match_triangles(lv, lf, LOCAL_V, LOCAL_F, tol)
        assert a.all() and b.all()
    # the wrong instance's inverse puts nothing of the other copy in the box
    _, lf, kept = crop_instance(bv[:5], bf[:3], mats[1], LOWER, UPPER)
    assert not kept.any() and len(lf) == 0


def test_blocks_and_assignment_follow_the_surfaces():
    mats = [_transform(0.7, 2, [10.0, 0.0, 0.0]), _transform(-1.1, 0, [-10.0, 5.0, 3.0]),
            _transform(0.0, 1, [0.0, 0.0, 0.0])]
    bv, bf = _bake(mats)
    np.testing.assert_array_equal(bake_blocks(bf), np.repeat([0, 1, 2], 3))
    np.testing.assert_array_equal(assign_instances(bv, bf, np.array(mats), LOWER, UPPER),
                                  np.repeat([0, 1, 2], 3))
    # instances listed in another order: the assignment follows the transforms
    np.testing.assert_array_equal(
        assign_instances(bv, bf, np.array(mats[::-1]), LOWER, UPPER), np.repeat([2, 1, 0], 3))
    far = np.array([_transform(0.0, 1, [100.0, 0.0, 0.0])])
    assert (assign_instances(bv, bf, far, LOWER, UPPER) == -1).all()


def test_shared_wall_planes_fool_the_centroid_crop_not_the_blocks():
    # a unit room: its floor and its +x wall; the next room at x + 1 shares that wall plane
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1],
                  [1, 0, 0], [1, 1, 0], [1, 1, 1], [1, 0, 1]], dtype=float)
    f = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    left = np.eye(4)
    right = np.eye(4)
    right[0, 3] = 1.0
    bv, bf = _bake([left, right], v, f)
    _, lf, kept = crop_instance(bv, bf, left, LOWER, UPPER)
    assert kept.sum() == 4  # its own; the neighbour's floor and wall lie beyond x = 1
    _, lf, kept = crop_instance(bv, bf, right, LOWER, UPPER)
    assert kept.sum() == 6  # its own 4 and the left room's wall on x = 1
    owner = assign_instances(bv, bf, np.array([left, right]), LOWER, UPPER)
    np.testing.assert_array_equal(owner, [0, 0, 0, 0, 1, 1, 1, 1])


def test_one_block_spanning_instances_is_split_by_triangle():
    mats = [_transform(0.0, 1, [0.0, 0.0, 0.0]), _transform(0.0, 1, [5.0, 0.0, 0.0])]
    bv, bf = _bake(mats)
    shared = np.concatenate([bf[3:], bf[:3]])  # interleaved ranges: one block
    assert (bake_blocks(shared) == 0).all()
    np.testing.assert_array_equal(assign_instances(bv, shared, np.array(mats), LOWER, UPPER),
                                  [1, 1, 1, 0, 0, 0])


# ----------------------------------------------------------------------------- the demo


@pytest.mark.skipif(not (DEMO / "node_3d.occ").is_file(), reason="Godot's demo files not present")
def test_bench_on_godots_demo():
    r = bench_godot_bake(DEMO.parent, views=16, samples=2000)
    b = r["bake"]
    assert (b["triangles"], b["vertices"]) == (191278, 91543)
    assert b["blocks"] == r["scene"]["instances"] == 1024 and b["unassigned"] == 0
    counts = b["per_instance"]["counts"]
    assert sum(int(k) * t for k, t in counts.items()) == b["triangles"]
    assert r["scene"]["instance"] == "Room" and r["scene"]["instance_origin"] == [0, 0, 0]
    assert b["instance_triangles"] == 186 and b["centroid_crop_in_instance"] == 186
    assert b["centroid_crop_triangles"] > 186  # the neighbours' coincident walls
    baked = [s["name"] for s in r["surfaces"] if s["godot_vertices_on_it"]]
    assert baked == ["Cube"]
    ours = r["comparisons"]["ours-godot-settings"]
    assert r["occluders"]["ours-godot-settings"]["distance"] == pytest.approx(0.1)
    assert ours["hausdorff"] < 1e-5  # the same surface, triangulated otherwise
    assert 0 < ours["matched"] <= min(ours["triangles"])
    assert r["comparisons"]["ours-default"]["hausdorff_directed"][0] > 0.05  # the spheres
    text = bench_godot_bake_text(r)
    assert "191,278 triangles" in text and "ours-godot-settings" in text
