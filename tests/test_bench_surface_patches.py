"""``viscore bench generate surface-patches``: the figures' structure on one small case.

No timing assertions: the figures are checked for shape and internal
consistency (the speed ratio is the quotient of the two times printed beside it).
"""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest
import trimesh

import viscore.cli.bench.surface_patches as bench_module
from viscore import InputError, load_mesh
from viscore.cli.bench.surface_patches import (
    BUDGET,
    bench_generate_surface_patches,
    bench_surface_patches_text,
    speed_building,
)
from viscore.cli.main import main

#: One building, cheap views and few rays: seconds, not minutes.
_SMALL = {"names": ("building-cottage",), "spacing": 0.3, "resolution": 16, "quads": 50,
          "rays": 2_000, "speed_triangles": 2_300}


@pytest.fixture(scope="module")
def small():
    return bench_generate_surface_patches(**_SMALL)


def test_bench_generate_surface_patches_rows_and_figures(small):
    (row,) = small["rows"]
    assert row["mesh"] == "building-cottage"
    assert row["triangles_input"] == len(load_mesh("building-cottage").faces)
    assert 0 < row["triangles"] <= BUDGET and row["seconds"] > 0
    for key in ("precision", "recall"):
        lo, hi = row[f"{key}_ci"]
        assert 0 <= lo <= row[key] <= hi <= 1, key
    assert row["conservative_guaranteed"] is True and row["rays"] == 2_000
    assert row["orbit_violations"] == 0 and row["volume_violations"] == 0
    assert 0 < row["violation_upper_bound"] < 1e-2
    assert small["buildings"] == 1 and small["mean_recall"] == row["recall"]
    assert small["targets"] == {"recall": 0.85, "seconds": 10.0}
    st = small["settings"]
    assert (st["budget"], st["resolution"], st["quads"], st["rays"]) == (BUDGET, 16, 50, 2_000)


def test_bench_generate_surface_patches_speed_row(small):
    s = small["speed"]
    assert s["triangles_input"] == 2_300 and 0 < s["triangles"] <= BUDGET
    assert s["ratio"] == pytest.approx(s["seconds"] / s["qem_seconds"])
    assert s["workers"] >= 1 and "building-warehouse" in s["mesh"]


def test_bench_surface_patches_text_has_every_row_and_the_targets(small):
    text = bench_surface_patches_text(small)
    assert "building-cottage" in text
    assert "mean recall over 1 built-in buildings" in text and "target >= 0.85" in text
    assert "2,300 triangles" in text and "target < 10 s on 2 cores" in text
    assert f"ratio x{small['speed']['ratio']:.1f}" in text


def test_speed_building_is_planar_and_exact():
    mesh = speed_building()
    assert len(mesh.faces) == 10_000
    base = load_mesh("building-warehouse")
    # the same surface: equal area, and every triangle in the plane of a base triangle
    assert mesh.area == pytest.approx(base.area, rel=1e-9)
    from scipy.spatial import cKDTree

    diag = float(np.linalg.norm(base.extents))

    def planes(m):
        n = np.asarray(m.face_normals)
        d = np.einsum("ij,ij->i", n, np.asarray(m.triangles)[:, 0]) / diag
        return np.column_stack([n, d])

    dist, _ = cKDTree(planes(base)).query(planes(mesh))
    assert dist.max() < 1e-6
    assert np.array_equal(speed_building().faces, mesh.faces)  # deterministic
    with pytest.raises(InputError, match="triangles"):
        speed_building(100)


def test_bench_generate_surface_patches_models_folder(tmp_path):
    (tmp_path / "kenney").mkdir()
    box = trimesh.creation.box(extents=(4, 4, 3))
    box.export(tmp_path / "kenney" / "block.glb")
    r = bench_generate_surface_patches(tmp_path, **{**_SMALL, "names": ("kenney/block",),
                                                    "speed_triangles": None})
    assert [row["mesh"] for row in r["rows"]] == ["kenney/block"]
    assert r["mean_recall"] is None and r["buildings"] == 0 and r["speed"] is None
    with pytest.raises(InputError, match="holds no"):
        bench_generate_surface_patches(tmp_path / "kenney")
    with pytest.raises(InputError, match="no such folder"):
        bench_generate_surface_patches(tmp_path / "missing")


def test_bench_generate_surface_patches_cli_json_is_one_document(capsys, monkeypatch):
    monkeypatch.setattr(bench_module, "bench_generate_surface_patches",
                        functools.partial(bench_generate_surface_patches,
                                          **{**_SMALL, "speed_triangles": None}))
    monkeypatch.delenv("VISCORE_MODELS", raising=False)
    assert main(["bench", "generate", "surface-patches", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [row["mesh"] for row in doc["rows"]] == ["building-cottage"]
    assert "provenance" in doc and doc["speed"] is None


def test_bench_generate_surface_patches_missing_models_exit_2(capsys, tmp_path):
    code = main(["bench", "generate", "surface-patches", "--models", str(tmp_path / "no")])
    assert code == 2 and "no such folder" in capsys.readouterr().err
