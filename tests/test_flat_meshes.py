"""Flat, tiny and huge meshes as original and as occluder: measure, precision/recall,
conservativeness and silhouettes (planar occluders are flat by construction).

References for the measure come from eq. 1 of Silvennoinen et al. 2014 without pixels:
the projection of a flat convex polygon is a convex polygon, and eroding it by r moves
each edge inward by r, so A(I_{d,r}) is the area of the polygon clipped by the edges'
half-planes shifted by r, integrated over r by adaptive quadrature.
"""

import numpy as np
import pytest
import trimesh
from scipy import integrate

from viscore import camera_basis, directions_uniform
from viscore.metrics import (
    SILHOUETTE_COLOURS,
    assert_conservative,
    check_conservative,
    occlusion_measure,
    orbit_precision_recall,
    silhouette_image,
    volume_precision_recall,
)

#: Total measure of the unit square over the sphere (integral of M(d) over directions).
SQUARE_TOTAL = 0.78653

#: Twelve view directions of the flat unit square: four tilts from its normal
#: (cos 0.3 to 0.95) at three azimuths, from both sides.
_TILTS = np.array([0.3, 0.5, 0.7, 0.95])
_AZIMUTHS = np.radians([15.0, 50.0, 110.0])
DIRECTIONS = np.array([[np.sqrt(1 - c * c) * np.cos(a), np.sqrt(1 - c * c) * np.sin(a),
                        c if k % 2 == 0 else -c]
                       for k, (c, a) in enumerate((c, a) for c in _TILTS for a in _AZIMUTHS)])


def _flat(vertices, faces):
    return trimesh.Trimesh(np.asarray(vertices, float), faces, process=False)


def _unit_square():
    return _flat([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])


def _scaled(mesh, factor, about=(0, 0, 0)):
    out = mesh.copy()
    out.apply_translation(-np.asarray(about, float))
    out.apply_scale(factor)
    out.apply_translation(about)
    return out


# ---------------------------------------------------------------- exact references
def _project(points, direction):
    """2-D coordinates of 3-D points in an image plane orthogonal to ``direction``."""
    _, r, u = camera_basis(direction)
    p = np.asarray(points, float)
    return np.stack([p @ r, p @ u], axis=1)


def _area(poly):
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _eroded_area(poly, r):
    """Area of a convex polygon with every edge moved inward by r (half-plane clipping)."""
    poly = np.asarray(poly, float)
    (ax, ay), (bx, by) = poly[1] - poly[0], poly[2] - poly[1]
    if ax * by - ay * bx < 0:
        poly = poly[::-1]
    out = poly
    for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        e = b - a
        n = np.array([-e[1], e[0]]) / np.linalg.norm(e)  # inward normal (counter-clockwise)
        side = (out - a) @ n - r
        if len(out) == 0 or (side < 0).all():
            return 0.0
        kept = []
        for k in range(len(out)):
            p, q, sp, sq = out[k], out[(k + 1) % len(out)], side[k], side[(k + 1) % len(out)]
            if sp >= 0:
                kept.append(p)
            if (sp >= 0) != (sq >= 0):
                kept.append(p + (q - p) * sp / (sp - sq))
        out = np.array(kept)
    return _area(out) if len(out) >= 3 else 0.0


def _convex_measure(poly):
    """M(d) of a convex polygon from eq. 1: the integral of the eroded area over r."""
    poly = np.asarray(poly, float)
    lo, hi = 0.0, np.linalg.norm(poly - poly.mean(axis=0), axis=1).max()
    for _ in range(60):  # the inradius, where the eroded polygon vanishes
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _eroded_area(poly, mid) > 0 else (lo, mid)
    value, _ = integrate.quad(lambda r: _eroded_area(poly, r), 0, hi, limit=200,
                              epsabs=1e-14, epsrel=1e-11)
    return value


def _parallelogram_measure(p1, p2):
    """Closed form of eq. 1 for a parallelogram with sides p1, p2 (2-D).

    Eroded by r it stays a parallelogram with heights h_a - 2r, h_b - 2r, so
    M = int_0^{h_a/2} (h_a - 2r)(h_b - 2r) dr / sin(phi) = h_a^2 (3 h_b - h_a) / (12 sin phi)
    with h_a <= h_b.
    """
    area = abs(p1[0] * p2[1] - p1[1] * p2[0])
    n1, n2 = np.linalg.norm(p1), np.linalg.norm(p2)
    ha, hb = sorted([area / n1, area / n2])
    return ha**2 * (3 * hb - ha) / (12 * area / (n1 * n2))


def _square_measure(direction):
    """Exact M(d) of the unit square in z = 0 seen along ``direction``."""
    p = _project([[1, 0, 0], [0, 1, 0]], direction)
    return _parallelogram_measure(p[0], p[1])


def test_reference_convex_erosion_matches_closed_forms():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    assert _convex_measure(square) == pytest.approx(1 / 6, rel=1e-8)
    for theta in (0.3, 0.9, 1.4):  # tilted about an edge: a 1 x c rectangle
        c = np.cos(theta)
        rect = square * [1, c]
        assert _convex_measure(rect) == pytest.approx(c**2 * (3 - c) / 12, rel=1e-8)
        assert _square_measure((0, np.sin(theta), np.cos(theta))) == pytest.approx(
            c**2 * (3 - c) / 12, rel=1e-10)
    tri = np.array([[0, 0], [1, 0], [0, 1]], float)  # M = A rho / 3, rho = (2 - sqrt 2) / 2
    assert _convex_measure(tri) == pytest.approx(0.5 * (2 - np.sqrt(2)) / 2 / 3, rel=1e-8)
    for d in DIRECTIONS:
        poly = _project([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], d)
        assert _convex_measure(poly) == pytest.approx(_square_measure(d), rel=1e-8)


def test_reference_square_total_over_sphere():
    """16 x the integral over the wedge 0 <= phi <= pi/4, z > 0 (the square's symmetries)."""
    x, w = np.polynomial.legendre.leggauss(48)
    mu, wmu = 0.5 * (x + 1), 0.5 * w
    phi, wphi = np.pi / 8 * (x + 1), np.pi / 8 * w
    s = np.sqrt(1 - mu**2)
    total = sum(wm * wp * _square_measure((sm * np.cos(p), sm * np.sin(p), m))
                for m, wm, sm in zip(mu, wmu, s, strict=True)
                for p, wp in zip(phi, wphi, strict=True))
    assert 16 * total == pytest.approx(SQUARE_TOTAL, abs=2e-5)


# ---------------------------------------------------------------- the measure
def test_occlusion_measure_flat_square_head_on_both_sides():
    res = occlusion_measure(_unit_square(), directions=[(0, 0, 1), (0, 0, -1)], resolution=512)
    np.testing.assert_allclose(res.per_view["measure"], 1 / 6, rtol=0.001)
    np.testing.assert_allclose(res.per_view["area"], 1.0, rtol=0.005)


def test_occlusion_measure_flat_square_tilted_about_edge():
    thetas = np.radians([30.0, 60.0, 75.0])
    dirs = np.stack([0 * thetas, np.sin(thetas), np.cos(thetas)], axis=1)
    c = np.cos(thetas)
    res = occlusion_measure(_unit_square(), directions=dirs, resolution=512)
    np.testing.assert_allclose(res.per_view["measure"], c**2 * (3 - c) / 12, rtol=0.001)


def test_occlusion_measure_flat_square_many_directions():
    res = occlusion_measure(_unit_square(), directions=DIRECTIONS, resolution=512)
    exact = np.array([_square_measure(d) for d in DIRECTIONS])
    np.testing.assert_allclose(res.per_view["measure"], exact, rtol=0.001)


def test_occlusion_measure_flat_square_total_within_three_se():
    res = occlusion_measure(_unit_square(), directions=96, resolution=64, seed=5)
    assert abs(res.occlusion_measure - SQUARE_TOTAL) < 3 * res.occlusion_measure_se
    # the per-direction values are those of the exact reference, to pixel accuracy
    exact = np.array([_square_measure(d) for d in directions_uniform(96, seed=5)])
    assert np.abs(res.per_view["measure"] - exact).max() < 0.01 * (1 / 6)


def test_occlusion_measure_single_triangle():
    tri = _flat([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    dirs = np.array([(0, 0, 1), (0.4, -0.3, 0.866)])
    res = occlusion_measure(tri, directions=dirs, resolution=512)
    exact = [_convex_measure(_project(tri.vertices, d)) for d in dirs]
    assert exact[0] == pytest.approx(0.5 * (2 - np.sqrt(2)) / 2 / 3, rel=1e-8)
    np.testing.assert_allclose(res.per_view["measure"], exact, rtol=0.001)


def test_occlusion_measure_single_quad():
    quad = _flat([[0, 0, 0], [1.2, 0, 0], [1.0, 0.8, 0], [0.1, 0.6, 0]], [[0, 1, 2], [0, 2, 3]])
    dirs = np.array([(0, 0, 1), (-0.5, 0.2, -0.84)])
    res = occlusion_measure(quad, directions=dirs, resolution=512)
    exact = [_convex_measure(_project(quad.vertices, d)) for d in dirs]
    np.testing.assert_allclose(res.per_view["measure"], exact, rtol=0.001)


@pytest.mark.parametrize("scale", [1e-12, 1e12])
@pytest.mark.parametrize("shape", ["cube", "square"])
def test_occlusion_measure_scales_as_length_cubed(shape, scale):
    """M has units of area x distance: scaling a mesh by s scales M by s^3."""
    mesh = trimesh.creation.box() if shape == "cube" else _unit_square()
    unit = occlusion_measure(mesh, directions=4, resolution=64, seed=2)
    scaled = occlusion_measure(_scaled(mesh, scale), directions=4, resolution=64, seed=2)
    np.testing.assert_allclose(scaled.per_view["measure"] / scale**3, unit.per_view["measure"],
                               rtol=1e-3)
    assert scaled.surface_area_measure / scale**2 == pytest.approx(unit.surface_area_measure,
                                                                   rel=1e-3)


# ---------------------------------------------------------------- precision / recall
def test_flat_occluder_equal_to_flat_original_is_perfect():
    sq = _unit_square()
    orbit = orbit_precision_recall(sq, sq, views=8, quads=400, resolution=48, seed=0)
    assert orbit.precision == 1.0 and orbit.recall == 1.0
    volume = volume_precision_recall(sq, sq, quads=200, resolution=24, spacing=0.5, seed=0)
    assert volume.precision == 1.0 and volume.recall == 1.0


def test_flat_triangle_original_and_occluder():
    tri = _flat([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    r = orbit_precision_recall(tri, tri, views=4, quads=200, resolution=32, seed=1)
    assert r.precision == 1.0 and r.recall == 1.0


# ---------------------------------------------------------------- conservativeness
@pytest.mark.parametrize("domain", ["orbit", "volume"])
def test_conservative_flat_original_and_occluder(domain):
    sq = _unit_square()
    assert check_conservative(sq, sq, rays=5000, domain=domain, seed=1).violations == 0
    assert assert_conservative(sq, _scaled(sq, 0.8, (0.5, 0.5, 0)), rays=5000,
                               domain=domain).violations == 0
    grown = check_conservative(sq, _scaled(sq, 1.2, (0.5, 0.5, 0)), rays=5000, domain=domain)
    assert grown.violations > 0
    with pytest.raises(AssertionError):
        assert_conservative(sq, _scaled(sq, 1.2, (0.5, 0.5, 0)), rays=5000, domain=domain)


@pytest.mark.parametrize("domain", ["orbit", "volume"])
def test_conservative_planar_section_of_a_solid(cube, domain):
    """A section strictly inside a closed solid occludes a subset of its rays."""
    section = _scaled(_unit_square(), 1.9, (0, 0, 0))
    section.apply_translation((-0.95, -0.95, 0.1))
    assert check_conservative(cube, section, rays=20000, domain=domain, seed=2).violations == 0


# ---------------------------------------------------------------- silhouettes
def _colours(img):
    names = {v: k for k, v in SILHOUETTE_COLOURS.items()}
    return {names[tuple(int(c) for c in px)] for px in np.unique(img.reshape(-1, 3), axis=0)}


def test_silhouette_flat_original_and_occluder(cube):
    sq = _unit_square()
    assert _colours(silhouette_image(sq, sq, (0, 0, 1), resolution=32)) == {"background", "both"}
    grown = _scaled(sq, 1.2, (0.5, 0.5, 0))
    assert "occluder" in _colours(silhouette_image(sq, grown, (0.2, 0.1, 1), resolution=32))
    section = _scaled(sq, 1.5, (0, 0, 0))
    section.apply_translation((-0.75, -0.75, 0))
    colours = _colours(silhouette_image(cube, section, (0, 0, 1), resolution=32))
    assert colours == {"background", "original", "both"}
