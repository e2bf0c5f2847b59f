import numpy as np
import pytest
import trimesh

from viscore import OrthoCamera, PerspectiveCamera, Scene, coverage_image, depth_image


def test_coverage_image_sphere_area_is_pi_r2(unit_sphere):
    r = 0.75
    sphere = unit_sphere.copy()
    sphere.apply_scale(r)
    cam = OrthoCamera((0.2, -0.5, 0.7), (0, 0, 0), 2.0, 512)
    cov = coverage_image(Scene(sphere), cam)
    area = cov.sum() * cam.pixel_size**2
    assert area == pytest.approx(np.pi * r**2, rel=0.01)


def test_depth_image_tilted_plane_matches_analytic():
    # plane z = 0.5 x + 0.25 y + 1 over [-2, 2]^2; rays along +z from z = -5
    x, y = np.meshgrid(np.linspace(-2, 2, 9), np.linspace(-2, 2, 9), indexing="ij")
    z = 0.5 * x + 0.25 * y + 1.0
    vertices = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    idx = np.arange(81).reshape(9, 9)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    plane = trimesh.Trimesh(vertices, np.concatenate([np.c_[a, b, c], np.c_[a, c, d]]),
                            process=False)
    cam = OrthoCamera((0, 0, 1), (0, 0, 0), 2.0, 16, up=(0, 1, 0), start=5.0)
    depth = depth_image(Scene(plane), cam)
    o, _ = cam.rays()
    expected = (0.5 * o[:, 0] + 0.25 * o[:, 1] + 1.0) + 5.0
    np.testing.assert_allclose(depth.ravel(), expected, atol=1e-5)


def test_depth_image_perspective_sphere_distance(unit_sphere):
    cam = PerspectiveCamera((0, 0, -4), (0, 0, 1), fov=60, resolution=64)
    depth = depth_image(Scene(unit_sphere), cam)
    _, d = cam.rays()
    # analytic ray/sphere distance from (0,0,-4)
    oc = np.array([0, 0, -4.0])
    b = d @ oc
    disc = b**2 - (oc @ oc - 1)
    hit = disc > 1e-3
    t = -b - np.sqrt(np.where(hit, disc, 0))
    got = depth.ravel()
    assert np.isfinite(got[hit & (disc > 0.05)]).all()
    assert np.isinf(got[disc < -0.05]).all()
    np.testing.assert_allclose(got[disc > 0.05], t[disc > 0.05], atol=5e-3)


def test_coverage_image_row_zero_is_up(cube):
    # a box only above the centre shows in the top rows
    box = trimesh.creation.box(extents=(0.5, 0.5, 0.5))
    box.apply_translation([0, 0.5, 0])
    cam = OrthoCamera((0, 0, 1), (0, 0, 0), 2.0, 8, up=(0, 1, 0))
    cov = coverage_image(Scene(box), cam)
    assert cov[:4].sum() > 0 and cov[4:].sum() == 0


def test_images_of_a_non_square_camera_have_its_shape():
    # a 1280 x 720-style camera (here 16 x 9) looking at a wall that fills the view
    import trimesh

    from viscore import PerspectiveCamera, Scene, coverage_image, depth_image

    wall = trimesh.creation.box(extents=(100.0, 100.0, 1.0))
    cam = PerspectiveCamera((0, 0, 10), (0, 0, -1), (0, 1, 0), fov=60, resolution=16, height=9)
    depth = depth_image(Scene(wall), cam)
    assert depth.shape == (9, 16) and coverage_image(Scene(wall), cam).all()
    # the centre rows look straight at the wall 9.5 units away; the corners see it farther
    assert abs(depth[4, 7] - 9.5) < 0.1 and depth[0, 0] > depth[4, 7]
