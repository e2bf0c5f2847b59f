"""The one plotting helper of the benchmarks: a figure with its own canvas, saved atomically."""

from __future__ import annotations

import io
import os
from pathlib import Path

from viscore._atomic import write_atomic

__all__ = ["figure", "save"]

#: Dots per inch of every benchmark figure.
DPI = 100


def figure(width: float, height: float):
    """A matplotlib figure of ``width`` x ``height`` inches with an Agg canvas (no pyplot)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def save(fig, path: str | os.PathLike) -> None:
    """Render ``fig`` in the format of ``path``'s suffix (default PNG) and write it atomically.

    Missing parent folders are made (the ablation folders the benchmarks are given).
    """
    path = Path(path)
    buf = io.BytesIO()
    fig.savefig(buf, format=path.suffix.lstrip(".") or "png")
    write_atomic(path, buf.getvalue(), parents=True)
