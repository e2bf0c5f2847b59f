"""``cull --out DIR``'s ``report.html``: the answer with its intervals, then the pictures.

The page leads with the table of ``cull.json`` (the truth's hidden share and
each runtime's culled share with their 95% block-bootstrap intervals, false
culls, triangles and overhead), then a plan of the level seen from above with
the camera walk on it (:func:`viscore.metrics.plots.walk_plot`; frames
numbered, far views marked, the drawn frames linked), then the frames, each
ray-cast once per runtime with every object tinted by what happened to it
(:mod:`.pictures`) and the runtime's occluders drawn over it; a row of buttons
picks the runtime (plain HTML and CSS, no script), and the triangles plot.
Pictures are named ``<scene>-frame-<NNN>-<runtime>`` and ``<scene>-plan`` so
that one can be cited and saved by name.

Long walks are sampled: :func:`report_frames` draws at most
:data:`REPORT_FRAMES` frames spread over the walk unless ``--report-frames``
names others.

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006 (Plzen), UNION Agency,
   ISBN 80-86943-03-8 (sec. 4, Figures 5-6: primitives rendered per frame).
.. [2] Politis, D. N., Romano, J. P. "A Circular Block-Resampling Procedure
   for Stationary Data". In: LePage, R., Billard, L. (eds.), Exploring the
   Limits of Bootstrap, Wiley, 1992, pp. 263-270.
"""

from __future__ import annotations

import logging
import re
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from viscore import InputError

from .page import Picture, cite_name, format_interval, format_share, picture, render_page
from .pictures import (
    FRAME_WIDTH,
    OCCLUDER_RGB,
    PLAN_PIXELS,
    STATE_RGB,
    FrameRays,
    frame_base,
    frame_picture,
    occluder_image,
    plan_picture,
    png_bytes,
)

__all__ = ["report_frames", "cull_report_html", "check_report_memory", "frame_size",
           "REPORT_FRAMES",
           "MAX_REPORT_FRAMES", "RUNTIME_COLUMNS"]

_log = logging.getLogger(__name__)

#: Frames drawn by default: all of a walk up to this many, else this many spread over it.
REPORT_FRAMES = 16
#: Most frames ``--report-frames`` may draw. Each is ray-cast once per runtime and held
#: inline in the page until it is written: 1,000 frames of the default five runtimes are
#: 5,000 pictures, a page of hundreds of MB that a browser opens slowly; ``all`` of a
#: 100,000-frame walk would be hours of drawing and gigabytes held.
MAX_REPORT_FRAMES = 1000

#: One item of ``--report-frames``: a frame or a range of frames, ASCII digits only
#: (Python's int() also takes '+1', '1_0' and other scripts' digits).
_FRAME_ITEM = re.compile(r"([0-9]+)(?:-([0-9]+))?")

#: Peak bytes per pixel of a picture: the rays (``PerspectiveCamera.rays``' own
#: estimate, 160), three casts of it held at once (the level, the hidden objects, the
#: occluders: object, triangle, normal, facing and depth, 40 each) and the shading's
#: float32 images.
_BYTES_PER_PICTURE_PIXEL = 320

#: Columns of the page's table: (key, header).
RUNTIME_COLUMNS = (
    ("runtime", "runtime"), ("share", "culled share"), ("share_ci", "95% interval"),
    ("false_culls", "false culls"), ("frames_with_false_culls", "frames with false culls"),
    ("triangles", "triangles per frame"), ("triangles_ci", "95% interval"),
    ("overhead_ms", "overhead ms (mean)"), ("overhead_ms_max", "overhead ms (max)"),
    ("conservative", "conservative"),
)


def report_frames(count: int, text: str | None = None, *, option: str = "--report-frames"
                  ) -> list[int]:
    """The frames the page draws: ``all``, or frames and ranges ``3,10-14``; by default all
    of a walk of up to :data:`REPORT_FRAMES` frames, else that many spread evenly over it
    (the first and the last included).

    Raises
    ------
    InputError
        A frame outside the walk, a range that runs backwards, more than
        :data:`MAX_REPORT_FRAMES` frames, or text that is neither ``all`` nor frames
        and ranges of ASCII digits.

    Examples
    --------
    >>> report_frames(100)[:4], len(report_frames(100))
    ([0, 7, 13, 20], 16)
    >>> report_frames(100, "3,10-12"), len(report_frames(40, "all"))
    ([3, 10, 11, 12], 40)
    """
    if text is None:
        if count <= REPORT_FRAMES:
            return list(range(count))
        return sorted(set(np.round(np.linspace(0, count - 1, REPORT_FRAMES)).astype(int)
                          .tolist()))
    text = str(text).strip()
    if text == "all":
        _check_drawn(count, count, option, text)
        return list(range(count))
    ranges = []
    for item in text.split(","):
        item = item.strip()
        match = _FRAME_ITEM.fullmatch(item)
        if match is None:
            raise InputError(f"{option}: expected 'all' or frames and ranges such as 3,10-14, "
                             f"got {text!r}")
        first = int(match[1])
        last = int(match[2]) if match[2] is not None else first
        if last < first:
            raise InputError(f"{option}: range {item} runs backwards (write {last}-{first})")
        if last >= count:
            raise InputError(f"{option}: frame {last} is not in the walk's 0-{count - 1}")
        ranges.append((first, last))
    # counted before the frames are listed (0-99999 is one item), overlaps once
    drawn, end = 0, -1
    for first, last in sorted(ranges):
        drawn += max(0, last - max(first, end + 1) + 1)
        end = max(end, last)
    _check_drawn(drawn, count, option, text)
    return sorted({f for first, last in ranges for f in range(first, last + 1)})


def _check_drawn(drawn: int, count: int, option: str, text: str) -> None:
    if drawn > MAX_REPORT_FRAMES:
        raise InputError(f"{option} {text}: {drawn:,} frames of the walk's {count:,}, more than "
                         f"the {MAX_REPORT_FRAMES:,} a page draws (each frame is ray-cast per "
                         "runtime and held in the page); name fewer frames")


def frame_size(width: int, height: int) -> tuple[int, int]:
    """Pixels (across, down) of a frame's picture: the truth's ``width`` x ``height``
    aspect ratio fitted in a square of :data:`~.pictures.FRAME_WIDTH` pixels (a wide view
    is that many across, as the page lays them out; a tall one that many down, so that
    ``--width 1 --height 8192`` is a 1 x 480 picture, not 480 x 3.9 million).

    Examples
    --------
    >>> frame_size(1280, 720), frame_size(720, 1280), frame_size(1, 8192)
    ((480, 270), (270, 480), (1, 480))
    """
    if width >= height:
        return FRAME_WIDTH, max(1, round(FRAME_WIDTH * height / width))
    return max(1, round(FRAME_WIDTH * width / height)), FRAME_WIDTH


def check_report_memory(width: int, height: int) -> None:
    """Refuse, before any work, a page whose pictures do not fit in memory: the plan
    (:data:`~.pictures.PLAN_PIXELS` square) or a frame (:func:`frame_size`), whichever
    is larger.

    Raises
    ------
    InputError
        One line (:func:`viscore._validate.check_memory`).
    """
    from viscore._validate import check_memory

    across, down = frame_size(width, height)
    pixels = max(PLAN_PIXELS**2, across * down)
    check_memory(float(pixels) * _BYTES_PER_PICTURE_PIXEL, "report.html's pictures")


def _rgb_css(rgb) -> str:
    return "rgb({}, {}, {})".format(*(int(round(255 * c)) for c in rgb))


def _table_rows(doc: Mapping) -> list[dict]:
    rows = []
    for name, t in doc["totals"].items():
        culled = t.get("culled", t.get("culled_share", 0))
        conservative = ("-" if not culled else "yes" if t["conservative"] else "no")
        row = {"runtime": name, "share": format_share(t["culled_share"]),
               "share_ci": format_interval(t.get("culled_share_ci")),
               "false_culls": int(t["false_culls"]),
               "frames_with_false_culls": int(t.get("frames_with_false_culls", 0)),
               "triangles": f"{t['triangles_rendered_per_frame']:,.0f}",
               "triangles_ci": format_interval(t.get("triangles_rendered_per_frame_ci"),
                                               "count"),
               "overhead_ms": float(t["overhead_ms"]),
               "overhead_ms_max": float(t.get("overhead_ms_max", t["overhead_ms"])),
               "conservative": conservative}
        if t["false_culls"] and t["conservative"]:
            row["_classes"] = {"false_culls": "bad", "conservative": "bad"}
        rows.append(row)
    gt = doc["ground_truth"]
    frames = max(1, doc["settings"]["frames"])
    rows.append({"_class": "truth", "runtime": "ray-cast truth (hidden share)",
                 "share": format_share(gt["hidden_share"]),
                 "share_ci": format_interval(gt.get("hidden_share_ci")), "false_culls": 0,
                 "frames_with_false_culls": 0,
                 "triangles": f"{gt['triangles_visible'] / frames:,.0f}", "triangles_ci": None,
                 "overhead_ms": None, "overhead_ms_max": None, "conservative": None})
    return rows


def _answer(doc: Mapping) -> str:
    """The page's first sentence: what the truth hides and what the best runtimes cull."""
    gt = doc["ground_truth"]
    frames = doc["settings"]["frames"]
    text = (f"Along {frames:,} frame{'s' if frames != 1 else ''}, the ray-cast truth hides "
            f"{format_share(gt['hidden_share'])} {format_interval(gt.get('hidden_share_ci'))} "
            "of the objects in the view frustum.")
    totals = {k: t for k, t in doc["totals"].items() if k != "none"}
    safe = {k: t for k, t in totals.items() if t["conservative"]}
    for label, group in (("guaranteed", safe), ("not guaranteed", {
            k: t for k, t in totals.items() if not t["conservative"]})):
        if not group:
            continue
        name, t = max(group.items(), key=lambda kv: kv[1]["culled_share"])
        text += (f" The best {label} runtime, {name}, culls "
                 f"{format_share(t['culled_share'])} "
                 f"{format_interval(t.get('culled_share_ci'))} with {t['false_culls']:,} "
                 f"false cull{'s' if t['false_culls'] != 1 else ''}.")
    return text


def _far(objects, positions: np.ndarray) -> np.ndarray:
    """(F,) bool: cameras outside the level's built box, seen from above."""
    up = np.asarray(objects.up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    box, _ = objects.built_bounds()
    flat = positions - np.outer(positions @ up, up)
    lo = box[0] - np.outer(box[0] @ up, up)[0]
    hi = box[1] - np.outer(box[1] @ up, up)[0]
    low, high = np.minimum(lo, hi), np.maximum(lo, hi)
    span = 1e-9 * max(1.0, float(np.linalg.norm(high - low)))
    return ((flat < low - span) | (flat > high + span)).any(axis=1)


def _plan(objects, cameras, frames: Sequence[int], scene: str, highlight) -> tuple[Picture,
                                                                                  list]:
    """The plan with the walk on it, and the image-map marks of the drawn frames."""
    from viscore.metrics import walk_plot

    plan = plan_picture(objects, highlight=highlight)
    positions = np.array([c.position for c in cameras], dtype=np.float64)
    forward = np.array([c.forward for c in cameras], dtype=np.float64)
    pixels, _ = plan.camera.project(positions)
    ahead, _ = plan.camera.project(positions + forward * 1e-3 * plan.camera.extent)
    far = _far(objects, positions)
    with tempfile.TemporaryDirectory(prefix="viscore-report-") as tmp:
        file = Path(tmp) / "plan.png"
        marks = walk_plot(plan.rgb, pixels, file, far=far, shown=frames,
                          headings=ahead - pixels)
        png = file.read_bytes()
    name = cite_name(scene, "plan")
    caption = (f"{scene} from above (orthographic, one ray per pixel; objects with occluders "
               f"in blue-grey), the camera walk of {len(cameras):,} frames: every few frames "
               "numbered, a tick for where each camera looks, "
               f"{int(far.sum())} far view{'s' if far.sum() != 1 else ''} (outside the "
               "level) as triangles, the frames drawn below circled (click one to go to it).")
    pic = picture(png, name, f"plan of {scene} with the camera walk", caption,
                  map=f"{name}-frames")
    area = [(int(k), int(round(marks[k, 0])), int(round(marks[k, 1]))) for k in frames]
    return pic, area


def _frame_pictures(result, objects, runtimes: Mapping, frames: Sequence[int], scene: str,
                    progress: Callable[[int], None] | None) -> list[dict]:
    width, height = frame_size(result.width, result.height)
    out = []
    for f in frames:
        pose = result.cameras[f]
        camera = FrameRays(pose.camera(width, height))
        truth = pose.camera(result.width, result.height)  # the runtimes' own view of it
        kept = result.kept[f]
        seen, hidden = frame_base(objects, camera, kept)
        pictures = []
        cast: list = []  # (scene, image): runtimes sharing occluders cast them once
        for name, runtime in runtimes.items():
            scene_of = getattr(runtime, "occluder_scene", None)
            occ = None
            if scene_of is not None and (occ_scene := scene_of(truth)) is not None:
                occ = next((img for other, img in cast if _same_scene(other, occ_scene)), None)
                if occ is None:
                    occ = occluder_image(occ_scene, camera)
                    cast.append((occ_scene, occ))
            rgb, n = frame_picture(len(objects), seen, hidden, kept, name, occ)
            caption = (f"Frame {f} of {len(result.cameras):,}, {name}: culled {n.culled:,} of "
                       f"the {n.in_view:,} objects in view ({n.false_culls:,} false), "
                       f"{n.missed:,} hidden yet drawn; the truth sees {n.visible:,}; "
                       f"{n.outside:,} outside the view frustum.")
            pictures.append(picture(png_bytes(rgb), cite_name(scene, f"frame-{f:03d}", name),
                                    f"frame {f}, {name}", caption))
        out.append({"index": int(f), "pictures": pictures})
        if progress is not None:
            progress(1)
    return out


def _same_scene(a, b) -> bool:
    """Whether two Embree scenes hold the same triangles (the frusta runtimes' solids)."""
    return a is b or (a.faces.shape == b.faces.shape and a.vertices.shape == b.vertices.shape
                      and np.array_equal(a.faces, b.faces)
                      and np.array_equal(a.vertices, b.vertices))


def cull_report_html(result, objects, runtimes: Mapping, doc: Mapping, *, scene: str,
                     frames: Sequence[int], triangles_png: bytes | None = None,
                     highlight: Sequence[int] | None = None, hint: str | None = None,
                     progress: Callable[[int], None] | None = None) -> bytes:
    """The page of a ``viscore cull`` run, UTF-8.

    Parameters
    ----------
    result : CullingResult
        Of :func:`viscore.metrics.culling.simulate_culling`, run with
        ``keep_frames=frames``.
    objects : SceneObjects
        The level.
    runtimes : mapping of str -> Runtime
        The runtimes simulated (their ``occluder_scene`` is drawn).
    doc : mapping
        The run's ``cull.json`` document (its numbers fill the table).
    scene : str
        The level's name, in the page and the pictures' names.
    frames : sequence of int
        The frames drawn (:func:`report_frames`).
    triangles_png : bytes, optional
        ``triangles.png``, shown last.
    highlight : sequence of int, optional
        The objects with occluders, tinted on the plan.
    hint : str, optional
        A line under the table.
    progress : callable, optional
        Called with 1 after each frame drawn.

    Returns
    -------
    html : bytes

    Raises
    ------
    InputError
        A frame the simulation did not keep.
    """
    missing = [f for f in frames if f not in result.kept]
    if missing:
        raise InputError(f"frames: the simulation kept no objects of frame {missing[0]} "
                         "(simulate_culling keep_frames)")
    names = list(runtimes)
    totals = doc["totals"]
    guaranteed = [n for n in names if n != "none" and totals[n]["conservative"]]
    best = max(guaranteed or [n for n in names if n != "none"] or names,
               key=lambda n: totals[n]["culled_share"])
    plan, marks = _plan(objects, result.cameras, frames, scene, highlight)
    drawn = _frame_pictures(result, objects, runtimes, frames, scene, progress)
    iv = doc.get("intervals", {})
    count = doc["settings"]["frames"]
    table_note = (
        "Culled share: of the objects in the view frustum, over all frames (view frustum "
        "culling first, the same for every runtime); 95% interval: circular block bootstrap "
        f"over the {count:,} frames in blocks of {iv.get('block', '?')} consecutive frames "
        f"({iv.get('resamples', '?')} resamples, seed {iv.get('seed', '?')}"
        + (f", the '{iv['stream']}' stream of --seed {doc.get('seed')}" if iv.get("stream")
           else "") + "; Politis and Romano 1992), since neighbouring frames see nearly the "
        "same objects. False culls: "
        "culled objects the ray-cast object-id image sees, summed over frames. Triangles: "
        "of the objects sent to render, per frame. Overhead: the runtime's own time per "
        "frame. Conservative: the runtime's guarantee ('-' where it culled nothing).")
    across, down = frame_size(result.width, result.height)
    frames_note = (
        f"{len(frames)} of the walk's {count:,} frames, ray-cast at {across} x {down} "
        "pixels; each object is tinted by what happened to it in that frame, the objects "
        "hidden behind what the camera sees are drawn through it, translucent, and the "
        "chosen runtime's occluders are drawn over the view (frusta runtimes: all their "
        "solids, of which each frame uses the best ranked). Pick the runtime with the "
        "buttons; other frames: cull --report-frames (e.g. 3,10-14 or all).")
    triangles = None
    if triangles_png is not None:
        triangles = picture(triangles_png, cite_name(scene, "triangles"),
                            "triangles rendered per frame",
                            "Triangles rendered per frame, each runtime against 'none' (every "
                            "object in view, grey) and the ray-cast truth (dashed): "
                            "Papaioannou et al. 2006, Figs. 5-6.")
    colors = {k: _rgb_css(v) for k, v in STATE_RGB.items()} | {
        "occluder": _rgb_css(OCCLUDER_RGB)}
    settings = {"scene": scene, **doc["settings"], "seed": doc.get("seed"),
                "bounds": doc.get("bounds"), "frusta from": doc.get("frusta_method"),
                "intervals": iv}
    html = render_page(
        "cull.html.j2", title=f"viscore cull: {scene}", heading=f"viscore cull: {scene}",
        lead=(f"{doc['settings']['objects']:,} objects ({doc['settings']['triangles']:,} "
              f"triangles), {doc.get('occluder_objects', 0):,} with occluders; "
              f"{count:,} frames at {doc['settings']['width']} x {doc['settings']['height']}."),
        sections=(("answer", "answer"), ("walk", "walk"), ("frames", "frames"),
                  ("triangles", "triangles"), ("settings", "settings")),
        answer=_answer(doc), rows=_table_rows(doc), columns=RUNTIME_COLUMNS,
        table_note=table_note, hint=hint, plan=plan, marks=marks, runtimes=names,
        chosen=names.index(best), frames=drawn, frames_note=frames_note, colors=colors,
        triangles=triangles, settings=settings, provenance=doc.get("provenance", {}))
    return html.encode("utf-8")
