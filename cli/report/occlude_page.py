"""``occlude -o DIR``'s ``preview.png`` and ``report.html``: the level and each method's occluders.

Each method's occluders are read back from the ``<method>.tscn`` the run wrote
(:func:`viscore.load_occluder`, as Godot would place them) and turned from
Godot's +Y-up frame back into the level's; the level is ray-cast from a few
views (:func:`.pictures.level_views`: from above, and obliquely from two
sides) with each method's occluders drawn over it. ``preview.png`` holds them
as a grid (views by methods); the page shows them one by one, named
``<level>-<view>-<method>``, then the methods' totals and, per object, each
method's triangles, guarantee or refusal reason (``occlude.json``'s).

References
----------
.. [1] Godot Engine documentation, "Occlusion culling" (``OccluderInstance3D``,
   ``ArrayOccluder3D``), https://docs.godotengine.org/en/stable/tutorials/3d/occlusion_culling.html
"""

from __future__ import annotations

import logging
import tempfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from viscore import InputError, Scene, load_occluder
from viscore._atomic import write_atomic

from .page import cite_name, picture, printable, render_page
from .pictures import level_picture, level_views, png_bytes

__all__ = ["write_occlude_report", "OCCLUDE_REPORT_FILES", "OCCLUDER_PREVIEW_RGB",
           "OBJECT_ROWS", "NAME_CHARS"]

_log = logging.getLogger(__name__)

#: The files :func:`write_occlude_report` writes into the folder.
OCCLUDE_REPORT_FILES = ("preview.png", "report.html")
#: Occluders on the occlude pictures: orange (compare's occluder colour), half opaque.
OCCLUDER_PREVIEW_RGB = (0.95, 0.45, 0.10)
_PREVIEW_ALPHA = 0.5
#: Objects listed one by one in the page's table (the chosen ones first); the rest
#: are counted.
OBJECT_ROWS = 2000
#: Characters of an object's or mesh's name shown in the table (occlude.json holds it
#: whole): a glTF node's name can be megabytes, one table row as wide.
NAME_CHARS = 120


def _shown_name(name) -> str:
    """A name cut to :data:`NAME_CHARS` characters (an ellipsis saying so)."""
    text = str(name)
    return text if len(text) <= NAME_CHARS else text[:NAME_CHARS - 1] + "\u2026"


def _method_scenes(out: Path, manifest: Mapping) -> dict[str, Scene | None]:
    """Each method's occluders in the level's frame, one Embree scene each (None: none)."""
    back = np.linalg.inv(np.asarray(manifest["to_godot"], dtype=np.float64))
    scenes: dict[str, Scene | None] = {}
    for method, summary in manifest["methods"].items():
        tscn = next((f for f in summary.get("files", ()) if f.endswith(".tscn")), None)
        if tscn is None:
            scenes[method] = None
            continue
        mesh = load_occluder(out / tscn)
        mesh.apply_transform(back)
        scenes[method] = Scene(mesh)
    return scenes


def _object_rows(manifest: Mapping, methods: list[str]) -> tuple[list[dict], int]:
    rows = []
    ordered = sorted(manifest["objects"].items(),
                     key=lambda kv: (not kv[1]["chosen"], -kv[1]["size"], kv[0]))
    for name, row in ordered[:OBJECT_ROWS]:
        entry = {"object": _shown_name(name), "mesh": _shown_name(row["mesh"]),
                 "size": f"{row['size']:.3f}",
                 "chosen": "yes" if row["chosen"] else "no: " + str(row.get("refused") or ""),
                 "_classes": {}}
        for m in methods:
            occ = row["occluders"].get(m)
            if occ is None:
                entry[m] = "-"
            elif "refused" in occ:
                entry[m] = "refused: " + str(occ["refused"])
                entry["_classes"][m] = "refused"
            else:
                entry[m] = (f"{occ['triangles']:,} triangles, "
                            + ("guaranteed" if occ["conservative_guaranteed"]
                               else "not guaranteed"))
        rows.append(entry)
    return rows, max(0, len(ordered) - OBJECT_ROWS)


def write_occlude_report(out: str | Path, level, manifest: Mapping) -> list[str]:
    """Write ``preview.png`` and ``report.html`` into an ``occlude`` output folder.

    Parameters
    ----------
    out : path
        The folder, holding the run's ``<method>.tscn`` files.
    level : LevelObjects
        The level the run read.
    manifest : mapping
        The run's ``occlude.json`` document.

    Returns
    -------
    list of str
        The files written, relative to ``out``.

    Raises
    ------
    InputError
        A method's ``.tscn`` that cannot be read back.

    Notes
    -----
    Each file is written atomically. Pictures: one ray per pixel per view for
    the level and one per view and method for its occluders.
    """
    from viscore.metrics import picture_grid

    out = Path(out)
    objects = level.objects
    methods = list(manifest["methods"])
    try:
        scenes = _method_scenes(out, manifest)
    except InputError as exc:
        raise InputError(f"report: {exc}") from None
    views = level_views(objects)
    # a file name's undecodable bytes cannot go into the plot's title or the UTF-8 page
    label = printable(Path(str(manifest.get("level", objects.source))).stem)
    grid, pictures = [], []
    for view, camera in views:
        row = []
        for m in methods:
            rgb = level_picture(objects, camera, highlight=level.chosen, occluders=scenes[m],
                                occluder_rgb=OCCLUDER_PREVIEW_RGB, alpha=_PREVIEW_ALPHA)
            row.append(rgb)
            s = manifest["methods"][m]
            caption = (f"{label} {view}, {m}: {s['triangles']:,} occluder triangles over "
                       f"{s['objects']:,} objects ({s['refused']:,} refused), "
                       + ("all guaranteed." if s["conservative_guaranteed"] else
                          "not all guaranteed."))
            pictures.append(picture(png_bytes(rgb), cite_name(label, view, m),
                                    f"{label} {view} with the {m} occluders", caption))
        grid.append(row)
    with tempfile.TemporaryDirectory(prefix="viscore-report-") as tmp:
        file = Path(tmp) / "preview.png"
        picture_grid(grid, file, row_labels=[v for v, _ in views], column_labels=methods,
                     title=f"{label}: each method's occluders (orange) over the level")
        preview = file.read_bytes()
    rows, more = _object_rows(manifest, methods)
    columns = [("object", "object"), ("mesh", "mesh"), ("size", "size (of the level)"),
               ("chosen", "chosen")] + [(m, m) for m in methods]
    summary = [{"method": m, **{k: v for k, v in s.items() if k != "files"},
                "conservative_guaranteed": "yes" if s["conservative_guaranteed"] else "no",
                "files": ", ".join(s.get("files", ())) or "-"}
               for m, s in manifest["methods"].items()]
    summary_columns = [("method", "method"), ("objects", "objects"), ("refused", "refused"),
                       ("meshes", "distinct meshes"), ("triangles", "triangles"),
                       ("conservative_guaranteed", "guaranteed"), ("seconds", "seconds"),
                       ("files", "files")]
    settings = {"level": manifest.get("level"), "up": manifest.get("up"),
                "up reason": manifest.get("up_reason"), **manifest.get("settings", {}),
                "objects": manifest.get("objects_total"),
                "chosen": manifest.get("objects_chosen")}
    html = render_page(
        "occlude.html.j2", title=f"viscore occlude: {label}",
        heading=f"viscore occlude: {label}",
        lead=(f"{manifest['objects_total']:,} objects, {manifest['objects_chosen']:,} chosen "
              f"for occluders (up +{str(manifest['up']).upper()}); methods "
              f"{', '.join(methods)}."),
        sections=(("methods", "methods"), ("views", "views"), ("objects", "objects"),
                  ("settings", "settings")),
        summary=summary, summary_columns=summary_columns,
        methods=methods, pictures=pictures, rows=rows, columns=columns, more=more,
        settings=settings)
    write_atomic(out / "preview.png", preview)
    write_atomic(out / "report.html", html.encode("utf-8"))
    return list(OCCLUDE_REPORT_FILES)
