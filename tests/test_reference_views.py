import pickle

import numpy as np
import pytest
import trimesh

from viscore import InputError, OrthoCamera, load_mesh
from viscore.metrics import (
    ReferenceViews,
    evaluate,
    orbit_precision_recall,
    volume_precision_recall,
)
from viscore.metrics._views import ortho_box_rays

ORBIT = dict(views=6, quads=800, resolution=32, seed=5)
VOLUME = dict(protocol="volume", spacing=0.9, quads=200, resolution=12, seed=1)


def _same(a, b):
    """Bit-identical results (timings aside)."""
    assert a.precision == b.precision or (np.isnan(a.precision) and np.isnan(b.precision))
    assert a.recall == b.recall
    np.testing.assert_array_equal(a.precision_ci, b.precision_ci)
    np.testing.assert_array_equal(a.recall_ci, b.recall_ci)
    assert a.per_view.keys() == b.per_view.keys()
    for k in a.per_view:
        np.testing.assert_array_equal(a.per_view[k], b.per_view[k])
    assert a.params == b.params and a.protocol == b.protocol and a.seed == b.seed


def _scaled(mesh, factor, about=(0, 0, 0)):
    out = mesh.copy()
    out.apply_translation(-np.asarray(about))
    out.apply_scale(factor)
    out.apply_translation(about)
    return out


@pytest.fixture(scope="module")
def torus():
    return load_mesh("fat-torus")


# ---------------------------------------------------------------- reference values
@pytest.mark.parametrize("settings", [ORBIT, VOLUME], ids=["orbit", "volume"])
@pytest.mark.parametrize("depth_aware", [False, True])
def test_score_identical_occluder_is_perfect(torus, settings, depth_aware):
    views = ReferenceViews(torus, depth_aware=depth_aware, **settings)
    r = views.score(torus)
    assert r.precision == 1.0 and r.recall == 1.0
    assert r.per_view["nt"].sum() > 0


@pytest.mark.parametrize("settings", [ORBIT, VOLUME], ids=["orbit", "volume"])
def test_score_bounding_box_recall_one_precision_below(torus, settings):
    views = ReferenceViews(torus, **settings)
    r = views.score(trimesh.creation.box(bounds=torus.bounds))
    assert r.recall == 1.0 and r.precision < 1.0


@pytest.mark.parametrize("settings", [ORBIT, VOLUME], ids=["orbit", "volume"])
def test_score_nothing_recall_zero(torus, settings):
    r = ReferenceViews(torus, **settings).score(None)
    assert r.recall == 0.0 and np.isnan(r.precision)


# ---------------------------------------------------------------- same as the one-call protocols
@pytest.mark.parametrize("depth_aware", [False, True])
def test_score_equals_orbit_precision_recall_and_repeats(torus, depth_aware):
    inner = _scaled(torus, 0.85, (0.05, 0, 0.02))
    views = ReferenceViews(torus, depth_aware=depth_aware, **ORBIT)
    assert views.cached
    first = views.score(inner)
    _same(first, orbit_precision_recall(torus, inner, depth_aware=depth_aware, **ORBIT))
    views.score(torus)  # another occluder in between changes nothing
    _same(first, views.score(inner))
    _same(first, ReferenceViews(torus, depth_aware=depth_aware, cache=False, **ORBIT)
          .score(inner))


@pytest.mark.parametrize("depth_aware", [False, True])
def test_score_equals_volume_precision_recall_occluder_beyond_mesh_box(torus, depth_aware):
    # a grown occluder: frusta that see only its box are counted, and the
    # quads of their positions are drawn again, as in the one-call protocol
    kw = {k: v for k, v in VOLUME.items() if k != "protocol"}
    for occ in (_scaled(torus, 0.9), _scaled(torus, 1.3, (0.4, 0, 0))):
        one = volume_precision_recall(torus, occ, depth_aware=depth_aware, **kw)
        cached = ReferenceViews(torus, depth_aware=depth_aware, **VOLUME)
        _same(one, cached.score(occ))
        _same(one, ReferenceViews(torus, depth_aware=depth_aware, cache=False, **VOLUME)
              .score(occ))
    assert one.timing["frusta"] > len(cached.images)  # the grown box adds frusta


def test_reference_views_pickle_round_trip(torus):
    views = ReferenceViews(torus, **ORBIT)
    inner = _scaled(torus, 0.8)
    _same(views.score(inner), pickle.loads(pickle.dumps(views)).score(inner))


def test_ortho_box_rays_bit_identical_to_the_whole_image():
    cam = OrthoCamera((0.3, -0.5, 0.8), (0.1, 0.2, -0.3), 2.7, 16)
    o, d = cam.rays()
    box = (3, 5, 11, 14)
    ob, db = ortho_box_rays(cam, box)
    np.testing.assert_array_equal(ob, o.reshape(16, 16, 3)[3:11, 5:14].reshape(-1, 3))
    np.testing.assert_array_equal(db, d.reshape(16, 16, 3)[3:11, 5:14].reshape(-1, 3))


def test_ortho_box_rays_bit_identical_on_random_cameras_and_boxes():
    """The compiled rays are those of the camera's numpy expression, bit for bit, over
    scales, resolutions, boxes and the whole image (the one the protocols cast)."""
    rng = np.random.default_rng(7)
    for _ in range(60):
        res = int(rng.integers(2, 80))
        cam = OrthoCamera(rng.normal(size=3), rng.normal(size=3) * rng.uniform(0.01, 100),
                          float(rng.uniform(1e-3, 1e3)), res)
        o, d = cam.rays()
        r0, r1 = sorted(rng.integers(0, res + 1, 2))
        c0, c1 = sorted(rng.integers(0, res + 1, 2))
        for box in ((r0, c0, r1, c1), (0, 0, res, res)):
            ob, db = ortho_box_rays(cam, box)
            part = (slice(box[0], box[2]), slice(box[1], box[3]))
            np.testing.assert_array_equal(ob, o.reshape(res, res, 3)[part].reshape(-1, 3))
            np.testing.assert_array_equal(db, d.reshape(res, res, 3)[part].reshape(-1, 3))


# ---------------------------------------------------------------- inspection
def test_depth_images_float32_and_quads_inside_images(torus):
    views = ReferenceViews(torus, **ORBIT)
    img = views.depth_images()
    assert img.dtype == np.float32 and img.shape == (6, 32, 32)
    assert np.isfinite(img).any(axis=(1, 2)).all()
    for k in range(len(views.images)):
        q = views.quads(k)
        assert q.shape == (800, 4) and q.min() >= 0 and q[:, 2:].max() <= 32
    uncached = ReferenceViews(torus, cache=False, **ORBIT)
    np.testing.assert_array_equal(uncached.quads(4), views.quads(4))


# ---------------------------------------------------------------- refusals before any work
def test_reference_views_invalid_input(torus):
    with pytest.raises(InputError, match="'orbit', 'volume'"):
        ReferenceViews(torus, protocol="orbti")
    with pytest.raises(InputError, match="spacing"):
        ReferenceViews(torus, protocol="orbit", spacing=0.5)
    with pytest.raises(InputError, match="views"):
        ReferenceViews(torus, protocol="volume", views=8)
    with pytest.raises(InputError):
        ReferenceViews(torus, quads=0)
    with pytest.raises(InputError):
        ReferenceViews(torus, seed=-5)
    with pytest.raises(InputError):
        ReferenceViews(trimesh.Trimesh(), views=2)
    with pytest.raises(InputError, match="cache"):
        ReferenceViews(torus, cache="yes")


def test_evaluate_protocol_validated(torus):
    with pytest.raises(InputError, match="'orbit', 'volume'"):
        evaluate(torus, torus, protocol="orbti")
    with pytest.raises(InputError, match="'orbit', 'volume'"):
        evaluate(torus, torus, protocol=None)


def test_reference_views_tiny_spacing_refused_not_overflowed(torus):
    # 1e-9 spacing: ~1e27 grid positions, past int64; refused with the limit
    with pytest.raises(InputError, match="grid positions"):
        ReferenceViews(torus, protocol="volume", spacing=1e-9)


def test_reference_views_memory_refused_before_work(torus, monkeypatch):
    import time

    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", "1e-6")
    start = time.perf_counter()
    with pytest.raises(InputError, match="memory"):
        ReferenceViews(torus, resolution=8192, depth_aware=True)
    with pytest.raises(InputError, match="memory"):
        ReferenceViews(torus, views=8, quads=100, resolution=16, cache=True)
    assert time.perf_counter() - start < 5  # refused before casting 8192^2 rays


def test_reference_views_cache_falls_back_when_it_does_not_fit(torus, monkeypatch):
    full = ReferenceViews(torus, **ORBIT).score(torus)
    # room for one image's rays but not for every quad: cache=None recasts per score
    from viscore.metrics import reference_views

    monkeypatch.setattr(reference_views, "memory_limit", lambda: 1.0 * 2**20)
    views = ReferenceViews(torus, **{**ORBIT, "quads": 20000})
    assert not views.cached
    assert views.score(torus).recall == full.recall == 1.0


# ---------------------------------------------------------------- plausible bugs
def test_orbit_quads_fill_exactly_the_covered_pixels_box(torus):
    # quads over the whole screen, or a box off by one pixel, would move the extremes
    views = ReferenceViews(torus, views=5, quads=4000, resolution=40, seed=3)
    depth = views.depth_images()
    for k in range(len(views.images)):
        covered = np.isfinite(depth[k])
        rows = np.flatnonzero(covered.any(axis=1))
        cols = np.flatnonzero(covered.any(axis=0))
        q = views.quads(k)
        assert (q[:, 0].min(), q[:, 1].min()) == (rows[0], cols[0])
        assert (q[:, 2].max(), q[:, 3].max()) == (rows[-1] + 1, cols[-1] + 1)
        assert (q[:, 2] > q[:, 0]).all() and (q[:, 3] > q[:, 1]).all()
        assert 0 < rows[-1] - rows[0] + 1 < 40  # the box is smaller than the screen


def test_classify_quads_depth_strictly_nearer_occludes():
    from viscore.metrics import classify_quads_depth

    # one level: the midpoint 0.5 of the original's depths [0, 1]; a pixel AT the
    # quad's depth does not occlude it (strict <), one in front does
    original = np.array([[0.0, 1.0], [0.5, 0.5]])
    occluder = np.zeros((2, 2))
    quads = np.array([[1, 0, 2, 2],    # the two pixels at depth 0.5: not occluded
                      [0, 0, 1, 1]])   # the pixel at 0: occluded by both
    c = classify_quads_depth(original, occluder, quads, np.random.default_rng(0),
                             depth_levels=1)
    assert (c.nt, c.pf, c.nf) == (1, 0, 2)


def test_classify_quads_depth_levels_span_the_original_not_the_occluder():
    from viscore.metrics import classify_quads_depth

    # the original spans [0.2, 0.8]: one level at 0.5. The occluder (all at 0)
    # occludes the quad; the original only its first pixel. Levels from the
    # occluder's range (0) would count nothing at all.
    original = np.array([[0.2, 0.8]])
    occluder = np.zeros((1, 2))
    c = classify_quads_depth(original, occluder, np.array([[0, 0, 1, 2]]),
                             np.random.default_rng(0), depth_levels=1)
    assert (c.nt, c.pf, c.nf) == (0, 0, 1)


def test_orbit_quad_depths_within_the_originals_depths(torus):
    views = ReferenceViews(torus, views=4, quads=500, resolution=32, seed=1, depth_aware=True)
    depth = views.depth_images()
    far = _scaled(torus, 0.5)  # another occluder's depths change nothing here
    before = [views.quad_depths(k).copy() for k in range(4)]
    views.score(far)
    for k in range(4):
        z = views.quad_depths(k)
        finite = depth[k][np.isfinite(depth[k])]
        tol = 1e-5 * float(finite.max())  # depth images are float32
        assert z.min() >= finite.min() - tol and z.max() <= finite.max() + tol
        assert len(np.unique(z)) > 1
        np.testing.assert_array_equal(z, before[k])


def test_reference_views_refuse_quads_that_do_not_fit_even_uncached(torus):
    # one batch of images' quads must fit: 1e12 quads raised a MemoryError (exit 3)
    for cache in (None, False):
        with pytest.raises(InputError, match="needs about"):
            ReferenceViews(torus, views=2, quads=10**12, resolution=16, cache=cache)
