"""Run every docstring example of the installed ``viscore`` package once.

The doctests are collected through the import names users see
(``viscore.metrics.orbit``, not ``metrics.orbit``), so that each module is
imported once, under one name.
"""

import doctest
import importlib
import pkgutil

import pytest

import viscore


def _module_names() -> list[str]:
    names = ["viscore"]
    for info in pkgutil.walk_packages(viscore.__path__, prefix="viscore."):
        names.append(info.name)
    for sub in ("metrics", "generators", "cli"):
        package = importlib.import_module(f"viscore.{sub}")
        names += [info.name for info in pkgutil.walk_packages(package.__path__,
                                                              prefix=f"viscore.{sub}.")]
    return sorted(set(names))


MODULES = _module_names()


def test_doctest_modules_cover_the_subpackages():
    assert {"viscore.metrics.orbit", "viscore.generators.registry",
            "viscore.ray.embree_scene"} <= set(MODULES)


@pytest.mark.parametrize("name", MODULES)
def test_doctests(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
                             verbose=False, report=True)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"
