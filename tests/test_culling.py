"""Culling simulation (viscore.metrics.culling) and scene occluders (generators.scene_occluders)."""

import json
import logging

import numpy as np
import pytest
import trimesh

from viscore import InputError, PerspectiveCamera
from viscore.generators import generate
from viscore.generators.levels import (
    culling_runtimes,
    joined_occluder,
    occluder_objects,
    scene_occluders,
    transform_occluder,
)
from viscore.level.scene_graph import load_scene_objects
from viscore.metrics import camera_walk
from viscore.metrics.culling import (
    PathCamera,
    Runtime,
    camera_path,
    camera_path_json,
    culling_plot,
    no_culling,
    read_camera_path,
    simulate_culling,
    view_frustum_mask,
)

UP = np.array([0.0, 1.0, 0.0])


def _pose(position, forward, fov=90.0):
    return PathCamera(position=np.asarray(position, float), forward=np.asarray(forward, float),
                      up=UP, fov=fov)


@pytest.fixture(scope="module")
def wall_scene():
    """A wall (x in [-5, 5], z in [-0.1, 0.1], y in [0, 6]) and a 1 m box 5 m behind it."""
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(bounds=[[-5, 0, -0.1], [5, 6, 0.1]]),
                       geom_name="wall", node_name="wall")
    scene.add_geometry(trimesh.creation.box(bounds=[[-0.5, 0, 4.5], [0.5, 1, 5.5]]),
                       geom_name="box", node_name="box")
    return load_scene_objects(scene)


def _cull_all(camera, lower, upper):
    return np.ones(len(lower), dtype=bool)


def test_simulate_culling_ground_truth_wall(wall_scene):
    behind = _pose((0, 1.5, -10), (0, 0, 1))  # the wall hides the box
    beside = _pose((12, 1.5, 5), (-1, 0, 0))  # past the wall's end, looking at the box
    runtimes = {"none": no_culling(), "all": Runtime(cull=_cull_all, conservative=False)}
    result = simulate_culling(wall_scene, runtimes, [behind, beside], width=96, height=54)
    assert result.in_view.tolist() == [2, 2]
    assert result.visible.tolist() == [1, 2]  # frame 0: the wall only
    rt = result.runtimes
    assert rt["none"].culled.tolist() == [0, 0] and rt["none"].false_culls.tolist() == [0, 0]
    assert rt["none"].triangles_rendered.tolist() == [24, 24]
    # culling everything: the wall is a false cull in frame 0, both objects in frame 1
    assert rt["all"].false_culls.tolist() == [1, 2]
    assert rt["all"].triangles_rendered.tolist() == [0, 0]
    assert rt["all"].false_cull_names[0] == ("wall",)
    assert result.visible_triangles.tolist() == [12, 24]


def test_simulate_culling_frusta_cull_box_behind_wall(wall_scene):
    wall = trimesh.creation.box(bounds=[[-4.9, 0, -0.05], [4.9, 5.9, 0.05]])  # inside the wall
    from viscore.metrics.culling import depth_buffer_runtime, frusta_runtime

    runtimes = {"solid-frusta": frusta_runtime([(wall.vertices, wall.faces)]),
                "depth-buffer": depth_buffer_runtime([wall])}
    poses = [_pose((0, 1.5, -10), (0, 0, 1)), _pose((12, 1.5, 5), (-1, 0, 0))]
    result = simulate_culling(wall_scene, runtimes, poses, width=96, height=54)
    for name in runtimes:
        assert result.runtimes[name].culled.tolist() == [1, 0], name
        assert result.runtimes[name].false_culls.tolist() == [0, 0], name


def test_view_frustum_mask_behind_and_beside():
    cam = PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 1, 0), fov=90, resolution=32, height=18)
    lower = np.array([[-1, -1, 5], [-1, -1, -6], [20, -1, 5], [-0.1, 3.5, 5], [-0.1, 2.5, 5]])
    upper = lower + [[2, 2, 1], [2, 2, 1], [1, 1, 1], [0.2, 0.2, 1], [0.2, 0.2, 1]]
    # vertical half-angle: tan = 9/16, so at depth 5..6 the top edge is at y = 2.81..3.38
    assert view_frustum_mask(cam, lower, upper).tolist() == [True, False, False, False, True]


def test_camera_path_json_roundtrip(tmp_path, wall_scene):
    poses = [_pose((0, 1.5, -10), (0, 0, 1), fov=70), _pose((12, 1.5, 5), (-2, 0, 0))]
    path = tmp_path / "cameras.json"
    path.write_text(camera_path_json(poses))
    back = read_camera_path(path)
    assert len(back) == 2 and back[0].fov == 70
    np.testing.assert_allclose(back[1].forward, [-1, 0, 0])
    path.write_text(json.dumps([{"position": [0, 1, 0], "forward": [0, 0, 1]}]))
    (only,) = read_camera_path(path, up=(0, 1, 0))
    assert only.fov == 90.0 and only.up.tolist() == [0, 1, 0]


@pytest.mark.parametrize("text, match", [
    ("", "not a valid JSON"),
    ("{}", "non-empty JSON list"),
    ("[]", "non-empty JSON list"),
    ('[{"position": [0, 0, 0]}]', "missing forward"),
    ('[{"position": [0, 0, 0], "forward": [0, 0, 0]}]', "zero-length"),
    ('[{"position": [0, 0, 0], "forward": [0, 1, 0]}]', "parallel"),
    ('[{"position": [0, "a", 0], "forward": [0, 0, 1]}]', "position"),
    ('[{"position": [0, 0, 0], "forward": [0, 0, 1], "fov": 180}]', "fov"),
    ('[{"position": [0, 0, 0], "forward": [0, 0, 1], "zoom": 2}]', "unknown key"),
])
def test_read_camera_path_invalid_input(tmp_path, text, match):
    path = tmp_path / "cameras.json"
    path.write_text(text)
    with pytest.raises(InputError, match=match):
        read_camera_path(path)


def test_read_camera_path_not_a_regular_file(tmp_path):
    import os

    with pytest.raises(InputError, match="directory"):
        read_camera_path(tmp_path)
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="not a regular file"):  # refused, never read
        read_camera_path(fifo)
    with pytest.raises(InputError, match="no such file"):
        read_camera_path(tmp_path / "missing.json")


def test_simulate_culling_invalid_input(wall_scene):
    with pytest.raises(InputError, match="at least one runtime"):
        simulate_culling(wall_scene, {}, [_pose((0, 1, -5), (0, 0, 1))])
    with pytest.raises(InputError, match="at least one camera"):
        simulate_culling(wall_scene, {"none": no_culling()}, [])
    with pytest.raises(InputError, match="width"):
        simulate_culling(wall_scene, {"none": no_culling()}, [_pose((0, 1, -5), (0, 0, 1))],
                         width=0)
    with pytest.raises(InputError, match="Runtime"):
        simulate_culling(wall_scene, {"x": lambda *a: None}, [_pose((0, 1, -5), (0, 0, 1))])
    with pytest.raises(InputError, match="jobs"):
        simulate_culling(wall_scene, {"none": no_culling()}, [_pose((0, 1, -5), (0, 0, 1))],
                         jobs=0)


def test_scene_objects_pickle_without_the_combined_scene(wall_scene):
    import pickle

    _ = wall_scene.combined
    copy = pickle.loads(pickle.dumps(wall_scene))
    assert "combined" in wall_scene.__dict__ and "combined" not in copy.__dict__
    assert copy.names == wall_scene.names
    scene, owner = copy.combined  # rebuilt on use: the same triangles, the same owners
    assert np.array_equal(owner, wall_scene.combined[1])
    assert np.array_equal(scene.vertices, wall_scene.combined[0].vertices)


def test_transform_occluder_boxes_become_moved_solids():
    box = trimesh.creation.box(extents=(2.0, 1.0, 1.0))
    occ = generate("aabb-skins", box, voxels=8)
    turn = trimesh.transformations.rotation_matrix(np.pi / 2, (0, 0, 1))
    turn[:3, 3] = (10, 0, 0)
    moved = transform_occluder(occ, turn)
    assert "boxes" not in moved.parts and len(moved.parts["solids"]) == len(occ.parts["boxes"])
    v, f = moved.parts["solids"][0]
    solid = trimesh.Trimesh(v, f, process=False)
    assert solid.volume > 0  # still outward-facing
    np.testing.assert_allclose(moved.mesh.bounds.mean(axis=0), [10, 0, 0], atol=1e-9)
    mirror = np.diag([-1.0, 1, 1, 1])
    flipped = transform_occluder(occ, mirror).parts["solids"][0]
    assert trimesh.Trimesh(*flipped, process=False).volume > 0


# --------------------------------------------------------------------------- the city
@pytest.fixture(scope="module")
def city():
    return load_scene_objects("city")


@pytest.fixture(scope="module")
def city_run(city):
    """Five street-level frames of the built-in path, runtimes from aabb-skins at 32 voxels."""
    indices = occluder_objects(city)
    runtimes, info = culling_runtimes(city, indices, ["aabb-skins"], frusta_source="aabb-skins",
                                      params={"aabb-skins": {"voxels": 32}})
    path = camera_path(city, frames=40)[::8]
    return simulate_culling(city, runtimes, path, width=256, height=144), info


def test_occluder_objects_city(city):
    chosen = occluder_objects(city)
    names = {city.names[i].split("_")[0] for i in chosen}
    assert names <= {"building", "ground"} and "building" in names
    assert occluder_objects(city, names=["building_0003"]).tolist() == [
        city.names.index("building_0003")]
    with pytest.raises(InputError, match="no object named"):
        occluder_objects(city, names=["nope"])
    with pytest.raises(InputError, match="no object"):
        occluder_objects(city, size_threshold=1e9)


def test_city_conservative_runtimes_never_cull_visible_objects(city_run):
    result, info = city_run
    assert set(result.runtimes) == {"none", "planar-frusta", "solid-frusta",
                                    "depth-buffer:aabb-skins"}
    for name, rf in result.runtimes.items():
        assert rf.conservative and info[name]["conservative"]
        assert rf.false_culls.tolist() == [0] * len(result.cameras), name
        assert (rf.triangles_rendered >= result.visible_triangles).all(), name
    for name in ("planar-frusta", "solid-frusta", "depth-buffer:aabb-skins"):
        assert result.runtimes[name].culled.sum() > 0, name
    # front-face caps and ranking by faces: solid frusta cull at least what planar
    # frusta of the same solids cull, every frame
    assert (result.runtimes["solid-frusta"].culled
            >= result.runtimes["planar-frusta"].culled).all()


def test_culling_result_json_keys(city_run):
    result, _ = city_run
    doc = json.loads(json.dumps(result.to_json()))
    assert set(doc) >= {"frames", "totals", "ground_truth", "settings"}
    assert len(doc["frames"]) == len(result.cameras)
    frame = doc["frames"][0]
    for name in result.runtimes:
        assert set(frame[name]) >= {"culled", "culled_share", "false_culls",
                                    "triangles_rendered", "overhead_ms"}
        assert set(doc["totals"][name]) >= {"culled", "culled_share", "false_culls",
                                            "triangles_rendered", "overhead_ms",
                                            "conservative"}
    assert doc["totals"]["none"]["culled"] == 0
    assert doc["totals"]["none"]["triangles_rendered"] == int(result.in_view_triangles.sum())


def test_culling_plot_writes_png(city_run, tmp_path):
    result, _ = city_run
    culling_plot(result, tmp_path / "triangles.png", title="city")
    assert (tmp_path / "triangles.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(InputError, match="figure"):
        culling_plot(result, tmp_path / "triangles.txt")


def test_camera_path_deterministic_and_in_free_space(city):
    a = camera_path(city, frames=30, seed=3)
    b = camera_path(city, frames=30, seed=3)
    assert len(a) == 30
    assert all(np.array_equal(p.position, q.position) and np.array_equal(p.forward, q.forward)
               for p, q in zip(a, b, strict=True))
    street = [p for p in a if abs(p.position[1] - 1.7) < 0.1]
    assert len(street) >= 15  # most frames at eye height above the street
    # never inside a building: an upward ray crosses each closed building's surface an
    # even number of times
    scene, owner = city.combined
    eyes = np.array([p.position for p in street])
    hits = scene.all_hits(eyes, np.tile([0.0, 1.0, 0.0], (len(eyes), 1)))
    building = np.array([n.startswith("building") for n in city.names])[owner[hits.triangle]]
    assert (np.bincount(hits.ray[building], minlength=len(eyes)) % 2 == 0).all()
    # and nothing rises to the eye right below it (the free-space map's promise)
    t, _ = scene.first_hit(eyes, np.tile([0.0, -1.0, 0.0], (len(eyes), 1)))
    assert (t > 0.1).all()
    far = [p for p in a if np.linalg.norm(p.position[[0, 2]]) > 300]
    assert not far  # no view from far outside: every camera stands where a player would


def test_scene_occluders_instances_share_one_generation(city):
    indices = occluder_objects(city)[:6]
    occ = scene_occluders(city, indices, "bbox")
    assert set(occ) <= set(indices.tolist())
    for i, o in occ.items():  # each instance's bounding box occluder sits on its object
        np.testing.assert_allclose(o.mesh.bounds, np.stack([city.lower[i], city.upper[i]]),
                                   atol=1e-6)


@pytest.mark.slow
def test_city_full_path_no_false_culls_full_resolution(city):
    indices = occluder_objects(city)
    runtimes, _ = culling_runtimes(city, indices, ["aabb-skins"])
    result = simulate_culling(city, runtimes, camera_path(city, frames=100))
    for name, rf in result.runtimes.items():
        assert rf.false_culls.tolist() == [0] * 100, name


@pytest.mark.slow
@pytest.mark.parametrize("scene", ["city", "city-dense"])
def test_solid_frusta_cull_at_least_planar_every_frame(scene):
    objects = load_scene_objects(scene)
    runtimes, _ = culling_runtimes(objects, occluder_objects(objects), [])  # default cap, rank
    fewer = []
    for k, pose in enumerate(camera_path(objects, frames=100)):
        cam = pose.camera(1280, 720)
        keep = view_frustum_mask(cam, objects.lower, objects.upper)
        lo, hi = objects.lower[keep], objects.upper[keep]
        solid = runtimes["solid-frusta"].cull(cam, lo, hi).sum()
        planar = runtimes["planar-frusta"].cull(cam, lo, hi).sum()
        if solid < planar:
            fewer.append(k)
    assert fewer == []


def test_culling_runtimes_hierarchy_cut_per_frame(monkeypatch):
    from viscore.generators import registry
    from viscore.generators.planar_hierarchy import generate_planar_hierarchy

    calls = []

    def tree(mesh, *, budget=None, seed=0):
        calls.append(len(mesh.faces))
        return generate_planar_hierarchy(mesh, budget=24, seed=seed, voxels=16,
                                         node_occluder="aabb-skins")

    spec = registry.GeneratorSpec("test-hierarchy", tree, "test", conservative=True,
                                  budgeted=False)
    monkeypatch.setitem(registry.REGISTRY, "test-hierarchy", spec)
    scene = trimesh.Scene()
    for k, x in enumerate((-3.0, -1.0, 1.0)):  # three walls side by side
        scene.add_geometry(trimesh.creation.box(bounds=[[x, 0, -0.5], [x + 2, 6, 0.5]]),
                           geom_name=f"wall{k}", node_name=f"wall{k}")
    scene.add_geometry(trimesh.creation.box(bounds=[[-0.3, 0.6, 4.7], [0.3, 1.2, 5.3]]),
                       geom_name="box", node_name="box")
    objects = load_scene_objects(scene)
    indices = occluder_objects(objects, names=["wall0", "wall1", "wall2"])
    runtimes, info = culling_runtimes(objects, indices, ["test-hierarchy"], frusta=False)
    assert info["depth-buffer:test-hierarchy"]["hierarchy"] is True
    assert info["depth-buffer:test-hierarchy"]["occluders"] == 1  # one tree for the scene
    assert calls[-1] == 3 * 12  # ... generated once over the three walls joined
    poses = [_pose((0, 1.5, -10), (0, 0, 1)), _pose((0, 1.5, -400), (0, 0, 1)),
             _pose((12, 1.5, 5), (-1, 0, 0))]
    result = simulate_culling(objects, runtimes, poses, width=192, height=108)
    rf = result.runtimes["depth-buffer:test-hierarchy"]
    assert rf.false_culls.tolist() == [0, 0, 0]
    assert rf.culled[0] == 1 and rf.culled[2] == 0  # the box behind the middle wall


def _fenced_streets(scale: float = 1.0):
    """Four buildings, and a fence 4 cm thick and 3 m tall across the whole scene at z = 0."""
    scene = trimesh.Scene()
    boxes = {"ground": [[-60, -0.2, -60], [60, 0, 60]], "fence": [[-60, 0, -0.02], [60, 3, 0.02]]}
    for k, (x, z) in enumerate([(-30, -30), (-30, 30), (30, -30), (30, 30)]):
        boxes[f"building{k}"] = [[x - 18, 0, z - 18], [x + 18, 12, z + 18]]
    for name, bounds in boxes.items():
        scene.add_geometry(trimesh.creation.box(bounds=np.asarray(bounds) * scale),
                           geom_name=name, node_name=name)
    return load_scene_objects(scene)


def test_camera_path_does_not_walk_through_thin_things():
    # the fence falls between the centre rays of the free-space map (it was crossed
    # by every seed's path); its edges block its cells, so the walk stays on one side
    objects = _fenced_streets()
    for seed in (0, 1):
        path = camera_path(objects, frames=40, seed=seed)[:36]  # street and elevated
        z = np.array([p.position[2] for p in path])
        assert (z > 0).all() or (z < 0).all(), seed
        scene, _ = objects.combined
        eyes = np.array([p.position for p in path])
        turns = np.array([[1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1], [0.6, 0, 0.8]])
        t, _ = scene.first_hit(np.repeat(eyes, len(turns), 0), np.tile(turns, (len(eyes), 1)))
        assert np.nanmin(t) > 0.2  # nothing within a cell of the map around an eye


def test_camera_path_tiny_scene_looks_at_it():
    # a scene in other units (1e-9): the eye height goes down with it; at 1.7 units the
    # street frames looked over the scene and saw nothing
    objects = _fenced_streets(1e-9)
    path = camera_path(objects, frames=20)
    street = path[:14]
    assert all(p.position[1] < 12e-9 for p in street)
    seen = [view_frustum_mask(p.camera(64, 36), objects.lower, objects.upper).sum()
            for p in street]
    assert min(seen) >= 1


def test_runtimes_not_conservative_on_an_open_occluder_mesh():
    # a wall without its bottom: aabb-skins reports conservative_guaranteed False for it,
    # so no runtime fed by it may claim the guarantee (the registry flag alone said yes)
    wall = trimesh.creation.box(bounds=[[-5, 0, -0.5], [5, 6, 0.5]])
    open_wall = trimesh.Trimesh(wall.vertices, wall.faces[wall.triangles_center[:, 1] > 1e-9],
                                process=False)
    scene = trimesh.Scene()
    scene.add_geometry(open_wall, geom_name="wall", node_name="wall")
    scene.add_geometry(wall, geom_name="closed", node_name="closed",
                       transform=trimesh.transformations.translation_matrix((20, 0, 0)))
    scene.add_geometry(trimesh.creation.box(bounds=[[-0.5, 0, 4.5], [0.5, 1, 5.5]]),
                       geom_name="box", node_name="box")
    objects = load_scene_objects(scene)
    params = {"aabb-skins": {"voxels": 16}}
    both = occluder_objects(objects, names=["wall", "closed"])
    runtimes, info = culling_runtimes(objects, both, ["aabb-skins"],
                                      frusta_source="aabb-skins", params=params)
    for name in ("planar-frusta", "solid-frusta", "depth-buffer:aabb-skins"):
        assert runtimes[name].conservative is False and info[name]["conservative"] is False
        assert info[name]["not_guaranteed"] == ["wall"]
    closed = occluder_objects(objects, names=["closed"])
    runtimes, info = culling_runtimes(objects, closed, ["aabb-skins"],
                                      frusta_source="aabb-skins", params=params)
    assert all(rt.conservative for rt in runtimes.values())
    assert info["depth-buffer:aabb-skins"]["not_guaranteed"] == []


@pytest.mark.parametrize("scene", ["fence", pytest.param("city", marks=pytest.mark.slow),
                                   pytest.param("city-dense", marks=pytest.mark.slow)])
def test_camera_path_never_inside_an_object(scene):
    # every camera of the path (street, elevated, far): a ray from inside a closed object
    # crosses its surface an odd number of times, in every direction
    objects = _fenced_streets() if scene == "fence" else load_scene_objects(scene)
    path = camera_path(objects, frames=60 if scene == "fence" else 100)
    eyes = np.array([p.position for p in path])
    rays = np.array([[1, 0.1, 0.2], [-1, 0.3, 0.1], [0.2, 1, -0.1], [0.1, -1, 0.3],
                     [0.3, 0.2, 1], [-0.2, 0.1, -1]])
    rays /= np.linalg.norm(rays, axis=1)[:, None]
    combined, owner = objects.combined
    hits = combined.all_hits(np.repeat(eyes, len(rays), 0), np.tile(rays, (len(eyes), 1)))
    counts = np.zeros((len(eyes) * len(rays), len(objects)), dtype=np.int64)
    np.add.at(counts, (hits.ray, owner[hits.triangle]), 1)
    odd = (counts % 2 == 1).reshape(len(eyes), len(rays), -1).all(axis=1)
    assert not odd.any(), [(int(c), objects.names[o]) for c, o in np.argwhere(odd)[:5]]


def test_surface_patches_joined_over_objects_closes_the_seams():
    """Two rooms side by side, each a closed box: cut object by object without welding,
    surface-patches' roofs are eroded inside each box and leave a real gap over the shared
    wall, which the depth buffer keeps open; joined (the default of culling_runtimes) the
    two roofs are one region and one polygon, and a box under the seam is culled from
    above. Welded (the default), each roof ends on its room's edges, so the roofs cut apart
    meet over the wall too."""
    from viscore.culling.depth_buffer import ConservativeDepthBuffer, OccluderScene

    scene = trimesh.Scene()
    for k in range(2):
        scene.add_geometry(trimesh.creation.box(bounds=[[4 * k, 0, 0], [4 * k + 4, 3, 4]]),
                           geom_name=f"room{k}", node_name=f"room{k}")
    objects = load_scene_objects(scene)
    both = occluder_objects(objects, names=["room0", "room1"])
    _, info = culling_runtimes(objects, both, ["surface-patches"], frusta=False)
    entry = info["depth-buffer:surface-patches"]
    assert entry["joined"] is True and entry["occluders"] == 1 and entry["conservative"]
    _, apart = culling_runtimes(objects, both, ["surface-patches"], frusta=False, joined=())
    assert apart["depth-buffer:surface-patches"]["occluders"] == 2
    with pytest.raises(InputError, match="joined"):
        culling_runtimes(objects, both, ["surface-patches"], frusta=False, joined=["qem"])
    variant = "surface-patches:chain=greedy"  # a variant with options is joined too
    _, info = culling_runtimes(objects, both, [variant], frusta=False)
    assert info[f"depth-buffer:{variant}"]["joined"] is True
    assert info[f"depth-buffer:{variant}"]["occluders"] == 1

    cam = PerspectiveCamera((4.0, 12.0, 2.0), (0, -1, 0), up=(0, 0, 1), fov=60,
                            resolution=128, height=128)
    under_seam = ([[3.8, 1.0, 1.5]], [[4.2, 1.5, 2.5]])
    # budgets under the rooms' 12 triangles each (a budget that holds a room keeps it as
    # it is, seams and all)
    joined = joined_occluder(objects, both, "surface-patches", budget=20)
    separate = list(scene_occluders(objects, both, "surface-patches", budget=10).values())
    eroded = list(scene_occluders(objects, both, "surface-patches", budget=10,
                                  weld="off").values())
    assert not joined.info["whole_input"] and not separate[0].info["whole_input"]
    culled = [ConservativeDepthBuffer.from_occluders(OccluderScene(occ), cam, width=64,
                                                     height=64).occluded(*under_seam)[0]
              for occ in ([joined], separate, eroded)]
    assert culled == [True, True, False]


def test_scene_occluders_say_a_warning_every_mesh_gives_once(caplog):
    # three distinct open meshes: planar-sections --conservative warns for each, said once
    scene = trimesh.Scene()
    for k in range(3):
        box = trimesh.creation.box(bounds=[[4 * k, 0, 0], [4 * k + 3 + 0.1 * k, 3, 3]])
        box.update_faces(np.arange(len(box.faces)) != 0)  # one triangle gone: open
        scene.add_geometry(box, geom_name=f"shell{k}", node_name=f"shell{k}")
    objects = load_scene_objects(scene)
    picked = occluder_objects(objects, names=["shell0", "shell1", "shell2"])
    logger = logging.getLogger("viscore")
    with caplog.at_level(logging.WARNING, logger="viscore"):
        logger.setLevel(logging.WARNING)
        scene_occluders(objects, picked, "planar-sections", conservative=True, voxels=8,
                        min_precision=0)
    texts = [r.getMessage() for r in caplog.records if "closed" in r.getMessage()]
    assert len(texts) == 1 and "3 of 3 meshes" in texts[0], texts
    # a message one mesh gives names that mesh
    with caplog.at_level(logging.WARNING, logger="viscore"):
        logger.setLevel(logging.WARNING)
        scene_occluders(objects, picked[:1], "planar-sections", conservative=True, voxels=8,
                        min_precision=0)
    texts = [r.getMessage() for r in caplog.records if "closed" in r.getMessage()]
    assert texts[-1].startswith("planar-sections mesh "), texts


def _town_on_a_wide_ground(ground: float = 1000.0):
    """Truck town's layout: houses on 200 x 200 inside a ground plane ``2 ground`` across."""
    rng = np.random.default_rng(0)
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(bounds=[[-ground, -0.2, -ground],
                                                    [ground, 0, ground]]),
                       geom_name="ground", node_name="ground")
    for k in range(16):
        x, z = rng.uniform(-95, 85, 2)
        scene.add_geometry(trimesh.creation.box(bounds=[[x, 0, z], [x + 9, 6, z + 9]]),
                           geom_name=f"house{k}", node_name=f"house{k}")
    return load_scene_objects(scene)


def test_camera_path_walks_the_town_not_the_wide_ground_around_it():
    """An outer ground 2,000 across around a town of 200: the path's street and elevated
    cameras stay over the town (they wandered the empty plane, 500 m from any house, so
    the walk saw the town as a speck), and its far cameras look at it from a ring around
    the town; a ground about as wide as the town (not over LEVEL_SPAN x) changes
    nothing."""
    from viscore.level.scene_graph import LEVEL_SPAN

    objects = _town_on_a_wide_ground()
    box, part = objects.built_bounds()
    assert part and box[0][0] > -100 and box[1][0] < 100
    path = camera_path(objects, frames=40, seed=0)
    eyes = np.array([p.position for p in path])
    near = eyes[:36]  # street and elevated
    assert (np.abs(near[:, [0, 2]]) < 110).all()
    assert (np.abs(eyes[36:, [0, 2]]).max(axis=1) < 400).all()
    seen = [view_frustum_mask(p.camera(64, 36), objects.lower[1:], objects.upper[1:]).sum()
            for p in path]
    assert np.mean(seen) > 3
    # a ground not much wider than the town: the map covers everything, as before
    small = _town_on_a_wide_ground(0.45 * LEVEL_SPAN * 130)
    assert small.built_bounds()[1] is False
    np.testing.assert_array_equal(small.built_bounds()[0], small.bounds)


def _towns_in_a_landscape(*, fine_hills: bool = False) -> trimesh.Scene:
    """Two towns 3 km apart on a lake (16 houses at the origin, 10 at x = 3000), each on
    its own ground, in a coarse bowl of hills 12 km across rising to 1,500 (a lake game's
    map): the hills are not flat, and their box holds the towns'."""
    rng = np.random.default_rng(1)
    scene = trimesh.Scene()
    for town, (cx, count) in enumerate(((0.0, 16), (3000.0, 10))):
        scene.add_geometry(trimesh.creation.box(bounds=[[cx - 110, -0.2, -110],
                                                        [cx + 110, 0, 110]]),
                           geom_name=f"ground{town}", node_name=f"ground{town}")
        for k in range(count):
            x, z = rng.uniform(-95, 85, 2)
            house = trimesh.creation.box(bounds=[[cx + x, 0, z], [cx + x + 9, 6, z + 9]])
            house = house.subdivide().subdivide()  # modelled: more triangles than a box
            scene.add_geometry(house, geom_name=f"house{town}_{k}",
                               node_name=f"house{town}_{k}")
    scene.add_geometry(trimesh.creation.box(bounds=[[-4000, -0.5, -4000], [4000, -0.3, 4000]]),
                       geom_name="lake", node_name="lake")
    xs = np.linspace(-6000, 6000, 5)
    gx, gz = np.meshgrid(xs, xs, indexing="ij")
    rim = (np.abs(gx) == 6000) | (np.abs(gz) == 6000)
    verts = np.stack([gx.ravel(), np.where(rim, 1500.0, -10.0).ravel(), gz.ravel()], axis=1)
    faces = [[i * 5 + j, i * 5 + j + 1, (i + 1) * 5 + j] for i in range(4) for j in range(4)]
    faces += [[i * 5 + j + 1, (i + 1) * 5 + j + 1, (i + 1) * 5 + j] for i in range(4)
              for j in range(4)]
    hills = trimesh.Trimesh(verts, faces)
    if fine_hills:  # the map's own mesh, holding most of its triangles
        hills = hills.subdivide().subdivide().subdivide().subdivide()
    scene.add_geometry(hills, geom_name="hills", node_name="hills")
    return scene


def test_two_towns_in_a_landscape_walk_and_size_the_larger_town(tmp_path):
    """A lake map 12 km across holding two towns of 200 m 3 km apart (a game's map seen
    on a new level: the walk stood on the lake 1-2 km from both towns, and 2% of the
    hills' 14 km diagonal left all but 13 of 307 objects without an occluder): the built
    part is the larger town, the walk stands among its houses, and its houses are sized
    against it. The hills are a landscape only while coarse: as a map's main mesh,
    holding most of the triangles, they still set the level's extent."""
    from viscore.level.objects import level_objects

    scene = _towns_in_a_landscape()
    objects = load_scene_objects(scene)
    box, part = objects.built_bounds()
    assert part
    assert -111 <= box[0][0] and box[1][0] <= 111 and -111 <= box[0][2] and box[1][2] <= 111
    walk = camera_walk(objects, frames=20, seed=0)
    eyes = np.array([c.position for c in walk.cameras])
    assert len(eyes) >= 17 and (np.abs(eyes[:, [0, 2]]) < 111).all()
    assert walk.floors and all(s.standing for s in walk.stances)
    level_file = tmp_path / "lake.glb"
    scene.export(level_file)
    level = level_objects(level_file)
    houses = [i for i, n in enumerate(level.objects.names) if n.startswith("house")]
    assert set(houses) <= set(level.chosen.tolist())
    # hills holding most of the triangles are the level's own mesh, not a landscape
    mesh = load_scene_objects(_towns_in_a_landscape(fine_hills=True))
    hills = mesh.names.index("hills")
    assert mesh.triangles[hills] > 0.5 * mesh.triangles.sum()
    box, part = mesh.built_bounds()
    assert not part and box[1][0] == 6000
    # nor is a coarse hall's shell (12 triangles) over detailed machines in its middle
    hall = trimesh.Scene()
    hall.add_geometry(trimesh.creation.box(bounds=[[-50, 0, -50], [50, 10, 50]]),
                      geom_name="shell", node_name="shell")
    for k in range(8):
        x, z = 8.0 * (k % 4) - 12, 8.0 * (k // 4) - 4
        machine = trimesh.creation.box(bounds=[[x, 0, z], [x + 4, 3, z + 4]])
        hall.add_geometry(machine.subdivide().subdivide(), geom_name=f"machine{k}",
                          node_name=f"machine{k}")
    inside = load_scene_objects(hall)
    assert inside.triangles[inside.names.index("shell")] < 0.25 * inside.triangles.sum()
    box, part = inside.built_bounds()
    assert not part and box[1][0] == 50


def test_a_scatter_of_props_keeps_the_whole_map():
    """Rocks strewn 100 apart over an open map 1 km across, three of them in one clump:
    the clump is the district of most objects but holds a fraction of the triangles, so
    the map is not cut down to it."""
    rng = np.random.default_rng(3)
    scene = trimesh.Scene()
    spots = [(x, z) for x in range(0, 1000, 100) for z in range(0, 1000, 100)]
    spots += [(503.0, 503.0), (506.0, 506.0)]  # a clump with the rock at (500, 500)
    for k, (x, z) in enumerate(spots):
        h = rng.uniform(2, 4)
        scene.add_geometry(trimesh.creation.box(bounds=[[x, 0, z], [x + 2, h, z + 2]]),
                           geom_name=f"rock{k}", node_name=f"rock{k}")
    objects = load_scene_objects(scene)
    box, part = objects.built_bounds()
    assert not part and box[1][0] == 902
    np.testing.assert_array_equal(box, objects.bounds)


def test_a_sky_dome_neither_sets_the_level_nor_gets_occluders(tmp_path):
    """A half-sphere sky 4 km across around a town of 200 m (Godot and three.js scenes
    ship one): the sky is found, the houses are sized against the town (all of them got
    refused as under 2% of the sky's diagonal), the path's street and elevated cameras stay
    under 3 house heights (they rose toward the dome), and the sky gets no occluder. A big terrain
    under the town, whose vertices reach the houses, is no sky."""
    from viscore.culling.occludee_bounds import object_cluster_boxes
    from viscore.level.objects import level_objects

    town = _town_on_a_wide_ground(100.0)
    scene = trimesh.Scene()
    for i, name in enumerate(town.names):
        scene.add_geometry(town.object_mesh(i), geom_name=name, node_name=name)
    dome = trimesh.creation.icosphere(subdivisions=3, radius=2000.0)
    dome = dome.slice_plane([0, -1, 0], [0, 1, 0])  # the upper half, open below
    scene.add_geometry(dome, geom_name="sky", node_name="sky")
    level_file = tmp_path / "town-sky.glb"
    scene.export(level_file)
    level = level_objects(level_file)
    objects = level.objects
    sky = objects.names.index("sky")
    assert np.flatnonzero(objects.sky()).tolist() == [sky]
    assert "sky" in level.refused["sky"]
    houses = [i for i, n in enumerate(objects.names) if n.startswith("house")]
    assert set(houses) <= set(level.chosen.tolist())
    box, part = objects.built_bounds()
    assert part and box[1][1] <= 6 + 1e-9 and box[1][0] < 150
    eyes = np.array([p.position for p in camera_path(objects, frames=20, seed=0)])
    assert eyes[:18, 1].max() < 18 and eyes[:, 1].max() < 100  # street, elevated; far
    # --bounds auto sizes objects against the town too: a house is 7% of it (0.4% of the sky)
    owner = object_cluster_boxes(objects, 8, min_size=0.05)[2]
    assert (np.bincount(owner, minlength=len(objects))[houses] > 1).all()
    # no sky: a hill whose vertices come down to the houses
    hill = trimesh.creation.icosphere(subdivisions=3, radius=2000.0)
    hill.apply_translation([0, -2000.0, 0])
    scene.delete_geometry("sky")
    scene.add_geometry(hill, geom_name="hill", node_name="hill")
    assert not load_scene_objects(scene).sky().any()
    # nor is a mountain far off to one side, though none of it comes near the town
    scene.delete_geometry("hill")
    scene.add_geometry(trimesh.creation.icosphere(subdivisions=2, radius=800.0),
                       geom_name="far", node_name="far",
                       transform=trimesh.transformations.translation_matrix([3000, 0, 0]))
    assert not load_scene_objects(scene).sky().any()


def test_height_field_methods_get_the_flat_objects_only():
    """culling_runtimes(flat=...): terrain-drape (inputs 'height-fields') makes occluders
    for the flat objects among the occluder objects, the others' methods for all."""
    from viscore.cli.bench.table1 import height_field_sheet

    x, y = np.meshgrid(np.linspace(0, 1, 24), np.linspace(0, 1, 24), indexing="ij")
    sheet = height_field_sheet(3 * np.sin(3 * x) * np.cos(2 * y) + 3, 100.0, 100.0)
    sheet.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
    scene = trimesh.Scene()
    scene.add_geometry(sheet, geom_name="hill", node_name="hill")
    for k in range(2):
        scene.add_geometry(trimesh.creation.box(bounds=[[10 + 40 * k, 5, -30],
                                                        [20 + 40 * k, 15, -20]]),
                           geom_name=f"house{k}", node_name=f"house{k}")
    objects = load_scene_objects(scene)
    flat = objects.flat()
    assert flat.tolist() == [True, False, False]  # hill, house0, house1
    everyone = np.arange(3)
    _, info = culling_runtimes(objects, everyone, ["terrain-drape", "bbox"], frusta=False,
                               flat=flat, joined=())
    assert info["depth-buffer:terrain-drape"]["occluders"] == 1
    assert info["depth-buffer:bbox"]["occluders"] == 3  # every object
    _, info = culling_runtimes(objects, everyone[1:], ["terrain-drape"], frusta=False,
                               flat=flat)
    assert info["depth-buffer:terrain-drape"]["occluders"] == 0
    with pytest.raises(InputError, match="one flag per object"):
        culling_runtimes(objects, everyone, ["terrain-drape"], frusta=False, flat=[True])


def test_the_mesh_itself_is_a_guaranteed_occluder_on_an_open_mesh():
    """'original' claims the guarantee on any input: an open, single-sided sheet is its own
    conservative occluder (0 violating rays), and its depth-buffer runtime is
    conservative, where the registry's flag alone promises closed meshes only."""
    from viscore.cli.bench.table1 import height_field_sheet
    from viscore.metrics.conservativeness import assert_conservative

    x, y = np.meshgrid(np.linspace(0, 1, 16), np.linspace(0, 1, 16), indexing="ij")
    sheet = height_field_sheet(2 * np.sin(4 * x) * np.cos(3 * y), 50.0, 50.0)
    occ = generate("original", sheet)
    assert occ.info["conservative_guaranteed"] is True
    assert not sheet.is_watertight
    assert_conservative(sheet, occ.mesh, rays=20_000, domain="volume", seed=1)
    scene = trimesh.Scene()
    scene.add_geometry(sheet, geom_name="sheet", node_name="sheet")
    objects = load_scene_objects(scene)
    runtimes, info = culling_runtimes(objects, [0], ["original"], frusta=False)
    assert runtimes["depth-buffer:original"].conservative
    assert info["depth-buffer:original"]["not_guaranteed"] == []


def test_culling_runtimes_generate_each_distinct_mesh_once(monkeypatch, caplog):
    """The probe for a hierarchy (on the first mesh) is the first mesh's occluder: a level
    of three distinct meshes is generated three times, not four, and the first mesh's
    warning is said with the others', once."""
    from viscore.generators import registry

    calls = []

    def counted(mesh, *, budget=None, seed=0):
        calls.append(len(mesh.faces))
        logging.getLogger("viscore.generators.test").warning("%s: open", mesh.metadata["name"])
        return generate("bbox", mesh)

    spec = registry.GeneratorSpec("test-counted", counted, "test", budgeted=False)
    monkeypatch.setitem(registry.REGISTRY, "test-counted", spec)
    scene = trimesh.Scene()
    for k in range(3):
        scene.add_geometry(trimesh.creation.box(bounds=[[3 * k, 0, 0], [3 * k + 1 + k, 2, 1]]),
                           geom_name=f"block{k}", node_name=f"block{k}")
    objects = load_scene_objects(scene)
    with caplog.at_level(logging.WARNING, logger="viscore"):
        _, info = culling_runtimes(objects, [0, 1, 2], ["test-counted"], frusta=False)
    assert len(calls) == 3 and info["depth-buffer:test-counted"]["occluders"] == 3
    said = [r.getMessage() for r in caplog.records if "open" in r.getMessage()]
    assert said == ["test-counted: 3 of 3 meshes: each of them: open"]


def _two_rooms():
    """Two rooms 10 x 3 x 8 side by side along x (y up), under one roof slab, joined by a
    door 1.5 wide in their shared wall, standing on nothing; a crate in each."""
    t = trimesh.transformations.translation_matrix
    scene = trimesh.Scene()

    def box(name, lo, hi):
        scene.add_geometry(trimesh.creation.box(bounds=[lo, hi]), geom_name=name, node_name=name)

    box("floor", (0, -0.2, 0), (20, 0, 8))
    box("roof", (0, 3, 0), (20, 3.2, 8))
    box("west", (-0.2, 0, 0), (0, 3, 8))
    box("east", (20, 0, 0), (20.2, 3, 8))
    box("south", (0, 0, -0.2), (20, 3, 0))
    box("north", (0, 0, 8), (20, 3, 8.2))
    box("middle-a", (9.9, 0, 0), (10.1, 3, 3.25))
    box("middle-b", (9.9, 0, 4.75), (10.1, 3, 8))
    box("crate-a", (3, 0, 3), (4, 1, 4))
    box("crate-b", (15, 0, 5), (16, 1, 6))
    del t
    return load_scene_objects(scene)


def test_camera_path_walks_the_floors_of_an_indoor_level():
    """A level seen from above is its roof, and its street map's free cells are the void
    around it: the street cameras stand on its floors instead, an eye height over a floor
    under the ceiling, inside the rooms, never in a wall or a crate."""
    objects = _two_rooms()
    path = camera_path(objects, frames=40, seed=0)
    street = np.array([p.position for p in path[:28]])  # 70% street level
    scene, owner = objects.combined
    down, tri_down = scene.first_hit(street, np.tile([0.0, -1.0, 0.0], (len(street), 1)))
    up_, tri_up = scene.first_hit(street, np.tile([0.0, 1.0, 0.0], (len(street), 1)))
    np.testing.assert_allclose(down, 1.7, atol=1e-9)  # on the floor, not a crate
    assert (owner[tri_down] == objects.names.index("floor")).all()
    assert (owner[tri_up] == objects.names.index("roof")).all()  # under the ceiling
    assert (street[:, 0] > 0).all() and (street[:, 0] < 20).all()
    assert (street[:, 2] > 0).all() and (street[:, 2] < 8).all()
    assert len({bool(x < 10) for x in street[:, 0]}) == 2  # both rooms, through the door
    elevated = np.array([p.position for p in path[28:36]])
    assert (elevated[:, 1] < 3.0).all()  # under the ceiling too
