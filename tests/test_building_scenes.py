"""The game-style building scenes made by data/make_scenes.py.

Each building is checked on the shipped file (loaded by name) against the construction
data its generator records in ``mesh.metadata`` (doors, rooms, wall thickness, open
bottom); the generators are re-run to check that the files regenerate identically.
"""

import importlib.util

import numpy as np
import pytest
import trimesh
from scipy import ndimage

from viscore import InputError, Scene, directions_fibonacci, load_mesh, points_inside, scene_names
from viscore.builtin_scenes import scene_group, scene_path

BUILDINGS = scene_group("buildings")


@pytest.fixture(scope="module")
def make_scenes():
    """data/make_scenes.py as a module (in a wheel it sits beside the scene files)."""
    path = scene_path(BUILDINGS[0]).parent / "make_scenes.py"
    spec = importlib.util.spec_from_file_location("_make_scenes_under_test", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def shipped():
    """Scene name -> (mesh loaded by name, its Embree scene)."""
    out = {}
    for name in BUILDINGS:
        mesh = load_mesh(name)
        out[name] = (mesh, Scene(mesh))
    return out


def _parts(mesh):
    """Per connected part (shared vertices): face count, closed flag, sorted extents, box."""
    labels = trimesh.graph.connected_component_labels(mesh.face_adjacency,
                                                      node_count=len(mesh.faces))
    n = labels.max() + 1
    faces = np.bincount(labels, minlength=n)
    # closed: every edge of the part is shared by exactly two of its faces
    edges = np.column_stack([np.repeat(labels, 3), np.sort(mesh.edges, axis=1)])
    _, inverse, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
    open_edge = counts[inverse.ravel()] != 2
    closed = np.bincount(np.repeat(labels, 3)[open_edge], minlength=n) == 0
    lo = np.full((n, 3), np.inf)
    hi = np.full((n, 3), -np.inf)
    corners = mesh.vertices[mesh.faces]
    np.minimum.at(lo, labels, corners.min(axis=1))
    np.maximum.at(hi, labels, corners.max(axis=1))
    return faces, closed, np.sort(hi - lo, axis=1), (lo, hi)


@pytest.fixture(scope="module")
def built(make_scenes):
    """Scene name -> freshly generated mesh (with its construction metadata)."""
    return {name: make() for name, (_, make) in make_scenes.BUILDINGS.items()}


def test_scene_group_buildings(make_scenes):
    assert len(BUILDINGS) >= 6 and len(set(BUILDINGS)) == len(BUILDINGS)
    assert all(name.startswith("building-") for name in BUILDINGS)
    assert set(BUILDINGS) <= set(scene_names()) and "buildings" not in scene_names()
    assert list(make_scenes.BUILDINGS) == BUILDINGS
    assert set(BUILDINGS) < set(scene_group("procedural"))
    assert set(scene_group("samples")).isdisjoint(scene_group("procedural"))
    with pytest.raises(InputError, match="group"):
        scene_group("houses")


def test_buildings_regenerate_identically(make_scenes, built, tmp_path):
    files = {file for file, _ in make_scenes.BUILDINGS.values()}
    written = make_scenes.write_scenes(tmp_path, files)
    assert set(written) == files
    for name, (file, make) in make_scenes.BUILDINGS.items():
        shipped = trimesh.load(scene_path(name), process=False)
        fresh = trimesh.load(tmp_path / file, process=False)
        np.testing.assert_array_equal(fresh.vertices, shipped.vertices)
        np.testing.assert_array_equal(fresh.faces, shipped.faces)
        np.testing.assert_array_equal(built[name].faces, shipped.faces)
        other = make(seed=99)  # the seed changes the details
        assert len(other.faces) != len(shipped.faces) or not np.allclose(
            other.vertices, built[name].vertices)


@pytest.mark.parametrize("name", BUILDINGS)
def test_building_counts_and_loose_panels(name, built, shipped):
    mesh = shipped[name][0]
    assert 500 <= len(mesh.faces) <= 20_000
    faces, closed, _, (lo, hi) = _parts(mesh)
    assert len(faces) >= 30  # loose panels, none welded to another
    if built[name].metadata["split_faces"]:  # each side its own vertices: weld them
        assert not closed.any()
        mesh = mesh.copy()
        mesh.merge_vertices()
        faces, closed, _, (lo, hi) = _parts(mesh)
    assert closed.sum() >= 0.6 * len(faces)  # most are closed boxes; the rest open boxes or sheets
    # duplicated faces: some triangle occurs twice, coincident
    _, point = np.unique(np.round(mesh.vertices, 6), axis=0, return_inverse=True)
    corners = np.sort(point.ravel()[mesh.faces], axis=1)  # the face's three positions
    assert len(np.unique(corners, axis=0)) < len(corners)
    # intersecting panels: parts whose bounding boxes overlap in volume (frames in walls,
    # walls through corners, roofs through gables)
    depth = np.minimum(hi[:, None], hi[None]) - np.maximum(lo[:, None], lo[None])
    overlap = (depth > 1e-3).all(axis=2)
    assert np.triu(overlap, 1).sum() >= 20


@pytest.mark.parametrize("name", BUILDINGS)
def test_building_wall_thickness(name, built, shipped):
    mesh = shipped[name][0]
    t = built[name].metadata["wall_thickness"]
    diag = float(np.linalg.norm(np.ptp(mesh.bounds, axis=0)))
    assert 0.005 <= t / diag <= 0.05
    # measured: from the rooms along +-x and +-y, the first panel's two faces
    rooms = np.array(built[name].metadata["rooms"], float)
    axes = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0]])
    origins = np.repeat(rooms, len(axes), axis=0)
    hits = shipped[name][1].all_hits(origins, np.tile(axes, (len(rooms), 1)))
    first = np.searchsorted(hits.ray, np.arange(len(origins)))
    two = hits.count >= 2
    measured = hits.t[first[two] + 1] - hits.t[first[two]]
    assert (np.abs(measured - t) < 2e-3).sum() >= 2, np.round(measured, 3)


@pytest.mark.parametrize("name", BUILDINGS)
def test_building_doors_lead_inside(name, built, shipped):
    doors = built[name].metadata["doors"]
    assert doors
    scene = shipped[name][1]
    centre = np.array([c for c, _, _ in doors], float)
    inward = np.array([d for _, d, _ in doors], float)
    t, _ = scene.first_hit(centre - 3.0 * inward, inward)
    # through the door (frame included) and at least a metre on into the building
    assert (t > 3.0 + 1.0).all(), t - 3.0


@pytest.mark.parametrize("name", BUILDINGS)
def test_building_rooms_enclosed_and_clear(name, built, shipped):
    meta = built[name].metadata
    rooms = np.array(meta["rooms"], float)
    assert len(rooms) >= 2  # more than one room or floor
    scene = shipped[name][1]
    assert not points_inside(scene, rooms).any()  # clear of every panel
    dirs = directions_fibonacci(400)
    for room in rooms:
        t, _ = scene.first_hit(np.repeat(room[None], len(dirs), 0), dirs)
        assert t.min() > 0.15  # standing room
        up = dirs[:, 2] > 0
        assert np.isfinite(t[up]).mean() >= 0.6  # enclosed: walls and ceiling, some openings
        if not meta["open_bottom"]:
            assert np.isfinite(t).mean() >= 0.8


@pytest.mark.parametrize("name", BUILDINGS)
def test_building_ground_rooms_reachable_through_doors(name, built, shipped):
    # a horizontal slice below every window sill: the free space is one region with the
    # outside, so every room on the ground is reached through a door
    mesh, scene = shipped[name]
    meta = built[name].metadata
    step, z = 0.1, 0.3  # finer than the thinnest wall (0.12)
    lo, hi = mesh.bounds[0, :2] - 1.0, mesh.bounds[1, :2] + 1.0
    xs, ys = np.arange(lo[0], hi[0], step), np.arange(lo[1], hi[1], step)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    pts = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, z)])
    free = ~points_inside(scene, pts).reshape(gx.shape)
    labels, _ = ndimage.label(free)
    outside = labels[0, 0]
    ground = [r for r in meta["rooms"] if r[2] < 2.0]
    assert ground
    for x, y, _ in ground:
        assert labels[int(round((x - lo[0]) / step)), int(round((y - lo[1]) / step))] == outside
    # and no way in without the doors: fill the door openings and the rooms are cut off
    blocked = free.copy()
    for (cx, cy, _), (_, dy, _), width in meta["doors"]:
        across = abs(dy) > 0.5  # a door in a wall along x
        near = (np.abs(gy - cy) < 0.6) if across else (np.abs(gx - cx) < 0.6)
        half = 0.5 * width + 0.3  # the frame too
        wide = (np.abs(gx - cx) < half) if across else (np.abs(gy - cy) < half)
        blocked[near & wide] = False
    labels, _ = ndimage.label(blocked)
    x, y, _ = ground[0]
    assert labels[int(round((x - lo[0]) / step)), int(round((y - lo[1]) / step))] != labels[0, 0]


def test_buildings_open_and_closed_bottoms(built, shipped):
    open_ = [n for n in BUILDINGS if built[n].metadata["open_bottom"]]
    assert 1 <= len(open_) < len(BUILDINGS)
    for name in BUILDINGS:
        mesh, scene = shipped[name]
        rooms = np.array([r for r in built[name].metadata["rooms"] if r[2] < 2.0])
        below = rooms.copy()
        below[:, 2] = -1.0
        t, _ = scene.first_hit(below, np.tile([0.0, 0.0, 1.0], (len(rooms), 1)))
        low = (mesh.vertices[mesh.faces][:, :, 2] <= 1e-6).all(axis=1)
        if name in open_:
            # nothing on or under the ground: from below, the first hit is above the floor
            assert mesh.bounds[0, 2] >= 0.0 and not low.any()
            assert (t > 1.0 + 1.0).all()
        else:  # a floor slab under the rooms
            assert mesh.bounds[0, 2] < 0.0 and (t < 1.0 + 1e-3).all()


def test_building_frames_cover_slots(make_scenes):
    # a framed window: the panels stop short of the frame's inside, so removing the frame
    # opens a slot through the wall; an unframed one is cut to size
    b = make_scenes._Builder()
    panels = b.wall("x", 0.0, -2.0, 2.0, 0.0, 3.0, 0.2, [(-0.5, 0.5, 1.0, 2.0, True)])
    whole = b.mesh(wall_thickness=0.2, open_bottom=False)
    b.parts = [b.parts[i] for i in panels]
    bare = b.mesh(wall_thickness=0.2, open_bottom=False)
    assert len(whole.faces) > len(bare.faces)
    origin = np.array([[-0.525, -1.0, 1.5], [0.0, -1.0, 1.5], [-0.8, -1.0, 1.5]])
    ray = np.tile([0.0, 1.0, 0.0], (3, 1))
    t_whole, _ = Scene(whole).first_hit(origin, ray)
    t_bare, _ = Scene(bare).first_hit(origin, ray)
    assert np.isfinite(t_whole[0]) and np.isinf(t_bare[0])  # the slot, under the frame
    assert np.isinf(t_whole[1]) and np.isinf(t_bare[1])  # the window itself
    assert np.isfinite(t_whole[2]) and np.isfinite(t_bare[2])  # the wall
    assert len(whole.split(only_watertight=False)) == len(whole.faces) // 12


@pytest.mark.parametrize("name", BUILDINGS)
def test_building_recesses_and_plaques_sit_in_their_walls(name, built, shipped, make_scenes):
    # from 0.5 m outside, at a recess's centre the first hit is its back face, RECESS_DEPTH
    # of the wall behind the outer face; at a plaque's, its face PLAQUE_PROUD in front
    openings = built[name].metadata["openings"]
    backed = [o for o in openings if o["kind"] != "through"]
    assert len(backed) >= 2 and {o["kind"] for o in openings} >= {"through", "recess"}
    centre = np.array([o["centre"] for o in backed])
    normal = np.array([o["normal"] for o in backed])
    t_wall = np.array([o["thickness"] for o in backed])
    start = centre + (0.5 * t_wall + 0.5)[:, None] * normal
    t, _ = shipped[name][1].first_hit(start, -normal)
    recess = np.array([o["kind"] == "recess" for o in backed])
    expected = np.where(recess, 0.5 + make_scenes.RECESS_DEPTH * t_wall,
                        0.5 - make_scenes.PLAQUE_PROUD)
    np.testing.assert_allclose(t, expected, atol=1e-5)
