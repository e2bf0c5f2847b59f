import numpy as np
import pytest
import trimesh

from viscore import (
    InputError,
    Scene,
    VoxelGrid,
    inner_voxels_six_direction,
    inside_voxels_parity,
    outside_voxels,
    surface_voxels,
    voxel_boundary_mesh,
    voxel_grid,
    voxelize,
)


def _box(lo, hi):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    b = trimesh.creation.box(extents=hi - lo)
    b.apply_translation((lo + hi) / 2)
    return b


def test_surface_voxels_axis_aligned_box_exact():
    # unit grid at the origin; box [1.25, 4.75] x [1.5, 3.5] x [2.2, 5.8]
    grid = VoxelGrid(np.zeros(3), 1.0, (7, 6, 8))
    box = _box((1.25, 1.5, 2.2), (4.75, 3.5, 5.8))
    got = surface_voxels(box.vertices, box.faces, grid)
    solid = np.zeros(grid.shape, bool)
    solid[1:5, 1:4, 2:6] = True  # voxels the box overlaps
    interior = np.zeros(grid.shape, bool)
    interior[2:4, 2:3, 3:5] = True  # voxels strictly inside, away from every face
    np.testing.assert_array_equal(got, solid & ~interior)


def test_surface_voxels_single_tilted_triangle_matches_dense_check(rng):
    grid = VoxelGrid(np.zeros(3), 1.0, (6, 6, 6))
    tri = np.array([[0.3, 0.4, 0.5], [5.2, 1.1, 2.7], [2.2, 5.5, 4.9]])
    got = surface_voxels(tri, np.array([[0, 1, 2]]), grid)
    # reference: a voxel is hit iff some dense sample of the triangle lies in it, or
    # the triangle passes within rounding of it; compare on samples only (subset test)
    w = rng.dirichlet(np.ones(3), 200000)
    idx = np.floor(w @ tri).astype(int)
    sampled = np.zeros(grid.shape, bool)
    sampled[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    assert (got >= sampled).all()  # every voxel the triangle visibly enters is found
    assert got.sum() - sampled.sum() <= 3  # only corner-grazing voxels may be missed by sampling


def test_outside_and_inner_on_closed_cube():
    v = voxelize(_box((0.05, 0.05, 0.05), (0.95, 0.95, 0.95)), resolution=9)
    assert not v.leaks
    # every solid non-surface voxel is inner by the six-direction rule, and vice versa
    np.testing.assert_array_equal(v.inner, v.solid & ~v.surface)
    assert v.inner.sum() > 0


def test_inside_parity_closed_cube_matches_analytic(cube):
    grid = voxel_grid(1.1 * cube.bounds, resolution=10)  # no voxel centre on a face
    inside = inside_voxels_parity(Scene(cube), grid)
    idx = np.argwhere(np.ones(grid.shape, bool))
    c = grid.centers(idx)
    expected = (np.abs(c) < 1).all(axis=1).reshape(grid.shape)
    np.testing.assert_array_equal(inside, expected)


def test_open_cube_parity_majority_inside_and_flood_leaks(open_cube):
    grid = voxel_grid(1.1 * open_cube.bounds, resolution=10)
    scene = Scene(open_cube)
    c = grid.centers(np.argwhere(np.ones(grid.shape, bool)))
    expected = (np.abs(c) < 1).all(axis=1).reshape(grid.shape)
    # documented: 5 of 6 votes inside, so the default majority keeps the interior ...
    np.testing.assert_array_equal(inside_voxels_parity(scene, grid), expected)
    # ... and unanimity rejects it
    assert not inside_voxels_parity(scene, grid, min_votes=6).any()
    # no voxel sees a surface in +Z: the six-direction rule and the flood fill find nothing
    v = voxelize(open_cube, resolution=10)
    assert not v.inner.any()
    assert not (v.solid & ~v.surface).any()


def test_leak_detected_through_small_hole():
    from viscore import load_mesh

    mesh = load_mesh("box-with-hole")  # 0.2-wide hole in a 2-wide hollow box
    fine = voxelize(mesh, resolution=40)  # hole 4 voxels wide: the fill leaks in
    assert fine.inner.sum() > 1000 and fine.leaks
    coarse = voxelize(mesh, resolution=8)  # hole below the voxel size: closed
    assert not coarse.leaks


def test_six_direction_rule_hollow_shell():
    s = np.zeros((7, 7, 7), bool)
    s[1:6, 1:6, 1:6] = True
    s[2:5, 2:5, 2:5] = False
    inner = inner_voxels_six_direction(s)
    assert inner.sum() == 27 and inner[2:5, 2:5, 2:5].all()
    assert not (inner & outside_voxels(s)).any()


def test_voxel_boundary_mesh_closed_and_volume():
    # a voxel ball has no edge-only contacts: the voxel mesh is a closed 2-manifold
    n = 12
    c = np.indices((n, n, n)).transpose(1, 2, 3, 0) - (n - 1) / 2
    ball = (c**2).sum(axis=-1) < 20
    grid = VoxelGrid(np.array([1.0, -2.0, 0.5]), 0.25, ball.shape)
    mesh = voxel_boundary_mesh(ball, grid)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume == pytest.approx(ball.sum() * 0.25**3, rel=1e-9)  # outward-oriented
    # any solid: every edge is shared by an even number of faces, volume still exact
    solid = np.random.default_rng(5).random((8, 9, 7)) < 0.5
    mesh = voxel_boundary_mesh(solid, grid)
    edges = np.sort(mesh.edges, axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts % 2 == 0).all()
    assert mesh.volume == pytest.approx(solid.sum() * 0.25**3, rel=1e-9)


def test_voxel_grid_refuses_huge_grid_with_estimate():
    with pytest.raises(InputError, match="GiB"):
        voxel_grid(np.array([[0, 0, 0], [1, 1, 1.0]]), resolution=5000)


def test_voxel_grid_invalid_input():
    with pytest.raises(InputError, match="resolution"):
        voxel_grid(np.array([[0, 0, 0], [1, 1, 1.0]]), resolution=0)
    with pytest.raises(InputError, match="pitch"):
        voxel_grid(np.array([[0, 0, 0], [1, 1, 1.0]]), pitch=-1.0)


def test_points_inside_parity_sphere(unit_sphere, rng):
    from viscore import points_inside_parity

    pts = rng.uniform(-1.3, 1.3, (3000, 3))
    pts = pts[np.abs(np.linalg.norm(pts, axis=1) - 1) > 0.01]
    got = points_inside_parity(Scene(unit_sphere), pts)
    np.testing.assert_array_equal(got, np.linalg.norm(pts, axis=1) < 1)


def test_surface_voxels_kernel_matches_vectorised_sat(rng):
    from viscore.voxels import _sat_overlap

    grid = VoxelGrid(np.array([-0.3, -0.2, -0.1]), 0.37, (9, 8, 10))
    tris = rng.uniform(-0.5, 3.3, (40, 3, 3))
    tris[:10] = tris[:10, :1] + 0.05 * (tris[:10] - tris[:10, :1])  # small ones too
    got = surface_voxels(tris.reshape(-1, 3), np.arange(120).reshape(40, 3), grid)
    idx = np.argwhere(np.ones(grid.shape, bool))
    expected = np.zeros(grid.shape, bool)
    for t in tris:
        hit = _sat_overlap(np.repeat(t[None], len(idx), 0), grid.centers(idx), grid.pitch / 2)
        expected[tuple(idx[hit].T)] = True
    np.testing.assert_array_equal(got, expected)


def test_points_inside_touching_parts_settled_by_winding_number():
    from viscore import load_mesh, points_inside, points_inside_parity, winding_numbers

    mesh = load_mesh("buildings")  # boxes standing on a slab: coincident faces at z = 0
    scene = Scene(mesh)
    rng = np.random.default_rng(4)
    # points in the slab under the first building and in that building just above it
    pts = np.column_stack([rng.uniform(-1.55, -0.45, 400), rng.uniform(-1.45, -0.55, 400),
                           np.where(np.arange(400) % 2, -0.004, 0.004)])
    assert points_inside(scene, pts).all()
    assert not points_inside_parity(scene, pts).all()  # the stand-in alone miscounts
    w = winding_numbers(mesh.vertices, mesh.faces, [[0.0, 0.0, 1.0], [-1.0, -1.0, 1.0]])
    np.testing.assert_allclose(w, [0.0, 1.0], atol=1e-9)
