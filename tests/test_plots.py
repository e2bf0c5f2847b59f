"""viscore.metrics.plots: right-sized, non-blank PNGs; the caller's backend left alone."""

import os
import subprocess
import sys
import textwrap
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh
from PIL import Image

from viscore import InputError
from viscore.metrics import AblationResult, orbit_precision_recall
from viscore.metrics.plots import (
    SILHOUETTE_VIEWS,
    ablation_plot,
    budget_plot,
    distribution_plot,
    recall_plot,
    silhouette_plot,
)


def _pixels(path):
    """(H, W, 3) uint8 of a PNG file, after checking its signature."""
    with open(path, "rb") as fh:
        assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    return np.asarray(Image.open(path).convert("RGB"))


def _assert_drawn(img, size):
    """Exactly ``size`` (width, height) pixels, with drawing on a non-trivial share of them."""
    assert (img.shape[1], img.shape[0]) == size
    inked = (img < 200).any(axis=2).mean()  # darker than the white background
    assert inked > 0.005
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 8  # lines, text, fills: many colours


def _rows(mesh="m.ply", methods=("qem", "bbox"), budgets=(64, 256), views=12, seed=0):
    rng = np.random.default_rng(seed)
    rows = []
    for c, method in enumerate(methods):
        for b in budgets:
            rec = rng.uniform(0.3 + 0.2 * c, 0.9, views).tolist()
            rec[0] = None  # undefined views are skipped
            rows.append({"mesh": mesh, "method": method, "budget": b, "triangles": b - 4 * c,
                         "recall": float(np.mean(rec[1:])), "precision": 0.9 + 0.01 * c,
                         "per_view": {"recall": rec},
                         "occluder_file": f"{method}_{b}.ply"})
    return rows


@pytest.fixture(scope="module")
def evaluation():
    box = trimesh.creation.box()
    inner = trimesh.creation.box(extents=(0.8, 0.8, 0.8))
    return orbit_precision_recall(box, inner, views=12, quads=300, resolution=32, seed=0)


def test_distribution_plot_png(tmp_path, evaluation):
    models = {"recall": SimpleNamespace(mean=0.62, spread=0.05),
              "precision": SimpleNamespace(mean=0.99, spread=0.004)}
    path = tmp_path / "per_view.png"
    distribution_plot(evaluation, models, path)
    _assert_drawn(_pixels(path), (900, 340))


def test_distribution_plot_invalid_input(tmp_path, evaluation):
    with pytest.raises(InputError, match="precision"):
        distribution_plot(evaluation, {"recall": SimpleNamespace(mean=0.5, spread=0.1)},
                          tmp_path / "x.png")
    with pytest.raises(InputError, match="suffix|ending"):
        distribution_plot(evaluation, {}, tmp_path / "x.jpeg")


def test_ablation_plot_png(tmp_path):
    rows = [{"factor": f, "value": v, "precision_sd": 0.1 / v ** 0.5, "recall_sd": 0.2 / v ** 0.5,
             "repeats": 10} for f, vals in (("quads", (100, 1000, 10000)), ("views", (16, 64)))
            for v in vals]
    path = tmp_path / "ablation.png"
    ablation_plot(AblationResult(rows=rows, seed=0, params={}), path)
    _assert_drawn(_pixels(path), (840, 340))  # 420 px per factor


def test_ablation_plot_invalid_input(tmp_path):
    with pytest.raises(InputError, match="rows"):
        ablation_plot(AblationResult(rows=[], seed=0, params={}), tmp_path / "a.png")


def test_recall_plot_png(tmp_path):
    rows = _rows("a.ply") + _rows("b.ply", seed=1)
    path = tmp_path / "recall.png"
    recall_plot(rows, path)
    _assert_drawn(_pixels(path), (640, 340))  # two panels of 300 px, +40; 340 high


def _captured(monkeypatch):
    """The figures the plots would write, kept instead of saved."""
    import viscore.metrics.plots as plots

    figures = []
    monkeypatch.setattr(plots, "_save", lambda fig, path: figures.append(fig))
    return figures


def _overlap(a, b):
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


EIGHT = ("aabb-skins", "planar-sections", "hybrid", "solid-frusta", "qem", "godot", "bbox",
         "original")


def test_recall_plot_eight_method_names_apart(tmp_path, monkeypatch):
    figures = _captured(monkeypatch)
    rows = [{"mesh": mesh, "method": name, "budget": 64,
             "per_view": {"recall": [0.5 + 0.05 * k, 0.6]}}
            for mesh in ("a.ply", "b.ply") for k, name in enumerate(EIGHT)]
    recall_plot(rows, tmp_path / "r.png")
    fig, = figures
    renderer = fig.canvas.get_renderer()
    size = fig.bbox
    for ax in fig.axes:
        labels = [t for t in ax.get_xticklabels() if t.get_text()]
        assert [t.get_text() for t in labels] == list(EIGHT)
        boxes = [t.get_window_extent(renderer) for t in labels]
        angle = np.radians(labels[0].get_rotation())
        if angle == 0:  # upright names: their boxes must not meet
            for i in range(len(boxes) - 1):
                assert not _overlap(boxes[i], boxes[i + 1]), (labels[i], labels[i + 1])
        else:  # slanted parallel names: the gap across them must exceed a line of text
            ticks = ax.transData.transform([(x, 0) for x in ax.get_xticks()])[:, 0]
            line = labels[0].get_fontsize() * fig.dpi / 72
            assert (np.diff(ticks) * np.sin(angle)).min() > line
        for b in boxes:  # and none is cut off by the figure's edge
            assert b.x0 >= 0 and b.y0 >= 0 and b.x1 <= size.x1 and b.y1 <= size.y1


def test_budget_plot_png_grid(tmp_path):
    rows = sum((_rows(f"m{k}.ply", seed=k) for k in range(4)), [])
    path = tmp_path / "budget.png"
    budget_plot(rows, path)
    # 3 columns x 2 rows of meshes, 520 px each (recall over precision), + 2 legend rows
    _assert_drawn(_pixels(path), (940, 2 * 520 + 2 * 30))
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".tmp")]  # temp file renamed


def test_budget_plot_precision_axis_separates_099_from_0999(tmp_path, monkeypatch):
    """Precisions 0.99, 0.999 and 1 are drawn a decade apart, not on one line at 1.0."""
    figures = _captured(monkeypatch)
    rows = [{"mesh": "m", "method": name, "budget": 64, "triangles": 64, "recall": 0.8,
             "precision": p} for name, p in (("a", 0.99), ("b", 0.999), ("c", 1.0))]
    budget_plot(rows, tmp_path / "b.png")
    fig, = figures
    recall_ax, precision_ax = fig.axes
    assert precision_ax.get_yscale() == "log"
    heights = {}
    for line in precision_ax.get_lines():
        y = line.get_ydata()
        if len(y) == 1 and line.get_linestyle() == "--":
            heights[line.get_color()] = precision_ax.transData.transform((64, y[0]))[1]
    assert len(heights) == 3
    a, b, c = (heights[f"C{k}"] for k in range(3))
    # a linear axis of 0..1 puts 0.99 and 0.999 two pixels apart; a decade is ~36 px here
    assert a - b > 25 and b - c > 25  # 0.99 above 0.999 above 1 (at the floor)
    recall_y = {round(float(line.get_ydata()[0]), 6) for line in recall_ax.get_lines()}
    assert recall_y == {0.8}  # recall keeps its own linear axis


def test_budget_plot_invalid_input_leaves_file(tmp_path):
    path = tmp_path / "budget.png"
    path.write_bytes(b"old")
    with pytest.raises(InputError, match="rows"):
        budget_plot([], path)
    with pytest.raises(InputError, match="per_view"):
        recall_plot([{"mesh": "m"}], path)
    assert path.read_bytes() == b"old"


def test_silhouette_plot_png(tmp_path):
    mesh_file = tmp_path / "cube.ply"
    trimesh.creation.box().export(mesh_file)
    (tmp_path / "occluders").mkdir()
    trimesh.creation.box(extents=(0.7, 0.7, 0.7)).export(tmp_path / "occluders" / "qem_64.ply")
    rows = _rows(str(mesh_file), methods=("qem",), budgets=(64,))
    rows += [{**rows[0], "method": "none", "triangles": 0, "occluder_file": "missing.ply"}]
    path = tmp_path / "sil.png"
    silhouette_plot(rows, tmp_path, str(mesh_file), path, resolution=24, seed=0)
    img = _pixels(path)
    _assert_drawn(img, (220 * SILHOUETTE_VIEWS, 2 * 220))
    yellow = (img[..., 0] > 200) & (img[..., 1] > 150) & (img[..., 2] < 80)
    assert yellow[:220].any() and not yellow[220:].any()  # overlap only where an occluder is


def test_silhouette_plot_invalid_input(tmp_path):
    with pytest.raises(InputError, match="no study row"):
        silhouette_plot(_rows("a.ply"), tmp_path, "other.ply", tmp_path / "s.png")


def test_plots_leave_backend_alone(tmp_path):
    """Importing and drawing neither switches the backend nor imports pyplot."""
    code = textwrap.dedent(f"""
        import sys, matplotlib
        matplotlib.use("svg")
        import viscore.metrics.plots as plots
        assert "matplotlib.pyplot" not in sys.modules
        rows = [{{"mesh": "m", "method": "qem", "budget": 8, "triangles": 8, "recall": 0.5,
                 "precision": 0.9, "per_view": {{"recall": [0.4, 0.6]}}}}]
        plots.budget_plot(rows, {str(tmp_path / "b.png")!r})
        plots.recall_plot(rows, {str(tmp_path / "r.png")!r})
        print(matplotlib.get_backend(), "matplotlib.pyplot" in sys.modules)
    """)
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, check=True).stdout.split()
    assert out == ["svg", "False"]
    assert (tmp_path / "b.png").stat().st_size > 0


def test_plots_import_keeps_backend_in_process(tmp_path):
    import matplotlib

    before = matplotlib.get_backend()
    import viscore.metrics.plots  # noqa: F401

    budget_plot(_rows(), tmp_path / "b.png")
    assert matplotlib.get_backend() == before


def test_plot_files_get_the_mode_open_gives(tmp_path):
    # the figures are written atomically like every output: 0o666 & ~umask, not mkstemp's 0o600
    import os
    import stat

    from matplotlib.figure import Figure

    from viscore.metrics.plots import _save

    old = os.umask(0o022)
    try:
        _save(Figure(figsize=(1, 1)), tmp_path / "f.png")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "f.png").stat().st_mode) == 0o644
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
