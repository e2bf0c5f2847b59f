import numpy as np
import pytest
import trimesh

from viscore import InputError, Scene, points_inside, winding_numbers
from viscore.voxel.winding import is_closed_oriented

#: libigl's fast winding number: within this of the exact value (Barnes-Hut
#: far field; measured 3e-3 on the bunny).
FAST_TOL = 1e-2


def _brute_force_winding(vertices, faces, points):
    """Exact sum of signed solid angles (Van Oosterom and Strackee), vectorised numpy."""
    tri = np.asarray(vertices, float)[np.asarray(faces)]  # (f, 3, 3)
    d = tri[None, :, :, :] - np.asarray(points, float)[:, None, None, :]  # (n, f, 3, 3)
    a, b, c = d[:, :, 0], d[:, :, 1], d[:, :, 2]
    la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
    det = np.einsum("nfi,nfi->nf", a, np.cross(b, c))
    dot = lambda x, y: np.einsum("nfi,nfi->nf", x, y)  # noqa: E731
    den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb
    return (2 * np.arctan2(det, den)).sum(axis=1) / (4 * np.pi)


def _square(half=1.0, z=0.0):
    """Square [-half, half]^2 at height z, normal +z (two triangles)."""
    v = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]])
    return v, np.array([[0, 1, 2], [0, 2, 3]])


def _hollow_box(outer=2.0, inner=1.6):
    inside = trimesh.creation.box(extents=(inner,) * 3)
    inside.invert()
    return trimesh.util.concatenate([trimesh.creation.box(extents=(outer,) * 3), inside])


@pytest.mark.parametrize("exact", [False, True])
def test_winding_numbers_closed_sphere_inside_one_outside_zero(exact, rng):
    sphere = trimesh.creation.icosphere(subdivisions=3)  # inscribed radius > 0.98
    r = np.r_[rng.uniform(0, 0.9, 300), rng.uniform(1.1, 5, 300)]
    pts = r[:, None] * trimesh.unitize(rng.normal(size=(600, 3)))
    w = winding_numbers(sphere.vertices, sphere.faces, pts, exact=exact)
    tol = 1e-9 if exact else FAST_TOL
    np.testing.assert_allclose(w, (r < 1).astype(float), atol=tol)
    inverted = sphere.copy()
    inverted.invert()
    w = winding_numbers(inverted.vertices, inverted.faces, pts, exact=exact)
    np.testing.assert_allclose(w, -(r < 1).astype(float), atol=tol)


@pytest.mark.parametrize("exact", [False, True])
def test_winding_numbers_square_solid_angle_analytic(exact):
    # a square of side 2a seen from height h above its centre subtends
    # 4 arctan(a^2 / (h sqrt(2 a^2 + h^2))); the point behind the front face counts +
    a = 1.0
    h = np.array([1e-3, 0.1, 0.5, 1.0, 3.0, 20.0])
    omega = 4 * np.arctan(a**2 / (h * np.sqrt(2 * a**2 + h**2)))
    v, f = _square(a)
    pts = np.c_[np.zeros((len(h), 2)), h]
    tol = 1e-9 if exact else FAST_TOL
    np.testing.assert_allclose(winding_numbers(v, f, pts, exact=exact), -omega / (4 * np.pi),
                               atol=tol)
    pts[:, 2] *= -1
    np.testing.assert_allclose(winding_numbers(v, f, pts, exact=exact), omega / (4 * np.pi),
                               atol=tol)
    # close to a large plane: half a turn on either side
    v, f = _square(1e4)
    w = winding_numbers(v, f, [[0.3, -0.2, -1.0], [0.1, 0.4, 1.0]], exact=exact)
    np.testing.assert_allclose(w, [0.5, -0.5], atol=max(tol, 1e-4))


@pytest.mark.parametrize("exact", [False, True])
def test_winding_numbers_open_cube_centre_five_sixths(exact, open_cube):
    # from the centre each face subtends a sixth of the sphere; one of six is missing
    w = winding_numbers(open_cube.vertices, open_cube.faces, [[0, 0, 0]], exact=exact)
    assert w[0] == pytest.approx(5 / 6, abs=1e-9 if exact else FAST_TOL)


def test_winding_numbers_match_brute_force_solid_angles(rng):
    torus = trimesh.creation.torus(major_radius=1.0, minor_radius=0.4, major_sections=16,
                                   minor_sections=8)
    soup_v = rng.uniform(-1, 1, (60, 3))
    soup_f = rng.integers(0, 60, (20, 3))
    soup_f = soup_f[(soup_f[:, 0] != soup_f[:, 1]) & (soup_f[:, 1] != soup_f[:, 2])
                    & (soup_f[:, 0] != soup_f[:, 2])]
    for v, f in ((torus.vertices, torus.faces), (soup_v, soup_f)):
        pts = rng.uniform(-1.6, 1.6, (400, 3))
        ref = _brute_force_winding(v, f, pts)
        np.testing.assert_allclose(winding_numbers(v, f, pts, exact=True), ref, atol=1e-9)
        np.testing.assert_allclose(winding_numbers(v, f, pts), ref, atol=FAST_TOL)


def test_winding_numbers_leave_numba_threads_alone():
    numba = pytest.importorskip("numba")
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        box = trimesh.creation.box()
        winding_numbers(box.vertices, box.faces, np.zeros((10, 3)))
        assert numba.get_num_threads() == 1
    finally:
        numba.set_num_threads(before)


def test_winding_numbers_empty():
    box = trimesh.creation.box()
    assert winding_numbers(box.vertices, box.faces, np.zeros((0, 3))).shape == (0,)
    assert winding_numbers(box.vertices, np.zeros((0, 3), int), [[0, 0, 0]]).tolist() == [0.0]


def test_winding_numbers_invalid_input():
    box = trimesh.creation.box()
    with pytest.raises(InputError, match="points"):
        winding_numbers(box.vertices, box.faces, [[0, 0]])
    with pytest.raises(InputError, match="points"):
        winding_numbers(box.vertices, box.faces, [[0, np.nan, 0]])
    with pytest.raises(InputError, match="faces"):
        winding_numbers(box.vertices, box.faces + 100, [[0, 0, 0]])
    with pytest.raises(InputError, match="vertices"):
        winding_numbers(box.vertices[:, :2], box.faces, [[0, 0, 0]])


def test_is_closed_oriented_cases(cube, open_cube):
    assert is_closed_oriented(cube.vertices, cube.faces)
    assert not is_closed_oriented(open_cube.vertices, open_cube.faces)
    flipped = np.array(cube.faces)
    flipped[0] = flipped[0, ::-1]
    assert not is_closed_oriented(cube.vertices, flipped)
    # two boxes sharing one edge: four faces on it, still a closed oriented surface
    a = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    b = trimesh.creation.box(bounds=[[1, 1, 0], [2, 2, 1]])
    pair = trimesh.util.concatenate([a, b])
    pair.merge_vertices()
    assert is_closed_oriented(pair.vertices, pair.faces)
    # unmerged copies of the vertices (one per face) are merged by position
    soup = np.asarray(cube.vertices)[np.asarray(cube.faces)].reshape(-1, 3)
    assert is_closed_oriented(soup, np.arange(len(soup)).reshape(-1, 3))
    assert is_closed_oriented(*_mesh(_hollow_box()))
    assert not is_closed_oriented(cube.vertices, np.zeros((0, 3), int))


def _mesh(m):
    return m.vertices, m.faces


def test_points_inside_overlaps_cavities_and_open_surfaces(open_cube, rng):
    # two overlapping closed boxes: winding number 2 in the overlap, which is inside
    a = trimesh.creation.box(bounds=[[0, 0, 0], [2, 1, 1]])
    b = trimesh.creation.box(bounds=[[1, 0.2, 0.2], [3, 0.8, 0.8]])
    both = trimesh.util.concatenate([a, b])
    got = points_inside(Scene(both), [[1.5, 0.5, 0.5], [0.5, 0.5, 0.5], [2.5, 0.5, 0.5],
                                      [1.5, 0.1, 0.5], [3.5, 0.5, 0.5]])
    assert got.tolist() == [True, True, True, True, False]
    # a hollow shell: the cavity is outside, the wall inside
    shell = _hollow_box()
    got = points_inside(Scene(shell), [[0, 0, 0], [0.9, 0.1, 0.2], [1.5, 0, 0]])
    assert got.tolist() == [False, True, False]
    # the open cube: its interior has winding number >= 5/6 > 1/2
    pts = rng.uniform(-0.9, 0.9, (200, 3))
    assert points_inside(Scene(open_cube), pts).all()


@pytest.mark.parametrize("name", ["bunny", "hairball", "city-block", "terrain", "building-house"])
def test_points_inside_agrees_with_exact_winding_number(name, rng):
    from viscore import load_mesh

    mesh = load_mesh(name)
    lo, hi = mesh.bounds
    pts = rng.uniform(lo, hi, (4000, 3))
    w = winding_numbers(mesh.vertices, mesh.faces, pts, exact=True)
    clear = np.abs(np.abs(w) - 0.5) > FAST_TOL  # away from the threshold of open surfaces
    got = points_inside(Scene(mesh), pts)
    np.testing.assert_array_equal(got[clear], np.abs(w[clear]) >= 0.5)


def test_points_inside_invalid_input(cube):
    with pytest.raises(InputError, match="points"):
        points_inside(Scene(cube), [[0, 0]])
    assert points_inside(Scene(cube), np.zeros((0, 3))).shape == (0,)


@pytest.mark.parametrize("scale", [1e-60, 1e-30, 1e20, 1e60])
def test_winding_numbers_do_not_depend_on_scale(scale):
    # libigl's fast winding number on raw coordinates gave 0 inside a 1e20 cube
    box = trimesh.creation.box()
    points = np.array([[0.0, 0.0, 0.0], [0.2, -0.3, 0.1], [2.0, 0.0, 0.0], [0.0, 0.0, -5.0]])
    w = winding_numbers(box.vertices * scale, box.faces, points * scale)
    np.testing.assert_allclose(w, [1.0, 1.0, 0.0, 0.0], atol=0.01)


def test_closed_oriented_answer_follows_the_content_not_the_array():
    """The answers are kept by content: the same arrays edited in place (one face flipped,
    then flipped back) give the new answer each time."""
    box = trimesh.creation.box()
    v, f = np.array(box.vertices), np.array(box.faces)
    assert is_closed_oriented(v, f)
    f[0] = f[0, ::-1]
    assert not is_closed_oriented(v, f)
    f[0] = f[0, ::-1]
    assert is_closed_oriented(v, f)
    v[0] += 0.5  # moved off its twins at the same position: the edges no longer pair
    assert is_closed_oriented(v, f) == is_closed_oriented(v.copy(), f.copy())
