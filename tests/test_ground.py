"""The solid under open ground (viscore.level.ground) and the coverage hull."""

import math

import numpy as np
import pytest
import trimesh

from viscore import InputError, Scene, voxelize
from viscore.level.ground import ground_fill, ground_layer, ground_share, guess_up
from viscore.voxel.coverage_hull import covered_voxels, hull_directions
from viscore.voxel.grid import VoxelGrid


def _grid(shape=(6, 5, 8)) -> VoxelGrid:
    return VoxelGrid(origin=np.zeros(3), pitch=1.0, shape=shape)


def test_ground_fill_fills_each_column_from_the_ground_to_its_highest_surface_voxel():
    grid = _grid()
    surface = np.zeros(grid.shape, bool)
    surface[1, 1, 5] = True  # a roof voxel
    surface[1, 1, 2] = True  # and a floor under it: the column still fills to the roof
    surface[3, 2, 6] = True
    fill = ground_fill(surface, grid, up="z", height=1.0)  # layer 1 (centre 1.5) and up
    assert fill[1, 1].tolist() == [False, True, True, True, True, True, False, False]
    assert fill[3, 2].tolist() == [False, True, True, True, True, True, True, False]
    assert fill.sum() == 5 + 6  # columns without a surface voxel stay empty


def test_ground_fill_along_y_is_the_z_case_with_the_axes_swapped():
    grid = _grid((5, 7, 5))
    rng = np.random.default_rng(3)
    surface = rng.random(grid.shape) < 0.05
    swapped = VoxelGrid(origin=np.zeros(3), pitch=1.0, shape=(5, 5, 7))
    along_y = ground_fill(surface, grid, up="y", height=2.0)
    along_z = ground_fill(np.swapaxes(surface, 1, 2), swapped, up="z", height=2.0)
    assert np.array_equal(along_y, np.swapaxes(along_z, 1, 2))
    assert along_y.any()


def test_ground_above_the_surface_fills_nothing_and_below_the_grid_fills_from_layer_0():
    grid = _grid()
    surface = np.zeros(grid.shape, bool)
    surface[2, 2, 3] = True
    assert not ground_fill(surface, grid, up="z", height=10.0).any()
    assert ground_fill(surface, grid, up="z", height=-5.0)[2, 2].tolist()[:4] == [True] * 4
    assert ground_layer(grid, "z", 10.0) == grid.shape[2]


def test_ground_share_is_the_covered_part_of_the_footprint_hull():
    n = 41
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    surface = np.zeros((n, n, 3), bool)
    surface[..., 1] = np.abs(i - 20) + np.abs(j - 20) <= 20  # a plan turned by 45 degrees
    assert ground_share(surface, "z") > 0.95  # half of its bounding rectangle
    surface[..., 1] &= ~((i > 20) & (j > 20))  # a quarter cut out: 3/4 of the diamond
    assert 0.7 < ground_share(surface, "z") < 0.85
    assert ground_share(np.zeros((3, 3, 3), bool)) == 0.0


def test_ground_refuses_bad_axes_and_shapes():
    with pytest.raises(InputError, match="up"):
        ground_fill(np.zeros((6, 5, 8), bool), _grid(), up="w", height=0.0)
    with pytest.raises(InputError, match="shape"):
        ground_fill(np.zeros((2, 2, 2), bool), _grid(), up="z", height=0.0)


def test_guess_up_moved_to_the_core_is_the_level_objects_function():
    from viscore.level.objects import guess_up as level_guess

    assert level_guess is guess_up
    roof = trimesh.creation.box(extents=(4, 4, 3))
    roof = trimesh.Trimesh(roof.vertices, roof.faces[roof.face_normals[:, 2] > -0.5])
    assert guess_up(roof)[0] == "z"


# ----------------------------------------------------------------------- coverage hull
def _open_bottom_box() -> trimesh.Trimesh:
    box = trimesh.creation.box(extents=(2, 2, 2))
    return trimesh.Trimesh(box.vertices, box.faces[box.face_normals[:, 2] > -0.5],
                           process=False)


def _cells_in(grid: VoxelGrid, lo, hi) -> np.ndarray:
    """Voxel indices whose centres lie in the box [lo, hi]."""
    idx = np.argwhere(np.ones(grid.shape, bool))
    c = grid.centers(idx)
    return idx[np.all((c >= lo) & (c <= hi), axis=1)]


def test_hull_directions_are_line_directions_of_the_upper_half_sphere_and_the_axes():
    d = hull_directions(40)
    assert d.shape[1] == 3 and 40 <= len(d) <= 43
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    assert (d[:, 2] >= 0).all()
    assert np.allclose(d[-3:], np.eye(3))


def test_the_inside_of_an_open_bottomed_box_is_covered_from_every_direction():
    # any line through an inside point crosses the box's boundary twice and the
    # bottom plane at most once, so it meets one of the five faces
    mesh = _open_bottom_box()
    grid = voxelize(mesh, resolution=16).grid
    inside = _cells_in(grid, [-0.8, -0.8, -0.8], [0.8, 0.8, 0.8])
    assert len(inside) > 1000
    assert covered_voxels(Scene(mesh), grid, inside).all()
    outside = _cells_in(grid, [-0.5, -0.5, -1.3], [0.5, 0.5, -1.2])  # below the opening
    assert len(outside) and not covered_voxels(Scene(mesh), grid, outside).any()


def test_a_point_under_a_sheet_is_exposed_along_the_grazing_lines_only():
    # a 2 x 2 square at z = 0; the point (0, 0, -h) sees past its edges along lines
    # within atan(h / 1) of the horizontal at most: a share about sin(atan(h)) of them
    sheet = trimesh.Trimesh([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]],
                            [[0, 1, 2], [0, 2, 3]], process=False)
    grid = VoxelGrid(origin=np.array([-1.55, -1.55, -1.55]), pitch=0.1, shape=(31, 31, 31))
    scene = Scene(sheet)
    h = 0.2
    cell = np.array([[15, 15, int(round((-h + 1.55) / 0.1 - 0.5))]])
    exposed = math.sin(math.atan(h / 0.8))  # the margin brings the edge 0.05 nearer
    assert not covered_voxels(scene, grid, cell)[0]
    assert covered_voxels(scene, grid, cell, misses=min(0.95, exposed + 0.1))[0]
    deep = np.array([[15, 15, 1]])  # 1.4 under the sheet: most lines miss it
    assert not covered_voxels(scene, grid, deep, misses=0.5)[0]


def test_covered_voxels_refuses_a_share_outside_0_1():
    mesh = _open_bottom_box()
    grid = voxelize(mesh, resolution=8).grid
    with pytest.raises(InputError, match="misses"):
        covered_voxels(Scene(mesh), grid, np.zeros((1, 3), int), misses=1.0)


def test_guess_up_of_an_object_reads_a_small_net_area_where_a_level_takes_the_thin_axis():
    from viscore import load_mesh

    chapel = load_mesh("building-church")  # 11.2 x 23.5 x 23 m, open at the bottom
    assert guess_up(chapel)[0] == "x"  # as a level: thinnest along x
    axis, reason = guess_up(chapel, level=False)
    assert axis == "z" and "net face area" in reason
    closed = trimesh.creation.box(extents=(1, 3, 2))  # no net area; most area faces x
    assert guess_up(closed, level=False)[0] == "x"
