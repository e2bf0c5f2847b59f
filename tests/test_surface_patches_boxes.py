"""surface-patches with aabb-skins' boxes in the closed parts (``boxes='auto'``)."""

from __future__ import annotations

import logging

import numpy as np
import pytest
import trimesh

from viscore import InputError, Scene
from viscore.generators import REGISTRY, generate_aabb_skins
from viscore.generators.surface_patches import _inner_boxes, generate_surface_patches
from viscore.generators.surface_patches._inner_boxes import (
    box_faces,
    box_source,
    closed_parts,
    unshadowed_measures,
)
from viscore.metrics import check_conservative

#: Rays per domain of the default-run conservativeness checks (the issue: 10^5).
RAYS = 100_000


def _wall(z=0.0):
    """A single-sided 4 x 3 wall in the plane z = ``z``: open, two triangles."""
    v = np.array([[0, 0, z], [4, 0, z], [4, 3, z], [0, 3, z]], dtype=np.float64)
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


def _hollow_sphere():
    outer = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    inner = trimesh.creation.icosphere(subdivisions=3, radius=0.55)
    inner.invert()
    return trimesh.util.concatenate([outer, inner])


def _cut_sphere():
    """A unit sphere cut flat at z = 0.2 and closed there: one planar face, the rest curved."""
    sphere = trimesh.creation.icosphere(subdivisions=3)
    return trimesh.intersections.slice_mesh_plane(sphere, [0, 0, 1], [0, 0, 0.2], cap=True)


def _rect_measure(a, b):
    """Head-on occlusion measure of an a x b rectangle: integral of the erosion, a <= b."""
    a, b = min(a, b), max(a, b)
    return a * a * b / 4 - a**3 / 12


def test_registry_wires_the_box_source_and_declares_the_option():
    assert box_source() is generate_aabb_skins
    option = REGISTRY["surface-patches"].option("boxes")
    assert option.default == "auto" and option.choices == ("auto", "off")


def test_closed_parts_box_beside_an_open_sheet():
    box = trimesh.creation.box()
    both = trimesh.util.concatenate([box, _wall(z=2.0)])
    assert closed_parts(both.vertices, both.faces).tolist() == [True] * 12 + [False] * 2


def test_closed_parts_flipped_face_opens_its_part_only():
    a = trimesh.creation.box()
    b = trimesh.creation.box(transform=trimesh.transformations.translation_matrix((3, 0, 0)))
    faces = np.asarray(b.faces).copy()
    faces[0] = faces[0, ::-1]
    b = trimesh.Trimesh(b.vertices, faces, process=False)
    both = trimesh.util.concatenate([a, b])
    assert closed_parts(both.vertices, both.faces).tolist() == [True] * 12 + [False] * 12


def test_closed_parts_unmerged_vertices_and_shells():
    # a box without shared vertices (each face its own) is one closed part after merging
    box = trimesh.creation.box()
    soup = trimesh.Trimesh(box.vertices[box.faces].reshape(-1, 3),
                           np.arange(36).reshape(-1, 3), process=False)
    assert closed_parts(soup.vertices, soup.faces).all()
    hollow = _hollow_sphere()
    assert closed_parts(hollow.vertices, hollow.faces).all()
    assert closed_parts(np.zeros((0, 3)), np.zeros((0, 3), int)).shape == (0,)


def test_unshadowed_measures_box_alone_is_its_six_faces():
    corners = np.array([[[0.0, 0, 0], [1, 2, 3]]])
    want = 2 * (_rect_measure(1, 2) + _rect_measure(2, 3) + _rect_measure(1, 3))
    assert unshadowed_measures(corners, None)[0] == pytest.approx(want, rel=0.01)


def test_unshadowed_measures_a_patch_in_front_takes_that_face():
    corners = np.array([[[0.0, 0, 0], [1, 2, 3]]])
    # a sheet in the plane z = 5 over the whole +z face (1 x 2) and beyond
    sheet = trimesh.Trimesh([[-1, -1, 5], [2, -1, 5], [2, 3, 5], [-1, 3, 5]],
                            [[0, 1, 2], [0, 2, 3]], process=False)
    full = unshadowed_measures(corners, None)[0]
    left = unshadowed_measures(corners, Scene(sheet))[0]
    assert full - left == pytest.approx(_rect_measure(1, 2), rel=0.02)


def test_box_faces_are_outward_quads():
    loops = box_faces(np.array([[[0.0, 0, 0], [1, 2, 3]]]))
    assert len(loops) == 6
    centre = np.array([0.5, 1.0, 1.5])
    for q in loops:
        n = np.cross(q[1] - q[0], q[2] - q[0])
        assert np.dot(n, q.mean(axis=0) - centre) > 0


@pytest.mark.parametrize("name", ["sphere", "box", "hollow_sphere", "cut_sphere"])
def test_generate_surface_patches_closed_solid_nonempty_guaranteed_and_clean(name):
    mesh = {"sphere": lambda: trimesh.creation.icosphere(subdivisions=3),
            "box": lambda: trimesh.creation.box(extents=(2, 1, 1)),
            "hollow_sphere": _hollow_sphere,
            "cut_sphere": _cut_sphere,
            }[name]()
    # the box's 12 triangles fit the default budget and would be kept as they are
    occ = generate_surface_patches(mesh, budget=None if name == "box" else 260)
    assert occ.triangles > 0 and occ.triangles <= 260
    assert occ.info["conservative_guaranteed"] is True and occ.info["whole_input"] is False
    if name in ("sphere", "hollow_sphere"):  # no planar region: boxes only
        assert occ.info["polygons"] == 0 and occ.info["boxes"] > 0
        assert occ.info["boxes_guaranteed"] is True
    if name == "box":  # its faces are patches; a box behind them adds nothing
        assert occ.info["polygons"] == 6 and occ.info["boxes"] == 0
        assert occ.info["box_candidates"] >= 1
    if name == "cut_sphere":  # the flat cut is a patch, the round rest gets boxes
        # (with the overlap-aware selection, facets of two coplanar faces on the rim may
        # join: they add silhouette the boxes leave)
        flat = [p for p in occ.parts["polygons"][:occ.info["polygons"]]
                if np.ptp(p[:, 2]) == 0 and p[0, 2] == pytest.approx(0.2)]
        assert len(flat) == 1 and np.ptp(flat[0][:, :2], axis=0).min() > 1.9
        assert occ.info["boxes"] > 0
    assert len(occ.parts["polygons"]) == occ.info["polygons"] + 6 * occ.info["boxes"]
    assert "boxes" not in occ.parts  # runtimes would take them for the whole occluder
    report = check_conservative(mesh, occ.mesh, rays=RAYS, domain="volume", seed=3)
    assert report.violations == 0, report.summary()


def test_generate_surface_patches_hollow_sphere_leaves_the_cavity_empty():
    occ = generate_surface_patches(_hollow_sphere(), budget=None)
    assert occ.info["boxes"] > 0
    # every box vertex lies in the shell, between the two radii
    box_v = np.asarray(occ.mesh.vertices)
    r = np.linalg.norm(box_v, axis=1)
    assert r.min() > 0.55 and r.max() < 1.0


def test_generate_surface_patches_open_wall_gets_patches_only():
    occ = generate_surface_patches(_wall())
    assert occ.triangles == 2 and occ.info["boxes"] == 0 and occ.info["closed_faces"] == 0
    assert occ.info["box_candidates"] == 0 and occ.info["boxes_guaranteed"] is None
    report = check_conservative(_wall(), occ.mesh, rays=RAYS, domain="volume", seed=3)
    assert report.violations == 0, report.summary()


def test_generate_surface_patches_sphere_beside_open_walls():
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    walls = [_wall(z=-2.0), _wall(z=2.0)]
    walls = [w.apply_translation((-2.0, -1.5, 0.0)) for w in walls]
    mesh = trimesh.util.concatenate([sphere, *walls])
    occ = generate_surface_patches(mesh)
    assert occ.info["polygons"] == 2 and occ.info["boxes"] > 0
    assert occ.info["closed_faces"] == len(sphere.faces)
    assert occ.info["conservative_guaranteed"] is True
    report = check_conservative(mesh, occ.mesh, rays=RAYS, domain="volume", seed=4)
    assert report.violations == 0, report.summary()


def test_generate_surface_patches_boxes_share_the_budget():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    counts = []
    for budget in (12, 24, 60):
        occ = generate_surface_patches(sphere, budget=budget)
        assert occ.triangles <= budget and occ.triangles % 12 == 0
        counts.append(occ.info["boxes"])
    assert counts[0] == 1 and counts[0] < counts[1] < counts[2]


def test_generate_surface_patches_claim_follows_the_box_source(monkeypatch):
    def unguaranteed(mesh, **kwargs):
        occ = generate_aabb_skins(mesh, **kwargs)
        return type(occ)(mesh=occ.mesh, method=occ.method, params=occ.params,
                         double_sided=occ.double_sided, seconds=occ.seconds, parts=occ.parts,
                         info={**occ.info, "conservative_guaranteed": False})

    monkeypatch.setitem(_inner_boxes._BOX_SOURCE, "generate", unguaranteed)
    sphere = trimesh.creation.icosphere(subdivisions=3)
    occ = generate_surface_patches(sphere)
    assert occ.info["boxes"] > 0 and occ.info["conservative_guaranteed"] is False
    # no box kept: the patches' guarantee alone
    assert generate_surface_patches(trimesh.creation.box()).info["conservative_guaranteed"]


def test_generate_surface_patches_curved_open_mesh_empty_says_why(caplog):
    sphere = trimesh.creation.icosphere(subdivisions=3)
    keep = sphere.triangles_center[:, 2] < 0.5
    dome = trimesh.Trimesh(sphere.vertices, sphere.faces[keep], process=False)
    with caplog.at_level(logging.WARNING, logger="viscore.generators.surface_patches"):
        occ = generate_surface_patches(dome, sheets="off")
    assert occ.triangles == 0
    lines = [r.getMessage() for r in caplog.records if "no occluder" in r.getMessage()]
    assert len(lines) == 1
    assert "curved regions contribute nothing" in lines[0] and "closed" in lines[0]
    assert occ.info["empty_reason"] in lines[0]
    # by default its own triangles are offered as sheets (test_surface_patches_sheets.py)
    occ = generate_surface_patches(dome)
    assert occ.triangles == occ.info["sheet_faces"] > 0 and occ.info["empty_reason"] is None


@pytest.mark.parametrize("kwargs, words", [
    ({"boxes": "off"}, "boxes are off"),
    ({"budget": 11}, "a budget of 11 holds no box"),
])
def test_generate_surface_patches_sphere_without_boxes_is_empty(kwargs, words, caplog):
    with caplog.at_level(logging.WARNING, logger="viscore.generators.surface_patches"):
        occ = generate_surface_patches(trimesh.creation.icosphere(subdivisions=3), **kwargs)
    assert occ.triangles == 0 and words in occ.info["empty_reason"]
    assert any(words in r.getMessage() for r in caplog.records)


def test_generate_surface_patches_boxes_invalid_input():
    with pytest.raises(InputError, match="boxes: expected one of auto, off"):
        generate_surface_patches(trimesh.creation.box(), boxes="on")
    with pytest.raises(InputError, match="boxes"):
        REGISTRY["surface-patches"].check_options({"boxes": "always"})


# ---------------------------------------------------------------- planted bugs
#: The check's message on a violation (``ConservativenessReport.summary``).
CAUGHT = "hit the occluder before the original"


def _hollow_guard():
    mesh = _hollow_sphere()
    occ = generate_surface_patches(mesh, budget=None)
    assert occ.info["conservative_guaranteed"] and occ.info["boxes"] > 0
    report = check_conservative(mesh, occ.mesh, rays=RAYS, domain="volume", seed=5)
    assert report.violations == 0, report.summary()


def test_plant_boxes_grown_per_closed_part_fill_the_cavity(monkeypatch):
    # planted: the box source run on each closed part alone; the outer shell of a hollow
    # sphere, taken alone, encloses its cavity, and boxes fill it
    import viscore.generators.surface_patches.generator as patches_module

    real = patches_module.candidate_boxes

    def per_part(vertices, faces, closed, *, max_boxes):
        union = trimesh.Trimesh(vertices, faces[closed], process=False)
        found, info = [], {}
        for part in union.split(only_watertight=False):
            corners, info = real(part.vertices, part.faces, np.ones(len(part.faces), bool),
                                 max_boxes=max_boxes)
            found.append(corners)
        return np.concatenate(found), info

    _hollow_guard()  # the shipped code keeps the cavity empty
    monkeypatch.setattr(patches_module, "candidate_boxes", per_part)
    with pytest.raises(AssertionError, match=CAUGHT):
        _hollow_guard()


def test_plant_open_parts_taken_for_closed_lose_the_claim(monkeypatch):
    # planted: every part counted as closed; the box source then gets an open input,
    # says its boxes are not guaranteed, and the occluder must not claim the guarantee
    import viscore.generators.surface_patches.generator as patches_module

    sphere = trimesh.creation.icosphere(subdivisions=3)
    keep = np.ones(len(sphere.faces), bool)
    keep[:4] = False  # a small hole
    holed = trimesh.Trimesh(sphere.vertices, sphere.faces[keep], process=False)
    # (no sheets: the holed sphere's own triangles would be offered too)
    assert generate_surface_patches(holed, sheets="off").triangles == 0  # no closed part
    monkeypatch.setattr(patches_module, "closed_parts",
                        lambda vertices, faces: np.ones(len(faces), bool))
    occ = generate_surface_patches(holed, sheets="off")
    assert occ.info["boxes"] > 0 and occ.info["boxes_guaranteed"] is False
    assert occ.info["conservative_guaranteed"] is False
