import os

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


def _vertex_fans_are_disks(mesh) -> bool:
    """Every vertex's triangles form one closed fan: the edges opposite the vertex
    (its link) make a single cycle, each link vertex entered and left once."""
    faces = np.asarray(mesh.faces)
    corner = np.repeat(np.arange(len(faces)), 3)
    slot = np.tile(np.arange(3), len(faces))
    centre = faces[corner, slot]
    start, end = faces[corner, (slot + 1) % 3], faces[corner, (slot + 2) % 3]
    for v in range(len(mesh.vertices)):
        sel = centre == v
        link = dict(zip(start[sel].tolist(), end[sel].tolist(), strict=True))
        if not link or len(link) != sel.sum() or set(link) != set(link.values()):
            return False
        first = next(iter(link))
        cur, steps = link[first], 1
        while cur != first:
            cur, steps = link[cur], steps + 1
        if steps != len(link):  # more than one cycle: fans touching at the vertex
            return False
    return True


def _assert_closed_manifold(solid, grid):
    mesh = voxel_boundary_mesh(solid, grid)
    edges = np.sort(mesh.edges, axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all()  # every edge in exactly two faces
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert _vertex_fans_are_disks(mesh)
    assert mesh.volume == pytest.approx(solid.sum() * grid.pitch**3, rel=1e-9)  # outward
    return mesh


def test_voxel_boundary_mesh_ball_unchanged_closed_manifold():
    # a voxel ball has no edge-only contacts: one vertex per grid vertex, two faces a square
    n = 12
    c = np.indices((n, n, n)).transpose(1, 2, 3, 0) - (n - 1) / 2
    ball = (c**2).sum(axis=-1) < 20
    grid = VoxelGrid(np.array([1.0, -2.0, 0.5]), 0.25, ball.shape)
    mesh = _assert_closed_manifold(ball, grid)
    assert len(np.unique(mesh.vertices, axis=0)) == len(mesh.vertices)
    padded = np.pad(ball, 1).astype(np.int8)
    squares = sum(int(np.abs(np.diff(padded, axis=a)).sum()) for a in range(3))
    assert len(mesh.faces) == 2 * squares
    assert (np.diff(mesh.vertices[:, 0]) >= 0).all()  # lexicographic grid-vertex order


def test_voxel_boundary_mesh_two_voxels_sharing_an_edge():
    grid = VoxelGrid(np.zeros(3), 0.5, (4, 4, 4))
    solid = np.zeros(grid.shape, bool)
    solid[1, 1, 1] = solid[2, 2, 1] = True  # touching along the edge x = y = 1 (grid units)
    mesh = _assert_closed_manifold(solid, grid)
    # two closed cubes, kept apart along the shared edge (split at its midpoint)
    assert mesh.body_count == 2 and len(mesh.faces) > 24


def test_voxel_boundary_mesh_two_voxels_sharing_a_vertex():
    grid = VoxelGrid(np.zeros(3), 1.0, (4, 4, 4))
    solid = np.zeros(grid.shape, bool)
    solid[1, 1, 1] = solid[2, 2, 2] = True
    mesh = _assert_closed_manifold(solid, grid)
    assert len(mesh.faces) == 24 and len(mesh.vertices) == 16  # the shared corner twice
    assert mesh.body_count == 2


def test_voxel_boundary_mesh_edge_contact_joined_at_both_ends():
    # two voxels touching along an edge, also joined around both of its end vertices (through
    # the layers below and above): splitting vertices alone would leave four faces on the edge
    grid = VoxelGrid(np.zeros(3), 1.0, (5, 5, 5))
    solid = np.zeros(grid.shape, bool)
    solid[1, 1, 1] = solid[2, 2, 1] = True
    solid[1, 1, 0] = solid[2, 1, 0] = solid[2, 2, 0] = True
    solid[1, 1, 2] = solid[1, 2, 2] = solid[2, 2, 2] = True
    _assert_closed_manifold(solid, grid)


def test_voxel_boundary_mesh_random_solids_closed_manifold():
    rng = np.random.default_rng(5)
    grid = VoxelGrid(np.array([1.0, -2.0, 0.5]), 0.25, (8, 9, 7))
    for density in (0.2, 0.35, 0.5, 0.65, 0.8):
        _assert_closed_manifold(rng.random(grid.shape) < density, grid)


def test_voxel_boundary_mesh_empty():
    grid = VoxelGrid(np.zeros(3), 1.0, (3, 3, 3))
    mesh = voxel_boundary_mesh(np.zeros(grid.shape, bool), grid)
    assert mesh.faces.shape == (0, 3) and mesh.vertices.shape == (0, 3)


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
    from viscore.voxel.grid import _sat_overlap

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

    mesh = load_mesh("building-house")  # wall panels on a slab: coincident faces at z = 0
    scene = Scene(mesh)
    rng = np.random.default_rng(4)
    # points in the slab under the front wall and in that wall's panels just above it
    pts = np.column_stack([rng.uniform(-4.4, -1.6, 400), rng.uniform(-4.08, -3.92, 400),
                           np.where(np.arange(400) % 2, -0.004, 0.004)])
    assert points_inside(scene, pts).all()
    assert not points_inside_parity(scene, pts).all()  # the stand-in alone miscounts
    # a room (outside every panel) and a point inside the front wall
    w = winding_numbers(mesh.vertices, mesh.faces, [[-2.0, -2.0, 1.2], [-3.0, -4.0, 0.5]])
    np.testing.assert_allclose(w, [0.0, 1.0], atol=1e-2)  # libigl's fast winding number


def test_surface_voxels_triangle_lying_on_voxel_faces():
    # a triangle in the plane z = 2, a boundary between voxel layers 1 and 2, with two edges
    # on grid lines (x = 1, y = 1) and its corners on grid vertices: every voxel whose closed
    # cube it touches is a surface voxel, on both sides of the plane
    grid = VoxelGrid(np.zeros(3), 1.0, (5, 5, 4))
    tri = np.array([[1.0, 1.0, 2.0], [4.0, 1.0, 2.0], [1.0, 4.0, 2.0]])
    got = surface_voxels(tri, np.array([[0, 1, 2]]), grid)
    i, j = np.meshgrid(np.arange(5), np.arange(5), indexing="ij")
    # square [i, i+1] x [j, j+1] meets {x >= 1, y >= 1, x + y <= 5} (touching counts)
    columns = (i + 1 >= 1) & (j + 1 >= 1) & (np.maximum(i, 1) + np.maximum(j, 1) <= 5)
    expected = np.zeros(grid.shape, bool)
    expected[:, :, 1] = expected[:, :, 2] = columns
    np.testing.assert_array_equal(got, expected)
    # the same triangle shifted off the plane by a hair: one layer only
    got = surface_voxels(tri + [0, 0, 0.25], np.array([[0, 1, 2]]), grid)
    np.testing.assert_array_equal(got[:, :, 2], columns)
    assert not got[:, :, 1].any() and not got[:, :, 3].any()


def _voxel_room(shape, wall, hole=None):
    """Solid of a hollow box: ``wall`` voxels thick, optional tunnel ``hole`` (slices)."""
    solid = np.ones(shape, bool)
    solid[wall:-wall, wall:-wall, wall:-wall] = False
    if hole is not None:
        solid[hole] = False
    return solid


def test_inside_voxels_winding_hollow_shell_drops_cavity():
    shell = trimesh.util.concatenate([_box((-1, -1, -1), (1, 1, 1)),
                                      _box((-0.6, -0.6, -0.6), (0.6, 0.6, 0.6))])
    shell.faces[12:] = shell.faces[12:, ::-1]  # the inner box faces the cavity
    v = voxelize(shell, resolution=20)
    from viscore.voxel.grid import inside_voxels_winding

    inside = inside_voxels_winding(shell.vertices, shell.faces, v.grid, v.surface)
    c = v.grid.centers(np.argwhere(np.ones(v.grid.shape, bool))).reshape(v.grid.shape + (3,))
    in_cavity = (np.abs(c) < 0.6).all(axis=-1)
    enclosed = v.solid & ~v.surface
    assert (enclosed & in_cavity).sum() > 0  # the flood fill takes the cavity for solid
    assert not (inside & in_cavity).any()
    np.testing.assert_array_equal(inside, enclosed & ~in_cavity)
    # the per-voxel route (an open mesh is not assumed closed) agrees here
    per_voxel = inside_voxels_winding(shell.vertices, shell.faces, v.grid, v.surface,
                                      closed=False)
    np.testing.assert_array_equal(per_voxel, inside)


def test_inside_voxels_winding_sealed_cavity_and_open_mesh(open_cube):
    from viscore.voxel.grid import inside_voxels_winding

    # a room with a one-voxel door, voxelized at a coarser pitch: the door is sealed
    room = _voxel_room((12, 12, 12), 3, hole=(slice(5, 6), slice(0, 3), slice(5, 6)))
    mesh = voxel_boundary_mesh(room, VoxelGrid(np.zeros(3), 1.0, room.shape))
    v = voxelize(mesh, pitch=1.7)
    assert not v.leaks
    inside = inside_voxels_winding(mesh.vertices, mesh.faces, v.grid, v.surface)
    c = v.grid.centers(np.argwhere(inside))
    assert len(c) > 0 and not ((c > 3) & (c < 9)).all(axis=1).any()  # nothing in the room
    # open cube: candidates tested one by one, at their centres
    v = voxelize(open_cube, resolution=10)
    cand = ~v.surface
    inside = inside_voxels_winding(open_cube.vertices, open_cube.faces, v.grid, v.surface,
                                   candidates=cand)
    c = v.grid.centers(np.argwhere(inside))
    assert (np.abs(c) <= 1 + 1e-9).all()  # the hole's plane z = 1 itself has w = 1/2
    deep = cand & (np.abs(v.grid.centers(np.argwhere(np.ones(v.grid.shape, bool))))
                   < 0.9).all(axis=1).reshape(v.grid.shape)
    assert deep.sum() > 0 and inside[deep].all()  # w >= 5/6 there
    with pytest.raises(InputError, match="surface"):
        inside_voxels_winding(open_cube.vertices, open_cube.faces, v.grid, v.surface[1:])


def test_voxelize_refuses_before_work_when_memory_is_short(monkeypatch, cube):
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", "1e-9")
    with pytest.raises(InputError, match="voxelize.*memory"):
        voxelize(cube, resolution=64)
    with pytest.raises(InputError, match="mesh"):
        voxelize(trimesh.Trimesh(), resolution=4)


def test_voxel_grid_tiny_pitch_refused_not_overflowed():
    with pytest.raises(InputError, match="cells"):
        voxel_grid(np.array([[0, 0, 0], [1, 1, 1.0]]), pitch=1e-300)


_NUMBA_IMPORT_AND_RUN = """
import trimesh
import viscore.generators.aabb_skins  # decorates the box-growth kernels
from viscore.voxel.grid import voxelize
v = voxelize(trimesh.creation.box(), resolution=4)
print(int(v.surface.sum()))
"""


def test_numba_kernels_import_and_run_without_a_cache_location():
    # a system-wide install run by another user: numba finds no writable folder for its
    # cache (here: no cache locator at all) and ``cache=True`` raised at import
    import subprocess
    import sys

    code = ("from numba.core import caching\n"
            "impl = getattr(caching, 'CacheImpl', None) or getattr(caching, '_CacheImpl')\n"
            "impl._locator_classes = []\n") + _NUMBA_IMPORT_AND_RUN
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_CACHE")}
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    assert int(run.stdout.split()[-1]) == 5**3 - 3**3  # the unit cube at 4 voxels: a 5^3 shell


@pytest.mark.slow
def test_numba_kernels_from_a_read_only_install(tmp_path):
    # the package copied as an install lays it out (package-dir mapping), made read-only,
    # run with a home folder that cannot hold ~/.cache either
    import shutil
    import stat
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    site = tmp_path / "site"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(repo / "viscore", site / "viscore", ignore=ignore)
    for folder, name in (("metrics", "metrics"), ("generators", "generators"), ("cli", "cli"),
                         ("data", "_scenes")):
        shutil.copytree(repo / folder, site / "viscore" / name, ignore=ignore)
    home = tmp_path / "home"
    home.mkdir()
    for path in [*site.rglob("*"), site, home, tmp_path]:
        mode = path.stat().st_mode
        path.chmod(mode & ~(stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH)
                   | stat.S_IRUSR | stat.S_IRGRP | stat.S_IROTH
                   | (stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH if path.is_dir() else 0))
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_CACHE", "PYTHON"))}
    env.update(PYTHONPATH=str(site), HOME=str(home), XDG_CACHE_HOME=str(home / ".cache"))
    code = (f"import viscore; assert viscore.__file__.startswith({str(site)!r})\n"
            + _NUMBA_IMPORT_AND_RUN)
    command = [sys.executable, "-c", code]
    try:
        if os.geteuid() == 0:  # root writes anywhere: run as an unprivileged user
            probe = subprocess.run(["runuser", "-u", "nobody", "--", sys.executable, "-c", ""],
                                   capture_output=True, timeout=60)
            if probe.returncode != 0:
                pytest.skip("cannot run this Python as user 'nobody'")
            command = ["runuser", "-u", "nobody", "--", "env", *(f"{k}={v}" for k, v in
                                                                env.items()), *command]
        run = subprocess.run(command, capture_output=True, text=True, env=env, cwd=tmp_path,
                             timeout=900)
    finally:
        for path in [tmp_path, home, site, *site.rglob("*")]:
            path.chmod(path.stat().st_mode | stat.S_IWUSR)
    assert run.returncode == 0, run.stderr[-3000:]
    assert int(run.stdout.split()[-1]) == 5**3 - 3**3


def test_voxelize_kept_by_content_answers_fresh_arrays():
    # a 2 x 2 x 2 box at pitch 0.5: the box's faces pass through voxel centres, so the
    # inner voxels are the 3 x 3 x 3 block strictly inside and the solid the 5 x 5 x 5 one
    box = _box((0, 0, 0), (2, 2, 2))
    first = voxelize(box, pitch=0.5)
    assert int(first.inner.sum()) == 27 and int(first.solid.sum()) == 125
    first.surface[:] = False  # a caller's change never reaches the kept answer
    first.inner[:] = True
    again = voxelize(box.copy(), pitch=0.5)  # equal content, another object
    assert int(again.inner.sum()) == 27 and int(again.surface.sum()) == 125 - 27
    moved = box.copy()
    moved.vertices[:, 0] *= 1.5  # other content: voxelized anew (3 x 2 x 2 box)
    wider = voxelize(moved, pitch=0.5)
    assert int(wider.inner.sum()) == 5 * 3 * 3


def test_inside_voxels_winding_closed_kept_by_content_answers_fresh_arrays():
    from viscore.voxel.grid import inside_voxels_winding

    box = _box((0, 0, 0), (2, 2, 2))
    vox = voxelize(box, pitch=0.5)
    inside = inside_voxels_winding(box.vertices, box.faces, vox.grid, vox.surface, closed=True)
    assert int(inside.sum()) == 27
    inside[:] = False
    some = np.zeros(vox.grid.shape, dtype=bool)
    some[4, 4, 4] = True  # the centre voxel only
    only = inside_voxels_winding(box.vertices, box.faces, vox.grid, vox.surface,
                                 candidates=some, closed=True)
    assert int(only.sum()) == 1 and only[4, 4, 4]
    assert int(inside_voxels_winding(box.vertices, box.faces, vox.grid, vox.surface,
                                     closed=True).sum()) == 27
