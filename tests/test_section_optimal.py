"""Largest inscribed stages of the planar-sections chains (generators/_polygon_chain/optimal.py)."""

from itertools import combinations

import numpy as np
import pytest
import shapely
from shapely.geometry import Point, Polygon

from viscore import InputError
from viscore.generators._polygon_chain.optimal import best_inscribed, refine_chain
from viscore.generators._polygon_chain.simplify import simplification_chain
from viscore.generators.planar_sections._loops import slice_polygons


def _annulus(outer=15, inner=6, size=40):
    yy, xx = np.mgrid[:size, :size]
    r = np.hypot(yy - size / 2, xx - size / 2)
    return (r < outer) & (r > inner)


def _blob(seed, size=32):
    """A star-shaped random pixel blob (simple polygon candidates)."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[:size, :size]
    ang = np.arctan2(yy - size / 2, xx - size / 2)
    radius = 9 + 3 * np.sin(3 * ang + rng.uniform(0, 6)) + 2 * np.cos(5 * ang + rng.uniform(0, 6))
    return np.hypot(yy - size / 2, xx - size / 2) < radius


def _area(loop):
    return 0.5 * float(np.sum(loop[:, 0] * np.roll(loop[:, 1], -1)
                              - np.roll(loop[:, 0], -1) * loop[:, 1]))


def _brute_force(ring, region, k):
    """Largest area over every vertex subset of k + 2 vertices (in loop order) whose
    polygon is simple and inside the region."""
    best = 0.0
    for idx in combinations(range(len(ring)), k + 2):
        poly = Polygon(ring[list(idx)])
        if poly.is_valid and poly.area > best and region.covers(poly):
            best = poly.area
    return best


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_best_inscribed_matches_brute_force_on_small_polygons(seed):
    rng = np.random.default_rng(seed)
    # a star-shaped polygon of 9 integer vertices: non-convex, simple
    ang = np.sort(rng.uniform(0, 2 * np.pi, 9))
    rad = rng.uniform(5, 12, 9)
    ring = np.round(np.stack([rad * np.cos(ang), rad * np.sin(ang)], axis=1))
    ring = ring[np.r_[True, np.any(np.diff(ring, axis=0) != 0, axis=1)]]
    poly = Polygon(ring)
    assume = poly.is_valid and _area(ring) > 0
    if not assume:
        pytest.skip("degenerate random polygon")
    found = best_inscribed(ring, poly, 4)
    for k in range(1, 5):
        expected = _brute_force(ring, poly, k)
        got = found.get(k, (0.0, None))[0]
        # the search is exact over subsets of exactly k + 2 vertices; a subset that is
        # not strictly simple is refused by both
        assert got == pytest.approx(expected, abs=1e-9), k


@pytest.mark.parametrize("seed", [0, 3, 7])
def test_refined_chain_stays_inside_and_beats_greedy(seed):
    cand = slice_polygons(_blob(seed))[0]
    greedy = simplification_chain(cand.ring)
    ch = refine_chain(greedy, cand.polygon)
    assert ch.counts[0] == greedy.counts[0] and ch.areas[0] == pytest.approx(greedy.areas[0])
    assert np.all(np.diff(ch.counts) < 0) and np.all(np.diff(ch.areas) < 0)
    for s in range(ch.stages):
        loop = ch.stage_ring(s)
        tri = ch.stage_triangles(s)
        assert len(tri) == ch.counts[s]
        assert cand.polygon.buffer(1e-9).covers(Polygon(loop))
        # the triangles tile the stage: their areas add up to its area, none overlap
        tris = [Polygon(ch.ring[t]) for t in tri]
        assert sum(t.area for t in tris) == pytest.approx(ch.areas[s])
        assert shapely.union_all(tris).area == pytest.approx(ch.areas[s])
    # at every triangle count the refined chain keeps at least the greedy one's area
    for count, area in zip(greedy.counts, greedy.areas, strict=True):
        best = ch.areas[ch.counts <= count].max()
        assert best >= area - 1e-9
    # and strictly more somewhere at the low end (greedy collapse is myopic)
    low = [(c, a) for c, a in zip(greedy.counts, greedy.areas, strict=True) if c <= 6]
    assert any(ch.areas[ch.counts <= c].max() > a + 1e-9 for c, a in low)


def test_refined_chain_never_covers_a_hole():
    cand = slice_polygons(_annulus())[0]
    assert cand.holes == 1
    greedy = simplification_chain(cand.ring)
    ch = refine_chain(greedy, cand.polygon)
    centre = Point(20, 20)
    for s in range(ch.stages):
        stage = Polygon(ch.stage_ring(s)).buffer(0)
        assert not stage.contains(centre)
        assert stage.area == pytest.approx(ch.areas[s])
        assert cand.polygon.buffer(1e-9).covers(stage)
        tris = [Polygon(ch.ring[t]) for t in ch.stage_triangles(s)]
        assert not any(t.contains(centre) for t in tris)
    # a convex hole cannot be cut by a chord: below the full polygon the stages open
    # the ring (a C shape), and they keep more than the greedy ones at each count
    for count, area in zip(greedy.counts, greedy.areas, strict=True):
        assert ch.areas[ch.counts <= count].max() >= area - 1e-9


def test_planar_sections_chain_option():
    import trimesh

    from viscore.generators.planar_sections import generate_planar_sections

    box = trimesh.creation.box(extents=(2, 1, 1))
    with pytest.raises(InputError, match="chain"):
        generate_planar_sections(box, chain="best")
    a = generate_planar_sections(box, budget=4, voxels=12, chain="greedy")
    b = generate_planar_sections(box, budget=4, voxels=12)
    assert a.params["chain"] == "greedy" and b.params["chain"] == "optimal"
    assert 0 < b.triangles <= 4 and 0 < a.triangles <= 4
