import json

import numpy as np
import pytest
import trimesh

from viscore import InputError, load_mesh, stream_seed
from viscore.generators import get_generator
from viscore.metrics import (
    OccluderAssessment,
    PrecisionRecall,
    ReferenceViews,
    assess_occluder,
    check_conservative,
    occlusion_measure,
)

VIEWS = dict(views=6, quads=600, resolution=32, seed=2)


@pytest.fixture(scope="module")
def torus():
    return load_mesh("fat-torus")


@pytest.fixture(scope="module")
def views(torus):
    return ReferenceViews(torus, **VIEWS)


def _inner(mesh, factor=0.85):
    out = mesh.copy()
    out.apply_scale(factor)
    return out


def _json_round_trip(doc: dict) -> dict:
    return json.loads(json.dumps(doc, allow_nan=False))


def _assert_same(a, b):
    """Two result dataclasses equal field by field (arrays and NaN included)."""
    assert type(a) is type(b)
    for name in a.__dataclass_fields__:
        x, y = getattr(a, name), getattr(b, name)
        if name == "per_view":
            assert x.keys() == y.keys()
            for k in x:
                np.testing.assert_array_equal(np.asarray(x[k]), np.asarray(y[k]))
        elif isinstance(x, float):
            assert x == y or (np.isnan(x) and np.isnan(y)), name
        elif isinstance(x, list):
            np.testing.assert_array_equal(np.asarray(x, float), np.asarray(y, float))
        else:
            assert x == y, name


def test_assess_occluder_matches_the_separate_steps(torus, views):
    occ = _inner(torus)
    a = assess_occluder(views, occ, directions=3, rays=2000)
    pr = views.score(occ)
    om = occlusion_measure(occ, directions=3, resolution=32,
                           seed=stream_seed(2, "occlusion-measure"))
    cons = check_conservative(torus, occ, rays=2000, seed=stream_seed(2, "conservativeness"))
    assert (a.precision, a.recall, a.precision_ci, a.recall_ci) == (
        pr.precision, pr.recall, pr.precision_ci, pr.recall_ci)
    assert a.occlusion_measure == om.occlusion_measure
    assert a.occlusion_measure_se == om.occlusion_measure_se
    assert (a.violations, a.rays, a.violation_upper_bound) == (
        cons.violations, 2000, cons.violation_upper_bound)
    assert a.triangles == len(occ.faces) and a.method is None and np.isnan(a.seconds)
    assert a.recall < 1.0 and a.violations > 0  # a shrunk torus is not inside the torus


def test_assess_occluder_carries_the_generator_fields(torus, views):
    occ = get_generator("bbox").function(torus)
    a = assess_occluder(views, occ, directions=2, rays=1000)
    assert a.method == "bbox" and a.triangles == 12 and a.seconds == occ.seconds
    assert a.params == occ.params and a.recall == 1.0 and a.precision < 1.0


def test_assess_occluder_mesh_reference_builds_the_same_views(torus, views):
    occ = _inner(torus, 0.7)
    a = assess_occluder(views, occ, directions=2, rays=1000)
    b = assess_occluder(torus, occ, directions=2, rays=1000, view_settings=VIEWS)
    strip = lambda d: {k: v for k, v in d.items() if not k.startswith("seconds")}  # noqa: E731
    assert strip(a.to_json()) == strip(b.to_json())


@pytest.mark.parametrize("occluder", ["inner", None])
def test_occluder_assessment_json_round_trip(torus, views, occluder):
    a = assess_occluder(views, _inner(torus) if occluder else None, directions=2, rays=500)
    doc = _json_round_trip(a.to_json())
    back = OccluderAssessment.from_json(doc)
    _assert_same(a, back)
    assert back.to_json() == a.to_json()
    if occluder is None:  # NaN precision and per-view NaNs survive JSON as null
        assert np.isnan(back.precision) and np.isnan(back.per_view["precision"]).all()
    # the PrecisionRecall inside comes back too, with its per-view arrays
    pr = back.precision_recall()
    assert pr.protocol == "orbit" and pr.seed == 2 and pr.views == 6
    assert pr.per_view["nt"].dtype.kind == "i"


def test_precision_recall_json_round_trip(torus, views):
    for r in (views.score(_inner(torus)), views.score(None),
              ReferenceViews(torus, protocol="volume", spacing=1.0, quads=100,
                             resolution=8).score(_inner(torus))):
        back = PrecisionRecall.from_json(_json_round_trip(r.to_json()))
        _assert_same(r, back)


def test_assess_occluder_invalid_input(torus, views):
    with pytest.raises(InputError, match="reference"):
        assess_occluder("bunny", torus)
    with pytest.raises(InputError, match="view_settings"):
        assess_occluder(views, torus, view_settings={"views": 4})
    with pytest.raises(InputError, match="domain"):
        assess_occluder(views, torus, domain="sky")
    with pytest.raises(InputError, match="confidence"):
        assess_occluder(views, torus, confidence=1.0)
    with pytest.raises(InputError, match="occluder"):
        assess_occluder(views, "not a mesh")
    with pytest.raises(InputError):
        assess_occluder(views, torus, rays=0)
    with pytest.raises(InputError):
        assess_occluder(torus, torus, view_settings={"protocol": "orbti"})


def test_assess_occluder_empty_occluder_measures_zero(views):
    a = assess_occluder(views, trimesh.Trimesh(), directions=2, rays=500)
    assert a.triangles == 0 and a.occlusion_measure == 0.0 and a.recall == 0.0
    assert a.violations == 0


def test_assess_occluder_builds_one_scene_per_mesh(monkeypatch, torus, views):
    """The occluder's Scene is built once for the three steps; the original's never again."""
    from viscore.ray.embree_scene import Scene

    built = []
    init = Scene.__init__

    def counting(self, mesh, **kw):
        init(self, mesh, **kw)
        built.append(mesh)

    monkeypatch.setattr(Scene, "__init__", counting)
    occ = _inner(torus)
    for domain in ("orbit", "volume"):
        built.clear()
        assess_occluder(views, occ, directions=2, rays=500, domain=domain)
        assert len(built) == 1 and built[0] is not torus, domain
    built.clear()
    assess_occluder(views, None, directions=2, rays=500)
    assert built == []


def test_steps_take_prebuilt_scenes(torus, views):
    """Scenes (and the views' frame) in place of meshes give the same figures."""
    from viscore import Scene

    occ = _inner(torus)
    scene = Scene(occ)
    assert views.scene.diagonal == Scene(torus).diagonal
    a, b = views.score(scene), views.score(occ)
    assert (a.precision, a.recall, a.precision_ci) == (b.precision, b.recall, b.precision_ci)
    np.testing.assert_array_equal(a.per_view["nt"], b.per_view["nt"])
    seed = stream_seed(2, "conservativeness")
    for domain, frame in (("orbit", (views.center, views.extent)), ("volume", None)):
        x = check_conservative(views.scene, scene, rays=2000, seed=seed, domain=domain,
                               frame=frame)
        y = check_conservative(torus, occ, rays=2000, seed=seed, domain=domain)
        assert (x.violations, x.worst, x.eps) == (y.violations, y.worst, y.eps), domain
    m = occlusion_measure(scene, directions=3, resolution=32, seed=1)
    n = occlusion_measure(occ, directions=3, resolution=32, seed=1)
    assert (m.occlusion_measure, m.occlusion_measure_se) == (
        n.occlusion_measure, n.occlusion_measure_se)
    with pytest.raises(InputError, match="frame"):
        check_conservative(torus, occ, rays=10, frame=(1, 2, 3))
