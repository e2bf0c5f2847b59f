"""solid-frusta on walls thinner than the extent-based voxel: the 'auto' voxel size."""

import logging

import numpy as np
import pytest
import trimesh
from scipy import ndimage
from test_aabb_skins_thin_walls import RAYS, thin_room

import viscore._validate as validate_module
from viscore import InputError
from viscore.generators import generate_solid_frusta
from viscore.generators.solid_frusta.generator import _inner_depth
from viscore.metrics import check_conservative
from viscore.voxel.wall_thickness import voxel_size_for_wall

LOGGER = "viscore.generators.solid_frusta.generator"
BOX_LOGGER = "viscore.generators.aabb_skins.generator"


def test_generate_solid_frusta_thin_walls_get_solids_and_keep_the_guarantee():
    room = thin_room()
    occ = generate_solid_frusta(room, voxel_sizing="auto")
    assert occ.info["voxel_sizing"] == "auto"
    assert occ.info["pitch"] < voxel_size_for_wall(0.05)
    assert occ.info["conservative_guaranteed"] and occ.triangles > 0
    report = check_conservative(room, occ.mesh, rays=RAYS, domain="volume", seed=12)
    assert report.violations == 0, report.summary()


def test_generate_solid_frusta_default_sizing_is_auto():
    occ = generate_solid_frusta(thin_room())
    assert occ.info["voxel_sizing"] == "auto" and occ.triangles > 0
    assert occ.info["pitch"] < voxel_size_for_wall(0.05)


def test_generate_solid_frusta_extent_sizing_gives_thin_walls_nothing():
    room = thin_room()
    for occ in (generate_solid_frusta(room, voxel_sizing="extent"),
                generate_solid_frusta(room, voxels=64)):
        assert occ.info["pitch"] == pytest.approx(4.0 / 64) and occ.triangles == 0


def test_generate_solid_frusta_grid_that_does_not_fit_falls_back_with_one_line(monkeypatch,
                                                                               caplog):
    room = thin_room()
    # twice aabb-skins' 40 bytes a cell: 375,000 cells fit, the extent-based grid
    # (176,000) does, the walls' (3.1M) does not
    monkeypatch.setattr(validate_module, "available_memory", lambda: 4 * 10**7)
    # both loggers' own levels: an earlier --quiet command in this worker may have left the
    # toolkit's loggers at ERROR
    with caplog.at_level(logging.DEBUG, logger=LOGGER), \
            caplog.at_level(logging.DEBUG, logger=BOX_LOGGER):
        occ = generate_solid_frusta(room, voxel_sizing="auto")
    lines = [r for r in caplog.records if r.name in (LOGGER, BOX_LOGGER)
             and r.levelno >= logging.WARNING]
    assert len(lines) == 1 and lines[0].name == LOGGER, [r.getMessage() for r in lines]
    assert "memory guard" in lines[0].getMessage()
    assert occ.info["wall_sizing"]["limited"]
    assert voxel_size_for_wall(0.05) < occ.info["pitch"] < 4.0 / 64


def test_inner_depth_equals_the_distance_transform():
    rng = np.random.default_rng(4)
    for _ in range(10):
        inner = np.zeros((24, 20, 18), bool)
        inner[2:-2, 2:-2, 2:-2] = ndimage.binary_opening(rng.random((20, 16, 14)) < 0.7)
        expected = ndimage.distance_transform_edt(inner)[inner]
        assert np.array_equal(_inner_depth(inner, np.argwhere(inner)), expected)


def test_generate_solid_frusta_voxel_sizing_invalid_input():
    with pytest.raises(InputError, match="voxel_sizing"):
        generate_solid_frusta(trimesh.creation.box(), voxel_sizing="walls")


def test_generate_solid_frusta_auto_open_room_same_solids_as_per_voxel(monkeypatch):
    from test_aabb_skins_thin_walls import _per_voxel_winding, open_room

    import viscore.generators.aabb_skins.generator as box_module
    import viscore.generators.solid_frusta.generator as module

    room = open_room()
    fast = generate_solid_frusta(room, voxel_sizing="auto")
    _per_voxel_winding(monkeypatch, module)
    _per_voxel_winding(monkeypatch, box_module)
    slow = generate_solid_frusta(room, voxel_sizing="auto")
    assert fast.info["kinds"] == slow.info["kinds"] and len(fast.info["kinds"]) > 0
    assert fast.info["volume_share"] == slow.info["volume_share"]
    np.testing.assert_array_equal(fast.mesh.vertices, slow.mesh.vertices)
    np.testing.assert_array_equal(fast.mesh.faces, slow.mesh.faces)
