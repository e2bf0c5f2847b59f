"""Surface patches welded onto the creases of the input (generators/surface_patches/_crease_weld):
walls meeting at a corner and a facade of several planes end on their planes' line, so the
conservative depth buffer covers the crease; walls apart keep their gap; the occluder stays
conservative."""

import numpy as np
import pytest
import trimesh
from test_depth_patches import _sampled_first_hits

from viscore import InputError, PerspectiveCamera, Scene
from viscore.culling.depth_buffer import ConservativeDepthBuffer, OccluderScene
from viscore.generators.surface_patches._crease_weld import crease_lines, weld_points
from viscore.generators.surface_patches.generator import EROSION, generate_surface_patches
from viscore.metrics import check_conservative


def _quads(corners) -> trimesh.Trimesh:
    """One quad (two triangles, its own four vertices) per ``(4, 3)`` loop: walls modelled
    apart, as game meshes split their vertices at hard edges."""
    v = np.concatenate([np.asarray(c, dtype=np.float64) for c in corners])
    f = np.concatenate([np.array([[0, 1, 2], [0, 2, 3]]) + 4 * k for k in range(len(corners))])
    return trimesh.Trimesh(v, f, process=False)


def _corner(gap: float = 0.0) -> trimesh.Trimesh:
    """Two walls 10 long and 4 high (z up), in the planes x = -gap and y = 0, meeting along
    the z axis when ``gap`` is 0."""
    a = [[-gap, 0, 0], [-gap, 10, 0], [-gap, 10, 4], [-gap, 0, 4]]
    b = [[0, 0, 0], [10, 0, 0], [10, 0, 4], [0, 0, 4]]
    return _quads([a, b])


def _facade() -> trimesh.Trimesh:
    """A facade of four planes along a polyline bending 12 degrees at each joint."""
    pts = [np.zeros(2)]
    for k in range(4):
        angle = np.radians(12.0 * k)
        pts.append(pts[-1] + 5.0 * np.array([np.cos(angle), np.sin(angle)]))
    return _quads([[[*p, 0], [*q, 0], [*q, 6], [*p, 6]]
                   for p, q in zip(pts[:-1], pts[1:], strict=True)])


def _off_line(occ_mesh: trimesh.Trimesh) -> float:
    """Nearest occluder vertex's distance from the z axis (the corner's crease)."""
    return float(np.linalg.norm(np.asarray(occ_mesh.vertices)[:, :2], axis=1).min())


def test_walls_at_a_corner_end_on_their_line():
    mesh = _corner()
    welded = generate_surface_patches(mesh, budget=None)
    apart = generate_surface_patches(mesh, budget=None, weld="off")
    diag = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    assert welded.info["welded"] == 2 and apart.info["welded"] == 0
    assert _off_line(welded.mesh) < 1e-12 * diag
    assert _off_line(apart.mesh) > 0.5 * EROSION * diag
    # both patches reach the crease along its whole height, and nothing passes it
    on_line = np.asarray(welded.mesh.vertices)
    on_line = on_line[np.linalg.norm(on_line[:, :2], axis=1) < 1e-9]
    assert on_line[:, 2].min() < 1e-3 and on_line[:, 2].max() > 4 - 1e-3
    assert np.asarray(welded.mesh.vertices)[:, :2].min() >= -1e-12


def test_a_box_behind_a_welded_corner_is_culled_and_never_too_near():
    mesh = _corner()
    cam = PerspectiveCamera((6, 6, 2), (-1, -1, 0), up=(0, 0, 1), fov=60, resolution=192,
                            height=108)
    box = ([[-3, -3, 1]], [[-1, -1, 3]])  # behind the corner, its image across the crease
    buffers = {}
    for weld in ("auto", "off"):
        occ = generate_surface_patches(mesh, budget=None, weld=weld)
        buffers[weld] = ConservativeDepthBuffer.from_occluders(OccluderScene([occ]), cam)
    assert buffers["auto"].occluded(*box)[0] and not buffers["off"].occluded(*box)[0]
    buf = buffers["auto"]
    assert buf.covered.sum() > buffers["off"].covered.sum()
    # every covered pixel: random rays through it meet the input itself no farther
    pixels = np.argwhere(buf.covered)
    hits = _sampled_first_hits(Scene(mesh), cam, buf.shape, pixels, np.random.default_rng(3),
                               per=16)
    assert np.isfinite(hits).all()
    assert (hits <= buf.depth[pixels[:, 0], pixels[:, 1]][:, None]).all()


def test_walls_apart_keep_their_gap():
    mesh = _corner(gap=1e-3)  # 70 grid steps: no shared edge, a real gap
    occ = generate_surface_patches(mesh, budget=None)
    assert occ.info["welded"] == 0
    vertices = np.asarray(occ.mesh.vertices)
    diag = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    # the wall in y = 0 keeps its erosion from its own end at x = 0
    assert vertices[np.abs(vertices[:, 1]) < 1e-12, 0].min() > 0.5 * EROSION * diag


def test_a_facade_of_several_planes_is_welded_and_conservative():
    mesh = _facade()
    occ = generate_surface_patches(mesh, budget=None)
    assert occ.info["welded"] == 4 and occ.info["conservative_guaranteed"] is True
    report = check_conservative(mesh, occ.mesh, rays=100_000, domain="volume", seed=7)
    assert report.violations == 0, report.summary()
    # the three joints: each has occluder vertices of both its walls on it
    v = np.asarray(mesh.vertices)
    joints = v[[4, 8, 12], :2]
    ov = np.asarray(occ.mesh.vertices)
    for joint in joints:
        assert (np.linalg.norm(ov[:, :2] - joint, axis=1) < 1e-9).sum() >= 4
    # seen from the front, a box behind the facade is culled only with the welds
    cam = PerspectiveCamera((10, -14, 3), (0, 1, 0), up=(0, 0, 1), fov=70, resolution=192,
                            height=108)
    box = ([[3, 6, 2]], [[15, 8, 4]])
    culled = {}
    for weld in ("auto", "off"):
        occ_w = generate_surface_patches(mesh, budget=None, weld=weld)
        buf = ConservativeDepthBuffer.from_occluders(OccluderScene([occ_w]), cam)
        culled[weld] = bool(buf.occluded(*box)[0])
    assert culled == {"auto": True, "off": False}


def test_crease_lines_match_vertices_by_position_and_skip_parallel_planes():
    mesh = _corner()
    faces = np.asarray(mesh.faces)
    planes = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])
    creases = crease_lines(np.asarray(mesh.vertices), faces, np.array([0, 0, 1, 1]), planes,
                           grid=1e-6)
    assert sorted(creases) == [0, 1]
    for region, (segs, partner) in creases.items():
        assert len(segs) == 1 and partner.tolist() == [1 - region]
        assert np.allclose(segs[0][:, :2], 0.0)
    # the same walls taken as one plane's two regions: parallel, no crease
    same = np.array([[1.0, 0, 0, 0], [1.0, 0, 0, 0]])
    assert crease_lines(np.asarray(mesh.vertices), faces, np.array([0, 0, 1, 1]), same,
                        grid=1e-6) == {}
    # a point within reach moves onto the line; a point beyond the edge's end stays
    segs, _ = creases[1]
    moved = weld_points(np.array([[1e-4, 0, 2.0], [1e-4, 0, 5.0]]), 1, creases,
                        np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]]), reach=1e-3)
    assert np.allclose(moved[0], [0, 0, 2.0], atol=1e-15)
    assert np.array_equal(moved[1], [1e-4, 0, 5.0])
    # the lines a caller keeps for one occluder's welds: found once, the same points moved
    lines: dict = {}
    for _ in range(2):
        kept = weld_points(np.array([[1e-4, 0, 2.0], [1e-4, 0, 5.0]]), 1, creases,
                           np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]]), reach=1e-3, lines=lines)
        assert np.array_equal(kept, moved) and list(lines) == [(1, 0), ("region", 1)]
    s0, span, length2, partner, point, _ = lines["region", 1]  # the kept edges are those used
    lines["region", 1] = (s0, span, length2, partner, np.zeros_like(point),
                          np.tile([0.0, 1, 0], (len(partner), 1)))
    assert not np.array_equal(weld_points(np.array([[1e-4, 0, 2.0]]), 1, creases, np.array(
        [[1.0, 0, 0, 0], [0, 1.0, 0, 0]]), reach=1e-3, lines=lines), moved[:1])


@pytest.mark.parametrize("weld", ["on", "", None])
def test_weld_choices_are_checked(weld):
    with pytest.raises(InputError):
        generate_surface_patches(_corner(), weld=weld)
