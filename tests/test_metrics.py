import numpy as np
import pytest

from viscore import InputError, load_mesh
from viscore.metrics import (
    assert_conservative,
    check_conservative,
    classify_quads,
    orbit_precision_recall,
    sample_quads,
    volume_precision_recall,
)


def _scaled(mesh, factor, about):
    out = mesh.copy()
    out.apply_translation(-np.asarray(about))
    out.apply_scale(factor)
    out.apply_translation(about)
    return out


# ---------------------------------------------------------------- quads
def test_classify_quads_hand_counts():
    orig = np.zeros((4, 4), bool)
    orig[:, :3] = True
    occ = np.zeros((4, 4), bool)
    occ[:2, :] = True
    quads = np.array([[0, 0, 2, 2],   # both full: Nt 4
                      [2, 0, 4, 2],   # orig full, occ empty: Pf 4
                      [0, 2, 2, 4],   # occ full, orig 2 of 4: Nf 2
                      [2, 2, 4, 4]])  # neither full: nothing
    c = classify_quads(orig, occ, quads)
    assert (c.nt, c.pf, c.nf) == (4, 4, 2)


def test_occluder_counts_kernel_matches_hand_and_table_counts():
    """The one-pass coverage tally counts as the summed-area tables and tally() do: on a
    hand case, and on random images and quads (int16 as cached, boxes at image edges)."""
    from viscore.metrics.quads import ImageQuads, occluder_counts, rect_sums, tally

    orig = np.ones((4, 4), bool)
    occ = orig.copy()
    occ[0, 0] = False
    quads = np.array([[0, 0, 2, 2], [2, 2, 4, 4]], dtype=np.int16)
    n = np.array([4, 4], np.int32)
    ref = ImageQuads(0, 0, (0, 0, 4, 4), quads, n, rect_sums(orig, quads).astype(np.int32))
    c = occluder_counts(ref, occ)
    assert (c.nt, c.pf, c.nf, c.quads, c.q_orig, c.q_occ, c.q_both) == (4, 4, 0, 2, 2, 1, 1)
    rng = np.random.default_rng(3)
    for _ in range(50):
        h, w = rng.integers(1, 40, size=2)
        original = rng.random((h, w)) < rng.random()
        occluder = rng.random((h, w)) < rng.random()
        r0 = rng.integers(0, h, 300)
        c0 = rng.integers(0, w, 300)
        q = np.stack([r0, c0, rng.integers(r0 + 1, h + 1), rng.integers(c0 + 1, w + 1)],
                     axis=1).astype(np.int16)
        n = ((q[:, 2] - q[:, 0]) * (q[:, 3] - q[:, 1])).astype(np.int32)
        a = rect_sums(original, q.astype(np.int64)).astype(np.int32)
        ref = ImageQuads(0, 0, (0, 0, h, w), q, n, a)
        want = tally(n, a, rect_sums(occluder, q.astype(np.int64)))
        assert occluder_counts(ref, occluder) == want


def test_sample_quads_distribution_bounds():
    q = sample_quads((10, 20, 50, 100), 20000, np.random.default_rng(0))
    h, w = q[:, 2] - q[:, 0], q[:, 3] - q[:, 1]
    assert h.min() == 1 and h.max() == 10 and w.min() == 1 and w.max() == 20
    assert q[:, 0].min() >= 10 and q[:, 2].max() <= 50
    assert q[:, 1].min() >= 20 and q[:, 3].max() <= 100


# ---------------------------------------------------------------- orbit / volume
def test_orbit_identical_occluder_is_perfect():
    mesh = load_mesh("fat-torus")
    r = orbit_precision_recall(mesh, mesh, views=8, quads=2000, resolution=64)
    assert r.precision == 1.0 and r.recall == 1.0
    assert r.views == 8 and r.per_view["nt"].sum() > 0


def test_orbit_shrunk_copy_precision_one_recall_below(unit_sphere):
    inner = _scaled(unit_sphere, 0.8, (0.05, -0.02, 0.03))
    r = orbit_precision_recall(unit_sphere, inner, views=8, quads=2000, resolution=64)
    assert r.precision == 1.0
    assert r.recall < 0.95
    assert r.recall_ci[0] <= r.recall <= r.recall_ci[1]


def test_orbit_grown_copy_precision_below_one(unit_sphere):
    outer = _scaled(unit_sphere, 1.2, (0, 0, 0))
    r = orbit_precision_recall(unit_sphere, outer, views=8, quads=2000, resolution=64)
    assert r.precision < 1.0 and r.recall == 1.0


def test_orbit_depth_aware_identical_and_shrunk(unit_sphere):
    same = orbit_precision_recall(unit_sphere, unit_sphere, views=4, quads=2000,
                                  resolution=64, depth_aware=True)
    assert same.precision == 1.0 and same.recall == 1.0
    inner = _scaled(unit_sphere, 0.7, (0, 0, 0))
    r = orbit_precision_recall(unit_sphere, inner, views=4, quads=2000, resolution=64,
                               depth_aware=True)
    assert r.precision == 1.0 and r.recall < 1.0


def test_orbit_empty_occluder_recall_zero(cube):
    r = orbit_precision_recall(cube, None, views=4, quads=500, resolution=32)
    assert r.recall == 0.0 and np.isnan(r.precision)


def test_orbit_seed_reproducible_and_prefix_stable(cube):
    inner = _scaled(cube, 0.6, (0, 0, 0))
    a = orbit_precision_recall(cube, inner, views=6, quads=500, resolution=32, seed=4)
    b = orbit_precision_recall(cube, inner, views=6, quads=500, resolution=32, seed=4)
    np.testing.assert_array_equal(a.per_view["pf"], b.per_view["pf"])
    more = orbit_precision_recall(cube, inner, views=9, quads=500, resolution=32, seed=4)
    np.testing.assert_array_equal(more.per_view["direction"][:6], a.per_view["direction"])
    np.testing.assert_array_equal(more.per_view["pf"][:6], a.per_view["pf"])


def test_volume_identical_and_shrunk(unit_sphere):
    same = volume_precision_recall(unit_sphere, unit_sphere, spacing=0.6, quads=300,
                                   resolution=24)
    assert same.precision == 1.0 and same.recall == 1.0
    inner = _scaled(unit_sphere, 0.8, (0, 0, 0))
    r = volume_precision_recall(unit_sphere, inner, spacing=0.6, quads=300, resolution=24)
    assert r.precision == 1.0 and r.recall < 1.0
    # no view position inside the sphere
    assert (np.linalg.norm(r.per_view["position"], axis=1) > 0.99).all()


def test_volume_merged_agrees_with_plain_within_error():
    mesh = load_mesh("building-house")
    occ = mesh.copy()
    occ.apply_scale(0.92)
    kw = dict(spacing=2.8, quads=300, resolution=24, seed=2)
    plain = volume_precision_recall(mesh, occ, merge_views=False, **kw)
    merged = volume_precision_recall(mesh, occ, merge_views=True, **kw)
    assert merged.views < plain.views
    assert merged.per_view["weight"].sum() == pytest.approx(plain.per_view["weight"].sum())
    for key in ("precision", "recall"):
        half = lambda r, k=key: (getattr(r, k + "_ci")[1] - getattr(r, k + "_ci")[0]) / 2  # noqa: E731
        se = np.hypot(half(plain), half(merged)) / 1.96
        assert abs(getattr(plain, key) - getattr(merged, key)) < 4 * se + 1e-3


def test_precision_recall_invalid_input(cube):
    with pytest.raises(InputError):
        orbit_precision_recall(cube, cube, views=0)
    with pytest.raises(InputError):
        volume_precision_recall(cube, cube, quads=-1)


# ---------------------------------------------------------------- conservativeness
def test_conservative_inner_copy_zero_violations(cube):
    inner = _scaled(cube, 0.9, (0, 0, 0))
    for domain in ("orbit", "volume"):
        rep = check_conservative(cube, inner, rays=20000, domain=domain, seed=1)
        assert rep.violations == 0
        assert rep.violation_upper_bound == pytest.approx(1 - 0.05 ** (1 / 20000), rel=1e-6)


def test_conservative_grown_copy_violates_and_reports_worst(cube):
    outer = _scaled(cube, 1.1, (0, 0, 0))
    rep = check_conservative(cube, outer, rays=5000, seed=0)
    assert rep.violation_rate > 0.5
    w = rep.worst[0]
    assert w["t_original"] is None or w["t_occluder"] < w["t_original"]


def test_assert_conservative_raises_with_report(cube):
    outer = _scaled(cube, 1.1, (0, 0, 0))
    with pytest.raises(AssertionError, match="upper bound"):
        assert_conservative(cube, outer, rays=2000)
    assert assert_conservative(cube, _scaled(cube, 0.5, (0, 0, 0)), rays=2000).violations == 0


def test_conservative_invalid_input(cube):
    with pytest.raises(InputError):
        check_conservative(cube, cube, rays=0)
    with pytest.raises(InputError):
        check_conservative(cube, cube, confidence=1.5)
    with pytest.raises(InputError):
        check_conservative(cube, cube, domain="sky")
