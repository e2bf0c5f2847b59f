"""The depth buffer's rules across creases and silhouettes: planar flats that share an edge
(viscore.culling._creases.flat_pairs: a wall meeting the floor, two faces of a box), two regions
along their planes' line and a region behind (viscore.culling._depth_kernel.region_creases: a wall
standing on a floor, a pillar before a wall). Pixels they cover are never nearer than the
occluders, and a crease seen as a silhouette, or a gap under a wall, stays open."""

import numpy as np
import pytest
import trimesh
from test_depth_patches import _sampled_first_hits

from viscore import PerspectiveCamera, Scene
from viscore.culling._creases import flat_pairs
from viscore.culling.depth_buffer import ConservativeDepthBuffer, OccluderScene


def _corner():
    """A floor 10 x 10 (y up) and a wall 10 wide and 4 high on its far edge (z = 10),
    each a flat of two triangles, sharing the edge along the crease."""
    v = np.array([[0, 0, 0], [10, 0, 0], [10, 0, 10], [0, 0, 10], [10, 4, 10], [0, 4, 10]],
                 dtype=np.float64)
    f = np.array([[0, 1, 2], [0, 2, 3], [3, 2, 4], [3, 4, 5]])
    return trimesh.Trimesh(v, f, process=False)


def _without_pairs(occ: OccluderScene) -> OccluderScene:
    occ._flat_pairs = occ._flat_pairs[:0]
    occ._region_creases = False  # the line rule of two regions covers such creases too
    occ._sheet_rule = False  # and so does the sheet rule of any edge-connected triangles
    return occ


def _without_region_creases(occ: OccluderScene) -> OccluderScene:
    """The scene without the region crease rule, nor the junction rule (which covers the
    same pixels by the triangles themselves)."""
    occ._region_creases = False
    occ._junction_rule = False
    return occ


def _assert_never_nearer(scene, cam, buf, mask, rng, rays: int = 24) -> None:
    """Every pixel of ``mask``: ``rays`` random rays through it hit the scene, no farther
    than the pixel's depth."""
    pixels = np.argwhere(mask)
    hits = _sampled_first_hits(scene, cam, buf.shape, pixels, rng, per=rays)
    i, j = pixels[:, 0], pixels[:, 1]
    assert np.isfinite(hits).all()
    assert (hits <= buf.depth[i, j][:, None]).all()


def test_a_wall_and_its_floor_are_a_pair_and_a_box_behind_the_crease_is_culled():
    corner = _corner()
    flat, pairs, edges = flat_pairs(corner.vertices, corner.faces)
    assert flat.tolist() == [0, 0, 1, 1] and pairs.tolist() == [0 * 2 + 1]
    creases = edges[edges[:, 3] >= 0]
    assert len(creases) == 1 and sorted(creases[0, :2].tolist()) == [2, 3]
    cam = PerspectiveCamera((5, 1.7, 2), (0, -0.05, 1), up=(0, 1, 0), fov=60, resolution=256,
                            height=144)
    box = ([[4, -2, 11]], [[6, 1, 12]])  # beyond the wall, reaching under the floor's level
    with_pairs = ConservativeDepthBuffer.from_occluders(OccluderScene([corner]), cam)
    without = ConservativeDepthBuffer.from_occluders(_without_pairs(OccluderScene([corner])),
                                                     cam)
    assert with_pairs.occluded(*box)[0] and not without.occluded(*box)[0]
    assert with_pairs.covered.sum() > without.covered.sum()
    world = trimesh.util.concatenate([corner, trimesh.creation.box(bounds=np.vstack(box))])
    o, d = cam.rays()
    _, tri = Scene(world).first_hit(o, d)
    assert not (tri >= len(corner.faces)).any()  # the truth: hidden


def test_a_crease_seen_as_a_silhouette_blocks_its_pixels():
    """Two faces of a wedge seen so that one is behind the other's edge: the edge is a
    silhouette of the pair (a boundary), and a box seen just past it is never culled."""
    # a roof ridge along x: two slopes meeting at y = 3 over z = 5; the eye above the far
    # slope's plane extension sees only the near slope; a box behind the ridge, its top
    # showing over the ridge
    v = np.array([[0, 0, 0], [10, 0, 0], [10, 3, 5], [0, 3, 5], [10, 0, 10], [0, 0, 10]],
                 dtype=np.float64)
    f = np.array([[0, 1, 2], [0, 2, 3], [3, 2, 4], [3, 4, 5]])
    roof = trimesh.Trimesh(v, f, process=False)
    assert len(flat_pairs(roof.vertices, roof.faces)[1]) == 1
    cam = PerspectiveCamera((5, 2, -8), (0, 0.05, 1), up=(0, 1, 0), fov=60, resolution=256,
                            height=144)
    box = ([[4, 2, 12]], [[6, 5, 13]])
    buf = ConservativeDepthBuffer.from_occluders(OccluderScene([roof]), cam)
    world = trimesh.util.concatenate([roof, trimesh.creation.box(bounds=np.vstack(box))])
    o, d = cam.rays()
    _, tri = Scene(world).first_hit(o, d)
    assert (tri >= len(roof.faces)).any()  # the truth: its top shows over the ridge
    assert not buf.occluded(*box)[0]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rooms_of_boxes_never_nearer_and_nothing_seen_is_culled(seed):
    """Random blocks standing in a hall (closed boxes: every face a flat, every edge
    between two faces a crease or a silhouette; the hall's inside meeting at concave
    creases, where a pixel's farthest point is on the crease), seen from random eyes among
    them: every
    covered pixel's rays meet the blocks no farther than its depth, the pairs cover pixels
    the other rules leave open, and no culled box shows in a full-resolution id image."""
    rng = np.random.default_rng(seed)
    hall = trimesh.creation.box(bounds=[[-30, 0, -30], [30, 12, 30]])
    hall.invert()  # its inside: a floor, walls and a ceiling meeting at concave creases
    blocks = [hall]
    eye = np.r_[rng.uniform(-25, 25), rng.choice([1.7, 4.0, 10.0]), rng.uniform(-25, 25)]
    while len(blocks) < 26:
        lo = np.r_[rng.uniform(-28, 24), 0.0, rng.uniform(-28, 24)]
        hi = lo + np.r_[rng.uniform(1, 6), rng.uniform(1, 8), rng.uniform(1, 6)]
        if not ((lo - 0.5 < eye) & (eye < hi + 0.5)).all():  # not around the eye
            blocks.append(trimesh.creation.box(bounds=[lo, hi]))
    world = trimesh.util.concatenate(blocks)
    scene = Scene(world)
    aim = np.r_[rng.uniform(-20, 20), 0.0, rng.uniform(-20, 20)] - eye
    cam = PerspectiveCamera(eye, aim, up=(0, 1, 0), fov=80, resolution=192, height=108)
    occ = OccluderScene([world])
    buf = ConservativeDepthBuffer.from_occluders(occ, cam)
    plain = ConservativeDepthBuffer.from_occluders(_without_pairs(OccluderScene([world])), cam)
    assert (buf.covered >= plain.covered).all()
    assert buf.covered.sum() > plain.covered.sum()  # the pairs cover creases
    _assert_never_nearer(scene, cam, buf, buf.covered & ~plain.covered, rng)
    centre = np.column_stack([rng.uniform(-29, 29, 1500), rng.uniform(0.5, 6, 1500),
                              rng.uniform(-29, 29, 1500)])
    half = rng.uniform(0.1, 1.5, (1500, 3))
    lo, hi = centre - half, centre + half
    culled = buf.occluded(lo, hi)
    occludees = [trimesh.creation.box(bounds=[a, b])
                 for a, b in zip(lo[culled], hi[culled], strict=True)]
    if occludees:
        both = trimesh.util.concatenate([world] + occludees)
        o, d = cam.rays()
        _, tri = Scene(both).first_hit(o, d)
        assert not (tri >= len(world.faces)).any()


def _wall_on_a_floor():
    """A floor 20 x 30 (y up) and, standing on it at z = 10, a wall 10 wide and 4 high of
    its own (no edge shared: the floor goes on behind the wall, a T-junction)."""
    floor = trimesh.Trimesh([[-5, 0, 0], [15, 0, 0], [15, 0, 30], [-5, 0, 30]],
                            [[0, 1, 2], [0, 2, 3]], process=False)
    wall = trimesh.Trimesh([[0, 0, 10], [10, 0, 10], [10, 4, 10], [0, 4, 10]],
                           [[0, 1, 2], [0, 2, 3]], process=False)
    return trimesh.util.concatenate([floor, wall])


def test_a_wall_standing_on_a_floor_covers_its_foot_and_a_box_behind_it_is_culled():
    """No flat pair (the wall and the floor share no edge), so only the line rule of two
    regions covers the pixels along the wall's foot: with it a box behind the wall, below
    the floor's level, is culled; without it the foot is a line of open pixels."""
    level = _wall_on_a_floor()
    assert len(flat_pairs(level.vertices, level.faces)[1]) == 0
    cam = PerspectiveCamera((5.3, 1.7, 2.1), (0, -0.05, 1), up=(0, 1, 0), fov=60,
                            resolution=256, height=144)
    box = ([[4, -2, 11]], [[6, 1, 12]])
    on = ConservativeDepthBuffer.from_occluders(OccluderScene([level]), cam)
    off = ConservativeDepthBuffer.from_occluders(
        _without_region_creases(OccluderScene([level])), cam)
    assert on.occluded(*box)[0] and not off.occluded(*box)[0]
    assert on.covered.sum() > off.covered.sum()
    assert (on.covered >= off.covered).all()
    world = trimesh.util.concatenate([level, trimesh.creation.box(bounds=np.vstack(box))])
    o, d = cam.rays()
    _, tri = Scene(world).first_hit(o, d)
    assert not (tri >= len(level.faces)).any()  # the truth: hidden


def test_a_wall_with_a_gap_under_it_keeps_its_foot_open():
    """The same wall lifted 0.05 off the floor: its lower edge is not on the floor's plane,
    so the pixels along it stay open and a box seen through the gap is never culled."""
    level = _wall_on_a_floor()
    level.vertices[4:, 1] += np.where(level.vertices[4:, 1] == 0, 0.05, 0.0)
    cam = PerspectiveCamera((5.3, 0.025, 2.1), (0, 0, 1), up=(0, 1, 0), fov=60,
                            resolution=256, height=144)  # the eye at the gap's height
    box = ([[4, 0.001, 12]], [[6, 0.04, 13]])  # behind the wall, in the gap's height
    buf = ConservativeDepthBuffer.from_occluders(OccluderScene([level]), cam)
    world = trimesh.util.concatenate([level, trimesh.creation.box(bounds=np.vstack(box))])
    o, d = cam.rays()
    _, tri = Scene(world).first_hit(o, d)
    assert (tri >= len(level.faces)).any()  # the truth: seen through the gap
    assert not buf.occluded(*box)[0]


@pytest.mark.parametrize("seed", [3, 4, 5])
def test_blocks_on_a_floor_region_creases_never_nearer(seed):
    """Blocks standing on a floor of its own, from random eyes: the pixels the line rule
    of two regions adds are never nearer than the blocks and the floor (24 rays per pixel),
    and it adds some."""
    rng = np.random.default_rng(seed)
    floor = trimesh.Trimesh([[-30, 0, -30], [30, 0, -30], [30, 0, 30], [-30, 0, 30]],
                            [[0, 2, 1], [0, 3, 2]], process=False)
    eye = np.r_[rng.uniform(-25, 25), rng.choice([1.7, 4.0, 10.0]), rng.uniform(-25, 25)]
    blocks = [floor]
    while len(blocks) < 26:
        lo = np.r_[rng.uniform(-28, 24), 0.0, rng.uniform(-28, 24)]
        hi = lo + np.r_[rng.uniform(1, 6), rng.uniform(1, 8), rng.uniform(1, 6)]
        if not ((lo - 0.5 < eye) & (eye < hi + 0.5)).all():
            blocks.append(trimesh.creation.box(bounds=[lo, hi]))
    world = trimesh.util.concatenate(blocks)
    scene = Scene(world)
    aim = np.r_[rng.uniform(-20, 20), 0.0, rng.uniform(-20, 20)] - eye
    cam = PerspectiveCamera(eye, aim, up=(0, 1, 0), fov=80, resolution=192, height=108)
    on = ConservativeDepthBuffer.from_occluders(OccluderScene([world]), cam)
    off = ConservativeDepthBuffer.from_occluders(
        _without_region_creases(OccluderScene([world])), cam)
    assert (on.covered >= off.covered).all() and on.covered.sum() > off.covered.sum()
    _assert_never_nearer(scene, cam, on, on.covered & ~off.covered, rng)


def test_a_pillar_against_a_wall_behind_it_covers_its_silhouette():
    """A pillar 3 m in front of a wide wall: the pixels along its sides see the pillar at
    some corners and the wall at others. The wall has no boundary there, so every ray of
    such a pixel meets it: a box behind the wall, just behind the pillar's edge, is culled
    with the region rule and not without; the truth hides it."""
    wall = trimesh.Trimesh([[-20, 0, 10], [20, 0, 10], [20, 8, 10], [-20, 8, 10]],
                           [[0, 1, 2], [0, 2, 3]], process=False)
    pillar = trimesh.creation.box(bounds=[[-0.5, 0, 6.5], [0.5, 6, 7.5]])
    level = trimesh.util.concatenate([wall, pillar])
    cam = PerspectiveCamera((0.1, 2.0, 0.0), (0, 0, 1), up=(0, 1, 0), fov=60, resolution=256,
                            height=144)
    box = ([[-1.2, 1, 11]], [[1.2, 3, 12]])  # behind the wall, wider than the pillar's image
    on = ConservativeDepthBuffer.from_occluders(OccluderScene([level]), cam)
    off = ConservativeDepthBuffer.from_occluders(
        _without_region_creases(OccluderScene([level])), cam)
    assert on.occluded(*box)[0] and not off.occluded(*box)[0]
    assert (on.covered >= off.covered).all() and on.covered.sum() > off.covered.sum()
    _assert_never_nearer(Scene(level), cam, on, on.covered & ~off.covered,
                         np.random.default_rng(7))
    world = trimesh.util.concatenate([level, trimesh.creation.box(bounds=np.vstack(box))])
    o, d = cam.rays()
    _, tri = Scene(world).first_hit(o, d)
    assert not (tri >= len(level.faces)).any()  # the truth: hidden


def test_a_region_behind_works_when_it_is_the_only_region():
    """The same rule when the wall is the scene's only region: a round pillar's triangles
    are lone facets under _LONE_FACET_SHARE of the area, so they are no regions."""
    wall = trimesh.Trimesh([[-400, 0, 10], [400, 0, 10], [400, 8, 10], [-400, 8, 10]],
                           [[0, 1, 2], [0, 2, 3]], process=False)
    pillar = trimesh.creation.capsule(height=6.0, radius=0.3, count=[32, 32])
    # jittered: no two of its triangles in one plane
    pillar.vertices += np.random.default_rng(1).uniform(-0.01, 0.01, pillar.vertices.shape)
    pillar.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
    pillar.apply_translation([0, 3.0, 7.0])
    level = trimesh.util.concatenate([wall, pillar])
    occ = OccluderScene([level])
    assert len(occ._region_plane) == 1
    cam = PerspectiveCamera((0.02, 2.0, 0.0), (0, 0, 1), up=(0, 1, 0), fov=60,
                            resolution=256, height=144)
    box = ([[-0.6, 2, 11]], [[0.6, 4, 12]])  # behind the wall, wider than the pillar's image
    on = ConservativeDepthBuffer.from_occluders(occ, cam, width=64, height=36)
    off = ConservativeDepthBuffer.from_occluders(
        _without_region_creases(OccluderScene([level])), cam, width=64, height=36)
    assert on.occluded(*box)[0] and not off.occluded(*box)[0]
    _assert_never_nearer(Scene(level), cam, on, on.covered & ~off.covered,
                         np.random.default_rng(8))
