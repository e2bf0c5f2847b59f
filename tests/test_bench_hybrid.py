"""``viscore bench generate hybrid``: its hole-filling figures are whole and consistent.

No timing or recall assertions: the bench prints figures; here they are checked for
shape and for what holds by construction (every open hole has one reason, filling
off fills nothing).
"""

import pytest

from viscore.cli.bench.command import _hybrid_holes_lines
from viscore.cli.bench.hybrid import bench_generate_hybrid
from viscore.cli.main import main

# a cheap hybrid: coarse voxels, small metric-guided views
_CHEAP = {"voxels": 16, "mgos_spacing": 0.3, "mgos_resolution": 16, "mgos_quads": 100}


@pytest.fixture(scope="module")
def cottage():
    return bench_generate_hybrid(None, spacing=0.3, resolution=16, quads=100, baselines=False,
                                 names=("building-cottage",), **_CHEAP)


@pytest.mark.slow  # the metric-guided step's numba kernels compile on first use
def test_bench_hybrid_counts_holes_and_scores_filling_on_and_off(cottage):
    (row,) = cottage["rows"]
    # the cottage's blind window and plaque are filled; its doors and windows are not
    assert row["holes_filled"] >= 2 and row["holes_open"] >= 4
    assert sum(row["holes_open_why"].values()) == row["holes_open"]
    assert row["holes_open_why"]["opening"] >= 4
    for key in ("patch_fill", "patch_nofill", "nofill"):
        assert row[f"{key}_faces"] > 0 and 0 <= row[f"{key}_recall"] <= 1
    assert row["nofill_faces"] <= row["faces"]  # the filled run's count is its budget
    # the patch candidates stop at the first patch past N_P either way
    assert abs(row["patch_fill_faces"] - row["patch_nofill_faces"]) < 0.1 * 600
    lines = _hybrid_holes_lines(cottage["rows"])
    assert len(lines) == 2 and "building-cottage" in lines[1]
    assert f"{row['nofill_faces']} {row['nofill_precision']:.4f}" in lines[1]


@pytest.mark.slow
def test_bench_hybrid_without_filling_fills_nothing():
    r = bench_generate_hybrid(None, spacing=0.3, resolution=16, quads=100, baselines=False,
                              names=("building-cottage",), fill_holes=False, **_CHEAP)
    (row,) = r["rows"]
    assert row["holes_filled"] == 0 and "patch_fill_faces" not in row
    assert "why open" in _hybrid_holes_lines(r["rows"])[0]


def test_no_fill_holes_only_for_hybrid(capsys):
    code = main(["bench", "generate", "aabb-skins", "--no-fill-holes"])
    _, err = capsys.readouterr()
    assert code == 2 and err.count("\n") == 1 and "--no-fill-holes" in err
