"""The Table 1 benchmark's stand-ins (cli/bench/table1.py) and its table."""

import numpy as np
import pytest

from viscore import Scene
from viscore.cli.bench.table1 import (
    PAPER_TABLE1,
    bench_table1,
    fractal_terrain,
    machine_assembly,
    table1_lines,
)


def test_fractal_terrain_is_a_seeded_height_field_of_the_papers_size():
    t = fractal_terrain()
    assert len(t.faces) == 2 * 173**2  # 59,858, the paper's TERRAIN has 60,160
    assert np.allclose(t.extents, [100, 100, 33])
    assert np.array_equal(t.vertices, fractal_terrain().vertices)
    assert not np.array_equal(t.vertices, fractal_terrain(seed=1).vertices)
    # a height field: every vertical line over the footprint meets it once
    rng = np.random.default_rng(0)
    xy = rng.uniform(1, 99, size=(200, 2))
    origins = np.column_stack([xy, np.full(200, 50.0)])
    hits = Scene(t).all_hits(origins, np.tile([0.0, 0, -1], (200, 1)))
    assert (hits.count == 1).all()


def test_machine_assembly_is_many_loose_parts_at_the_papers_scale():
    m = machine_assembly()
    assert 350_000 < len(m.faces) < 450_000  # the paper's MACHINE: 394,452
    assert len(m.split(only_watertight=False)) >= 400
    assert np.array_equal(m.faces, machine_assembly().faces)


def test_table1_lines_put_the_papers_row_beside_ours():
    row = {"name": "TERRAIN", "triangles": 59858, "budget": 23,
           "paper": {"triangles": 60160, "seconds": 11.0, "precision": 0.999, "recall": 0.823},
           "planar-sections": {"triangles": 23, "seconds": 4.25, "precision": 0.99712,
                               "recall": 0.5, "precision_ci": [0.99, 1.0],
                               "recall_ci": [0.4, 0.6]},
           "qem": {"triangles": 23, "seconds": 1.5, "precision": 0.9, "recall": 0.317},
           "godot": None}
    lines = table1_lines([row])
    assert lines[-1].split()[:7] == ["TERRAIN", "59858", "23", "|", "0.999", "0.823", "11"]
    assert "0.9971" in lines[-1] and "0.500 [0.400, 0.600]" in lines[-1]
    assert "0.317" in lines[-1] and lines[-1].endswith("| -")
    assert [r[0] for r in PAPER_TABLE1] == ["BUNNY", "DRAGON", "TERRAIN", "MACHINE", "BUDDHA"]


@pytest.mark.slow
def test_table1_terrain_row_runs_all_three_methods_at_its_budget():
    (row,) = bench_table1(views=32, rows=("TERRAIN",))
    assert row["budget"] == 23
    assert row["planar-sections"]["triangles"] <= 23 and row["qem"]["triangles"] <= 23
    assert row["godot"] is None or row["godot"]["triangles"] <= 23
    assert row["planar-sections"]["precision"] >= 0.99


def test_table1_flag_is_for_planar_sections_only(capsys):
    from viscore.cli.main import main

    rc = main(["bench", "generate", "aabb-skins", "--table1"])
    err = capsys.readouterr().err
    assert rc == 2 and "--table1: only for planar-sections" in err
    assert "Traceback" not in err
