"""Shadow frusta of convex solids and planar polygons: construction, culling, ranking."""

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from viscore import InputError, PerspectiveCamera, Scene
from viscore.culling import (
    FrustumCuller,
    boxes_in_frusta,
    boxes_in_frustum,
    polygon_frustum,
    rank_planar,
    rank_solids,
    solid_faces_as_polygons,
    solid_frustum,
)


def _hull(seed):
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(12, 3)) * rng.uniform(0.3, 2.0, 3)
    return trimesh.convex.convex_hull(pts)


def _eye_outside(mesh, rng):
    d = rng.normal(size=3)
    d /= np.linalg.norm(d)
    return mesh.centroid + d * rng.uniform(1.05, 4.0) * np.linalg.norm(mesh.extents)


def _hidden(scene, eye, points):
    """Each point is hidden from the eye: the solid is hit before it."""
    d = points - eye
    dist = np.linalg.norm(d, axis=1)
    t, _ = scene.first_hit(np.broadcast_to(eye, d.shape), d / dist[:, None])
    return t < dist + 1e-6 * dist


def _boxes_in(fr, rng, n=400):
    """Random boxes in the frustum's shadow region (and around it); which are culled."""
    eye = fr.eye
    far = np.linalg.norm(fr.near_point - eye)
    sil = fr.silhouette[:, 0]
    w = rng.dirichlet(np.ones(len(sil)), size=n)
    target = w @ sil
    centre = eye + (target - eye) * rng.uniform(1.0, 3.0, (n, 1))
    half = rng.uniform(0.0, 0.3, (n, 3)) * far * 0.1
    return centre - half, centre + half


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 10_000))
def test_solid_frustum_culled_boxes_are_hidden(seed):
    rng = np.random.default_rng(seed)
    mesh = _hull(seed)
    eye = _eye_outside(mesh, rng)
    fr = solid_frustum(mesh.vertices, mesh.faces, eye)
    assert fr is not None and fr.kind == "solid"
    lo, hi = _boxes_in(fr, rng)
    culled = boxes_in_frustum(fr, lo, hi)
    if not culled.any():
        return
    scene = Scene(mesh)
    corners = np.stack([np.where(np.array(m)[None], hi, lo)[culled]
                        for m in np.ndindex(2, 2, 2)], axis=1).reshape(-1, 3)
    u = rng.random((culled.sum(), 20, 3))
    inner = (lo[culled][:, None] + u * (hi - lo)[culled][:, None]).reshape(-1, 3)
    assert _hidden(scene, eye, np.vstack([corners, inner])).all()


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 10_000))
def test_solid_frustum_cone_holds_solid_and_cap_through_furthest(seed):
    rng = np.random.default_rng(seed)
    mesh = _hull(seed)
    eye = _eye_outside(mesh, rng)
    fr = solid_frustum(mesh.vertices, mesh.faces, eye)
    planes = fr.planes
    np.testing.assert_allclose(np.linalg.norm(planes[:, :3], axis=1), 1)
    scale = np.linalg.norm(mesh.extents) + np.linalg.norm(eye)
    # the side planes contain the whole solid (each supports it)
    side = mesh.vertices @ planes[:-1, :3].T + planes[:-1, 3]
    assert side.min() > -1e-7 * scale
    # every side plane passes through the eye
    np.testing.assert_allclose(planes[:-1, :3] @ eye + planes[:-1, 3], 0, atol=1e-7 * scale)
    # the cap passes through the furthest silhouette point, all others in front of it
    cap = planes[-1]
    assert abs(cap[:3] @ fr.near_point + cap[3]) < 1e-7 * scale
    sil = fr.silhouette.reshape(-1, 3)
    assert (sil @ cap[:3] + cap[3]).max() < 1e-7 * scale
    assert np.isclose(np.linalg.norm(sil - fr.near_point, axis=1), 0).any()
    # eq. 2: the cap normal is the mean direction from the eye to the silhouette points
    starts = fr.silhouette[:, 0]
    m = (starts - eye).sum(axis=0)
    np.testing.assert_allclose(cap[:3], m / np.linalg.norm(m), atol=1e-9)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 10_000))
def test_solid_frustum_box_straddling_silhouette_not_culled(seed):
    rng = np.random.default_rng(seed)
    mesh = _hull(seed)
    eye = _eye_outside(mesh, rng)
    fr = solid_frustum(mesh.vertices, mesh.faces, eye)
    a, b = fr.silhouette[:, 0], fr.silhouette[:, 1]
    on_edge = a + rng.random((len(a), 1)) * (b - a)
    behind = eye + (on_edge - eye) * rng.uniform(1.2, 3.0, (len(a), 1))
    half = 0.01 * np.linalg.norm(mesh.extents)
    assert not boxes_in_frustum(fr, behind - half, behind + half).any()


def test_solid_frustum_eye_inside_or_on_surface_gives_none():
    box = trimesh.creation.box(extents=(2, 2, 2))
    assert solid_frustum(box.vertices, box.faces, (0.5, 0.2, 0.1)) is None
    assert solid_frustum(box.vertices, box.faces, (1.0, 0.0, 0.0)) is None


def test_solid_frustum_box_seen_at_corner_has_six_side_planes():
    box = trimesh.creation.box(extents=(2, 2, 2))
    fr = solid_frustum(box.vertices, box.faces, (5, 4, 3))
    assert len(fr.planes) == 7  # hexagonal outline and the cap
    assert np.allclose(fr.planes[:-1, :3] @ [5, 4, 3] + fr.planes[:-1, 3], 0, atol=1e-6)


def test_polygon_frustum_culled_boxes_are_hidden(rng):
    sq = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
    scene = Scene(trimesh.Trimesh(sq, [[0, 1, 2], [0, 2, 3]]))
    for eye in ([0.3, 0.2, 2.0], [0.0, 0.0, -3.0], [2.0, 1.0, 1.0]):
        fr = polygon_frustum(sq, eye)
        centre = rng.uniform([-3, -3, -6], [3, 3, 6], (3000, 3))
        lo, hi = centre - 0.1, centre + 0.1
        culled = boxes_in_frustum(fr, lo, hi)
        assert culled.any()
        corners = np.stack([np.where(np.array(m)[None], hi, lo)[culled]
                            for m in np.ndindex(2, 2, 2)], axis=1).reshape(-1, 3)
        assert _hidden(scene, np.asarray(eye), corners).all()
    assert polygon_frustum(sq, (3, 3, 0)) is None  # eye in the polygon's plane


def test_solid_beats_planar_at_a_corner():
    """A box seen across its vertical edge hides what no single face hides (Fig. 2 of
    Papaioannou et al.)."""
    box = trimesh.creation.box(extents=(2, 2, 2))
    eye = np.array([4.0, 4.0, 0.0])
    lo, hi = np.array([[-2.6, -2.6, -0.2]]), np.array([[-2.2, -2.2, 0.2]])
    solid = FrustumCuller([(box.vertices, box.faces)], mode="solid")
    planar = FrustumCuller([(box.vertices, box.faces)], mode="planar")
    assert planar.count == 6 and solid.count == 1
    assert solid.cull(eye, lo, hi).tolist() == [True]
    assert planar.cull(eye, lo, hi).tolist() == [False]


def test_frustum_culler_active_set_and_view():
    boxes = [trimesh.creation.box(bounds=[[x, 2, -1], [x + 1, 3, 1]]) for x in (-6, 0, 6)]
    solids = [(b.vertices, b.faces) for b in boxes]
    cam = PerspectiveCamera((0.5, -5, 0), (0, 1, 0), fov=40, resolution=32)
    culler = FrustumCuller(solids, active=15)
    fr = culler.frusta(cam)
    assert len(fr) == 1  # the two side boxes lie outside the 40-degree view
    behind_side = ([[-11.6, 9.9, -0.1]], [[-11.4, 10.1, 0.1]])  # behind the left box
    assert not culler.cull(cam, *behind_side).any()
    assert culler.cull(cam.position, *behind_side).all()  # no view: all three ranked
    one = FrustumCuller(solids, active=1)
    assert len(one.frusta(cam.position)) == 1
    assert len(FrustumCuller(solids, active=2).frusta(cam.position)) == 2


def test_frustum_culler_from_occluders_boxes_and_polygons():
    from viscore.generators.occluder import Occluder

    occ = Occluder(mesh=trimesh.Trimesh(), method="x", params={}, double_sided=False,
                   seconds=0.0, parts={"boxes": np.array([[[-1.0, -1, -1], [1, 1, 1]]]),
                                       "polygons": [np.array([[5.0, 0, 0], [6, 0, 0],
                                                              [6, 0, 1], [5, 0, 1]])]})
    culler = FrustumCuller.from_occluders([occ])
    assert culler.count == 2
    assert culler.cull((0, -5, 0), [[-0.2, 3, -0.2]], [[0.2, 4, 0.2]]).tolist() == [True]


def test_boxes_in_frusta_any_and_empty():
    box = trimesh.creation.box()
    a = solid_frustum(box.vertices, box.faces, (0, 0, -3))
    b = solid_frustum(box.vertices, box.faces, (0, 0, 3))
    lo = np.array([[-0.1, -0.1, 2], [-0.1, -0.1, -3], [5, 5, 5]])
    assert boxes_in_frusta([a, b], lo, lo + 0.2).tolist() == [True, True, False]
    assert boxes_in_frusta([], lo, lo + 0.2).tolist() == [False] * 3
    assert boxes_in_frustum(a, np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)


def test_rank_solids_and_planar_equations():
    np.testing.assert_allclose(rank_solids([1.0, 27.0], [[0, 0, 1], [0, 3, 0]], (0, 0, 0)),
                               [1.0, 1.0])
    # eq. 3: facing the eye positive, facing away negative, |.| when two-sided
    r = rank_planar([2.0, 2.0], [[0, 0, -1], [0, 0, 1]], [[0, 0, 2], [0, 0, 2]], (0, 0, 0))
    np.testing.assert_allclose(r, [1.0, -1.0])
    r2 = rank_planar([2.0], [[0, 0, 1]], [[0, 0, 2]], (0, 0, 0), two_sided=True)
    np.testing.assert_allclose(r2, [1.0])


def test_solid_faces_as_polygons_box_and_hull():
    box = trimesh.creation.box(extents=(1, 2, 3))
    polys = solid_faces_as_polygons(box.vertices, box.faces)
    assert sorted(len(p) for p in polys) == [4] * 6
    area = sum(0.5 * np.linalg.norm(np.cross(p - p[0], np.roll(p, -1, 0) - p[0]).sum(0))
               for p in polys)
    assert area == pytest.approx(box.area)


def test_frusta_invalid_input():
    box = trimesh.creation.box()
    with pytest.raises(InputError, match="convex"):
        solid_frustum(*_concave(), (5, 5, 5))
    flipped = box.copy()
    flipped.invert()
    with pytest.raises(InputError, match="solids"):
        solid_frustum(flipped.vertices, flipped.faces, (5, 5, 5))
    with pytest.raises(InputError, match="closed"):
        solid_frustum(box.vertices, box.faces[:-1], (5, 5, 5))
    with pytest.raises(InputError, match="convex"):
        polygon_frustum([[0, 0, 0], [2, 0, 0], [1, 0.2, 0], [1, 2, 0]], (0, 0, 1))
    with pytest.raises(InputError, match="planar"):
        polygon_frustum([[0, 0, 0], [1, 0, 0], [1, 1, 1], [0, 1, 0]], (0, 0, 5))
    with pytest.raises(InputError, match="mode"):
        FrustumCuller([], mode="cone")
    with pytest.raises(InputError, match="active"):
        FrustumCuller([], active=0)
    with pytest.raises(InputError, match="cap"):
        FrustumCuller([], cap="far")
    with pytest.raises(InputError, match="rank"):
        FrustumCuller([], rank="eq5")
    with pytest.raises(InputError, match="cap"):
        solid_frustum(box.vertices, box.faces, (5, 5, 5), cap="none")
    fr = solid_frustum(box.vertices, box.faces, (0, 0, -3))
    with pytest.raises(InputError, match="lower"):
        boxes_in_frustum(fr, [[1, 1, 1]], [[0, 0, 0]])
    with pytest.raises(InputError, match="eye"):
        solid_frustum(box.vertices, box.faces, (0, 0))


def _concave():
    """An L-shaped prism: closed and oriented but not convex."""
    from shapely.geometry import Polygon

    outline = Polygon([(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)])
    m = trimesh.creation.extrude_polygon(outline, 1.0)
    return m.vertices, m.faces


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 10_000))
def test_solid_frustum_front_faces_cap_exact_shadow(seed):
    """The front-face caps contain the eq. 2 frustum, and what they cull is hidden."""
    rng = np.random.default_rng(seed)
    mesh = _hull(seed)
    eye = _eye_outside(mesh, rng)
    eq2 = solid_frustum(mesh.vertices, mesh.faces, eye)
    exact = solid_frustum(mesh.vertices, mesh.faces, eye, cap="front-faces")
    lo, hi = _boxes_in(eq2, rng)
    a, b = boxes_in_frustum(eq2, lo, hi), boxes_in_frustum(exact, lo, hi)
    assert not (a & ~b).any()
    if b.any():
        corners = np.stack([np.where(np.array(m)[None], hi, lo)[b]
                            for m in np.ndindex(2, 2, 2)], axis=1).reshape(-1, 3)
        assert _hidden(Scene(mesh), eye, corners).all()


def _scene_solids(rng, n=25):
    solids = []
    for _ in range(n):
        c = rng.uniform([-30, 0, 0], [30, 60, 10])
        if rng.random() < 0.5:
            m = trimesh.creation.box(extents=rng.uniform(2, 10, 3))
        else:
            m = trimesh.convex.convex_hull(rng.normal(size=(10, 3)) * rng.uniform(1, 5, 3))
        m.apply_translation(c)
        solids.append((np.asarray(m.vertices), np.asarray(m.faces)))
    return solids


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_frustum_culler_solid_culls_superset_of_planar(seed):
    """With front-face caps and face ranking, every box planar frusta cull, solid frusta
    cull too, frame by frame (and the paper's defaults may not)."""
    rng = np.random.default_rng(seed)
    solids = _scene_solids(rng)
    centre = rng.uniform([-40, -10, -2], [40, 80, 15], (2000, 3))
    lo = centre - rng.uniform(0.1, 1.5, (2000, 3))
    hi = centre + rng.uniform(0.1, 1.5, (2000, 3))
    solid = FrustumCuller(solids, cap="front-faces", rank="faces", active=8)
    planar = FrustumCuller(solids, mode="planar", active=8)
    more = 0
    for _ in range(12):
        eye = rng.uniform([-30, -20, 1], [30, 70, 3])
        cam = PerspectiveCamera(eye, rng.normal(size=3) * [1, 1, 0.1], fov=90, resolution=16,
                                height=9)
        a, b = solid.cull(cam, lo, hi), planar.cull(cam, lo, hi)
        assert not (b & ~a).any()
        more += int(a.sum() > b.sum())
    assert more > 0


def test_frustum_culler_eye_inside_solid_uses_its_faces():
    room = trimesh.creation.box(extents=(10, 10, 10))
    culler = FrustumCuller([(room.vertices, room.faces)])
    fr = culler.frusta((1.0, 2.0, 0.5))
    assert len(fr) == 6 and {f.kind for f in fr} == {"planar"}
    culled = culler.cull((1.0, 2.0, 0.5), [[7, -1, -1], [1, 1, 1]], [[8, 1, 1], [2, 2, 2]])
    assert culled.tolist() == [True, False]


@pytest.mark.parametrize("seed", [3, 4])
def test_frustum_culler_culled_boxes_hidden_in_scene(seed):
    """Every runtime variant culls only boxes whose corners and samples are hidden by the
    solids (ray casts from the eye), on random scenes and cameras."""
    rng = np.random.default_rng(seed)
    solids = _scene_solids(rng)
    scene = Scene(trimesh.util.concatenate([trimesh.Trimesh(v, f) for v, f in solids]))
    centre = rng.uniform([-40, -10, -2], [40, 80, 15], (1500, 3))
    lo = centre - rng.uniform(0.1, 1.5, (1500, 3))
    hi = centre + rng.uniform(0.1, 1.5, (1500, 3))
    cullers = [FrustumCuller(solids), FrustumCuller(solids, mode="planar"),
               FrustumCuller(solids, cap="front-faces", rank="faces")]
    total = 0
    for _ in range(6):
        eye = rng.uniform([-30, -20, 1], [30, 70, 3])
        cam = PerspectiveCamera(eye, rng.normal(size=3) * [1, 1, 0.1], fov=90, resolution=16)
        for culler in cullers:
            c = culler.cull(cam, lo, hi)
            total += int(c.sum())
            corners = np.stack([np.where(np.array(m)[None], hi, lo)[c]
                                for m in np.ndindex(2, 2, 2)], axis=1).reshape(-1, 3)
            u = rng.random((c.sum(), 8, 3))
            inner = (lo[c][:, None] + u * (hi - lo)[c][:, None]).reshape(-1, 3)
            assert _hidden(scene, eye, np.vstack([corners, inner])).all()
    assert total > 100


@pytest.mark.parametrize("scale", [1e-9, 1e9])
def test_frustum_culler_scale_invariant(scale):
    wall = trimesh.creation.box(extents=(4, 1, 4)).apply_scale(scale)
    lo = np.array([[-0.5, 3, -0.5], [5, 3, 0], [-0.5, -3, -0.5]]) * scale
    hi = np.array([[0.5, 4, 0.5], [6, 4, 1], [0.5, -2, 0.5]]) * scale
    for kw in ({}, {"mode": "planar"}, {"cap": "front-faces", "rank": "faces"}):
        culler = FrustumCuller([(wall.vertices, wall.faces)], **kw)
        assert culler.cull(np.array([0.3, -5, 0.2]) * scale, lo, hi).tolist() == \
            [True, False, False]


def test_frustum_culler_from_occluders_nonconvex_polygon_triangulated():
    from viscore.generators.occluder import Occluder

    ell = np.array([[0, 0, 0], [4, 0, 0], [4, 0, 1], [1, 0, 1], [1, 0, 4], [0, 0, 4]], float)
    bent = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 1], [0, 1, 0]], float)
    occ = Occluder(mesh=trimesh.Trimesh(), method="x", params={}, double_sided=True,
                   seconds=0.0, parts={"polygons": [ell, bent]})
    culler = FrustumCuller.from_occluders([occ], mode="planar")
    assert culler.count == 4  # the L in four triangles, the bent loop skipped
    eye = (0.5, -5, 0.5)
    # behind the L's foot: culled; behind its notch (2..4 x 2..4): seen through it
    lo = np.array([[1.8, 4.9, 0.45], [2.8, 4.9, 2.8]])
    assert culler.cull(eye, lo, lo + 0.1).tolist() == [True, False]


def _reference_cull(culler, camera_or_eye, lo, hi):
    """Straightforward reference of FrustumCuller.cull: numpy frusta, numpy box test."""
    return boxes_in_frusta(culler.frusta(camera_or_eye), lo, hi)


@pytest.mark.parametrize("seed", [0, 1])
def test_frustum_culler_cull_matches_reference_city(seed):
    """The compiled per-frame path culls exactly the boxes the frusta of frusta() hold,
    for every mode, on a street-grid city walked at eye height."""
    from viscore.cli.bench.cull_runtimes import bench_city

    solids, lo, hi = bench_city(occludees=600, blocks=5, seed=seed)
    rng = np.random.default_rng(seed)
    cullers = [FrustumCuller(solids), FrustumCuller(solids, mode="planar"),
               FrustumCuller(solids, cap="front-faces", rank="faces"),
               FrustumCuller(solids, active=4)]
    total = 0
    for _ in range(8):
        eye = np.append(rng.uniform(-5, 145, 2), rng.uniform(1, 30))
        heading = rng.uniform(0, 2 * np.pi)
        cam = PerspectiveCamera(eye, (np.cos(heading), np.sin(heading), rng.uniform(-0.3, 0.1)),
                                fov=90, resolution=16, height=9)
        for culler in cullers:
            for view in (cam, eye):
                got = culler.cull(view, lo, hi)
                assert got.dtype == bool and got.shape == (len(lo),)
                np.testing.assert_array_equal(got, _reference_cull(culler, view, lo, hi))
                total += int(got.sum())
    assert total > 100


#: Three upright 6 x 8 wall polygons across the street at y = 30 (planar occluders).
_WALLS = [np.array([[x, 30, 0], [x + 6, 30, 0], [x + 6, 30, 8], [x, 30, 8]], float)
          for x in (-20, 0, 20)]


@pytest.mark.parametrize("seed", [5, 6])
def test_frustum_culler_cull_matches_reference_hulls_polygons_inside(seed):
    """Convex hulls, extra polygons, and eyes inside solids (their faces' frusta)."""
    rng = np.random.default_rng(seed)
    solids = _scene_solids(rng, n=15)
    polygons = _WALLS
    centre = rng.uniform([-40, -10, -2], [40, 80, 15], (800, 3))
    lo = centre - rng.uniform(0.05, 1.5, (800, 3))
    hi = centre + rng.uniform(0.05, 1.5, (800, 3))
    cullers = [FrustumCuller(solids, polygons=polygons, **kw)
               for kw in ({}, {"mode": "planar"}, {"cap": "front-faces", "rank": "faces"},
                          {"rank": "faces"}, {"cap": "front-faces"})]
    eyes = [rng.uniform([-30, -20, 1], [30, 70, 3]) for _ in range(5)]
    eyes += [np.mean(v, axis=0) for v, _ in solids[:3]]  # inside a solid
    inside = 0
    for eye in eyes:
        cam = PerspectiveCamera(eye, rng.normal(size=3) * [1, 1, 0.1], fov=90, resolution=16)
        for culler in cullers:
            for view in (cam, eye):
                np.testing.assert_array_equal(culler.cull(view, lo, hi),
                                              _reference_cull(culler, view, lo, hi))
            inside += sum(f.kind == "planar" for f in culler.frusta(eye)) if \
                culler.mode == "solid" else 0
    assert inside > 0


def test_frustum_culler_cull_box_input():
    """cull takes lists and (3,) boxes as the reference does, and refuses bad boxes."""
    wall = trimesh.creation.box(extents=(4, 1, 4))
    culler = FrustumCuller([(wall.vertices, wall.faces)])
    eye = (0.3, -5, 0.2)
    assert culler.cull(eye, [-0.5, 3, -0.5], [0.5, 4, 0.5]).tolist() == [True]
    assert culler.cull(eye, np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)
    lo = np.array([[-0.5, 3, -0.5], [5, 3, 0]])
    hi = lo + 1.0
    assert culler.cull(eye, lo.astype(np.float32), hi).tolist() == [True, False]
    assert culler.cull(eye, np.asfortranarray(lo), hi).tolist() == [True, False]
    for bad_lo, bad_hi, match in ((lo + [[0, 0, 0], [np.nan, 0, 0]], hi, "NaN"),
                                  (lo, hi - [[0, 0, 0], [0, 0, np.inf]], "infinite"),
                                  (hi, lo, "exceeds"), (lo, hi[:1], "shapes")):
        with pytest.raises(InputError, match=match):
            culler.cull(eye, bad_lo, bad_hi)


def test_top_k_is_stable_sort():
    """The active set: the k best ranks, ties by index, without NaN and -inf."""
    from viscore.culling._culler_kernel import top_k

    rng = np.random.default_rng(0)
    for _ in range(200):
        n = int(rng.integers(0, 40))
        rank = rng.integers(-3, 4, n).astype(float)
        rank[rng.random(n) < 0.2] = -np.inf
        rank[rng.random(n) < 0.1] = np.nan
        rank[rng.random(n) < 0.1] = np.inf
        k = int(rng.integers(1, 20))
        clean = np.where(np.isnan(rank), -np.inf, rank)
        want = np.argsort(-clean, kind="stable")[:k]
        want = want[clean[want] > -np.inf]
        np.testing.assert_array_equal(top_k(rank, k), want)


def _reference_select(culler, camera_or_eye):
    """The active set by numpy: public ranks, view test, a stable sort of all of them."""
    if isinstance(camera_or_eye, PerspectiveCamera):
        eye = camera_or_eye.position
        f, r, u = camera_or_eye.basis
        hx, hy = camera_or_eye._half, camera_or_eye._half_vertical
        vn = np.array([hx * f - r, hx * f + r, hy * f - u, hy * f + u])
        vn /= np.linalg.norm(vn, axis=1)[:, None]
        vd = -(vn @ eye)
    else:
        eye = np.asarray(camera_or_eye, float)

    def seen(c, radius):
        if not isinstance(camera_or_eye, PerspectiveCamera):
            return np.ones(len(c), bool)
        return ((c @ vn.T + vd) >= -radius[:, None]).all(axis=1)

    fc, ex, sv = culler._faces, culler._extra, culler._solids
    face = np.where(seen(fc.centroid, fc.radius),
                    rank_planar(fc.area, fc.normal, fc.centroid, eye), -np.inf)
    if culler.mode == "planar":
        first = face
    elif culler.rank == "faces":
        first = np.maximum.reduceat(face, culler._face_start[:-1])
    else:
        first = np.where(seen(sv.centroid, sv.radius),
                         rank_solids(sv.volume, sv.centroid, eye), -np.inf)
    extra = np.where(seen(ex.centroid, ex.radius),
                     rank_planar(ex.area, ex.normal, ex.centroid, eye, two_sided=True), -np.inf)
    rank = np.concatenate([first, extra])
    rank[np.isnan(rank)] = -np.inf
    order = np.argsort(-rank, kind="stable")[:culler.active]
    order = order[rank[order] > -np.inf]
    return order[order < len(first)], order[order >= len(first)] - len(first)


@pytest.mark.parametrize("seed", [7, 8])
def test_frustum_culler_selection_matches_reference(seed):
    """The compiled ranking picks the active set numpy's ranks and sort pick."""
    rng = np.random.default_rng(seed)
    solids = _scene_solids(rng, n=30)
    polygons = _WALLS
    for kw in ({}, {"mode": "planar"}, {"rank": "faces"}, {"active": 3}):
        culler = FrustumCuller(solids, polygons=polygons, **kw)
        for _ in range(6):
            eye = rng.uniform([-30, -20, 1], [30, 70, 3])
            cam = PerspectiveCamera(eye, rng.normal(size=3) * [1, 1, 0.1], fov=70,
                                    resolution=16, height=9)
            for view in (cam, eye):
                first, extra = _reference_select(culler, view)
                s, f, e = culler._select(culler._view(view))
                np.testing.assert_array_equal(f if culler.mode == "planar" else s, first)
                np.testing.assert_array_equal(e, extra)
