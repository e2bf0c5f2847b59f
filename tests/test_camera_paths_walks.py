"""Where the walk's cameras stand: floors far above the origin, centimetres, a roof,
terrain under the elevated pass, and OBJ maps split by their o/g and usemtl groups."""

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.level import level_objects
from viscore.level.scene_graph import load_scene_objects
from viscore.metrics.camera_paths import (
    PathCamera,
    camera_stances,
    camera_walk,
    guess_eye_height,
)


def _objects(boxes: dict, scale: float = 1.0):
    scene = trimesh.Scene()
    for name, bounds in boxes.items():
        scene.add_geometry(trimesh.creation.box(bounds=np.asarray(bounds, float) * scale),
                           geom_name=name, node_name=name)
    return load_scene_objects(scene)


def _down_up(objects, eyes):
    scene, owner = objects.combined
    n = len(eyes)
    down, tri_down = scene.first_hit(eyes, np.tile([0.0, -1.0, 0.0], (n, 1)))
    up, tri_up = scene.first_hit(eyes, np.tile([0.0, 1.0, 0.0], (n, 1)))
    return down, owner[tri_down], up, owner[tri_up]


def _rooms(scale: float = 1.0, lift: float = 0.0):
    """Four rooms 10 x 3 x 10 under one roof, doors in their inner walls, a crate in each."""
    b = {"floor": [[0, -0.2, 0], [20, 0, 20]], "roof": [[0, 3, 0], [20, 3.2, 20]],
         "west": [[-0.2, 0, 0], [0, 3, 20]], "east": [[20, 0, 0], [20.2, 3, 20]],
         "south": [[0, 0, -0.2], [20, 3, 0]], "north": [[0, 0, 20], [20, 3, 20.2]],
         "mid-x-a": [[9.9, 0, 0], [10.1, 3, 4]], "mid-x-b": [[9.9, 0, 6], [10.1, 3, 20]],
         "mid-z-a": [[0, 0, 9.9], [4, 3, 10.1]], "mid-z-b": [[6, 0, 9.9], [20, 3, 10.1]]}
    for k, (x, z) in enumerate([(3, 3), (15, 3), (3, 15), (15, 15)]):
        b[f"crate{k}"] = [[x, 0, z], [x + 1, 1, z + 1]]
    for v in b.values():
        v[0][1] += lift
        v[1][1] += lift
    return _objects(b, scale)


def test_camera_walk_indoor_level_stands_under_its_roof():
    objects = _rooms()
    walk = camera_walk(objects, frames=30, seed=0)
    assert walk.floors and walk.dropped == 0 and len(walk.cameras) == 30
    eyes = np.array([c.position for c in walk.cameras])
    down, below, up, above = _down_up(objects, eyes)
    street = np.array([s.kind in ("street", "close-up") for s in walk.stances])
    np.testing.assert_allclose(down[street], 1.7, atol=1e-6)
    assert (below[street] == objects.names.index("floor")).all()
    assert (above == objects.names.index("roof")).all()  # every camera under the roof
    assert ((eyes[:, [0, 2]] > 0) & (eyes[:, [0, 2]] < 20)).all()
    assert all(s.standing for s in walk.stances)
    assert all(s.back_faces < 0.3 for s in walk.stances)


def test_camera_walk_floors_far_above_the_origin():
    # the level's floors at y 500 on nothing (a platform over a void): the cameras stand
    # an eye height over them, never at 1.7 over the origin
    objects = _rooms(lift=500.0)
    walk = camera_walk(objects, frames=20, seed=1)
    eyes = np.array([c.position for c in walk.cameras])
    down, below, _, _ = _down_up(objects, eyes)
    assert len(eyes) == 20 and (eyes[:, 1] > 500).all() and (eyes[:, 1] < 503).all()
    assert (below == objects.names.index("floor")).all() and (down <= 3 * 1.7).all()


def test_camera_walk_level_in_centimetres():
    # the same rooms in centimetres (a glTF whose author kept cm): the rooms say the eye
    # is about 0.35 x 300 = 105, thirty times the metre default, and the walk stands there
    objects = _rooms(scale=100.0)
    eye = guess_eye_height(objects, metres=True)
    assert eye.value == pytest.approx(0.35 * 300.0, rel=0.05)
    walk = camera_walk(objects, frames=20, seed=0, eye=eye)
    eyes = np.array([c.position for c in walk.cameras])
    down, below, up, above = _down_up(objects, eyes)
    street = np.array([s.kind in ("street", "close-up") for s in walk.stances])
    np.testing.assert_allclose(down[street], eye.value, rtol=1e-6)
    assert (above == objects.names.index("roof")).all() and walk.to_json()["standing"] == 20
    # and the same in metres keeps 1.7 (a glTF's unit), whatever the low rooms say
    assert guess_eye_height(_rooms(), metres=True).value == 1.7


def test_eye_height_leaves_out_cavities_between_layers():
    """A deck 0.125 thick on legs 0.375 over half of the rooms' floor (a Sauerbraten map's
    4-unit gaps under its platforms, a fifth of its floors under a ceiling, put the eye
    at 1.4 where the game's is 14): the lower quartile of the headrooms is the gap under
    the deck, which no one stands in; without it, the rooms over the deck (2.5) set the
    eye, not the gap (0.375)."""
    rooms = _rooms()
    boxes = {n: [rooms.lower[i], rooms.upper[i]] for i, n in enumerate(rooms.names)}
    boxes["deck"] = [[0.0, 0.375, 0.0], [9.9, 0.5, 20.0]]
    objects = _objects(boxes)
    eye = guess_eye_height(objects)
    assert eye.sign == 1.0
    assert eye.value == pytest.approx(0.35 * 2.5, rel=0.02)
    assert "cavities" in eye.reason
    # the rooms alone: their lower quartile is the crates' tops and the floor (2-3)
    assert guess_eye_height(rooms).value >= 0.35 * 2.0


def test_camera_walk_open_blockout_in_small_units():
    # the rooms without their roof, a twentieth of the size (a blockout of closed boxes,
    # 0.16 high): no floor has a ceiling, and turned over the floor slab's inside reads
    # as a room 0.01 high; the faces stay as wound, the eye is a twentieth of the level's
    # height (it is lower than a person), and every camera stands that high over the floor
    scale = 0.05
    rooms = _rooms(scale=scale)
    keep = [i for i, n in enumerate(rooms.names) if n != "roof"]
    boxes = {rooms.names[i]: [rooms.lower[i] / scale, rooms.upper[i] / scale] for i in keep}
    objects = _objects(boxes, scale)
    eye = guess_eye_height(objects)
    assert eye.sign == 1.0
    assert eye.value == pytest.approx(3.2 * scale / 20, rel=1e-6)
    walk = camera_walk(objects, frames=20, seed=0, eye=eye)
    assert walk.floors and len(walk.cameras) == 20
    eyes = np.array([c.position for c in walk.cameras])
    down, below, _, _ = _down_up(objects, eyes)
    street = np.array([s.kind in ("street", "close-up") for s in walk.stances])
    np.testing.assert_allclose(down[street], eye.value, rtol=1e-5)  # Embree's float32
    assert (below == objects.names.index("floor")).all()
    assert all(s.standing for s in walk.stances)


def _quad(x0, z0, x1, z1, y):
    """One upward-facing rectangle at height y (a single-sided platform top)."""
    v = np.array([[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]], float)
    return trimesh.Trimesh(v, [[0, 2, 1], [0, 3, 2]], process=False)


def test_camera_walk_open_level_of_single_sided_platforms():
    # a small open level of platform tops only (a navigation demo's level): the undersides
    # of the platforms over the eye are back faces, yet no wall; a camera on the edge
    # looks out at nothing. The walk keeps at least 85% of the frames asked, each on a
    # platform, an eye height over it where it walks
    parts = {"ground": _quad(0, 0, 10, 8, 0.0), "low": _quad(1, 1, 4, 4, 2.5),
             "high": _quad(5, 2, 9, 6, 4.0), "step": _quad(2, 5, 4, 7, 1.0)}
    scene = trimesh.Scene()
    for name, mesh in parts.items():
        scene.add_geometry(mesh, geom_name=name, node_name=name)
    objects = load_scene_objects(scene)
    walk = camera_walk(objects, frames=20, seed=0, eye_height=1.7)
    assert len(walk.cameras) >= 17 and walk.dropped == 20 - len(walk.cameras)
    assert all(s.standing for s in walk.stances)
    eyes = np.array([c.position for c in walk.cameras])
    down, below, _, _ = _down_up(objects, eyes)
    assert (below >= 0).all() and (down <= 3 * 1.7 + 1e-6).all()
    street = np.array([s.kind in ("street", "close-up") for s in walk.stances])
    np.testing.assert_allclose(down[street], 1.7, rtol=1e-5)
    # the check itself: under the high platform, looking at its underside, it stands;
    # looking at nothing (off the level's edge, level), it does not
    under = PathCamera(np.array([8.8, 1.7, 4.0]), np.array([-1.0, 0.3, 0.0]),
                       np.array([0.0, 1.0, 0.0]))
    out = PathCamera(np.array([9.5, 1.7, 4.0]), np.array([1.0, 0.0, 0.0]),
                     np.array([0.0, 1.0, 0.0]))
    st_under, st_out = camera_stances(objects, [under, out], eye_height=1.7)
    assert st_under.standing and st_under.back_faces < 0.3
    assert not st_out.standing and st_out.in_view < 0.05


def test_camera_walk_elevated_pass_over_terrain():
    # a ridge 12 high across open ground: the elevated cameras rise at most 2 eye heights
    # over the floor under them, never into the ridge, and the ridge is under each eye
    ground = trimesh.creation.box(bounds=[[-50, -1, -50], [50, 0, 50]])
    ridge = trimesh.creation.box(bounds=[[-50, 0, -3], [50, 12, 3]])
    ridge.vertices[ridge.vertices[:, 1] > 1, 2] *= 0.1  # a steep-sided wedge
    hill = trimesh.creation.box(bounds=[[10, 0, 10], [30, 4, 30]])
    scene = trimesh.Scene()
    for name, mesh in (("ground", ground), ("ridge", ridge), ("hill", hill)):
        scene.add_geometry(mesh, geom_name=name, node_name=name)
    objects = load_scene_objects(scene)
    walk = camera_walk(objects, frames=40, seed=2)
    eyes = np.array([c.position for c in walk.cameras])
    high = np.array([s.kind == "elevated" for s in walk.stances])
    assert high.sum() >= 6
    down, _, _, _ = _down_up(objects, eyes)
    assert (down[high] <= 3 * 1.7 + 1e-6).all() and (down[high] >= 1.7 - 1e-6).all()
    # inside no object: a ray from inside a closed box crosses it an odd number of times
    scene_, owner = objects.combined
    hits = scene_.all_hits(eyes, np.tile([0.3, 1.0, 0.2], (len(eyes), 1)))
    counts = np.zeros((len(eyes), len(objects)), np.int64)
    np.add.at(counts, (hits.ray, owner[hits.triangle]), 1)
    assert not (counts % 2).any()


def test_camera_stances_flags_a_camera_behind_a_wall_and_one_on_nothing():
    objects = _rooms()
    up = np.array([0.0, 1.0, 0.0])
    cams = [PathCamera(np.array([5.0, 1.7, 5.0]), np.array([1.0, 0, 0]), up),   # in a room
            PathCamera(np.array([3.5, 0.5, 3.5]), np.array([1.0, 0, 0]), up),   # in a crate
            PathCamera(np.array([-5.0, 1.7, 5.0]), np.array([1.0, 0, 0]), up),  # outside
            PathCamera(np.array([5.0, 40.0, 5.0]), np.array([1.0, 0, 0]), up)]  # high above
    inside, crate, outside, above = camera_stances(objects, cams, eye_height=1.7)
    assert inside.standing and inside.height == pytest.approx(1.7)
    assert inside.back_faces == 0.0 and inside.in_view == 1.0
    assert not crate.standing and crate.back_faces == 1.0  # the inside of a closed box
    assert not outside.standing and not outside.floor  # nothing under it
    assert not above.standing and above.height > 3 * 1.7
    with pytest.raises(InputError, match="eye_height"):
        camera_stances(objects, cams, eye_height=0.0)
    with pytest.raises(InputError, match="kinds"):
        camera_stances(objects, cams, eye_height=1.7, kinds=["given"])


def _tiles_obj(path, key: str) -> None:
    """A floor strip 40 x 8 of five tiles 8 x 8 sharing their edges (one connected mesh),
    each tile under its own ``key`` statement (``o`` or ``usemtl``)."""
    lines = [f"v {8 * i} 0 {z}" for i in range(6) for z in (0, 8)]
    for i in range(5):  # vertices 2i+1, 2i+2 at x = 8i; 2i+3, 2i+4 at x = 8i + 8
        lines.append(f"{key} tile{i}")
        lines.append(f"f {2 * i + 1} {2 * i + 2} {2 * i + 4} {2 * i + 3}")
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("key,rule", [("o", "groups"), ("usemtl", "materials")])
def test_level_objects_obj_groups_and_where_the_walk_stands(tmp_path, key, rule):
    path = tmp_path / f"tiles-{key}.obj"
    _tiles_obj(path, key)
    level = level_objects(path, up="y")
    assert level.components == 1 and level.split_rule == rule
    objects = level.objects
    assert sorted(objects.names) == [f"tile{i}" for i in range(5)]
    for name, lo, hi in zip(objects.names, objects.lower, objects.upper, strict=True):
        k = int(name[-1])
        np.testing.assert_allclose([lo[0], hi[0], lo[2], hi[2]], [8 * k, 8 * k + 8, 0, 8])
    walk = camera_walk(objects, frames=10, seed=0, eye_height=1.7, metres=False)
    eyes = np.array([c.position for c in walk.cameras])
    assert len(eyes) == 10 and walk.eye.value == 1.7
    np.testing.assert_allclose(eyes[:, 1][[s.kind != "elevated" for s in walk.stances]], 1.7)
    assert ((eyes[:, 0] > 0) & (eyes[:, 0] < 40) & (eyes[:, 2] > 0) & (eyes[:, 2] < 8)).all()
    assert all(s.standing for s in walk.stances)


def test_level_objects_obj_without_groups_keeps_connected_parts(tmp_path):
    path = tmp_path / "tiles.obj"
    _tiles_obj(path, "#")
    level = level_objects(path, up="y")
    assert level.components == 1
    assert level.split_rule == "parts" and len(level.objects) == 1


def test_surface_patches_writes_no_zero_area_triangle():
    # a room whose walls' edges are split into many collinear points (as a map's brushes
    # meet): the triangulated patches had triangles of three collinear corners
    from viscore.generators import generate

    room = trimesh.creation.box(bounds=[[0, 0, 0], [12, 4, 8]]).subdivide().subdivide()
    occ = generate("surface-patches", room, budget=400, seed=0)
    corner = np.asarray(occ.mesh.vertices)[np.asarray(occ.mesh.faces)]
    area = np.linalg.norm(np.cross(corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0]),
                          axis=1)
    assert len(area) and area.min() > 1e-9


def _sheet_obj(path, nx: int, nz: int, size: float) -> None:
    """A wavy sheet of ``nx`` x ``nz`` quads over [0, nx*size] x [0, nz*size], y up, one
    connected mesh with no ``o``, ``g`` or ``usemtl`` statement."""
    lines = [f"v {i * size} {np.sin(i) + np.cos(k)} {k * size}"
             for i in range(nx + 1) for k in range(nz + 1)]
    for i in range(nx):
        for k in range(nz):
            a = i * (nz + 1) + k + 1
            lines.append(f"f {a} {a + 1} {a + nz + 2} {a + nz + 1}")
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("nx,nz,tiles", [(20, 20, 16), (40, 10, 4)])
def test_level_objects_one_welded_sheet_is_cut_into_ground_tiles(tmp_path, nx, nz, tiles):
    # one connected part and no groups: a grid of TILE_GRID cells along the longer side
    from viscore.level.objects import TILE_GRID

    path = tmp_path / "sheet.obj"
    _sheet_obj(path, nx, nz, 2.0)
    level = level_objects(path, up="y")
    objects = level.objects
    assert level.components == 1 and level.split_rule == "tiles"
    assert len(objects) == tiles and objects.triangles.sum() == 2 * nx * nz
    side = 2.0 * max(nx, nz) / TILE_GRID  # 10 (square) or 20 (strip)
    cells = set()
    for lo, hi in zip(objects.lower, objects.upper, strict=True):
        # a tile holds the faces whose centroids lie in its cell: its box pokes out of
        # the cell by less than one quad (2 units) on each side
        cell = np.floor((lo[[0, 2]] + hi[[0, 2]]) / 2 / side).astype(int)
        assert (lo[[0, 2]] >= cell * side - 2.0 - 1e-9).all()
        assert (hi[[0, 2]] <= (cell + 1) * side + 2.0 + 1e-9).all()
        cells.add(tuple(cell))
    assert len(cells) == tiles


def test_level_objects_one_tall_part_is_not_tiled(tmp_path):
    # a scan or a building (taller than half its width) stays one object
    path = tmp_path / "tower.obj"
    trimesh.creation.box(bounds=[[0, 0, 0], [10, 6, 10]]).subdivide().subdivide().export(path)
    level = level_objects(path, up="y")
    assert level.split_rule == "parts" and len(level.objects) == 1
