"""Plugins: methods other packages register under the ``viscore.generators`` entry points.

Entry points are simulated (``importlib.metadata.EntryPoint`` objects pointing
at a module written to ``tmp_path``); the ``slow`` test installs the fixture
package of ``tests/plugin_fixture`` into a virtual environment for real.
"""

from __future__ import annotations

import importlib
import logging
import os
import subprocess
import textwrap
import venv
from importlib.metadata import EntryPoint
from pathlib import Path

import numpy as np
import pytest
import trimesh

from viscore import InputError
from viscore.cli.main import main
from viscore.generators import (
    REGISTRY,
    GeneratorSpec,
    Occluder,
    PluginError,
    generate,
    get_generator,
    plugin_versions,
    plugins,
    registry,
)

_PLUGIN_MODULE = '''
import numpy as np
import trimesh
from viscore.generators import GeneratorOption, GeneratorSpec, Occluder


def shrunk(mesh, *, budget=None, seed=0, scale: float = 0.5, mode: str = "centre",
           passes: int | None = None, keep_flat=False):
    """The mesh shrunk about its centre.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Input.
    scale : float, optional
        Shrink factor, a fraction
        of the size.

        Not this paragraph.
    mode : str, optional
        Where to shrink to.
    passes : int, optional
        Repeat count.
    """
    out = mesh.copy()
    out.apply_translation(-out.bounds.mean(axis=0))
    out.apply_scale(scale)
    out.apply_translation(mesh.bounds.mean(axis=0))
    out.metadata["conservative_guaranteed"] = False
    return out


def _spec_function(mesh, *, budget=None, seed=0, boxes=1):
    box = trimesh.creation.box(bounds=mesh.bounds)
    return Occluder(box, "spec-box", {"budget": budget, "seed": seed, "boxes": boxes},
                    double_sided=False, seconds=0.0)


spec_box = GeneratorSpec("spec-box", _spec_function, "the bounding box, by a spec",
                         options=(GeneratorOption("boxes", int, 1, "boxes", low=1, high=4),),
                         min_budget=12)


def nan_vertices(mesh, *, budget=None, seed=0):
    v = np.array(mesh.vertices, dtype=float)
    v[0] = np.nan
    return trimesh.Trimesh(v, mesh.faces, process=False)


def bad_indices(mesh, *, budget=None, seed=0):
    faces = np.array(mesh.faces)
    faces[0, 0] = len(mesh.vertices) + 5
    return trimesh.Trimesh(np.array(mesh.vertices), faces, process=False)


def everything(mesh, *, budget=None, seed=0):
    return mesh.copy()


def raising(mesh, *, budget=None, seed=0):
    return 1 / 0


def not_a_mesh(mesh, *, budget=None, seed=0):
    return [1, 2, 3]


def seen(mesh, *, budget=None, seed=0):
    seen.meshes.append(mesh)
    return mesh.copy()


seen.meshes = []

NOT_CALLABLE = 42
'''


@pytest.fixture
def plugin_env(tmp_path, monkeypatch):
    """A plugin module on sys.path, fake entry points, and the registry restored after."""
    name = f"vc_plugin_{abs(hash(tmp_path)) % 10**8}"
    (tmp_path / f"{name}.py").write_text(_PLUGIN_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delenv("VISCORE_NO_PLUGINS", raising=False)
    saved = (dict(REGISTRY._specs), REGISTRY._state)

    def install(*pairs: tuple[str, str], **entries: str):
        """Entry points ``name=MOD:attr`` (underscores become dashes) or (name, value) pairs."""
        items = [*pairs, *((k.replace("_", "-"), v) for k, v in entries.items())]
        eps = [EntryPoint(name=k, value=v.replace("MOD", name), group=registry.PLUGIN_GROUP)
               for k, v in items]
        monkeypatch.setattr(plugins, "_entry_points", lambda: eps)
        REGISTRY._rediscover()
        return importlib.import_module(name)

    yield install
    REGISTRY._specs, REGISTRY._state = saved


def _warnings(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records
            if r.levelno == logging.WARNING and r.name == plugins.__name__]


def test_plugin_function_options_from_signature_and_docstring(plugin_env):
    plugin_env(shrunk="MOD:shrunk")
    spec = REGISTRY["shrunk"]
    assert spec.plugin == (spec.function.__module__, "unknown")  # no distribution: fake EP
    assert spec.description == "The mesh shrunk about its centre."
    assert [o.name for o in spec.options] == ["scale", "mode", "passes", "keep_flat"]
    scale, mode, passes, keep_flat = spec.options
    assert (scale.type, scale.default, scale.help) == (float, 0.5,
                                                       "Shrink factor, a fraction of the size.")
    assert (mode.type, mode.default, mode.help) == (str, "centre", "Where to shrink to.")
    assert (passes.type, passes.default, passes.nullable) == (int, None, True)
    assert (keep_flat.type, keep_flat.help) == (bool, "keep flat")  # undocumented: its name
    assert spec.budgeted and spec.min_budget == 1 and not spec.conservative


def test_plugin_function_runs_through_generate(plugin_env):
    plugin_env(shrunk="MOD:shrunk")
    occ = generate("shrunk", trimesh.creation.box(), scale=0.25, seed=3)
    assert isinstance(occ, Occluder) and occ.method == "shrunk" and occ.triangles == 12
    assert np.allclose(occ.mesh.extents, 0.25)
    assert occ.params["scale"] == 0.25 and occ.params["seed"] == 3
    assert occ.info["conservative_guaranteed"] is False  # the mesh's metadata, as its claim
    assert occ.info["plugin"]["version"] == "unknown"
    with pytest.raises(InputError, match="scale: expected a number"):
        generate("shrunk", trimesh.creation.box(), scale="big")
    with pytest.raises(InputError, match="unknown option"):
        generate("shrunk", trimesh.creation.box(), nope=1)
    variant = generate("shrunk:scale=0.5", trimesh.creation.box())
    assert np.allclose(variant.mesh.extents, 0.5)


def test_plugin_spec_keeps_its_declaration(plugin_env):
    plugin_env(spec_box="MOD:spec_box")
    spec = get_generator("spec-box")
    assert spec.min_budget == 12 and spec.option("boxes").high == 4 and spec.plugin
    assert generate("spec-box", trimesh.creation.icosphere(), budget=12).triangles == 12
    with pytest.raises(InputError, match="boxes: expected an integer >= 1 and <= 4"):
        generate("spec-box", trimesh.creation.icosphere(), boxes=9)
    with pytest.raises(InputError, match="at least 12"):
        generate("spec-box", trimesh.creation.icosphere(), budget=4)


def test_plugin_that_fails_to_import_costs_one_line(plugin_env, caplog):
    plugin_env(broken="vc_no_such_module_anywhere:f", shrunk="MOD:shrunk",
               missing_attr="MOD:no_such_name", not_callable="MOD:NOT_CALLABLE")
    with caplog.at_level(logging.WARNING):
        names = list(REGISTRY)
    lines = _warnings(caplog)
    assert len(lines) == 3, lines
    assert all("\n" not in line for line in lines)
    broken = next(line for line in lines if "'broken'" in line)
    assert "cannot be loaded" in broken and "ModuleNotFoundError" in broken
    assert any("'missing-attr'" in line and "AttributeError" in line for line in lines)
    assert any("'not-callable'" in line and "not a GeneratorSpec or a function" in line
               for line in lines)
    assert "shrunk" in names and "broken" not in names and "bbox" in names
    assert generate("bbox", trimesh.creation.box()).triangles == 12
    assert generate("shrunk", trimesh.creation.box()).triangles == 12


def test_plugin_with_a_taken_name_costs_one_line(plugin_env, caplog):
    plugin_env(bbox="MOD:shrunk", shrunk="MOD:shrunk")
    with caplog.at_level(logging.WARNING):
        spec = REGISTRY["bbox"]
    lines = _warnings(caplog)
    assert spec.plugin is None and spec.function.__name__ == "generate_bbox"
    assert any("'bbox'" in line and "taken by a built-in method" in line for line in lines)
    assert generate("bbox", trimesh.creation.box()).info == {}  # the built-in, untouched


def test_two_plugins_with_one_name_keep_the_first(plugin_env, caplog):
    plugin_env(("twin", "MOD:shrunk"), ("twin", "MOD:everything"))
    with caplog.at_level(logging.WARNING):
        spec = REGISTRY["twin"]
    assert spec.function.function.__name__ == "everything"  # by value: the same everywhere
    lines = _warnings(caplog)
    assert len(lines) == 1 and "'twin'" in lines[0] and "taken by the plugin of" in lines[0]


def test_plugin_that_raises_is_one_error_and_others_keep_working(plugin_env, capsys,
                                                                  tmp_path):
    plugin_env(raising="MOD:raising", shrunk="MOD:shrunk")
    with pytest.raises(PluginError, match=r"plugin method 'raising' \(.* unknown\) raised "
                                          r"ZeroDivisionError: division by zero"):
        generate("raising", trimesh.creation.box())
    assert generate("shrunk", trimesh.creation.box()).triangles == 12
    mesh = tmp_path / "box.ply"
    trimesh.creation.box().export(mesh)
    code = main(["generate", "raising", str(mesh), "-o", str(tmp_path / "o.ply")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 3 and len(err) == 1 and "'raising'" in err[0], err
    assert main(["generate", "shrunk", str(mesh), "-o", str(tmp_path / "s.ply")]) == 0


@pytest.mark.parametrize(("entry", "message"), [
    ("nan_vertices", r"1 of \d+ vertices not finite"),
    ("bad_indices", r"faces indexing vertices outside"),
    ("not_a_mesh", r"returned a list, expected an Occluder or a trimesh.Trimesh"),
])
def test_plugin_output_is_checked(plugin_env, entry, message):
    plugin_env(**{entry: f"MOD:{entry}"})
    with pytest.raises(PluginError, match=message):
        generate(entry.replace("_", "-"), trimesh.creation.box())


def test_plugin_over_budget_is_flagged(plugin_env, caplog):
    plugin_env(everything="MOD:everything")
    with caplog.at_level(logging.WARNING):
        occ = generate("everything", trimesh.creation.icosphere(), budget=10)
    assert occ.triangles == 1280 and occ.info["over_budget"] is True
    assert any("exceed the budget of 10" in r.getMessage() for r in caplog.records)
    assert generate("everything", trimesh.creation.box(), budget=12).info["over_budget"] is False


def test_plugin_input_is_validated_before_the_call(plugin_env):
    module = plugin_env(seen="MOD:seen")
    bad = [trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=int), process=False),
           trimesh.Trimesh([[0, 0, 0], [np.nan, 0, 0], [0, 1, 0]], [[0, 1, 2]], process=False),
           trimesh.Trimesh([[0, 0, 0], [0, 0, 0], [0, 0, 0]], [[0, 1, 2]], process=False)]
    for mesh in bad:
        with pytest.raises(InputError):
            generate("seen", mesh)
    assert module.seen.meshes == []
    # a degenerate face among good ones is dropped before the plugin sees the mesh
    box = trimesh.creation.box()
    soup = trimesh.Trimesh(box.vertices, np.vstack([box.faces, [[0, 0, 1]]]), process=False)
    generate("seen", soup)
    assert len(module.seen.meshes) == 1 and len(module.seen.meshes[0].faces) == 12


def test_no_plugins_env_turns_discovery_off(plugin_env, monkeypatch):
    plugin_env(shrunk="MOD:shrunk")
    monkeypatch.setenv("VISCORE_NO_PLUGINS", "1")
    REGISTRY._rediscover()
    assert "shrunk" not in REGISTRY and "bbox" in REGISTRY
    with pytest.raises(InputError, match="unknown generator 'shrunk'"):
        get_generator("shrunk")


def test_discovery_runs_once(plugin_env, monkeypatch):
    plugin_env(shrunk="MOD:shrunk")
    calls = []
    eps = plugins._entry_points()
    monkeypatch.setattr(plugins, "_entry_points", lambda: calls.append(1) or eps)
    REGISTRY._rediscover()
    for _ in range(3):
        assert "shrunk" in REGISTRY and len(list(REGISTRY.items())) == len(REGISTRY)
    assert calls == [1]


def test_plugin_versions_for_provenance(plugin_env):
    plugin_env(shrunk="MOD:shrunk")
    versions = plugin_versions(["bbox", "shrunk:scale=0.5", "nope"])
    assert list(versions) == ["shrunk"] and versions["shrunk"]["version"] == "unknown"
    assert "shrunk" in plugin_versions() and "bbox" not in plugin_versions()


def test_generate_help_marks_plugin_methods(plugin_env, capsys):
    plugin_env(shrunk="MOD:shrunk")
    REGISTRY["shrunk"] = __import__("dataclasses").replace(REGISTRY["shrunk"],
                                                           plugin=("shrunk-pkg", "1.2.3"))
    assert main(["generate", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "shrunk The mesh shrunk about its centre. [plugin: shrunk-pkg 1.2.3]" in out
    assert main(["generate", "shrunk", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "--scale SCALE Shrink factor, a fraction of the size. (a number; default: 0.5)" \
        in out and "Plugin method from the shrunk-pkg 1.2.3 package." in out


def test_from_function_refuses_what_it_cannot_call():
    def no_default(mesh, *, budget=None, seed=0, level):
        return mesh

    def untyped_none(mesh, *, budget=None, seed=0, level=None):
        return mesh

    def list_default(mesh, *, budget=None, seed=0, levels=(1, 2)):
        return mesh

    def keyword_mesh(*, mesh, budget=None, seed=0):
        return mesh

    for function, message in [(no_default, "'level' has no default"),
                              (untyped_none, "defaults to None without an annotation"),
                              (list_default, "default of type tuple"),
                              (keyword_mesh, "first parameter must be the mesh")]:
        with pytest.raises(TypeError, match=message):
            GeneratorSpec.from_function(function)


def test_from_function_literal_choices_and_text_annotations():
    from typing import Literal

    def picky(mesh, *, budget=None, seed=0, mode: Literal["a", "b"] = "a",
              size: float | None = None):
        return mesh

    spec = GeneratorSpec.from_function(picky, "picky")
    mode, size = spec.options
    assert mode.choices == ("a", "b") and (size.type, size.nullable) == (float, True)
    with pytest.raises(InputError, match="one of a, b"):
        spec.check_params({"mode": "c"})


def test_function_without_budget_is_not_budgeted():
    def fixed(mesh, seed=0):
        return mesh.copy()

    spec = GeneratorSpec.from_function(fixed)
    assert not spec.budgeted
    assert spec.function(trimesh.creation.box(), budget=3).triangles == 12  # budget not passed


# --------------------------------------------------------------------------- real install

_FIXTURE = Path(__file__).parent / "plugin_fixture"


@pytest.mark.slow
def test_installed_plugin_is_listed_with_its_package_and_version(tmp_path):
    env = tmp_path / "venv"
    venv.EnvBuilder(system_site_packages=True, with_pip=False).create(env)
    python = env / "bin" / "python"
    build = tmp_path / "src"
    # a copy, so that the build leaves nothing in the repository
    subprocess.run(["cp", "-r", str(_FIXTURE), str(build)], check=True)
    run_env = {k: v for k, v in os.environ.items() if k != "VISCORE_NO_PLUGINS"}
    pip = [str(python), "-m", "pip", "install", "--no-deps", "--quiet"]
    # offline with the environment's own setuptools and wheel; else an isolated build
    # (its setuptools from the configured package index)
    done = subprocess.run([*pip, "--no-index", "--no-build-isolation", str(build)],
                          capture_output=True, text=True, timeout=600, env=run_env)
    if done.returncode != 0:
        done = subprocess.run([*pip, str(build)], capture_output=True, text=True,
                              timeout=600, env=run_env)
    assert done.returncode == 0, done.stderr[-2000:]
    viscore_cmd = [str(python), "-m", "viscore.cli.main"]
    listed = subprocess.run([*viscore_cmd, "generate", "--help"], capture_output=True,
                            text=True, timeout=600, env=run_env)
    assert listed.returncode == 0, listed.stderr
    text = " ".join(listed.stdout.split())
    assert "hull-box The mesh's bounding box shrunk about its centre. [plugin: " \
           "viscore-plugin-fixture 0.3.1]" in text, listed.stdout
    assert "fixture-spec the bounding box, declared by a GeneratorSpec [plugin: " \
           "viscore-plugin-fixture 0.3.1]" in text, listed.stdout
    assert listed.stderr == ""
    out, mesh = tmp_path / "o.ply", tmp_path / "box.ply"
    trimesh.creation.box().export(mesh)
    made = subprocess.run([*viscore_cmd, "generate", "hull-box", str(mesh), "-o", str(out),
                           "--json"], capture_output=True, text=True, timeout=600, env=run_env)
    assert made.returncode == 0, made.stderr
    assert '"package": "viscore-plugin-fixture"' in made.stdout and out.exists()
    off = subprocess.run([*viscore_cmd, "generate", "--help"], capture_output=True, text=True,
                         timeout=600, env={**run_env, "VISCORE_NO_PLUGINS": "1"})
    assert off.returncode == 0 and "hull-box" not in off.stdout
    check = subprocess.run([str(python), "-c", textwrap.dedent("""
        from viscore.generators import check_generator
        print(sorted(check_generator("hull-box", scenes=["sphere", "quad"])))
        print(sorted(check_generator("fixture-spec")))
        """)], capture_output=True, text=True, timeout=600, env=run_env)
    assert check.returncode == 0 and "sphere" in check.stdout, check.stderr


def test_compare_records_plugin_methods_in_its_provenance(plugin_env, tmp_path, capsys):
    """A study's provenance names each plugin method's distribution and version."""
    import json

    module = plugin_env(shrunk="MOD:shrunk")
    out = tmp_path / "study"
    code = main(["compare", "cow", "--methods", "bbox,shrunk", "--budget", "64", "--views", "4",
                 "--quads", "200", "--rays", "500", "--res", "32",
                 "--no-culling", "--quiet", "--json", "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    doc = json.loads(capsys.readouterr().out)
    assert doc["provenance"]["plugins"] == {
        "shrunk": {"package": module.__name__, "version": "unknown"}}
    assert {row["method"] for row in doc["rows"]} == {"bbox", "shrunk"}
    stored = json.loads((out / "results.json").read_text())
    assert stored["provenance"]["plugins"] == doc["provenance"]["plugins"]
