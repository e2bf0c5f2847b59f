"""Method variants: a registered generator with options fixed (``name:option=value``)."""

import json

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.cli.main import main
from viscore.generators import check_method, generate, parse_method


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


#: Variants whose options conflict (issue 23): each option is valid, their pairing is not.
CONFLICTING = [
    ("planar-sections:pixel-error=1", "pixel_error: needs distance"),
    ("planar-sections:voxels=32:voxel-size=0.1", "voxels and voxel_size: give one way"),
    ("planar-sections:close=2:conservative=true", "close: not with conservative"),
    ("planar-sections:hierarchy=true:voxel-size=0.1", "voxel_size: not with a hierarchy"),
]


@pytest.mark.parametrize("text, message", CONFLICTING)
def test_check_method_runs_the_generators_rules_across_options(text, message):
    assert parse_method(text).options  # each option alone is fine
    with pytest.raises(InputError, match=f"^--methods: {parse_method(text).label}: {message}"):
        check_method(text, "--methods")
    assert check_method("planar-sections:pixel-error=1:distance=20").options == {
        "pixel_error": 1.0, "distance": 20.0}


def _no_work(*args, **kwargs):
    raise AssertionError("nothing may be loaded or generated before the methods are checked")


@pytest.mark.parametrize("command", ["compare", "cull", "occlude"])
@pytest.mark.parametrize("text, message", CONFLICTING[:3])
def test_conflicting_variants_refused_before_any_folder_or_work(command, text, message,
                                                                tmp_path, monkeypatch, capfd):
    """Issue 23: the rule fired inside the job, after the study folder, lock and store."""
    from viscore.cli import compare_cmd, cull_cmd, occlude_cmd

    for module in (compare_cmd, cull_cmd, occlude_cmd):
        for name in ("load_mesh", "load_scene_objects", "level_objects", "run_study",
                     "culling_runtimes", "occlude_level"):
            if hasattr(module, name):
                monkeypatch.setattr(module, name, _no_work)
    out = tmp_path / "out"
    argv = {"compare": ["compare", "fat-torus", "--out", str(out)],
            "cull": ["cull", "city", "--out", str(out)],
            "occlude": ["occlude", "building-house", "-o", str(out)]}[command]
    assert main([*argv, "--methods", f"bbox,{text}"]) == 2
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("viscore: error: --methods: planar-sections"), err
    assert message in err[0]
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_compare_checks_culling_methods_and_cull_its_frusta_method(tmp_path, capfd):
    out = tmp_path / "out"
    assert main(["compare", "fat-torus", "--out", str(out), "--methods", "bbox",
                 "--culling-methods", "planar-sections:pixel-error=1"]) == 2
    assert "--culling-methods: planar-sections" in capfd.readouterr().err
    assert main(["cull", "city", "--out", str(out),
                 "--frusta-method", "planar-sections:close=1:conservative=yes"]) == 2
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--frusta-method: planar-sections" in err[0], err
    assert not out.exists()
