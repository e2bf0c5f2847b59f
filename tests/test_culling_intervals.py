"""Intervals on the culling simulation's shares, and the objects kept for pictures."""

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.level.scene_graph import load_scene_objects
from viscore.metrics.bootstrap import BOOTSTRAP_RESAMPLES
from viscore.metrics.culling import (
    CULLING_CONFIDENCE,
    CullingResult,
    PathCamera,
    Runtime,
    RuntimeFrames,
    no_culling,
    simulate_culling,
)

UP = np.array([0.0, 1.0, 0.0])


def _frames(culled, in_view, visible=None):
    """A CullingResult of given per-frame counts (one runtime 'r' beside 'none')."""
    culled = np.asarray(culled, np.int64)
    in_view = np.asarray(in_view, np.int64)
    visible = in_view // 2 if visible is None else np.asarray(visible, np.int64)
    zeros = np.zeros(len(in_view), np.int64)
    rt = {"none": RuntimeFrames(zeros, zeros, 10 * in_view, np.zeros(len(in_view)), True),
          "r": RuntimeFrames(culled, zeros, 10 * (in_view - culled), np.zeros(len(in_view)),
                             True)}
    pose = PathCamera(position=np.zeros(3), forward=np.array([0.0, 0, 1]), up=UP)
    return CullingResult(cameras=(pose,) * len(in_view), width=8, height=8, objects=100,
                         triangles=1000, in_view=in_view, in_view_triangles=10 * in_view,
                         visible=visible, visible_triangles=10 * visible, runtimes=rt)


def test_totals_interval_of_a_constant_share_is_that_share():
    result = _frames([5] * 12, [10] * 12)  # half of the objects in view, every frame
    t = result.totals()
    assert t["r"]["culled_share"] == 0.5 and t["r"]["culled_share_ci"] == [0.5, 0.5]
    assert t["none"]["culled_share_ci"] == [0.0, 0.0]
    assert t["r"]["triangles_rendered_per_frame_ci"] == [50.0, 50.0]


def test_totals_interval_holds_the_share_and_follows_the_seed():
    rng = np.random.default_rng(0)
    in_view = rng.integers(20, 40, 30)
    culled = (in_view * rng.uniform(0.2, 0.8, 30)).astype(np.int64)
    result = _frames(culled, in_view)
    t = result.totals(seed=3)["r"]
    lo, hi = t["culled_share_ci"]
    assert lo < t["culled_share"] < hi
    assert result.totals(seed=3)["r"]["culled_share_ci"] == [lo, hi]
    assert result.totals(seed=4)["r"]["culled_share_ci"] != [lo, hi]


def test_totals_interval_widens_with_correlated_frames():
    # the same 30 per-frame shares, in runs of 6 equal frames or shuffled: blocks see the
    # runs, so the walk in runs gets the wider interval (fewer independent stretches)
    shares = np.repeat([0.1, 0.5, 0.9, 0.4, 0.2], 6)  # into a dense quarter and out
    in_view = np.full(30, 100)
    runs = _frames((shares * 100).astype(int), in_view)
    mixed = _frames((np.random.default_rng(1).permutation(shares) * 100).astype(int), in_view)
    assert runs.interval_block() > 1
    assert mixed.interval_block() == 1

    def width(r):
        lo, hi = r.totals(seed=0)["r"]["culled_share_ci"]
        return hi - lo

    assert width(runs) > 1.5 * width(mixed)


def test_to_json_records_the_intervals_settings():
    result = _frames([2, 3, 4, 5, 6, 7], [10] * 6, visible=[5, 6, 5, 6, 5, 6])
    doc = result.to_json(seed=17)
    assert doc["intervals"] == {"method": "circular block bootstrap over frames",
                                "confidence": CULLING_CONFIDENCE,
                                "block": result.interval_block(),
                                "resamples": BOOTSTRAP_RESAMPLES, "seed": 17}
    lo, hi = doc["ground_truth"]["hidden_share_ci"]
    assert lo < doc["ground_truth"]["hidden_share"] == 0.45 < hi
    assert doc["totals"]["r"]["culled_share_ci"] == result.totals(seed=17)["r"][
        "culled_share_ci"]


def test_totals_interval_of_one_frame_is_undefined():
    t = _frames([3], [10]).totals()
    assert np.isnan(t["r"]["culled_share_ci"]).all()


@pytest.fixture(scope="module")
def wall_scene():
    """A wall (x in [-5, 5], z in [-0.1, 0.1], y in [0, 6]) and a 1 m box 5 m behind it."""
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(bounds=[[-5, 0, -0.1], [5, 6, 0.1]]),
                       geom_name="wall", node_name="wall")
    scene.add_geometry(trimesh.creation.box(bounds=[[-0.5, 0, 4.5], [0.5, 1, 5.5]]),
                       geom_name="box", node_name="box")
    return load_scene_objects(scene)


def _pose(position, forward):
    return PathCamera(position=np.asarray(position, float), forward=np.asarray(forward, float),
                      up=UP, fov=90.0)


def _cull_box(camera, lower, upper):
    return upper[:, 2] > 1.0  # everything beyond the wall's plane


def test_simulate_culling_keeps_the_objects_of_chosen_frames(wall_scene):
    box, wall = wall_scene.names.index("box"), wall_scene.names.index("wall")
    poses = [_pose((0, 1.5, -10), (0, 0, 1)),   # the wall hides the box
             _pose((12, 1.5, 5), (-1, 0, 0)),   # beside the wall: both seen
             _pose((0, 1.5, -10), (0, 0, -1))]  # looking away: nothing in view
    runtimes = {"none": no_culling(), "far": Runtime(cull=_cull_box, conservative=False)}
    result = simulate_culling(wall_scene, runtimes, poses, width=96, height=54,
                              keep_frames=[0, 1, 2])
    k0, k1, k2 = (result.kept[f] for f in range(3))
    assert k0.in_view.tolist() == sorted([box, wall]) and k0.visible.tolist() == [wall]
    assert k0.culled["far"].tolist() == [box] and k0.culled["none"].tolist() == []
    assert k1.visible.tolist() == sorted([box, wall]) and k1.culled["far"].tolist() == [box]
    assert k2.in_view.tolist() == [] and k2.culled["far"].tolist() == []
    # the kept sets agree with the counts
    for f in range(3):
        assert len(result.kept[f].culled["far"]) == result.runtimes["far"].culled[f]
    assert simulate_culling(wall_scene, runtimes, poses, width=96, height=54).kept == {}


@pytest.mark.parametrize("frames", [[3], [-1], [0.5], ["a"], 5])
def test_simulate_culling_keep_frames_invalid_input(wall_scene, frames):
    with pytest.raises(InputError, match="keep_frames"):
        simulate_culling(wall_scene, {"none": no_culling()}, [_pose((0, 1.5, -10), (0, 0, 1))],
                         width=8, height=8, keep_frames=frames)


def test_simulate_culling_keeps_the_objects_with_cluster_bounds(wall_scene):
    # occludees tested through boxes of their parts (bounds=): the kept sets still hold
    from viscore.culling.occludee_bounds import occludee_boxes

    bounds, _, _ = occludee_boxes(wall_scene, "clusters", 2)
    poses = [_pose((0, 1.5, -10), (0, 0, 1))]
    runtimes = {"far": Runtime(cull=_cull_box, conservative=False)}
    result = simulate_culling(wall_scene, runtimes, poses, width=96, height=54, bounds=bounds,
                              keep_frames=[0])
    box = wall_scene.names.index("box")
    assert result.kept[0].culled["far"].tolist() == [box]
    assert result.kept[0].visible.tolist() == [wall_scene.names.index("wall")]


def test_runtimes_give_their_occluders_for_pictures():
    from viscore.culling.depth_buffer import OccluderScene
    from viscore.metrics.culling import depth_buffer_runtime, frusta_runtime

    box = trimesh.creation.box(extents=(2, 2, 2))
    cam = _pose((0, 0, -10), (0, 0, 1)).camera(16, 9)
    assert no_culling().occluder_scene is None
    solids = frusta_runtime([(box.vertices, box.faces), (box.vertices + 5, box.faces)])
    scene = solids.occluder_scene(cam)
    assert len(scene.faces) == 24 and scene is solids.occluder_scene(cam)  # built once
    assert np.allclose(scene.vertices.min(axis=0), -1) and np.allclose(
        scene.vertices.max(axis=0), 6)
    fixed = depth_buffer_runtime([box])
    assert len(fixed.occluder_scene(cam).faces) == 12
    shifted = OccluderScene([box.apply_translation((0, 0, 3))])
    per_frame = depth_buffer_runtime(lambda camera: shifted, count=1)
    assert per_frame.occluder_scene(cam) is shifted.scene  # the frame's own occluders
