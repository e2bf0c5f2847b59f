"""docs/extending.md stays true: its worked method keeps the contract, its package names it."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from viscore.generators import GeneratorSpec
from viscore.generators.testing import check_generator

DOC = Path(__file__).resolve().parents[1] / "docs" / "extending.md"


def _blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", DOC.read_text(encoding="utf-8"), flags=re.S)


def test_worked_method_passes_the_checker_and_claims_its_guarantee():
    code = _blocks("python")[0]
    assert len(code.strip().splitlines()) <= 40  # "a worked method in under 40 lines"
    namespace: dict = {}
    exec(compile(code, str(DOC), "exec"), namespace)
    method = namespace["inscribed_sphere"]
    report = check_generator(method)
    assert report["sphere"]["conservative_guaranteed"] is True
    assert report["open-sphere"]["conservative_guaranteed"] is False
    assert report["quad"]["triangles"] == 0  # nothing inside an open sheet
    spec = GeneratorSpec.from_function(method, "inscribed-sphere")
    assert [o.name for o in spec.options] == ["samples", "margin"]


def test_package_declares_the_entry_point_of_the_worked_method():
    toml = tomllib.loads(_blocks("toml")[0])
    points = toml["project"]["entry-points"]["viscore.generators"]
    assert points == {"inscribed-sphere": "inscribed_sphere.occluders:inscribed_sphere"}
    assert "def inscribed_sphere(" in _blocks("python")[0]
