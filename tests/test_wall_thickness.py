"""Wall thickness by inward rays; the wall-to-voxel factor; voxel sizes within the memory guard."""

import logging

import numpy as np
import pytest
import trimesh
from scipy import ndimage

import viscore._validate as validate_module
from viscore import InputError, voxelize
from viscore.voxel.grid import inside_voxels_winding
from viscore.voxel.wall_thickness import (
    AUTO_MAX_CELLS,
    FIT_SHARE,
    PITCH_MARGIN,
    finest_fitting_pitch,
    voxel_size_for_wall,
    wall_thickness,
    wall_voxel_size,
)


def _shell(outer, inner) -> trimesh.Trimesh:
    """Closed box shell: an outward box around an inverted (cavity-facing) one."""
    cavity = trimesh.creation.box(extents=inner)
    cavity.invert()
    return trimesh.util.concatenate([trimesh.creation.box(extents=outer), cavity])


def _rotation(normal) -> np.ndarray:
    """4 x 4 rotation taking +X to the unit vector along ``normal``."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    return trimesh.geometry.align_vectors([1.0, 0.0, 0.0], n)


# ------------------------------------------------------------------ wall_thickness
def test_wall_thickness_box_shell_gives_its_wall():
    # walls 0.1 thick everywhere; from the outer faces' rims (|y| or |z| > 0.9 on a +-X
    # face: 19% of the outer area, 10.5% of all) the ray runs along a wall: 2 across
    wt = wall_thickness(_shell((2, 2, 2), (1.8, 1.8, 1.8)), samples=4000, seed=3)
    assert wt.wall_share == 1.0
    assert wt.quantile(0.0) == pytest.approx(0.1, abs=1e-6)
    assert wt.quantile(0.5) == pytest.approx(0.1, abs=1e-6)
    assert wt.quantile(0.8) == pytest.approx(0.1, abs=1e-6)
    # the rim samples: those whose thickness is the box's side
    rim = np.mean(np.abs(wt.thickness - 2.0) < 1e-5)
    assert rim == pytest.approx(0.19 * 24 / (24 + 6 * 3.24), abs=0.015)


def test_wall_thickness_uneven_shell_gives_each_wall_by_area():
    # walls 0.05 (+-X), 0.2 (+-Y), 0.4 (+-Z): the lowest quantile is the thinnest
    wt = wall_thickness(_shell((2, 2, 2), (1.9, 1.6, 1.2)), samples=8000)
    assert wt.quantile(0.0) == pytest.approx(0.05, abs=1e-6)
    t = wt.thickness
    for wall in (0.05, 0.2, 0.4):
        assert np.mean(np.abs(t - wall) < 1e-5) > 0.05


def test_wall_thickness_oblique_shell():
    shell = _shell((2, 2, 2), (1.8, 1.8, 1.8))
    shell.apply_transform(_rotation((2, 1, 1)))
    assert wall_thickness(shell, samples=2000).quantile(0.5) == pytest.approx(0.1, abs=1e-6)


def test_wall_thickness_inside_out_mesh_flips_its_normals():
    box = trimesh.creation.box(extents=(1, 2, 4))
    box.invert()
    wt = wall_thickness(box, samples=1000)
    assert wt.wall_share == 1.0
    assert (wt.quantile(0.0), wt.quantile(1.0)) == pytest.approx((1.0, 4.0), abs=1e-6)


def test_wall_thickness_walks_through_overlapping_panels():
    # two closed panels overlapping by 0.1 along X: from x = -1 the wall ends at x = 0.9
    a = trimesh.creation.box(extents=(1.0, 1, 1))
    a.apply_translation([-0.5, 0, 0])
    b = trimesh.creation.box(extents=(1.0, 1, 1))
    b.apply_translation([0.4, 0, 0])
    both = trimesh.util.concatenate([a, b])
    wt = wall_thickness(both, samples=4000)
    on_left = np.abs(wt.points[:, 0] + 1.0) < 1e-9
    assert on_left.any()
    assert np.allclose(wt.thickness[on_left], 1.9, atol=1e-5)


def test_wall_thickness_open_geometry_is_no_wall():
    # a single-sided sheet, and a box whose faces all face inwards only from outside
    sheet = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    wt = wall_thickness(sheet, samples=100)
    assert wt.wall_share == 0.0 and np.isinf(wt.thickness).all()
    assert wt.quantile(0.1) == np.inf
    # an open box (top removed) whose normals point out: rays from the floor go down
    # and escape; rays from the side walls cross the room to the opposite wall's back
    box = trimesh.creation.box(extents=(1, 1, 1))
    open_box = trimesh.Trimesh(box.vertices, box.faces[box.face_normals[:, 2] < 0.5],
                               process=False)
    wt = wall_thickness(open_box, samples=2000)
    floor = np.abs(wt.points[:, 2] + 0.5) < 1e-9
    assert np.isinf(wt.thickness[floor]).all()


def test_wall_thickness_is_seeded():
    shell = _shell((2, 2, 2), (1.8, 1.8, 1.8))
    a, b = wall_thickness(shell, samples=500, seed=7), wall_thickness(shell, samples=500, seed=7)
    assert np.array_equal(a.thickness, b.thickness) and a.seed == 7
    assert not np.array_equal(a.points, wall_thickness(shell, samples=500, seed=8).points)


def test_wall_thickness_invalid_input():
    with pytest.raises(InputError):
        wall_thickness(trimesh.Trimesh())
    with pytest.raises(InputError):
        wall_thickness(trimesh.creation.box(), samples=0)
    with pytest.raises(InputError):
        wall_thickness(trimesh.creation.box(), seed=-1)
    flat = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]], process=False)
    with pytest.raises(InputError):
        wall_thickness(flat)
    with pytest.raises(InputError):
        wall_thickness(trimesh.creation.box()).quantile(1.5)


# ------------------------------------------------------------------ the factor
def _slab_inner_voxels(t: float, pitch: float, normal, offset: float, erode: int = 0) -> int:
    """Inner voxels (closed cube touching no triangle, inside by the winding number) of a
    wide closed slab of thickness ``t`` along ``normal``, shifted by ``offset`` along it;
    those left after ``erode`` erosions by the 3 x 3 x 3 cube."""
    slab = trimesh.creation.box(extents=(t, 24 * pitch, 24 * pitch))
    slab.apply_translation([offset, 0, 0])
    slab.apply_transform(_rotation(normal))
    vox = voxelize(slab, pitch=pitch)
    inner = inside_voxels_winding(slab.vertices, slab.faces, vox.grid, vox.surface)
    if erode:
        inner = ndimage.binary_erosion(inner, structure=np.ones((3, 3, 3), bool),
                                       iterations=erode)
    return int(inner.sum())


@pytest.mark.parametrize("normal", [(1, 0, 0), (1, 1, 0), (1, 1, 1), (2, 1, 1), (3, 1, 0.5)])
def test_voxel_size_for_wall_gives_inner_voxels_wherever_the_grid_falls(normal):
    t = 1.0
    pitch = 0.97 * voxel_size_for_wall(t, normal)
    for offset in np.linspace(0.0, 1.0, 7) * pitch:
        assert _slab_inner_voxels(t, pitch, normal, offset) > 0, offset


@pytest.mark.parametrize("normal", [(1, 0, 0), (1, 1, 0), (1, 1, 1), (2, 1, 1), (3, 1, 0.5)])
def test_voxel_size_for_wall_block_survives_one_erosion_wherever_the_grid_falls(normal):
    t = 1.0
    pitch = 0.97 * voxel_size_for_wall(t, normal, block=3)
    for offset in np.linspace(0.0, 1.0, 5) * pitch:
        assert _slab_inner_voxels(t, pitch, normal, offset, erode=1) > 0, offset
    # the one-voxel bound is not enough for the erosion: along the axes, all are gone
    coarse = 0.97 * voxel_size_for_wall(t, normal)
    if normal == (1, 0, 0):
        assert _slab_inner_voxels(t, coarse, normal, 0.0, erode=1) == 0


def test_voxel_size_for_wall_bound_is_tight_along_the_axes():
    p = 0.1

    def inner(t: float, x0: float) -> int:
        """Inner voxels of a slab [x0 - t/2, x0 + t/2] on a grid whose voxel boundaries
        lie at odd multiples of p / 2 (two pins fix the bounding box to [-5p, 5p] in X:
        15 voxels, centred, so boundaries at (k - 7.5) p)."""
        slab = trimesh.creation.box(extents=(t, 24 * p, 24 * p))
        slab.apply_translation([x0, 0, 0])
        pins = [trimesh.creation.box(extents=(0.2 * p,) * 3) for _ in range(2)]
        pins[0].apply_translation([-4.9 * p, 20 * p, 0])
        pins[1].apply_translation([4.9 * p, 20 * p, 0])
        mesh = trimesh.util.concatenate([slab, *pins])
        vox = voxelize(mesh, pitch=p)
        return int(inside_voxels_winding(mesh.vertices, mesh.faces, vox.grid, vox.surface).sum())

    assert inner(2.0 * p, 0.5 * p) == 0  # t = 2p, both faces on voxel boundaries: none
    assert inner(2.06 * p, 0.5 * p) > 0  # a little thicker: one layer
    assert voxel_size_for_wall(2 * p) == pytest.approx(p)


def test_voxel_size_for_wall_values():
    assert voxel_size_for_wall(0.05) == pytest.approx(0.025)
    assert voxel_size_for_wall(0.05, block=3) == pytest.approx(0.0125)  # t / 4
    assert voxel_size_for_wall(1.0, (1, 1, 1)) == pytest.approx(1 / (np.sqrt(3) + 1 / np.sqrt(3)))
    assert voxel_size_for_wall(1.0, (2, 1, 1)) == pytest.approx(1 / np.sqrt(6))


def test_voxel_size_for_wall_invalid_input():
    with pytest.raises(InputError):
        voxel_size_for_wall(0.0)
    with pytest.raises(InputError):
        voxel_size_for_wall(1.0, (0, 0, 0))


# ------------------------------------------------------------------ sizes within the guard
def test_finest_fitting_pitch_meets_the_memory_limit(monkeypatch):
    monkeypatch.setattr(validate_module, "available_memory", lambda: 4 * 10**6)
    bounds = np.array([[0, 0, 0], [10.0, 5.0, 10.0]])
    p = finest_fitting_pitch(bounds, bytes_per_cell=40)
    limit = FIT_SHARE * 0.75 * 4 * 10**6 / 40  # 71,250 cells
    counts = np.ceil(np.array([10, 5, 10]) / p - 1e-9) + 5
    assert np.prod(counts) <= limit
    counts_finer = np.ceil(np.array([10, 5, 10]) / (0.99 * p) - 1e-9) + 5
    assert np.prod(counts_finer) > limit


def test_finest_fitting_pitch_invalid_input():
    with pytest.raises(InputError):
        finest_fitting_pitch([[0, 0, 0], [0, 0, 0]], bytes_per_cell=40)
    with pytest.raises(InputError):
        finest_fitting_pitch([[0, 0, 0], [1, 1, 1]], bytes_per_cell=0)


def test_wall_voxel_size_from_walls_and_extent():
    shell = _shell((2, 2, 2), (1.8, 1.8, 1.8))  # walls 0.1: 0.9 x 0.1 / 2
    size = wall_voxel_size(shell, bytes_per_cell=40, resolution=8, samples=2000)
    assert size.pitch == pytest.approx(PITCH_MARGIN * 0.05, rel=1e-5)
    assert size.extent_pitch == 0.25 and not size.limited
    assert size.resolved_share > 0.8
    thick = wall_voxel_size(trimesh.creation.box(extents=(2, 2, 2)), bytes_per_cell=40)
    assert thick.pitch == thick.extent_pitch == 2 / 64  # thick walls: the extent decides


def test_wall_voxel_size_falls_back_to_the_finest_grid_that_fits(monkeypatch):
    # 750,000 cells of 40 bytes: the extent-based grid fits (69 x 37 x 69), the walls'
    # (444 x 222 x 444) does not
    monkeypatch.setattr(validate_module, "available_memory", lambda: 4 * 10**7)
    shell = _shell((10, 5, 10), (9.9, 4.9, 9.9))  # walls 0.05: 0.0225 wanted
    size = wall_voxel_size(shell, bytes_per_cell=40, samples=2000, what="test")
    assert size.limited and size.pitch > size.wall_pitch
    assert size.pitch == pytest.approx(finest_fitting_pitch(shell.bounds, bytes_per_cell=40))
    assert "memory guard" in size.reason and "too thin" in size.reason
    assert size.log_level == logging.WARNING


def _cells(bounds, pitch: float) -> int:
    from viscore import voxel_grid

    return int(np.prod(voxel_grid(np.asarray(bounds), pitch=pitch).shape))


def test_wall_voxel_size_cell_cap_bounds_the_grid():
    # walls 0.05 of a 10 x 5 x 10 shell ask for 0.0225 voxels: 449 x 227 x 449 = 45.8M
    # cells, past the default cap of 16M; one byte per cell, so memory never decides
    shell = _shell((10, 5, 10), (9.9, 4.9, 9.9))
    shell.metadata["name"] = "big-shell"
    free = wall_voxel_size(shell, bytes_per_cell=1, samples=2000, max_cells=None)
    assert free.pitch == pytest.approx(PITCH_MARGIN * 0.025, rel=1e-5)
    assert not free.limited and not free.capped
    assert _cells(shell.bounds, free.pitch) > AUTO_MAX_CELLS
    capped = wall_voxel_size(shell, bytes_per_cell=1, samples=2000, what="test")
    assert capped.limited and capped.capped and capped.info["capped"]
    assert free.pitch < capped.pitch < shell.extents.max() / 64
    assert _cells(shell.bounds, capped.pitch) <= AUTO_MAX_CELLS
    assert _cells(shell.bounds, 0.99 * capped.pitch) > AUTO_MAX_CELLS  # the finest under it
    assert "cap of 16,000,000 cells" in capped.reason and "big-shell" in capped.reason
    # the hint names the method's own option, never a flag of one command (cull and
    # occlude have no --voxel-size; generate has no METHOD:option=value)
    assert "goes finer" not in capped.reason
    named = wall_voxel_size(shell, bytes_per_cell=1, samples=2000, what="aabb-skins",
                            finer="voxel-size")
    assert "the aabb-skins option voxel-size goes finer" in named.reason
    assert "--" not in named.reason and ":voxel-size=" not in named.reason
    assert capped.log_level == logging.WARNING
    small = wall_voxel_size(shell, bytes_per_cell=1, samples=2000, max_cells=10**6)
    assert _cells(shell.bounds, small.pitch) <= 10**6 < _cells(shell.bounds, capped.pitch)
    assert small.capped
    # never coarser than the extent-based grid (69 x 37 x 69 cells), whatever the cap
    tiny = wall_voxel_size(shell, bytes_per_cell=1, samples=2000, max_cells=10**5)
    assert tiny.pitch == tiny.extent_pitch
    # a cap the extent-based grid already meets changes nothing
    thick = trimesh.creation.box(extents=(2, 2, 2))
    assert wall_voxel_size(thick, bytes_per_cell=1, max_cells=10**6).pitch == 2 / 64


def test_wall_voxel_size_memory_guard_is_not_called_the_cap(monkeypatch):
    monkeypatch.setattr(validate_module, "available_memory", lambda: 4 * 10**7)
    shell = _shell((10, 5, 10), (9.9, 4.9, 9.9))
    size = wall_voxel_size(shell, bytes_per_cell=40, samples=2000)  # 750,000 cells fit
    assert size.limited and not size.capped and "cap" not in size.reason


def test_wall_voxel_size_mostly_open_mesh_keeps_the_extent_size():
    shell = _shell((2, 2, 2), (1.8, 1.8, 1.8))  # walls 0.1, 43.44 units^2 of area
    sheet = trimesh.Trimesh([[-6, -1, -6], [6, -1, -6], [6, -1, 6], [-6, -1, 6]],
                            [[0, 1, 2], [0, 2, 3]])  # 144 units^2, no wall
    mesh = trimesh.util.concatenate([shell, sheet])
    size = wall_voxel_size(mesh, bytes_per_cell=1, samples=4000)
    assert size.wall_share == pytest.approx(43.44 / 187.44, abs=0.03)
    assert size.pitch == size.extent_pitch == 12 / 64 and not size.limited
    assert "mostly open" in size.reason
    finer = wall_voxel_size(mesh, bytes_per_cell=1, samples=4000, min_wall_share=0.2)
    assert finer.pitch == pytest.approx(PITCH_MARGIN * 0.05, rel=1e-5)


def test_wall_voxel_size_no_wall():
    sheet = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    size = wall_voxel_size(sheet, bytes_per_cell=40)
    assert size.pitch == size.extent_pitch and size.wall_share == 0.0
    assert "no wall found" in size.reason and size.log_level == logging.DEBUG
    assert size.info["wall_quantile"] is None and size.info["wall_pitch"] is None


def test_wall_voxel_size_invalid_input():
    with pytest.raises(InputError):
        wall_voxel_size(trimesh.creation.box(), bytes_per_cell=40, quantile=2.0)
    with pytest.raises(InputError):
        wall_voxel_size(trimesh.creation.box(), bytes_per_cell=40, resolution=0)
