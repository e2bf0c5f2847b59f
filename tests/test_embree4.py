"""The packet path (viscore/ray/_embree4.py) against embreex's per-ray path, and its fallback.

Every comparison is exact: the same float64 distances bit for bit (float32
tfar times a power of two), the same triangle ids, the same hit/miss. No timing.
"""

import ctypes.util
import pickle

import numpy as np
import pytest
import trimesh

from viscore import Scene, load_mesh
from viscore.depth_buffer import _first_triangles
from viscore.ray import _embree4

needs_packets = pytest.mark.skipif(_embree4.library() is None,
                                   reason="no libembree4 with packet calls beside embreex")


def _pair(mesh, monkeypatch, workers=1):
    """(Scene traced by packets, Scene traced by embreex) of one mesh."""
    packets = Scene(mesh, workers=workers).build()
    with monkeypatch.context() as m:
        m.setenv(_embree4.PACKETS_ENV, "0")
        embreex = Scene(mesh, workers=workers).build()
    assert packets._packets is not None
    assert embreex._packets is None
    return packets, embreex


def _assert_same(packets, embreex, o, d, max_distance=None):
    """First hits, any-hits and all-hits identical on both paths."""
    t, tri = packets.first_hit(o, d, max_distance=max_distance)
    t_ref, tri_ref = embreex.first_hit(o, d, max_distance=max_distance)
    np.testing.assert_array_equal(tri, tri_ref)
    assert t.tobytes() == t_ref.tobytes()
    np.testing.assert_array_equal(packets.any_hit(o, d, max_distance=max_distance),
                                  embreex.any_hit(o, d, max_distance=max_distance))
    return t, tri


def _cube_rays():
    """Rays at the cube [-1, 1]^3 through its vertices, edges, face diagonals and faces.

    The two triangles of a face share its diagonal, two faces share a cube
    edge and three a vertex: rays through them are the ones robust mode must
    not lose. Each target is approached along the three axes and along
    oblique directions, from 5 units away.
    """
    g = np.array([-1.0, 0.0, 1.0])
    grid = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    on_surface = grid[np.abs(grid).max(axis=1) == 1]  # vertices, edge midpoints, face centres
    s = np.linspace(-1, 1, 9)
    diagonals = np.column_stack([s, s, np.full_like(s, -1.0)])  # the -Z face's shared edge
    targets = np.concatenate([on_surface, diagonals])
    directions = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0], [0, -1, 0], [0, 0, -1],
                           [1, 1, 1], [1, -2, 3], [-3, 1, 2]], dtype=np.float64)
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    d = np.repeat(directions, len(targets), axis=0)
    o = np.tile(targets, (len(directions), 1)) - 5.0 * d
    return o, d


def _cube_entry(o, d):
    """Distance at which each ray enters the closed cube [-1, 1]^3 along a segment of
    positive length (slab test), inf where it misses it or only touches it at a point."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = (-1.0 - o) / d, (1.0 - o) / d
    near = np.where(d != 0, np.minimum(a, b), np.where(np.abs(o) <= 1, -np.inf, np.inf))
    far = np.where(d != 0, np.maximum(a, b), np.where(np.abs(o) <= 1, np.inf, -np.inf))
    t0, t1 = near.max(axis=1), far.min(axis=1)
    return np.where(t1 > t0, t0, np.inf)


@needs_packets
def test_packets_unit_cube_shared_edges_and_vertices(cube, monkeypatch):
    packets, embreex = _pair(cube, monkeypatch)
    o, d = _cube_rays()
    t, tri = _assert_same(packets, embreex, o, d)
    # robust mode: no ray entering the cube through a vertex, an edge or a face
    # diagonal is lost (the few that only touch it at a point may go either way)
    entry = _cube_entry(o, d)
    enters = np.isfinite(entry)
    assert enters.sum() > 250
    assert (tri[enters] >= 0).all()
    np.testing.assert_allclose(t[enters], entry[enters], atol=1e-5)


@needs_packets
def test_packets_unit_cube_axis_rays_hit_the_near_face(cube, monkeypatch):
    packets, embreex = _pair(cube, monkeypatch)
    o = np.array([[0.3, -0.2, -5.0], [0.0, 0.0, 5.0], [-1.0, -1.0, -5.0], [1.0, 1.0, -5.0]])
    d = np.array([[0, 0, 1.0], [0, 0, -1.0], [0, 0, 1.0], [0, 0, 1.0]])
    t, tri = _assert_same(packets, embreex, o, d)
    np.testing.assert_allclose(t, 4.0, atol=1e-5)
    assert cube.face_normals[tri[0]][2] == pytest.approx(-1.0)
    assert cube.face_normals[tri[1]][2] == pytest.approx(1.0)


@needs_packets
def test_packets_rays_that_miss(cube, monkeypatch):
    packets, embreex = _pair(cube, monkeypatch)
    o = np.array([[3.0, 3.0, -5.0], [0.0, 0.0, -5.0], [1.0 + 1e-3, 0.0, -5.0], [0.0, 0.0, 5.0]])
    d = np.array([[0, 0, 1.0], [0, 0, -1.0], [0, 0, 1.0], [1.0, 0, 0]])
    t, tri = _assert_same(packets, embreex, o, d)
    assert tri.tolist() == [-1, -1, -1, -1]
    assert np.isinf(t).all()


@needs_packets
def test_packets_max_distance_limits(cube, monkeypatch):
    packets, embreex = _pair(cube, monkeypatch)
    n = 7
    o = np.tile([0.25, -0.5, -5.0], (n, 1))
    d = np.tile([0, 0, 1.0], (n, 1))
    t_hit = packets.first_hit(o[:1], d[:1])[0][0]
    scale = packets._scale  # the float32 just below the hit, in world units
    below = float(np.nextafter(np.float32(t_hit / scale), np.float32(0))) * scale
    limits = np.array([0.0, 1.0, below, t_hit, 4.5, 1e300, np.inf])
    t, tri = _assert_same(packets, embreex, o, d, max_distance=limits)
    assert (tri[:3] == -1).all() and (tri[3:] >= 0).all()
    for limit in (0.0, t_hit, np.inf):  # one limit for every ray
        _assert_same(packets, embreex, o, d, max_distance=limit)


@needs_packets
def test_packets_empty_batches(cube, monkeypatch):
    packets, embreex = _pair(cube, monkeypatch)
    t, tri = packets.first_hit(np.zeros((0, 3)), np.zeros((0, 3)))
    assert t.shape == (0,) and tri.shape == (0,) and tri.dtype == np.int64
    assert packets.any_hit(np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)
    hits = packets.all_hits(np.zeros((0, 3)), np.zeros((0, 3)))
    assert hits.count.shape == (0,) and hits.t.shape == (0,)


@needs_packets
@pytest.mark.parametrize("n", [1, 5, 15, 16, 17, 31, 33, 16 * 1100 + 7])
def test_packets_batch_sizes_not_a_multiple_of_16(unit_sphere, monkeypatch, rng, n):
    # the last packet's missing lanes are invalid: the rays before them are traced
    # as alone, and as embreex traces them
    packets, embreex = _pair(unit_sphere, monkeypatch)
    o = rng.uniform(-1.5, 1.5, (n, 3))
    d = rng.normal(size=(n, 3))
    t, tri = _assert_same(packets, embreex, o, d)
    last = slice(n - 1, n)
    t1, tri1 = packets.first_hit(o[last], d[last])
    assert t1.tobytes() == t[last].tobytes() and tri1[0] == tri[-1]


@needs_packets
@pytest.mark.parametrize("workers", [1, 2])
def test_packets_coherent_and_incoherent_batches(unit_sphere, monkeypatch, rng, workers):
    # orthographic rays (packets traced with the coherent flag), scattered rays, and
    # the two interleaved so that packets mix them: a ray's hit never depends on its
    # neighbours
    packets, embreex = _pair(unit_sphere, monkeypatch, workers=workers)
    n = 40_000
    xy = rng.uniform(-1.2, 1.2, (n, 2))
    ortho_o = np.column_stack([xy, np.full(n, -3.0)])
    ortho_d = np.tile([0.0, 0.0, 1.0], (n, 1))
    scattered_o = rng.uniform(-2, 2, (n, 3))
    scattered_d = rng.normal(size=(n, 3))
    scattered_d /= np.linalg.norm(scattered_d, axis=1)[:, None]
    mixed_o = np.empty((2 * n, 3))
    mixed_d = np.empty((2 * n, 3))
    mixed_o[::2], mixed_o[1::2] = ortho_o, scattered_o
    mixed_d[::2], mixed_d[1::2] = ortho_d, scattered_d
    t_ortho, tri_ortho = _assert_same(packets, embreex, ortho_o, ortho_d)
    t_scat, tri_scat = _assert_same(packets, embreex, scattered_o, scattered_d)
    t_mixed, tri_mixed = _assert_same(packets, embreex, mixed_o, mixed_d)
    assert t_mixed[::2].tobytes() == t_ortho.tobytes()
    assert t_mixed[1::2].tobytes() == t_scat.tobytes()
    np.testing.assert_array_equal(tri_mixed[::2], tri_ortho)
    np.testing.assert_array_equal(tri_mixed[1::2], tri_scat)
    hits, hits_ref = packets.all_hits(mixed_o, mixed_d), embreex.all_hits(mixed_o, mixed_d)
    np.testing.assert_array_equal(hits.count, hits_ref.count)
    np.testing.assert_array_equal(hits.triangle, hits_ref.triangle)
    assert hits.t.tobytes() == hits_ref.t.tobytes()


@needs_packets
def test_packets_duplicated_triangles(monkeypatch, rng):
    # every face three times over (two of them with their corners rotated): hits at
    # exactly equal distances on different triangles; both paths must pick the same
    base = trimesh.creation.icosphere(subdivisions=3)
    f = base.faces
    mesh = trimesh.Trimesh(base.vertices, np.concatenate([f, f[:, [1, 2, 0]], f[::-1]]),
                           process=False)
    packets, embreex = _pair(mesh, monkeypatch)
    n = 20_000
    o = rng.uniform(-2, 2, (n, 3))
    d = -o + rng.normal(scale=0.3, size=(n, 3))
    _assert_same(packets, embreex, o, d)


@needs_packets
def test_packets_far_from_the_origin_and_scaled(monkeypatch, rng):
    box = trimesh.creation.box(extents=(2.0, 3.0, 1.0))
    far = trimesh.Trimesh(box.vertices * 3e5 + 1e6, box.faces, process=False)
    packets, embreex = _pair(far, monkeypatch)
    n = 5000
    o = rng.uniform(far.bounds[0] - 5e5, far.bounds[1] + 5e5, (n, 3))
    d = far.centroid - o
    _assert_same(packets, embreex, o, d)


@needs_packets
def test_packets_depth_buffer_first_triangles(unit_sphere, monkeypatch, rng):
    # the depth buffer's direct small-batch call goes through the same packets
    packets, embreex = _pair(unit_sphere, monkeypatch)
    d32 = rng.normal(size=(1000, 3))
    d32 = (d32 / np.linalg.norm(d32, axis=1)[:, None]).astype(np.float32)
    eye = np.array([0.1, 0.2, 0.3])
    got = _first_triangles(packets, eye, d32)
    assert got.dtype == np.int32
    np.testing.assert_array_equal(got, _first_triangles(embreex, eye, d32))
    np.testing.assert_array_equal(got, packets.first_hit(eye[None], d32.astype(np.float64))[1])


@needs_packets
def test_packets_scene_pickles_and_rebuilds(cube):
    scene = Scene(cube).build()
    o, d = _cube_rays()
    t, tri = scene.first_hit(o, d)
    again = pickle.loads(pickle.dumps(scene))
    assert "_packets" not in again.__dict__
    t2, tri2 = again.first_hit(o, d)
    assert t.tobytes() == t2.tobytes()
    np.testing.assert_array_equal(tri, tri2)


@needs_packets
def test_library_finds_embreex_libembree4():
    lib = _embree4.library()
    assert lib.version // 10000 == 4
    assert "embree4" in lib.path
    assert lib.intersect16 and lib.occluded16


def test_library_fallback_when_not_found(cube, monkeypatch):
    # no libembree4 beside embreex: Scene traces with embreex, with the same results
    monkeypatch.setattr(_embree4, "_library", [])
    monkeypatch.setattr(_embree4, "_library_candidates", lambda: [])
    assert _embree4.library() is None
    scene = Scene(cube)
    o, d = _cube_rays()
    t, tri = scene.first_hit(o, d)
    assert scene._packets is None and "_embree" in scene.__dict__
    enters = np.isfinite(_cube_entry(o, d))
    assert (tri[enters] >= 0).all()
    np.testing.assert_allclose(t[enters], _cube_entry(o, d)[enters], atol=1e-5)
    assert scene.any_hit(o, d)[enters].all()


def test_library_fallback_when_symbols_are_missing(monkeypatch, tmp_path):
    # a library that opens but has no Embree calls (the C library), a file that is
    # no library at all: neither is used, and the search goes on to the next path
    libc = ctypes.util.find_library("c")
    junk = tmp_path / "libembree4.so.4"
    junk.write_bytes(b"not a shared object")
    monkeypatch.setattr(_embree4, "_library", [])
    monkeypatch.setattr(_embree4, "_library_candidates",
                        lambda: [p for p in (str(junk), libc) if p])
    assert _embree4.library() is None


def test_library_turned_off_by_the_environment(cube, monkeypatch):
    monkeypatch.setenv(_embree4.PACKETS_ENV, "0")
    assert _embree4.library() is None
    assert Scene(cube).build()._packets is None
    monkeypatch.setenv(_embree4.PACKETS_ENV, "off")
    assert not _embree4.packets_enabled()
    monkeypatch.setenv(_embree4.PACKETS_ENV, "1")
    assert _embree4.packets_enabled()


def test_stacked_triangles_marks_overlaps_in_one_plane():
    # a face doubled (either winding) overlaps its twin; a subdivided box's coplanar
    # neighbours only share edges; a small square laid on a big one overlaps it
    box = trimesh.creation.box(extents=(0.8, 0.8, 0.8))
    doubled = np.concatenate([box.faces, box.faces[:, ::-1]])
    assert _embree4._stacked_triangles(box.vertices.astype(np.float32), doubled).all()
    fine = box.subdivide().subdivide()
    assert not _embree4._stacked_triangles(fine.vertices.astype(np.float32), fine.faces).any()
    v = np.array([[-0.4, -0.4, 0], [0.4, -0.4, 0], [0.4, 0.4, 0], [-0.4, 0.4, 0],
                  [0.0, 0.0, 0], [0.1, 0.0, 0], [0.1, 0.1, 0], [0.3, 0.3, 0.2]], np.float32)
    f = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 5, 7]])
    assert _embree4._stacked_triangles(v, f).tolist() == [True, False, True, False]


@needs_packets
@pytest.mark.parametrize("workers", [1, 2])
def test_packets_stacked_walls_seen_by_orthographic_views(monkeypatch, workers):
    # a game-kit building whose walls overlap in their planes, seen by orthographic
    # views (coherent packets, Embree's frustum traversal): the triangle and distance
    # embreex gives, where an overlapping twin lies at the same distance or a ulp off
    from viscore.cli.bench.core import bench_ray_sets

    mesh = load_mesh("building-house")
    packets, embreex = _pair(mesh, monkeypatch, workers=workers)
    assert packets._packets._stacked.any()
    o, d = bench_ray_sets(mesh, views=2, resolution=256, rays=10, seed=256)["coherent"]
    _assert_same(packets, embreex, o, d)


def test_cell_quantiles_are_each_large_groups_percentile_of_sizes():
    rng = np.random.default_rng(1)
    counts = np.array([3, _embree4._SWEEP_GROUP, _embree4._SWEEP_GROUP + 1, 250, 1, 400])
    starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    box = rng.random((starts[-1], 4))
    size = np.maximum(box[:, 1] - box[:, 0], box[:, 3] - box[:, 2])
    got = _embree4._cell_quantiles(box, starts)
    for g, (a, b) in enumerate(zip(starts[:-1], starts[1:], strict=True)):
        if b - a > _embree4._SWEEP_GROUP:
            want = np.percentile(size[a:b], _embree4._GRID_CELL_QUANTILE)
            assert got[g] == pytest.approx(want, rel=1e-12)
        else:  # swept, not put on grids
            assert got[g] == 0.0


def test_stacked_triangles_on_a_plane_of_more_triangles_than_a_sweep():
    # 20 x 20 unit squares in z = 0 (800 triangles, one group: put on grids) share
    # edges only; a small triangle laid inside square (3, 5) overlaps its two halves
    # and nothing else
    n = 20
    xs, ys = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    v = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], axis=1)
    at = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    faces = np.concatenate([np.stack([at, at + n + 1, at + n + 2], axis=1),
                            np.stack([at, at + n + 2, at + 1], axis=1)])
    assert len(faces) > _embree4._SWEEP_GROUP
    small = np.array([[3.2, 5.2, 0], [3.8, 5.3, 0], [3.5, 5.8, 0]])
    v = np.concatenate([v, small]).astype(np.float32)
    faces = np.concatenate([faces, [[len(v) - 3, len(v) - 2, len(v) - 1]]])
    stacked = _embree4._stacked_triangles(v, faces)
    square = 3 * n + 5
    assert sorted(np.flatnonzero(stacked).tolist()) == [square, n * n + square, len(faces) - 1]
