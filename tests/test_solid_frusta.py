"""Solid-frusta generator: convex solids inside the mesh, conservative, volume share."""

import logging

import numpy as np
import pytest
import trimesh

from viscore import InputError, load_mesh, winding_numbers
from viscore.culling import FrustumCuller, solid_frustum
from viscore.generators.aabb_skins import generate_aabb_skins
from viscore.generators.solid_frusta import generator as solid_frusta_module
from viscore.generators.solid_frusta.generator import (
    _Containment,
    _hull,
    _inner_depth,
    _line_extremes,
    _segments_meet,
    generate_solid_frusta,
)
from viscore.metrics import check_conservative

#: Closed, consistently oriented built-in scenes.
CLOSED_SCENES = ["fat-torus", "box-with-hole", "sponge", "hairball", "bunny", "cow",
                 "airplane", "bone"]


def _check_solids(mesh, occ, rng):
    """Every solid is a closed outward convex solid whose points are inside the mesh."""
    assert len(occ.parts["solids"]) == occ.info["solids"] > 0
    for v, f in occ.parts["solids"]:
        assert solid_frustum(v, f, v.max(axis=0) + 10 * (v.max(axis=0) - v.min(axis=0))) \
            is not None  # convexity and orientation are checked there
        w = rng.dirichlet(np.ones(len(v)), size=100) @ v
        # fast winding numbers (error ~1e-3): 1 inside, 0 outside
        np.testing.assert_allclose(winding_numbers(mesh.vertices, mesh.faces, w), 1.0,
                                   atol=0.02)


@pytest.mark.parametrize("name,options", [("fat-torus", {"voxels": 40}),
                                          ("bunny", {"voxels": 32, "solids": 5})])
def test_solid_frusta_conservative_fast(name, options, rng):
    mesh = load_mesh(name)
    occ = generate_solid_frusta(mesh, **options)
    assert occ.info["conservative_guaranteed"] and not occ.double_sided
    assert "hull" in occ.info["kinds"]
    _check_solids(mesh, occ, rng)
    for domain in ("orbit", "volume"):
        rep = check_conservative(mesh, occ.mesh, rays=50_000, domain=domain, seed=3)
        assert rep.violations == 0, rep.summary()


@pytest.mark.slow
@pytest.mark.parametrize("name", CLOSED_SCENES)
def test_solid_frusta_conservative_million_rays(name):
    mesh = load_mesh(name)
    occ = generate_solid_frusta(mesh)
    if occ.triangles == 0:
        pytest.skip("no inner voxels")
    assert occ.info["conservative_guaranteed"]
    for domain in ("orbit", "volume"):
        rep = check_conservative(mesh, occ.mesh, rays=1_000_000, domain=domain, seed=11)
        assert rep.violations == 0, rep.summary()


def test_solid_frusta_volume_share_beats_boxes_and_grows():
    mesh = load_mesh("fat-torus")
    occ = generate_solid_frusta(mesh, voxels=40, solids=6)
    share, boxes = occ.info["volume_share"], occ.info["aabb_skins_volume_share"]
    assert len(share) == occ.info["solids"] == 6
    assert (np.diff(share) > 0).all() and share[-1] <= 1.0
    assert share[0] >= boxes[0] - 1e-12  # the first pick is at least the largest box
    assert share[-1] > boxes[len(share) - 1] + 0.05  # hulls follow the tube's curve
    # the boxes' shares are those of aabb-skins itself
    skins = generate_aabb_skins(mesh, voxels=40, max_boxes=6, fill=1.0)
    assert boxes[-1] == pytest.approx(skins.info["volume_share"])


def test_solid_frusta_box_mesh_one_box_and_runtime_accepts_solids():
    box = trimesh.creation.box(extents=(2, 1, 1))
    occ = generate_solid_frusta(box, voxels=16)
    assert occ.info["kinds"] == ["box"] and occ.triangles == 12
    assert occ.parts["boxes"].shape == (1, 2, 3)
    culler = FrustumCuller.from_occluders([occ])
    assert culler.count == 1
    assert culler.cull((0, -5, 0), [[-0.1, 3, -0.1]], [[0.1, 4, 0.1]]).tolist() == [True]


def test_solid_frusta_boxes_only_and_budget():
    mesh = load_mesh("cow")
    only = generate_solid_frusta(mesh, voxels=32, solids=4, pieces="boxes-only")
    assert set(only.info["kinds"]) == {"box"} and only.info["candidates"]["hulls"] == 0
    capped = generate_solid_frusta(mesh, voxels=32, solids=8, budget=40)
    assert capped.triangles <= 40


def test_solid_frusta_open_mesh_not_guaranteed(open_cube):
    occ = generate_solid_frusta(open_cube, voxels=16, pieces="boxes-only")
    assert not occ.info["conservative_guaranteed"]


def test_solid_frusta_open_mesh_warns_once(open_cube, caplog):
    """Issue 23: its box source's "not closed" warning came first, then its own."""
    caplog.set_level(logging.INFO, logger="viscore")
    generate_solid_frusta(open_cube, voxels=16)
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1 and warnings[0].startswith("solid-frusta: ")
    assert "not closed" in warnings[0]
    infos = [r.getMessage() for r in caplog.records if r.levelno == logging.INFO]
    assert any(m.startswith("aabb-skins: ") for m in infos)  # its other lines are kept
    caplog.clear()
    generate_aabb_skins(open_cube, voxels=16)  # alone, aabb-skins says it itself
    assert any("not closed" in r.getMessage() for r in caplog.records)


def test_solid_frusta_budgets_share_the_candidates_and_match_made_anew(monkeypatch):
    """A second budget of the same mesh chooses from the kept candidates (made once) and
    gives the occluder a call alone gives; another mesh misses."""
    mesh = load_mesh("bunny")
    made = []
    original = solid_frusta_module._solid_candidates
    monkeypatch.setattr(solid_frusta_module, "_solid_candidates",
                        lambda *a, **k: made.append(1) or original(*a, **k))
    solid_frusta_module._SOLIDS.clear()
    options = {"voxels": 32, "solids": 5}
    large = generate_solid_frusta(mesh, budget=60, **options)
    small = generate_solid_frusta(mesh, budget=24, **options)
    assert len(made) == 1
    solid_frusta_module._SOLIDS.clear()
    alone = generate_solid_frusta(mesh, budget=24, **options)
    assert len(made) == 2 and small.triangles < large.triangles
    assert np.array_equal(small.mesh.vertices, alone.mesh.vertices)
    assert np.array_equal(small.mesh.faces, alone.mesh.faces)
    assert small.info == alone.info
    moved = trimesh.Trimesh(mesh.vertices + 1.0, mesh.faces, process=False)
    generate_solid_frusta(moved, budget=24, **options)
    assert len(made) == 3


def test_solid_frusta_kept_candidates_say_the_box_source_lines_again(open_cube, caplog):
    caplog.set_level(logging.INFO, logger="viscore")
    solid_frusta_module._SOLIDS.clear()
    said = []
    for budget in (24, 12):  # a miss, then a hit
        caplog.clear()
        generate_solid_frusta(open_cube, voxels=16, budget=budget)
        said.append([(r.levelno, r.getMessage()) for r in caplog.records])
    assert said[0] == said[1]
    assert any(m.startswith("aabb-skins: ") for _, m in said[1])


def test_containment_rejects_crossing_and_accepts_inner():
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    test = _Containment(mesh, pitch=0.05)
    centre = np.zeros(3)
    inner = trimesh.creation.box(extents=(1, 1, 1))  # corners at 0.866 < 1
    assert test.inside(inner, centre)
    assert not test.inside(trimesh.creation.box(extents=(1.2, 1.2, 1.2)), centre)  # corners out
    # a thin spike of the surface entering a hull whose vertices are all inside
    spike = trimesh.creation.box(extents=(1.1, 1.1, 0.2))
    pierced = trimesh.util.concatenate([mesh, trimesh.creation.cone(0.05, 0.9).apply_translation(
        (0, 0, 0.0))])
    assert not _Containment(pierced, pitch=0.05).inside(spike, np.array([0.5, 0.5, 0.0]))


def test_segments_meet_analytic():
    box = trimesh.creation.box(extents=(2, 2, 2))
    n = np.asarray(box.face_normals)
    d = np.einsum("ij,ij->i", n, box.vertices[box.faces[:, 0]])
    a = np.array([[-3.0, 0, 0], [-3.0, 3, 0], [0.2, 0.2, 0.2], [-3, -3, 0]])
    b = np.array([[3.0, 0, 0], [3.0, 3, 0], [0.3, 0.3, 0.3], [3, 3, 0]])
    assert [_segments_meet(a[i:i + 1], b[i:i + 1], n, d) for i in range(4)] == \
        [True, False, True, True]


def test_solid_frusta_invalid_input():
    box = trimesh.creation.box()
    with pytest.raises(InputError, match="pieces"):
        generate_solid_frusta(box, pieces="coacd!")
    with pytest.raises(InputError, match="solids"):
        generate_solid_frusta(box, solids=0)
    with pytest.raises(InputError, match="budget"):
        generate_solid_frusta(box, budget=5)
    with pytest.raises(InputError, match="mesh"):
        generate_solid_frusta(trimesh.Trimesh())
    with pytest.raises(InputError, match="shrink_steps"):
        generate_solid_frusta(box, shrink_steps=0)


@pytest.mark.parametrize("scale", [1e-12, 1e12])
def test_solid_frusta_scale_invariant(scale):
    unit = trimesh.creation.icosphere(subdivisions=2)
    ref = generate_solid_frusta(unit, voxels=24, solids=4)
    occ = generate_solid_frusta(unit.copy().apply_scale(scale), voxels=24, solids=4)
    assert occ.info["kinds"] == ref.info["kinds"]
    np.testing.assert_allclose(occ.info["volume_share"], ref.info["volume_share"], atol=0.01)
    rep = check_conservative(unit.copy().apply_scale(scale), occ.mesh, rays=20_000, seed=2)
    assert rep.violations == 0, rep.summary()


def test_line_extremes_keep_the_hull_of_voxel_centres():
    rng = np.random.default_rng(3)
    pitch = 0.25
    centres = (rng.integers(0, 12, (4000, 3)) + 0.5) * pitch - 1.0
    centres = np.unique(centres, axis=0)
    ends = _line_extremes(centres, pitch)
    assert len(ends) < len(centres) / 3
    assert set(map(tuple, ends)) <= set(map(tuple, centres))
    whole, kept = trimesh.convex.convex_hull(centres), trimesh.convex.convex_hull(ends)
    assert kept.volume == pytest.approx(whole.volume, rel=1e-12)
    # a flat layer of 40 x 30 centres keeps only its rim
    i, j = np.meshgrid(np.arange(40), np.arange(30), indexing="ij")
    layer = np.stack([i.ravel(), j.ravel(), np.zeros(i.size)], axis=1) * pitch
    rim = _line_extremes(layer, pitch)
    on_rim = ((rim[:, 0] == 0) | (rim[:, 0] == 39 * pitch) | (rim[:, 1] == 0)
              | (rim[:, 1] == 29 * pitch))
    assert on_rim.all() and len(rim) <= 2 * (40 + 30)


def test_hull_refuses_a_hull_that_comes_back_open(monkeypatch):
    # trimesh drops qhull's zero-area faces, so a thin hull can come back with a hole
    # (a 0.075 x 0.045 x 0.015 piece of a Sauerbraten map: 16 vertices, 27 faces), and
    # the frusta runtimes refuse the whole level for one such solid
    points = trimesh.creation.box().vertices
    assert _hull(points) is not None
    box = trimesh.creation.box()
    holed = trimesh.Trimesh(box.vertices, box.faces[1:], process=False)
    monkeypatch.setattr(trimesh.convex, "convex_hull", lambda pts: holed)
    assert _hull(points) is None


def test_flat_hull_is_no_piece_and_warns_nothing():
    # 40 coplanar points: qhull returns a hull of zero volume, whose centre of mass
    # trimesh divides by it; that is viscore's business, not a warning for the user
    import warnings

    rng = np.random.default_rng(0)
    flat = np.c_[rng.random((40, 2)), np.zeros(40)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert _hull(flat) is None
        assert _hull(np.c_[flat[:, :2], rng.random(40)]) is not None  # a solid is kept
    assert [str(w.message) for w in caught] == []


def test_solid_frusta_one_box_over_every_inner_voxel_skips_the_hulls(monkeypatch):
    # a thin slab (a level's ground): one aabb-skins box covers every inner voxel, so no
    # hull can gain more; the hulls are not built and the answer is that box alone
    import viscore.generators.solid_frusta.generator as sf

    slab = trimesh.creation.box(extents=(40, 40, 2))
    built = []
    real = sf._voxel_hulls
    monkeypatch.setattr(sf, "_voxel_hulls", lambda *a, **k: built.append(1) or real(*a, **k))
    occ = generate_solid_frusta(slab, voxels=64)
    assert not built and occ.info["candidates"] == {"boxes": 1, "hulls": 0}
    assert occ.info["kinds"] == ["box"] and occ.info["volume_share"] == [
        pytest.approx(occ.info["aabb_skins_volume_share"][0])]
    lo, hi = occ.parts["boxes"][0]
    assert (lo > [-20, -20, -1]).all() and (hi < [20, 20, 1]).all()  # inside the slab
    # a torus: many boxes, the hulls are still built (and win: see the volume-share test)
    generate_solid_frusta(load_mesh("fat-torus"), voxels=24, solids=3)
    assert built


@pytest.mark.parametrize("dense", [True, False])
def test_inner_depth_equals_the_distance_transform(dense):
    """Both ways (the distance transform of the inner voxels' box where they fill it, a
    k-d tree of their rim where they are sparse) give the grid's distance transform."""
    from scipy import ndimage

    inner = np.zeros((20, 24, 18), bool)
    if dense:
        inner[3:17, 4:20, 2:15] = True
        inner[8:11, 9:14, 5:9] = False  # a cavity
    else:  # two far-apart thin plates: a box of mostly empty cells
        inner[2:18, 2, 2:16] = True
        inner[2:18, 21, 2:16] = True
    index = np.argwhere(inner)
    box = np.ptp(index, axis=0) + 3
    assert (np.prod(box) <= solid_frusta_module._EDT_CELLS_PER_VOXEL * len(index)) == dense
    expected = ndimage.distance_transform_edt(inner)[inner]
    got = _inner_depth(inner, index)
    assert got.dtype == np.float64 and np.array_equal(got, expected)
