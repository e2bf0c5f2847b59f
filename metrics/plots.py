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
           "silhouette_plot", "culling_plot", "SILHOUETTE_VIEWS", "CULLING_LOG_SPAN",
           "walk_plot", "picture_grid"]

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

#: The culling plot's triangle axis turns logarithmic when its largest count is more
#: than this many times its smallest positive one (two decades: a close-up of a wall
#: beside a view over the whole level would leave the close-up flat on the axis).
CULLING_LOG_SPAN = 100
#: Panels per row of the culling plot, and inches per row.
_CULLING_COLUMNS = 3
_CULLING_ROW_INCHES = 2.5
#: Side of the walk plot, inches; frames numbered on it (about); a far view outside
#: the plan is drawn this fraction of the way from the centre to the edge.
_WALK_INCHES = 7.2
_WALK_LABELS = 25
_WALK_EDGE = 0.95
#: Length of a camera's heading tick on a 720-pixel plan, pixels.
_HEADING_PIXELS = 10.0
#: Colours of the walk, its far views and the frames a report draws.
_WALK_RGB = (0.85, 0.10, 0.45)
_FAR_RGB = (1.0, 0.60, 0.0)
_SHOWN_RGB = (0.05, 0.20, 0.75)
#: Room for a label of a picture grid (a row's, a column's, the title), inches.
_GRID_LABEL_INCHES = 0.3


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

    Small multiples: one panel per runtime (``none`` has none of its own),
    each with that runtime's line, the ``none`` runtime (every object in the
    view frustum) in grey and the ground truth (triangles of the visible
    objects, what an exact culler renders) dashed, on one shared axis. Where
    one part holds most triangles the runtimes' lines would lie on one
    another in a single panel; apart, each is read against the same two
    references. The triangle axis is logarithmic when the counts span more
    than :data:`CULLING_LOG_SPAN` (a close-up next to a view of the whole
    level), and the frame axis has integer ticks only.

    Parameters
    ----------
    result : CullingResult
        Of :func:`viscore.metrics.culling.simulate_culling` (not imported
        here: the simulation's module re-exports this function).
    path : str or path-like
        Figure file (``.png``, ``.pdf`` or ``.svg``), 1100 pixels wide and
        :data:`_CULLING_ROW_INCHES` x 100 pixels per row of
        :data:`_CULLING_COLUMNS` panels (plus the title), written atomically.
    title : str, optional
        Figure title.

    Raises
    ------
    InputError
        If the suffix of ``path`` is not a figure format, or the result has
        no frames.
    """
    from matplotlib.ticker import MaxNLocator

    _format_of(path)
    if not len(result.cameras):
        raise InputError("result: no frames to plot")
    names = [n for n in result.runtimes if n != "none"] or list(result.runtimes)
    columns = min(_CULLING_COLUMNS, max(1, len(names)))
    rows = -(-len(names) // columns)
    fig = _figure(11, _CULLING_ROW_INCHES * rows + (0.4 if title else 0.0))
    axes = np.atleast_1d(fig.subplots(rows, columns, sharex=True, sharey=True,
                                      squeeze=False)).reshape(-1)
    x = np.arange(len(result.cameras))
    reference = result.runtimes.get("none")
    every = [np.asarray(rf.triangles_rendered, dtype=np.float64)
             for rf in result.runtimes.values()] + [
        np.asarray(result.visible_triangles, dtype=np.float64)]
    positive = np.concatenate(every)
    positive = positive[positive > 0]
    log = bool(len(positive)) and positive.max() > CULLING_LOG_SPAN * positive.min()
    for k, name in enumerate(names):
        ax = axes[k]
        if reference is not None and name != "none":
            ax.plot(x, reference.triangles_rendered, "-", color="0.65", lw=1.0,
                    label="none (in view)")
        ax.plot(x, result.visible_triangles, "k--", lw=0.9, label="visible (ray-cast truth)")
        ax.plot(x, result.runtimes[name].triangles_rendered, "-", color=f"C{k}", lw=1.4,
                label=name)
        ax.set_title(name, fontsize=9, color=f"C{k}")
        ax.grid(True, color="0.92", lw=0.6)
        ax.xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
        if log:
            ax.set_yscale("log")
        else:
            ax.set_ylim(bottom=0)
        if k % columns == 0:
            ax.set_ylabel("triangles rendered", fontsize=8)
        if k >= len(names) - columns:
            ax.set_xlabel("frame along the camera path", fontsize=8)
            ax.tick_params(labelbottom=True)
        ax.tick_params(labelsize=8)
    for ax in axes[len(names):]:
        ax.set_visible(False)
    axes[0].set_xlim(0, max(1, len(x) - 1))
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles[:-1] if len(handles) > 1 else handles,
               labels[:-1] if len(labels) > 1 else labels, loc="upper right", fontsize=8,
               ncols=2, frameon=False)
    if title:
        fig.suptitle(title + (" (log scale)" if log else ""), fontsize=10, x=0.01,
                     ha="left")
    fig.tight_layout(rect=(0, 0, 1, 0.94 if rows == 1 else 0.97))
    _save(fig, Path(path))


def walk_plot(image: np.ndarray, points: np.ndarray, path: str | os.PathLike, *,
              far: np.ndarray | None = None, shown: Sequence[int] = (),
              headings: np.ndarray | None = None, title: str | None = None) -> np.ndarray:
    """A plan picture with a camera walk drawn over it: frames numbered, far views marked.

    Parameters
    ----------
    image : (R, C, 3) uint8
        The plan (for example ray-cast from above).
    points : (F, 2) float
        Each camera's position on the plan, pixels (column, row), in walk
        order; positions outside the picture are drawn on its edge, where the
        line from the picture's centre to them leaves it.
    path : str or path-like
        Figure file (``.png``, ``.pdf`` or ``.svg``), written atomically;
        :data:`_WALK_INCHES` inches square at :data:`DPI`.
    far : (F,) bool, optional
        Far views (drawn as triangles, and on the edge when outside).
    shown : sequence of int, optional
        Frames circled and always numbered (those drawn in a report).
    headings : (F, 2) float, optional
        Each camera's viewing direction on the plan, pixels (a short tick).
    title : str, optional

    Returns
    -------
    marks : (F, 2) float64
        Where each camera's mark is in the written picture, pixels from its
        top-left corner (for an image map of the frames).

    Raises
    ------
    InputError
        On a bad suffix, an image that is not (R, C, 3), or points that are
        not (F, 2) finite.

    Notes
    -----
    At most about :data:`_WALK_LABELS` frames are numbered (every k-th, plus
    the first, the last and ``shown``), so that numbers do not pile up.
    """
    from matplotlib.lines import Line2D
    from matplotlib.ticker import NullLocator

    _format_of(path)
    img = np.asarray(image)
    pts = np.asarray(points, dtype=np.float64)
    if img.ndim != 3 or img.shape[2] != 3:
        raise InputError(f"image: expected (R, C, 3) RGB, got shape {img.shape}")
    if pts.ndim != 2 or pts.shape[1] != 2 or not np.isfinite(pts).all():
        raise InputError(f"points: expected (F, 2) finite pixel positions, got {pts.shape}")
    n = len(pts)
    far = np.zeros(n, dtype=bool) if far is None else np.asarray(far, dtype=bool).reshape(n)
    rows, cols = img.shape[:2]
    centre = np.array([cols / 2.0, rows / 2.0])
    off = pts - centre
    # outside the picture: pulled back along the line from its centre to the edge
    reach = np.max(np.abs(off) / np.array([cols / 2.0, rows / 2.0]), axis=1)
    outside = reach > 1.0
    drawn = pts.copy()
    drawn[outside] = centre + off[outside] / reach[outside, None] * _WALK_EDGE
    fig = _figure(_WALK_INCHES, _WALK_INCHES)
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0 if not title else 0.95))
    ax.imshow(img, extent=(0, cols, rows, 0), interpolation="nearest")
    ax.set_xlim(0, cols)
    ax.set_ylim(rows, 0)
    ax.xaxis.set_major_locator(NullLocator())
    ax.yaxis.set_major_locator(NullLocator())
    near = ~far
    # the walk: a line through consecutive near cameras, far views on their own
    for segment in np.split(np.arange(n), np.flatnonzero(np.diff(near.astype(int)) != 0) + 1):
        if near[segment[0]] and len(segment) > 1:
            ax.plot(drawn[segment, 0], drawn[segment, 1], "-", color=_WALK_RGB, lw=1.2,
                    alpha=0.8)
    ax.plot(drawn[near, 0], drawn[near, 1], "o", ms=3.2, color=_WALK_RGB)
    ax.plot(drawn[far, 0], drawn[far, 1], "^", ms=7, color=_FAR_RGB, mec="k", mew=0.5)
    if headings is not None:
        h = np.asarray(headings, dtype=np.float64).reshape(n, 2)
        length = np.linalg.norm(h, axis=1, keepdims=True)
        h = np.where(length > 0, h / np.where(length > 0, length, 1.0), 0.0) * _HEADING_PIXELS
        tip = drawn + h * np.array([cols, rows]) / 720.0
        gap = np.full(n, np.nan)  # one line of n ticks, apart
        ax.plot(np.stack([drawn[:, 0], tip[:, 0], gap], axis=1).reshape(-1),
                np.stack([drawn[:, 1], tip[:, 1], gap], axis=1).reshape(-1), "-", color="k",
                lw=0.8)
    shown = [int(k) for k in shown if 0 <= int(k) < n]
    ax.plot(drawn[shown, 0], drawn[shown, 1], "o", ms=9, mfc="none", mec=_SHOWN_RGB, mew=1.6)
    step = max(1, -(-n // _WALK_LABELS))
    labelled = sorted(set(range(0, n, step)) | {n - 1} | set(shown))
    for k in labelled:  # numbers up-right, up-left near the right edge
        right = drawn[k, 0] > 0.9 * cols
        ax.annotate(str(k), drawn[k], xytext=(-4 if right else 4, 4), textcoords="offset points",
                    ha="right" if right else "left", fontsize=7,
                    color=_SHOWN_RGB if k in shown else "k",
                    bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none",
                          "alpha": 0.75})
    handles = [Line2D([], [], color=_WALK_RGB, marker="o", ms=4, label="camera walk"),
               Line2D([], [], color=_FAR_RGB, marker="^", ls="none", mec="k", ms=7,
                      label="far view" + (" (outside: on the edge)" if outside.any() else "")),
               Line2D([], [], marker="o", ls="none", mfc="none", mec=_SHOWN_RGB, ms=9,
                      label="frame drawn below")]
    ax.legend(handles=handles, loc="lower right", fontsize=7, framealpha=0.85)
    if title:
        fig.suptitle(title, fontsize=9, y=0.985)
    fig.canvas.draw()
    display = ax.transData.transform(drawn)
    marks = np.stack([display[:, 0], fig.bbox.height - display[:, 1]], axis=1)
    _save(fig, Path(path))
    return marks


def picture_grid(images: Sequence[Sequence[np.ndarray]], path: str | os.PathLike, *,
                 row_labels: Sequence[str], column_labels: Sequence[str],
                 title: str | None = None) -> None:
    """Pictures in a grid, a label over each column and beside each row, at one pixel per
    pixel (``viscore occlude``'s ``preview.png``: views by methods).

    Parameters
    ----------
    images : sequence of sequence of (H, W, 3) uint8
        ``images[r][c]``: the pictures of a row of one size, every picture of
        one width.
    path : str or path-like
        Figure file (``.png``, ``.pdf`` or ``.svg``), written atomically: the
        pictures' own size times the grid, plus :data:`_GRID_LABEL_INCHES`
        for the labels.
    row_labels, column_labels : sequence of str
        One per row and per column.
    title : str, optional

    Raises
    ------
    InputError
        A bad suffix, no picture, pictures of different sizes, or labels that
        do not match the grid.
    """
    _format_of(path)
    grid = [[np.asarray(img) for img in row] for row in images]
    if not grid or not grid[0]:
        raise InputError("images: expected at least one picture")
    widths = {img.shape[1] for row in grid for img in row}
    if (any(len(row) != len(grid[0]) for row in grid) or len(widths) != 1
            or any(img.ndim != 3 or img.shape != row[0].shape for row in grid for img in row)):
        raise InputError("images: expected rows of equally many (H, W, 3) pictures, one size "
                         "in a row, one width in all")
    rows, cols = len(grid), len(grid[0])
    if len(row_labels) != rows or len(column_labels) != cols:
        raise InputError(f"labels: expected {rows} row and {cols} column labels")
    w = widths.pop() / DPI
    heights = [row[0].shape[0] / DPI for row in grid]
    top = _GRID_LABEL_INCHES * (2 if title else 1)
    left = _GRID_LABEL_INCHES
    width, height = left + cols * w, top + sum(heights)
    fig = _figure(width, height)
    below = sum(heights)
    for r in range(rows):
        below -= heights[r]
        for c in range(cols):
            ax = fig.add_axes(((left + c * w) / width, below / height, w / width,
                               heights[r] / height))
            ax.imshow(grid[r][c], interpolation="nearest")
            ax.set_axis_off()
        fig.text(0.5 * left / width, (below + 0.5 * heights[r]) / height, row_labels[r],
                 rotation=90, ha="center", va="center", fontsize=9)
    for c in range(cols):
        fig.text((left + (c + 0.5) * w) / width,
                 (sum(heights) + 0.5 * _GRID_LABEL_INCHES) / height,
                 column_labels[c], ha="center", va="center", fontsize=10)
    if title:
        fig.text(0.01, 1 - 0.5 * _GRID_LABEL_INCHES / height, title, ha="left",
                 va="center", fontsize=10)
    _save(fig, Path(path))
