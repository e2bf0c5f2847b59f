"""AABB skins: the conservativeness guarantee, cavities, thresholds, memory refusal."""

import numpy as np
import pytest
import trimesh

from viscore import InputError, VoxelGrid, load_mesh, voxel_boundary_mesh, winding_numbers
from viscore.generators import generate_aabb_skins
from viscore.generators.aabb_skins.generator import BYTES_PER_CELL
from viscore.metrics import check_conservative


def _hollow_box(outer=2.0, inner=1.6):
    """Closed hollow box: an outward box around an inverted (cavity-facing) one."""
    cavity = trimesh.creation.box(extents=(inner,) * 3)
    cavity.invert()
    return trimesh.util.concatenate([trimesh.creation.box(extents=(outer,) * 3), cavity])


def _voxel_mesh(solid, pitch=1.0):
    return voxel_boundary_mesh(solid, VoxelGrid(np.zeros(3), pitch, solid.shape))


def _room(n=12, wall=3, door=None):
    """Solid of a cubic room, ``wall`` cells thick; ``door``: width of a square tunnel
    through the -Y wall (cells), or None."""
    solid = np.ones((n, n, n), bool)
    solid[wall:-wall, wall:-wall, wall:-wall] = False
    if door:
        lo = n // 2 - door // 2
        solid[lo:lo + door, :wall, lo:lo + door] = False
    return solid


def _nested_rooms():
    """A room (walls 3 cells) whose inside holds a second room (walls 2 cells) with a cavity."""
    solid = _room(24, 3)
    solid[8:16, 8:16, 8:16] = _room(8, 2)
    return _voxel_mesh(solid, 0.25)


#: Closed meshes enclosing empty space, and the aabb-skins settings to try on them.
CAVITY_CASES = {
    "hollow-box": (_hollow_box, {"voxels": 32}),
    "box-with-hole": (lambda: load_mesh("box-with-hole"), {"voxels": 8}),
    "door-narrower-than-voxel": (lambda: _voxel_mesh(_room(12, 3, door=1)),
                                 {"voxel_size": 1.7}),
    "door-wider-than-voxel": (lambda: _voxel_mesh(_room(12, 3, door=2)), {"voxel_size": 0.5}),
    "nested-rooms": (_nested_rooms, {"voxels": 40}),
}


def _skins(case, **extra):
    make, params = CAVITY_CASES[case]
    mesh = make()
    return mesh, generate_aabb_skins(mesh, max_boxes=64, fill=1.0, **params, **extra)


def _box_points(boxes, n, rng):
    """``n`` uniform points inside each box."""
    u = rng.random((len(boxes), n, 3))
    return (boxes[:, None, 0] + u * (boxes[:, None, 1] - boxes[:, None, 0])).reshape(-1, 3)


@pytest.mark.parametrize("case", sorted(CAVITY_CASES))
def test_aabb_skins_cavities_stay_empty_and_guarantee_holds(case, rng):
    mesh, occ = _skins(case)
    assert occ.info["closed_oriented"] and occ.info["conservative_guaranteed"]
    assert occ.info["inside"] == "winding-number"
    if case == "door-wider-than-voxel":  # the flood fill comes in through the door
        assert occ.info["cavity_voxels"] == 0
    else:  # the flood fill alone would have filled the cavities
        assert occ.info["cavity_voxels"] > 0
    if case != "box-with-hole":  # its walls are thinner than a voxel: no box at all
        assert occ.info["boxes"] > 0
    boxes = occ.parts["boxes"]
    if len(boxes):
        # every point of every box lies inside the solid (exact winding number 1)
        w = winding_numbers(mesh.vertices, mesh.faces, _box_points(boxes, 50, rng), exact=True)
        np.testing.assert_allclose(w, 1.0, atol=1e-6)
    for domain in ("orbit", "volume"):
        rep = check_conservative(mesh, occ.mesh, rays=100_000, domain=domain, seed=5)
        assert rep.violations == 0, rep.summary()


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(CAVITY_CASES))
@pytest.mark.parametrize("seed_voxel", ["max-volume", "densest"])
def test_aabb_skins_cavities_million_rays(case, seed_voxel):
    mesh, occ = _skins(case, seed_voxel=seed_voxel)
    assert occ.info["conservative_guaranteed"]
    for domain in ("orbit", "volume"):
        rep = check_conservative(mesh, occ.mesh, rays=1_000_000, domain=domain, seed=17)
        assert rep.violations == 0, rep.summary()


def test_aabb_skins_hollow_box_fills_the_walls_only():
    _, occ = _skins("hollow-box")
    lo, hi = occ.parts["boxes"][:, 0], occ.parts["boxes"][:, 1]
    # no box reaches into the cavity [-0.8, 0.8]^3
    assert not ((lo < 0.8) & (hi > -0.8)).all(axis=1).any()
    # the wall volume 8 - 1.6^3 = 3.904: boxes fill at most that
    assert 0 < occ.info["volume_share"] <= 1 + 1e-9


def test_aabb_skins_no_guarantee_for_open_or_flipped_meshes(cube, open_cube):
    occ = generate_aabb_skins(open_cube, voxels=16)
    assert not occ.info["closed_oriented"] and not occ.info["conservative_guaranteed"]
    assert occ.info["inside"] in ("flood-fill", "ray-parity")
    flipped = cube.copy()
    flipped.faces[0] = flipped.faces[0, ::-1]  # watertight, but one triangle inside out
    occ = generate_aabb_skins(flipped, voxels=16)
    assert not occ.info["conservative_guaranteed"]
    occ = generate_aabb_skins(cube, voxels=16)
    assert occ.info["conservative_guaranteed"] and occ.info["cavity_voxels"] == 0


def test_aabb_skins_open_mesh_keeps_only_inside_centres():
    mesh = load_mesh("terrain")  # an open height field: parity votes mark space below it
    occ = generate_aabb_skins(mesh, voxels=32, max_boxes=8)
    boxes = occ.parts["boxes"]
    assert not occ.info["conservative_guaranteed"]
    if len(boxes):
        centres = boxes.mean(axis=1)
        assert (np.abs(winding_numbers(mesh.vertices, mesh.faces, centres)) >= 0.5).all()


def test_aabb_skins_huge_min_volume_gives_no_box():
    occ = generate_aabb_skins(trimesh.creation.box(), voxels=8, min_volume=1e300)
    assert occ.info["boxes"] == 0 and occ.triangles == 0


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -1.0, "big"])
def test_aabb_skins_invalid_min_volume(bad):
    with pytest.raises(InputError, match="min_volume"):
        generate_aabb_skins(trimesh.creation.box(), voxels=8, min_volume=bad)


def test_aabb_skins_memory_refused_before_any_work(monkeypatch):
    import viscore.generators.aabb_skins.generator as skins

    def no_work(*args, **kwargs):
        raise AssertionError("voxelized before the memory check")

    monkeypatch.setattr(skins, "voxelize", no_work)
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", "1e-9")
    with pytest.raises(InputError, match="voxels=64.*memory"):
        generate_aabb_skins(trimesh.creation.box(), voxels=64)
    with pytest.raises(InputError, match="voxel_size=0.01.*memory"):
        generate_aabb_skins(trimesh.creation.box(), voxel_size=0.01)
    with pytest.raises(InputError, match="mesh"):
        generate_aabb_skins(trimesh.Trimesh())


_PEAK_SCRIPT = """
import resource, sys
import numpy as np, trimesh
from viscore.generators.aabb_skins import generate_aabb_skins
from viscore import voxel_grid
mesh = {mesh}
mode, res = sys.argv[1], int(sys.argv[2])
generate_aabb_skins(mesh, voxels=12, seed_voxel=mode)  # compile and import first
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
occ = generate_aabb_skins(mesh, voxels=res, seed_voxel=mode, max_boxes=8)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
cells = np.prod(voxel_grid(np.asarray(mesh.bounds), resolution=res).shape)
print((peak - base) / cells)
"""


@pytest.mark.slow
@pytest.mark.parametrize("seed_voxel", ["max-volume", "densest"])
@pytest.mark.parametrize("mesh", ["trimesh.creation.box(extents=(2, 1.5, 1))",
                                  "__import__('viscore').load_mesh('city-block')"])
def test_aabb_skins_memory_estimate_bounds_the_peak(seed_voxel, mesh):
    import subprocess
    import sys

    code = _PEAK_SCRIPT.format(mesh=mesh)
    run = subprocess.run([sys.executable, "-c", code, seed_voxel, "160"], capture_output=True,
                         text=True, timeout=1800)
    assert run.returncode == 0, run.stderr[-3000:]
    per_cell = float(run.stdout.split()[-1])
    assert per_cell <= BYTES_PER_CELL[seed_voxel]
