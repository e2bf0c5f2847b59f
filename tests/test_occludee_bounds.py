"""Cluster bounds of occludees: boxes that hold every triangle, and a chunk culled through them."""

import json

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.cli.main import main
from viscore.culling.occludee_bounds import cluster_boxes, object_cluster_boxes
from viscore.level.scene_graph import load_scene_objects
from viscore.metrics import culling

#: The one camera of the chunk scenes: at the origin, looking along +z, y up.
EYE = culling.PathCamera(position=np.zeros(3), forward=np.array([0.0, 0.0, 1.0]),
                         up=np.array([0.0, 1.0, 0.0]), fov=90.0)


def test_cluster_boxes_hold_every_triangle_and_part_separated_pieces():
    mesh = trimesh.creation.icosphere(subdivisions=3)
    lo, hi = cluster_boxes(mesh.vertices, mesh.faces, 16)
    assert 1 < len(lo) <= 16
    tri = mesh.triangles
    inside = ((tri.min(axis=1)[:, None] >= lo[None] - 1e-12)
              & (tri.max(axis=1)[:, None] <= hi[None] + 1e-12)).all(axis=2)
    assert inside.any(axis=1).all()  # every triangle lies in some cluster's box
    assert np.allclose(lo.min(axis=0), mesh.bounds[0]) and np.allclose(hi.max(axis=0),
                                                                       mesh.bounds[1])
    # two unit cubes 10 apart: two clusters are the two cubes' boxes exactly
    pair = trimesh.util.concatenate([trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]]),
                                     trimesh.creation.box(bounds=[[10, 0, 0], [11, 1, 1]])])
    lo, hi = cluster_boxes(pair.vertices, pair.faces, 2)
    order = np.argsort(lo[:, 0])
    assert lo[order].tolist() == [[0, 0, 0], [10, 0, 0]]
    assert hi[order].tolist() == [[1, 1, 1], [11, 1, 1]]
    # one cluster is the mesh's box; a single triangle is never split
    lo, hi = cluster_boxes(pair.vertices, pair.faces, 1)
    assert lo.tolist() == [[0, 0, 0]] and hi.tolist() == [[11, 1, 1]]
    assert len(cluster_boxes([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], 8)[0]) == 1


def test_cluster_boxes_as_many_as_triangles_are_the_triangles_boxes():
    mesh = trimesh.creation.icosphere(subdivisions=1)  # 80 triangles
    tri = mesh.triangles
    for k in (80, 4096):
        lo, hi = cluster_boxes(mesh.vertices, mesh.faces, k)
        assert np.array_equal(lo, tri.min(axis=1)) and np.array_equal(hi, tri.max(axis=1))
    assert len(cluster_boxes(mesh.vertices, mesh.faces, 79)[0]) == 79  # the k-d split


def test_default_bounds_cull_bars_behind_two_walls_that_their_box_sees_through_a_gap():
    """Two walls with a gap between them, each hiding half of an object of six thin bars
    (72 triangles): the object's box spans the gap and is seen through it, the default
    bounds (a box per triangle) are each behind a wall: culled, and nothing culled is
    visible."""
    from viscore.culling.occludee_bounds import DEFAULT_BOUNDS, occludee_boxes, parse_bounds

    scene = trimesh.Scene()
    walls = [trimesh.creation.box(bounds=[[x0, -2, 2.9], [x1, 2, 3.1]])
             for x0, x1 in ((-4, -0.3), (0.3, 4))]  # the gap: x in (-0.3, 0.3)
    for i, wall in enumerate(walls):
        scene.add_geometry(wall, geom_name=f"wall{i}", node_name=f"wall{i}")
    bars = [trimesh.creation.box(bounds=[[x, -1, 6], [x + 0.1, 1, 6.1]])
            for x in (-3.0, -2.0, -1.0, 0.9, 1.9, 2.9)]
    scene.add_geometry(trimesh.util.concatenate(bars), geom_name="bars", node_name="bars")
    objects = load_scene_objects(scene)
    runtimes = {"none": culling.no_culling(), "depth": culling.depth_buffer_runtime(walls)}
    culled = {}
    for text in ("box", "meshlets:1", DEFAULT_BOUNDS):
        bounds = occludee_boxes(objects, *parse_bounds(text))[0]
        r = culling.simulate_culling(objects, runtimes, [EYE], width=128, height=72,
                                     bounds=bounds)
        assert r.visible.tolist() == [2] and r.in_view.tolist() == [3]  # bars hidden
        assert r.runtimes["depth"].false_culls.tolist() == [0]
        culled[text] = r.runtimes["depth"].culled.tolist()
    assert culled == {"box": [0], "meshlets:1": [1], DEFAULT_BOUNDS: [1]}
    assert DEFAULT_BOUNDS == "triangles"


def test_object_cluster_boxes_follow_instances():
    box = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    scene = trimesh.Scene()
    scene.add_geometry(box, geom_name="b", node_name="a")
    scene.add_geometry(box, geom_name="b", node_name="c",
                       transform=trimesh.transformations.translation_matrix([5, 0, 0]))
    scene.add_geometry(trimesh.creation.icosphere(subdivisions=2), geom_name="s",
                       node_name="d",  # turned: its clusters' boxes turn out of its own
                       transform=trimesh.transformations.rotation_matrix(np.pi / 6, [0, 1, 0]))
    objects = load_scene_objects(scene)
    lo, hi, owner = object_cluster_boxes(objects, 4)
    assert owner.tolist() == sorted(owner.tolist()) and set(owner.tolist()) == {0, 1, 2}
    for i in range(3):
        mine = owner == i
        # every cluster box inside the object's box, and together they reach its sides
        assert (lo[mine] >= objects.lower[i] - 1e-12).all()
        assert (hi[mine] <= objects.upper[i] + 1e-12).all()
        assert np.allclose(lo[mine].min(axis=0), objects.lower[i])
        assert np.allclose(hi[mine].max(axis=0), objects.upper[i])
        # and every world triangle lies in one of them
        tri = objects.object_triangles(i)
        inside = ((tri.min(axis=1)[:, None] >= lo[mine][None] - 1e-9)
                  & (tri.max(axis=1)[:, None] <= hi[mine][None] + 1e-9)).all(axis=2)
        assert inside.any(axis=1).all()
    with pytest.raises(InputError, match="clusters"):
        object_cluster_boxes(objects, 0)


def test_object_cluster_boxes_split_only_objects_of_min_size():
    scene = trimesh.Scene()  # a 20 m chunk of two pillars (not flat) and two small spheres
    # (the pillars modelled finely: a coarse object around detailed ones is a landscape,
    # which does not set the level's size)
    chunk = trimesh.util.concatenate([
        trimesh.creation.box(bounds=[[0, 0, 0], [2, 3, 1]]).subdivide().subdivide(),
        trimesh.creation.box(bounds=[[18, 0, 0], [20, 3, 1]]).subdivide().subdivide()])
    scene.add_geometry(chunk, geom_name="chunk", node_name="chunk")
    ball = trimesh.creation.icosphere(subdivisions=2)
    for x in (5, 12):
        scene.add_geometry(ball, geom_name="ball", node_name=f"ball{x}",
                           transform=trimesh.transformations.translation_matrix([x, 3, 0]))
    objects = load_scene_objects(scene)
    c = objects.names.index("chunk")
    balls = [i for i in range(3) if i != c]
    every = object_cluster_boxes(objects, 8)
    assert (np.bincount(every[2])[balls] == 8).all()  # without min_size: all split
    lo, hi, owner = object_cluster_boxes(objects, 8, min_size=0.25)
    counts = np.bincount(owner)
    assert counts[c] > 1 and (counts[balls] == 1).all()
    for i in balls:  # a small object's one box is its own box
        assert np.allclose(lo[owner == i], objects.lower[i])
        assert np.allclose(hi[owner == i], objects.upper[i])
    # the chunk's split is the one it gets without min_size
    assert np.array_equal(lo[owner == c], every[0][every[2] == c])
    # above the largest object's share, nothing is split
    assert np.bincount(object_cluster_boxes(objects, 8, min_size=1.0)[2]).tolist() == [1, 1, 1]
    for bad in (0, 1.5, float("nan")):
        with pytest.raises(InputError, match="min_size"):
            object_cluster_boxes(objects, 8, min_size=bad)


def _chunk_scene(layout: str):
    """A wall in front of the camera and one object of two cubes (a chunk of a level).

    The camera at the origin looks along +z at a 2 m wall 3 m ahead. ``hidden``: one cube
    5 m ahead behind the wall, the other 5 m behind the eye (out of view), so the chunk's
    box holds the eye and no box test can cull it. ``beside``: the cube ahead is beside the
    wall, in view. ``half``: both cubes ahead, one behind the wall, one beside it.
    """
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(bounds=[[-1, -1, 2.9], [1, 1, 3.1]]),
                       geom_name="wall", node_name="wall")
    behind_wall = [[-0.5, -0.5, 5], [0.5, 0.5, 6]]
    beside_wall = [[-3.5, -0.5, 5], [-2.5, 0.5, 6]]
    behind_eye = [[-0.5, -0.5, -6], [0.5, 0.5, -5]]
    cubes = {"hidden": [behind_wall, behind_eye], "beside": [beside_wall, behind_eye],
             "half": [behind_wall, beside_wall]}[layout]
    chunk = trimesh.util.concatenate([trimesh.creation.box(bounds=b) for b in cubes])
    scene.add_geometry(chunk, geom_name="chunk", node_name="chunk")
    return load_scene_objects(scene)


@pytest.mark.parametrize("layout", ["hidden", "beside", "half"])
def test_a_chunk_is_culled_through_its_clusters_only_when_all_are_hidden(layout):
    objects = _chunk_scene(layout)
    wall = trimesh.creation.box(bounds=[[-0.95, -0.95, 2.95], [0.95, 0.95, 3.05]])
    runtimes = {"none": culling.no_culling(), "depth": culling.depth_buffer_runtime([wall])}
    poses = [EYE]
    box = culling.simulate_culling(objects, runtimes, poses, width=96, height=54)
    clusters = culling.simulate_culling(objects, runtimes, poses, width=96, height=54,
                                bounds=object_cluster_boxes(objects, 2))
    hidden = layout == "hidden"
    assert box.visible[0] == (1 if hidden else 2)
    if layout != "half":
        assert box.runtimes["depth"].culled.tolist() == [0]  # the chunk's box holds the eye
    assert clusters.runtimes["depth"].culled.tolist() == [1 if hidden else 0]
    assert clusters.runtimes["depth"].false_culls.tolist() == [0]
    assert clusters.runtimes["none"].culled.tolist() == [0]
    assert box.in_view.tolist() == clusters.in_view.tolist() == [2]


def test_simulate_culling_refuses_bad_bounds():
    objects = _chunk_scene("hidden")
    poses = [EYE]
    lo, hi, owner = object_cluster_boxes(objects, 2)
    for bad, match in [((lo, hi), "expected"), ((lo, hi[:1], owner), "expected"),
                       ((lo, hi, owner[::-1]), "non-decreasing"),
                       ((lo, hi, owner + 5), "non-decreasing"),
                       ((hi, lo, owner), "lower <= upper")]:
        with pytest.raises(InputError, match=match):
            culling.simulate_culling(objects, {"none": culling.no_culling()}, poses,
                                     width=32, height=18, bounds=bad)


def test_cull_cli_bounds_option(tmp_path, capsys):
    scene = trimesh.Scene()
    for i in range(4):  # four walls of a yard and a long chunk across it
        scene.add_geometry(trimesh.creation.box(extents=[20, 0.5, 4]), geom_name=f"w{i}",
                           node_name=f"w{i}", transform=trimesh.transformations.rotation_matrix(
                               i * np.pi / 2, [0, 1, 0]) @ trimesh.transformations.
                           translation_matrix([0, 2, 10]) @ trimesh.transformations.
                           rotation_matrix(np.pi / 2, [1, 0, 0]))
    scene.add_geometry(trimesh.creation.box(extents=[1, 1, 1]), geom_name="c", node_name="c")
    level = tmp_path / "yard.glb"
    scene.export(level)
    out = tmp_path / "run"
    assert main(["cull", str(level), "--frames", "3", "--methods", "aabb-skins", "--bounds",
                 "clusters:8", "--width", "160", "--height", "90", "--out", str(out), "--json",
                 "--quiet"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["bounds"]["kind"] == "clusters" and doc["bounds"]["clusters"] == 8
    assert doc["bounds"]["boxes"] > doc["settings"]["objects"]
    # auto: the long walls (0.7 of the yard's diagonal) split, the cube not
    assert main(["cull", str(level), "--frames", "3", "--methods", "aabb-skins", "--bounds",
                 "auto", "--width", "160", "--height", "90", "--out", str(out), "--json",
                 "--quiet"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["bounds"]["kind"] == "auto" and doc["bounds"]["split_objects"] == 4
    assert doc["bounds"]["boxes"] > doc["settings"]["objects"]
    # meshlets:1: every object through its triangles' boxes, 5 boxes of 12
    assert main(["cull", str(level), "--frames", "3", "--methods", "aabb-skins", "--bounds",
                 "meshlets:1", "--width", "160", "--height", "90", "--out", str(out), "--json",
                 "--quiet"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["bounds"]["kind"] == "meshlets" and doc["bounds"]["clusters"] == 1
    assert doc["bounds"]["split_objects"] == 5 and doc["bounds"]["boxes"] == 5 * 12
    # the default, triangles: every object through its own 12 triangles, said in the table
    assert main(["cull", str(level), "--frames", "3", "--methods", "aabb-skins", "--width",
                 "160", "--height", "90", "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "5 objects tested by their triangles, 60 in all" in text
    assert json.loads((out / "cull.json").read_text())["bounds"]["kind"] == "triangles"
    for bad in ["clusters:0", "clusters:x", "sphere", "box:3", "auto:0"]:
        assert main(["cull", "--bounds", bad, "--out", str(tmp_path / "x"), "--quiet"]) == 2
        assert "--bounds" in capsys.readouterr().err
        assert not (tmp_path / "x").exists()


def test_object_cluster_boxes_meshlets_count_by_triangles():
    # meshlets of 16 triangles: a 12-triangle box is one cluster (its own box), an
    # icosphere of 320 triangles 20, a two-triangle quad one; every triangle in its box
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]]), geom_name="box",
                       node_name="box")
    scene.add_geometry(trimesh.creation.icosphere(subdivisions=2), geom_name="ball",
                       node_name="ball",
                       transform=trimesh.transformations.translation_matrix([5, 0, 0]))
    quad = trimesh.Trimesh([[0, 0, 3], [1, 0, 3], [1, 1, 3], [0, 1, 3]], [[0, 1, 2], [0, 2, 3]])
    scene.add_geometry(quad, geom_name="quad", node_name="quad")
    objects = load_scene_objects(scene)
    lo, hi, owner = object_cluster_boxes(objects, 4096, per_cluster=16)
    counts = np.bincount(owner, minlength=3)
    assert counts[objects.names.index("box")] == 1
    assert counts[objects.names.index("ball")] == 20
    assert counts[objects.names.index("quad")] == 1
    for i in range(3):
        mine = owner == i
        tri = objects.object_triangles(i)
        inside = ((tri.min(axis=1)[:, None] >= lo[mine][None] - 1e-9)
                  & (tri.max(axis=1)[:, None] <= hi[mine][None] + 1e-9)).all(axis=2)
        assert inside.any(axis=1).all()
    # at most the cluster cap, whatever the triangles
    _, _, owner = object_cluster_boxes(objects, 8, per_cluster=1)
    assert np.bincount(owner).max() == 8
    with pytest.raises(InputError, match="per_cluster"):
        object_cluster_boxes(objects, 8, per_cluster=0)


def test_parse_bounds_kinds_and_refusals():
    from viscore.culling.occludee_bounds import (
        DEFAULT_CLUSTERS,
        MESHLET_TRIANGLES,
        parse_bounds,
    )

    assert parse_bounds("box") == ("box", 1)
    assert parse_bounds("auto") == ("auto", DEFAULT_CLUSTERS)
    assert parse_bounds("clusters:8") == ("clusters", 8)
    assert parse_bounds("meshlets") == ("meshlets", MESHLET_TRIANGLES)
    assert parse_bounds("meshlets:4") == ("meshlets", 4)
    for bad in ("boxes", "box:2", "meshlets:0", "meshlets:x", "clusters:99999",
                "clusters:+3", "clusters:1_0", "clusters:\u0663", "meshlets: 4"):
        with pytest.raises(InputError, match="--bounds"):
            parse_bounds(bad)
