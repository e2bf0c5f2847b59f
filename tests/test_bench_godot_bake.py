"""``viscore bench godot-bake``'s parts on hand-built cases, and the bench on Godot's demo.

Only the last test needs Godot's demo files (``$VISCORE_MODELS`` or
``../shared/models`` beside the repository, holding ``godot-occlusion-demo/``);
it is skipped without them.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from viscore import InputError
from viscore.cli.bench.godot_bake import (
    DEMO_FOLDER,
    assign_instances,
    bake_blocks,
    bench_godot_bake,
    bench_godot_bake_text,
    crop_instance,
    match_triangles,
    scene_instances,
    surface_distance,
)


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


def test_scene_instances_composes_parents_relative_to_the_occluder():
    r = scene_instances(SCENE, "room.glb")
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


def test_scene_instances_refuses_an_unknown_parent():
    text = SCENE + '\n[node name="Lost" parent="Nowhere" instance=ExtResource("2_room")]\n'
    with pytest.raises(InputError, match="Nowhere"):
        scene_instances(text, "room.glb")


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


# ----------------------------------------------------------------------------- matching


SQUARE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
SQUARE_F = np.array([[0, 1, 2], [0, 2, 3]])


def test_match_triangles_ignores_order_and_orientation():
    perm = np.array([2, 0, 3, 1])  # new vertex k is old vertex perm[k]
    where = np.argsort(perm)
    v = SQUARE_V[perm]
    f = where[SQUARE_F][::-1][:, [2, 1, 0]]  # triangles swapped and flipped
    a, b = match_triangles(v, f, SQUARE_V, SQUARE_F, 1e-4)
    assert a.all() and b.all()
    # the other diagonal covers the same square with other triangles: no match
    a, b = match_triangles(SQUARE_V, np.array([[0, 1, 3], [1, 2, 3]]), SQUARE_V, SQUARE_F, 1e-4)
    assert not a.any() and not b.any()


def test_match_triangles_tolerance_and_duplicates():
    moved = SQUARE_V.copy()
    moved = np.vstack([moved, moved[[0]] + [0, 0, 1e-2]])  # a copy of vertex 0, lifted
    f = np.array([[0, 1, 2], [4, 2, 3]])
    a, b = match_triangles(moved, f, SQUARE_V, SQUARE_F, 1e-4)
    assert a.tolist() == [True, False] and b.tolist() == [True, False]
    moved[4] = SQUARE_V[0] + [0, 1e-5, 0]  # within the tolerance
    a, b = match_triangles(moved, f, SQUARE_V, SQUARE_F, 1e-4)
    assert a.all() and b.all()
    twice = np.array([[0, 1, 2], [2, 1, 0]])  # the same triangle twice against once
    a, b = match_triangles(SQUARE_V, twice, SQUARE_V, SQUARE_F, 1e-4)
    assert a.sum() == 1 == b.sum() and b.tolist() == [True, False]


# ----------------------------------------------------------------------------- distances


def test_surface_distance_is_exact_on_a_square():
    rng = np.random.default_rng(1)
    inside = np.column_stack([rng.uniform(0, 1, 50), rng.uniform(0, 1, 50),
                              rng.uniform(-2, 2, 50)])
    np.testing.assert_allclose(surface_distance(inside, SQUARE_V, SQUARE_F),
                               np.abs(inside[:, 2]), atol=1e-12)
    beside = np.column_stack([1 + rng.uniform(0.1, 1, 50), rng.uniform(0, 1, 50),
                              rng.uniform(-1, 1, 50)])
    np.testing.assert_allclose(surface_distance(beside, SQUARE_V, SQUARE_F),
                               np.hypot(beside[:, 0] - 1, beside[:, 2]), atol=1e-12)
    corner = np.array([[2.0, 3.0, 1.0]])
    np.testing.assert_allclose(surface_distance(corner, SQUARE_V, SQUARE_F), [np.sqrt(6.0)])
    # one candidate per point suffices for the estimate's nearest triangle
    np.testing.assert_allclose(surface_distance(inside, SQUARE_V, SQUARE_F, candidates=1),
                               np.abs(inside[:, 2]), atol=1e-12)


def test_surface_distance_far_from_the_origin_picks_the_right_triangle():
    # a fine grid a million units out: squared distances there lose ~1e-3, more than the
    # 1e-2 cells' spread; centred coordinates keep the estimate's nearest triangle right
    n, cell = 20, 0.01
    x, y = np.meshgrid(np.arange(n + 1) * cell, np.arange(n + 1) * cell, indexing="ij")
    shift = np.array([1e6, -2e6, 1.5e6])
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)]) + shift
    k = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    f = np.concatenate([np.column_stack([k, k + n + 1, k + n + 2]),
                        np.column_stack([k, k + n + 2, k + 1])])
    rng = np.random.default_rng(2)
    points = np.column_stack([rng.uniform(0, n * cell, 40), rng.uniform(0, n * cell, 40),
                              np.full(40, 1e-6)]) + shift
    np.testing.assert_allclose(surface_distance(points, v, f, candidates=1), 1e-6, rtol=1e-3)


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
