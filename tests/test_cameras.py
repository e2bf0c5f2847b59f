import numpy as np
import pytest

from viscore import InputError, OrthoCamera, PerspectiveCamera, cube_cameras, directions_uniform


def test_cube_cameras_cover_every_direction_once():
    cams = cube_cameras((0.0, 0.0, 0.0), resolution=8)
    d = directions_uniform(20000, seed=3)
    inside = np.stack([c.contains(d) for c in cams])
    counts = inside.sum(axis=0)
    # away from the frustum edges exactly one face sees the direction
    a = np.sort(np.abs(d), axis=1)
    interior = (a[:, 2] - a[:, 1]) > 1e-9
    assert (counts[interior] == 1).all()
    assert (counts >= 1).all()


def test_cube_cameras_pixel_rays_belong_to_own_face():
    cams = cube_cameras((1.0, 2.0, 3.0), resolution=16)
    for k, cam in enumerate(cams):
        _, d = cam.rays()
        owners = np.stack([c.contains(d) for c in cams])
        assert owners[k].all()
        assert owners.sum(axis=0).max() == 1  # pixel centres are never on an edge


def test_perspective_rays_unit_and_corner_angle():
    cam = PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 1, 0), fov=90, resolution=2)
    o, d = cam.rays()
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1)
    # pixel (0, 0) is top-left: up is +Y, right = forward x up = -X
    x, y = d[0, 0] / d[0, 2], d[0, 1] / d[0, 2]
    assert x == pytest.approx(0.5) and y == pytest.approx(0.5)  # tan(45) * 0.5 pixel centre


def test_ortho_project_inverts_rays():
    cam = OrthoCamera((1, 2, -0.5), (0.3, 0.1, 0.0), 3.0, 32)
    o, d = cam.rays()
    pixel, depth = cam.project(o + 2.5 * d)
    cols = np.tile(np.arange(32), 32) + 0.5
    rows = np.repeat(np.arange(32), 32) + 0.5
    np.testing.assert_allclose(pixel[:, 0], cols, atol=1e-9)
    np.testing.assert_allclose(pixel[:, 1], rows, atol=1e-9)
    np.testing.assert_allclose(depth, 2.5, atol=1e-9)


def test_cameras_invalid_input():
    with pytest.raises(InputError, match="extent"):
        OrthoCamera((0, 0, 1), (0, 0, 0), -1.0, 8)
    with pytest.raises(InputError, match="resolution"):
        OrthoCamera((0, 0, 1), (0, 0, 0), 1.0, 0)
    with pytest.raises(InputError, match="fov"):
        PerspectiveCamera((0, 0, 0), (0, 0, 1), fov=180)
    with pytest.raises(InputError, match="up"):
        PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 0, 2))
    with pytest.raises(InputError, match="forward"):
        OrthoCamera((0, 0, 0), (0, 0, 0), 1.0, 8)
