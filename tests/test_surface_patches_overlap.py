"""Tests of surface-patches' overlap-aware selection (values scaled by their share of the soup)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.generators.surface_patches import generate_surface_patches
from viscore.generators.surface_patches._overlap import select_with_overlap
from viscore.generators.surface_patches.generator import _select


def _square_maps(n_dirs=3, size=16):
    """Bitmaps of three candidates: 0 and 1 identical (a 8 x 8 square), 2 a disjoint 6 x 6."""
    maps = np.zeros((3, n_dirs, size, size), dtype=bool)
    maps[0, :, 1:9, 1:9] = True
    maps[1] = maps[0]
    maps[2, :, 9:15, 9:15] = True
    return maps


def test_select_with_overlap_skips_a_copy_of_a_chosen_candidate():
    values = [np.array([64.0]), np.array([64.0]), np.array([36.0])]
    counts = [np.array([2]), np.array([2]), np.array([2])]
    # taken one by one, the two copies win; with overlap the copy adds nothing
    assert (_select(values, counts, 4) >= 0).tolist() == [True, True, False]
    assert (select_with_overlap(values, counts, _square_maps(), 4) >= 0).tolist() == [
        True, False, True]


def test_select_with_overlap_spends_the_rest_of_the_budget_on_hidden_candidates():
    values = [np.array([64.0]), np.array([64.0]), np.array([36.0])]
    counts = [np.array([2]), np.array([2]), np.array([2])]
    stages = select_with_overlap(values, counts, _square_maps(), 6)
    assert stages.tolist() == [0, 0, 0]


def test_select_with_overlap_takes_stages_within_the_budget():
    # candidate 0: stages of 4, 2 and 1 triangles; 1 a copy of it, 2 disjoint, 2 each.
    # Per added triangle: 0's one-triangle stage (30), its step to two (20), then 2 (18);
    # the copy adds nothing, and the last triangle of room holds neither 0's full stage
    # nor the copy (the separate values would take the copy, 20 per triangle, before 2)
    values = [np.array([64.0, 50.0, 30.0]), np.array([40.0]), np.array([36.0])]
    counts = [np.array([4, 2, 1]), np.array([2]), np.array([2])]
    assert _select(values, counts, 5).tolist() == [1, 0, -1]
    assert select_with_overlap(values, counts, _square_maps(), 5).tolist() == [1, -1, 0]


def _square(z, x0=0.0, side=2.0):
    v = np.array([[x0, 0, z], [x0 + side, 0, z], [x0 + side, side, z], [x0, side, z]],
                 dtype=np.float64)
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


def test_surface_patches_keeps_one_face_of_a_thick_wall_and_the_other_panel():
    # the two faces of a 2 x 2 wall 0.05 thick, open (no box), and a 1.8 x 1.8 panel
    # elsewhere; room for two squares: separate values keep both wall faces
    mesh = trimesh.util.concatenate([_square(0.0), _square(0.05), _square(3.0, 5.0, 1.8)])
    zs = {}
    for selection in ("separate", "overlap"):
        occ = generate_surface_patches(mesh, budget=4, selection=selection, chain="greedy")
        assert occ.triangles == 4
        zs[selection] = sorted({round(float(p[0, 2]), 3) for p in occ.parts["polygons"]})
    assert zs["separate"] == [0.0, 0.05]
    assert zs["overlap"] in ([0.0, 3.0], [0.05, 3.0])


def test_surface_patches_selection_option_is_checked():
    with pytest.raises(InputError, match="selection"):
        generate_surface_patches(_square(0.0), selection="best")
