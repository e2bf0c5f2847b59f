"""The depth buffer's sheet rule (viscore.culling._sheets): a pixel covered by the union of
edge-connected occluder triangles of any shape. Three faces meeting at a corner cover the
pixels around their vertex, which no triangle, flat, pair or region covers alone; a hole
or a slit between triangles keeps its pixels open; on folded sheets of many small
triangles, seen from random eyes, covered pixels are never nearer than the sheet and
nothing seen is culled."""

import numpy as np
import pytest
import trimesh
from test_depth_patches import _sampled_first_hits

from viscore import PerspectiveCamera, Scene
from viscore.culling._sheets import mesh_sheets
from viscore.culling.depth_buffer import ConservativeDepthBuffer, OccluderScene


def _buffers(mesh, cam):
    """The buffer with every rule, and without the sheet rule, the junction rule (which
    covers the same pixels by the union of the triangles sharing edges there) and the
    occludee test's cover rule (which does the same for an occludee's pixels)."""
    occ = OccluderScene([mesh])
    plain = OccluderScene([mesh])
    plain._sheet_rule = plain._junction_rule = plain._cover_rule = False
    return (ConservativeDepthBuffer.from_occluders(occ, cam),
            ConservativeDepthBuffer.from_occluders(plain, cam))


def _corner(subdivisions: int = 0) -> trimesh.Trimesh:
    """The three faces of the cube [0, 10]^3 that meet at (10, 10, 10), open (no other
    face), each of two triangles, subdivided ``subdivisions`` times."""
    box = trimesh.creation.box(bounds=[[0, 0, 0], [10, 10, 10]])
    keep = (box.face_normals > 0.5).any(axis=1)
    mesh = trimesh.Trimesh(box.vertices, box.faces[keep], process=False)
    for _ in range(subdivisions):
        mesh = mesh.subdivide()
    return mesh


def _never_nearer(mesh, cam, buf, mask, rng, per=48):
    pixels = np.argwhere(mask)
    hits = _sampled_first_hits(Scene(mesh), cam, buf.shape, pixels, rng, per=per)
    assert np.isfinite(hits).all()  # every ray through a covered pixel meets the sheet
    assert (hits <= buf.depth[pixels[:, 0], pixels[:, 1]][:, None]).all()


def _seen(world_parts, cam, first_occludee):
    """Whether any triangle from index ``first_occludee`` on shows in a full-resolution
    id image of the parts put together."""
    o, d = cam.rays()
    _, tri = Scene(trimesh.util.concatenate(world_parts)).first_hit(o, d)
    return bool((tri >= first_occludee).any())


def test_mesh_sheets_join_across_shared_edges_only():
    corner = _corner()
    sheet, edges = mesh_sheets(corner.vertices, corner.faces)
    assert (sheet == 0).all()
    creases = edges[edges[:, 3] >= 0]
    assert len(creases) == 3 + 3  # the three faces' diagonals and the three creases
    assert (edges[edges[:, 3] < 0, 5] == -1).all() and len(edges) == 6 + 6  # the border
    # two triangles touching at a vertex only, and one alone: no sheet
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0.0]])
    assert (mesh_sheets(v, [[0, 1, 2], [0, 3, 4]])[0] == -1).all()
    # split vertices (as glTF writes them) are joined by their coordinates
    split = trimesh.Trimesh(corner.triangles.reshape(-1, 3),
                            np.arange(3 * len(corner.faces)).reshape(-1, 3), process=False)
    assert (mesh_sheets(split.vertices, split.faces)[0] == 0).all()


@pytest.mark.parametrize("subdivisions", [0, 2])
def test_three_faces_at_a_corner_cover_its_vertex_and_a_box_behind_it_is_culled(
        subdivisions):
    """Seen along the diagonal, the pixels around the vertex have their corners on three
    faces: no flat, pair or region covers them; the sheet does, never nearer than the faces,
    and a box behind the vertex (hidden: the truth) is culled only with it."""
    corner = _corner(subdivisions)
    cam = PerspectiveCamera((25, 25, 25), (-1, -1, -1), up=(0, 1, 0), fov=40, resolution=256,
                            height=144)
    buf, plain = _buffers(corner, cam)
    assert (buf.covered >= plain.covered).all()
    new = buf.covered & ~plain.covered
    h, w = buf.shape
    around = np.s_[h // 2 - 2:h // 2 + 2, w // 2 - 2:w // 2 + 2]  # the vertex's pixels
    assert buf.covered[around].all() and new[around].sum() == 3
    _never_nearer(corner, cam, buf, new, np.random.default_rng(subdivisions))
    box = ([[4.5, 4.5, 4.5]], [[5.5, 5.5, 5.5]])
    assert buf.occluded(*box)[0] and not plain.occluded(*box)[0]
    tri = trimesh.creation.box(bounds=np.vstack(box)).triangles
    assert buf.occluded_triangles(tri, [0, len(tri)])[0]
    assert not plain.occluded_triangles(tri, [0, len(tri)])[0]
    occludee = trimesh.creation.box(bounds=np.vstack(box))
    assert not _seen([corner, occludee], cam, len(corner.faces))


def test_a_hole_at_the_corner_keeps_its_pixels_open_and_a_box_seen_through_it_is_kept():
    """The subdivided corner without the triangles around its vertex: a hole whose
    border edges cross the pixels there; a box behind it shows through and is never
    culled, and no pixel the hole's rays pass through is covered."""
    corner = _corner(3)
    far = np.linalg.norm(corner.triangles_center - 10.0, axis=1) > 1.2
    holed = trimesh.Trimesh(corner.vertices, corner.faces[far], process=False)
    cam = PerspectiveCamera((25, 25, 25), (-1, -1, -1), up=(0, 1, 0), fov=40, resolution=256,
                            height=144)
    buf, _ = _buffers(holed, cam)
    occludee = trimesh.creation.box(bounds=[[4.5, 4.5, 4.5], [5.5, 5.5, 5.5]])
    assert _seen([holed, occludee], cam, len(holed.faces))  # the truth: it shows
    assert not buf.occluded([[4.5, 4.5, 4.5]], [[5.5, 5.5, 5.5]])[0]
    tri = occludee.triangles
    assert not buf.occluded_triangles(tri, [0, len(tri)])[0]
    # a ray through the hole's middle misses the sheet: its pixel stays open
    h, w = buf.shape
    assert not buf.covered[h // 2, w // 2]
    _never_nearer(holed, cam, buf, buf.covered, np.random.default_rng(3), per=8)


def test_a_slit_between_two_faces_keeps_its_pixels_open():
    """Two faces of the corner apart by a slit far narrower than a pixel (they share no
    edge): their sides are boundary edges, the pixels along the slit stay open, and a
    thin box behind it, seen through the slit, is never culled."""
    corner = _corner(1)
    top = corner.triangles_center[:, 1] > 10 - 1e-9
    v = corner.vertices[corner.faces].reshape(-1, 3).copy()
    moved = np.repeat(top, 3)
    v[moved, 1] += 1e-3  # the top face lifted: a slit along its edges
    slit = trimesh.Trimesh(v, np.arange(len(v)).reshape(-1, 3), process=False)
    sheet, _ = mesh_sheets(slit.vertices, slit.faces)
    assert len(np.unique(sheet[top])) == 1 and sheet[top][0] not in sheet[~top]
    cam = PerspectiveCamera((25, 25, 25), (-1, -1, -1), up=(0, 1, 0), fov=40, resolution=256,
                            height=144)
    buf, _ = _buffers(slit, cam)
    _never_nearer(slit, cam, buf, buf.covered, np.random.default_rng(4), per=8)
    # rays along the slit pass between the faces: each pixel crossing it stays open
    fine = PerspectiveCamera((25, 25, 25), (-1, -1, -1), up=(0, 1, 0), fov=40,
                             resolution=2048, height=1152)
    o, d = fine.rays()
    _, tri = Scene(slit).first_hit(o, d)
    h, w = buf.shape
    rows, cols = np.nonzero((tri < 0).reshape(1152, 2048))
    seen = (rows * h) // 1152, (cols * w) // 2048
    lit = np.zeros((h, w), dtype=bool)
    lit[seen] = True
    assert lit[h // 4:3 * h // 4, w // 4:3 * w // 4].any()  # the slit is seen in the middle
    assert not (buf.covered & lit).any()  # every pixel a ray passes through stays open


def _crumpled(rng, n=40):
    """A sheet of 2 (n - 1)^2 triangles over a square, displaced along all three axes by
    smooth random bumps big enough to fold it over itself: no height field along any
    axis."""
    s, t = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    p = np.stack([20 * s, 20 * t, np.zeros_like(s)], axis=-1)
    for _ in range(6):
        cs, ct = rng.uniform(0, 1, 2)
        bump = np.exp(-((s - cs) ** 2 + (t - ct) ** 2) / rng.uniform(0.01, 0.05))
        p += bump[..., None] * rng.normal(0, 6, 3)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    f = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                        np.stack([a, c, d], -1).reshape(-1, 3)])
    return trimesh.Trimesh(p.reshape(-1, 3), f, process=False)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_folded_sheets_and_a_torus_never_nearer_and_nothing_seen_is_culled(seed):
    """Crumpled sheets of small triangles (folding over themselves: several layers over
    a pixel) and a torus of 2,048 (closed, not convex), from random eyes: every pixel the
    sheet and junction rules cover has all its rays meet them no farther than its depth,
    they cover pixels the others leave open, and no culled box shows in a full-resolution
    id image."""
    rng = np.random.default_rng(seed)
    torus = trimesh.creation.torus(major_radius=4.0, minor_radius=1.5, major_sections=64,
                                   minor_sections=16)
    torus.apply_translation([10, 10, 8])
    mesh = trimesh.util.concatenate([_crumpled(rng), torus])
    eye = np.r_[rng.uniform(-15, 35), rng.uniform(-15, 35), rng.uniform(15, 30)]
    aim = np.r_[rng.uniform(5, 15), rng.uniform(5, 15), 0.0] - eye
    cam = PerspectiveCamera(eye, aim, up=(0, 0, 1), fov=70, resolution=192, height=108)
    buf, plain = _buffers(mesh, cam)
    assert (buf.covered >= plain.covered).all()
    new = buf.covered & ~plain.covered
    assert new.sum() > 0
    _never_nearer(mesh, cam, buf, new, rng)
    centre = np.column_stack([rng.uniform(-5, 25, 1500), rng.uniform(-5, 25, 1500),
                              rng.uniform(-10, 10, 1500)])
    half = rng.uniform(0.1, 1.0, (1500, 3))
    lo, hi = centre - half, centre + half
    culled = buf.occluded(lo, hi)
    assert culled.sum() >= plain.occluded(lo, hi).sum()
    occludees = [trimesh.creation.box(bounds=[a, b])
                 for a, b in zip(lo[culled], hi[culled], strict=True)]
    if occludees:
        assert not _seen([mesh] + occludees, cam, len(mesh.faces))


def _waves(n=80, size=60.0):
    """A sheet of 2 (n - 1)^2 triangles, z = 2 sin(x / 3) over [0, size]^2: crests in rows
    along y."""
    x, y = np.meshgrid(np.linspace(0, size, n), np.linspace(0, size, n), indexing="ij")
    v = np.stack([x.ravel(), y.ravel(), 2 * np.sin(x / 3).ravel()], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    f = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                        np.stack([a, c, d], -1).reshape(-1, 3)])
    return trimesh.Trimesh(v, f, process=False)


@pytest.mark.parametrize("height", [2.5, 4.0])
def test_a_crest_seen_against_the_waves_behind_covers_its_pixels(height):
    """Seen from low over the waves, each crest is a fold of the sheet seen against the
    next waves behind it: a pixel that one fold edge crosses from side to side, all four
    corners on the sheet, is covered (every ray meets the crest or the waves behind),
    never nearer than the sheet; with folds blocking, it is not."""
    waves = _waves()
    cam = PerspectiveCamera((-5, 30, height), (1, 0, -0.08), up=(0, 0, 1), fov=60,
                            resolution=256, height=144)
    occ = OccluderScene([waves])
    strict = OccluderScene([waves])
    strict._sheet_folds = False
    occ._junction_rule = strict._junction_rule = False  # the sheet rule alone
    buf = ConservativeDepthBuffer.from_occluders(occ, cam)
    without = ConservativeDepthBuffer.from_occluders(strict, cam)
    assert (buf.covered >= without.covered).all()
    new = buf.covered & ~without.covered
    assert new.sum() >= 10
    _never_nearer(waves, cam, buf, new, np.random.default_rng(int(height)), per=64)
