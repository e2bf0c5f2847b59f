"""Orbit precision and recall against a brute-force count, exact to the pixel.

An independent reference for the orbit protocol's bookkeeping (DESIGN.md,
"Evaluation protocols"): the camera frame is rebuilt from the smallest
enclosing sphere of the original's vertices, both coverage images are cast with
:func:`viscore.coverage_image`, and Nt, Pf and Nf are counted with plain Python
loops over every pixel of every quad (no summed-area tables, no vectorised
reduction), then compared with the library's per-view counts and its pooled
P and R, on scenes where P and R lie strictly between 0 and 1.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from viscore import OrthoCamera, Scene, coverage_image
from viscore.metrics import orbit_precision_recall
from viscore.metrics.reference_views import ReferenceViews

#: Small enough for Python loops over every quad's pixels, large enough for
#: quads of several sizes (the box is ~20 pixels wide: widths 1 to 5).
RESOLUTION, VIEWS, QUADS, SEED = 24, 4, 150, 7


def brute_force_counts(original_covered, occluder_covered, quads):
    """Nt, Pf, Nf of the orbit protocol, one pixel at a time.

    ``quads`` are (row0, col0, row1, col1) with exclusive ends.
    """
    nt = pf = nf = 0
    for r0, c0, r1, c1 in quads.tolist():
        n = a = b = 0
        for row in range(r0, r1):
            for col in range(c0, c1):
                n += 1
                a += bool(original_covered[row][col])
                b += bool(occluder_covered[row][col])
        if a == n and b == n:
            nt += n
        elif a == n:
            pf += n
        elif b == n:
            nf += n - a
    return nt, pf, nf


def _frame(mesh):
    """Centre and square extent of the orbit window, from the protocol's definition."""
    center, radius = trimesh.nsphere.minimum_nsphere(mesh.vertices)
    return np.asarray(center, dtype=np.float64), 2.0 * float(radius) * 1.01


def _screen_box(covered):
    rows, cols = np.nonzero(covered)
    return int(rows.min()), int(cols.min()), int(rows.max()) + 1, int(cols.max()) + 1


def _scenes():
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    # wider in x, narrower in y and z than the original: lost and false occlusion both
    skewed = trimesh.creation.box(extents=(1.25, 0.8, 0.85))
    skewed.apply_translation((0.05, -0.04, 0.02))
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.6)
    cube_in_sphere = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    cube_in_sphere.apply_translation((0.08, 0.0, 0.0))
    return [("box-vs-skewed-box", box, skewed), ("sphere-vs-cube", sphere, cube_in_sphere)]


@pytest.mark.parametrize("name, original, occluder", _scenes(), ids=[s[0] for s in _scenes()])
def test_orbit_precision_recall_matches_brute_force(name, original, occluder):
    views = ReferenceViews(original, views=VIEWS, quads=QUADS, resolution=RESOLUTION,
                           seed=SEED, cache=True)
    result = views.score(occluder)
    center, extent = _frame(original)
    assert np.allclose(views.center, center, atol=1e-9) and extent == pytest.approx(
        views.extent, rel=1e-12)
    orig_scene, occ_scene = Scene(original), Scene(occluder)
    totals = np.zeros(3, dtype=np.int64)
    for v, direction in enumerate(views.directions):
        camera = OrthoCamera(direction, center, extent, RESOLUTION)
        # the camera is the one the protocol casts (same origins and directions)
        origins, dirs = views.pixel_rays(v, v)
        own_origins, own_dirs = camera.rays()
        assert np.allclose(origins, own_origins) and np.allclose(dirs, own_dirs)
        a_img = coverage_image(orig_scene, camera)
        b_img = coverage_image(occ_scene, camera)
        quads = views.quads(v)
        assert len(quads) == QUADS
        # the quads obey the protocol: inside the original's screen box, sizes in range
        r0, c0, r1, c1 = _screen_box(a_img)
        h, w = r1 - r0, c1 - c0
        assert (quads[:, 0] >= r0).all() and (quads[:, 2] <= r1).all()
        assert (quads[:, 1] >= c0).all() and (quads[:, 3] <= c1).all()
        widths, heights = quads[:, 3] - quads[:, 1], quads[:, 2] - quads[:, 0]
        assert widths.min() >= 1 and widths.max() <= max(1, w // 4)
        assert heights.min() >= 1 and heights.max() <= max(1, h // 4)
        counts = brute_force_counts(a_img, b_img, quads)
        pv = result.per_view
        assert (pv["nt"][v], pv["pf"][v], pv["nf"][v]) == counts, (name, v)
        totals += counts
    nt, pf, nf = (int(t) for t in totals)
    assert pf > 0 and nf > 0 and nt > 0  # values strictly between 0 and 1
    assert result.precision == nt / (nt + nf)
    assert result.recall == nt / (nt + pf)
    assert 0 < result.precision < 1 and 0 < result.recall < 1
    # the one-call public function gives the same pooled figures
    once = orbit_precision_recall(original, occluder, views=VIEWS, quads=QUADS,
                                  resolution=RESOLUTION, seed=SEED)
    assert (once.precision, once.recall) == (result.precision, result.recall)
