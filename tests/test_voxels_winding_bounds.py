"""The bounded inside test of open meshes: ``inside_voxels_winding`` decides most voxels
from the winding number's gradient bound and must keep every voxel's classification
(the per-voxel evaluation, ``per_voxel=True``, is the reference)."""

import logging

import numpy as np
import pytest
import trimesh

import viscore.voxel.grid as voxels_module
import viscore.voxel.winding as winding_module
from viscore import Scene, VoxelGrid, inside_voxels_parity, load_mesh, scene_path, voxelize
from viscore.voxel.grid import (
    _grid_side_flags,
    _voxel_gradient_bounds,
    inside_voxels_winding,
)
from viscore.voxel.winding import _boundary_edges, _winding_gradient_bounds, winding_numbers


@pytest.fixture(autouse=True)
def _no_kept_answers():
    """Each test computes its own answers (the last one is kept by content)."""
    voxels_module._INSIDE_OPEN.clear()
    yield
    voxels_module._INSIDE_OPEN.clear()


def _box(lo, hi) -> trimesh.Trimesh:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    b = trimesh.creation.box(extents=hi - lo)
    b.apply_translation(0.5 * (lo + hi))
    return b


def _open_bottomed_hall(size=(4.0, 3.0, 2.5), wall=0.12) -> trimesh.Trimesh:
    """A hall of thin walls, open at the bottom: an outer box without its -Z face and an
    inner box, inverted, without its -Z face either, joined by nothing (the rim is open)."""
    outer = _box((0, 0, 0), size)
    inner = _box((wall, wall, 0), np.asarray(size) - (wall, wall, wall))
    inner.faces = inner.faces[:, ::-1]
    keep_o = outer.face_normals[:, 2] > -0.5
    keep_i = inner.face_normals[:, 2] < 0.5  # the inverted inner box's bottom points up
    parts = [trimesh.Trimesh(outer.vertices, outer.faces[keep_o], process=False),
             trimesh.Trimesh(inner.vertices, inner.faces[keep_i], process=False)]
    return trimesh.util.concatenate(parts)


def _hall_on_a_slab() -> trimesh.Trimesh:
    """The open-bottomed hall standing in a floor slab (a closed box) that seals its rim:
    the flood fill no longer leaks, and the rim's edges still bound the winding number."""
    return trimesh.util.concatenate([_open_bottomed_hall(), _box((-0.2, -0.2, -0.1),
                                                                 (4.2, 3.2, 0.02))])


def _with_hole(mesh: trimesh.Trimesh, count: int) -> trimesh.Trimesh:
    """``mesh`` without its ``count`` faces of highest centroid z (a hole in the top)."""
    keep = np.argsort(mesh.triangles_center[:, 2])[:len(mesh.faces) - count]
    return trimesh.Trimesh(mesh.vertices, mesh.faces[np.sort(keep)], process=False)


def _grid_candidates(mesh, pitch, kind):
    v = voxelize(mesh, pitch=pitch)
    if kind == "all":
        cand = None
    elif kind == "flood":
        cand = v.solid & ~v.surface
    else:
        cand = inside_voxels_parity(Scene(mesh), v.grid) & ~v.surface
    return v, cand


def _assert_same_as_per_voxel(mesh, pitch, kind):
    v, cand = _grid_candidates(mesh, pitch, kind)
    fast = inside_voxels_winding(mesh.vertices, mesh.faces, v.grid, v.surface, candidates=cand,
                                 closed=False)
    exact = inside_voxels_winding(mesh.vertices, mesh.faces, v.grid, v.surface, candidates=cand,
                                  closed=False, per_voxel=True)
    np.testing.assert_array_equal(fast, exact)
    return fast


def test_boundary_edges_empty_for_a_closed_mesh_and_the_rim_of_an_open_one(cube, open_cube):
    a, b, weight = _boundary_edges(np.asarray(cube.vertices), np.asarray(cube.faces))
    assert len(a) == 0
    a, b, weight = _boundary_edges(np.asarray(open_cube.vertices), np.asarray(open_cube.faces))
    assert len(a) == 4  # the square at z = 1 (the two triangles' diagonal cancels)
    np.testing.assert_allclose(np.linalg.norm(b - a, axis=1), 2.0)
    np.testing.assert_array_equal(weight, 1.0)
    np.testing.assert_allclose(np.r_[a[:, 2], b[:, 2]], 1.0)


def test_boundary_edges_merge_vertices_at_equal_positions(cube):
    soup = trimesh.Trimesh(cube.triangles.reshape(-1, 3), np.arange(36).reshape(12, 3),
                           process=False)  # every face its own vertices: still closed
    assert len(_boundary_edges(np.asarray(soup.vertices), np.asarray(soup.faces))[0]) == 0


@pytest.mark.parametrize("radius", [0.0, 0.05])
def test_winding_gradient_bounds_cover_finite_differences(open_cube, rng, radius):
    v, f = np.asarray(open_cube.vertices), np.asarray(open_cube.faces)
    edges = _boundary_edges(v, f)
    pts = rng.uniform(-1.6, 1.6, (300, 3))
    near_surface = (np.abs(np.abs(pts) - 1) < 0.1).any(axis=1)
    pts = pts[~near_surface]
    bound = _winding_gradient_bounds(edges, pts, radius)
    h = 1e-5
    grad = np.stack([(winding_numbers(v, f, pts + h * e, exact=True)
                      - winding_numbers(v, f, pts - h * e, exact=True)) / (2 * h)
                     for e in np.eye(3)], axis=1)
    finite = np.isfinite(bound)
    assert finite.sum() > 200
    assert (np.linalg.norm(grad[finite], axis=1) <= bound[finite] * (1 + 1e-3) + 1e-6).all()


def test_voxel_gradient_bounds_by_blocks_are_at_least_the_per_voxel_ones():
    hall = _open_bottomed_hall()
    v = voxelize(hall, pitch=0.05)
    flat = np.flatnonzero(~v.surface)
    edges = _boundary_edges(np.asarray(hall.vertices), np.asarray(hall.faces))
    blocked = np.zeros(len(flat))
    _voxel_gradient_bounds(flat, np.array(v.grid.shape, dtype=np.int64),
                           np.asarray(v.grid.origin), float(v.grid.pitch), *edges, blocked)
    centres = v.grid.centers(np.stack(np.unravel_index(flat, v.grid.shape), axis=1))
    single = _winding_gradient_bounds(edges, centres, 0.5 * np.sqrt(3) * v.grid.pitch)
    assert (blocked >= single * (1 - 1e-12)).all()
    assert np.isfinite(blocked).mean() > 0.9


def test_grid_side_flags_mark_the_rows_ends():
    shape = np.array([2, 3, 4], dtype=np.int64)
    flat = np.arange(24, dtype=np.int64)
    x, y, z = np.unravel_index(flat, tuple(shape))
    want = (z == 0) * 1 | (z == 3) * 2 | (y == 0) * 4 | (y == 2) * 8
    np.testing.assert_array_equal(_grid_side_flags(flat, shape), want)


@pytest.mark.parametrize("kind", ["parity", "all"])
def test_inside_voxels_winding_thin_open_hall_same_as_per_voxel(kind):
    inside = _assert_same_as_per_voxel(_open_bottomed_hall(), 0.045, kind)
    assert inside.sum() > 1000  # the walls hold inner voxels at this pitch


def test_inside_voxels_winding_hall_on_a_slab_same_as_per_voxel():
    inside = _assert_same_as_per_voxel(_hall_on_a_slab(), 0.045, "flood")
    assert inside.sum() > 1000


@pytest.mark.parametrize("kind", ["flood", "all"])
def test_inside_voxels_winding_box_with_a_hole_same_as_per_voxel(kind):
    mesh = _with_hole(load_mesh(scene_path("box-with-hole")), 40)
    _assert_same_as_per_voxel(mesh, 0.06, kind)


def test_inside_voxels_winding_open_cube_same_as_per_voxel(open_cube):
    inside = _assert_same_as_per_voxel(open_cube, 0.1, "all")
    assert inside.sum() > 0


def test_inside_voxels_winding_cottage_same_as_per_voxel():
    cottage = load_mesh(scene_path("building-cottage"))
    _assert_same_as_per_voxel(cottage, 0.06, "parity")


def test_inside_voxels_winding_closed_mesh_taken_as_open_same_as_per_voxel(cube):
    # no boundary edge: the winding number is constant per component, one evaluation each
    _assert_same_as_per_voxel(cube, 0.1, "all")


def test_inside_voxels_winding_evaluates_few_voxels(monkeypatch):
    hall = _hall_on_a_slab()
    v = voxelize(hall, pitch=0.03)
    cand = v.solid & ~v.surface
    evaluated = []
    real = winding_module.winding_numbers

    def counting(vertices, faces, points, **kwargs):
        evaluated.append(len(points))
        return real(vertices, faces, points, **kwargs)

    monkeypatch.setattr(winding_module, "winding_numbers", counting)
    inside = inside_voxels_winding(hall.vertices, hall.faces, v.grid, v.surface,
                                   candidates=cand, closed=False)
    assert inside.sum() > 10_000
    assert sum(evaluated) < 0.05 * cand.sum()


def test_inside_voxels_winding_contradicting_bounds_fall_back_to_every_voxel(monkeypatch,
                                                                              caplog):
    # a negative margin claims more than the bounds give: the labels carried from the
    # inside of the hall's walls meet those from outside, and every voxel is evaluated
    hall = _open_bottomed_hall()
    v = voxelize(hall, pitch=0.045)
    monkeypatch.setattr(winding_module, "FAST_WINDING_ERROR", -2.0)
    with caplog.at_level(logging.WARNING, logger="viscore.voxel.grid"):
        fast = inside_voxels_winding(hall.vertices, hall.faces, v.grid, v.surface,
                                     closed=False)
    assert any("contradict" in r.getMessage() for r in caplog.records)
    exact = inside_voxels_winding(hall.vertices, hall.faces, v.grid, v.surface, closed=False,
                                  per_voxel=True)
    np.testing.assert_array_equal(fast, exact)


def test_inside_voxels_winding_empty_candidates(open_cube):
    v = voxelize(open_cube, resolution=8)
    none = np.zeros(v.grid.shape, dtype=bool)
    out = inside_voxels_winding(open_cube.vertices, open_cube.faces, v.grid, v.surface,
                                candidates=none, closed=False)
    assert out.shape == v.grid.shape and not out.any()


def test_inside_voxels_winding_grid_of_one_row_has_no_wrapped_neighbours(open_cube):
    # voxels at the end of one row and the start of the next are consecutive flat indices
    # but not neighbours: a label must not jump between them
    v = voxelize(open_cube, resolution=6)
    g = VoxelGrid(v.grid.origin, v.grid.pitch, v.grid.shape)
    fast = inside_voxels_winding(open_cube.vertices, open_cube.faces, g, v.surface,
                                 closed=False)
    exact = inside_voxels_winding(open_cube.vertices, open_cube.faces, g, v.surface,
                                  closed=False, per_voxel=True)
    np.testing.assert_array_equal(fast, exact)


def test_inside_voxels_winding_keeps_its_last_answer_by_content(monkeypatch, open_cube):
    v = voxelize(open_cube, resolution=12)
    first = inside_voxels_winding(open_cube.vertices, open_cube.faces, v.grid, v.surface,
                                  closed=False)
    count = int(first.sum())
    first[:] = False  # the caller's copy: the kept answer is not touched

    def refuse(*args, **kwargs):
        raise AssertionError("the kept answer should have been used")

    monkeypatch.setattr(winding_module, "winding_numbers", refuse)
    again = inside_voxels_winding(np.array(open_cube.vertices), np.array(open_cube.faces),
                                  v.grid, v.surface.copy(), closed=False)
    assert int(again.sum()) == count > 0 and again.dtype == bool
    fewer = ~v.surface
    fewer[0, 0, 0] = False
    with pytest.raises(AssertionError, match="kept"):  # other candidates: computed anew
        inside_voxels_winding(open_cube.vertices, open_cube.faces, v.grid, v.surface,
                              candidates=fewer, closed=False)
