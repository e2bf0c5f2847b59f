"""generators/specs.py: a method's checks run without its work (check-only calls, ``checker``),
and a generator's arguments checked by the options it declares (``checked_by``)."""

import dataclasses
import inspect

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.generators import REGISTRY, GeneratorOption, GeneratorSpec
from viscore.generators.specs import (
    _CheckOnlyMesh,
    _ChecksPassed,
    check_only,
    check_only_call,
    checked_by,
)


def _recording(steps: list):
    """A generator that checks ``a`` against ``b`` (a rule across options), then works."""
    def method(mesh, *, budget=None, seed=0, a=0, b=0):
        steps.append("checks")
        if a and b:
            raise InputError("a and b: give one")
        n = len(mesh.faces)  # the first use of the mesh: the work begins
        steps.append("work")
        return mesh.copy() if n else mesh
    return method


def test_check_only_call_runs_the_rules_and_stops_at_the_mesh():
    steps = []
    method = _recording(steps)
    assert check_only_call(method, {"a": 1}) is True
    assert steps == ["checks"]  # no work
    with pytest.raises(InputError, match="a and b: give one"):
        check_only_call(method, {"a": 1, "b": 1})
    assert steps == ["checks", "checks"]


def test_check_only_call_is_not_swallowed_by_a_generator_catching_exception():
    steps = []

    def method(mesh, *, budget=None, seed=0):
        try:
            mesh.faces  # noqa: B018 - the first use
        except Exception:  # noqa: BLE001 - a generator's own broad handler
            steps.append("caught")
        steps.append("work")

    assert check_only_call(method, {}) is True
    assert steps == []


def test_check_only_call_leaves_to_the_real_call_what_only_a_real_mesh_survives():
    def method(mesh, *, budget=None, seed=0):
        return len(mesh)  # Trimesh has no len(): a TypeError, not the method's refusal

    assert check_only_call(method, {}) is False


def test_the_stand_in_passes_isinstance_and_ends_at_any_use():
    mesh = _CheckOnlyMesh()
    assert isinstance(mesh, trimesh.Trimesh)
    for use in (lambda: mesh.faces, lambda: mesh.vertices, lambda: mesh.bounds,
                lambda: mesh.metadata, lambda: mesh.copy(), lambda: hash(mesh),
                lambda: repr(mesh), lambda: mesh + mesh):
        with pytest.raises(_ChecksPassed):
            use()


@pytest.mark.parametrize("name", [n for n, s in REGISTRY.items() if s.plugin is None])
def test_every_method_reaches_its_mesh_with_its_defaults(name):
    """No registered method refuses its own defaults, or ends before its mesh, when checked."""
    spec = REGISTRY[name]
    assert check_only_call(spec.function, {}) is True
    assert spec.check_options({}) == {}


@pytest.mark.parametrize("options, message", [
    ({"pixel_error": 1.0}, "pixel_error: needs distance"),
    ({"distance": 10.0}, "need pixel_error"),
    ({"voxels": 32, "voxel_size": 0.1}, "voxels and voxel_size: give one way"),
    ({"voxels": 32, "pixel_error": 1.0, "distance": 4.0}, "voxels and pixel_error"),
    ({"close": 2, "conservative": True}, "close: not with conservative"),
    ({"pixel_error": 1.0, "distance": 4.0, "lod_distances": "4,8"}, "give one"),
    ({"pixel_error": 1.0, "lod_distances": "4,8", "min_precision": 0.9}, "not with lod_"),
    ({"hierarchy": True, "voxel_size": 0.1}, "not with a hierarchy"),
    ({"hierarchy": True, "dilate": 1}, "dilate: not with a hierarchy"),
])
def test_planar_sections_rules_across_options_run_without_work(options, message):
    with pytest.raises(InputError, match=message):
        REGISTRY["planar-sections"].check_options(options)


@pytest.mark.parametrize("options", [
    {"pixel_error": 1.0, "distance": 4.0}, {"voxel_size": 0.1}, {"close": 2},
    {"conservative": True}, {"hierarchy": True}, {"pixel_error": 2.0, "lod_distances": "4,8"},
])
def test_planar_sections_valid_combinations_pass(options):
    assert REGISTRY["planar-sections"].check_options(options) == options


def test_single_values_are_checked_first_and_converted():
    spec = REGISTRY["planar-sections"]
    with pytest.raises(InputError, match="voxels: expected"):
        spec.check_options({"voxels": 0})
    assert spec.check_options({"alpha": 2}) == {"alpha": 2.0}


def test_a_checker_replaces_the_check_only_call():
    seen = []

    def work(mesh, *, budget=None, seed=0, side=1.0):
        raise AssertionError("the method must not run")

    def checker(**params):
        seen.append(params)
        if params.get("side", 1.0) > 10:
            raise InputError("side: too long for this method")

    spec = GeneratorSpec("sized", work, "a sized method", checker=checker, options=(
        GeneratorOption("side", float, 1.0, "side, world units", low=0, low_open=True),))
    assert spec.check_options({"side": 2}) == {"side": 2.0}
    with pytest.raises(InputError, match="too long"):
        spec.check_options({"side": 11})
    assert seen == [{"side": 2.0}, {"side": 11.0}]


def test_a_spec_without_a_checker_is_not_called():
    """A method of another package (a plugin, a spec made by hand) is never run on the stand-in."""
    def plugin(mesh, *, budget=None, seed=0):
        raise AssertionError("not run by a check")

    spec = dataclasses.replace(GeneratorSpec.from_function(plugin), plugin=("pkg", "1.0"))
    assert spec.checker is None and spec.check_options({"budget": 8}) == {"budget": 8}
    assert GeneratorSpec("by-hand", plugin, "made by hand").check_options({}) == {}


def test_the_toolkits_methods_are_checked_by_a_check_only_call():
    steps = []
    spec = GeneratorSpec("recording", _recording(steps), "records its steps",
                         checker=check_only(_recording(steps)), options=(
                             GeneratorOption("a", int, 0, "a"), GeneratorOption("b", int, 0, "b")))
    with pytest.raises(InputError, match="give one"):
        spec.check_options({"a": 1, "b": 2})
    assert spec.check_options({"a": 1}) == {"a": 1} and steps == ["checks", "checks"]
    assert all(s.checker is not None for s in REGISTRY.values() if s.plugin is None)


# ----------------------------------------------------------------------------- checked_by

SIDE = GeneratorOption("side", float, 1.0, "side, world units", low=0, low_open=True)
MODE = GeneratorOption("mode", str, "a", "mode", choices=("a", "b"))
LIMIT = GeneratorOption("limit", int, None, "limit", low=1, default_text="from the mesh")


def _checked(seen: list):
    @checked_by((SIDE, MODE, LIMIT))
    def method(mesh, *, budget=None, seed=0, side=1.0, mode="a", limit=None):
        seen.append({"budget": budget, "seed": seed, "side": side, "mode": mode,
                     "limit": limit})
        return mesh
    return method


def test_checked_by_gives_the_body_checked_values_defaults_included():
    seen = []
    method = _checked(seen)
    assert method("mesh", side=2, budget=np.int64(8), seed=np.uint8(3)) == "mesh"
    assert seen == [{"budget": 8, "seed": 3, "side": 2.0, "mode": "a", "limit": None}]
    assert type(seen[0]["side"]) is float and type(seen[0]["budget"]) is int
    assert list(inspect.signature(method).parameters) == ["mesh", "budget", "seed", "side",
                                                          "mode", "limit"]


@pytest.mark.parametrize("kwargs, message", [
    ({"side": 0}, "side: expected a number > 0, got 0"),
    ({"mode": "c"}, "mode: expected one of a, b, got 'c'"),
    ({"limit": 0}, "limit: expected an integer >= 1, got 0"),
    ({"budget": 0}, "budget: expected a positive integer, got 0"),
    ({"seed": -1}, "seed: expected a non-negative integer, got -1"),
])
def test_checked_by_refuses_before_the_body(kwargs, message):
    seen = []
    with pytest.raises(InputError) as caught:
        _checked(seen)(None, **kwargs)
    assert str(caught.value) == message and seen == []
    with pytest.raises(TypeError):  # an unknown keyword, as without the decorator
        _checked(seen)(None, sides=2)


def test_checked_by_refuses_declarations_that_disagree_with_the_generator():
    with pytest.raises(TypeError, match="declared"):
        @checked_by((SIDE,))
        def undeclared(mesh, *, budget=None, seed=0, side=1.0, mode="a"):
            return mesh
    with pytest.raises(TypeError, match="default"):
        @checked_by((SIDE,))
        def other_default(mesh, *, budget=None, seed=0, side=2.0):
            return mesh


def test_an_option_with_a_reader_checks_by_it_and_keeps_the_text():
    def reader(value, label):
        if value in ("off", None):
            return None
        try:
            return float(value)
        except (TypeError, ValueError):
            raise InputError(f"{label}: expected off or a height, got {value!r}") from None

    ground = GeneratorOption("ground", str, "off", "ground", convert=reader)
    assert ground.check("1") == "1" and ground.read("1") == 1.0
    assert ground.check(0.5) == 0.5 and ground.read("off") is None
    assert ground.parse("2.5") == "2.5"  # a method variant keeps its text as written
    with pytest.raises(InputError, match="--ground: expected off or a height, got 'x'"):
        ground.parse("x")


def test_bool_options_take_numpys_booleans():
    switch = GeneratorOption("conservative", bool, False, "a switch")
    assert switch.check(np.bool_(True)) is True and switch.read(np.False_) is False


def _bad_value(option: GeneratorOption):
    """A value the declaration refuses."""
    if option.convert is not None:
        return object()
    if option.choices:
        return "not-a-choice"
    if option.type is bool:
        return "yes"
    if option.low is not None:
        return option.low - 1
    return float("nan")


CHECKED = [(name, o.name) for name, spec in REGISTRY.items()
           if getattr(spec.function, "options", None) is not None for o in spec.options]


@pytest.mark.parametrize(("name", "option"), CHECKED, ids=[f"{n}.{o}" for n, o in CHECKED])
def test_a_direct_call_and_a_call_by_name_refuse_alike(name, option):
    """The generator's own check of an option is the spec's: one declaration, one message."""
    spec = REGISTRY[name]
    assert spec.function.options == spec.options  # the spec takes the generator's table
    bad = _bad_value(spec.option(option))
    with pytest.raises(InputError) as by_name:
        spec.check_params({option: bad})
    with pytest.raises(InputError) as direct:
        spec.function(None, **{option: bad})
    assert str(direct.value) == str(by_name.value)


def test_the_generators_declaring_their_options_are_the_long_ones():
    assert {n for n, _ in CHECKED} >= {"surface-patches", "planar-sections", "godot"}
