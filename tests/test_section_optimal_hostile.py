"""Adversarial checks of the largest inscribed chain stages (generators/_section_optimal.py).

Containment and tiling on candidates from real slices and hostile pixel images (holes,
loops touching at pixel corners, one-pixel bridges, nested and many holes), optimality
against a brute force over vertex subsets (holes included), and regressions of the bugs
found by this reading.
"""

from itertools import combinations

import numpy as np
import pytest
import shapely
import trimesh
from scipy import ndimage
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient

from viscore import load_mesh
from viscore.generators._polygon_chain.optimal import _pocket_rules, best_inscribed, refine_chain
from viscore.generators._polygon_chain.simplify import simplification_chain
from viscore.generators.planar_sections._loops import bridge_holes, slice_polygons
from viscore.generators.planar_sections._slices import best_slices, section_solid, slice_image


def _shoelace(loop):
    return 0.5 * float(np.sum(loop[:, 0] * np.roll(loop[:, 1], -1)
                              - np.roll(loop[:, 0], -1) * loop[:, 1]))


def _feasible(loop, region):
    """The brute force's definition: the loop, repaired by buffer(0), keeps its (positive)
    shoelace area and lies in the region."""
    area = _shoelace(loop)
    if area <= 0:
        return 0.0
    fixed = Polygon(loop).buffer(0)
    if abs(fixed.area - area) > 1e-9 * max(1.0, area) or not region.covers(fixed):
        return 0.0
    return area


def _brute_force(ring, region, kmax):
    """Best area over vertex subsets of at most k + 2 vertices (in loop order), k <= kmax."""
    best = np.zeros(kmax + 1)
    for m in range(3, min(kmax + 2, len(ring)) + 1):
        for idx in combinations(range(len(ring)), m):
            best[m - 2] = max(best[m - 2], _feasible(ring[list(idx)], region))
    return np.maximum.accumulate(best)


def _cumulative(found, kmax):
    best = np.zeros(kmax + 1)
    for k, (area, _) in found.items():
        best[k] = area
    return np.maximum.accumulate(best)


def _check_chain(ch, greedy, region, *, searched_only=False):
    """Counts and areas strictly decrease; every stage (or every searched one) lies in the
    region, and (up to 40 triangles) its triangles tile its loop without overlap; never
    less area than a greedy stage that lies in the region, at each count."""
    assert np.all(np.diff(ch.counts) < 0) and np.all(np.diff(ch.areas) < 0)
    greedy_sets = {(int(c), greedy.stage_triangles(s).tobytes())
                   for s, c in enumerate(greedy.counts)}
    shapely.prepare(region)
    every = np.unique(np.concatenate([ch.stage_triangles(s) for s in range(ch.stages)]),
                      axis=0)
    inside = {t.tobytes() for t, ok in zip(every, shapely.covers(
        region, shapely.polygons(ch.ring[every])), strict=True) if ok}
    for s in range(ch.stages):
        tri = ch.stage_triangles(s)
        assert len(tri) == ch.counts[s]
        if searched_only and (int(ch.counts[s]), tri.tobytes()) in greedy_sets:
            continue
        assert all(t.tobytes() in inside for t in tri), (s, ch.counts[s])
        if len(tri) > 40:
            continue
        tris = shapely.polygons(ch.ring[tri])
        total = float(shapely.area(tris).sum())
        assert total == pytest.approx(ch.areas[s], abs=1e-9 * max(1.0, total))
        union = shapely.union_all(tris)
        tol = 1e-9 * max(1.0, total)
        assert union.area == pytest.approx(total, abs=tol)  # no overlap
        fixed = Polygon(ch.stage_ring(s)).buffer(0)
        assert fixed.symmetric_difference(union).area <= tol  # the triangles tile the loop
    # greedy stage s has the triangles greedy.triangles[s:]
    p = greedy.ring[greedy.triangles]
    outside = ~shapely.covers(region, shapely.polygons(p)) & (
        shapely.area(shapely.polygons(p)) > 0)
    first_inside = int(np.flatnonzero(outside)[-1]) + 1 if outside.any() else 0
    for count, area in zip(greedy.counts[first_inside:], greedy.areas[first_inside:],
                           strict=True):
        kept = ch.areas[ch.counts <= count]
        assert (kept.max() if len(kept) else 0.0) >= area - 1e-9


# ------------------------------------------------------------------ regressions
#: A slice part with one triangular hole bridged to the outer loop: the pocket of the
#: chord 1-9 winds once around the triangle (11,18)-(13,18)-(11,19) and once, the other
#: way, around the hole, both of area 1, so its shoelace area is 0. The pocket check
#: passed every loop of zero shoelace area, the search chose polygons covering the hole,
#: the final check refused them, and no stage was found at any count.
_ZERO_RING = np.array([[10, 16], [11, 18], [13, 18], [11, 19], [10, 19], [8, 20], [10, 20],
                       [10, 19], [11, 19], [11, 22], [6, 19]], float)
_ZERO_REGION = Polygon([(10, 16), (11, 18), (13, 18), (11, 19), (11, 22), (6, 19)],
                       [[(8, 20), (10, 20), (10, 19)]])


def test_zero_area_pocket_around_a_hole_is_refused():
    n = len(_ZERO_RING)
    ok = np.ones((n, n), dtype=bool)
    np.fill_diagonal(ok, False)
    rules = _pocket_rules(_ZERO_RING, _ZERO_REGION, ok)
    assert not rules[1, 9]
    found = best_inscribed(_ZERO_RING, _ZERO_REGION, 5)
    assert sorted(found) == [1, 2, 3, 4, 5]
    np.testing.assert_allclose(_cumulative(found, 5), _brute_force(_ZERO_RING, _ZERO_REGION, 5))
    for area, idx in found.values():
        assert _feasible(_ZERO_RING[idx], _ZERO_REGION) == pytest.approx(area)


def test_simple_loop_in_a_candidate_with_a_hole():
    """A stage that lost its bridge (no repeated vertex) in a candidate with a hole: chords
    inside the candidate reach around the hole. Searched without pocket checks (the loop
    has no repeated vertex), every best polygon covered the hole and nothing was found."""
    region = Polygon([(0, 0), (12, 0), (12, 12), (0, 12)], [[(5, 5), (5, 7), (7, 7), (7, 5)]])
    # the square minus a channel (y 6..7) to a cavity (4..8)^2 around the hole (5..7)^2
    ring = np.array([[0, 0], [12, 0], [12, 12], [0, 12], [0, 7], [4, 7], [4, 8], [8, 8],
                     [8, 4], [4, 4], [4, 6], [0, 6]], float)
    assert Polygon(ring).is_valid and region.covers(Polygon(ring))
    found = best_inscribed(ring, region, 5)
    assert sorted(found) == [1, 2, 3, 4, 5]
    for area, idx in found.values():
        assert _feasible(ring[idx], region) == pytest.approx(area)
    # a lower bound of the best: pockets are taken along this loop, not along the
    # candidate's boundary, so polygons reaching into the cavity are missed (42 at k = 1)
    got, best = _cumulative(found, 5), _brute_force(ring, region, 5)
    assert np.all(got <= best + 1e-9) and got[2] == best[2] == 48.0


def test_chain_stopped_above_the_pool_is_not_searched():
    """A chain whose smallest stage has more vertices than the pool stays greedy (the
    search used to run on all of that stage's vertices: 19 s on a 642-vertex candidate of
    a noisy pixel image in the conservative variant, whose chain stopped at 300 vertices)."""
    ring = np.array([[0, 0], [4, 0], [4, 1], [5, 2], [4, 3], [4, 4], [0, 4]], float)
    greedy = simplification_chain(ring)
    assert greedy.areas[-1] == 8.0
    assert refine_chain(greedy, Polygon(ring)).areas.tolist() == [17.0, 16.0, 10.0]
    assert refine_chain(greedy, Polygon(ring), pool=2).areas.tolist() == [17.0, 16.0, 8.0]


#: Four holes, two touching at (2, 5), bridged into one loop (a random 12 x 12 pixel image,
#: RDP at one pixel): the greedy chain's full stage has the triangle (2,7)-(2,5)-(4,2),
#: which overlaps the hole (6,6)-(6,5)-(2,5). Upstream (the ear test of
#: generators/_section_simplify.py); refine_chain keeps greedy stages above 12 triangles.
_TOUCH_RING = np.array([
    [5, 0], [4, 2], [2, 3], [1, 3], [2, 5], [2, 3], [4, 2], [6, 3], [6, 5], [2, 5], [6, 6],
    [8, 5], [9, 7], [8, 8], [8, 9], [10, 9], [8, 8], [9, 7], [10, 5], [8, 5], [6, 6], [6, 5],
    [6, 3], [10, 2], [7, 0], [11, 0], [11, 10], [0, 10], [0, 8], [2, 7], [0, 7], [0, 1]], float)
_TOUCH_REGION = Polygon([(5, 0), (4, 2), (6, 3), (10, 2), (7, 0), (11, 0), (11, 10), (0, 10),
                         (0, 8), (2, 7), (0, 7), (0, 1)],
                        [[(9, 7), (10, 5), (8, 5)], [(8, 8), (8, 9), (10, 9)],
                         [(6, 6), (6, 5), (2, 5)], [(2, 5), (2, 3), (1, 3)]])


def test_stages_of_touching_holes_stay_inside():
    """refine_chain drops the greedy stages that hold a triangle outside the candidate."""
    greedy = simplification_chain(_TOUCH_RING)
    ch = refine_chain(greedy, _TOUCH_REGION)
    _check_chain(ch, greedy, _TOUCH_REGION)
    assert ch.counts[0] < greedy.counts[0] and ch.counts[-1] == 1


@pytest.mark.xfail(strict=True, reason="greedy ear chain on holes touching at a vertex "
                   "(generators/_section_simplify.py), reported to the lead")
def test_greedy_full_stage_of_touching_holes_stays_inside():
    greedy = simplification_chain(_TOUCH_RING)
    tris = shapely.polygons(_TOUCH_RING[greedy.stage_triangles(0)])
    assert _TOUCH_REGION.covers(shapely.union_all(tris))


#: Conservative loops (no RDP) of this image: the one-pixel hole at row 2, column 2 touches
#: the other loops at all four corners, so bridge_holes has no untouched vertex for it; it
#: used to leave it out of the loop, which then covered it (area 23 for a candidate of
#: 22), and now bridges it at a touching point.
_CORNER_HOLE_IMAGE = np.array([[c == "#" for c in row] for row in [
    "..####.", "..#..#.", "##.####", "#.#...#", "#######"]])


def test_stages_avoid_a_hole_left_out_of_the_loop():
    (cand,) = slice_polygons(_CORNER_HOLE_IMAGE, tolerance=None)
    greedy = simplification_chain(cand.ring, loose=False)
    ch = refine_chain(greedy, cand.polygon)
    _check_chain(ch, greedy, cand.polygon)
    assert ch.stages >= 3
    assert ch.areas[0] == pytest.approx(greedy.areas[0]) == pytest.approx(cand.polygon.area)


def test_loop_of_a_corner_touching_hole_keeps_it_out():
    (cand,) = slice_polygons(_CORNER_HOLE_IMAGE, tolerance=None)
    assert Polygon(cand.ring).buffer(0).area == pytest.approx(cand.polygon.area)


# ------------------------------------------------------------------ optimality
def _star(rng, m, radius=(5, 12)):
    ang = np.sort(rng.uniform(0, 2 * np.pi, m))
    rad = rng.uniform(*radius, m)
    return np.round(np.stack([rad * np.cos(ang), rad * np.sin(ang)], axis=1))


def _small_with_hole(seed):
    rng = np.random.default_rng(seed)
    for _ in range(200):
        outer = _star(rng, 6, (8, 14))
        c = rng.integers(-2, 3, 2)
        hole = c + np.round(_star(rng, 3, (1.5, 3)))
        poly = Polygon(outer, [hole])
        if poly.is_valid and len(poly.interiors) == 1 and Polygon(outer).is_valid:
            poly = orient(poly, sign=1.0)
            ring = bridge_holes(poly)
            if len(ring) <= 11:
                return ring, poly
    pytest.skip("no valid random polygon with a hole")


@pytest.mark.parametrize("seed", [0, 1, 2, 4, 5])
def test_matches_brute_force_with_a_hole(seed):
    ring, region = _small_with_hole(seed)
    found = best_inscribed(ring, region, 5)
    np.testing.assert_allclose(_cumulative(found, 5), _brute_force(ring, region, 5), atol=1e-9)
    for area, idx in found.values():
        assert _feasible(ring[idx], region) == pytest.approx(area)


def test_bridge_through_the_best_polygon_is_a_known_gap():
    """The best triangle (1,2,9) of area 86 contains the bridge (-8,4)-(-2,-1): its pocket
    along the loop crosses its own chord, fails the pocket check, and the search keeps
    62.5. Found polygons stay feasible and never claim more than the brute force."""
    ring, region = _small_with_hole(3)
    assert ring[[1, 2, 9]].tolist() == [[7, 5], [1, 12], [-9, -5]]
    found = best_inscribed(ring, region, 5)
    got, best = _cumulative(found, 5), _brute_force(ring, region, 5)
    assert best[1] == 86.0 and got[1] == 62.5 and np.all(got <= best + 1e-9)
    for area, idx in found.values():
        assert _feasible(ring[idx], region) == pytest.approx(area)


@pytest.mark.parametrize("seed", range(4))
def test_matches_brute_force_on_pixel_slices(seed):
    """Small candidates of random pixel images: collinear runs, touching loops."""
    rng = np.random.default_rng(100 + seed)
    done = 0
    for _ in range(60):
        img = ndimage.binary_opening(rng.random((9, 9)) < 0.65)
        for tol in (1.0, None):
            for cand in slice_polygons(img, tolerance=tol):
                if 3 <= len(cand.ring) <= 10:
                    found = best_inscribed(cand.ring, cand.polygon, 5)
                    np.testing.assert_allclose(_cumulative(found, 5),
                                               _brute_force(cand.ring, cand.polygon, 5))
                    done += 1
        if done >= 6:
            break
    assert done >= 3


@pytest.mark.parametrize("ring", [
    [[0, 0], [1, 0], [0, 1]],
    [[0, 0], [2, 0], [2, 2], [0, 2]],
    [[0, 0], [1, 0], [2, 0], [3, 0], [3, 1], [0, 1]],  # collinear run
    [[0, 0], [4, 0], [4, 4], [2, 1], [0, 4]],  # reflex, 5 vertices
    [[0, 0], [4, 0], [2, 2], [4, 4], [0, 4], [2, 2]],  # touches itself at (2, 2)
])
def test_tiny_polygons(ring):
    ring = np.array(ring, float)
    region = Polygon(ring).buffer(0)
    found = best_inscribed(ring, region, 4)
    np.testing.assert_allclose(_cumulative(found, 4), _brute_force(ring, region, 4))
    greedy = simplification_chain(ring)
    _check_chain(refine_chain(greedy, region), greedy, region)


# ------------------------------------------------------------------ containment
def _hostile_images():
    rng = np.random.default_rng(7)
    out = []
    img = np.zeros((24, 24), bool)  # nested: a ring in a ring's hole, holes in holes
    yy, xx = np.mgrid[:24, :24]
    r = np.hypot(yy - 11.5, xx - 11.5)
    img[(r < 11) & (r > 8)] = True
    img[(r < 6) & (r > 3)] = True
    out.append(img)
    img = np.ones((16, 16), bool)  # holes touching each other and the outline at corners
    img[0, 0] = img[1, 1] = img[2, 2] = False
    img[5, 5] = img[6, 6] = img[5, 7] = False
    img[10:12, 10:12] = False
    img[12, 12] = False
    out.append(img)
    img = np.zeros((12, 20), bool)  # two blobs joined by a one-pixel bridge
    img[2:10, 1:8] = True
    img[2:10, 12:19] = True
    img[5, 8:12] = True
    img[4:6, 3:5] = False
    out.append(img)
    img = np.ones((20, 20), bool)  # many one-pixel holes (kept by the conservative loops)
    img[2:18:3, 2:18:3] = False
    out.append(img)
    for _ in range(10):
        img = ndimage.binary_opening(rng.random((20, 20)) < 0.7) | (rng.random((20, 20)) < 0.05)
        out.append(img)
    return out


def test_hostile_pixel_images_stay_inside():
    count = holes = 0
    for img in _hostile_images():
        for tol in (1.0, None):
            for cand in slice_polygons(img, tolerance=tol):
                greedy = simplification_chain(cand.ring, loose=tol is not None)
                ch = refine_chain(greedy, cand.polygon)
                # greedy stages of loops through bridges can leave the candidate
                # (upstream, see the xfails above): refine_chain drops them
                _check_chain(ch, greedy, cand.polygon)
                count += 1
                holes += cand.holes > 0
    assert count >= 20 and holes >= 8


@pytest.fixture(scope="module")
def builtin_candidates():
    meshes = [load_mesh("fat-torus"), load_mesh("box-with-hole"), load_mesh("bunny"),
              trimesh.creation.torus(major_radius=1.0, minor_radius=0.35)]
    out = []
    for mesh in meshes:
        sec = section_solid(mesh, resolution=24)
        for s in best_slices(sec, 3, 2):
            out += slice_polygons(slice_image(sec, s))
    return out


def test_builtin_slices_stay_inside(builtin_candidates):
    assert len(builtin_candidates) >= 10 and any(c.holes for c in builtin_candidates)
    for cand in builtin_candidates:
        greedy = simplification_chain(cand.ring)
        _check_chain(refine_chain(greedy, cand.polygon), greedy, cand.polygon)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["bunny", "fat-torus", "sponge", "hairball", "city-block",
                                  "box-with-hole"])
@pytest.mark.parametrize("conservative", [False, True])
def test_builtin_slices_stay_inside_many(name, conservative):
    sec = section_solid(load_mesh(name), resolution=32, conservative=conservative)
    for s in best_slices(sec, 8, 3):
        for cand in slice_polygons(slice_image(sec, s), tolerance=None if conservative else 1.0):
            greedy = simplification_chain(cand.ring, loose=not conservative)
            _check_chain(refine_chain(greedy, cand.polygon), greedy, cand.polygon)


# ------------------------------------------------------------------ conservative, end to end
@pytest.mark.slow
@pytest.mark.parametrize("name, budget", [("fat-torus", 16), ("fat-torus", 64), ("bunny", 24),
                                          ("cow", 16)])
def test_conservative_no_ray_sees_the_occluder_first(name, budget):
    from viscore.generators.planar_sections import generate_planar_sections
    from viscore.metrics import check_conservative

    mesh = load_mesh(name)
    occ = generate_planar_sections(mesh, budget=budget, voxels=32, conservative=True,
                                   direction_bins=6, depth_bins=2)
    assert occ.info["conservative_guaranteed"] and 0 < occ.triangles <= budget
    for domain in ("orbit", "volume"):
        rep = check_conservative(mesh, occ.mesh, rays=100_000, domain=domain, seed=3)
        assert rep.violations == 0, rep.summary()
