"""Occlusion measure (metrics/erosion.py): analytic values on curved and oblique boundaries."""

import numpy as np
import pytest
import trimesh

from viscore import InputError, directions_uniform
from viscore.metrics import directional_occlusion_measure, erosion_curve, occlusion_measure
from viscore.metrics import erosion as erosion_module


def _disk_mesh(radius=1.0, segments=1024):
    """Flat regular polygon (triangle fan) in z = 0 and its exact measure head-on.

    1024 sides of 1.5 pixels at 512 px: a curved boundary at the pixel scale.

    A regular polygon is tangential: eroding it by r gives the polygon of
    inradius rho - r, so M = A rho / 3 (A its area, rho its inradius).
    """
    a = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    v = np.vstack([[0, 0, 0], np.stack([radius * np.cos(a), radius * np.sin(a), 0 * a], 1)])
    k = np.arange(segments)
    faces = np.stack([np.zeros(segments, int), 1 + k, 1 + (k + 1) % segments], 1)
    area = 0.5 * segments * radius**2 * np.sin(2 * np.pi / segments)
    return trimesh.Trimesh(v, faces, process=False), area * radius * np.cos(np.pi / segments) / 3


def _turned_square(degrees):
    """Unit square centred at the origin in z = 0, turned in its plane."""
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    v = (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float) - [0.5, 0.5, 0])
    v = v @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


# ---------------------------------------------------------------- images
def test_directional_occlusion_measure_unit_square_is_one_sixth():
    r = 512
    img = np.zeros((r, r), bool)
    img[r // 4: 3 * r // 4, r // 4: 3 * r // 4] = True
    m, a = directional_occlusion_measure(img, 1 / (r // 2))
    assert m == pytest.approx(1 / 6, rel=0.005)
    assert a == pytest.approx(1.0)


def test_directional_occlusion_measure_disk_with_inside_second_order():
    """An analytic disk: the bisected boundary is within 0.3% at 128 px, mid-points are not."""
    res, radius = 128, 0.45
    pixel = 1.0 / res
    centre = np.array([0.503, 0.497])  # off the pixel grid

    def inside(points):
        return (((points * pixel - centre) ** 2).sum(axis=1)) <= radius**2

    c = (np.arange(res) + 0.5)
    img = inside(np.stack(np.meshgrid(c, c), -1).reshape(-1, 2)).reshape(res, res)
    exact = np.pi * radius**3 / 3
    m, a = directional_occlusion_measure(img, pixel, inside=inside)
    m_mid, _ = directional_occlusion_measure(img, pixel)
    assert m == pytest.approx(exact, rel=0.003)
    assert abs(m_mid / exact - 1) > 3 * abs(m / exact - 1)
    assert a == pytest.approx(np.pi * radius**2, rel=0.01)
    radii = np.linspace(0, radius, 4001)
    curve = erosion_curve(img, pixel, radii, inside=inside)
    assert np.trapezoid(curve, radii) == pytest.approx(m, rel=2e-3)


def test_occlusion_measure_square_with_holes_far_smaller():
    r = 512
    solid = np.zeros((r, r), bool)
    solid[128:384, 128:384] = True
    holes = solid.copy()
    holes[136:384:16, 136:384:16] = False  # 256 one-pixel holes
    m_solid, a_solid = directional_occlusion_measure(solid, 1 / 256)
    m_holes, a_holes = directional_occlusion_measure(holes, 1 / 256)
    assert a_holes > 0.99 * a_solid  # nearly the same area ...
    assert m_holes < 0.25 * m_solid  # ... but a far smaller occlusion measure


def test_erosion_curve_integrates_to_measure():
    img = np.zeros((256, 256), bool)
    img[64:192, 32:224] = True
    pix = 1 / 128
    m, a = directional_occlusion_measure(img, pix)
    radii = np.linspace(0, 1, 20001)
    curve = erosion_curve(img, pix, radii)
    assert curve[0] == pytest.approx(a)
    assert (np.diff(curve) <= 0).all()
    assert np.trapezoid(curve, radii) == pytest.approx(m, rel=1e-3)


def test_erosion_radius_is_exact_distance_to_crossings(rng):
    """The separable transform equals brute force over the crossings on a random image."""
    img = rng.random((23, 31)) < 0.7
    radius = erosion_module._erosion_radius(img, 1.0, None, 0)
    rows, cols = erosion_module._crossings(np.pad(img, 1), None, 0)
    i, j = np.nonzero(~np.isnan(rows))
    seeds = [np.stack([j + rows[i, j], i], 1)]
    i, j = np.nonzero(~np.isnan(cols))
    seeds.append(np.stack([j, i + cols[i, j]], 1))
    seeds = np.concatenate(seeds)
    ci, cj = np.nonzero(img)
    brute = np.sqrt((((np.stack([cj + 1, ci + 1], 1)[:, None] - seeds) ** 2).sum(-1)).min(1))
    np.testing.assert_allclose(radius[ci, cj], brute, rtol=1e-12)
    assert (radius[~img] == 0).all()


# ---------------------------------------------------------------- meshes (Embree)
def test_occlusion_measure_sphere_pi_r3_over_3():
    r = 0.8
    sphere = trimesh.creation.icosphere(subdivisions=6, radius=r)  # polygonal: -0.02%
    dirs = [(0.3, 0.5, 0.81), (-0.7, 0.1, -0.2)]
    frame = ((0, 0, 0), 2 * r * 1.01)  # the orbit frame, without its 1 s for 40,962 vertices
    res = occlusion_measure(sphere, directions=dirs, resolution=512, frame=frame)
    np.testing.assert_allclose(res.per_view["measure"], np.pi * r**3 / 3, rtol=0.001)
    np.testing.assert_allclose(res.per_view["area"], np.pi * r**2, rtol=0.005)
    assert res.params["directions"] == "given"


def test_occlusion_measure_random_directions_sphere_total(unit_sphere):
    res = occlusion_measure(unit_sphere, directions=3, resolution=256, seed=1)
    assert res.occlusion_measure == pytest.approx(4 * np.pi * np.pi / 3, rel=0.005)
    assert res.surface_area_measure == pytest.approx(4 * np.pi * np.pi, rel=0.005)


def test_occlusion_measure_disk_head_on():
    disk, exact = _disk_mesh()
    res = occlusion_measure(disk, directions=[(0, 0, 1)], resolution=512)
    assert res.per_view["measure"][0] == pytest.approx(exact, rel=0.001)


@pytest.mark.parametrize("degrees", [10, 20, 30])
def test_occlusion_measure_turned_square_one_sixth(degrees):
    res = occlusion_measure(_turned_square(degrees), directions=[(0, 0, 1)], resolution=512)
    assert res.per_view["measure"][0] == pytest.approx(1 / 6, rel=0.001)


def test_occlusion_measure_boundary_steps_beat_midpoints():
    """Per ray: 5 bisection steps at 128 px beat the mid-point boundary at 512 px."""
    sq = _turned_square(20)
    fine = occlusion_measure(sq, directions=[(0, 0, 1)], resolution=512, boundary_steps=0)
    coarse = occlusion_measure(sq, directions=[(0, 0, 1)], resolution=128)
    assert coarse.params["rays"] < fine.params["rays"] / 10
    assert abs(6 * coarse.occlusion_measure / (4 * np.pi) - 1) < 0.002
    assert abs(6 * fine.occlusion_measure / (4 * np.pi) - 1) > 0.002


def test_occlusion_measure_seed_reproducible(cube):
    a = occlusion_measure(cube, directions=5, resolution=64, seed=3)
    b = occlusion_measure(cube, directions=5, resolution=64, seed=3)
    assert a.occlusion_measure == b.occlusion_measure and a.occlusion_measure_se > 0
    assert occlusion_measure(cube, directions=2, resolution=16, seed=2**70).seed == 2**70


def test_occlusion_measure_direction_batches_match_directions_uniform(cube, monkeypatch):
    """Directions are drawn a batch at a time, as directions_uniform draws them at once."""
    batches = list(erosion_module._direction_batches(2500, 9))
    assert max(len(b) for b in batches) <= erosion_module._DIRECTIONS_PER_BATCH
    np.testing.assert_array_equal(np.concatenate(batches), directions_uniform(2500, seed=9))
    whole = occlusion_measure(cube, directions=9, resolution=16, seed=4)
    monkeypatch.setattr(erosion_module, "_DIRECTIONS_PER_BATCH", 2)
    batched = occlusion_measure(cube, directions=9, resolution=16, seed=4)
    np.testing.assert_array_equal(whole.per_view["measure"], batched.per_view["measure"])
    given = occlusion_measure(cube, directions=directions_uniform(9, seed=4), resolution=16)
    np.testing.assert_array_equal(whole.per_view["measure"], given.per_view["measure"])


def test_occlusion_measure_memory_checked_before_work(cube, monkeypatch):
    monkeypatch.setattr("viscore._validate.available_memory", lambda: 4 * 2**30)
    with pytest.raises(InputError, match="resolution=8192"):
        occlusion_measure(cube, resolution=8192)
    with pytest.raises(InputError, match="directions=1000000000"):
        occlusion_measure(cube, directions=10**9)
    huge = np.broadcast_to(np.zeros((1, 1), bool), (30000, 30000))  # a view of one byte
    with pytest.raises(InputError, match="memory"):
        directional_occlusion_measure(huge, 1.0)


def test_occlusion_measure_invalid_input(cube):
    with pytest.raises(InputError):
        occlusion_measure(cube, directions=0)
    with pytest.raises(InputError):
        occlusion_measure(cube, directions=np.zeros((0, 3)))
    with pytest.raises(InputError):
        occlusion_measure(cube, directions=[(0, 0, 0)])
    with pytest.raises(InputError):
        occlusion_measure(cube, resolution=8193)
    with pytest.raises(InputError):
        occlusion_measure(cube, seed=-5)
    with pytest.raises(InputError):
        occlusion_measure(cube, seed=1.5)
    with pytest.raises(InputError):
        occlusion_measure(cube, boundary_steps=-1)
    with pytest.raises(InputError):
        occlusion_measure(cube, frame=(0, 1))
    with pytest.raises(InputError):
        occlusion_measure(trimesh.Trimesh(), directions=4)


def test_directional_occlusion_measure_invalid_input():
    with pytest.raises(InputError):
        directional_occlusion_measure(np.zeros((4, 4), np.uint8), 1.0)
    with pytest.raises(InputError):
        directional_occlusion_measure(np.zeros(4, bool), 1.0)
    with pytest.raises(InputError):
        directional_occlusion_measure(np.zeros((4, 4), bool), 0.0)
    with pytest.raises(InputError):
        erosion_curve(np.zeros((4, 4), bool), 1.0, [np.nan])
