"""Method variants: a registered generator with options fixed (``name:option=value``)."""

import json

import numpy as np
import pytest
import trimesh
from viscore.cli.main import main
from viscore.generators import generate, parse_method

from viscore import InputError


def test_label_is_canonical_and_round_trips():
    v = parse_method(" planar-sections : reduce=area:chain=greedy:rdp-tolerance=1.5 ")
    assert v.spec.name == "planar-sections"
    assert v.options == {"reduce": "area", "chain": "greedy", "rdp_tolerance": 1.5}
    assert v.label == "planar-sections:chain=greedy:rdp-tolerance=1.5:reduce=area"
    assert parse_method(v.label).label == v.label  # idempotent
    # keyword or flag spelling, and the CLI's words for booleans, give one label
    assert (parse_method("planar-sections:conservative=yes").label
            == parse_method("planar-sections:conservative=true").label
            == "planar-sections:conservative=true")
    assert parse_method("bbox").label == "bbox" and parse_method("bbox").options == {}


@pytest.mark.parametrize("text, message", [
    ("magic", "unknown method 'magic'"),
    ("planar-sections:x=1", "has no option 'x'"),
    ("planar-sections:budget=3", "set for every method"),
    ("planar-sections:seed=3", "set for every method"),
    ("planar-sections:chain", "expected planar-sections:option=value"),
    ("planar-sections:chain=best", "expected one of optimal, greedy"),
    ("planar-sections:close=1:close=2", "given twice"),
    ("planar-sections:close=99", "close"),
    ("qem:", "expected qem:option=value"),
    ("", "expected a method name"),
])
def test_bad_variants_are_refused_with_one_message(text, message):
    with pytest.raises(InputError, match=message):
        parse_method(text, "--methods")


def test_a_variant_generates_what_its_options_generate():
    box = trimesh.creation.box(extents=(2, 1, 1))
    a = generate("planar-sections:chain=greedy:voxels=12", box, budget=4)
    b = generate("planar-sections", box, budget=4, chain="greedy", voxels=12)
    assert a.params == b.params and a.params["chain"] == "greedy"
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices)
    assert np.array_equal(a.mesh.faces, b.mesh.faces)
    with pytest.raises(InputError, match="given in the method and again"):
        generate("planar-sections:chain=greedy", box, chain="optimal")


def test_compare_runs_variants_as_methods_of_their_own(tmp_path, capsys):
    out = tmp_path / "study"
    argv = ["compare", "fat-torus", "--methods",
            "aabb-skins,aabb-skins:max-boxes=1,aabb-skins:max_boxes=1", "--budget", "64",
            "--views", "4", "--quads", "300", "--res", "32", "--rays", "1000", "--no-culling",
            "--versus", "aabb-skins", "--out", str(out), "--json"]
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    rows = {r["method"]: r for r in doc["rows"]}
    # the two spellings of one variant are one method, run once
    assert sorted(rows) == ["aabb-skins", "aabb-skins:max-boxes=1"]
    assert rows["aabb-skins:max-boxes=1"]["triangles"] == 12  # one box
    assert rows["aabb-skins"]["triangles"] > 12
    # the occluder files carry no characters that file systems refuse
    files = [p.name for p in (out / "occluders").iterdir()]
    assert files and not any(":" in f or "=" in f for f in files)
    # paired against the plain method on the same views
    assert [p["method"] for p in doc["paired"]] == ["aabb-skins:max-boxes=1"]
    # a variant that cannot be run is refused before the study exists
    bad = tmp_path / "bad"
    assert main(["compare", "fat-torus", "--methods", "aabb-skins:max-boxes=0",
                 "--out", str(bad)]) == 2
    assert "--methods: aabb-skins:max-boxes" in capsys.readouterr().err
    assert not bad.exists()
