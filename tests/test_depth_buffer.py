"""Conservative depth buffer: sub-pixel gaps, full occlusion, no false culls vs ray casting."""

import numpy as np
import pytest
import trimesh

from viscore import InputError, PerspectiveCamera, Scene
from viscore.depth_buffer import ConservativeDepthBuffer, OccluderScene


def _quad(x0, x1, y=0.0, z0=-5.0, z1=5.0):
    """A vertical quad in the plane Y = y, two triangles."""
    v = np.array([[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]], float)
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


def _corners(lo, hi):
    return np.stack([np.where(np.array(m, bool), hi, lo) for m in np.ndindex(2, 2, 2)], axis=1)


def _hidden_samples(scene, eye, lo, hi, rng, n=64, camera=None):
    """For each box, whether every corner and ``n`` random points are hidden by the scene
    (points outside the camera's view, when one is given, count as hidden)."""
    u = rng.random((len(lo), n, 3))
    pts = np.concatenate([_corners(lo, hi), lo[:, None] + u * (hi - lo)[:, None]], axis=1)
    d = pts.reshape(-1, 3) - eye
    dist = np.linalg.norm(d, axis=1)
    t, _ = scene.first_hit(eye[None], d / dist[:, None])
    hidden = t < dist
    if camera is not None:
        hidden |= ~camera.contains(d)
    return hidden.reshape(len(lo), -1).all(axis=1)


CAM = dict(fov=60, resolution=128, height=72)  # buffer 32 x 18


@pytest.mark.parametrize("offset", np.linspace(0.0, 1.0, 9))
def test_depth_buffer_subpixel_gap_never_hides_object_behind(offset):
    """Two walls with a gap of 0.3 buffer pixels: the thin pole behind the gap is visible
    through it, and must never be culled (a point-sampled buffer culls it for some offsets:
    godot issue 53288)."""
    eye = np.array([0.0, -10.0, 0.0])
    cam = PerspectiveCamera(eye, (0, 1, 0), **CAM)
    pixel = 2 * np.tan(np.radians(30)) * 10.0 / 32  # one buffer pixel at the wall, world units
    gap_lo = (offset - 0.5) * pixel
    gap_hi = gap_lo + 0.3 * pixel
    walls = trimesh.util.concatenate([_quad(-20, gap_lo), _quad(gap_hi, 20)])
    buf = ConservativeDepthBuffer.from_occluders(walls, cam)
    # the pole: seen through the gap (its centre line projects into the gap)
    mid = 0.5 * (gap_lo + gap_hi) * 2.0  # at Y = 10 the gap's centre ray is twice as far out
    lo = np.array([[mid - 0.01 * pixel, 9.9, -1.0]])
    hi = np.array([[mid + 0.01 * pixel, 10.1, 1.0]])
    assert not _hidden_samples(Scene(walls), eye, lo, hi, np.random.default_rng(0), 8).all()
    assert not buf.occluded(lo, hi)[0]


def test_point_sampled_buffer_would_cull_through_gap():
    """The motivation: with one ray per pixel centre the gap disappears for some offset."""
    eye = np.array([0.0, -10.0, 0.0])
    pixel = 2 * np.tan(np.radians(30)) * 10.0 / 32
    culled_somewhere = False
    for offset in np.linspace(0.0, 1.0, 9):
        gap_lo = (offset - 0.5) * pixel
        walls = trimesh.util.concatenate([_quad(-20, gap_lo), _quad(gap_lo + 0.3 * pixel, 20)])
        cam = PerspectiveCamera(eye, (0, 1, 0), fov=60, resolution=32, height=18)
        o, d = cam.rays()
        t, _ = Scene(walls).first_hit(o, d)
        culled_somewhere |= bool(np.isfinite(t).all())  # every centre ray hits a wall
    assert culled_somewhere


def test_depth_buffer_wall_culls_hidden_not_partly_visible():
    wall = trimesh.creation.box(extents=(10, 1, 10))
    cam = PerspectiveCamera((0, -20, 0), (0, 1, 0), **CAM)
    buf = ConservativeDepthBuffer.from_occluders(wall, cam)
    assert buf.shape == (18, 32)
    lo = np.array([[-1, 3, -1], [6.0, 3, -1], [-1, -4, -1], [-1, 0.51, -1]])
    hi = np.array([[1, 4, 1], [9.0, 4, 1], [1, -3, 1], [1, 1, 1]])
    # behind; behind but sticking out past the wall's edge; in front; touching the back face
    assert buf.occluded(lo, hi).tolist() == [True, False, False, True]
    # depths: the buffer never holds a depth nearer than the wall's front face (y = -0.5)
    assert buf.depth[buf.covered].min() >= 19.5 - 1e-6
    assert buf.covered.any() and not buf.covered.all()


def test_depth_buffer_never_culls_boxes_at_or_behind_eye():
    wall = trimesh.creation.box(extents=(10, 1, 10))
    cam = PerspectiveCamera((0, -8, 0), (0, 1, 0), **CAM)
    buf = ConservativeDepthBuffer.from_occluders(wall, cam)
    lo = np.array([[-1, -9, -1], [-1, -12, -1], [-50, 3, -1], [-0.1, -8.1, -0.1]])
    hi = np.array([[1, 4, 1], [1, -11, 1], [-40, 4, 1], [0.1, -7.9, 0.1]])
    # crossing the eye plane; behind; off screen; containing the eye
    assert not buf.occluded(lo, hi).any()


def _city(rng, n=30):
    boxes = []
    for _ in range(n):
        c = rng.uniform([-20, 0, -2], [20, 40, 2])
        e = rng.uniform([1, 1, 2], [6, 6, 8])
        boxes.append(trimesh.creation.box(extents=e, transform=trimesh.transformations
                                          .translation_matrix(c)))
    return boxes


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_depth_buffer_no_false_culls_random_scene(seed):
    """Boxes culled by the buffer are hidden: every corner and sampled point behind an
    occluder; and no culled box shows in a full-resolution id image."""
    rng = np.random.default_rng(seed)
    solids = [(b.vertices, b.faces) for b in _city(rng)]
    occ = OccluderScene(solids)
    assert occ.pieces == len(solids)
    eye = np.array([rng.uniform(-5, 5), -15.0, rng.uniform(-1, 1)])
    cam = PerspectiveCamera(eye, (rng.uniform(-0.3, 0.3), 1, 0), fov=70, resolution=160,
                            height=90)
    buf = ConservativeDepthBuffer.from_occluders(occ, cam)
    centre = rng.uniform([-25, -5, -3], [25, 50, 3], (1500, 3))
    half = rng.uniform(0.05, 1.0, (1500, 3))
    lo, hi = centre - half, centre + half
    culled = buf.occluded(lo, hi)
    assert culled.sum() > 20  # the test has teeth
    assert _hidden_samples(occ.scene, eye, lo[culled], hi[culled], rng, camera=cam).all()
    # full-resolution ground truth: occludees drawn with the occluders
    occludees = [trimesh.creation.box(bounds=[a, b])
                 for a, b in zip(lo[culled], hi[culled], strict=True)]
    world = trimesh.util.concatenate([trimesh.Trimesh(*s) for s in solids] + occludees)
    o, d = cam.rays()
    _, tri = Scene(world).first_hit(o, d)
    first_occludee = sum(len(s[1]) for s in solids)
    assert not (tri >= first_occludee).any()


def test_depth_buffer_solid_beats_facets_and_eye_inside_falls_back():
    """Seen from outside, a box's pixels across its edges are covered (one convex solid);
    from inside, only pixels within one wall are, and culls stay correct."""
    box = trimesh.creation.box(extents=(4, 4, 4))
    cam = PerspectiveCamera((7, -9, 5), (-7, 9, -5), fov=40, resolution=128, height=128)
    solid = ConservativeDepthBuffer.from_occluders(OccluderScene([(box.vertices, box.faces)]),
                                                   cam, width=64, height=64)
    facets = ConservativeDepthBuffer.from_occluders(box, cam, width=64, height=64)
    assert solid.covered.sum() > facets.covered.sum()  # the edges' pixels
    assert (facets.covered <= solid.covered).all()
    # eye inside the box: everything outside is hidden; inside boxes are not culled
    room = PerspectiveCamera((0.3, -0.2, 0.1), (1, 0.2, 0.1), fov=90, resolution=64)
    buf = ConservativeDepthBuffer.from_occluders(OccluderScene([(box.vertices, box.faces)]),
                                                 room, width=32, height=32)
    assert buf.covered.mean() > 0.8
    assert buf.occluded([[3, -0.5, -0.5], [1.0, -0.1, -0.1]],
                        [[4, 0.5, 0.5], [1.2, 0.1, 0.1]]).tolist() == [True, False]


def test_depth_buffer_invalid_input():
    wall = trimesh.creation.box(extents=(10, 1, 10))
    cam = PerspectiveCamera((0, -8, 0), (0, 1, 0), **CAM)
    with pytest.raises(InputError, match="camera"):
        ConservativeDepthBuffer.from_occluders(wall, "camera")
    with pytest.raises(InputError, match="width"):
        ConservativeDepthBuffer.from_occluders(wall, cam, width=0)
    with pytest.raises(InputError, match="occluders"):
        OccluderScene([])
    with pytest.raises(InputError, match="occluders"):
        OccluderScene([42])
    buf = ConservativeDepthBuffer.from_occluders(wall, cam)
    with pytest.raises(InputError, match="lower"):
        buf.occluded([[1, 1, 1]], [[0, 0, 0]])
    assert buf.occluded(np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)


def test_depth_buffer_casting_only_occluder_rectangles_changes_nothing(monkeypatch, rng):
    import viscore.depth_buffer as db

    solids = [(b.vertices, b.faces) for b in _city(rng, 12)]
    occ = OccluderScene(solids)
    cam = PerspectiveCamera((0, -15, 0.5), (0.1, 1, 0.05), fov=70, resolution=160, height=90)
    restricted = ConservativeDepthBuffer.from_occluders(occ, cam)
    cast = db._corners_to_cast(occ._bounds, cam.position, cam.basis,
                               np.tan(np.radians(35)), np.tan(np.radians(35)) * 90 / 160, 40, 22)
    assert 0 < cast.mean() < 1
    monkeypatch.setattr(db, "_corners_to_cast", lambda *a: np.ones((23, 41), bool))
    full = ConservativeDepthBuffer.from_occluders(occ, cam)
    np.testing.assert_array_equal(restricted.depth, full.depth)


@pytest.mark.parametrize("scale", [1e-9, 1e9])
def test_depth_buffer_scale_invariant(scale):
    wall = trimesh.creation.box(extents=(10, 1, 10)).apply_scale(scale)
    cam = PerspectiveCamera(np.array([0, -20, 0]) * scale, (0, 1, 0), **CAM)
    buf = ConservativeDepthBuffer.from_occluders(wall, cam)
    lo = np.array([[-1, 3, -1], [6.0, 3, -1], [-1, -4, -1]]) * scale
    hi = np.array([[1, 4, 1], [9.0, 4, 1], [1, -3, 1]]) * scale
    assert buf.occluded(lo, hi).tolist() == [True, False, False]


def test_depth_buffer_from_generated_solids_hidden_by_the_mesh(rng):
    """End to end: the cow's solid-frusta occluder fed as an Occluder (its convex solids as
    pieces); what the buffer culls is hidden by the cow itself."""
    from viscore.generators.solid_frusta import generate_solid_frusta

    from viscore import load_mesh

    cow = load_mesh("cow")
    occ = generate_solid_frusta(cow, voxels=32, solids=6)
    scene = OccluderScene([occ])
    assert scene.pieces == len(occ.parts["solids"])
    lo_c, hi_c = cow.bounds
    size = float(np.linalg.norm(hi_c - lo_c))
    total = 0
    for _ in range(4):
        d = rng.normal(size=3)
        eye = 0.5 * (lo_c + hi_c) + 1.2 * size * d / np.linalg.norm(d)
        cam = PerspectiveCamera(eye, 0.5 * (lo_c + hi_c) - eye, fov=50, resolution=128,
                                height=128)
        buf = ConservativeDepthBuffer.from_occluders(scene, cam, width=64, height=64)
        centre = 0.5 * (lo_c + hi_c) + rng.normal(size=(600, 3)) * 0.4 * size
        half = rng.uniform(0.002, 0.03, (600, 1)) * size
        culled = buf.occluded(centre - half, centre + half)
        total += int(culled.sum())
        assert _hidden_samples(Scene(cow), eye, (centre - half)[culled], (centre + half)[culled],
                               rng, 16, camera=cam).all()
    assert total > 0
