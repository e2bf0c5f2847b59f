import numpy as np
import pytest
import trimesh
from viscore.generators import REGISTRY, generate, generate_aabb_skins, generate_bbox, generate_qem
from viscore.metrics import check_conservative, orbit_precision_recall

from viscore import InputError, load_mesh

WATERTIGHT_SCENES = ["fat-torus", "sponge", "buildings", "box-with-hole", "bunny", "cow"]


def test_aabb_skins_single_box_exact_for_box_mesh():
    box = trimesh.creation.box(extents=(2.0, 1.0, 1.0))
    occ = generate_aabb_skins(box, voxels=20, max_boxes=4, fill=1.0)
    assert occ.info["boxes"] == 1 and occ.triangles == 12
    lo, hi = occ.parts["boxes"][0]
    pitch = occ.info["pitch"]
    # the faces pass through voxel centres: the box fills all but that half voxel
    np.testing.assert_allclose(lo, [-1 + pitch / 2, -0.5 + pitch / 2, -0.5 + pitch / 2],
                               atol=1e-9)
    np.testing.assert_allclose(hi, [1 - pitch / 2, 0.5 - pitch / 2, 0.5 - pitch / 2], atol=1e-9)


@pytest.mark.parametrize("name", WATERTIGHT_SCENES)
def test_aabb_skins_conservative_on_watertight_scenes(name):
    mesh = load_mesh(name)
    occ = generate_aabb_skins(mesh, voxels=48, max_boxes=24)
    assert occ.info["boxes"] > 0
    for domain in ("orbit", "volume"):
        rep = check_conservative(mesh, occ.mesh, rays=50_000, domain=domain, seed=3)
        assert rep.violations == 0, rep.summary()


@pytest.mark.slow
@pytest.mark.parametrize("name", WATERTIGHT_SCENES + ["airplane", "bone"])
def test_aabb_skins_conservative_million_rays(name):
    mesh = load_mesh(name)
    occ = generate_aabb_skins(mesh, voxels=64, max_boxes=64)
    if occ.triangles == 0:
        pytest.skip("no inner voxels")
    if occ.info["inside"] != "flood-fill":
        pytest.skip("open mesh: not guaranteed conservative")
    rep = check_conservative(mesh, occ.mesh, rays=1_000_000, seed=11)
    assert rep.violations == 0, rep.summary()


def test_aabb_skins_thresholds():
    mesh = load_mesh("fat-torus")
    few = generate_aabb_skins(mesh, voxels=32, max_boxes=3, fill=1.0)
    assert few.info["boxes"] == 3
    filled = generate_aabb_skins(mesh, voxels=32, max_boxes=None, fill=0.5)
    assert filled.info["fill"] >= 0.5
    capped = generate_aabb_skins(mesh, voxels=32, max_boxes=None, fill=0.5, budget=24)
    assert capped.info["boxes"] <= 2
    big = generate_aabb_skins(mesh, voxels=32, max_boxes=None, fill=1.0, min_volume=0.05)
    vols = np.prod(big.parts["boxes"][:, 1] - big.parts["boxes"][:, 0], axis=1)
    assert (vols >= 0.05).all()
    # greedy: volumes do not increase
    assert (np.diff(vols) <= 1e-12).all()


def test_aabb_skins_open_mesh_falls_back_to_parity():
    mesh = load_mesh("city-block")  # towers with open bottoms
    occ = generate_aabb_skins(mesh, voxels=48, max_boxes=8)
    assert occ.info["inside"] == "ray-parity" and occ.info["boxes"] > 0


def test_aabb_skins_invalid_input(cube):
    with pytest.raises(InputError):
        generate_aabb_skins(cube, fill=0)
    with pytest.raises(InputError):
        generate_aabb_skins(cube, max_boxes=0)
    with pytest.raises(InputError, match="GiB"):
        generate_aabb_skins(cube, voxels=2000)
    with pytest.raises(InputError):
        generate_aabb_skins(cube, budget=5)


def test_baselines_original_perfect_bbox_recall_one(unit_sphere):
    orig = generate("original", unit_sphere)
    r = orbit_precision_recall(unit_sphere, orig.mesh, views=4, quads=1000, resolution=48)
    assert r.precision == 1.0 and r.recall == 1.0
    box = generate_bbox(unit_sphere)
    r = orbit_precision_recall(unit_sphere, box.mesh, views=4, quads=1000, resolution=48)
    assert r.recall == 1.0 and r.precision < 1.0


def test_qem_respects_budget(unit_sphere):
    occ = generate_qem(unit_sphere, budget=64)
    assert 32 <= occ.triangles <= 64


def test_registry_names_and_unknown():
    assert {"aabb-skins", "qem", "bbox", "original"} <= set(REGISTRY)
    with pytest.raises(InputError, match="registered"):
        generate("nope", trimesh.creation.box())


def test_aabb_skins_densest_seed_conservative_and_first_box_not_larger():
    mesh = load_mesh("cow")
    dense = generate_aabb_skins(mesh, voxels=40, max_boxes=6, seed_voxel="densest")
    best = generate_aabb_skins(mesh, voxels=40, max_boxes=6)
    vol = lambda b: np.prod(b[:, 1] - b[:, 0], axis=1)  # noqa: E731
    assert dense.info["boxes"] == 6
    assert vol(best.parts["boxes"])[0] >= vol(dense.parts["boxes"])[0] - 1e-12
    assert check_conservative(mesh, dense.mesh, rays=20000).violations == 0
    with pytest.raises(InputError, match="seed_voxel"):
        generate_aabb_skins(mesh, seed_voxel="random")


def test_densest_order_starts_at_centre_of_hollow_cube():
    from viscore.generators.aabb_skins import _densest_order, _six_direction_distance

    s = np.zeros((9, 9, 9), bool)
    s[0], s[-1], s[:, 0], s[:, -1], s[:, :, 0], s[:, :, -1] = (True,) * 6
    order = _densest_order(~s, s)
    assert order[0].tolist() == [4, 4, 4]
    # along one axis the two distances always add up to the width between the walls
    assert np.unique(_six_direction_distance(s)[~s]).tolist() == [4.0]
