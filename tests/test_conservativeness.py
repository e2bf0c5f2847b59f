"""The conservativeness check's tolerance: float32 candidates judged again in float64.

Analytic geometry after the module docstring of :mod:`viscore.metrics.conservativeness`:
a tilted unit-square wall (the original) and a triangle in its plane, or offset
along its normal by a chosen fraction of eps along the ray, met by hand-made rays
at grazing incidence (cos 1e-3, where Embree's float32 distances of two coplanar
triangles differ by several eps) and at cos 0.5. Every test asserts something
the float32-only check of before (``gap > eps`` on Embree's distances) gets wrong
or right, so that it fails if the float64 judgement were dropped or made blind.
"""

import numpy as np
import pytest
import trimesh

from viscore import Scene, load_mesh
from viscore.constants import CONSERVATIVE_EPS_RELATIVE
from viscore.metrics import check_conservative, orbit_frame
from viscore.metrics.conservativeness import (
    _domain_rays,
    _float32_error,
    _meet64,
    _violating_rays,
)

#: A rotation about an oblique axis and an offset: no coordinate of the wall is
#: exact in float32, as on the sloped roof of building-cottage.
_POSE = trimesh.transformations.rotation_matrix(0.7, [1.0, 2.0, 3.0])
_POSE[:3, 3] = [3.3, -1.7, 2.9]
_SQUARE = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
_TRIANGLE = np.array([[0.2, 0.1, 0.0], [0.9, 0.3, 0.0], [0.4, 0.9, 0.0]])


def _posed(vertices, faces, lift=0.0):
    """Mesh of local ``vertices`` (z = 0 plane), ``lift`` along the plane's normal, posed."""
    v = np.asarray(vertices, dtype=np.float64) @ _POSE[:3, :3].T + _POSE[:3, 3]
    return trimesh.Trimesh(v + lift * _POSE[:3, 2], faces, process=False)


def _wall():
    return _posed(_SQUARE, [[0, 1, 2], [0, 2, 3]])


def _eps():
    return CONSERVATIVE_EPS_RELATIVE * Scene(_wall()).diagonal


def _rays(cos, n=20_000, seed=0, length=0.5):
    """Rays from the +normal side meeting the wall plane at incidence ``cos``, at points
    well inside the triangle (barycentric >= 0.05), ``length`` from their origins."""
    rng = np.random.default_rng(seed)
    w = rng.dirichlet(np.ones(3), n) * 0.85 + 0.05
    local = w @ _TRIANGLE
    phi = rng.uniform(0, 2 * np.pi, n)
    sin = np.sqrt(1 - cos**2)
    d_local = np.c_[sin * np.cos(phi), sin * np.sin(phi), np.full(n, -cos)]
    d = d_local @ _POSE[:3, :3].T
    aim = local @ _POSE[:3, :3].T + _POSE[:3, 3]
    return aim - length * d, d


def _float32_gaps(wall, occ, o, d):
    """Gaps of the float32-only check: Embree's original distance minus the occluder's."""
    t_wall, _ = Scene(wall).first_hit(o, d)
    t_occ, _ = Scene(occ).first_hit(o, d)
    with np.errstate(invalid="ignore"):  # both missed: nan, no violation
        return t_wall - t_occ


def _judge(occ, cos, fraction_of_eps=None, **kw):
    """(float32-flagged count, violations, cleared, gaps) of the rays at ``cos`` against
    the triangle lifted so that its along-ray gap is ``fraction_of_eps`` x eps."""
    eps = _eps()
    o, d = _rays(cos, **kw)
    wall = _wall()
    if fraction_of_eps is not None:
        occ = _posed(_TRIANGLE, [[0, 1, 2]], lift=fraction_of_eps * eps * cos)
    flagged = int((_float32_gaps(wall, occ, o, d) > eps).sum())
    bad, gap, _, _, cleared = _violating_rays(Scene(wall), Scene(occ), o, d, eps)
    return flagged, len(bad), cleared, gap


def test_grazing_coplanar_triangle_float32_flags_float64_clears():
    # the cottage's case: occluder triangles in the original's plane, another triangulation
    occ = _posed(_TRIANGLE, [[0, 1, 2]])
    flagged, violations, cleared, _ = _judge(occ, 1e-3)
    assert flagged >= 100  # float32 alone reports these grazing rays as violations
    assert violations == 0 and cleared == flagged


def test_grazing_just_below_eps_is_no_violation():
    flagged, violations, cleared, _ = _judge(None, 1e-3, fraction_of_eps=0.9)
    assert flagged >= 100
    assert violations == 0 and cleared == flagged


def test_grazing_just_above_eps_is_a_violation_on_every_flagged_ray():
    eps = _eps()
    flagged, violations, cleared, gap = _judge(None, 1e-3, fraction_of_eps=1.1)
    assert flagged >= 100
    assert violations == flagged and cleared == 0
    # the reported gaps are the float64 ones: 1.1 eps to float64 precision, not float32 noise
    np.testing.assert_allclose(gap, 1.1 * eps, rtol=1e-6)


@pytest.mark.parametrize("fraction,expected", [(0.9, 0), (1.1, 20_000)])
def test_oblique_protrusion_just_below_and_above_eps(fraction, expected):
    flagged, violations, cleared, _ = _judge(None, 0.5, fraction_of_eps=fraction)
    assert violations == expected and flagged == expected and cleared == 0


def test_eps_zero_coincident_occluder_only_float_noise_is_cleared():
    """With ``eps=0``, a retriangulated copy of the wall is no violation; lifted by 1e-9
    (far under float32's resolution), it is one on rays from the lifted side only."""
    wall = _wall()
    twin = _posed(_SQUARE, [[0, 1, 3], [1, 2, 3]])
    rep = check_conservative(wall, twin, rays=100_000, eps=0.0, seed=1)
    assert rep.violations == 0 and rep.cleared > 1000  # float32 noise: ~13% of the rays
    assert rep.eps == 0.0
    lifted = _posed(_SQUARE, [[0, 1, 3], [1, 2, 3]], lift=1e-9)
    rep = check_conservative(wall, lifted, rays=100_000, eps=0.0, seed=1)
    assert rep.violations > 1000 and rep.cleared > 1000
    normal = _POSE[:3, 2]
    for w in rep.worst:  # every violating ray comes from the side the occluder is lifted to
        assert np.dot(w["direction"], normal) < 0
        assert w["t_original"] - w["t_occluder"] > 0


def _grown_cube(h):
    """The cube [-1, 1]^3 and a box grown by ``h`` on every side."""
    return trimesh.creation.box(extents=(2.0,) * 3), trimesh.creation.box(extents=(2 + 2 * h,) * 3)


@pytest.mark.parametrize("domain", ["orbit", "volume"])
def test_protrusion_just_above_default_eps_every_meeting_ray_violates(domain):
    cube, _ = _grown_cube(0.0)
    eps = CONSERVATIVE_EPS_RELATIVE * Scene(cube).diagonal
    cube, grown = _grown_cube(1.1 * eps)
    default = check_conservative(cube, grown, rays=100_000, domain=domain, seed=4)
    exact = check_conservative(cube, grown, rays=100_000, domain=domain, seed=4, eps=0.0)
    # every ray meeting the grown box is ahead of the cube by >= 1.1 eps along it
    assert default.violations == exact.violations > 5_000
    below = check_conservative(cube, _grown_cube(0.9 * eps)[1], rays=100_000, domain=domain,
                               seed=4)
    # 0.9 eps along the normal: only rays at incidence cos < 0.9 are ahead by more than eps
    # (orbit: 79% of the meeting rays, volume: 86%)
    assert 0.05 * exact.violations < below.violations < 0.9 * exact.violations
    user = check_conservative(cube, grown, rays=100_000, domain=domain, seed=4, eps=0.5 * eps)
    assert user.eps == 0.5 * eps and user.violations == exact.violations
    assert default.eps == pytest.approx(eps, rel=1e-12) and exact.eps == 0.0


def test_float32_error_bound_holds_with_a_margin():
    """Embree's float32 distances stay within a quarter of the bound that decides which
    rays are judged again (measured: 0.85 / 16 of it)."""
    for name in ("building-cottage", "fat-torus"):
        mesh = load_mesh(name)
        scene = Scene(mesh)
        o, d = _domain_rays("orbit", orbit_frame(mesh), scene, 100_000,
                            np.random.default_rng(3))
        t, tri = scene.first_hit(o, d)
        hit = tri >= 0
        o, d, t, tri = o[hit], d[hit], t[hit], tri[hit]
        t64, meets, _ = _meet64(scene, tri, o, d)
        assert meets.mean() > 0.9999
        err = _float32_error(scene, o, d, t, tri)
        assert (np.abs(t - t64) <= 0.25 * err).all()


def test_ordinary_violations_counted_as_float32_counts_them():
    """Away from grazing incidence the float64 judgement changes nothing: the count is the
    float32 count of the same rays (the check draws them as ``_domain_rays`` does)."""
    mesh = load_mesh("fat-torus")
    occ = mesh.copy()
    occ.apply_scale(1.002)
    rep = check_conservative(mesh, occ, rays=50_000, seed=9)
    o, d = _domain_rays("orbit", orbit_frame(mesh), Scene(mesh), 50_000,
                        np.random.default_rng(9))
    gap = _float32_gaps(mesh, occ, o, d)
    assert rep.violations == int((gap > rep.eps).sum()) > 1000
    assert rep.cleared == 0
    worst = rep.worst[0]
    assert worst["t_original"] is None or worst["t_original"] > worst["t_occluder"] + rep.eps
