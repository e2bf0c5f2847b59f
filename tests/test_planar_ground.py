"""Planar sections on open ground: ``ground`` and ``up`` (viscore.level.ground)."""

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.generators.planar_sections import generate_planar_sections
from viscore.generators.planar_sections._slices import section_solid
from viscore.metrics import ReferenceViews

#: Few bins: the generator's speed is a benchmark figure, not a test's.
FAST = {"direction_bins": 6, "depth_bins": 2}


def _open_bottom_box(up: int = 2) -> trimesh.Trimesh:
    """A 4 x 4 x 2 box without its bottom face (the face facing -up), turned by 30 degrees
    about the up axis: its walls lie across the voxels, so no slice runs along one."""
    box = trimesh.creation.box(extents=(4, 4, 2))
    mesh = trimesh.Trimesh(box.vertices, box.faces[box.face_normals[:, 2] > -0.5],
                           process=False)
    mesh.apply_transform(trimesh.transformations.rotation_matrix(np.radians(30), [0, 0, 1]))
    if up == 1:  # z up -> y up
        mesh.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
    return mesh


@pytest.fixture(scope="module")
def views():
    return ReferenceViews(_open_bottom_box(), protocol="orbit", views=48, seed=3)


def test_the_ground_fills_an_open_bottomed_box_that_the_flood_fill_leaves_a_shell(views):
    box = _open_bottom_box()
    shell = section_solid(box, resolution=24)
    filled = section_solid(box, resolution=24, ground=-1.0, up="z")
    assert filled.solid_voxels > 2 * shell.solid_voxels  # the inside, about 18 x 18 x 8
    assert filled.interior_voxels > 0.5 * filled.solid_voxels > shell.interior_voxels
    plain = generate_planar_sections(box, budget=16, voxels=24, ground="off", **FAST)
    grounded = generate_planar_sections(box, budget=16, voxels=24, ground=-1.0, up="z",
                                        **FAST)
    assert grounded.info["ground"] == {"height": -1.0, "grazing": 0.0, "misses": 0.05}
    assert plain.info["ground"] is None
    p, g = views.score(plain.mesh), views.score(grounded.mesh)
    assert g.precision >= 0.995
    assert g.recall > 0.8 > 0.5 > p.recall


def test_the_ground_follows_the_up_axis(views):
    box = _open_bottom_box(up=1)  # the same box, +Y up: its opening faces -y
    filled = section_solid(box, resolution=24, ground=-1.0, up="y")
    shell = section_solid(box, resolution=24)
    same = section_solid(_open_bottom_box(), resolution=24, ground=-1.0, up="z")
    assert filled.solid_voxels > 2 * shell.solid_voxels
    assert abs(filled.solid_voxels - same.solid_voxels) < 0.05 * same.solid_voxels
    assert filled.footprint_share > 0.9


def test_ground_auto_keeps_the_fill_only_where_it_passes_the_floor():
    box = _open_bottom_box()
    occ = generate_planar_sections(box, budget=16, **FAST)
    assert occ.info["up"] == "z"
    assert occ.info["ground"]["height"] == pytest.approx(-1.0)
    floor = occ.info["precision_floor"]
    assert floor["met"]
    def key(fill):
        return None if fill is None else (fill["grazing"], fill["misses"])

    tried = {(s["close"], key(s["ground"])): s["recall"] for s in floor["closings"]}
    assert (0, None) in tried and (0, (0.2, 0.1)) in tried
    assert len(tried) == 8  # as it is, closed by 2, 3 and 4, and 4 ground fills
    kept = occ.info["ground"]
    assert tried[(0, (kept["grazing"], kept["misses"]))] > tried[(0, None)] + 0.2
    closed = generate_planar_sections(trimesh.creation.box(extents=(4, 4, 2)), budget=16,
                                      **FAST)
    assert closed.info["ground"] is None  # a closed solid: no closing, no ground tried
    assert "closings" not in closed.info["precision_floor"]


@pytest.mark.parametrize("options, match", [
    ({"ground": "sideways"}, "ground: expected 'auto', 'off' or a finite height"),
    ({"ground": float("nan")}, "ground: expected"),
    ({"ground": 0.0, "conservative": True}, "ground: not with conservative"),
    ({"up": "w"}, "up: expected auto, x, y or z"),
])
def test_bad_ground_options_are_refused_before_any_work(options, match):
    with pytest.raises(InputError, match=match):
        generate_planar_sections(_open_bottom_box(), **options)



def _bumpy_sheet(n: int = 16) -> trimesh.Trimesh:
    """An open height field over 4 x 4: seen past its edges from low views, so a fill
    that keeps voxels most directions expose over-occludes."""
    x, y = np.meshgrid(np.linspace(0, 4, n), np.linspace(0, 4, n))
    z = 0.6 * np.sin(1.7 * x) * np.cos(1.3 * y) + 0.075 * x + 0.8
    a = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]).ravel()
    faces = np.concatenate([np.column_stack([a, a + 1, a + n + 1]),
                            np.column_stack([a, a + n + 1, a + n])])
    return trimesh.Trimesh(np.column_stack([x.ravel(), y.ravel(), z.ravel()]), faces,
                           process=False)


@pytest.mark.parametrize("case", ["fills", "fill-skipped", "coarser"])
def test_the_floor_on_two_threads_makes_what_one_makes(case, caplog, monkeypatch):
    """The precision floor's independent runs (closings, ground fills, coarser voxels),
    made side by side on two threads, are the runs one thread makes and keeps, in the
    same order and with the same log lines: the same occluder.

    - fills: the open-bottomed box tries 3 closings and 4 ground fills.
    - fill-skipped: on a sheet, a fill that keeps voxels 90% of the directions expose
      fails the floor, so the next fill of its grazing is not kept, though on two
      threads it was made ahead.
    - coarser: a closed box at the default size is coarsened twice (64 -> 45 -> 32).
    """
    import logging

    import viscore.generators.planar_sections.floor as floor_module
    from viscore import get_workers, set_workers

    mesh, options = {
        "fills": (_open_bottom_box(), {"voxels": 24, "min_precision": 0.995}),
        "fill-skipped": (_bumpy_sheet(), {"voxels": 24, "min_precision": 0.95}),
        "coarser": (trimesh.creation.box(extents=(4, 4, 2)), {}),
    }[case]
    if case == "fill-skipped":
        monkeypatch.setattr(floor_module, "GROUND_FILLS", (
            {"grazing": 0.0, "misses": 0.9}, {"grazing": 0.0, "misses": 0.95},
            {"grazing": 0.2, "misses": 0.05}))
    caplog.set_level(logging.DEBUG, logger="viscore")  # the floor's lines are diagnostics
    made, logs = [], []
    before = get_workers()
    try:
        for workers in (1, 2):
            set_workers(workers)
            caplog.clear()
            made.append(generate_planar_sections(mesh, budget=16, **options, **FAST))
            logs.append([(r.name, r.levelno, r.getMessage()) for r in caplog.records])
    finally:
        set_workers(before)
    one, two = made

    def runs(occ):
        floor = occ.info["precision_floor"]
        return [{k: v for k, v in s.items() if k != "seconds"}
                for s in floor.get("closings", []) + floor["steps"]]

    assert np.array_equal(one.mesh.vertices, two.mesh.vertices)
    assert np.array_equal(one.mesh.faces, two.mesh.faces)
    assert runs(one) == runs(two)
    assert logs[0] == logs[1] and (case == "coarser" or len(logs[0]) > 0)
    tried = one.info["precision_floor"].get("closings", [])
    fills = [(s["ground"]["misses"], s["precision"]) for s in tried if s["ground"]]
    if case == "fills":
        assert len(tried) == 8 and len(fills) == 4
    elif case == "fill-skipped":
        assert [m for m, _ in fills] == [0.9, 0.05] and fills[0][1] < 0.95
    else:
        assert [s["voxels"] for s in one.info["precision_floor"]["steps"]] == [64, 45, 32]


def _flat_sheet(n: int = 6) -> trimesh.Trimesh:
    """A flat 4 x 4 square of ``2 n^2`` triangles in z = 0, turned by 20 degrees about z:
    an open sheet that no closing nor ground fill can give an interior."""
    xs = np.linspace(-2.0, 2.0, n + 1)
    x, y = np.meshgrid(xs, xs, indexing="ij")
    vertices = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    idx = np.arange(x.size).reshape(n + 1, n + 1)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    mesh.apply_transform(trimesh.transformations.rotation_matrix(np.radians(20), [0, 0, 1]))
    return mesh


def test_the_floor_generates_once_per_distinct_solid_on_a_flat_sheet(monkeypatch):
    from viscore.generators.planar_sections import floor

    calls = []
    real = floor._generate_one

    def counted(*args, **kwargs):
        calls.append(kwargs["sec"].solid_voxels)
        return real(*args, **kwargs)

    monkeypatch.setattr(floor, "_generate_one", counted)
    occ = generate_planar_sections(_flat_sheet(), budget=8, **FAST)
    record = occ.info["precision_floor"]
    closings = record["closings"]
    # every closing (2, 3, 4) and every ground fill tried leaves the sheet's solid as it is
    assert [t["close"] for t in closings][:4] == [0, 2, 3, 4]
    assert len(closings) >= 4
    for t in closings[1:]:
        assert (t["precision"], t["recall"], t["triangles"]) == (
            closings[0]["precision"], closings[0]["recall"], closings[0]["triangles"])
    # so the sheet is generated once at the first size, and once per other size tried
    sizes = {t["voxels"] for t in record["steps"]} | {closings[0]["voxels"]}
    assert len(calls) == len(sizes)
    assert occ.info["close"] == 0 and occ.info["ground"] is None


def test_solids_from_one_voxelization_equal_solids_made_alone():
    from viscore.generators.planar_sections._slices import voxel_base

    box = _open_bottom_box()
    base = voxel_base(box, resolution=24)
    for kwargs in ({}, {"close": 2}, {"ground": -1.0, "up": "z", "ground_misses": 0.1,
                                      "ground_grazing": 0.2}):
        alone = section_solid(box, resolution=24, **kwargs)
        shared = section_solid(box, resolution=24, base=base, **kwargs)
        assert np.array_equal(alone.solid, shared.solid)
        assert alone.solid_voxels == shared.solid_voxels
        assert alone.interior_voxels == shared.interior_voxels


def test_solid_along_is_kept_per_normal_and_equals_the_fill_rule():
    from viscore.voxel.coverage_hull import exposed_count

    box = _open_bottom_box()
    sec = section_solid(box, resolution=24, ground=-1.0, up="z", ground_misses=0.05,
                        ground_grazing=0.2)
    assert len(sec.fill.cells) > 0
    for normal in (np.array([0.0, 0.0, 1.0]), np.array([0.6, 0.0, 0.8])):
        # the rule cell by cell: at most floor(misses x seen) of the seen directions expose it
        seen = np.abs(sec.fill.directions @ normal) >= 0.2
        allowed = exposed_count(sec.fill.exposure, seen) <= np.floor(0.05 * seen.sum())
        assert allowed.sum() > 0
        assert np.array_equal(sec.fill.allowed(normal), allowed)
        expected = sec.solid.copy()
        dropped = sec.fill.cells[~allowed]
        expected[tuple(dropped.T)] = False
        first = sec.solid_along(normal)
        assert np.array_equal(first, expected)
        assert sec.solid_along(normal.copy()) is first  # kept, not made again


def test_ground_fill_allowed_counts_each_cell_as_its_own_row():
    from viscore.generators.planar_sections._slices import GroundFill
    from viscore.voxel.coverage_hull import exposed_count

    rng = np.random.default_rng(5)
    directions = rng.normal(size=(20, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    # 3,000 cells sharing 40 exposure patterns, so that rows repeat, in no order
    patterns = rng.random((40, 20)) < 0.15
    bits = np.packbits(patterns[rng.integers(0, 40, 3000)], axis=1)
    fill = GroundFill(cells=np.zeros((3000, 3), np.int64), exposure=bits,
                      directions=directions, misses=0.1, grazing=0.3)
    for normal in directions[:5]:
        seen = np.abs(directions @ normal) >= 0.3
        expected = exposed_count(bits, seen) <= np.floor(0.1 * seen.sum())
        assert 0 < expected.sum() < len(expected)
        assert np.array_equal(fill.allowed(normal), expected)


@pytest.mark.parametrize("kind", ["sheet", "slab"])
def test_no_interior_warning_says_why_the_plain_solid_was_kept(kind, caplog):
    """A solid with no interior keeps its plain voxels for one of two reasons, and the
    warning says which: on an open sheet no closing passes the precision floor; on a thin
    closed slab every closing passes but gives the same solid, so none recalls more."""
    import logging

    from viscore.generators import generate

    mesh = _flat_sheet() if kind == "sheet" else trimesh.creation.box(extents=[8, 0.12, 8])
    with caplog.at_level(logging.WARNING, logger="viscore"):
        generate("planar-sections", mesh, budget=64, seed=0)
    said = [r.getMessage() for r in caplog.records if "no interior" in r.getMessage()]
    assert len(said) == 1
    if kind == "sheet":
        assert "passes the precision floor" in said[0] and "recalls more" not in said[0]
    else:
        assert "recalls more than none" in said[0] and "passes the precision" not in said[0]
