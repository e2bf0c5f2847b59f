"""The depth buffer's junction rule (viscore.culling._junctions): a pixel covered by the union
of occluder triangles from separate meshes, decided exactly. Two separate triangles at
different depths whose edges overlap by a fraction of a pixel cover the seam's pixels, which
neither covers alone and no other rule covers (each one's boundary crosses them): a box
behind the seam is culled with the rule and not without, and the truth hides it. A gap of a
fraction of a pixel between them keeps the seam open and the box seen through it kept. On
random scenes of separate meshes meeting without shared edges, the pixels the rule adds
are never nearer than the occluders. Triangles sharing edges inside a pixel (a fan, a
quad's halves, a T-junction) cover it, and a thousandth of a pixel opened along the shared
edge keeps it open."""

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
        assert out.shape == (1,) and np.isfinite(out[0]) == expect, push
        if expect:  # the far triangle's farthest point over its half: (-0.5, 0) or (0, 0.5)
            far = 7.0 * np.sqrt(1 + 0.5 ** 2)
            assert far - 1e-6 <= out[0] <= far * (1 + 1e-2)
        alone = junction_depths(t1, [[0, 1, 2]], todo, np.zeros(3), cam.basis, cam._half,
                                cam._half_vertical, 1e-6, 1e-3)
        assert not np.isfinite(alone[0])


def test_the_rule_answers_for_each_tested_pixel_in_row_major_order():
    """Three tested pixels of a 4 x 4 buffer, the same two triangles a thousandth of a pixel
    apart along the diagonal through the pixel (1, 1): the pixel (0, 0), wholly in the near
    one (z = 5), gets its farthest corner's distance, the pixel (1, 1) stays open, and the
    pixel (3, 3), wholly in the far one (z = 7), gets its own; the answers come in
    ``np.nonzero(todo)``'s order."""
    cam = _one_pixel_cam()
    def tri(pts, z):
        return _at(cam, [(x, y, z) for x, y in pts])

    d = 1e-3 / np.sqrt(2) * 0.5
    t1 = tri([(-2, -1.5), (1.5, 2), (-2, 2)], 5.0)
    t2 = tri([(-2 + d, -1.5 - d), (1.5 + d, -1.5 - d), (1.5 + d, 2 - d)], 7.0)
    todo = np.zeros((4, 4), dtype=bool)
    todo[[3, 0, 1], [3, 0, 1]] = True
    out = junction_depths(np.vstack([t1, t2]), [[0, 1, 2], [3, 4, 5]], todo, np.zeros(3),
                          cam.basis, cam._half, cam._half_vertical, 1e-6, 1e-3)
    assert out.shape == (3,)
    corner = np.sqrt(1 + 1 + 1)  # the screen's corners, tangents (+-1, +-1)
    assert 5.0 * corner - 1e-6 <= out[0] <= 5.0 * corner * (1 + 1e-2)
    assert not np.isfinite(out[1])
    assert 7.0 * corner - 1e-6 <= out[2] <= 7.0 * corner * (1 + 1e-2)


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


def _one_pixel_cam():
    """A 4 x 4 buffer of 90 degrees: the pixel (1, 1) spans tangents x in [-0.5, 0] and
    y in [0, 0.5]."""
    return PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 1, 0), fov=90, resolution=4,
                             height=4)


def _shared_edge_mesh(kind: str, gap_px: float):
    """Triangles sharing edges over the pixel (1, 1) of :func:`_one_pixel_cam`, at depth 6,
    tangent coordinates turned by 0.3 rad around a point inside the pixel: a fan of four
    around a vertex inside it (``fan``), a quad's two halves along a diagonal through it
    (``quad``), or a quad's half split again at a point on that diagonal inside the pixel
    (``tjunction``). ``gap_px`` > 0 moves every triangle but the first that far away from
    the first across their shared edge (the fan's from its vertex to corner 1, the
    diagonal), in buffer pixels (0.5 tangent units each): a gap along that edge."""
    c = np.array([-0.23, 0.31])
    s, ang = 1.5, 0.3
    rot = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
    sq = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1.0]]) * s
    if kind == "fan":  # the edge from the centre to corner 1 shared
        pts = np.vstack([sq, [0.02, -0.03]])
        tris = [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]
        cut = (4, 1)
    else:  # the diagonal 0-2 shared
        tris = [[0, 1, 2], [0, 2, 3]] if kind == "quad" else [[0, 1, 2], [0, 4, 3], [4, 2, 3]]
        pts = sq if kind == "quad" else np.vstack([sq, 0.48 * sq[0] + 0.52 * sq[2]])
        cut = (0, 2)
    e = pts[cut[1]] - pts[cut[0]]
    normal = np.array([-e[1], e[0]]) / np.linalg.norm(e)
    if normal @ (pts[tris[0]].mean(axis=0) - pts[cut[0]]) > 0:
        normal = -normal  # away from the first triangle: the others moved open a gap
    cam = _one_pixel_cam()
    verts, faces = [], []
    for k, t in enumerate(tris):
        p = pts[t] + (0.5 * gap_px * normal if k else 0.0)
        faces.append([len(verts), len(verts) + 1, len(verts) + 2])
        verts.extend(p @ rot.T + c)
    world = _at(cam, [(x, y, 6.0) for x, y in verts])
    return world, np.array(faces)


@pytest.mark.parametrize("kind", ["fan", "quad", "tjunction"])
def test_triangles_sharing_edges_cover_the_pixel_and_a_gap_along_one_does_not(kind):
    """The copies of a shared edge give bit-identical crossings, and the crossings of a fan's
    edges at its vertex or of a T-junction's lines a rounding apart leave no piece: the
    pixel is covered, at the plane's farthest point over it; a thousandth of a pixel open
    along the shared edge keeps it open."""
    cam = _one_pixel_cam()
    todo = np.zeros((4, 4), dtype=bool)
    todo[1, 1] = True
    args = (todo, np.zeros(3), cam.basis, cam._half, cam._half_vertical, 1e-6, 1e-3)
    v, f = _shared_edge_mesh(kind, 0.0)
    out = junction_depths(v, f, *args)
    # a plane at z = 6 facing the eye: farthest over the widened pixel at its corner
    # (-0.5, 0.5), at least at the nearest point (0, 0)
    far = 6.0 * np.sqrt(1 + 0.5 ** 2 + 0.5 ** 2)
    assert out.shape == (1,) and 6.0 <= out[0] <= far * (1 + 1e-2)
    v, f = _shared_edge_mesh(kind, 1e-3)
    assert not np.isfinite(junction_depths(v, f, *args)[0])


def _seam_with_shared_edges(cam, gap_px: float) -> list[trimesh.Trimesh]:
    """:func:`_halves`' seam, overlapping by 0.4 pixel, with each half made of triangles
    sharing edges inside the seam's column: the left one a fan from a far-left vertex to
    points along its right edge (the fan's edges reach it inside the seam's pixels), the
    right one a T-junction: the lower triangles meet at a point of the upper one's lower
    edge 0.6 pixel right of its left edge (right of the left half's cover), and one of
    their shared edges runs nearly upright through the seam's column there. ``gap_px`` > 0
    moves the two triangles right of that shared edge right by that many buffer pixels:
    a gap along it."""
    tan = _pixel_tangent()
    seam = 0.37 * tan
    a, b = seam + 0.2 * tan, seam - 0.2 * tan
    ys = [-10.0, -0.21, -0.011, 0.013, 0.11, 10.0]
    left_pts = [(-10.0, 0.0, 10.0)] + [(a, y, 10.0) for y in ys]
    left_faces = [[0, k + 2, k + 1] for k in range(len(ys) - 1)]
    left = trimesh.Trimesh(_at(cam, left_pts), left_faces, process=False)
    c, y0, d = b + 0.6 * tan, 0.0171, gap_px * tan
    right_pts = [(b, y0, 12), (10, y0, 12), (b, 10, 12),            # upper: A
                 (b, -10, 12), (c, y0, 12), (b, y0, 12),            # lower left: B
                 (b + d, -10, 12), (10 + d, -10, 12), (c + d, y0, 12),  # C1, right of B
                 (10 + d, -10, 12), (10 + d, y0, 12), (c + d, y0, 12)]  # C2
    right = trimesh.Trimesh(_at(cam, right_pts), np.arange(12).reshape(4, 3), process=False)
    return [left, right]


def test_a_seam_of_halves_sharing_edges_is_covered_and_a_gap_along_one_keeps_it_open():
    """Each side of the seam is triangles sharing edges inside the seam's pixels (a fan's
    edges, a T-junction and a shared edge running along the seam's column): the junction
    rule covers every pixel of the seam, never nearer than the triangles, and the box
    behind it is culled, as the truth hides it. A thousandth of a pixel opened along the
    shared edge keeps its pixels open and the box kept."""
    cam = PerspectiveCamera((0, 0, 0), (0, 0, 1), up=(0, 1, 0), **_CAM)
    parts = _seam_with_shared_edges(cam, 0.0)
    on, off = _buffers(parts, cam)
    seam_col = 64
    assert not off.covered[:, seam_col].any()  # no other rule covers the seam
    assert on.covered.all()
    hits = _sampled_first_hits(Scene(trimesh.util.concatenate(parts)), cam, on.shape,
                               np.argwhere(~off.covered), np.random.default_rng(1), per=32)
    assert np.isfinite(hits).all()
    assert (hits <= on.depth[:, seam_col][:, None]).all()
    box = _seam_box(cam)
    assert not _seen(parts, box, cam)
    assert on.occluded(*box)[0] and not off.occluded(*box)[0]
    # the gap runs down the seam's column from the T-junction's row (tangent 0.0171)
    opened = _seam_with_shared_edges(cam, 1e-3)
    gap_on, _ = _buffers(opened, cam)
    below = np.arange(on.shape[0]) > 36 - 0.0171 / _pixel_tangent()
    assert not gap_on.covered[below, seam_col].any()
    assert not gap_on.occluded(*box)[0]
