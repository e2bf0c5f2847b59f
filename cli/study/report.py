"""What people look at after ``viscore compare``: ``report.html`` and a ``.glb`` per occluder.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (orbit protocol, sec. 6.1;
   occlusion measure, sec. 3).
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (volume protocol, sec. 3.2).
.. [3] Efron, B. "Better Bootstrap Confidence Intervals". Journal of the
   American Statistical Association 82(397), 1987.
   :DOI:`10.1080/01621459.1987.10478410`
.. [4] Clopper, C.J., Pearson, E.S. "The use of confidence or fiducial limits
   illustrated in the case of the binomial". Biometrika 26(4), 1934.
   :DOI:`10.1093/biomet/26.4.404`
.. [5] The Khronos Group. "glTF 2.0 Specification", 2021
   (materials: ``alphaMode``, ``doubleSided``, ``pbrMetallicRoughness``).
"""

from __future__ import annotations

import base64
import dataclasses
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from markupsafe import Markup

from viscore import InputError
from viscore.exchange import with_buffer_view_targets

from .._common import write_atomic
from ..report.page import render_page
from .store import OCCLUDER_DIR

__all__ = ["write_report", "write_occluder_glb", "write_occluder_glbs", "best_at_precision",
           "CULLING_COLUMNS", "REPORT_COLUMNS", "PAIRED_COLUMNS", "SUMMARY_COLUMNS",
           "SUMMARY_PRECISION", "ORIGINAL_RGBA", "OCCLUDER_RGBA"]

#: Precision a method must reach (point estimate) to be named in the page's summary:
#: the question every study asks is the highest recall at precision >= this.
SUMMARY_PRECISION = 0.995

#: Columns of the results table: (row key, header). A ``*_ci`` key shows as an
#: interval; the columns follow ``viscore.cli.study.tables.TABLE_COLUMNS``.
REPORT_COLUMNS = (
    ("mesh", "mesh"), ("method", "method"), ("budget", "budget"), ("triangles", "triangles"),
    ("precision", "precision"), ("precision_ci", "precision 95% interval"),
    ("recall", "recall"), ("recall_ci", "recall 95% interval"),
    ("occlusion_measure", "occlusion measure"), ("occlusion_measure_se", "s.e."),
    ("violation_upper_bound", "violation upper bound"), ("seconds", "seconds"),
)

#: Columns of the summary table (:func:`best_at_precision`'s rows): (key, header).
SUMMARY_COLUMNS = (
    ("mesh", "mesh"), ("budget", "budget"), ("method", "best method"),
    ("triangles", "triangles"), ("recall", "recall"), ("recall_ci", "recall 95% interval"),
    ("precision", "precision"), ("guaranteed", "conservative guarantee"),
    ("violation_upper_bound", "violation upper bound"),
)

#: Columns of the paired comparisons: (row key, header).
PAIRED_COLUMNS = (
    ("mesh", "mesh"), ("method", "method"), ("budget", "budget"), ("versus", "versus"),
    ("versus_budget", "versus budget"), ("recall_diff", "recall difference"),
    ("recall_diff_ci", "95% interval"), ("prob_better_recall", "P(better recall)"),
    ("precision_diff", "precision difference"), ("precision_diff_ci", "95% interval"),
    ("prob_better_precision", "P(better precision)"),
)

#: Columns of the culling table (``viscore compare``'s culling column): (row key, header).
CULLING_COLUMNS = (
    ("method", "method"), ("culled_share", "culled share"), ("false_culls", "false culls"),
    ("conservative", "conservative"), ("overhead_ms", "overhead ms per frame"),
)

#: glTF base colour (linear RGBA in [0, 1]) of the original: grey, translucent.
ORIGINAL_RGBA = (0.6, 0.6, 0.6, 0.35)
#: glTF base colour of the occluder: orange, opaque.
OCCLUDER_RGBA = (0.95, 0.45, 0.1, 1.0)

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _count(n: int, one: str, many: str | None = None) -> str:
    return f"{n} {one if n == 1 else (many or one + 's')}"


def _guaranteed(row: Mapping) -> bool | None:
    """Whether a row's occluder carries the conservativeness guarantee, None if unknown.

    The generator's own word when the row records it
    (``info["conservative_guaranteed"]``: aabb-skins, solid-frusta and
    planar-sections say False on an open or inconsistently oriented mesh);
    otherwise the registry's ``conservative`` flag of the method (a promise
    on closed meshes); None for a method the registry does not know.
    """
    info = row.get("info")
    if isinstance(info, Mapping) and info.get("conservative_guaranteed") is not None:
        return bool(info["conservative_guaranteed"])
    try:
        from viscore.generators import get_generator

        return bool(get_generator(str(row.get("method"))).conservative)
    except Exception:  # an unknown or renamed method: say so rather than guess
        return None


def _study_budgets(rows: Sequence[Mapping], budgets: Sequence[int] | None) -> list:
    if budgets:
        return sorted({int(b) for b in budgets})
    found = sorted({int(r["budget"]) for r in rows if r.get("budget") is not None})
    return found or [None]


def _finite(value) -> float | None:
    if value is None or isinstance(value, (bool, np.bool_)):
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def best_at_precision(rows: Sequence[Mapping], *, budgets: Sequence[int] | None = None,
                      precision: float = SUMMARY_PRECISION) -> list[dict]:
    """For each mesh and budget, the method of highest recall among those of precision >= a floor.

    Parameters
    ----------
    rows : sequence of dict
        Study rows (``mesh``, ``method``, ``budget``, ``triangles``,
        ``precision``, ``recall``; optional ``recall_ci``,
        ``violation_upper_bound``, ``info``).
    budgets : sequence of int, optional
        The study's budgets. Default: those found in the rows (one group per
        mesh, budget None, when no row has one).
    precision : float, optional
        The precision floor (point estimate). Default :data:`SUMMARY_PRECISION`.

    Returns
    -------
    summary : list of dict
        One per (mesh, budget), meshes in order of appearance, budgets
        ascending, keyed as :data:`SUMMARY_COLUMNS` plus ``winners`` (the
        indices into ``rows`` of the named methods) and ``candidates`` (how
        many rows were eligible). ``method`` is None when no eligible row
        reaches the floor; tied recalls name every tied method, fewest
        triangles first, joined by " = ".

    Notes
    -----
    A row is eligible at budget B when it was made for B (``budget == B``),
    or its method ignores the budget (``budget`` None), and its occluder
    has at most B triangles: a method over its budget does not compete.
    Recall ties are exact equalities of the stored values. Precision and
    recall are the orbit or volume protocol's pooled values (Silvennoinen et
    al. 2014, sec. 6.1; Wu et al. 2022, sec. 3.2; module references [1], [2]).

    Examples
    --------
    >>> rows = [{"mesh": "m", "method": "a", "budget": 64, "triangles": 64,
    ...          "precision": 0.999, "recall": 0.8},
    ...         {"mesh": "m", "method": "b", "budget": 64, "triangles": 60,
    ...          "precision": 0.99, "recall": 0.9}]
    >>> [(e["budget"], e["method"]) for e in best_at_precision(rows)]
    [(64, 'a')]
    """
    rows = list(rows)
    meshes = list(dict.fromkeys(str(r.get("mesh")) for r in rows))
    out = []
    for mesh in meshes:
        for budget in _study_budgets(rows, budgets):
            eligible = []
            for i, r in enumerate(rows):
                if str(r.get("mesh")) != mesh:
                    continue
                if budget is not None:
                    tri = _finite(r.get("triangles"))
                    if r.get("budget") not in (None, budget) or tri is None or tri > budget:
                        continue
                eligible.append(i)
            ok = [i for i in eligible
                  if (p := _finite(rows[i].get("precision"))) is not None and p >= precision
                  and _finite(rows[i].get("recall")) is not None]
            entry = {"mesh": mesh, "budget": budget, "candidates": len(eligible),
                     "winners": [], "method": None}
            if ok:
                top = max(_finite(rows[i]["recall"]) for i in ok)
                winners = sorted((i for i in ok if _finite(rows[i]["recall"]) == top),
                                 key=lambda i: (_finite(rows[i].get("triangles")) or 0, i))
                first = rows[winners[0]]
                guarantees = [_guaranteed(rows[i]) for i in winners]
                entry.update(
                    winners=winners,
                    method=" = ".join(str(rows[i].get("method")) for i in winners),
                    triangles=first.get("triangles"), recall=first.get("recall"),
                    recall_ci=first.get("recall_ci"), precision=first.get("precision"),
                    violation_upper_bound=first.get("violation_upper_bound"),
                    guaranteed=" / ".join({True: "yes", False: "no", None: "unknown"}[g]
                                          for g in guarantees))
            out.append(entry)
    return out


def _summary_rows(summary: list[dict], precision: float) -> list[dict]:
    """The summary table's rows; a (mesh, budget) without a qualifier says so in its
    method cell (of class ``none``)."""
    shown = []
    for e in summary:
        row = dict(e)
        if row["budget"] is None:
            row["budget"] = "any"
        if row["method"] is None:
            row["method"] = (f"none reaches precision {precision:g}"
                             f" ({_count(row['candidates'], 'eligible result')})")
            row["_classes"] = {"method": "none"}
        shown.append(row)
    return shown


def _as_mapping(value, name: str) -> dict:
    if value is None:
        return {}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.asdict(value)
    if isinstance(value, Mapping):
        return dict(value)
    raise InputError(f"{name}: expected a mapping or a dataclass, got {type(value).__name__}")


def _image_items(images, out_dir: Path) -> list[tuple[str, Path]]:
    if images is None:
        return []
    if isinstance(images, Mapping):
        items = [(str(k), Path(v)) for k, v in images.items()]
    elif isinstance(images, (str, os.PathLike)):
        raise InputError("images: expected a mapping caption -> PNG file or a list of PNG "
                         f"files, got the single path {images}")
    else:
        items = [(Path(v).stem, Path(v)) for v in images]
    return [(caption, p if p.is_absolute() else out_dir / p) for caption, p in items]


def _data_uri(path: Path) -> str:
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise InputError(f"images: {path}: no such file") from None
    if not data.startswith(_PNG_SIGNATURE):
        raise InputError(f"images: {path}: not a PNG file")
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def _file_links(rows: Sequence[Mapping], out_dir: Path) -> list[Markup] | None:
    """Relative links to each row's occluder mesh and its .glb, where they exist."""
    if not any(r.get("occluder_file") for r in rows):
        return None
    links = []
    for r in rows:
        name = r.get("occluder_file")
        parts = []
        if name:
            for file in (Path("occluders") / name, (Path("occluders") / name).with_suffix(".glb")):
                if (out_dir / file).is_file():
                    parts.append(Markup('<a href="{}">{}</a>').format(
                        file.as_posix(), file.suffix.lstrip(".")))
        links.append(Markup(" ").join(parts) if parts else Markup("-"))
    return links


def write_report(out_dir: str | os.PathLike, rows: Sequence[Mapping], *,
                 paired_rows: Sequence[Mapping] = (), settings=None,
                 provenance: Mapping | None = None,
                 images: Mapping[str, str | os.PathLike] | Sequence[str | os.PathLike] | None
                 = None, culling_rows: Sequence[Mapping] = ()) -> Path:
    """Write ``out_dir/report.html``: one self-contained page of a comparison study.

    Parameters
    ----------
    out_dir : path-like
        Study folder; created if missing. Relative image paths and the
        occluder links are taken from here.
    rows : sequence of dict
        One result per row, keyed as the study's JSON rows (``mesh``,
        ``method``, ``budget``, ``triangles``, ``precision``,
        ``precision_ci``, ``recall``, ``recall_ci``, ``occlusion_measure``,
        ``occlusion_measure_se``, ``violation_upper_bound``, ``seconds``;
        optional ``occluder_file`` and ``info``, whose
        ``conservative_guaranteed`` the summary reports). Missing or None
        values show as "-".
    paired_rows : sequence of dict, optional
        Paired comparisons keyed as :data:`PAIRED_COLUMNS` (the output of
        ``viscore.cli.study.paired_rows``). Default none.
    settings : dict or dataclass, optional
        Evaluation settings (e.g. ``StudySettings``), shown as a table; its
        ``budgets`` are the summary's budgets (default: those of the rows).
    provenance : dict, optional
        Versions and platform (``viscore.provenance()``), shown as a table.
    culling_rows : sequence of dict, optional
        The culling column, one row per method keyed as :data:`CULLING_COLUMNS`
        (culled share and false culls on the built-in city). Default none.
    images : dict of caption -> path, or sequence of paths, optional
        PNG files to inline as ``data:image/png;base64`` URIs, in order;
        captions default to the file stems.

    Returns
    -------
    path : Path
        ``out_dir/report.html``, written atomically (UTF-8).

    Raises
    ------
    InputError
        If ``rows`` is empty, an image is missing or not a PNG, or
        ``settings`` / ``provenance`` is not a mapping.

    Notes
    -----
    The page loads nothing from outside itself (no script, no remote
    stylesheet, font or image); links to the occluder files beside it are
    relative and only shown for files that exist. Each (mesh, budget) of the
    summary is one ``<tr class="summary">``, each result one
    ``<tr class="result">`` of the results table (the summary's winners have
    their method and recall cells of class ``best``), each paired comparison
    one ``<tr class="paired">``. Tables take the page's width (no fixed
    column); paragraphs stay at most 76 em wide for reading. Deterministic:
    the same inputs give the same bytes.

    Examples
    --------
    >>> import tempfile
    >>> rows = [{"mesh": "cube", "method": "bbox", "budget": None, "triangles": 12,
    ...          "precision": 1.0, "precision_ci": [1.0, 1.0]}]
    >>> page = write_report(tempfile.mkdtemp(), rows)
    >>> page.name, page.read_text().count('<tr class="result">')
    ('report.html', 1)
    """
    out_dir = Path(out_dir)
    rows = [dict(r) for r in rows]
    if not rows:
        raise InputError("rows: expected at least one result, got none")
    settings = _as_mapping(settings, "settings")
    provenance = _as_mapping(provenance, "provenance")
    figures = [(caption, _data_uri(path)) for caption, path in _image_items(images, out_dir)]
    meshes = list(dict.fromkeys(str(r.get("mesh")) for r in rows))
    methods = list(dict.fromkeys(str(r.get("method")) for r in rows))
    protocol = settings.get("protocol")
    summary = best_at_precision(rows, budgets=settings.get("budgets"))
    best: list[set] = [set() for _ in rows]
    for e in summary:
        for i in e["winners"]:
            best[i].update(("method", "recall"))
    for k, r in enumerate(rows):
        r["_classes"] = {key: "best" for key in best[k]}
    versus = sorted({str(p.get("versus")) for p in paired_rows})
    intro = (f"{_count(len(rows), 'result')}: {_count(len(methods), 'method')} "
             f"({', '.join(methods)}) on {_count(len(meshes), 'mesh', 'meshes')} "
             f"({', '.join(meshes)})" + (f", {protocol} protocol" if protocol else "") + ".")
    html = render_page(
        "compare.html.j2", title="viscore compare: report", heading="viscore compare",
        version=str(provenance.get("viscore", "")), intro=intro,
        floor=f"{SUMMARY_PRECISION:g}", summary=_summary_rows(summary, SUMMARY_PRECISION),
        summary_columns=SUMMARY_COLUMNS, rows=rows, columns=REPORT_COLUMNS,
        links=_file_links(rows, out_dir), paired=[dict(p) for p in paired_rows],
        paired_columns=PAIRED_COLUMNS, versus=", ".join(versus),
        culling=[dict(c) for c in culling_rows], culling_columns=CULLING_COLUMNS,
        figures=figures, settings=settings, provenance=provenance)
    path = out_dir / "report.html"
    write_atomic(path, html.encode("utf-8"))
    return path


def _as_triangles(mesh, name: str):
    import trimesh

    if not isinstance(mesh, trimesh.Trimesh):
        raise InputError(f"{name}: expected a trimesh.Trimesh, got {type(mesh).__name__}")
    if len(mesh.faces) == 0:
        raise InputError(f"{name}: expected at least one triangle, got none")
    return mesh


def write_occluder_glb(original, occluder, path: str | os.PathLike) -> Path:
    """Write a glTF binary holding the original (grey, translucent) and the occluder (coloured).

    Parameters
    ----------
    original : trimesh.Trimesh
        The mesh the occluder stands for.
    occluder : trimesh.Trimesh
        The occluder, in the same coordinates.
    path : path-like
        Output file, ending in ``.glb``; its folder is created if missing.

    Returns
    -------
    path : Path
        The file written (atomically).

    Raises
    ------
    InputError
        If a mesh is not a ``trimesh.Trimesh`` or has no triangles, or
        ``path`` does not end in ``.glb``.

    Notes
    -----
    Two meshes and nodes named ``original`` and ``occluder``, each with one
    PBR material (metallic 0): the original's base colour is
    :data:`ORIGINAL_RGBA` with ``alphaMode`` BLEND, the occluder's
    :data:`OCCLUDER_RGBA` with ``alphaMode`` OPAQUE; both double-sided, since
    occluders may be open or single polygons. No normals are stored, so
    viewers shade flat (glTF 2.0, sec. 3.7.2.1). Inputs are not modified.

    Examples
    --------
    >>> import tempfile, trimesh
    >>> p = write_occluder_glb(trimesh.creation.icosphere(), trimesh.creation.box(),
    ...                        Path(tempfile.mkdtemp()) / "occ.glb")
    >>> scene = trimesh.load(p)
    >>> sorted((k, len(g.faces)) for k, g in scene.geometry.items())
    [('occluder', 12), ('original', 1280)]
    """
    import trimesh
    from trimesh.visual import TextureVisuals
    from trimesh.visual.material import PBRMaterial

    path = Path(path)
    if path.suffix.lower() != ".glb":
        raise InputError(f"path {path}: expected a file ending in .glb")
    scene = trimesh.Scene()
    for name, mesh, rgba, mode in (("original", original, ORIGINAL_RGBA, "BLEND"),
                                   ("occluder", occluder, OCCLUDER_RGBA, "OPAQUE")):
        mesh = _as_triangles(mesh, name)
        material = PBRMaterial(name=name, baseColorFactor=list(rgba), alphaMode=mode,
                               doubleSided=True, metallicFactor=0.0, roughnessFactor=0.9)
        copy = trimesh.Trimesh(np.asarray(mesh.vertices, dtype=np.float64),
                               np.asarray(mesh.faces, dtype=np.int64), process=False,
                               visual=TextureVisuals(material=material))
        scene.add_geometry(copy, geom_name=name, node_name=name)
    write_atomic(path, with_buffer_view_targets(scene.export(file_type="glb")))
    return path


def write_occluder_glbs(rows: list[dict], study_dir: Path, originals: dict) -> list[Path]:
    """A ``.glb`` beside each kept occluder file (original grey, occluder coloured).

    Written where missing (a resumed study gets those of its earlier rows);
    ``originals`` maps each row's mesh name to its loaded mesh.
    """
    import trimesh

    written = []
    for r in rows:
        if not r.get("triangles") or not r.get("occluder_file"):
            continue
        ply = Path(study_dir) / OCCLUDER_DIR / r["occluder_file"]
        glb = ply.with_suffix(".glb")
        if ply.is_file() and not glb.is_file():
            occ = trimesh.load(ply, force="mesh", process=False)
            write_occluder_glb(originals[r["mesh"]], occ, glb)
        if glb.is_file():
            written.append(glb)
    return written
