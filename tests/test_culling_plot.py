"""culling_plot (viscore.metrics.plots): small multiples, integer frame ticks, log when needed."""

from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

import viscore.metrics.plots as plots
from viscore import InputError
from viscore.metrics.plots import CULLING_LOG_SPAN, culling_plot


def _result(frames=20, big=0, names=("none", "planar-frusta", "solid-frusta",
                                      "depth-buffer:aabb-skins")):
    """A walk where every runtime renders one dominant part of ``big`` triangles plus a few."""
    x = np.arange(frames)
    runtimes = {}
    for k, name in enumerate(names):
        runtimes[name] = SimpleNamespace(triangles_rendered=big + 1000 - 100 * k + 10 * (x % 3))
    return SimpleNamespace(cameras=[None] * frames, runtimes=runtimes,
                           visible_triangles=big + 500 + 0 * x)


def _figures(monkeypatch):
    figures = []
    monkeypatch.setattr(plots, "_save", lambda fig, path: figures.append(fig))
    return figures


def test_culling_plot_one_panel_per_runtime_with_the_references(monkeypatch, tmp_path):
    figures = _figures(monkeypatch)
    result = _result()
    culling_plot(result, tmp_path / "t.png")
    fig, = figures
    shown = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title() for ax in shown] == ["planar-frusta", "solid-frusta",
                                                "depth-buffer:aabb-skins"]
    for ax in shown:
        ys = [line.get_ydata().tolist() for line in ax.get_lines()]
        assert result.runtimes["none"].triangles_rendered.tolist() in ys
        assert result.visible_triangles.tolist() in ys
        assert result.runtimes[ax.get_title()].triangles_rendered.tolist() in ys
        assert len(ys) == 3  # its own line and the two references, no other runtime's


def test_culling_plot_frame_ticks_are_integers(monkeypatch, tmp_path):
    figures = _figures(monkeypatch)
    culling_plot(_result(frames=6), tmp_path / "t.png")
    fig, = figures
    fig.canvas.draw()
    ax = fig.axes[0]
    lo, hi = ax.get_xlim()
    ticks = [t for t in ax.get_xticks() if lo <= t <= hi]
    assert len(ticks) >= 2
    assert all(float(t).is_integer() for t in ticks)  # no frame 2.5


def test_culling_plot_log_axis_when_counts_span_decades(monkeypatch, tmp_path):
    figures = _figures(monkeypatch)
    culling_plot(_result(big=0), tmp_path / "a.png")  # 500 to 1,020: linear
    spread = _result(big=0)
    spread.visible_triangles = spread.visible_triangles.copy()
    spread.visible_triangles[3] = 1000 // (CULLING_LOG_SPAN + 1)  # a frame seeing almost none
    culling_plot(spread, tmp_path / "b.png")
    linear, log = figures
    assert {ax.get_yscale() for ax in linear.axes if ax.get_visible()} == {"linear"}
    assert {ax.get_yscale() for ax in log.axes if ax.get_visible()} == {"log"}


def test_culling_plot_png_size(tmp_path):
    culling_plot(_result(names=("none", "a", "b", "c", "d")), tmp_path / "t.png", title="t")
    img = Image.open(tmp_path / "t.png")
    # 1100 px wide; two rows of panels (4 runtimes beside none, 3 a row) and the title
    assert img.size == (1100, int(round(100 * (2 * plots._CULLING_ROW_INCHES + 0.4))))


def test_culling_plot_only_none(monkeypatch, tmp_path):
    figures = _figures(monkeypatch)
    culling_plot(_result(names=("none",)), tmp_path / "t.png")
    assert [ax.get_title() for ax in figures[0].axes if ax.get_visible()] == ["none"]


def test_culling_plot_invalid_input(tmp_path):
    with pytest.raises(InputError, match="figure"):
        culling_plot(_result(), tmp_path / "t.txt")
    with pytest.raises(InputError, match="no frames"):
        culling_plot(_result(frames=0), tmp_path / "t.png")
