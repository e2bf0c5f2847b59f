"""Every figure of the toolkit, drawn on :class:`matplotlib.figure.Figure`.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (Figure 7: silhouette colour
   coding; Figure 11: recall per view).
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (Figure 10: convergence ablation).
"""

from __future__ import annotations

import io
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from viscore import InputError

if TYPE_CHECKING:  # pragma: no cover - hints only
    from matplotlib.figure import Figure

    from .ablation import AblationResult
    from .bayes import BetaModelSummary
    from .precision_recall import PrecisionRecall

__all__ = ["distribution_plot", "ablation_plot", "recall_plot", "budget_plot",
           "silhouette_plot", "culling_plot", "SILHOUETTE_VIEWS"]

#: Dots per inch of every figure: a figure of w x h inches is 100 w x 100 h pixels.
DPI = 100

#: File formats the figures are written in (from the path's suffix).
_FORMATS = {".png": "png", ".pdf": "pdf", ".svg": "svg"}

#: Views shown in the silhouette plots (Silvennoinen et al. 2014, Figure 7).
SILHOUETTE_VIEWS = 3

#: Panels per row of the per-mesh figures, and inches per panel.
_PANEL_COLUMNS = 3
_PANEL_INCHES = 3.0
#: Inches per row of recall panels: the panel plus its slanted method names.
_RECALL_PANEL_HEIGHT = 3.4
#: Slant of the method names under the recall boxes, degrees.
_LABEL_ROTATION = 45
#: Inches per row of meshes in the budget plot (recall above, precision below).
_BUDGET_PANEL_HEIGHT = 5.2
#: Methods per legend row of the budget plot, and inches per legend row.
_LEGEND_COLUMNS = 4
_LEGEND_ROW_INCHES = 0.3
#: Where the budget plot's 1 - P axis stops: a precision of exactly 1 is drawn here.
#: 1e-5 resolves precisions up to 0.99999, beyond the quads' own resolution at the
#: default settings (a few hundred thousand pixels scored per view).
_ONE_MINUS_P_FLOOR = 1e-5


def _figure(width: float, height: float) -> Figure:
    """A figure of ``width`` x ``height`` inches with its own Agg canvas (no pyplot)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def _format_of(path: str | os.PathLike) -> str:
    suffix = Path(path).suffix.lower() or ".png"
    if suffix not in _FORMATS:
        raise InputError(f"path {path}: expected a figure file ending in "
                         + ", ".join(_FORMATS) + f", got '{suffix}'")
    return _FORMATS[suffix]


def _save(fig: Figure, path: str | os.PathLike) -> None:
    """Render ``fig`` and write it to ``path`` atomically (:func:`viscore._atomic.write_atomic`).

    The folder must exist; the file gets the mode ``open`` would give it.
    """
    from viscore._atomic import write_atomic

    path = Path(path)
    buf = io.BytesIO()
    fig.savefig(buf, format=_format_of(path), dpi=DPI)
    write_atomic(path, buf.getvalue())


def _check_rows(rows: Sequence[Mapping], keys: tuple[str, ...], name: str = "rows") -> list:
    rows = list(rows)
    if not rows:
        raise InputError(f"{name}: expected at least one study row, got none")
    for k, r in enumerate(rows):
        missing = [key for key in keys if key not in r]
        if missing:
            raise InputError(f"{name}[{k}]: missing {', '.join(missing)}")
    return rows


def distribution_plot(result: PrecisionRecall, models: dict[str, BetaModelSummary], path
                      ) -> None:
    """Per-view histograms of quad recall and precision with the fitted population.

    Parameters
    ----------
    result : PrecisionRecall
        An evaluation whose ``per_view`` holds ``quads_orig``, ``quads_occ``
        and ``quads_both``, each (V,) int.
    models : dict of {'recall', 'precision'} -> BetaModelSummary
        The hierarchical Beta models of the two quantities.
    path : str or path-like
        Figure file (``.png``, ``.pdf`` or ``.svg``); 900 x 340 pixels.

    Raises
    ------
    InputError
        If ``models`` lacks a quantity, ``per_view`` lacks a count, or the
        suffix of ``path`` is not a figure format.

    Examples
    --------
    See ``viscore uncertainty``, which writes ``per_view.png`` with it.
    """
    from scipy import stats

    _format_of(path)
    pv = result.per_view
    missing = [q for q in ("recall", "precision") if q not in models]
    missing += [k for k in ("quads_orig", "quads_occ", "quads_both") if k not in pv]
    if missing:
        raise InputError(f"distribution_plot: missing {', '.join(missing)}")
    fig = _figure(9, 3.4)
    axes = fig.subplots(1, 2)
    for ax, q, den in ((axes[0], "recall", "quads_orig"), (axes[1], "precision", "quads_occ")):
        n = np.asarray(pv[den], float)
        k = np.asarray(pv["quads_both"], float)
        rates = k[n > 0] / n[n > 0]
        m = models[q]
        ax.hist(rates, bins=30, range=(0, 1), density=True, alpha=0.6, label="views")
        x = np.linspace(0.001, 0.999, 400)
        phi = m.mean * (1 - m.mean) / max(m.spread**2, 1e-12) - 1
        if phi > 0:
            ax.plot(x, stats.beta.pdf(x, m.mean * phi, (1 - m.mean) * phi), "k-",
                    label="population (posterior mean)")
        ax.axvline(m.mean, color="C3", lw=1, label=f"mean {m.mean:.3f}")
        ax.set_xlabel(f"{q} per view (per quad)")
        ax.set_ylabel("density")
        ax.legend(fontsize=7)
    fig.tight_layout()
    _save(fig, path)


def ablation_plot(result: AblationResult, path) -> None:
    """Standard deviation of P and R against each factor, log-log (Wu et al. 2022, Fig. 10).

    Parameters
    ----------
    result : AblationResult
        Rows with ``factor``, ``value``, ``precision_sd``, ``recall_sd`` and
        ``repeats``.
    path : str or path-like
        Figure file; 420 pixels wide per factor, 340 high.

    Raises
    ------
    InputError
        If ``result`` has no rows, or the suffix of ``path`` is not a figure
        format.
    """
    _format_of(path)
    _check_rows(result.rows, ("factor", "value", "precision_sd", "recall_sd", "repeats"),
                "result.rows")
    factors = [f for f in ("quads", "spacing", "views") if any(r["factor"] == f for r in
                                                             result.rows)]
    fig = _figure(4.2 * max(1, len(factors)), 3.4)
    axes = fig.subplots(1, max(1, len(factors)), squeeze=False)
    labels = {"quads": "quads per view", "spacing": "view spacing (fraction of diagonal)",
              "views": "orbit views"}
    for ax, f in zip(axes[0], factors, strict=False):
        rows = [r for r in result.rows if r["factor"] == f]
        x = [r["value"] for r in rows]
        for key, style in (("precision_sd", "o-"), ("recall_sd", "s--")):
            ax.plot(x, [max(r[key], 1e-12) for r in rows], style, label=key.split("_")[0])
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(x, [f"{v:g}" for v in x])
        ax.minorticks_off()
        ax.set_xlabel(labels[f])
        ax.set_ylabel(f"s.d. over {rows[0]['repeats']} repeats")
        ax.legend(fontsize=8)
        if f == "spacing":
            ax.invert_xaxis()
    fig.tight_layout()
    _save(fig, path)


def _largest_budget(rows: list[Mapping]) -> list[Mapping]:
    """One row per (mesh, method): the largest budget."""
    best: dict = {}
    for r in rows:
        k = (r["mesh"], r["method"])
        if k not in best or (r["budget"] or 0) > (best[k]["budget"] or 0):
            best[k] = r
    return list(best.values())


def _panels(count: int, size: float = _PANEL_INCHES, height: float | None = None):
    cols = min(_PANEL_COLUMNS, count)
    rows = -(-count // cols)
    fig = _figure(size * cols + 0.4, (height or size) * rows)
    axes = fig.subplots(rows, cols, squeeze=False)
    for ax in axes.flat[count:]:
        ax.set_axis_off()
    return fig, axes.flat


def recall_plot(rows: list[dict], path: Path) -> None:
    """Per-method distribution of per-view recall, one panel per mesh.

    As Silvennoinen et al. 2014, Figure 11; each (mesh, method) at its
    largest budget. Method names stand under their boxes at 45 degrees, so
    that eight or more names stay apart.

    Parameters
    ----------
    rows : list of dict
        Study rows with ``mesh``, ``method``, ``budget`` and
        ``per_view['recall']`` ((V,) floats, None where undefined).
    path : str or path-like
        Figure file; 300 pixels wide per panel, up to three panels a row
        (+40 pixels of width), 340 pixels high per row of panels (room for
        the slanted names).

    Raises
    ------
    InputError
        If ``rows`` is empty or a row lacks a key, or the suffix of ``path``
        is not a figure format.
    """
    _format_of(path)
    rows = _largest_budget(_check_rows(rows, ("mesh", "method", "budget", "per_view")))
    meshes = list(dict.fromkeys(r["mesh"] for r in rows))
    fig, axes = _panels(len(meshes), height=_RECALL_PANEL_HEIGHT)
    for ax, mesh in zip(axes, meshes, strict=False):
        sub = [r for r in rows if r["mesh"] == mesh]
        data = [np.array([v for v in r["per_view"].get("recall", []) if v is not None],
                         dtype=float) for r in sub]
        data = [d if len(d) else np.array([np.nan]) for d in data]
        ax.boxplot(data, showfliers=False)
        ax.set_xticks(range(1, len(sub) + 1), [r["method"] for r in sub], fontsize=7,
                      rotation=_LABEL_ROTATION, ha="right", rotation_mode="anchor")
        ax.set_ylim(-0.02, 1.02)
        ax.set_title(Path(mesh).stem, fontsize=9)
        ax.set_ylabel("recall per view", fontsize=8)
    fig.tight_layout()
    _save(fig, path)


def budget_plot(rows: list[dict], path: Path, *, precision_target: float = 0.995) -> None:
    """Recall and precision against occluder triangles, two stacked panels per mesh.

    The upper panel draws recall on a linear axis; the lower one precision
    as 1 - P on a log axis (ticks labelled with P: 0.9, 0.99, 0.999, ...), so
    that precisions of 0.99 and 0.999 lie a decade apart instead of on one
    line at 1.0. A precision of exactly 1 (no false occlusion) is drawn as a
    downward triangle on the axis floor, 1 - P = 1e-5 (labelled >= 0.99999).
    A dotted line marks ``precision_target``.

    Parameters
    ----------
    rows : list of dict
        Study rows with ``mesh``, ``method``, ``triangles``, ``recall`` and
        ``precision`` (None where undefined).
    path : str or path-like
        Figure file; 300 pixels wide per mesh, up to three meshes a row (+40
        pixels of width), 520 pixels high per row of meshes, plus a legend
        row of 30 pixels per four methods.
    precision_target : float, optional
        Precision marked by the dotted line. Default 0.995 (the report's
        summary floor).

    Raises
    ------
    InputError
        If ``rows`` is empty or a row lacks a key, or the suffix of ``path``
        is not a figure format.
    """
    _format_of(path)
    rows = _check_rows(rows, ("mesh", "method", "triangles", "recall", "precision"))
    meshes = list(dict.fromkeys(r["mesh"] for r in rows))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    cols = min(_PANEL_COLUMNS, len(meshes))
    grid_rows = -(-len(meshes) // cols)
    legend_rows = 1 + -(-len(methods) // _LEGEND_COLUMNS)  # + the two-line title
    legend_inches = _LEGEND_ROW_INCHES * legend_rows
    fig = _figure(_PANEL_INCHES * cols + 0.4,
                  _BUDGET_PANEL_HEIGHT * grid_rows + legend_inches)
    gs = fig.add_gridspec(2 * grid_rows, cols, height_ratios=[1.15, 1.0] * grid_rows)
    floor = _ONE_MINUS_P_FLOOR
    handles: dict = {}
    for m, mesh in enumerate(meshes):
        g, c = divmod(m, cols)
        top = fig.add_subplot(gs[2 * g, c])
        low = fig.add_subplot(gs[2 * g + 1, c], sharex=top)
        for k, method in enumerate(methods):
            sub = sorted((r for r in rows if r["mesh"] == mesh and r["method"] == method),
                         key=lambda r: r["triangles"])
            if not sub:
                continue
            x = np.array([max(1, r["triangles"]) for r in sub], dtype=float)
            rec = np.array([np.nan if r["recall"] is None else r["recall"] for r in sub])
            line, = top.plot(x, rec, "o-", ms=3, color=f"C{k % 10}")
            handles.setdefault(method, line)
            miss = np.array([np.nan if r["precision"] is None else 1.0 - r["precision"]
                             for r in sub])
            low.plot(x, np.maximum(miss, floor), "s--", ms=3, color=f"C{k % 10}")
            exact = miss <= floor
            if exact.any():
                low.plot(x[exact], np.full(exact.sum(), floor), "v", ms=5,
                         color=f"C{k % 10}")
        top.set_xscale("log")
        top.set_ylim(-0.02, 1.02)
        top.set_title(Path(mesh).stem, fontsize=9)
        top.set_ylabel("recall", fontsize=8)
        top.tick_params(labelbottom=False, labelsize=7)
        low.set_yscale("log")
        low.set_ylim(floor / 2, 1.0)
        decades = [10.0 ** -e for e in range(1, 1 + round(-np.log10(floor)))]
        labels = [f"{1 - d:.{e + 1}f}" for e, d in enumerate(decades)]
        labels[-1] = "\u2265" + labels[-1]  # the floor also holds P = 1
        low.set_yticks(decades, labels, fontsize=7)
        low.minorticks_off()
        low.axhline(1.0 - precision_target, color="0.4", lw=0.8, ls=":")
        low.set_ylabel("precision (log 1 - P)", fontsize=8)
        low.set_xlabel("occluder triangles", fontsize=8)
        low.tick_params(labelsize=7)
    fig.legend(list(handles.values()), list(handles), loc="lower center",
               ncol=min(_LEGEND_COLUMNS, len(handles)), fontsize=7, frameon=False,
               title=f"recall solid, precision dashed\nP = 1: triangle; dotted: P = "
                     f"{precision_target:g}", title_fontsize=7)
    fig.tight_layout(rect=(0, legend_inches / fig.get_figheight(), 1, 1))
    _save(fig, path)


def silhouette_plot(rows: list[dict], out_dir: Path, mesh: str, path: Path, *,
                    resolution: int = 160, seed: int = 0) -> None:
    """Silhouette colour coding for a few views of one mesh, one row of panels per method.

    As Silvennoinen et al. 2014, Figure 7: black where only the original
    covers a pixel, yellow where both do, blue where only the occluder does;
    each method at its largest budget, :data:`SILHOUETTE_VIEWS` seeded
    uniform directions.

    Parameters
    ----------
    rows : list of dict
        Study rows with ``mesh``, ``method``, ``budget``, ``triangles`` and
        ``occluder_file``; rows of other meshes are ignored.
    out_dir : path-like
        Study folder: the occluders are read from ``out_dir/occluders/``; a
        row whose file is missing (or with no triangles) shows no occluder.
    mesh : str
        Mesh file or built-in scene, as in the rows.
    path : str or path-like
        Figure file; 220 x 220 pixels per panel.
    resolution : int, optional
        Pixels per side of each silhouette image. Default 160.
    seed : int, optional
        Seed of the view directions. Default 0.

    Raises
    ------
    InputError
        If no row is of ``mesh``, a row lacks a key, or the suffix of
        ``path`` is not a figure format.
    """
    from viscore import directions_uniform, load_mesh
    from viscore._validate import as_positive_int, as_seed

    from ._views import scene_of
    from .frames import orbit_frame
    from .silhouettes import silhouette_image

    _format_of(path)
    resolution = as_positive_int(resolution, "resolution", maximum=4096)
    seed = as_seed(seed, "seed")
    rows = _check_rows(rows, ("mesh", "method", "budget", "triangles", "occluder_file"))
    sub = [r for r in _largest_budget(rows) if r["mesh"] == mesh]  # type: ignore[arg-type]
    if not sub:
        raise InputError(f"mesh {mesh!r}: no study row of this mesh")
    original = load_mesh(mesh)
    # one Embree scene for the original and one per occluder, shared by every view
    frame = orbit_frame(original)
    original_scene = scene_of(original, "mesh")
    dirs = directions_uniform(SILHOUETTE_VIEWS, seed=seed)
    fig = _figure(2.2 * SILHOUETTE_VIEWS, 2.2 * len(sub))
    axes = fig.subplots(len(sub), SILHOUETTE_VIEWS, squeeze=False)
    for i, r in enumerate(sub):
        file = Path(out_dir) / "occluders" / r["occluder_file"]
        # viscore's loader: trimesh's own merges vertices at 1e-8 and ruins tiny or huge meshes
        occ = load_mesh(file) if r["triangles"] and file.is_file() else None
        occ_scene = scene_of(occ, "occluder")
        for j, d in enumerate(dirs):
            axes[i, j].imshow(silhouette_image(original_scene, occ_scene, d,  # type: ignore[arg-type]
                                               resolution=resolution, frame=frame))
            axes[i, j].set_axis_off()
        axes[i, 0].set_title(f"{r['method']} ({r['triangles']} tris)", fontsize=8, loc="left")
    fig.suptitle(f"{Path(mesh).stem}: black original only, yellow both, blue occluder only",
                 fontsize=8)
    fig.tight_layout()
    _save(fig, path)


def culling_plot(result, path: str | os.PathLike, *, title: str | None = None) -> None:
    """Triangles rendered per frame for every runtime (Papaioannou et al. 2006, Figs. 5-6).

    One line per runtime, and the ground truth (triangles of the visible
    objects, what an exact culler renders) dashed.

    Parameters
    ----------
    result : CullingResult
        Of :func:`viscore.metrics.culling.simulate_culling` (not imported
        here: the simulation's module re-exports this function).
    path : str or path-like
        Figure file (``.png``, ``.pdf`` or ``.svg``), 1100 x 420 pixels,
        written atomically.
    title : str, optional
        Figure title.

    Raises
    ------
    InputError
        If the suffix of ``path`` is not a figure format, or the result has
        no frames.
    """
    _format_of(path)
    if not len(result.cameras):
        raise InputError("result: no frames to plot")
    fig = _figure(11, 4.2)
    ax = fig.subplots()
    x = np.arange(len(result.cameras))
    for k, (name, rf) in enumerate(result.runtimes.items()):
        ax.plot(x, rf.triangles_rendered, "-", color=f"C{k}", lw=1.2, label=name)
    ax.plot(x, result.visible_triangles, "k--", lw=1.0, label="visible (ray-cast truth)")
    ax.set_xlabel("frame along the camera path")
    ax.set_ylabel("triangles rendered")
    ax.set_ylim(bottom=0)
    ax.set_xlim(0, max(1, len(x) - 1))
    if title:
        ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    fig.tight_layout()
    _save(fig, Path(path))
