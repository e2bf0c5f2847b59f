"""Occludees tested through their own triangles, pixel by pixel (``--bounds triangles``)."""

import numpy as np
import pytest
import trimesh

from viscore import InputError, PerspectiveCamera, Scene
from viscore.culling.depth_buffer import ConservativeDepthBuffer
from viscore.culling.occludee_bounds import object_triangles, occludee_boxes, parse_bounds
from viscore.level.scene_graph import load_scene_objects
from viscore.metrics import culling

#: A 64 x 36 camera at the origin looking along +z, y up (its right is -x): a 16 x 9
#: buffer, 90 degrees wide.
CAM = PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 1, 0), fov=90, resolution=64, height=36)


def _buffer(depth):
    return ConservativeDepthBuffer(depth=np.asarray(depth, dtype=np.float64), camera=CAM,
                                   hits=0)


def _ray_hits(tri, d):
    """(m, n) distance along unit rays ``d`` (n, 3) from the origin to triangles ``tri``
    (m, 3, 3); inf on a miss (Moller-Trumbore)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    e1, e2 = b - a, c - a
    p = np.cross(d[None], e2[:, None])
    det = np.einsum("mj,mnj->mn", e1, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = -a[:, None]
        uu = np.einsum("mnj,mnj->mn", s, p) * inv
        q = np.cross(s, e1[:, None])
        vv = np.einsum("nj,mnj->mn", d, q) * inv
        t = np.einsum("mj,mnj->mn", e2, q) * inv
    hit = (np.abs(det) > 1e-14) & (uu >= 0) & (vv >= 0) & (uu + vv <= 1) & (t > 0)
    return np.where(hit, t, np.inf)


def _dense_rays(shape, n):
    """Unit directions of an (n + 1) x (n + 1) grid of rays through every pixel of a buffer
    of ``shape`` over CAM's view, edges and corners included; and each ray's pixel."""
    h, w = shape
    hx = np.tan(np.radians(45.0))
    hy = hx * 36 / 64
    g = np.linspace(0.0, 1.0, n + 1)
    i, j, a, b = np.meshgrid(np.arange(h), np.arange(w), g, g, indexing="ij")
    x = ((j + b) / w - 0.5) * 2 * hx
    y = (0.5 - (i + a) / h) * 2 * hy
    f, r, u = CAM.basis
    d = (x[..., None] * r + y[..., None] * u + f).reshape(-1, 3)
    return d / np.linalg.norm(d, axis=1)[:, None], i.reshape(-1), j.reshape(-1)


@pytest.mark.parametrize("seed", [0, 1])
def test_occluded_triangles_never_hides_a_triangle_a_ray_sees_nearer_than_the_buffer(seed):
    """A random buffer (depths 3-10, some pixels empty) and 300 random triangles in front of
    the eye, some reaching outside the view: a triangle called hidden is met by no ray of
    a dense grid through the buffer's pixels (edges and corners included) at or nearer than
    its pixel's depth; and the test is tight enough to hide many."""
    rng = np.random.default_rng(seed)
    depth = rng.uniform(3.0, 10.0, (9, 16))
    depth[rng.random(depth.shape) < 0.05] = np.inf
    centre = rng.uniform([-12, -7, 4], [12, 7, 14], (300, 3))
    tri = centre[:, None] + rng.normal(0.0, 0.6, (300, 3, 3))
    hidden = _buffer(depth).occluded_triangles(tri, np.arange(301))
    d, i, j = _dense_rays(depth.shape, 12)
    t = _ray_hits(tri, d)
    seen = (np.isfinite(t) & (t <= depth[i, j][None])).any(axis=1)
    assert not (hidden & seen).any()
    assert hidden.sum() > 60 and seen.sum() > 30  # the test has teeth both ways


def test_triangles_cull_a_diagonal_sliver_that_its_box_does_not():
    """Two walls, lower-left and upper-right, overlapping at the centre: a thin sliver along
    the diagonal behind them is hidden, its box (reaching the two open quadrants) is not."""
    walls = trimesh.util.concatenate([
        trimesh.creation.box(bounds=[[-9, -9, 2.9], [0.3, 0.3, 3.1]]),
        trimesh.creation.box(bounds=[[-0.3, -0.3, 2.9], [9, 9, 3.1]])])
    buf = ConservativeDepthBuffer.from_occluders(walls, CAM)
    sliver = np.array([[[-3.0, -1.5, 6.0], [3.0, 1.5, 6.0], [3.0, 1.45, 6.0]]])
    assert buf.occluded_triangles(sliver, [0, 1]).tolist() == [True]
    assert buf.occluded(sliver.min(axis=1), sliver.max(axis=1)).tolist() == [False]


def test_triangles_outside_the_view_are_hidden_where_their_box_meets_it():
    """A triangle right of the view pyramid (x > z at every vertex) whose box reaches into it
    (the corner (3, 0, 9)): hidden with no occluder at all; its box is not."""
    buf = _buffer(np.full((9, 16), np.inf))
    tri = np.array([[[3.0, 0.0, 1.0], [10.0, 0.0, 9.0], [10.0, 0.0, 1.0]]])
    assert buf.occluded_triangles(tri, [0, 1]).tolist() == [True]
    assert buf.occluded(tri.min(axis=1), tri.max(axis=1)).tolist() == [False]
    # in view, or through the eye, or behind it and in front: never hidden without a depth
    more = np.array([[[-1, -1, 5], [1, -1, 5], [0, 1, 5]], [[-1, 0, -1], [1, 0, -1], [0, 0, 1]]],
                    dtype=float)
    assert buf.occluded_triangles(more, [0, 1, 2]).tolist() == [False, False]
    # a group is hidden only when all its triangles are
    assert buf.occluded_triangles(np.concatenate([tri, more]), [0, 2, 3]).tolist() == [False,
                                                                                       False]


@pytest.mark.parametrize("offset", np.linspace(0.0, 1.0, 5))
def test_triangles_seen_through_a_gap_narrower_than_a_pixel_are_not_culled(offset):
    """Two walls with a gap of 0.4 buffer pixels, anywhere across a pixel: an object behind
    the gap, visible through it in the ray-cast truth, is never culled through its
    triangles; the same object behind the closed wall is."""
    pixel = 2.0 * 3.0 / 16  # one buffer pixel at the walls (z = 3), world units
    gap_lo = (offset - 0.5) * pixel
    gap_hi = gap_lo + 0.4 * pixel
    walls = [trimesh.creation.box(bounds=[[-20, -20, 2.9], [gap_lo, 20, 3.0]]),
             trimesh.creation.box(bounds=[[gap_hi, -20, 2.9], [20, 20, 3.0]])]
    mid = (gap_lo + gap_hi)  # the gap's centre line, at z = 6
    scene = trimesh.Scene()
    for k, wall in enumerate(walls):
        scene.add_geometry(wall, geom_name=f"wall{k}", node_name=f"wall{k}")
    panel = trimesh.creation.box(bounds=[[mid - 1.0, -1, 6.0], [mid + 1.0, 1, 6.1]])
    scene.add_geometry(panel, geom_name="panel", node_name="panel")
    objects = load_scene_objects(scene)
    pose = culling.PathCamera(position=np.zeros(3), forward=np.array([0.0, 0.0, 1.0]),
                              up=np.array([0.0, 1.0, 0.0]), fov=90.0)
    runtimes = {"depth": culling.depth_buffer_runtime(walls)}
    bounds = occludee_boxes(objects, *parse_bounds("triangles"))[0]
    r = culling.simulate_culling(objects, runtimes, [pose], width=256, height=144,
                                 bounds=bounds)
    assert r.visible.tolist() == [3]  # the panel is seen through the gap
    assert r.runtimes["depth"].culled.tolist() == [0]
    assert r.runtimes["depth"].false_culls.tolist() == [0]
    # closed: one wall; the panel culled by its triangles
    closed = trimesh.creation.box(bounds=[[-20, -20, 2.9], [20, 20, 3.0]])
    buf = ConservativeDepthBuffer.from_occluders(closed, CAM)
    assert buf.occluded_triangles(panel.triangles, [0, len(panel.triangles)]).tolist() == [True]
    assert Scene(closed).first_hit(np.zeros(3)[None], np.array([[mid / 6, 0, 1.0]]))[1][0] >= 0


def test_object_triangles_are_world_triangles_by_object():
    scene = trimesh.Scene()
    box = trimesh.creation.box(extents=(1, 1, 1))
    scene.add_geometry(box, geom_name="a", node_name="a")
    scene.add_geometry(box, geom_name="b", node_name="b",
                       transform=trimesh.transformations.translation_matrix([10, 0, 0]))
    objects = load_scene_objects(scene)
    lo, hi, owner, tri = object_triangles(objects)
    assert owner.tolist() == [0] * 12 + [1] * 12
    assert np.allclose(tri[owner == 1].reshape(-1, 3).min(axis=0), [9.5, -0.5, -0.5])
    assert np.array_equal(lo, tri.min(axis=1)) and np.array_equal(hi, tri.max(axis=1))
    assert parse_bounds("triangles") == ("triangles", 1)
    with pytest.raises(InputError, match="--bounds"):
        parse_bounds("triangles:4")
    bounds, kind, split = occludee_boxes(objects, "triangles", 1)
    assert kind == "triangles" and split == 2 and len(bounds) == 4


def test_occluded_triangles_invalid_input():
    buf = _buffer(np.full((9, 16), np.inf))
    tri = np.zeros((2, 3, 3))
    for bad_tri, start, match in [(np.zeros((2, 3)), [0, 2], "triangles"),
                                  (np.full((1, 3, 3), np.nan), [0, 1], "triangles"),
                                  (tri, [0, 1], "start"), (tri, [1, 2], "start"),
                                  (tri, [0, 2, 1, 2], "start"), (tri, [0.0, 2.0], "start")]:
        with pytest.raises(InputError, match=match):
            buf.occluded_triangles(bad_tri, start)
    assert buf.occluded_triangles(np.zeros((0, 3, 3)), [0]).shape == (0,)


def test_triangles_under_a_ground_seen_at_a_grazing_angle_are_culled_by_its_plane():
    """A ground quad (two triangles, one planar facet) 1.7 under an eye looking along it,
    and a slab 0.3 under the ground from 15 to 40 ahead: every ray to the slab crosses the
    ground first (hidden), yet two buffer pixels under the horizon a pixel of the ground
    spans depths from 23 to 35 (1.4 degrees), beyond the slab's nearest there, so depths
    alone keep it. The pixel's plane culls it; the same slab 0.3 over the ground (seen)
    is never culled."""
    eye = np.array([0.0, 1.7, 0.0])
    cam = PerspectiveCamera(eye, (0, 0, 1), up=(0, 1, 0), fov=90, resolution=256, height=144)
    ground = trimesh.Trimesh([[-4000, 0, -1], [4000, 0, -1], [4000, 0, 4000],
                              [-4000, 0, 4000]], [[0, 2, 1], [0, 3, 2]])
    buf = ConservativeDepthBuffer.from_occluders(ground, cam)
    under = trimesh.creation.box(bounds=[[-3, -0.4, 15], [3, -0.3, 40]])
    over = trimesh.creation.box(bounds=[[-3, 0.3, 15], [3, 0.4, 40]])
    # the truth: every ray from the eye to the slab's corners meets the ground first
    ends = under.vertices - eye
    t_ground = 1.7 / -ends[:, 1]  # fraction of the way at which y reaches 0
    assert (t_ground < 1).all()
    assert buf.occluded_triangles(under.triangles, [0, len(under.triangles)]).tolist() == [True]
    assert buf.occluded_triangles(over.triangles, [0, len(over.triangles)]).tolist() == [False]
    # depths alone (no planes) keep the slab under the ground: the plane rule culls it
    bare = ConservativeDepthBuffer(depth=buf.depth, camera=cam, hits=0)
    assert bare.occluded_triangles(under.triangles, [0, len(under.triangles)]).tolist() \
        == [False]
    assert np.isfinite(buf.plane[..., 3]).any()
