"""The depth buffer's contour rule: pixels covered by a union of many small triangles."""

import numpy as np
import pytest
import trimesh

from viscore import PerspectiveCamera, Scene
from viscore.culling import depth_buffer as db
from viscore.culling._contour import edge_topology


def _pixel_rays(cam, shape, n):
    """(H, W, (n + 1)^2, 3) unit directions of a grid of rays through every buffer pixel,
    its edges and corners included."""
    h, w = shape
    f, r, u = cam.basis
    g = np.linspace(0.0, 1.0, n + 1)
    i, j, a, b = np.meshgrid(np.arange(h), np.arange(w), g, g, indexing="ij")
    x = ((j + b) / w - 0.5) * 2 * cam._half
    y = (0.5 - (i + a) / h) * 2 * cam._half_vertical
    d = x[..., None] * r + y[..., None] * u + f
    return (d / np.linalg.norm(d, axis=-1)[..., None]).reshape(h, w, -1, 3)


def _contour_only(mesh, cam, w, h):
    """The depths the contour rule alone gives a w x h buffer of ``mesh``."""
    occ = db.OccluderScene([mesh])
    depth = np.full((h, w), np.inf)
    eye = np.asarray(cam.position, dtype=np.float64)
    size = occ.scene.diagonal + float(np.linalg.norm(eye - occ._center))
    db._contour_depths(occ, eye, cam.basis, cam._half, cam._half_vertical, depth,
                       db.DEPTH_MARGIN_RELATIVE * size)
    return depth


def test_edge_topology_of_a_closed_mesh_and_a_sheet():
    box = trimesh.creation.box()
    edges, opposite = edge_topology(np.asarray(box.vertices), np.asarray(box.faces))
    assert len(edges) == 18 and (opposite >= 0).all()  # 12 box edges + 6 face diagonals
    quad = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    # the same two triangles with their vertices unshared: merged by position
    soup = quad[[0, 1, 2, 0, 2, 3]]
    edges, opposite = edge_topology(soup, np.arange(6).reshape(2, 3))
    assert len(edges) == 5 and (opposite[:, 0] >= 0).sum() == 1


def test_sphere_of_5000_triangles_covers_its_disk_and_never_its_outside():
    """A sphere of 5,120 triangles seen from outside, the contour rule alone: every pixel
    whose square, widened by a pixel, lies inside the silhouette disk of the sphere's
    inscribed ball is covered; no covered pixel has a ray of a dense grid (edges and
    corners included) that misses the mesh or meets it beyond the pixel's depth."""
    mesh = trimesh.creation.icosphere(subdivisions=4)
    assert len(mesh.faces) == 5120
    inner = float(np.abs(np.einsum("ij,ij->i", mesh.face_normals,
                                   mesh.triangles[:, 0])).min())  # inscribed ball's radius
    eye = np.array([0.3, -4.0, 0.2])
    cam = PerspectiveCamera(eye, -eye, fov=60, resolution=128, height=72)
    w, h = 32, 18
    depth = _contour_only(mesh, cam, w, h)
    d = _pixel_rays(cam, (h, w), 8)
    t, _ = Scene(mesh).first_hit(eye[None], d.reshape(-1, 3))
    t = t.reshape(h, w, -1)
    covered = np.isfinite(depth)
    assert np.isfinite(t[covered]).all()  # never a pixel touching the outside
    assert (t[covered] <= depth[covered][:, None]).all()  # never nearer than the surface
    # the disk shrunk by a pixel: the corners of the pixel's 3 x 3 block inside the cone
    # of the inscribed ball (the true silhouette lies outside it)
    axis = -eye / np.linalg.norm(eye)
    cos_edge = np.sqrt(1.0 - (inner / np.linalg.norm(eye)) ** 2)
    corner_in = _pixel_rays(cam, (h, w), 1) @ axis > cos_edge  # (h, w, 4)
    inside = corner_in.all(axis=2)
    pad = np.zeros((h + 2, w + 2), dtype=bool)
    pad[1:-1, 1:-1] = inside
    deep = np.ones((h, w), dtype=bool)
    for a in range(3):
        for b in range(3):
            deep &= pad[a:a + h, b:b + w]
    assert deep.sum() > 40  # the test has teeth
    assert covered[deep].all()


def test_contour_rule_never_covers_a_gap_narrower_than_a_pixel():
    """Two bumpy sheets of small triangles with a gap of 0.3 buffer pixels between them:
    a pole seen through the gap is never culled with the contour rule on, and the sheets'
    own pixels are covered by it where the other rules leave them open."""
    eye = np.array([0.0, -10.0, 0.0])
    cam = PerspectiveCamera(eye, (0, 1, 0), fov=60, resolution=128, height=72)
    pixel = 2 * np.tan(np.radians(30)) * 10.0 / 32

    def sheet(x0, x1):
        g = trimesh.creation.box(extents=(x1 - x0, 0.01, 10)).subdivide_to_size(0.25)
        v = np.asarray(g.vertices).copy()
        v[:, 0] += 0.5 * (x0 + x1)
        front = v[:, 1] < 0
        v[front, 1] -= 0.05 * np.sin(3 * v[front, 0]) * np.cos(2 * v[front, 2])
        return trimesh.Trimesh(v, g.faces, process=False)

    gap_lo = 0.1 * pixel
    walls = [sheet(-8, gap_lo), sheet(gap_lo + 0.3 * pixel, 8)]
    mid = (gap_lo + 0.15 * pixel) * 2.0
    lo, hi = np.array([[mid - 0.01 * pixel, 9.9, -1.0]]), np.array([[mid + 0.01 * pixel,
                                                                      10.1, 1.0]])
    assert Scene(trimesh.util.concatenate(walls)).first_hit(
        eye[None], np.array([[mid / 20, 1.0, 0.0]]))[1][0] < 0  # visible through the gap
    bufs = {}
    for on in (False, True):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(db, "CONTOUR_RULE", on)
            bufs[on] = db.ConservativeDepthBuffer.from_occluders(walls, cam)
        assert not bufs[on].occluded(lo, hi)[0]
    assert bufs[True].covered.sum() >= bufs[False].covered.sum()
    assert (bufs[True].depth <= bufs[False].depth).all()
