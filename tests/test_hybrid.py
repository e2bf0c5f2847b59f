"""Tests of the hybrid occluder generator (Wu et al. 2022, sec. 3.1 and its combination)."""

import math

import numpy as np
import pytest
import shapely
import trimesh

from viscore import InputError, Scene
from viscore.builtin_scenes import scene_group, scene_path
from viscore.generators._polygons import triangulate_polygon
from viscore.generators.hybrid import generate_hybrid
from viscore.generators.hybrid._enforce import (
    SignedDistanceGrid,
    enforce_conservative,
    enforcement_energy,
)
from viscore.generators.hybrid._holes import SEGMENT_LENGTH, holes_to_fill, judge_holes
from viscore.generators.hybrid._patches import (
    clean_soup,
    curved_patch_labels,
    patch_candidates,
    planar_patch_labels,
    xatlas_patch_labels,
)
from viscore.generators.hybrid._voxel import grid_shape, simplify_isosurface, winding_isosurface


# ---------------------------------------------------------------------------- helpers
def _sheet(polygon, z: float, *, flip: bool = False) -> trimesh.Trimesh:
    """A planar polygon (shapely, with holes) at height z, triangulated."""
    v2, t = triangulate_polygon(polygon)
    v3 = np.column_stack([v2, np.full(len(v2), z)])
    return trimesh.Trimesh(v3, t[:, ::-1] if flip else t, process=False)


def _rotate_to(mesh: trimesh.Trimesh, matrix) -> trimesh.Trimesh:
    out = mesh.copy()
    out.apply_transform(matrix)
    return out


def _slab_with_pocket(depth: float) -> trimesh.Trimesh:
    """A closed 2 x 2 x 0.2 slab whose top face has a 0.2 x 0.2 pocket ``depth`` deep."""
    outer = shapely.box(-1, -1, 1, 1)
    hole = shapely.box(-0.1, -0.1, 0.1, 0.1)
    top = _sheet(outer.difference(hole), 0.2)
    bottom = _sheet(outer, 0.0, flip=True)
    floor = _sheet(hole, 0.2 - depth)
    walls = trimesh.creation.box(bounds=[[-1, -1, 0], [1, 1, 0.2]])
    sides = trimesh.Trimesh(walls.vertices, walls.faces[np.abs(walls.face_normals[:, 2]) < 0.5])
    pocket = trimesh.creation.box(bounds=[[-0.1, -0.1, 0.2 - depth], [0.1, 0.1, 0.2]])
    pocket_sides = trimesh.Trimesh(pocket.vertices,
                                   pocket.faces[np.abs(pocket.face_normals[:, 2]) < 0.5][:, ::-1])
    return trimesh.util.concatenate([top, bottom, floor, sides, pocket_sides])


def _thin_room() -> trimesh.Trimesh:
    """A closed 2 x 2 x 2 room of zero-thickness walls; the +X wall has a 0.6 x 1 opening."""
    full = shapely.box(-1, -1, 1, 1)
    door = shapely.box(-0.3, -0.5, 0.3, 0.5)
    parts = [_sheet(full, -1.0, flip=True), _sheet(full, 1.0)]
    rot = trimesh.transformations.rotation_matrix
    for k, axis in enumerate([(0, 1, 0), (0, 1, 0), (1, 0, 0), (1, 0, 0)]):
        angle = [math.pi / 2, -math.pi / 2, math.pi / 2, -math.pi / 2][k]
        shape = full.difference(door) if k == 0 else full
        parts.append(_rotate_to(_sheet(shape, 1.0), rot(angle, axis)))
    return trimesh.util.concatenate(parts)


def _panel_house() -> trimesh.Trimesh:
    """A small game-style house: loose wall panels (one with a doorway), a floor slab, a roof
    slab overlapping the walls, a chimney through it, and a duplicated panel."""
    t = 0.1
    panels = [
        [[-2, -2, 0], [2, -2 + t, 2]],          # south wall
        [[-2, 2 - t, 0], [2, 2, 2]],            # north wall
        [[-2, -2, 0], [-2 + t, 2, 2]],          # west wall
        # east wall with a doorway 1 wide, 1.5 high
        [[2 - t, -2, 0], [2, -0.5, 2]],
        [[2 - t, 0.5, 0], [2, 2, 2]],
        [[2 - t, -0.5, 1.5], [2, 0.5, 2]],
        [[-2.2, -2.2, 2], [2.2, 2.2, 2 + t]],   # roof slab
        [[-2, -2, -t], [2, 2, 0]],              # floor slab
        [[0.5, 0.5, 1.2], [1.5, 1.5, 2.8]],     # a solid chimney through the roof
    ]
    boxes = [trimesh.creation.box(bounds=b) for b in panels]
    boxes.append(boxes[0].copy())  # a duplicated panel
    return trimesh.util.concatenate(boxes)


# ---------------------------------------------------------------------------- patches
def test_planar_patch_labels_box_gives_six():
    box = clean_soup(trimesh.creation.box())
    labels = planar_patch_labels(box)
    assert len(np.unique(labels)) == 6
    # the two triangles of a side share its label, and each side has its own
    normals = np.round(box.face_normals).astype(int)
    for lab in np.unique(labels):
        assert len(np.unique(normals[labels == lab], axis=0)) == 1


def test_planar_patch_labels_inconsistent_winding_groups_coplanar_faces():
    v = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    mesh = clean_soup(trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3][::-1]], process=False))
    assert len(np.unique(planar_patch_labels(mesh))) == 1


def test_curved_patch_labels_cylinder_groups_sides():
    cyl = clean_soup(trimesh.creation.cylinder(radius=1.0, height=2.0, sections=32))
    planar = planar_patch_labels(cyl)
    assert len(np.unique(planar)) == 34  # 32 side quads and two caps
    curved = curved_patch_labels(cyl, planar, eps_a=math.pi / 3)
    assert len(np.unique(curved)) == 3
    side = np.abs(cyl.face_normals[:, 2]) < 0.5
    assert len(np.unique(curved[side])) == 1
    # below the 2 pi / 32 step between side faces nothing joins
    assert len(np.unique(curved_patch_labels(cyl, planar, eps_a=0.1))) == 34


def test_xatlas_patch_labels_cover_every_face():
    cyl = clean_soup(trimesh.creation.cylinder(radius=1.0, height=2.0, sections=16))
    labels = xatlas_patch_labels(cyl, planar_patch_labels(cyl))
    assert labels.shape == (len(cyl.faces),) and labels.min() == 0
    assert 3 <= len(np.unique(labels)) < len(cyl.faces)


def test_patch_candidates_reduction_stops_past_patch_faces():
    mesh = _panel_house()
    diag = float(np.linalg.norm(mesh.extents))
    kw = dict(eps_a=math.pi / 3, grouping="dihedral", fill_holes=False,
              segment_length=SEGMENT_LENGTH * diag, seed=0)
    full = patch_candidates(mesh, Scene(mesh), patch_faces=10_000, **kw)
    small = patch_candidates(mesh, Scene(mesh), patch_faces=20, **kw)
    assert len(full.mesh.faces) == full.info["faces_before_reduction"]
    # the patch that crosses N_P (the last kept, largest first) is kept: one patch over
    last = small.face_patch == small.face_patch.max()
    assert len(small.mesh.faces) > 20 >= len(small.mesh.faces) - last.sum()
    kept_area = small.mesh.area
    assert kept_area > 0.5 * full.mesh.area  # the largest patches went first


# ---------------------------------------------------------------------------- holes
def test_hole_filling_fills_pocket_in_slab():
    slab = _slab_with_pocket(depth=0.01)
    diag = float(np.linalg.norm(slab.extents))
    assert 0.01 < SEGMENT_LENGTH * diag  # the pocket floor lies within l_s
    pc = patch_candidates(slab, Scene(slab), eps_a=math.pi / 3, grouping="dihedral",
                          patch_faces=600, fill_holes=True, segment_length=SEGMENT_LENGTH * diag,
                          seed=0)
    assert pc.info["holes_filled"] == 1 and pc.info["holes_open"] == 0
    # the top patch is the whole 2 x 2 square again
    top = pc.mesh.triangles_center[:, 2] > 0.2 - 1e-9
    assert np.isclose(pc.mesh.area_faces[top].sum(), 4.0, rtol=1e-6)


def test_hole_filling_keeps_door_of_thin_room_open():
    room = _thin_room()
    diag = float(np.linalg.norm(room.extents))
    pc = patch_candidates(room, Scene(room), eps_a=math.pi / 3, grouping="dihedral",
                          patch_faces=600, fill_holes=True, segment_length=SEGMENT_LENGTH * diag,
                          seed=0)
    assert pc.info["holes_open"] == 1 and pc.info["holes_filled"] == 0
    assert np.isclose(pc.mesh.area, 6 * 4.0 - 0.6, rtol=1e-6)


def test_holes_to_fill_decides_per_hole():
    slab = _slab_with_pocket(depth=0.01)
    frame = np.array([[0, 0, 0.2], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    holes = [shapely.box(-0.1, -0.1, 0.1, 0.1), shapely.box(1.5, 1.5, 1.7, 1.7)]
    fill = holes_to_fill(Scene(slab), holes, frame, segment_length=0.03,
                         rng=np.random.default_rng(0))
    assert fill.tolist() == [True, False]  # the second lies beside the slab: rays miss


def test_judge_holes_says_why_a_hole_stays_open():
    # a 2 x 2 slab (z 0..0.2, a pocket on top), a box far below and one far above x 2..4;
    # the holes lie in the plane z = 0.1, inside the slab where it is under them
    slab = _slab_with_pocket(depth=0.01)
    below = trimesh.creation.box(bounds=[[2, -1, -3], [4, 1, -2]])
    above = trimesh.creation.box(bounds=[[2, -1, 3], [4, 1, 4]])
    scene = Scene(trimesh.util.concatenate([slab, below, above]))
    frame = np.array([[0, 0, 0.1], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    holes = [shapely.box(-0.1, -0.1, 0.1, 0.1),  # inside the slab: filled
             shapely.box(2.5, -0.1, 2.7, 0.1),  # between the boxes: a hollow both ways
             shapely.box(5.0, -0.1, 5.2, 0.1),  # nothing either way: an opening
             shapely.box(0.7, -0.1, 1.1, 0.1)]  # three quarters over the slab
    fill, why = judge_holes(scene, holes, frame, segment_length=0.3,
                            rng=np.random.default_rng(0))
    assert fill.tolist() == [True, False, False, False]
    assert why == [None, "hollow", "opening", "partly backed"]


def _load_make_scenes():
    import importlib.util

    path = scene_path("building-house").parent / "make_scenes.py"
    spec = importlib.util.spec_from_file_location("_make_scenes_for_hybrid", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _recessed_wall(recess: float) -> trimesh.Trimesh:
    """A 4 x 3 wall 0.2 thick of seven loose panels round a blind window ``recess`` deep
    (a back box behind it) and a through-window."""
    t = 0.2
    columns = [(-2.0, -0.5, [(0.0, 3.0)]), (-0.5, 0.5, [(0.0, 1.0), (2.0, 3.0)]),
               (0.5, 1.0, [(0.0, 3.0)]), (1.0, 1.6, [(0.0, 1.0), (2.0, 3.0)]),
               (1.6, 2.0, [(0.0, 3.0)])]
    boxes = [trimesh.creation.box(bounds=[[a, 0.0, za], [b, t, zb]])
             for a, b, spans in columns for za, zb in spans]
    boxes.append(trimesh.creation.box(bounds=[[-0.5, recess, 1.0], [0.5, t, 2.0]]))
    return trimesh.util.concatenate(boxes)


def test_panelled_wall_is_one_patch_whose_recess_is_filled():
    wall = _recessed_wall(recess=0.03)
    diag = float(np.linalg.norm(wall.extents))
    assert 0.03 < SEGMENT_LENGTH * diag < 0.2  # the back face within l_s, the wall deeper
    kw = dict(eps_a=math.pi / 3, grouping="dihedral", patch_faces=600,
              segment_length=SEGMENT_LENGTH * diag, seed=0)
    scene = Scene(wall)
    pc = patch_candidates(wall, scene, fill_holes=True, **kw)
    # the window is a hole of both faces' patches; the back box closes the inner face
    assert pc.info["holes_filled"] == 1 and pc.info["holes_open"] == 2
    assert pc.info["holes_open_why"]["opening"] == 2
    occ = Scene(pc.mesh)
    ray = np.array([[0.0, 1.0, 0.0]])
    t_recess, _ = occ.first_hit(np.array([[0.0, -1.0, 1.5]]), ray)
    t_window, _ = occ.first_hit(np.array([[1.3, -1.0, 1.5]]), ray)
    assert abs(t_recess[0] - 1.0) < 1e-5  # filled in the wall's face (float32 distances)
    assert np.isinf(t_window[0])  # the through-window stays open
    # without the plane grouping the panels share no edge: many patches, no hole at all
    apart = patch_candidates(wall, scene, fill_holes=True, coplanar=False, **kw)
    assert apart.info["holes_filled"] == 0 and apart.info["holes_open"] == 0
    t_apart, _ = Scene(apart.mesh).first_hit(np.array([[0.0, -1.0, 1.5]]), ray)
    assert abs(t_apart[0] - 1.03) < 1e-5  # only the recess's back face
    unfilled = patch_candidates(wall, scene, fill_holes=False, **kw)
    assert unfilled.info["holes_filled"] == 0 and unfilled.info["holes_open_why"] == {
        "opening": 0, "hollow": 0, "partly backed": 0}


@pytest.mark.parametrize("name", scene_group("buildings"))
def test_building_recesses_filled_and_through_openings_kept(name):
    # the buildings' recesses and plaques (metadata "openings") are holes of their wall's
    # patch that the test fills; no ray through a door or window meets the candidates
    # from 1 mm before the wall to 1 mm behind it where the input lets it through (every
    # patch kept: no reduction)
    mesh = _load_make_scenes().BUILDINGS[name][1]()
    diag = float(np.linalg.norm(mesh.extents))
    scene = Scene(mesh)
    pc = patch_candidates(mesh, scene, eps_a=math.pi / 3, grouping="dihedral",
                          patch_faces=10**6, fill_holes=True,
                          segment_length=SEGMENT_LENGTH * diag, seed=0)
    openings = mesh.metadata["openings"]
    backed = [o for o in openings if o["kind"] != "through"]
    assert len(backed) >= 2 and pc.info["holes_filled"] >= len(backed)
    occ = Scene(pc.mesh)
    grid = np.linspace(-0.4, 0.4, 5)
    for o in openings:
        centre, n = np.array(o["centre"]), np.array(o["normal"])
        along = np.cross([0.0, 0.0, 1.0], n)  # the wall's run direction
        w, h = o["size"]
        pts = (centre + grid[:, None, None] * w * along
               + grid[None, :, None] * h * np.array([0.0, 0.0, 1.0])).reshape(-1, 3)
        start = pts + (0.5 * o["thickness"] + 1e-3) * n  # 1 mm outside the outer face
        t, _ = occ.first_hit(start, np.broadcast_to(-n, start.shape))
        if o["kind"] == "through":  # nothing in either face's plane, nor between
            span = o["thickness"] + 2e-3
            clear = ~scene.any_hit(start, np.broadcast_to(-n, start.shape), max_distance=span)
            assert clear.sum() >= 0.5 * len(clear)  # (a sign board can cover a window)
            assert np.all(t[clear] > span), (o, t[clear].min())
        else:  # the outer face is covered where the recess or plaque lies
            assert np.all(t <= 1e-3 + 1e-5), (o, t.max())


# ---------------------------------------------------------------------------- voxels + enforcement
def _sphere_case():
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    iso, info = winding_isosurface(sphere, voxels=24)
    coarse = simplify_isosurface(iso, faces=40)
    origin, pitch, shape = grid_shape(sphere.bounds, 24)
    return iso, coarse, origin, pitch, shape


def test_winding_isosurface_closed_and_near_sphere():
    iso, coarse, *_ = _sphere_case()
    assert iso.is_watertight and iso.volume > 0
    r = np.linalg.norm(iso.vertices, axis=1)
    assert np.abs(r - 1.0).max() < 0.15
    assert coarse.is_watertight and len(coarse.faces) <= 40


def test_enforce_conservative_vertices_inside_isosurface():
    import igl

    iso, coarse, origin, pitch, shape = _sphere_case()

    def sdf(points):
        return igl.signed_distance(np.ascontiguousarray(points, dtype=np.float64),
                                   np.asarray(iso.vertices, dtype=np.float64),
                                   np.asarray(iso.faces, dtype=np.int64))[0]

    tol = 0.05 * pitch
    assert sdf(coarse.vertices).max() > tol  # quadric placement left vertices outside
    out, info = enforce_conservative(coarse, iso, origin=origin, pitch=pitch, shape=shape)
    assert sdf(out.vertices).max() <= tol + 1e-9
    assert info["outside_after"] == 0 and info["outside_before"] > 0
    assert np.array_equal(out.faces, coarse.faces)


def test_enforcement_energy_gradient_matches_finite_differences():
    from scipy.sparse import identity

    iso, coarse, origin, pitch, shape = _sphere_case()
    field = SignedDistanceGrid.of_mesh(iso.vertices, iso.faces, origin, pitch, shape)
    rng = np.random.default_rng(3)
    pos = (coarse.vertices - origin) / pitch + rng.normal(0, 0.3, coarse.vertices.shape)
    faces = np.asarray(coarse.faces)
    edges = np.unique(np.sort(np.concatenate([faces[:, :2], faces[:, 1:], faces[:, ::2]]),
                              axis=1), axis=0)
    rest = np.linalg.norm(pos[edges[:, 0]] - pos[edges[:, 1]], axis=1) * 1.1
    n = len(pos)
    weights = rng.uniform(0.5, 3.0, n)
    offsets = rng.uniform(0.0, 2.0, n)  # most points inside the penalised zone
    args = (edges, rest, identity(n, format="csr"), field, weights, offsets)
    x = pos.reshape(-1)
    e0, grad = enforcement_energy(x, *args)
    assert e0 > 0 and np.linalg.norm(grad) > 0
    h = 1e-6
    fd = np.empty_like(x)
    for i in range(len(x)):
        step = np.zeros_like(x)
        step[i] = h
        fd[i] = (enforcement_energy(x + step, *args)[0]
                 - enforcement_energy(x - step, *args)[0]) / (2 * h)
    assert np.allclose(grad, fd, rtol=1e-4, atol=1e-6 * np.abs(fd).max())


def test_signed_distance_grid_beyond_grid_grows_with_distance():
    iso, _, origin, pitch, shape = _sphere_case()
    field = SignedDistanceGrid.of_mesh(iso.vertices, iso.faces, origin, pitch, shape)
    mid = np.array(shape) / 2
    far = np.array([[-5.0, mid[1], mid[2]], [-10.0, mid[1], mid[2]]])
    phi, grad = field(far)
    assert phi[1] > phi[0] > 0 and grad[0, 0] < 0


# ---------------------------------------------------------------------------- generate_hybrid
def test_generate_hybrid_candidates_without_mgos():
    house = _panel_house()
    occ = generate_hybrid(house, mgos=False, voxels=16)
    info = occ.info
    assert occ.method == "hybrid" and occ.double_sided
    assert info["faces"] == occ.triangles == info["candidates_patch"] + info["candidates_voxel"]
    assert info["triangles_single_sided"] == 2 * occ.triangles
    assert info["candidates_patch"] > 0 and info["candidates_voxel"] > 0
    for stage in ("seconds_patch", "seconds_voxel", "seconds_enforce", "seconds_mgos"):
        assert info[stage] >= 0
    # the voxel candidates alone: closed, single-sided
    vox = generate_hybrid(trimesh.creation.box(), candidates="voxel", mgos=False, voxels=16)
    assert vox.info["faces_patch"] == 0 and not vox.double_sided
    assert vox.info["triangles_single_sided"] == vox.triangles


@pytest.mark.slow  # the metric-guided step's numba kernels compile on first use (~40 s)
def test_generate_hybrid_respects_budget():
    house = _panel_house()
    occ = generate_hybrid(house, budget=30, voxels=16, mgos_spacing=0.3, mgos_resolution=16,
                          mgos_quads=100)
    assert 0 < occ.triangles <= 30
    assert occ.info["faces_patch"] + occ.info["faces_voxel"] == occ.triangles
    assert occ.info["mgos"]["faces_after"] == occ.triangles


def test_generate_hybrid_xatlas_grouping_covers_the_same_planes():
    house = _panel_house()
    # charts never join two planes: as many groups as edge-connected planar patches
    ref = generate_hybrid(house, candidates="patch", mgos=False, coplanar=False)
    occ = generate_hybrid(house, candidates="patch", mgos=False, grouping="xatlas",
                          coplanar=False)
    assert occ.info["patch"]["grouping"] == "xatlas"
    assert occ.info["patch"]["groups"] >= ref.info["patch"]["planar_patches"] - 1
    assert np.isclose(occ.mesh.area, ref.mesh.area, rtol=1e-6)
    # regrouped by plane across loose parts, both cover the same planes again
    ref = generate_hybrid(house, candidates="patch", mgos=False)
    occ = generate_hybrid(house, candidates="patch", mgos=False, grouping="xatlas")
    assert ref.info["patch"]["groups"] < ref.info["patch"]["planar_patches"]
    assert np.isclose(occ.mesh.area, ref.mesh.area, rtol=1e-6)


@pytest.mark.parametrize("scale", [1e-30, 1e30])
def test_generate_hybrid_scale_free(scale):
    box = trimesh.creation.box()
    ref = generate_hybrid(box, mgos=False, voxels=16)
    big = box.copy()
    big.apply_scale(scale)
    occ = generate_hybrid(big, mgos=False, voxels=16)
    assert occ.triangles == ref.triangles
    assert np.allclose(occ.mesh.bounds, ref.mesh.bounds * scale, rtol=1e-9, atol=0)


def test_generate_hybrid_keeps_patches_thinner_than_rdp_tolerance():
    needle = trimesh.creation.box(extents=(1000, 0.001, 0.001))
    occ = generate_hybrid(needle, mgos=False, voxels=16)
    assert occ.info["candidates_patch"] > 0
    assert np.isclose(occ.mesh.area, needle.area, rtol=1e-6)


@pytest.mark.parametrize("kwargs", [
    {"budget": 0}, {"voxels": 2}, {"voxels": 10_000}, {"eps_a": 0.0}, {"eps_a": 4.0},
    {"eps_a": float("nan")}, {"grouping": "charts"}, {"candidates": "both"},
    {"enforce": "yes"}, {"mgos": 1}, {"patch_faces": 0}, {"voxel_faces": -1},
    {"eps_p": 2.0}, {"eps_r": -0.1}, {"seed": -1}, {"mgos_spacing": 0.0},
    {"mgos_resolution": 0}, {"mgos_quads": 1.5}, {"fill_holes": None},
])
def test_generate_hybrid_invalid_input(kwargs):
    with pytest.raises(InputError):
        generate_hybrid(trimesh.creation.box(), **kwargs)


def test_generate_hybrid_invalid_mesh():
    with pytest.raises(InputError):
        generate_hybrid(trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=int)))
    with pytest.raises(InputError):
        generate_hybrid("not a mesh")


@pytest.mark.slow
def test_generate_hybrid_city_block_budget_and_sources():
    from viscore import load_mesh

    mesh = load_mesh("city-block")
    occ = generate_hybrid(mesh, budget=120)
    assert occ.triangles <= 120
    assert occ.info["mgos"]["precision_after"] >= 0.95
