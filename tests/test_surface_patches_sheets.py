"""surface-patches' sheets (step 7): curved open surfaces offered as their own triangles.

A hill gives no planar region, no box (it is open) and no curtain by default;
its own triangles are the conservative occluder, and the depth buffer's
crease rule covers them across their seams, so a level's terrain hides what
lies behind it with the guarantee kept."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from viscore import InputError, PerspectiveCamera, Scene
from viscore.cli.bench.table1 import height_field_sheet
from viscore.culling.depth_buffer import ConservativeDepthBuffer, OccluderScene
from viscore.generators import generate
from viscore.generators.levels.occluders import joined_occluder
from viscore.generators.surface_patches._overlap import select_with_overlap
from viscore.generators.surface_patches._sheets import chunk_measure, sheet_chunks
from viscore.level.scene_graph import load_scene_objects
from viscore.metrics.conservativeness import assert_conservative


def _hill(n=25, size=100.0, height=15.0, hole=True):
    """A smooth open hill (z up) over [0, size]^2 peaking in the middle, rippled along y,
    with a square hole in its west flank."""
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    z = height * np.exp(-((x - 0.5) ** 2 + (y - 0.5) ** 2) / 0.05) + np.sin(7 * y)
    sheet = height_field_sheet(z, size, size)
    if hole:
        c = sheet.triangles_center
        sheet = trimesh.Trimesh(sheet.vertices, sheet.faces[~((np.abs(c[:, 0] - 25) < 6)
                                                               & (np.abs(c[:, 1] - 50) < 6))],
                                process=False)
    return sheet


def _triangle_keys(vertices, faces):
    """Each triangle as its sorted vertex triples, exact float64."""
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)]
    return {tuple(sorted(map(tuple, t))) for t in tri}


def test_a_hill_is_its_own_occluder_triangle_for_triangle():
    hill = _hill()
    occ = generate("surface-patches", hill, budget=None)
    assert occ.info["sheets"] > 1 and occ.info["sheet_faces"] == len(hill.faces)
    assert occ.info["conservative_guaranteed"] is True
    # every occluder triangle is an input triangle, vertex for vertex
    assert _triangle_keys(occ.mesh.vertices, occ.mesh.faces) == _triangle_keys(hill.vertices,
                                                                              hill.faces)
    assert occ.info["polygons"] == 0 and len(occ.parts["polygons"]) == len(hill.faces)
    assert_conservative(hill, occ.mesh, rays=20_000, domain="volume", seed=3)
    # without them only the few quads whose two triangles are coplanar (patches)
    off = generate("surface-patches", hill, budget=None, sheets="off")
    assert off.info["sheet_candidates"] == 0 and off.triangles < 10


def test_sheet_chunks_cover_the_sheet_once_and_fit_the_budget_whole():
    hill = _hill()
    sheets = sheet_chunks(hill.vertices, hill.faces, np.arange(len(hill.faces)))
    chunks = [c for sheet in sheets for c in sheet]
    every = np.concatenate(chunks)
    assert len(every) == len(set(every.tolist())) == len(hill.faces)
    assert len(chunks) >= len(hill.faces) // 128  # cut into cells of about 64
    occ = generate("surface-patches", hill, budget=150)
    assert 0 < occ.triangles <= 150 and occ.info["sheets"] >= 1
    # the input's triangles among the kept ones (the rest: patches of coplanar pairs) are
    # whole chunks
    kept = _triangle_keys(occ.mesh.vertices, occ.mesh.faces) & _triangle_keys(hill.vertices,
                                                                                hill.faces)
    assert len(kept) == occ.info["sheet_faces"]
    keys = [_triangle_keys(hill.vertices, hill.faces[c]) for c in chunks]
    assert sum(len(k) for k in keys if k <= kept) == len(kept)


def test_chunk_measure_of_a_square_and_of_a_grid_of_it():
    """The measure of a chunk is its projection's (Silvennoinen et al. eq. 1): the unit
    square's 1/6, whether in 2 triangles or in 2 x 16^2, tilted or not (turned in the
    image, its 64-pixel rasterization reads a few percent low)."""
    sq = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0]], [[0, 0, 0], [1, 1, 0], [0, 1, 0]]], float)
    assert chunk_measure(sq) == pytest.approx(1 / 6, rel=0.01)
    grid = height_field_sheet(np.zeros((17, 17)), 4.0, 4.0)
    turn = trimesh.transformations.rotation_matrix(0.7, [1, 2, 0.5])
    grid.apply_transform(turn)
    assert chunk_measure(grid.triangles) == pytest.approx(4.0 ** 3 / 6, rel=0.05)


def test_planar_regions_are_not_offered_again_as_sheets():
    """A wall's coplanar triangles give patch candidates: no sheet of them; a lone facet
    (one triangle alone in its plane) is no sheet either, a bent pair is one."""
    wall = trimesh.Trimesh([[0, 0, 0], [4, 0, 0], [4, 0, 3], [0, 0, 3]], [[0, 1, 2], [0, 2, 3]],
                           process=False)
    occ = generate("surface-patches", wall, budget=None)
    assert occ.info["sheet_candidates"] == 0 and occ.info["polygons"] == 1
    lone = trimesh.Trimesh([[0, 0, 0], [3, 0, 0], [0, 2, 1]], [[0, 1, 2]], process=False)
    occ = generate("surface-patches", lone, budget=None)
    assert occ.info["sheet_candidates"] == 0 and occ.triangles == 0
    bent = trimesh.Trimesh([[0, 0, 0], [3, 0, 0], [0, 2, 1], [3, 2, 0]], [[0, 1, 2], [1, 3, 2]],
                           process=False)
    occ = generate("surface-patches", bent, budget=None)
    assert occ.info["sheet_candidates"] == 1 and occ.triangles == 2


def test_a_box_behind_a_wavy_curtain_is_culled_only_with_the_sheets():
    """A wavy open curtain (a sheet standing upright, one-to-one along y), a box behind
    it: the curtain's own triangles, through the crease rule, hide the box (and the
    ray-cast truth agrees); without the sheets it hides nothing. (Seen head-on, every
    triangle faces the eye, so the sheet has no silhouette across the box's image: a
    silhouette, or a border hidden behind the sheet, leaves its pixels open.)"""
    x, z = np.meshgrid(np.linspace(0, 1, 41), np.linspace(0, 1, 17), indexing="ij")
    curtain = height_field_sheet(3 * np.sin(100 * x / 7) + 2 * np.cos(40 * z / 5), 100.0, 40.0)
    v = np.asarray(curtain.vertices)
    curtain = trimesh.Trimesh(v[:, [0, 2, 1]], curtain.faces, process=False)  # y = f(x, z)
    cam = PerspectiveCamera((50.0, -60.0, 20.0), (0.0, 1.0, 0.0), up=(0, 0, 1), fov=60,
                            resolution=256, height=144)
    box = ([[40.0, 20.0, 10.0]], [[60.0, 30.0, 25.0]])
    occ = generate("surface-patches", curtain, budget=None)
    assert occ.info["sheet_faces"] == len(curtain.faces)
    buf = ConservativeDepthBuffer.from_occluders(OccluderScene([occ]), cam)
    assert buf.occluded(*box)[0]
    world = trimesh.util.concatenate([curtain, trimesh.creation.box(bounds=np.vstack(box))])
    o, d = cam.rays()
    _, tri = Scene(world).first_hit(o, d)
    assert not (tri >= len(curtain.faces)).any()  # the truth: hidden
    # without them each planar quad is a patch of its own, eroded inside the quad: a gap
    # along every seam, which the buffer keeps open
    off = generate("surface-patches", curtain, budget=None, sheets="off")
    assert off.info["polygons"] >= 100
    assert not ConservativeDepthBuffer.from_occluders(OccluderScene([off]), cam).occluded(*box)[0]


def test_a_wide_ground_does_not_set_a_levels_floor():
    """A ground plane 2,000 across around 16 houses: joined, the crumb floor (min_area) is
    a share of the mean object's area, not of the ground's, so every house's walls are
    candidates (a share of the level's area, 400 units^2, is over every wall's 54)."""
    rng = np.random.default_rng(0)
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(bounds=[[-1000, -1000, -0.2], [1000, 1000, 0]]),
                       geom_name="ground", node_name="ground")
    for k in range(16):
        x, y = rng.uniform(-95, 85, 2)
        scene.add_geometry(trimesh.creation.box(bounds=[[x, y, 0], [x + 9, y + 9, 6]]),
                           geom_name=f"house{k}", node_name=f"house{k}")
    objects = load_scene_objects(scene)
    # a budget under the level's 204 triangles: the planar regions are searched
    occ = joined_occluder(objects, np.arange(17), "surface-patches", budget=160)
    # each house's four walls (a share of the level's area keeps the ground's top and
    # bottom only)
    assert occ.info["regions_used"] >= 16 * 4
    with pytest.raises(InputError, match="min_area"):
        joined_occluder(objects, np.arange(17), "surface-patches", min_area=2.0)


def test_a_candidate_under_a_pixel_of_the_images_keeps_its_value():
    """The overlap selection cannot measure a candidate that covers no pixel of its images
    (a wall in a level a hundred times its size): it keeps its own value and is taken when
    the budget allows, where a share of 0 had left it out."""
    bitmaps = np.zeros((2, 3, 8, 8), dtype=bool)
    bitmaps[0, :, 2:6, 2:6] = True
    values = [np.array([5.0]), np.array([1.0])]
    counts = [np.array([2]), np.array([2])]
    assert select_with_overlap(values, counts, bitmaps, budget=4).tolist() == [0, 0]
    assert select_with_overlap(values, counts, bitmaps, budget=2).tolist() == [0, -1]


def test_sheets_option_is_checked():
    with pytest.raises(InputError, match="sheets"):
        generate("surface-patches", _hill(n=5), sheets="yes")
