"""Sphinx configuration: the pages of docs/ (Markdown through myst-parser) and the API
reference of the package faces, generated from their ``__all__`` at each build.

Build (warnings are errors; the second command runs the worked examples)::

    sphinx-build -W --keep-going -b html -d docs/_build/doctrees docs docs/_build/html
    sphinx-build -W --keep-going -b doctest -d docs/_build/doctrees docs docs/_build/doctest
"""

from __future__ import annotations

import importlib
import inspect
from pathlib import Path

import viscore

project = "viscore"
author = "viscore developers"
copyright = "viscore developers"  # noqa: A001 (Sphinx's setting name)
release = viscore.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.doctest",
    "sphinx.ext.extlinks",
    "sphinx.ext.mathjax",
    "numpydoc",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build"]
root_doc = "index"
html_theme = "alabaster"
html_static_path: list[str] = []

# Markdown: $...$ math in protocols.md, anchors for its section links
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3

# docstrings cite papers as :DOI:`10.xxxx/yyyy` (scikit-image's role)
extlinks = {"DOI": ("https://doi.org/%s", "DOI: %s")}

# numpydoc: no member tables of its own (the API pages list members), and the
# docstrings' cross references stay plain text where they name private objects
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

autodoc_default_options = {"members": False}
autodoc_typehints = "none"  # the signatures show the hints; numpydoc writes the types
autosummary_generate = False

# the worked examples are `doctest` directives; the docstrings' own examples are run by
# the test suite (tests/test_doctests.py), not again here
doctest_test_doctest_blocks = ""
doctest_global_setup = "import numpy as np\nimport viscore"

#: The package faces documented, in the order a name is given its home: a name
#: re-exported by a later face links to the first face that offers it.
FACES = [
    ("viscore.ray", "Rays and cameras"),
    ("viscore.exchange", "Mesh and engine files"),
    ("viscore.level", "Levels"),
    ("viscore.voxel", "Voxels"),
    ("viscore.culling", "Culling runtimes"),
    ("viscore", "The core's face"),
    ("viscore.metrics", "Metrics"),
    ("viscore.generators.levels", "A level's occluders"),
    ("viscore.generators", "Generators"),
]

API = Path(__file__).parent / "api"


def _kind(obj: object) -> str:
    if inspect.isclass(obj):
        return "class"
    if callable(obj):
        return "function"
    return "data"


def _face_page(face: str, title: str, home: dict[tuple[str, int], str]) -> str:
    module = importlib.import_module(face)
    own, elsewhere = [], []
    for name in module.__all__:
        obj = getattr(module, name)
        key = (name, id(obj))
        if home.setdefault(key, face) == face:
            own.append((name, obj))
        else:
            elsewhere.append((name, home[key]))
    lines = [f"{face}: {title}", "=" * (len(face) + len(title) + 2), "",
             f".. automodule:: {face}", "   :no-members:", "",
             f".. currentmodule:: {face}", ""]
    if own:
        lines += [".. autosummary::", ""] + [f"   {name}" for name, _ in own] + [""]
    if elsewhere:
        lines += ["Also offered here, documented with the face that holds them:", ""]
        lines += [f"- :py:obj:`{name} <{where}.{name}>` (:mod:`{where}`)"
                  for name, where in elsewhere]
        lines.append("")
    for name, obj in own:
        kind = _kind(obj)
        lines.append(f".. auto{kind}:: {name}")
        if kind == "class":
            lines.append("   :members:")
        lines.append("")
    return "\n".join(lines)


def write_api_pages(app=None) -> None:
    """Write api/<face>.rst for every face from its ``__all__`` (the pages are not kept
    in git: a face that changes changes its page)."""
    API.mkdir(exist_ok=True)
    home: dict[tuple[str, int], str] = {}
    index = ["API reference", "=============", "",
             "One page per package face: the names a user imports.", "",
             ".. toctree::", "   :maxdepth: 1", ""]
    for face, title in FACES:
        page = _face_page(face, title, home)
        path = API / f"{face}.rst"
        if not path.exists() or path.read_text(encoding="utf-8") != page:
            path.write_text(page, encoding="utf-8")
        index.append(f"   {face}")
    text = "\n".join(index) + "\n"
    path = API / "index.rst"
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def setup(app):
    app.connect("builder-inited", write_api_pages)
