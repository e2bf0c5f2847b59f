"""One look for the report pages: the Jinja2 templates, number formatting, inline pictures.

``compare``'s ``report.html`` (:mod:`viscore.cli.study.report`), ``cull``'s
(:mod:`.cull_page`) and ``occlude``'s (:mod:`.occlude_page`) extend one base
template (``templates/base.html.j2``: heading, section links, settings,
provenance, footer) and share its style and macros (``macros.html.j2``:
tables, key-value tables, pictures with a name to cite). Every page is one
self-contained file: pictures are inline ``data:image/png`` URIs, nothing is
loaded from elsewhere and no script runs, so a page opens offline and can be
mailed or archived as one file. Text is escaped by the template engine
(autoescape), never by hand, after :func:`printable` made it valid Unicode
without control characters (a file name's undecodable bytes, a glTF name's
NUL or escape character).
"""

from __future__ import annotations

import base64
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from markupsafe import Markup

__all__ = ["render_page", "format_number", "cell_text", "data_uri", "Picture", "cite_name",
           "format_interval", "format_share", "printable"]

#: The templates' folder, installed with the package.
TEMPLATES = Path(__file__).resolve().parent / "templates"

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

#: What :func:`printable` replaces: UTF-16 surrogates (a file name's undecodable bytes,
#: as Python's surrogateescape holds them, or a JSON string's lone ``\\ud800``) and
#: control characters other than tab, line feed and carriage return (C0, DEL, C1).
_UNPRINTABLE = re.compile("[\ud800-\udfff\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]")
#: Shown in place of each: U+FFFD REPLACEMENT CHARACTER.
_REPLACEMENT = "\ufffd"


def printable(text) -> str:
    """``text`` as valid Unicode without control characters, each other character kept.

    A page is UTF-8 and a plot title goes through a font: neither can hold a
    surrogate (a non-UTF-8 file name's byte ``0xff`` is ``\\udcff`` in Python),
    and a NUL or an escape character in HTML is a parse error. Each such
    character becomes U+FFFD; tab, line feed and carriage return stay.

    Examples
    --------
    >>> printable("bad\\udcffname\\x00")
    'bad\ufffdname\ufffd'
    >>> printable("<script>")
    '<script>'
    """
    return _UNPRINTABLE.sub(_REPLACEMENT, str(text))


def _finalize(value):
    """Every text a template shows, made :func:`printable` (markup the code built, such as
    compare's links, is left as it is: its text went through the escape already)."""
    if isinstance(value, str) and not isinstance(value, Markup):
        return printable(value)
    return value


def format_number(value, digits: int = 4) -> str:
    """A number as the tables show it: integers plain (thousands separated from 10,000),
    floats with ``digits`` decimals (significant digits when very large or small),
    ``-`` for NaN or inf."""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (int, np.integer)):
        return f"{int(value):,}" if abs(int(value)) >= 10_000 else str(int(value))
    v = float(value)
    if not math.isfinite(v):
        return "-"
    if v != 0 and (abs(v) >= 1e4 or abs(v) < 1e-3):
        return f"{v:.{digits}g}"
    return f"{v:.{digits}f}"


def _numeric(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating, np.bool_))


def cell_text(value) -> str:
    """Text of a table cell (not escaped: the template escapes it); ``-`` for None,
    ``[a, b]`` for an interval or list, ``key: value, ...`` for a mapping."""
    if value is None:
        return "-"
    if isinstance(value, Mapping):
        return ", ".join(f"{k}: {cell_text(v)}" for k, v in value.items())
    if isinstance(value, (list, tuple, np.ndarray)):
        return "[" + ", ".join(cell_text(v) for v in value) + "]"
    if _numeric(value):
        return format_number(value)
    return str(value)


def format_share(value) -> str:
    """A share in [0, 1] as a percentage with one decimal, ``-`` when undefined."""
    if value is None or not math.isfinite(float(value)):
        return "-"
    return f"{100 * float(value):.1f}%"


def format_interval(interval, kind: str = "share") -> str:
    """``[low, high]`` as shares (percentages) or counts; ``-`` when undefined."""
    if interval is None or len(interval) != 2:
        return "-"
    lo, hi = (float(x) if x is not None else math.nan for x in interval)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return "-"
    if kind == "share":
        return f"[{100 * lo:.1f}, {100 * hi:.1f}]%"
    return f"[{lo:,.0f}, {hi:,.0f}]"


@dataclass(frozen=True)
class _Cell:
    text: str
    classes: str


def _cell(row, key: str) -> _Cell:
    """A row's cell for the table macro: its text and classes (``num`` for numbers,
    plus the row's ``_classes[key]``)."""
    value = row.get(key)
    numeric = _numeric(value) or isinstance(value, (list, tuple, np.ndarray))
    classes = (["num"] if numeric and value is not None else []) + (
        [row["_classes"][key]] if key in row.get("_classes", {}) else [])
    return _Cell(cell_text(value), " ".join(classes))


def data_uri(png: bytes) -> str:
    """PNG bytes as a ``data:image/png;base64`` URI."""
    if not png.startswith(_PNG_SIGNATURE):
        raise ValueError("not PNG data")
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def cite_name(*parts: str) -> str:
    """A picture's name to cite and save it by: its parts joined by ``-``, each reduced to
    lower-case letters, digits, ``.`` and ``_`` (``depth-buffer:aabb-skins`` ->
    ``depth-buffer_aabb-skins``).

    Examples
    --------
    >>> cite_name("city", "frame-007", "depth-buffer:aabb-skins")
    'city-frame-007-depth-buffer_aabb-skins'
    """
    clean = [re.sub(r"[^a-z0-9._-]+", "_", str(p).lower()).strip("_") for p in parts]
    return "-".join(c for c in clean if c)


@dataclass(frozen=True)
class Picture:
    """An inline picture of a page: its data URI, name to cite, alt text and caption.

    ``map`` names an image map of the page (the plan's frames link to them).
    """

    uri: str
    name: str
    alt: str
    caption: str
    width: int | None = None
    height: int | None = None
    map: str | None = None


def picture(png: bytes, name: str, alt: str, caption: str, **kw) -> Picture:
    """A :class:`Picture` of PNG bytes, with its pixel size read from the PNG header."""
    width = int.from_bytes(png[16:20], "big")
    height = int.from_bytes(png[20:24], "big")
    return Picture(uri=data_uri(png), name=name, alt=alt, caption=caption, width=width,
                   height=height, **kw)


def _environment():
    from jinja2 import Environment, FileSystemLoader, StrictUndefined

    env = Environment(loader=FileSystemLoader(str(TEMPLATES)), autoescape=True,
                      finalize=_finalize, undefined=StrictUndefined, trim_blocks=True,
                      lstrip_blocks=True, keep_trailing_newline=True)
    env.filters.update(number=format_number, cell_text=cell_text, cell=_cell,
                       share=format_share, interval=format_interval)
    return env


_ENV = None


def render_page(template: str, **context) -> str:
    """Render one page from ``templates/<template>``; the base's variables default empty.

    Parameters
    ----------
    template : str
        ``compare.html.j2``, ``cull.html.j2`` or ``occlude.html.j2``.
    **context
        The page's variables; ``title``, ``heading``, ``lead``, ``sections``
        (``(id, name)`` pairs), ``settings``, ``provenance``, ``command`` and
        ``version`` default to empty.

    Returns
    -------
    html : str
    """
    import viscore

    global _ENV
    if _ENV is None:
        _ENV = _environment()
    base = {"title": "viscore", "heading": "viscore", "lead": "", "sections": (),
            "settings": {}, "provenance": {}, "version": viscore.__version__}
    return _ENV.get_template(template).render(**{**base, **context})
