"""The house keeps its structure: the import chain, no circles, families apart, the doc true.

Read from the source with :mod:`ast` (imports inside functions count), so a
circle hidden by a deferred import fails here too. DESIGN.md's chain is
``viscore <- viscore.metrics <- viscore.generators <- viscore.cli``: the core
imports none of the others, metrics never imports generators or cli, and
generators never import cli. Method families (the folders under
``generators/``) never import each other. The command line takes the library
through the packages' faces only (the names on a package's ``__all__``, the
core's shared helpers aside), and a subcommand or a benchmark imports no other
subcommand's module.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Source folder -> installed package name (pyproject.toml's package-dir mapping).
PACKAGES = {"viscore": "viscore", "metrics": "viscore.metrics",
            "generators": "viscore.generators", "cli": "viscore.cli"}

#: Rank of each package in the import chain: a module may import only packages of
#: equal or lower rank.
RANK = {"viscore": 0, "viscore.metrics": 1, "viscore.generators": 2, "viscore.cli": 3}


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = [PACKAGES[rel.parts[0]], *rel.parts[1:]]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    found = {}
    for folder in PACKAGES:
        for path in sorted((ROOT / folder).rglob("*.py")):
            if "__pycache__" not in path.parts:
                found[_module_name(path)] = path
    return found


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """Modules of ours that ``name`` imports anywhere in its source."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        targets = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(up + ([base] if base else []))
            targets = [f"{base}.{alias.name}" for alias in node.names] + [base]
        for target in targets:
            while target and target not in known:
                target = target.rpartition(".")[0]
            if target and target != name:
                out.add(target)
    return out


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    known = set(modules)
    graph = {name: _imports(name, path, known) for name, path in modules.items()}
    # a package face re-exporting its own submodules is not an arrow of the house
    return {name: {t for t in targets if not (modules[name].name == "__init__.py"
                                              and t.startswith(name + "."))}
            for name, targets in graph.items()}


def _package(module: str) -> str:
    for package in sorted(RANK, key=len, reverse=True):
        if module == package or module.startswith(package + "."):
            return package
    raise AssertionError(module)


def test_no_import_circle_between_modules():
    graph = _graph()
    index, low, on_stack, stack, circles = {}, {}, set(), [], []
    counter = [0]

    def visit(v):  # Tarjan's strongly connected components, iteratively deep enough here
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert not circles, f"import circles: {circles}"


def test_imports_follow_the_chain():
    wrong = [f"{a} -> {b}" for a, targets in _graph().items() for b in targets
             if RANK[_package(b)] > RANK[_package(a)]]
    assert not wrong, f"imports against viscore <- metrics <- generators <- cli: {wrong}"


#: The core's folders in the order they stand on each other: a folder imports only
#: folders of lower rank (and the core's top-level helpers).
CORE_RANK = {"ray": 0, "exchange": 0, "voxel": 1, "level": 2, "culling": 3}


#: Arrows from a top-level helper down into a core folder, each with its reason.
HELPER_ARROWS = {
    # a pool worker sets its ray threads (set_workers) as it starts (worker_init)
    ("viscore._jobs", "viscore.ray.embree_scene"),
}


def test_core_folders_stand_on_each_other_in_order():
    def folder(module: str) -> str | None:
        parts = module.split(".")
        return parts[1] if len(parts) > 2 and parts[0] == "viscore" and \
            parts[1] in CORE_RANK else None

    present = {p.name for p in (ROOT / "viscore").iterdir() if (p / "__init__.py").is_file()}
    assert set(CORE_RANK) <= present
    wrong = [f"{a} -> {b}" for a, targets in _graph().items() for b in targets
             if folder(a) and folder(b) and folder(a) != folder(b)
             and CORE_RANK[folder(b)] >= CORE_RANK[folder(a)]]
    assert not wrong, f"core folders import against {CORE_RANK}: {wrong}"
    # the shared helpers (_validate, _atomic, ...) and constants stand under every
    # folder: none of them imports one (the alias table, and the arrows named in
    # HELPER_ARROWS, aside)
    up = [f"{a} -> {b}" for a, targets in _graph().items() for b in targets
          if a.count(".") == 1 and a.startswith(("viscore._", "viscore.constants"))
          and folder(b) and a != "viscore._moved" and (a, b) not in HELPER_ARROWS]
    assert not up, f"top-level helpers import a core folder: {up}"


#: Folders of ``generators/`` that compose the families rather than being one: ``levels/``
#: runs the registered methods over a level's objects (and cuts a hierarchy per frame),
#: as the registry composes them; no family imports it.
COMPOSERS = {"levels"}


def test_method_families_never_import_each_other():
    families = sorted(p.name for p in (ROOT / "generators").iterdir()
                      if p.is_dir() and not p.name.startswith(("_", ".")) and
                      (p / "__init__.py").is_file() and p.name not in COMPOSERS)
    assert {"aabb_skins", "planar_sections", "hybrid", "solid_frusta", "baselines"} <= set(families)
    assert COMPOSERS <= {p.name for p in (ROOT / "generators").iterdir() if p.is_dir()}

    def family(module: str) -> str | None:
        parts = module.split(".")
        return parts[2] if len(parts) > 2 and parts[:2] == ["viscore", "generators"] \
            and parts[2] in families else None

    graph = _graph()
    crossing = [f"{a} -> {b}" for a, targets in graph.items() for b in targets
                if family(a) and family(b) and family(a) != family(b)]
    assert not crossing, f"families import each other: {crossing}"
    composer = tuple(f"viscore.generators.{c}" for c in COMPOSERS)
    up = [f"{a} -> {b}" for a, targets in graph.items() for b in targets
          if family(a) and (b in composer or b.startswith(tuple(c + "." for c in composer)))]
    assert not up, f"families import what composes them: {up}"


def test_cli_imports_no_private_library_name():
    """Besides the core's shared helpers (validators, atomic writes), cli uses public names."""
    shared = {"viscore._validate", "viscore._atomic", "viscore._jobs"}
    offending = []
    for name, path in _modules().items():
        if not name.startswith("viscore.cli"):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and not node.level:
                module = node.module
                if not module.startswith("viscore") or module.startswith("viscore.cli"):
                    continue
                private_module = any(p.startswith("_") for p in module.split(".")[1:])
                if module in shared:
                    continue
                if private_module or any(a.name.startswith("_") for a in node.names):
                    offending.append(f"{path.relative_to(ROOT)}: {module}")
    assert not offending, offending


@pytest.mark.parametrize("folder", sorted(PACKAGES))
def test_layout_doc_names_every_module(folder):
    """docs/layout.md has a line for every library module (a family folder counts once)."""
    doc = (ROOT / "docs" / "layout.md").read_text(encoding="utf-8")
    named = set(re.findall(r"[\w/]+\.py|[\w]+/", doc))
    missing = []
    for path in sorted((ROOT / folder).glob("*.py")):
        if path.name != "__init__.py" and path.name not in named:
            missing.append(str(path.relative_to(ROOT)))
    for sub in sorted(p for p in (ROOT / folder).iterdir() if (p / "__init__.py").is_file()):
        if f"{sub.name}/" not in named:
            missing.append(f"{sub.relative_to(ROOT)}/")
    assert not missing, f"docs/layout.md does not name: {missing}"


def test_pyproject_installs_every_package():
    """A non-editable install (``pip install .``) ships every folder with an
    ``__init__.py``: pyproject.toml lists packages by hand, and a family missing from
    the list imports in an editable install but not in a wheel."""
    import tomllib

    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
                 ["tool"]["setuptools"]["packages"])
    found = {_module_name(init) for folder in PACKAGES
             for init in (ROOT / folder).rglob("__init__.py")}
    assert found - listed == set(), "add these to [tool.setuptools] packages"


#: The core's shared helpers the command line may import from (STYLE rule 3).
SHARED = {"viscore._validate", "viscore._atomic", "viscore._jobs"}


def _from_imports(name: str, path: Path) -> list[tuple[str, list[str], int]]:
    """``(module, names, line)`` of each import in a module, relative ones made absolute."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(alias.name, [], node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(up + ([base] if base else []))
            out.append((base, [alias.name for alias in node.names], node.lineno))
    return out


def _face_names(modules: dict[str, Path], package: str) -> set[str]:
    """The names a package's face lists in its ``__all__`` (read from its source)."""
    tree = ast.parse(modules[package].read_text(encoding="utf-8"))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Assign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                names |= set(ast.literal_eval(node.value))
    return names


def test_cli_imports_the_library_through_its_faces():
    """A CLI module names a package (a face), never one of its modules, and only names on
    the face's ``__all__``; the core's shared helpers aside."""
    modules = _modules()
    faces = {name for name, path in modules.items() if path.name == "__init__.py"}
    wrong = []
    for name, path in modules.items():
        if not name.startswith("viscore.cli"):
            continue
        for target, names, line in _from_imports(name, path):
            if not target.startswith("viscore") or target.startswith("viscore.cli") \
                    or target in SHARED:
                continue
            where = f"{path.relative_to(ROOT)}:{line}: {target}"
            if target not in faces:
                wrong.append(f"{where} (a module, not a face)")
                continue
            missing = sorted(set(names) - _face_names(modules, target))
            if missing:
                wrong.append(f"{where}: {', '.join(missing)} not on its __all__")
    assert not wrong, "CLI imports past the faces:\n" + "\n".join(wrong)


#: What every command-line module may import of ``cli/``: the shared helpers and the
#: report pages (presentation, shared by cull, occlude and compare).
CLI_SHARED = ("viscore.cli._common", "viscore.cli.report")

#: A subcommand module's own subpackage (``compare``'s study runner).
OWN_SUBPACKAGE = {"viscore.cli.compare_cmd": "viscore.cli.study"}


def test_cli_modules_import_no_benchmark_nor_another_subcommand():
    """``cli/*_cmd.py`` and ``cli/bench/*`` (and the study runner) import, of the command
    line, only ``cli/_common.py``, the report pages and their own subpackage: library code
    a subcommand needs from a benchmark or another subcommand belongs in the library."""
    modules = _modules()
    wrong = []
    for name, path in modules.items():
        if not name.startswith("viscore.cli.") or name == "viscore.cli.main":
            continue
        parts = name.split(".")
        own = ".".join(parts[:3]) if len(parts) > 3 or path.name == "__init__.py" \
            else OWN_SUBPACKAGE.get(name)
        for target, names, line in _from_imports(name, path):
            if not target.startswith("viscore.cli"):
                continue
            targets = {target} if target != "viscore.cli" else {f"{target}.{n}" for n in names}
            for t in targets:
                if t in CLI_SHARED or t.startswith("viscore.cli.report.") or (own and (t == own or
                                                           t.startswith(own + "."))):
                    continue
                wrong.append(f"{path.relative_to(ROOT)}:{line}: {t}")
    assert not wrong, "CLI modules import another subcommand or a benchmark:\n" + \
        "\n".join(wrong)
