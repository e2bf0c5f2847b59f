"""viscore.ray.render: object-id and normal images by ray casting, shaded and overlaid."""

import numpy as np
import pytest
import trimesh

from viscore import InputError, OrthoCamera, PerspectiveCamera, Scene
from viscore.ray import render
from viscore.ray.render import object_image, overlay, shade


def _two_boxes():
    """Box 0 at z in [-1, 1], box 1 behind it at z in [-6, -4]; both 2 x 2 across."""
    front = trimesh.creation.box(extents=(2, 2, 2))
    back = trimesh.creation.box(extents=(2, 2, 2)).apply_translation((0, 0, -5))
    mesh = trimesh.util.concatenate([front, back])
    return Scene(mesh), np.repeat([0, 1], 12)


def _down(resolution=8):
    """Looking down -z from z = 10 over a 4 x 4 window."""
    return OrthoCamera((0, 0, -1), (0, 0, 0), 4.0, resolution, start=10.0)


def test_object_image_ids_depth_and_normals_of_a_box():
    scene, owner = _two_boxes()
    img = object_image(scene, owner, _down(4))
    # pixel centres at -1.5, -0.5, 0.5, 1.5: the middle 2 x 2 see the front box's top
    assert img.object.tolist() == [[-1] * 4, [-1, 0, 0, -1], [-1, 0, 0, -1], [-1] * 4]
    assert np.allclose(img.depth[1:3, 1:3], 9.0, atol=1e-5)  # from z = 10 to z = 1
    assert np.isinf(img.depth[0]).all() and (img.triangle[0] == -1).all()
    assert np.allclose(img.normal[1:3, 1:3], [0, 0, 1], atol=1e-6)  # towards the eye
    assert np.allclose(img.facing[1:3, 1:3], 1.0) and (img.facing[0] == 0).all()


def test_object_image_facing_is_the_cosine_of_a_tilted_plane():
    # a plane tilted 60 degrees from the view direction: |cos| = 0.5 at every pixel
    a = np.radians(60)
    quad = trimesh.Trimesh([[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]],
                           [[0, 1, 2], [0, 2, 3]], process=False)
    quad.apply_transform(trimesh.transformations.rotation_matrix(a, (1, 0, 0)))
    img = object_image(Scene(quad), np.zeros(2, dtype=int), _down(6))
    assert img.hit.all()
    assert np.allclose(img.facing, 0.5, atol=1e-6)
    # the normal turned towards the eye whichever way the triangles wind
    assert (img.normal[..., 2] > 0).all()
    flipped = trimesh.Trimesh(quad.vertices, quad.faces[:, ::-1], process=False)
    img2 = object_image(Scene(flipped), np.zeros(2, dtype=int), _down(6))
    assert np.allclose(img2.normal, img.normal, atol=1e-6)


def test_object_image_skip_passes_objects():
    scene, owner = _two_boxes()
    img = object_image(scene, owner, _down(4), skip=[True, False])  # through the front box
    assert img.object[1:3, 1:3].tolist() == [[1, 1], [1, 1]]
    assert np.allclose(img.depth[1:3, 1:3], 14.0, atol=1e-4)  # z = 10 down to z = -4
    gone = object_image(scene, owner, _down(4), skip=[True, True])
    assert (gone.object == -1).all() and np.isinf(gone.depth).all()


def test_object_image_start_continues_an_earlier_cast():
    scene, owner = _two_boxes()
    cam = PerspectiveCamera((0.2, 0.3, 8), (0, 0, -1), fov=40, resolution=24, height=16)
    seen = object_image(scene, owner, cam)
    fresh = object_image(scene, owner, cam, skip=[True, False])
    again = object_image(scene, owner, cam, skip=[True, False], start=seen)
    assert np.array_equal(again.object, fresh.object)
    assert np.allclose(again.depth[again.hit], fresh.depth[fresh.hit], rtol=1e-6)


def test_object_image_layers_are_bounded(monkeypatch):
    # 4 boxes in a row, all passed: at most MAX_PASSED_LAYERS surfaces, then nothing
    boxes = [trimesh.creation.box(extents=(2, 2, 1)).apply_translation((0, 0, -3 * k))
             for k in range(4)]
    scene = Scene(trimesh.util.concatenate(boxes))
    owner = np.repeat(np.arange(4), 12)
    monkeypatch.setattr(render, "MAX_PASSED_LAYERS", 3)  # 2 faces per box: box 2 unseen
    cam = OrthoCamera((0, 0, -1), (0, 0, 0), 1.0, 2, start=10.0)
    img = object_image(scene, owner, cam, skip=[True, True, False, False])
    assert (img.object == -1).all()
    monkeypatch.setattr(render, "MAX_PASSED_LAYERS", 4)
    img = object_image(scene, owner, cam, skip=[True, True, False, False])
    assert (img.object == 2).all()


def test_shade_colours_outlines_and_background():
    scene, owner = _two_boxes()
    img = object_image(scene, owner, _down(8))
    red = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    rgb = shade(img, red, background=(0.0, 1.0, 0.0))
    assert rgb.dtype == np.uint8 and rgb.shape == (8, 8, 3)
    assert rgb[0, 0].tolist() == [0, 255, 0]  # nothing hit
    assert rgb[4, 4].tolist() == [255, 0, 0]  # object 0 faces the eye: its colour itself
    outline = np.round(np.array(render.OUTLINE_RGB) * 255).tolist()
    assert rgb[2, 3].tolist() == outline  # first row of the box: the edge with the void
    # the box's 4 x 4 pixels: its ring of 12 and the 16 void pixels around it, not its inside
    assert img.outline.sum() == 28 and not img.outline[3:5, 3:5].any()


def test_shade_tells_neighbours_of_one_colour_apart():
    two = trimesh.util.concatenate([trimesh.creation.box(extents=(2, 4, 2)).apply_translation(
        (-1, 0, 0)), trimesh.creation.box(extents=(2, 4, 2)).apply_translation((1, 0, 0))])
    img = object_image(Scene(two), np.repeat([0, 1], 12), _down(8))
    rgb = shade(img, [[0.5, 0.5, 0.5]] * 2)
    a, b = rgb[4, 1], rgb[4, 6]  # inside each box's top, away from the outlines
    assert a.tolist() != b.tolist()
    tone = 1 - (1 - render.ID_SHADE_LOW) * ((1 * render._GOLDEN) % 1.0)
    assert b[0] == round(0.5 * tone * 255)


def test_overlay_blends_fill_and_draws_outlines():
    scene, owner = _two_boxes()
    img = object_image(scene, owner, _down(8))
    base = np.full((8, 8, 3), 100, dtype=np.uint8)
    out = overlay(base, img, (1.0, 0.0, 0.0), alpha=0.25)
    assert out[0, 0].tolist() == [100, 100, 100]  # nothing of the overlay there
    assert out[4, 4].tolist() == [round(0.75 * 100 + 0.25 * 255), 75, 75]
    assert out[2, 3].tolist() == [255, 0, 0]  # its outline, opaque
    assert base[4, 4].tolist() == [100, 100, 100]  # the input untouched
    per = overlay(base, img, colors=[[0, 0, 1.0], [1.0, 0, 0]], alpha=1.0, outline=False)
    assert per[4, 4].tolist() == [0, 0, 255]


def test_render_invalid_input():
    scene, owner = _two_boxes()
    cam = _down(4)
    with pytest.raises(InputError, match="triangle_object"):
        object_image(scene, owner[:5], cam)
    with pytest.raises(InputError, match="skip"):
        object_image(scene, owner, cam, skip=[True])
    img = object_image(scene, owner, cam)
    with pytest.raises(InputError, match="start"):
        object_image(scene, owner, _down(8), start=img)
    with pytest.raises(InputError, match="colors"):  # object 1 seen, one colour given
        shade(object_image(scene, owner, cam, skip=[True, False]), [[1, 0, 0]])
    with pytest.raises(InputError, match="colors"):
        shade(img, [[1, 0], [0, 1]])
    base = np.zeros((4, 4, 3), np.uint8)
    with pytest.raises(InputError, match="rgb"):
        overlay(np.zeros((5, 4, 3), np.uint8), img, (1, 0, 0))
    with pytest.raises(InputError, match="not both"):
        overlay(base, img, (1, 0, 0), colors=[[1, 0, 0]] * 2)
    with pytest.raises(InputError, match="alpha"):
        overlay(base, img, (1, 0, 0), alpha=1.5)
