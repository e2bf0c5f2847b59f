"""planar-sections --conservative on walls thinner than the extent-based voxel."""

import pytest
from test_aabb_skins_thin_walls import RAYS, thin_room

from viscore.generators import generate_planar_sections
from viscore.metrics import check_conservative
from viscore.voxel.wall_thickness import voxel_size_for_wall


def test_conservative_sizes_its_voxels_for_walls_that_survive_the_erosion():
    room = thin_room(wall=0.1)  # 0.1 thick: 1.6 extent-based voxels (4 / 64)
    occ = generate_planar_sections(room, conservative=True)
    # the solid is eroded once: walls must hold 3 x 3 x 3 inside voxels, t / 4 along the axes
    assert occ.info["voxel_size"] < voxel_size_for_wall(0.1, block=3)
    assert occ.info["wall_sizing"]["resolved_share"] > 0.8
    assert occ.info["conservative_guaranteed"] and occ.triangles > 0
    report = check_conservative(room, occ.mesh, rays=RAYS, domain="volume", seed=13)
    assert report.violations == 0, report.summary()


def test_conservative_with_voxels_given_keeps_the_extent_grid():
    occ = generate_planar_sections(thin_room(wall=0.1), conservative=True, voxels=64)
    assert occ.info["voxel_size"] == pytest.approx(4.0 / 64)
    assert occ.triangles == 0 and "wall_sizing" not in occ.info


def test_non_conservative_default_is_unchanged():
    occ = generate_planar_sections(thin_room(wall=0.1), budget=12, min_precision=0)
    assert occ.info["voxel_size"] == pytest.approx(4.0 / 64) and "wall_sizing" not in occ.info
