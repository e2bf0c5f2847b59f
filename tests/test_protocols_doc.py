"""docs/protocols.md stays true to the code: defaults, names, citations and seed streams.

The document's defaults table names, per row, the code that holds the default
(``module:function:parameter`` or ``module:CONSTANT``, optionally ``[key]``);
changing a default without the document fails here, and so does a new keyword
default of a tabled function that the table does not list.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import math
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh

DOC = Path(__file__).resolve().parents[1] / "docs" / "protocols.md"

#: Functions whose every non-None keyword default must be in the table.
REQUIRED = {
    "viscore.metrics.orbit:orbit_precision_recall",
    "viscore.metrics.volume:volume_precision_recall",
    "viscore.metrics.reference_views:ReferenceViews",
    "viscore.metrics.erosion:occlusion_measure",
    "viscore.metrics.conservativeness:check_conservative",
    "viscore.metrics.bootstrap:bootstrap_ratio",
}


def _doc() -> str:
    return DOC.read_text(encoding="utf-8")


def _table() -> list[dict]:
    text = _doc()
    start = text.index("<!-- defaults-table")
    end = text.index("<!-- end defaults-table -->")
    header, rows = None, []
    for line in text[start:end].splitlines():
        if not line.startswith("|"):
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if header is None:
            header = cells
        elif not all(set(c) <= set("-: ") for c in cells):
            rows.append(dict(zip(header, cells, strict=True)))
    return rows


def _value(text: str):
    """The table's default: a Python literal, thousands separators allowed."""
    text = re.sub(r"(?<=\d),(?=\d{3}\b)", "", text.strip("` "))
    return ast.literal_eval(text)


def _split(code: str) -> tuple[str, str, str, str | None]:
    """module, name, key (or ''), parameter (or None)."""
    parts = code.strip("` ").split(":")
    assert len(parts) in (2, 3), code
    m = re.fullmatch(r"(\w+)(?:\[(\w+)\])?", parts[1])
    assert m, code
    return parts[0], m[1], m[2] or "", parts[2] if len(parts) == 3 else None


def _code_default(code: str):
    module, name, key, param = _split(code)
    obj = getattr(importlib.import_module(module), name)
    if param is None:
        return obj[key] if key else obj
    p = inspect.signature(obj).parameters[param]
    assert p.default is not inspect.Parameter.empty, f"{code}: no default"
    return p.default


def _same(doc, code) -> bool:
    if doc is None or code is None:  # a default decided at run time
        return doc is code
    if isinstance(doc, (bool, str, tuple)) or isinstance(code, (bool, str, tuple)):
        return type(doc) is type(code) and doc == code
    return math.isclose(doc, code, rel_tol=1e-12, abs_tol=0.0)


def test_defaults_table_matches_code():
    rows = _table()
    assert len(rows) >= 40
    wrong = []
    for row in rows:
        doc, code = _value(row["default"]), _code_default(row["code"])
        if not _same(doc, code):
            wrong.append(f"{row['code']}: document {doc!r}, code {code!r}")
    assert not wrong, "docs/protocols.md defaults differ from the code:\n" + "\n".join(wrong)


def test_defaults_table_lists_every_keyword_default():
    listed: dict[str, set] = {}
    for row in _table():
        module, name, _, param = _split(row["code"])
        if param is not None:
            listed.setdefault(f"{module}:{name}", set()).add(param)
    assert REQUIRED <= set(listed), sorted(REQUIRED - set(listed))
    missing = []
    for target, params in listed.items():
        module, name = target.split(":")
        obj = getattr(importlib.import_module(module), name)
        for p in inspect.signature(obj).parameters.values():
            if p.default is not inspect.Parameter.empty and p.default is not None \
                    and p.name not in params:
                missing.append(f"{target}:{p.name} = {p.default!r}")
    assert not missing, "defaults missing from docs/protocols.md: " + ", ".join(missing)


def _resolve(dotted: str):
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise ImportError(dotted)


def test_every_viscore_name_in_the_document_resolves():
    names = set(re.findall(r"`(viscore(?:\.\w+)+)(?:\(\))?`", _doc()))
    assert len(names) >= 20
    broken = []
    for name in sorted(names):
        try:
            _resolve(name)
        except (ImportError, AttributeError) as exc:
            broken.append(f"{name} ({exc})")
    assert not broken, "names in docs/protocols.md that do not resolve: " + ", ".join(broken)


def test_every_doi_of_the_document_is_cited_in_the_code():
    references = _doc().split("## References", 1)[1].split("\n---", 1)[0]
    dois = set(re.findall(r"DOI: \[(10\.[^\]]+)\]", references))
    assert len(dois) >= 10
    source = ""
    for package in ("viscore", "viscore.metrics", "viscore.generators", "viscore.cli"):
        folder = Path(importlib.import_module(package).__file__).parent
        source += "".join(p.read_text(encoding="utf-8") for p in folder.rglob("*.py"))
    assert not sorted(d for d in dois if d not in source)


# ---------------------------------------------------------------- seed streams (section 1)
def _box():
    return trimesh.creation.box()


def test_orbit_directions_and_quads_come_from_the_documented_streams():
    from viscore.metrics import ReferenceViews, sample_quads

    seed, n, q = 7, 3, 50
    views = ReferenceViews(_box(), views=n, quads=q, resolution=32, seed=seed)
    u = np.random.default_rng(seed).random((n, 2))
    z, phi = 2 * u[:, 0] - 1, 2 * np.pi * u[:, 1]
    s = np.sqrt(1 - z * z)
    assert np.array_equal(views.directions,
                          np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1))
    depth = views.depth_images()
    children = np.random.SeedSequence(seed).spawn(n)
    for k in range(n):
        covered = np.isfinite(depth[k])
        rows, cols = np.flatnonzero(covered.any(1)), np.flatnonzero(covered.any(0))
        box = (rows[0], cols[0], rows[-1] + 1, cols[-1] + 1)
        expected = sample_quads(box, q, np.random.default_rng(children[k]))
        assert np.array_equal(views.quads(k), expected)


def test_volume_quads_run_through_the_frusta_of_a_position():
    from viscore.metrics import ReferenceViews, sample_quads

    seed, q, res = 3, 20, 8
    views = ReferenceViews(_box(), protocol="volume", quads=q, resolution=res, spacing=0.5,
                           seed=seed)
    images = views.images
    unit = int(images[0, 0])
    own = np.flatnonzero(images[:, 0] == unit)
    assert len(own) >= 2
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(len(views.weights))[unit])
    for j in own:  # one generator, continued in frustum order
        assert np.array_equal(views.quads(int(j)), sample_quads((0, 0, res, res), q, rng))


def test_pooling_and_bootstrap_as_documented():
    from viscore import stream_seed
    from viscore.metrics import ReferenceViews, bootstrap_ratio

    small = _box()
    small.apply_scale(0.7)
    orbit = ReferenceViews(_box(), views=6, quads=100, resolution=24, seed=5).score(small)
    pv = orbit.per_view
    nt, pf, nf = (np.asarray(pv[k], float) for k in ("nt", "pf", "nf"))
    assert orbit.recall == pytest.approx(nt.sum() / (nt + pf).sum(), rel=1e-12)
    assert orbit.precision == pytest.approx(nt.sum() / (nt + nf).sum(), rel=1e-12)
    assert orbit.recall_ci == list(bootstrap_ratio(nt, nt + pf, seed=stream_seed(5, "bootstrap")))
    volume = ReferenceViews(_box(), protocol="volume", quads=30, resolution=8, spacing=0.5,
                            seed=5).score(small)
    r, w = np.asarray(volume.per_view["recall"], float), np.asarray(volume.per_view["weight"])
    ok = np.isfinite(r)
    assert ok.any() and volume.recall == pytest.approx((w[ok] * r[ok]).sum() / w[ok].sum())


def test_depth_levels_are_midpoints_of_the_originals_depth_range():
    from viscore.metrics import ReferenceViews

    levels = 4
    views = ReferenceViews(_box(), views=2, quads=200, resolution=24, depth_aware=True,
                           depth_levels=levels, seed=1)
    depth = views.depth_images()[0]
    lo, hi = depth[np.isfinite(depth)].min(), depth[np.isfinite(depth)].max()
    expected = lo + (hi - lo) * (np.arange(levels) + 0.5) / levels
    got = np.unique(views.quad_depths(0))
    assert len(got) == levels  # 200 uniform draws hit all four levels
    assert np.allclose(got, expected, rtol=1e-5)  # the images are float32 copies
