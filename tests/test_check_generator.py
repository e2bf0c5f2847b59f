"""``check_generator``: the generator contract, on every registered method and on broken ones."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.generators import REGISTRY, GeneratorOption, GeneratorSpec, Occluder
from viscore.generators.testing import CHECK_SCENES, check_generator

#: Methods cheap enough for the default run (a few seconds each); the rest are slow.
_CHEAP = ("bbox", "original", "qem", "godot", "aabb-skins")
_BUILTIN = [name for name, spec in REGISTRY.items() if spec.plugin is None]


@pytest.mark.parametrize("name", _CHEAP)
def test_check_generator_accepts_cheap_registered_methods(name):
    report = check_generator(name)
    assert list(report) == list(CHECK_SCENES)
    assert all(report[s]["triangles"] for s, closed in CHECK_SCENES.items() if closed)


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in _BUILTIN if n not in _CHEAP])
def test_check_generator_accepts_heavy_registered_methods(name):
    check_generator(name)


def test_check_generator_reports_the_claim_and_its_bound():
    report = check_generator("aabb-skins", scenes=["sphere", "quad"])
    assert report["sphere"]["conservative_guaranteed"] is True
    assert 0 < report["sphere"]["violation_upper_bound"] < 1e-3  # 20,000 clean rays
    assert report["quad"]["conservative_guaranteed"] is False  # nothing claimed on a quad


def test_check_generator_accepts_a_variant_a_spec_and_a_function():
    assert check_generator("godot:distance=0", scenes=["sphere"])["sphere"]["triangles"] == 320
    check_generator(dataclasses.replace(REGISTRY["bbox"], name="my-bbox"), scenes=["quad"])

    def decimated(mesh, *, budget=None, seed=0, keep: float = 1.0):
        """The first faces, up to the budget."""
        faces = mesh.faces[: max(1, min(len(mesh.faces), budget or len(mesh.faces)))]
        return trimesh.Trimesh(mesh.vertices, faces, process=False)

    report = check_generator(decimated)
    assert report["sphere"]["triangles"] == 64


def test_check_generator_on_meshes_of_your_own():
    cylinder = trimesh.creation.cylinder(radius=1, height=2)
    report = check_generator("bbox", scenes=[cylinder, "triangle"])
    assert list(report) == ["mesh0", "triangle"]


def test_check_generator_invalid_input():
    with pytest.raises(InputError, match="unknown scene 'nope'"):
        check_generator("bbox", scenes=["nope"])
    with pytest.raises(InputError, match="unknown generator"):
        check_generator("no-such-method")
    with pytest.raises(InputError, match="seed"):
        check_generator("bbox", seed=-1)
    with pytest.raises(InputError, match="expected a registered name"):
        check_generator(42)
    with pytest.raises(InputError, match="at least one scene"):
        check_generator("bbox", scenes=[])


# --------------------------------------------------------------------------- broken methods


def _box_of(mesh) -> trimesh.Trimesh:
    return trimesh.creation.box(bounds=mesh.bounds) if mesh.extents.min() > 0 else mesh.copy()


def raises_on_flat(mesh, *, budget=None, seed=0):
    if mesh.extents.min() == 0:
        raise ValueError("cannot handle a flat mesh")
    return _box_of(mesh)


def refuses_flat(mesh, *, budget=None, seed=0):
    if mesh.extents.min() == 0:
        from viscore import InputError

        raise InputError("mesh: no volume")
    return _box_of(mesh)


def nan_output(mesh, *, budget=None, seed=0):
    out = _box_of(mesh)
    vertices = np.array(out.vertices)
    vertices[3] = np.inf
    return trimesh.Trimesh(vertices, out.faces, process=False)


def bad_indices(mesh, *, budget=None, seed=0):
    faces = np.array(mesh.faces)
    faces[-1] = [0, 1, -1]
    return trimesh.Trimesh(np.array(mesh.vertices), faces, process=False)


def empty_output(mesh, *, budget=None, seed=0):
    return trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), process=False)


def ignores_budget(mesh, *, budget=None, seed=0):
    return mesh.copy()


def says_over_budget(mesh, *, budget=None, seed=0):
    over = budget is not None and len(mesh.faces) > budget
    return Occluder(mesh.copy(), "says-over-budget", {}, True, 0.0,
                    info={"over_budget": over})


def unseeded(mesh, *, budget=None, seed=0):
    out = _box_of(mesh)
    return trimesh.Trimesh(out.vertices * np.random.default_rng().uniform(0.9, 1.0),
                           out.faces, process=False)


def false_claim(mesh, *, budget=None, seed=0):
    out = _box_of(mesh)  # the bounding box: seen before a sphere
    out.metadata["conservative_guaranteed"] = True
    return out


def _spec(option: GeneratorOption, function=None) -> GeneratorSpec:
    def fn(mesh, *, budget=None, seed=0, level=option.default):
        return _box_of(mesh)
    return GeneratorSpec("broken-options", function or fn, "declares options badly",
                         options=(option,))


class _LaxOption(GeneratorOption):
    """Declares a range but does not enforce it."""

    def check(self, value, label=None):
        return value


@pytest.mark.parametrize(("method", "rule", "detail"), [
    (raises_on_flat, "runs", "scene 'quad': raised ValueError: cannot handle a flat mesh"),
    (nan_output, "finite output", "vertices not finite"),
    (bad_indices, "finite output", "faces indexing vertices outside"),
    (empty_output, "non-empty output", "scene 'sphere': no triangles for a closed solid"),
    (ignores_budget, "budget", "320 triangles for a budget of 64"),
    (unseeded, "determinism", "seed 0 gave 12 triangles"),
    (false_claim, "conservative claim", r"rays hit the occluder before the mesh \(violation "
                                        r"rate <= 0\.\d+ at 95%, one-sided\)"),
    (_spec(GeneratorOption("level", int, 0, "level", low=1)), "options",
     "the default of 'level' is refused"),
    (_spec(GeneratorOption("depth", int, 1, "depth", low=1)), "options",
     "'depth' is declared but the function takes no such keyword"),
    (_spec(_LaxOption("level", float, 0.5, "level", low=0, high=1)), "options",
     r"level=-1\.0 is outside a number >= 0 and <= 1 but was accepted"),
    (_spec(_LaxOption("level", str, "a", "level", choices=("a", "b"))), "options",
     "level='not-a-b' is outside one of a, b but was accepted"),
])
def test_check_generator_rejects_broken_methods(method, rule, detail):
    with pytest.raises(AssertionError, match=rf"rule '{rule}' broken.*{detail}"):
        check_generator(method)


def test_check_generator_rule_order_names_the_first():
    # a broken option is found before anything runs
    spec = _spec(GeneratorOption("level", int, 0, "level", low=1), function=raises_on_flat)
    with pytest.raises(AssertionError, match="rule 'options'"):
        check_generator(spec)


def test_check_generator_accepts_clean_refusals_and_reported_overruns():
    report = check_generator(refuses_flat)
    assert report["quad"]["triangles"] is None and report["sphere"]["triangles"] == 12
    assert check_generator(says_over_budget)["sphere"]["over_budget"] is True


def test_check_generator_refuses_a_closed_solid_refusal():
    def refuses_all(mesh, *, budget=None, seed=0):
        raise InputError("mesh: too round")

    with pytest.raises(AssertionError, match="rule 'non-empty output'.*refused a closed solid"):
        check_generator(refuses_all)


def test_check_generator_signature_it_cannot_call():
    def no_mesh(*, budget=None, seed=0):
        return None

    with pytest.raises(AssertionError, match="rule 'options'.*first parameter must be the mesh"):
        check_generator(no_mesh)
