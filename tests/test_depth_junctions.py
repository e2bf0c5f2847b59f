"""The depth buffer's junction rule (viscore.culling._junctions): a pixel covered by the union
of occluder triangles from separate meshes, decided exactly. Two separate triangles at
different depths whose edges overlap by a fraction of a pixel cover the seam's pixels, which
neither covers alone and no other rule covers (each one's boundary crosses them): a box
behind the seam is culled with the rule and not without, and the truth hides it. A gap of a
fraction of a pixel between them keeps the seam open and the box seen through it kept. On
random scenes of separate meshes meeting without shared edges, the pixels the rule adds
are never nearer than the occluders."""

import numpy as np
import pytest
import trimesh
from test_depth_patches import _sampled_first_hits

from viscore import PerspectiveCamera, Scene
from viscore.culling._junctions import junction_depths
from viscore.culling.depth_buffer import ConservativeDepthBuffer, OccluderScene

#: A 256 x 144 camera of 60 degrees: a buffer of 128 x 72 (the default reduction, 2).
_CAM = dict(fov=60, resolution=256, height=144)


def _pixel_tangent() -> float:
    """A buffer pixel's width in tangent units."""
    return 2 * np.tan(np.radians(30)) / 128


def _at(cam, points) -> np.ndarray:
    """World points at camera tangents ``(x, y)`` and forward depth ``z``, rows of
    ``points``."""
    f, r, u = cam.basis
    return np.array([z * (f + x * r + y * u) for x, y, z in points]) + cam.position


def _halves(cam, overlap_px: float) -> list[trimesh.Trimesh]:
    """Two separate triangles facing the eye: ``left`` at depth 10 covering the screen left
    of its vertical right edge, ``right`` at depth 12 covering it right of its vertical left
    edge; their images overlap by ``overlap_px`` buffer pixels (a gap when negative) around
    a tangent 0.37 pixel right of the centre (inside the pixel column 64)."""
    tan = _pixel_tangent()
    x = 0.5 * overlap_px * tan
    seam = 0.37 * tan
    a, b = seam + x, seam - x
    left = trimesh.Trimesh(_at(cam, [(a, -10, 10), (-10, 0, 10), (a, 10, 10)]), [[0, 1, 2]],
                           process=False)
    right = trimesh.Trimesh(_at(cam, [(b, -10, 12), (b, 10, 12), (10, 0, 12)]), [[0, 1, 2]],
                            process=False)
    return [left, right]


def _seam_box(cam) -> tuple[list, list]:
    """A box at depths 20 to 21 around the seam's tangent, two pixels wide."""
    c = _at(cam, [(0.37 * _pixel_tangent(), 0, 20.5)])[0]
    half = np.array([20 * _pixel_tangent(), 0.5, 0.5])
    return [list(c - half)], [list(c + half)]


def _buffers(parts, cam):
    on = OccluderScene(parts)
    off = OccluderScene(parts)
    off._junction_rule = False
    return (ConservativeDepthBuffer.from_occluders(on, cam),
            ConservativeDepthBuffer.from_occluders(off, cam))


def _seen(parts, box, cam) -> bool:
    """Whether the box shows in a full-resolution id image of the parts and the box."""
    lo, hi = np.asarray(box[0][0], float), np.asarray(box[1][0], float)
    mesh = trimesh.creation.box(bounds=[lo, hi])
    o, d = cam.rays()
    first = sum(len(p.faces) for p in parts)
    _, tri = Scene(trimesh.util.concatenate([*parts, mesh])).first_hit(o, d)
    return bool((tri >= first).any())


def test_two_separate_triangles_overlapping_cover_the_seam_and_cull_behind_it():
    cam = PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 1, 0), **_CAM)
    parts = _halves(cam, 0.4)
    on, off = _buffers(parts, cam)
    seam_col = 64  # the seam's tangent 0.37 pixel right of the centre: column 64
    assert not off.covered[:, seam_col].any()  # no other rule covers the seam
    assert off.covered[:, :seam_col].all() and off.covered[:, seam_col + 1:].all()
    assert on.covered.all()  # the two together cover every pixel of the seam
    # its depth: never nearer than the triangles, at most the far one's (z = 12) over the
    # pixel (a plane facing the eye: its distance grows off-axis), plus the margin
    hits = _sampled_first_hits(Scene(trimesh.util.concatenate(parts)), cam, on.shape,
                               np.argwhere(~off.covered), np.random.default_rng(0), per=32)
    assert (hits <= on.depth[:, seam_col][:, None]).all()
    corner_far = 12 * np.sqrt(1 + (2 * _pixel_tangent()) ** 2 + np.tan(np.radians(30)) ** 2
                              * (16 / 9) ** 2 * 1.01)
    assert (on.depth[:, seam_col] <= corner_far).all()
    box = _seam_box(cam)  # behind the seam
    assert not _seen(parts, box, cam)  # the truth hides it
    assert on.occluded(*box)[0] and not off.occluded(*box)[0]


def test_a_gap_between_them_keeps_the_seam_open_and_the_box_seen_through_it():
    cam = PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 1, 0), **_CAM)
    parts = _halves(cam, -0.4)
    on, off = _buffers(parts, cam)
    assert not on.covered[:, 64].any()
    assert (on.depth == off.depth).all()
    box = _seam_box(cam)
    assert _seen(parts, box, cam)  # seen through the gap
    assert not on.occluded(*box)[0]


def test_the_cover_test_directly_on_one_pixel():
    """The kernel on one pixel: two squares' halves meeting along the pixel's diagonal cover
    it; pushed apart by a thousandth of a pixel they do not; one alone never does."""
    cam = PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 1, 0), fov=90, resolution=4,
                            height=4)
    # the pixel (1, 1) of a 4 x 4 buffer spans tangents x in [-0.5, 0], y in [0, 0.5]
    def tri(pts, z):
        return _at(cam, [(x, y, z) for x, y in pts])

    for push, expect in ((0.0, True), (-0.01, True), (1e-3, False)):
        t1 = tri([(-2, -1.5), (1.5, 2), (-2, 2)], 5.0)  # above the diagonal y = x + 0.5
        d = push / np.sqrt(2) * 0.5  # a thousandth of a pixel of 0.5 tangent units
        t2 = tri([(-2 + d, -1.5 - d), (1.5 + d, -1.5 - d), (1.5 + d, 2 - d)], 7.0)
        v = np.vstack([t1, t2])
        todo = np.zeros((4, 4), dtype=bool)
        todo[1, 1] = True
        out = junction_depths(v, [[0, 1, 2], [3, 4, 5]], todo, np.zeros(3), cam.basis,
                              cam._half, cam._half_vertical, 1e-6, 1e-3)
        assert np.isfinite(out[1, 1]) == expect, push
        if expect:  # the far triangle's farthest point over its half: (-0.5, 0) or (0, 0.5)
            far = 7.0 * np.sqrt(1 + 0.5 ** 2)
            assert far - 1e-6 <= out[1, 1] <= far * (1 + 1e-2)
        alone = junction_depths(t1, [[0, 1, 2]], todo, np.zeros(3), cam.basis, cam._half,
                                cam._half_vertical, 1e-6, 1e-3)
        assert not np.isfinite(alone[1, 1])


def _random_scene(rng, kind):
    """Separate meshes meeting without shared edges: a ground of quads with T-junctions and
    walls with roofs laid on them (kind 0), or loose triangles (kind 1)."""
    parts = []
    if kind == 0:
        n, size = 5, 40.0
        step = size / n
        for a in range(n):
            for b in range(n):
                x0, y0 = a * step - size / 2, b * step - size / 2
                q = np.array([[x0, y0, 0], [x0 + step, y0, 0], [x0 + step, y0 + step, 0],
                              [x0, y0 + step, 0.0]])
                m = np.r_[x0 + step * rng.uniform(0.2, 0.8), y0, 0]
                parts.append(trimesh.Trimesh(np.vstack([q, m]), [[0, 4, 3], [4, 1, 2],
                                                                 [4, 2, 3]], process=False))
        for _ in range(int(rng.integers(2, 6))):
            c = rng.uniform(-15, 15, 2)
            ext = rng.uniform(2, 8, 2)
            hgt = rng.uniform(2, 8)
            walls = trimesh.creation.box(extents=(ext[0], ext[1], hgt))
            walls.apply_translation([c[0], c[1], hgt / 2])
            keep = np.abs(walls.face_normals[:, 2]) < 0.5
            parts.append(trimesh.Trimesh(walls.vertices, walls.faces[keep], process=False))
            over = rng.uniform(-0.3, 0.5)
            lo, hi = c - ext / 2 - over, c + ext / 2 + over
            apex = np.r_[c + rng.uniform(-0.5, 0.5, 2), hgt + rng.uniform(0.5, 4)]
            v = np.array([[lo[0], lo[1], hgt], [hi[0], lo[1], hgt], [hi[0], hi[1], hgt],
                          [lo[0], hi[1], hgt], apex])
            parts.append(trimesh.Trimesh(v, [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
                                         process=False))
    else:
        for _ in range(int(rng.integers(10, 50))):
            c = rng.uniform(-10, 10, 3) * [1, 1, 0.2]
            parts.append(trimesh.Trimesh(c + rng.normal(size=(3, 3)) * rng.uniform(1, 6),
                                         [[0, 1, 2]], process=False))
    return parts


@pytest.mark.parametrize("seed", range(6))
def test_random_junctions_are_never_nearer_than_the_occluders(seed):
    rng = np.random.default_rng(100 + seed)
    parts = _random_scene(rng, seed % 2)
    target = np.r_[rng.uniform(-5, 5, 2), rng.uniform(0, 3)]
    eye = target + rng.normal(size=3) * rng.choice([10.0, 30.0])
    eye[2] = abs(eye[2]) + 1.0
    cam = PerspectiveCamera(eye, target - eye, up=(0, 0, 1), fov=70, resolution=160, height=90)
    on, off = _buffers(parts, cam)
    assert (on.covered >= off.covered).all()
    assert (on.depth[off.covered] == off.depth[off.covered]).all()
    new = np.argwhere(on.covered & ~off.covered)
    if len(new):
        hits = _sampled_first_hits(Scene(trimesh.util.concatenate(parts)), cam, on.shape, new,
                                   rng, per=48)
        assert np.isfinite(hits).all()
        assert (hits <= on.depth[new[:, 0], new[:, 1]][:, None]).all()
