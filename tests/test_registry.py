"""The generator registry: declared options, their checks, budgets, the parts schema."""

import inspect
import logging

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.generators import (
    REGISTRY,
    GeneratorOption,
    GeneratorSpec,
    Occluder,
    check_parts,
    generate,
    get_generator,
)


@pytest.mark.parametrize("name", list(REGISTRY))
def test_registry_options_match_the_generator_signature(name):
    spec = REGISTRY[name]
    params = inspect.signature(spec.function).parameters
    # the common signature: budget and seed are keyword options of every generator
    for common in ("budget", "seed"):
        assert params[common].kind is inspect.Parameter.KEYWORD_ONLY
    for option in spec.options:
        assert option.name in params, f"{name}: {option.name} is not a keyword of the function"
        assert params[option.name].kind is inspect.Parameter.KEYWORD_ONLY
        assert params[option.name].default == option.default, (name, option.name)
        assert option.type in (int, float, str, bool)
        if option.default is not None:
            assert option.check(option.default) == option.default
    # every keyword option of the function is declared (or common)
    declared = {o.name for o in spec.options} | {"budget", "seed"}
    keywords = {k for k, p in params.items() if p.kind is inspect.Parameter.KEYWORD_ONLY}
    assert keywords == declared, f"{name}: undeclared options {keywords - declared}"


def test_registry_flags_compare_uses():
    assert {"aabb-skins", "qem", "godot", "bbox", "original"} <= set(REGISTRY)
    assert REGISTRY["godot"].baseline and not REGISTRY["godot"].budgeted
    assert REGISTRY["qem"].budgeted and not REGISTRY["bbox"].budgeted
    assert REGISTRY["aabb-skins"].conservative


def test_generator_option_check_types_and_ranges():
    fill = GeneratorOption("fill", float, 0.9, "share", low=0, low_open=True, high=1)
    assert fill.check(1) == 1.0 and isinstance(fill.check(1), float)
    for bad in (0, 0.0, 1.5, float("nan"), float("inf"), "0.5", True, None):
        with pytest.raises(InputError, match="fill: expected a number > 0 and <= 1"):
            fill.check(bad)
    count = GeneratorOption("count", int, 4, "n", low=1, nullable=True)
    assert count.check(None) is None and count.check(np.int64(3)) == 3
    with pytest.raises(InputError, match="count"):
        count.check(2.0)
    assert count.parse("none") is None and count.parse("12") == 12
    with pytest.raises(InputError, match="--count: expected an integer >= 1, or none"):
        count.parse("1e3")
    mode = GeneratorOption("mode", str, "a", "which", choices=("a", "b"))
    assert mode.parse("b") == "b"
    with pytest.raises(InputError, match="one of a, b"):
        mode.check("c")
    with pytest.raises(TypeError):
        GeneratorOption("x", list, [], "no lists")


def test_check_params_names_unknown_options_and_checks_common_ones():
    spec = get_generator("aabb-skins")
    assert spec.check_params({"voxels": 8, "budget": 24, "seed": 2**70}) == {
        "voxels": 8, "budget": 24, "seed": 2**70}
    with pytest.raises(InputError, match=r"unknown option --distance \(takes: --budget, --seed, "
                                         r"--voxels"):
        spec.check_params({"distance": 1.0}, flags=True)
    with pytest.raises(InputError, match="seed"):
        spec.check_params({"seed": -1})
    with pytest.raises(InputError, match="budget"):
        spec.check_params({"budget": 0})


def test_generate_checks_options_before_running(monkeypatch):
    calls = []
    spec = GeneratorSpec("spy", lambda mesh, **kw: calls.append(kw), "records its call",
                         options=(GeneratorOption("size", float, 1.0, "side", low=0),))
    monkeypatch.setitem(REGISTRY, "spy", spec)
    with pytest.raises(InputError, match="size"):
        generate("spy", trimesh.creation.box(), size=-1.0)
    with pytest.raises(InputError, match="unknown option"):
        generate("spy", trimesh.creation.box(), colour="red")
    assert calls == []


def test_generate_flags_an_occluder_over_its_budget(caplog):
    box = trimesh.creation.icosphere()
    with caplog.at_level(logging.WARNING, logger="viscore"):
        over = generate("bbox", box, budget=5)
    assert over.triangles == 12 and over.info["over_budget"] is True
    warnings = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "budget of 5" in warnings[0].getMessage()
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="viscore"):
        within = generate("bbox", box, budget=12)
    assert within.info["over_budget"] is False and not caplog.records
    assert "over_budget" not in generate("bbox", box).info


def test_unknown_generator_lists_the_registered_ones():
    with pytest.raises(InputError, match="registered: aabb-skins"):
        get_generator("nope")


@pytest.mark.parametrize("name", list(REGISTRY))
def test_every_generator_fills_parts_by_the_schema(name):
    mesh = trimesh.creation.box(extents=(2.0, 1.0, 1.0))
    occ = generate(name, mesh, **({"voxels": 16} if name == "aabb-skins" else {}))
    assert isinstance(occ, Occluder) and occ.method == name
    found = check_parts(occ.parts)
    if "boxes" in occ.parts:
        lo, hi = occ.parts["boxes"][:, 0], occ.parts["boxes"][:, 1]
        assert found["boxes"] == len(lo)
        # boxes lie within the mesh's bounding box
        assert (lo >= mesh.bounds[0] - 1e-9).all() and (hi <= mesh.bounds[1] + 1e-9).all()


def test_check_parts_accepts_the_schema():
    leaf = {"bounds": np.array([[0.0, 0, 0], [1, 1, 1]]), "occluder": trimesh.creation.box(),
            "children": []}
    root = {"bounds": np.array([[0.0, 0, 0], [2, 2, 2]]), "occluder": trimesh.Trimesh(),
            "children": [leaf, dict(leaf)]}
    tetra = trimesh.creation.box()
    parts = {"boxes": np.zeros((0, 2, 3)),
             "polygons": [np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])],
             "solids": [(tetra.vertices, tetra.faces)],
             "hierarchy": root, "method_specific": object()}
    assert check_parts(parts) == {"boxes": 0, "polygons": 1, "solids": 1, "hierarchy": 3}


@pytest.mark.parametrize("parts, match", [
    ({"boxes": np.zeros((2, 3))}, r"boxes\]: expected shape \(k, 2, 3\)"),
    ({"boxes": np.array([[[1.0, 0, 0], [0, 1, 1]]])}, "lower corner exceeds"),
    ({"boxes": np.array([[[np.nan, 0, 0], [1, 1, 1]]])}, "finite"),
    ({"polygons": [np.zeros((2, 3))]}, r"polygons\]\[0\]"),
    ({"solids": [(np.zeros((4, 3)), np.array([[0, 1, 4]]))]}, "missing vertex"),
    ({"hierarchy": {"bounds": np.zeros((2, 3))}}, "bounds, occluder, children"),
    ({"hierarchy": {"bounds": np.array([[0.0, 0, 0], [1, 1, 1]]), "occluder": trimesh.Trimesh(),
                    "children": [{"bounds": np.array([[0.0, 0, 0], [2, 1, 1]]),
                                  "occluder": trimesh.Trimesh(), "children": []}]}},
     "leave the parent"),
])
def test_check_parts_invalid_input(parts, match):
    with pytest.raises(ValueError, match=match):
        check_parts(parts)


def test_check_params_refuses_budgets_below_the_methods_minimum():
    from viscore import InputError
    from viscore.generators import REGISTRY

    spec = REGISTRY["aabb-skins"]
    assert spec.min_budget == 12
    assert spec.check_params({"budget": 12}) == {"budget": 12}
    with pytest.raises(InputError, match="at least 12"):
        spec.check_params({"budget": 11})
    # a method that ignores the budget takes any
    assert REGISTRY["bbox"].check_params({"budget": 1}) == {"budget": 1}


def test_bool_options_take_only_booleans_and_parse_words():
    option = GeneratorOption("conservative", bool, False, "a switch")
    assert option.check(True) is True and option.check(False) is False
    for bad in (1, 0, "true", None, 1.0):
        with pytest.raises(InputError, match="true or false"):
            option.check(bad)
    assert option.parse("Yes") is True and option.parse("0") is False
    with pytest.raises(InputError, match="--conservative: expected true or false"):
        option.parse("maybe")


def test_bool_options_are_switch_pairs_on_the_command_line(tmp_path, capsys):
    from viscore.cli.main import main

    spec = REGISTRY["planar-sections"]
    assert spec.option("conservative").type is bool
    assert main(["generate", "planar-sections", "--help"]) == 0
    out = capsys.readouterr().out
    assert "--conservative, --no-conservative" in out
    # a value after the switch is a usage error, not a silently ignored word
    code = main(["generate", "planar-sections", "fat-torus", "-o", str(tmp_path / "o.ply"),
                 "--conservative", "maybe"])
    assert code == 2
    assert not (tmp_path / "o.ply").exists()
