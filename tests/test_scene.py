import numpy as np
import pytest
import trimesh

from viscore import InputError, Scene


def test_first_hit_box_distances(cube):
    scene = Scene(cube)
    origins = np.array([[0.3, -0.2, -5.0], [0.0, 0.0, 5.0], [3.0, 3.0, -5.0]])
    dirs = np.array([[0, 0, 1], [0, 0, -1], [0, 0, 1]])
    t, tri = scene.first_hit(origins, dirs)
    assert t[0] == pytest.approx(4.0, abs=1e-5)
    assert t[1] == pytest.approx(4.0, abs=1e-5)
    assert t[2] == np.inf and tri[2] == -1
    # the hit triangle's plane is the face z = -1 for the first ray
    assert cube.face_normals[tri[0]][2] == pytest.approx(-1.0)


def test_first_hit_unnormalised_directions_give_world_distances(cube):
    t, _ = Scene(cube).first_hit([[0, 0, -5.0]], [[0, 0, 10.0]])
    assert t[0] == pytest.approx(4.0, abs=1e-5)


def test_first_hit_max_distance(cube):
    scene = Scene(cube)
    t, tri = scene.first_hit([[0, 0, -5.0]] * 2, [[0, 0, 1]] * 2, max_distance=[3.9, 4.1])
    assert t[0] == np.inf and tri[0] == -1
    assert t[1] == pytest.approx(4.0, abs=1e-5)


def test_any_hit_segment_length(cube):
    scene = Scene(cube)
    occ = scene.any_hit([[0, 0, -5.0]] * 3, [[0, 0, 1], [0, 0, 1], [1, 0, 0]],
                        max_distance=[3.5, 4.5, 100])
    assert occ.tolist() == [False, True, False]


def test_all_hits_counts_and_sorted(cube, rng):
    scene = Scene(cube)
    n = 500
    origins = np.column_stack([rng.uniform(-0.9, 0.9, (n, 2)), np.full(n, -5.0)])
    hits = scene.all_hits(origins, np.tile([0, 0, 1.0], (n, 1)))
    assert hits.count.tolist() == [2] * n  # enter and leave, shared diagonal edges not doubled
    t = hits.t.reshape(n, 2)
    np.testing.assert_allclose(t[:, 0], 4.0, atol=1e-5)
    np.testing.assert_allclose(t[:, 1], 6.0, atol=1e-5)
    assert not hits.truncated


def test_all_hits_parity_inside_outside(unit_sphere, rng):
    scene = Scene(unit_sphere)
    pts = rng.uniform(-1.2, 1.2, (2000, 3))
    r = np.linalg.norm(pts, axis=1)
    pts = pts[np.abs(r - 1) > 0.01]  # away from the polygonal surface
    hits = scene.all_hits(pts, np.tile([0.3, 0.5, 0.81], (len(pts), 1)))
    inside = hits.count % 2 == 1
    assert (inside == (np.linalg.norm(pts, axis=1) < 1)).all()


def test_all_hits_truncated_flag(cube):
    hits = Scene(cube).all_hits([[0, 0, -5.0]], [[0, 0, 1]], max_hits=1)
    assert hits.count.tolist() == [1] and hits.truncated


def test_scene_threads_agree_with_one_worker(unit_sphere, rng):
    o = rng.uniform(-2, 2, (40000, 3))
    d = rng.normal(size=(40000, 3))
    t1, i1 = Scene(unit_sphere, workers=1).first_hit(o, d)
    t2, i2 = Scene(unit_sphere, workers=2).first_hit(o, d)
    np.testing.assert_array_equal(i1, i2)
    np.testing.assert_array_equal(t1, t2)


@pytest.mark.parametrize("n, workers", [(1_000_000, 2), (4_194_304, 2), (300_000, 3),
                                        (1_000_000, 1), (100_000, 2), (20_000, 2)])
def test_chunk_bounds_cover_the_batch_and_shrink_at_the_end(n, workers):
    from viscore.constants import MIN_RAYS_PER_TASK
    from viscore.ray.embree_scene import _MAX_RAYS_PER_CHUNK, _TAIL_RAYS

    bounds = Scene._chunk_bounds(n, workers)
    sizes = np.diff(bounds)
    assert bounds[0] == 0 and bounds[-1] == n and (sizes > 0).all()
    assert sizes.max() <= _MAX_RAYS_PER_CHUNK
    count = Scene._chunk_count(n, workers)
    if workers == 1 or count < 4 * workers:  # one thread or a small batch: equal chunks
        assert len(sizes) == count and sizes.max() - sizes.min() <= 1
    else:
        # guided: never growing but for the last, none under _TAIL_RAYS, the last
        # under two of them and smaller than the first
        assert (np.diff(sizes) <= 0).sum() >= len(sizes) - 2
        assert sizes[:-1].min() >= _TAIL_RAYS and sizes[-1] < 2 * _TAIL_RAYS
        assert sizes[-1] < sizes[0]
    assert sizes.min() >= MIN_RAYS_PER_TASK // 2 or len(sizes) == 1


def test_guided_chunks_trace_as_one_worker_and_name_the_first_bad_ray(unit_sphere, rng):
    # 300k rays on 2 threads: equal chunks, then shrinking ones (_chunk_bounds)
    n = 300_000
    assert len(Scene._chunk_bounds(n, 2)) - 1 > len(Scene._chunk_bounds(n, 1)) - 1
    o = rng.uniform(-2, 2, (n, 3))
    d = rng.normal(size=(n, 3))
    t1, i1 = Scene(unit_sphere, workers=1).first_hit(o, d)
    t2, i2 = Scene(unit_sphere, workers=2).first_hit(o, d)
    np.testing.assert_array_equal(i1, i2)
    np.testing.assert_array_equal(t1, t2)
    np.testing.assert_array_equal(Scene(unit_sphere, workers=2).any_hit(o, d), i1 >= 0)
    o[296_000, 1] = np.nan  # in one of the last, small chunks
    o[299_999, 0] = np.inf
    with pytest.raises(InputError, match=r"\(first at ray 296000\)"):
        Scene(unit_sphere, workers=2).first_hit(o, d)


def test_scene_far_from_origin_keeps_precision():
    box = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
    box.apply_translation([1e5, 1e5, 1e5])
    t, _ = Scene(box).first_hit([[1e5, 1e5, 1e5 - 5]], [[0, 0, 1]])
    assert t[0] == pytest.approx(4.0, abs=1e-4)


def test_scene_empty_batch(cube):
    t, tri = Scene(cube).first_hit(np.zeros((0, 3)), np.zeros((0, 3)))
    assert t.shape == (0,) and tri.shape == (0,)


def test_scene_invalid_input(cube):
    scene = Scene(cube)
    with pytest.raises(InputError, match="origins"):
        scene.first_hit([[0, 0, np.nan]], [[0, 0, 1]])
    with pytest.raises(InputError, match="directions"):
        scene.first_hit([[0, 0, 0]], [[0, 0, 0]])
    with pytest.raises(InputError, match=r"\(n, 3\)"):
        scene.first_hit([[0, 0]], [[0, 0, 1]])
    with pytest.raises(InputError, match="lengths differ"):
        scene.first_hit(np.zeros((2, 3)), np.ones((3, 3)))
    with pytest.raises(InputError):
        Scene("not a mesh")


# --------------------------------------------------------------------------- scale
#: Relative tolerance of a float32 ray distance: a few ulps (2^-24 each) of the
#: unit-scaled scene, whose coordinates and distances are of order 1.
_F32_RTOL = 16 * 2.0**-24


@pytest.mark.parametrize("scale", [1e-60, 1e-30, 1e-12, 1e-3, 1.0, 1e12, 1e17, 1e30, 1e60])
def test_first_hit_analytic_distances_at_any_scale(scale):
    # cube [-1, 1]^3 x scale, shifted by 3 of its sizes: world units throughout
    box = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
    shift = np.array([3.0, -2.0, 1.0]) * scale
    mesh = trimesh.Trimesh(box.vertices * scale + shift, box.faces, process=False)
    scene = Scene(mesh)
    xy = np.array([[0.3, -0.2], [0.0, 0.0], [-0.9, 0.7]]) * scale
    origins = np.column_stack([xy, np.full(3, -5.0 * scale)]) + shift
    t, tri = scene.first_hit(origins, [[0, 0, 1]] * 3)
    np.testing.assert_allclose(t, 4.0 * scale, rtol=_F32_RTOL)
    assert (tri >= 0).all()
    hits = scene.all_hits(origins, [[0, 0, 1]] * 3)
    assert hits.count.tolist() == [1 + 1] * 3
    np.testing.assert_allclose(hits.t.reshape(3, 2), [[4 * scale, 6 * scale]] * 3,
                               rtol=_F32_RTOL)
    occ = scene.any_hit(origins[:2], [[0, 0, 1]] * 2, max_distance=[3.9 * scale, 4.1 * scale])
    assert occ.tolist() == [False, True]
    t_cut, _ = scene.first_hit(origins[:1], [[0, 0, 1]], max_distance=3.9 * scale)
    assert t_cut[0] == np.inf
    # oblique ray through the centre: hits the face x = -1 at distance 4 sqrt(3)
    t_ob, _ = scene.first_hit(shift - 5 * scale, [[1, 1, 1]])
    assert t_ob[0] == pytest.approx(4 * np.sqrt(3) * scale, rel=_F32_RTOL)


def test_first_hit_max_distance_nan_or_negative_refused(cube):
    scene = Scene(cube)
    for bad in (np.nan, [1.0, np.nan], -1.0):
        with pytest.raises(InputError, match="max_distance"):
            scene.first_hit([[0, 0, -5.0]] * 2, [[0, 0, 1]] * 2, max_distance=bad)
        with pytest.raises(InputError, match="max_distance"):
            scene.any_hit([[0, 0, -5.0]] * 2, [[0, 0, 1]] * 2, max_distance=bad)
    t, _ = scene.first_hit([[0, 0, -5.0]], [[0, 0, 1]], max_distance=np.inf)
    assert t[0] == pytest.approx(4.0, rel=_F32_RTOL)


def test_scene_vertices_and_faces_read_only(cube):
    import pickle

    scene = Scene(cube)
    for arr in (scene.vertices, scene.faces, scene.bounds):
        with pytest.raises(ValueError, match="read-only"):
            arr[0, 0] = 7
    with pytest.raises(AttributeError):
        scene.vertices = np.zeros((3, 3))
    cube.vertices[0] = [9, 9, 9]  # the scene holds its own copy
    assert scene.vertices[0].tolist() != [9, 9, 9]
    again = pickle.loads(pickle.dumps(scene))
    assert not again.vertices.flags.writeable and not again.faces.flags.writeable
    t, _ = again.first_hit([[0, 0, -5.0]], [[0, 0, 1]])
    assert t[0] == pytest.approx(4.0, rel=_F32_RTOL)


def test_scene_origin_beyond_float32_of_the_scene_refused():
    tiny = trimesh.creation.box(extents=(1e-30, 1e-30, 1e-30))
    with pytest.raises(InputError, match="too far from the mesh"):
        Scene(tiny).first_hit([[0, 0, -1e10]], [[0, 0, 1]])  # 1e40 sizes away


def test_integers_beyond_float64_are_refused_in_one_line():
    from viscore._validate import as_points, as_vector

    with pytest.raises(InputError, match="beyond float64's range"):
        as_vector([10**400, 0, 0], "up")
    with pytest.raises(InputError, match="beyond float64's range"):
        as_points([[0, 0, -(10**400)]], "origins")


# --------------------------------------------------------------------------- bit identity
def _bare_reference(scene, o, d, max_distance=None, occluded=False):
    """What Scene promises, computed the plain numpy way with one bare Embree call.

    Origins to the unit frame in float64 then float32; directions to float32,
    those whose float32 squared norm is off 1 by more than 1e-6 normalised in
    float64 first; distances back as float64(tfar) * scale, inf on a miss.
    """
    o = np.broadcast_to(np.asarray(o, dtype=np.float64), np.shape(d))
    d = np.asarray(d, dtype=np.float64)
    o32 = ((o - scene._offset) / scene._scale).astype(np.float32)
    d32 = d.astype(np.float32)
    sq = d32 * d32
    norm2 = (sq[:, 0] + sq[:, 1]) + sq[:, 2]
    off = np.abs(norm2 - np.float32(1)) > np.float32(1e-6)
    d32[off] = d[off] / np.sqrt(np.einsum("ij,ij->i", d[off], d[off]))[:, None]
    dists = None
    if max_distance is not None:
        t64 = np.broadcast_to(np.asarray(max_distance, dtype=np.float64), (len(d),))
        dists = np.minimum(t64 / scene._scale, 1e30).astype(np.float32)
    if occluded:
        return scene._embree.run(o32, d32, dists=dists, query="OCCLUDED") >= 0
    res = scene._embree.run(o32, d32, dists=dists, output=1)
    tri = res["primID"].astype(np.int64)
    return np.where(tri >= 0, res["tfar"].astype(np.float64) * scene._scale, np.inf), tri


def _ray_batches(mesh, rng, n=40_000):
    """Ray batches in the layouts Scene meets: contiguous, broadcast, strided, read-only."""
    lo, hi = mesh.bounds
    r = float(np.linalg.norm(hi - lo))
    o = rng.uniform(lo - 0.3 * r, hi + 0.3 * r, (n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    # off unit: within the 1e-6 tolerance (kept), just beyond it and far (normalised)
    d_off = d * rng.choice([1.0, 1 + 2e-7, 1 + 3e-6, 1e-3, 7.0], n)[:, None]
    wide = np.empty((2 * n, 3))
    wide[::2] = o
    frozen = o.copy()
    frozen.flags.writeable = False
    raw = np.zeros(n * 24 + 1, np.uint8)
    unaligned = np.frombuffer(raw.data, np.float64, 3 * n, offset=1).reshape(n, 3)
    unaligned.flags.writeable = True
    unaligned[:] = o
    return {"contiguous": (o, d), "off-unit": (o, d_off), "one origin": (o[:1], d),
            "strided": (wide[::2], np.asfortranarray(d)), "read-only": (frozen, d_off),
            "unaligned": (unaligned, d)}


@pytest.mark.parametrize("workers", [1, 2])
def test_scene_matches_bare_embree_bit_for_bit(unit_sphere, rng, workers):
    # a regression guard for the compiled per-chunk passes: every distance,
    # triangle and hit/miss as the plain numpy conversion and one Embree call give
    box = trimesh.creation.box(extents=(2.0, 3.0, 1.0))
    far = trimesh.Trimesh(box.vertices * 3e5 + 1e6, box.faces, process=False)  # scale != 1
    for mesh in (unit_sphere, far):
        scene = Scene(mesh, workers=workers)
        for name, (o, d) in _ray_batches(mesh, rng).items():
            t, tri = scene.first_hit(o, d)
            t_ref, tri_ref = _bare_reference(scene, o, d)
            assert (tri >= 0).any() and (tri < 0).any(), name
            np.testing.assert_array_equal(tri, tri_ref, err_msg=name)
            assert t.tobytes() == t_ref.tobytes(), name
            md = rng.uniform(0, scene.diagonal, len(d))
            md[::5] = np.inf
            t, tri = scene.first_hit(o, d, max_distance=md)
            t_ref, tri_ref = _bare_reference(scene, o, d, max_distance=md)
            np.testing.assert_array_equal(tri, tri_ref, err_msg=name)
            assert t.tobytes() == t_ref.tobytes(), name
            for limit in (md, 0.3 * scene.diagonal, None):
                occ = scene.any_hit(o, d, max_distance=limit)
                np.testing.assert_array_equal(occ, _bare_reference(scene, o, d, limit, True),
                                              err_msg=name)


def test_all_hits_first_layer_is_first_hit(unit_sphere, rng):
    o = rng.uniform(-2, 2, (40_000, 3))
    d = rng.normal(size=(40_000, 3))
    scene = Scene(unit_sphere, workers=2)
    hits = scene.all_hits(o, d)
    t, tri = scene.first_hit(o, d)
    starts = np.cumsum(hits.count) - hits.count
    first = hits.count > 0
    np.testing.assert_array_equal(first, tri >= 0)
    assert hits.t[starts[first]].tobytes() == t[first].tobytes()
    np.testing.assert_array_equal(hits.triangle[starts[first]], tri[first])


def test_unit_frame_kernel_matches_numpy(rng):
    from viscore.ray.embree_scene import _BAD_RAY, _OFF_UNIT, _ready_kernels, _unit_frame

    _ready_kernels()
    n = 50_000
    o = rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-30, 30, (n, 1))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    d *= rng.choice([1.0, 1 + 1e-7, 1 - 4e-7, 1 + 6e-7, 1e-20, 1e20], (n, 1))
    d[:7] = [[0, 0, 0], [np.nan, 0, 1], [np.inf, 0, 0], [1e-30, 0, 0], [1e30, 1, 1],
             [-0.0, 0, 0], [3e-23, 0, 0]]  # zero, NaN, inf, underflow to 0, overflow to inf
    offset = np.array([0.25, -3.0, 1e-3])
    o32, d32 = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)
    norm2 = np.empty(n, np.float32)
    for scale, exact in ((2.0**-7, True), (2.0**-7, False), (3.0, False)):
        for rows in (slice(0, n), slice(7, n), slice(7, 20), slice(7, 8)):
            for one in (False, True):
                oo = np.broadcast_to(o[rows][:1], o[rows].shape) if one else o[rows]
                k = rows.stop - rows.start
                flags = _unit_frame(oo[0].copy() if one else oo.reshape(-1),
                                    d[rows].reshape(-1), offset, 1 / scale, scale, exact, one,
                                    o32[:k].reshape(-1), d32[:k].reshape(-1), norm2[:k])
                with np.errstate(over="ignore", invalid="ignore", under="ignore"):
                    shifted = oo - offset
                    ref_o = (shifted * (1 / scale) if exact else shifted / scale).astype(
                        np.float32)
                    ref_d = d[rows].astype(np.float32)
                    sq = ref_d * ref_d
                    ref_n = (sq[:, 0] + sq[:, 1]) + sq[:, 2]
                    off = np.abs(ref_n - 1.0) > 1e-6
                assert o32[:k].tobytes() == ref_o.tobytes()
                assert d32[:k].tobytes() == ref_d.tobytes()
                assert norm2[:k].tobytes() == ref_n.tobytes()
                ok = np.isfinite(ref_o).all(axis=1) & np.isfinite(ref_n) & (ref_n > 0)
                assert bool(flags & _BAD_RAY) == (not ok.all())
                if off[ok].any():  # never misses a direction numpy would normalise
                    assert flags & _OFF_UNIT


def test_bad_ray_in_a_later_chunk_is_named(unit_sphere, rng):
    o = rng.uniform(-2, 2, (100_000, 3))
    d = rng.normal(size=(100_000, 3))
    o[70_123, 2] = np.inf
    d[90_000] = 0
    for workers in (1, 2):
        with pytest.raises(InputError, match=r"origins: contains NaN or infinite values "
                                             r"\(first at ray 70123\)"):
            Scene(unit_sphere, workers=workers).first_hit(o, d)
        with pytest.raises(InputError, match=r"zero-length direction vectors "
                                             r"\(first at ray 90000\)"):
            Scene(unit_sphere, workers=workers).any_hit(np.zeros_like(o), d)
