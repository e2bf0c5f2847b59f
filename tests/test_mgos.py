"""Metric-guided occluder simplification (Wu et al. 2022, sec. 3.3): hybrid/metric_guided.py."""

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.generators.hybrid._face_tallies import _State
from viscore.generators.hybrid.metric_guided import metric_guided_simplify
from viscore.metrics.reference_views import ReferenceViews

#: Small volume-protocol settings: ~100 positions, 16 x 16 pixels, 60 quads per frustum.
SMALL = {"resolution": 16, "quads": 60, "spacing": 1.2, "seed": 0}


def _box():
    return trimesh.creation.box(extents=(2.0, 2.0, 2.0))


def _sheet(x: float, half: float, *, y: float = 0.0, z: float = 0.0) -> trimesh.Trimesh:
    """A square of side 2 * half in the plane X = x (two triangles, open)."""
    v = [[x, y - half, z - half], [x, y + half, z - half], [x, y + half, z + half],
         [x, y - half, z + half]]
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


def _join(*meshes) -> trimesh.Trimesh:
    return trimesh.util.concatenate(list(meshes))


@pytest.fixture(scope="module")
def box_views():
    return ReferenceViews(_box(), protocol="volume", **SMALL)


def test_metric_guided_simplify_stray_face_removed_by_precision_step(box_views):
    # a sheet floating beside the box covers quads the box does not: false occlusion only
    occ = _join(_box(), _sheet(1.7, 0.6))
    out, info = metric_guided_simplify(_box(), occ, reference=box_views, eps_r=1e-9)
    assert info["precision_before"] < 1.0
    assert info["removed_precision"] == 2
    assert 12 not in info["kept"] and 13 not in info["kept"]
    assert info["precision_after"] > info["precision_before"]
    assert info["precision_after"] == 1.0
    assert info["recall_after"] == info["recall_before"] == 1.0


def test_metric_guided_simplify_hidden_face_removed_without_recall_change(box_views):
    # a small triangle inside the closed box: every ray through it crosses the box twice
    tiny = trimesh.Trimesh([[0, 0, 0], [0.2, 0, 0], [0, 0.2, 0.1]], [[0, 1, 2]])
    occ = _join(_box(), tiny)
    before = box_views.score(occ)
    out, info = metric_guided_simplify(_box(), occ, reference=box_views, eps_r=1e-9)
    assert (info["precision_before"], info["recall_before"]) == (before.precision,
                                                                  before.recall)
    assert 12 not in info["kept"]
    assert info["removed_recall"] >= 1
    assert info["recall_after"] == before.recall == 1.0
    assert info["precision_after"] == before.precision


def test_metric_guided_simplify_eps_zero_removes_nothing(box_views):
    tiny = trimesh.Trimesh([[0, 0, 0], [0.2, 0, 0], [0, 0.2, 0.1]], [[0, 1, 2]])
    out, info = metric_guided_simplify(_box(), _join(_box(), tiny), reference=box_views,
                                       eps_r=0.0)
    assert info["removed_recall"] == 0 and info["faces_after"] == 13


def test_metric_guided_simplify_every_face_matters_keeps_all():
    # one open sheet as original and occluder: each triangle alone covers its pixels
    sheet = _sheet(0.0, 1.0)
    views = ReferenceViews(sheet, protocol="volume", **SMALL)
    out, info = metric_guided_simplify(sheet, sheet, reference=views, eps_r=1e-12)
    assert info["removed_precision"] == 0 and info["removed_recall"] == 0
    assert len(out.faces) == 2
    # and with a large eps both go (recall then 0)
    out, info = metric_guided_simplify(sheet, sheet, reference=views, eps_r=1.0)
    assert len(out.faces) < 2


def test_state_tracked_tallies_equal_fresh_score(box_views):
    occ = _join(_box(), _sheet(1.5, 0.5), _sheet(-0.2, 0.3))
    state = _State(box_views, occ, skip_unseen=True, skip_backfacing=False)
    order = np.random.default_rng(3).permutation(len(occ.faces))
    for f in order[:5]:
        state.remove(int(f))
        kept = trimesh.Trimesh(occ.vertices, occ.faces[state.alive], process=False)
        fresh = box_views.score(kept)
        for key, mine in (("nt", state.nt), ("pf", state.pf), ("nf", state.nf)):
            np.testing.assert_array_equal(mine, fresh.per_view[key])
        assert state.figures() == pytest.approx((fresh.precision, fresh.recall), abs=1e-12)


def test_state_pixel_rays_are_the_reference_rays(box_views):
    occ = _join(_box(), _sheet(1.5, 0.5))
    state = _State(box_views, occ, skip_unseen=True, skip_backfacing=False)
    assert state._rays_by_table
    pixels = np.random.default_rng(1).permutation(len(state.a_loc))[:200]
    origins, dirs = state._pixel_rays(pixels)
    for k, p in enumerate(pixels):  # each pixel's ray as ReferenceViews casts it
        r = state.live[state.a_img[p]]
        o, d = box_views.pixel_rays(r.unit, r.cam, r.box)
        assert np.array_equal(origins[k], o[state.a_loc[p]])
        assert np.array_equal(dirs[k], d[state.a_loc[p]])


def test_state_face_pixel_lists_ascend_strictly(box_views):
    """remove() takes a face's own pixels as they are listed: ascending, each once."""
    occ = _join(_box(), _sheet(0.5, 0.4), _sheet(0.5, 0.4))  # a duplicated face too
    state = _State(box_views, occ, skip_unseen=True, skip_backfacing=False)
    for f in range(len(occ.faces)):
        own = state.fpix[state.fptr[f]:state.fptr[f + 1]]
        assert np.all(np.diff(own) > 0)
    assert state.fptr[-1] > 0


def test_state_kept_losses_equal_recomputed(box_views):
    occ = _join(_box(), _sheet(0.5, 0.4))
    state = _State(box_views, occ, skip_unseen=True, skip_backfacing=False)
    state.refresh_losses()
    for f in (0, 5, 12):
        state.remove(f)
    kept_loss, kept_relief = state.loss.copy(), state.relief.copy()
    state.refresh_losses()
    alone = state.rep[state.group_alone()]
    np.testing.assert_allclose(kept_loss[alone], state.loss[alone], atol=1e-12)
    np.testing.assert_allclose(kept_relief[alone], state.relief[alone], atol=1e-12)


@pytest.mark.parametrize("turn", [False, True])
def test_state_recall_loss_is_the_drop_in_recall(box_views, turn):
    # the kept loss is the exact drop where no pixel ray runs through a shared edge (a
    # generic rotation); rays through an edge list one of its two faces, so there the
    # loss can only be overestimated (the tallies stay exact: see the test above)
    occ = _join(_box(), _sheet(1.5, 0.5))
    if turn:
        occ.apply_transform(trimesh.transformations.random_rotation_matrix(
            np.random.default_rng(7).random(3)) @ np.diag([0.7, 0.7, 0.7, 1]))
    state = _State(box_views, occ, skip_unseen=True, skip_backfacing=False)
    state.remove(0)
    state.refresh_losses()
    r0 = state.figures()[1]
    for f in np.flatnonzero(state.group_alone())[:3]:
        trial = _State(box_views, occ, skip_unseen=True, skip_backfacing=False)
        trial.remove(0)
        trial.remove(int(f))
        drop = r0 - trial.figures()[1]
        if turn:
            assert drop == pytest.approx(state.loss[state.rep[f]], abs=1e-12)
        else:
            assert drop <= state.loss[state.rep[f]] + 1e-12


def test_metric_guided_simplify_duplicate_faces_share_coverage(box_views):
    sheet = _sheet(1.7, 0.6)
    occ = _join(_box(), sheet, sheet)  # the sheet twice
    state = _State(box_views, occ, skip_unseen=True, skip_backfacing=False)
    assert (state.members[state.rep[12:]] == 2).all()
    before = box_views.score(occ)
    state.remove(12)  # its copy still covers the same pixels
    np.testing.assert_array_equal(state.nf, before.per_view["nf"])


def test_metric_guided_simplify_skip_unseen_is_exact(box_views):
    # an occluder smaller than the box: some frusta see the box but not the occluder's box
    occ = _join(trimesh.creation.box(extents=(1.0, 1.0, 1.0)), _sheet(-1.5, 0.3))
    _, base = metric_guided_simplify(_box(), occ, reference=box_views, skip_unseen=False)
    _, skip = metric_guided_simplify(_box(), occ, reference=box_views, skip_unseen=True)
    assert skip["kept"] == base["kept"]
    assert skip["recall_after"] == base["recall_after"]
    assert skip["precision_after"] == base["precision_after"]
    assert skip["rays"] < base["rays"]


def test_metric_guided_simplify_skip_backfacing_precision_step(box_views):
    # the precision step on front-facing candidates: the same choice either way
    occ = _join(_box(), _sheet(1.7, 0.6))
    _, base = metric_guided_simplify(_box(), occ, reference=box_views, eps_r=0.0)
    _, back = metric_guided_simplify(_box(), occ, reference=box_views, eps_r=0.0,
                                     skip_backfacing=True)
    assert back["kept"] == base["kept"] == list(range(12))


def test_metric_guided_simplify_skip_backfacing_misjudges_open_occluders(box_views):
    # double-sided scoring: once a face of the closed box goes, the views through the hole
    # see the inner sides of the others; the paper's rule ignores them and removes faces
    # whose loss is not zero, so recall falls where the exact evaluation keeps it at 1
    occ = _join(_box(), _sheet(1.7, 0.6))
    _, base = metric_guided_simplify(_box(), occ, reference=box_views, eps_r=1e-9)
    _, back = metric_guided_simplify(_box(), occ, reference=box_views, eps_r=1e-9,
                                     skip_backfacing=True)
    assert base["recall_after"] == 1.0
    assert back["recall_after"] < base["recall_after"]
    assert back["faces_after"] < base["faces_after"]


def test_metric_guided_simplify_builds_its_own_reference():
    box = _box()
    occ = _join(box, _sheet(1.7, 0.6))
    out, info = metric_guided_simplify(box, occ, **SMALL)
    assert info["settings"]["resolution"] == 16 and info["settings"]["quads"] == 60
    assert len(out.faces) <= 12


def test_metric_guided_simplify_empty_occluder(box_views):
    empty = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), int))
    out, info = metric_guided_simplify(_box(), empty, reference=box_views)
    assert len(out.faces) == 0 and info["faces_after"] == 0 and info["recall_after"] == 0


@pytest.mark.parametrize("kwargs, match", [
    ({"eps_p": -0.1}, "eps_p"), ({"eps_r": 2.0}, "eps_r"), ({"eps_p": float("nan")}, "eps_p"),
    ({"skip_unseen": 1}, "skip_unseen"), ({"skip_backfacing": "yes"}, "skip_backfacing"),
    ({"seed": -1}, "seed"), ({"quads": 0}, "quads"), ({"resolution": 0}, "resolution"),
    ({"spacing": -1.0}, "spacing"), ({"max_faces": 0}, "max_faces"),
])
def test_metric_guided_simplify_invalid_input(kwargs, match):
    with pytest.raises(InputError, match=match):
        metric_guided_simplify(_box(), _box(), **kwargs)


def test_metric_guided_simplify_invalid_reference(box_views):
    with pytest.raises(InputError, match="quads"):
        metric_guided_simplify(_box(), _box(), reference=box_views, quads=10)
    with pytest.raises(InputError, match="ReferenceViews"):
        metric_guided_simplify(_box(), _box(), reference="views")
    orbit = ReferenceViews(_box(), views=2, quads=10, resolution=8)
    with pytest.raises(InputError, match="volume"):
        metric_guided_simplify(_box(), _box(), reference=orbit)
    other = trimesh.creation.icosphere(subdivisions=1)
    with pytest.raises(InputError, match="another mesh"):
        metric_guided_simplify(other, _box(), reference=box_views)
    with pytest.raises(InputError, match="occluder_mesh"):
        metric_guided_simplify(_box(), "box", reference=box_views)


def test_metric_guided_simplify_max_faces_continues_the_greedy(box_views):
    occ = _join(_box(), _sheet(1.7, 0.6))
    _, free = metric_guided_simplify(_box(), occ, reference=box_views, eps_r=1e-9)
    out, info = metric_guided_simplify(_box(), occ, reference=box_views, eps_r=1e-9,
                                       max_faces=6)
    assert len(out.faces) == info["faces_after"] == 6
    assert info["removed_budget"] == free["faces_after"] - 6
    assert info["eps_r_final"] > 1e-9
    assert info["recall_after"] < free["recall_after"]
    # the same as a larger threshold just above the last loss removed
    _, wide = metric_guided_simplify(_box(), occ, reference=box_views,
                                     eps_r=info["eps_r_final"] * (1 + 1e-9))
    assert wide["faces_after"] <= 6


def test_metric_guided_simplify_kept_indexes_the_given_faces(box_views):
    # a degenerate face first: validation drops it, ``kept`` still indexes the input
    flat = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]], process=False)
    occ = _join(flat, _box(), _sheet(1.7, 0.6))
    out, info = metric_guided_simplify(_box(), occ, reference=box_views, eps_r=0.0)
    assert info["faces_before"] == 14
    assert info["kept"] == list(range(1, 13))
    np.testing.assert_allclose(out.vertices[out.faces], occ.vertices[occ.faces[1:13]])


def test_metric_guided_simplify_memory_checked_before_casting(box_views, monkeypatch):
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", "1e-12")
    with pytest.raises(InputError, match="metric-guided simplification"):
        metric_guided_simplify(_box(), _box(), reference=box_views)


def test_state_lists_coplanar_overlapping_faces():
    # a small triangle lying in the sheet: all-hits lists one of the two per ray; the
    # coplanar partner rule adds the other, so no pixel needs a re-cast when the sheet goes
    sheet = _sheet(0.0, 1.0)
    small = trimesh.Trimesh([[0, -0.5, -0.4], [0, 0.45, -0.5], [0, 0.1, 0.5]], [[0, 1, 2]])
    occ = _join(sheet, small)
    views = ReferenceViews(sheet, protocol="volume", **SMALL)
    state = _State(views, occ, skip_unseen=True, skip_backfacing=False)
    state.refresh_losses()
    assert state.loss[2] == 0.0  # the sheet covers all its pixels
    state.remove(0)
    state.remove(1)
    assert state.refound == 0
    fresh = views.score(small)
    np.testing.assert_array_equal(state.nt, fresh.per_view["nt"])
    np.testing.assert_array_equal(state.nf, fresh.per_view["nf"])


def test_metric_guided_simplify_precision_floor_removes_spread_false_occlusion(box_views):
    # a stray sheet whose removal gains less than eps_p = 1: the paper's step keeps it
    # (and eps_r = 0 keeps every face in the recall step); the floor removes it while
    # precision is under the floor, and only then
    occ = _join(_box(), _sheet(1.7, 0.6))
    kept, plain = metric_guided_simplify(_box(), occ, reference=box_views, eps_p=1.0,
                                         eps_r=0.0)
    assert plain["removed_precision"] == 0 and plain["precision_after"] < 1.0
    assert {12, 13} <= set(plain["kept"]) and plain["removed_floor"] == 0
    out, info = metric_guided_simplify(_box(), occ, reference=box_views, eps_p=1.0,
                                       eps_r=0.0, min_precision=0.999)
    assert info["removed_floor"] == 2 and not {12, 13} & set(info["kept"])
    assert info["precision_after"] == 1.0 and info["recall_after"] == 1.0
    # a floor already met removes nothing
    _, met = metric_guided_simplify(_box(), occ, reference=box_views, eps_p=1.0, eps_r=0.0,
                                    min_precision=plain["precision_after"] * 0.999)
    assert met["removed_floor"] == 0
    with pytest.raises(InputError, match="min_precision"):
        metric_guided_simplify(_box(), occ, reference=box_views, min_precision=1.5)


def _near_args(tri):
    """The per-triangle arrays :func:`_any_ray_near` takes, as ``_State`` builds them."""
    tri = np.asarray(tri, dtype=np.float64).reshape(-1, 3, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    edges = np.roll(tri, -1, axis=1) - tri
    planes = np.cross(n[:, None, :], edges)
    planes /= np.linalg.norm(planes, axis=2, keepdims=True)
    centre = tri.mean(axis=1)
    return (centre, np.linalg.norm(tri - centre[:, None], axis=2).max(axis=1), n, planes,
            np.einsum("mkd,mkd->mk", planes, tri))


def test_any_ray_near_analytic_margins():
    from viscore.generators.hybrid._face_tallies import _any_ray_near

    args = _near_args([[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    m = 1e-3

    def near(origin, direction):
        return _any_ray_near(*args, np.array([origin], float), np.array([direction], float), m)

    down = (0, 0, -1)
    assert near((0.2, 0.2, 5), down)  # through the interior
    assert near((0.5, -0.5 * m, 5), down)  # outside the edge y = 0 by half the margin
    assert not near((0.5, -3 * m, 5), down)  # by three margins
    assert not near((0.2, 0.2, -5), down)  # the triangle is behind the origin
    assert near((-1, 0.2, 0.5 * m), (1, 0, 0))  # grazing, in the plane's margin
    assert not near((-1, 0.2, 2 * m), (1, 0, 0))  # parallel, two margins above
    assert not near((2, 2, 5), down)  # off the bounding sphere


def test_any_ray_near_false_means_embree_misses(rng):
    # the test is conservative: where it says no ray comes near, Embree finds no hit
    from viscore import Scene
    from viscore.generators.hybrid._face_tallies import _any_ray_near

    misses = 0
    for _ in range(300):
        tri = rng.normal(size=(3, 3))
        origin = rng.normal(size=3) * 3
        target = tri[rng.integers(3)] + rng.normal(size=3) * 0.05  # near a corner
        direction = target - origin
        scene = Scene(trimesh.Trimesh(tri, [[0, 1, 2]], process=False))
        margin = 1e-5 * scene.diagonal
        if not _any_ray_near(*_near_args(tri), origin[None], direction[None], margin):
            misses += 1
            assert scene.first_hit(origin[None], direction[None])[1][0] == -1
    assert misses > 50  # the draw tests both answers


def test_state_copy_removals_leave_the_original_unchanged(box_views):
    """copy() shares the read-only tables: removals in the copy change none of the
    original's arrays, and give what the same removals give on a fresh state."""
    occ = _join(_box(), _sheet(1.5, 0.5), _sheet(-0.2, 0.3))
    state = _State(box_views, occ, skip_unseen=True, skip_backfacing=False)
    state.refresh_losses()
    before = {k: v.copy() for k, v in vars(state).items() if isinstance(v, np.ndarray)}
    trial, fresh = state.copy(), _State(box_views, occ, skip_unseen=True,
                                        skip_backfacing=False)
    fresh.refresh_losses()
    for f in np.random.default_rng(5).permutation(len(occ.faces))[:8]:
        trial.remove(int(f))
        fresh.remove(int(f))
    for k, v in before.items():
        assert np.array_equal(getattr(state, k), v), k
    for k in _State._CHANGING:
        assert np.array_equal(getattr(trial, k), getattr(fresh, k)) or k in ("mark", "sat"), k
    assert trial.figures() == fresh.figures()
