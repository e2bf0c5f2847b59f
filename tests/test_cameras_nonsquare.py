"""Non-square perspective cameras (``height``): rays, projection and containment."""

import numpy as np
import pytest

from viscore import InputError, PerspectiveCamera


def test_perspective_nonsquare_shape_and_fov():
    cam = PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 1, 0), fov=90, resolution=16, height=9)
    assert cam.shape == (9, 16)
    o, d = cam.rays()
    assert o.shape == d.shape == (144, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1)
    # horizontal: pixel-centre of the last column at tan = (15.5/16 - 0.5) * 2
    x = d[:, 0] / d[:, 2]
    y = d[:, 1] / d[:, 2]
    assert np.abs(x).max() == pytest.approx(15 / 16)
    # vertical half-tan = 9/16, pixel centres at (8.5/9 - 0.5) * 2 * 9/16
    assert np.abs(y).max() == pytest.approx((8.5 / 9 - 0.5) * 2 * 9 / 16)
    assert cam.vertical_fov == pytest.approx(np.degrees(2 * np.arctan(9 / 16)))


def test_perspective_nonsquare_project_inverts_rays():
    cam = PerspectiveCamera((1, 2, 3), (0.3, -1, 0.2), fov=70, resolution=32, height=18)
    o, d = cam.rays()
    pixel, depth = cam.project(o + 2.5 * d)
    cols = np.tile(np.arange(32), 18) + 0.5
    rows = np.repeat(np.arange(18), 32) + 0.5
    np.testing.assert_allclose(pixel[:, 0], cols, atol=1e-9)
    np.testing.assert_allclose(pixel[:, 1], rows, atol=1e-9)
    np.testing.assert_allclose(depth, 2.5, atol=1e-9)
    assert cam.contains(d).all()


def test_perspective_nonsquare_contains_vertical_limit():
    cam = PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 1, 0), fov=90, resolution=1280,
                            height=720)
    half_v = 720 / 1280
    inside = cam.contains([[0, 0.99 * half_v, 1], [0, 1.01 * half_v, 1], [0.99, 0, 1],
                           [1.01, 0, 1], [0, 0, -1]])
    assert inside.tolist() == [True, False, True, False, False]


def test_perspective_square_unchanged_by_height():
    a = PerspectiveCamera((0, 0, 0), (1, 1, 0), fov=60, resolution=8)
    b = PerspectiveCamera((0, 0, 0), (1, 1, 0), fov=60, resolution=8, height=8)
    assert b.height is None and a.shape == b.shape == (8, 8)
    assert np.array_equal(a.rays()[1], b.rays()[1])


def test_perspective_height_invalid_input():
    with pytest.raises(InputError, match="height"):
        PerspectiveCamera((0, 0, 0), (0, 0, 1), height=0)
    with pytest.raises(InputError, match="height"):
        PerspectiveCamera((0, 0, 0), (0, 0, 1), height=2.5)
