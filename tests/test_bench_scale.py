"""The scale benchmark (cli/bench/scale.py): its open scan stand-in and its table."""

import numpy as np
import pytest

from viscore import load_mesh
from viscore.cli.bench.scale import OPEN_BASE, bench_scale, open_scan, scale_lines


def test_open_scan_is_the_bunny_with_its_base_cut_open():
    bunny, scan = load_mesh("bunny"), open_scan()
    low, high = bunny.bounds[:, 2]
    cut = bunny.triangles_center[:, 2] <= low + OPEN_BASE * (high - low)
    assert len(scan.faces) == len(bunny.faces) - cut.sum() and cut.sum() > 0
    assert not scan.is_watertight
    # the opening is at the bottom: every boundary edge is within one edge of the cut
    edges = scan.edges_sorted
    _, index, counts = np.unique(edges, axis=0, return_index=True, return_counts=True)
    rim = scan.vertices[edges[index[counts == 1]].ravel()]
    assert rim[:, 2].max() <= low + OPEN_BASE * (high - low) + scan.edges_unique_length.max()
    assert len(rim) > 50
    finer = open_scan(1)  # the same surface, four times the triangles
    assert len(finer.faces) == 4 * len(scan.faces)
    assert np.allclose(finer.bounds, scan.bounds)


def test_scale_lines_give_the_ratios_of_the_targets():
    def row(tris, planar, qem):
        made = {"triangles": 64, "precision": 0.999, "recall": 0.9}
        return {"triangles": tris, "planar-sections": {**made, "seconds": planar,
                                                       "generations": 10},
                "qem": {**made, "seconds": qem}}

    lines = scale_lines([row(55_880, 20.0, 2.0), row(894_080, 30.0, 40.0)])
    assert lines[2].split()[-1] == "10.00" and lines[3].split()[-1] == "0.75"
    assert "1.50x the time for 16.0x the triangles" in lines[-1]


@pytest.mark.slow
def test_bench_scale_runs_both_methods_on_the_open_scan():
    (row,) = bench_scale(views=16, subdivisions=(0,))
    assert row["triangles"] == len(open_scan().faces)
    for method in ("planar-sections", "qem"):
        assert row[method]["triangles"] <= 64 and row[method]["seconds"] > 0
    assert row["planar-sections"]["generations"] > 1  # the floor tried closings and fills


def test_scale_flag_is_for_planar_sections_only(capsys):
    from viscore.cli.main import main

    rc = main(["bench", "generate", "hybrid", "--scale"])
    err = capsys.readouterr().err
    assert rc == 2 and "--scale: only for planar-sections" in err
    assert "Traceback" not in err
