"""AABB skins on walls thinner than the extent-based voxel: the 'auto' voxel size."""

import logging

import numpy as np
import pytest
import trimesh

import viscore._validate as validate_module
from viscore import InputError, load_mesh
from viscore.generators import generate_aabb_skins, get_generator
from viscore.metrics import check_conservative
from viscore.voxel.wall_thickness import finest_fitting_pitch, voxel_size_for_wall
from viscore.voxel.winding import is_closed_oriented

LOGGER = "viscore.generators.aabb_skins.generator"

#: Volume-domain rays of each guarantee check (issue 24: at least 10^5).
RAYS = 100_000


def _panel(lo, hi) -> trimesh.Trimesh:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    box = trimesh.creation.box(extents=hi - lo)
    box.apply_translation(0.5 * (lo + hi))
    return box


def thin_room(size=(4.0, 2.0, 4.0), wall=0.05, door=(0.8, 1.4)) -> trimesh.Trimesh:
    """A game-style room of closed wall panels ``wall`` thick (0.0125 of its 4 m extent,
    under one voxel of the extent-based 4 / 64), overlapping at the corners, a door
    through the -Z wall: closed and consistently oriented, the room itself outside."""
    x, y, z = size
    w = wall
    dw, dh = door
    panels = [
        _panel((0, 0, 0), (x, w, z)),              # floor
        _panel((0, y - w, 0), (x, y, z)),          # ceiling
        _panel((0, 0, 0), (w, y, z)),              # -X wall
        _panel((x - w, 0, 0), (x, y, z)),          # +X wall
        _panel((0, 0, z - w), (x, y, z)),          # +Z wall
        # -Z wall with a door in its middle: left, right, lintel
        _panel((0, 0, 0), (0.5 * (x - dw), y, w)),
        _panel((0.5 * (x + dw), 0, 0), (x, y, w)),
        _panel((0.5 * (x - dw), dh, 0), (0.5 * (x + dw), y, w)),
    ]
    room = trimesh.util.concatenate(panels)
    room.metadata["name"] = "thin-room"
    return room


def test_thin_room_is_closed_and_thinner_than_the_extent_voxel():
    room = thin_room()
    assert is_closed_oriented(room.vertices, room.faces)
    assert 0.05 < 4.0 / 64  # a wall is thinner than one extent-based voxel


def test_generate_aabb_skins_thin_walls_get_boxes_and_keep_the_guarantee():
    room = thin_room()
    occ = generate_aabb_skins(room, voxel_sizing="auto")
    assert occ.info["voxel_sizing"] == "auto"
    assert occ.info["pitch"] < voxel_size_for_wall(0.05)  # under 0.025
    assert occ.info["conservative_guaranteed"]
    assert occ.triangles > 0 and occ.info["inner_voxels"] > 0
    sizing = occ.info["wall_sizing"]
    assert sizing["wall_quantile"] == pytest.approx(0.05, abs=1e-5)
    assert not sizing["limited"] and sizing["resolved_share"] > 0.8
    report = check_conservative(room, occ.mesh, rays=RAYS, domain="volume", seed=11)
    assert report.violations == 0, report.summary()


def test_generate_aabb_skins_default_sizing_is_auto():
    room = thin_room()
    occ = generate_aabb_skins(room)
    assert occ.info["voxel_sizing"] == "auto" and occ.triangles > 0
    assert occ.info["pitch"] < voxel_size_for_wall(0.05)
    option = {o.name: o for o in get_generator("aabb-skins").options}["voxel_sizing"]
    assert option.default == "auto"


def test_generate_aabb_skins_extent_sizing_gives_thin_walls_nothing():
    room = thin_room()
    for occ in (generate_aabb_skins(room, voxel_sizing="extent"),
                generate_aabb_skins(room, voxels=64)):
        assert occ.info["pitch"] == pytest.approx(4.0 / 64)
        assert occ.triangles == 0 and occ.info["inner_voxels"] == 0
    assert generate_aabb_skins(room, voxel_sizing="extent").info["voxel_sizing"] == "extent"
    assert generate_aabb_skins(room, voxels=64).info["voxel_sizing"] == "voxels"


def test_generate_aabb_skins_auto_keeps_thick_solids_as_before():
    torus = load_mesh("fat-torus")
    auto = generate_aabb_skins(torus, voxel_sizing="auto")
    extent = generate_aabb_skins(torus, voxel_sizing="extent")
    assert auto.info["pitch"] == extent.info["pitch"]
    assert np.array_equal(auto.parts["boxes"], extent.parts["boxes"])


def test_generate_aabb_skins_grid_that_does_not_fit_falls_back_with_one_line(monkeypatch,
                                                                              caplog):
    room = thin_room()
    # 750,000 cells of 40 bytes: the extent-based grid (69 x 37 x 69) fits, the one the
    # walls ask for (183 x 94 x 183) does not
    monkeypatch.setattr(validate_module, "available_memory", lambda: 4 * 10**7)
    with caplog.at_level(logging.DEBUG, logger=LOGGER):
        occ = generate_aabb_skins(room, voxel_sizing="auto")
    lines = [r for r in caplog.records if r.name == LOGGER and r.levelno >= logging.WARNING]
    assert len(lines) == 1, [r.getMessage() for r in lines]
    message = lines[0].getMessage()
    assert "thin-room" in message and "memory guard" in message and "too thin" in message
    assert occ.info["wall_sizing"]["limited"]
    fitting = finest_fitting_pitch(room.bounds, bytes_per_cell=40, coarsest=4.0 / 64)
    assert occ.info["pitch"] == pytest.approx(fitting)
    assert voxel_size_for_wall(0.05) < occ.info["pitch"] < 4.0 / 64
    # the refusal of a size the user gives is kept
    with pytest.raises(InputError, match="memory"):
        generate_aabb_skins(room, voxel_size=0.0225)


def test_generate_aabb_skins_voxel_sizing_invalid_input():
    with pytest.raises(InputError, match="voxel_sizing"):
        generate_aabb_skins(trimesh.creation.box(), voxel_sizing="walls")


def open_room(wall=0.1) -> trimesh.Trimesh:
    """``thin_room`` without its floor panel and with its -Z panels' bottom faces gone:
    open at the bottom, as the built-in buildings are (not closed, so every inner voxel
    comes from the winding number of an open mesh)."""
    room = thin_room(wall=wall)
    keep = ~((room.face_normals[:, 1] < -0.5) & (room.triangles_center[:, 1] < 1e-9))
    return trimesh.Trimesh(room.vertices, room.faces[keep], process=False,
                           metadata={"name": "open-room"})


def _per_voxel_winding(monkeypatch, module):
    """Make ``module``'s inside test evaluate every voxel (the reference of the bounds)."""
    from functools import partial

    from viscore.voxel.grid import inside_voxels_winding

    monkeypatch.setattr(module, "inside_voxels_winding",
                        partial(inside_voxels_winding, per_voxel=True))


def test_generate_aabb_skins_auto_open_room_same_boxes_as_per_voxel(monkeypatch):
    import viscore.generators.aabb_skins.generator as module

    room = open_room()
    assert not is_closed_oriented(room.vertices, room.faces)
    fast = generate_aabb_skins(room, voxel_sizing="auto", seed_voxel="densest")
    _per_voxel_winding(monkeypatch, module)
    slow = generate_aabb_skins(room, voxel_sizing="auto", seed_voxel="densest")
    assert fast.info["inner_voxels"] == slow.info["inner_voxels"] > 1000
    assert fast.info["cavity_voxels"] == slow.info["cavity_voxels"]
    np.testing.assert_array_equal(fast.parts["boxes"], slow.parts["boxes"])
    np.testing.assert_array_equal(fast.mesh.faces, slow.mesh.faces)
