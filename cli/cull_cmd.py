"""``viscore cull [SCENE]``: how many objects each occluder set culls along a walk, and is it safe.

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006 (Plzen), UNION Agency,
   ISBN 80-86943-03-8 (Tables 1-2, Figures 5-6).
"""

from __future__ import annotations

import logging
import sys
import time
from pathlib import Path

import numpy as np

from viscore import InputError, provenance, stream_seed
from viscore._atomic import LockedFolder
from viscore._jobs import JOBS_PER_CORE, check_scheduler, connect_scheduler
from viscore._validate import as_positive, as_positive_int, as_seed, check_memory
from viscore.culling import (
    AUTO_MIN_SIZE,
    DEFAULT_BOUNDS,
    DEFAULT_CLUSTERS,
    DEFAULT_REDUCTION,
    MAX_CLUSTERS,
    MESHLET_TRIANGLES,
    occludee_boxes,
    parse_bounds,
)
from viscore.generators import call_held, check_method, report_kinds
from viscore.generators.levels import (
    JOINED_METHODS,
    culling_runtimes,
    file_occluder,
    frusta_method,
    guaranteed_methods,
    method_indices,
)
from viscore.level import SPLIT_RULES, UP_AXES, level_objects, occluder_objects
from viscore.metrics import (
    DEFAULT_HEIGHT,
    DEFAULT_WIDTH,
    camera_path_json,
    camera_stances,
    camera_walk,
    check_camera_path,
    check_culling_memory,
    culling_plot,
    guess_eye_height,
    read_camera_path,
    simulate_culling,
)

from ._common import RateEstimate, check_jobs, check_output_folder, dumps, emit, format_duration
from .report.cull_page import check_report_memory, cull_report_html, report_frames
from .report.page import printable

#: Frames of a generated camera path when ``--frames`` is not given.
DEFAULT_FRAMES = 100


#: Largest image side accepted by ``--width`` and ``--height``, pixels.
MAX_SIDE = 8192

_log = logging.getLogger(__name__)

#: Most cameras of a walk, ``--frames`` and ``--path`` alike.
MAX_FRAMES = 100_000

#: Memory held per frame of the walk until the end, bytes: every runtime's
#: figures of the frame and its entry in the JSON document (about 10 KB a frame
#: at the default runtimes, measured as resident growth: 1.25 GB held after
#: 125,000 frames of a long ``--path``).
_BYTES_PER_FRAME = 10_000

#: Objects from which a level is big enough for ``cull`` to say, once it is read, how
#: long the work before the first frame takes.
MANY_OBJECTS = 10_000
#: The work before the first frame (the walk's planning, the occludees' boxes, the
#: runtimes' set-up), as a multiple of the time the level took to read: 1.1 on a glTF
#: of 10^5 instanced boxes (43 s after a 38 s read, one frame, 16 x 9, 2 loaded cores).
_SETUP_PER_READ = 1.2

#: The files of a run, written as one set (the main document first in the table).
_OUTPUTS = ("cull.json", "triangles.png", "cameras.json", "report.html")


def _default_methods() -> str:
    """Registered methods that carry the conservativeness guarantee, comma-separated."""
    return ",".join(guaranteed_methods())


def add_parser(sub, common) -> None:
    c = sub.add_parser(
        "cull", parents=[common],
        help="simulate occlusion culling along a camera path against ray-cast truth",
        description="Walk a camera through a scene of objects and report, per runtime "
                    "(none, planar-frusta, solid-frusta, depth-buffer:<method>, "
                    "depth-buffer:<file> per --occluder-files file), the objects "
                    "culled, the false culls (culled yet visible in a ray-cast object-id "
                    "image), the triangles rendered and the overhead per frame.")
    c.add_argument("scene", nargs="?", default="city", metavar="SCENE",
                   help="glTF/GLB file (every mesh node is an object), another mesh file "
                        "(a single-mesh level, split into parts as occlude splits it), or a "
                        "built-in culling scene: city, city-dense (default city)")
    c.add_argument("--up", choices=UP_AXES, default=None,
                   help="up axis of the level (default: guessed and printed for a single "
                        "mesh; +Y for glTF, as its specification says: give z for a file "
                        "written Z-up)")
    c.add_argument("--eye-height", type=float, default=None, metavar="H",
                   help="eye height of the walk over the floor, in the level's units "
                        "(default: guessed from the headroom of the level's floors under "
                        "their ceilings, 1.7 for a glTF level, whose unit is the metre; "
                        "printed beside the up axis)")
    c.add_argument("--frames", type=int, default=None,
                   help=f"cameras of the generated path (default {DEFAULT_FRAMES}); with "
                        "--path, the first N of the file (default all)")
    c.add_argument("--methods", default=None,
                   help="generators whose occluders feed a depth-buffer runtime each, "
                        "comma-separated (default: the methods that can be guaranteed, "
                        f"{_default_methods()}; aabb-skins and solid-frusta (and the "
                        "planar-frusta and solid-frusta runtimes fed by them) are guaranteed "
                        "only when every occluder object is a closed mesh, and a runtime "
                        "with an open one is reported not guaranteed; surface-patches on "
                        "any input; a runtime that made no occluder culls nothing and is "
                        "reported so)")
    c.add_argument("--occluders", default=None,
                   help="comma-separated object names that get occluders (default: those "
                        "from 2%% of the level's diagonal, as 'viscore occlude' chooses them)")
    c.add_argument("--occluder-files", default=None, metavar="PATH[,PATH...]",
                   help="occluders made by other tools, each a runtime "
                        "depth-buffer:<file stem> beside the methods': a file "
                        "viscore.load_occluder reads (Godot .tscn/.tres/.occ such as the bake's "
                        "node_3d.occ, an -occonly glTF, any mesh) holding the whole level's "
                        "occluders in world space, or a folder of 'viscore occlude' (each of "
                        "its *.tscn); not conservative unless the file says so")
    c.add_argument("--size-threshold", type=float, default=None,
                   help="bounding-box diagonal, world units, from which an object gets "
                        "occluders (default: 2%% of the level's diagonal, never the flat "
                        "ground alone)")
    c.add_argument("--path", default=None, metavar="CAMERAS.JSON",
                   help='camera path: a JSON list of {"position": [x,y,z], "forward": '
                        '[x,y,z], "up"?: [x,y,z], "fov"?: horizontal degrees} (default: '
                        "generated through the scene's free space)")
    c.add_argument("--width", type=int, default=DEFAULT_WIDTH,
                   help=f"ground-truth image width, pixels (default {DEFAULT_WIDTH})")
    c.add_argument("--height", type=int, default=DEFAULT_HEIGHT,
                   help=f"ground-truth image height, pixels (default {DEFAULT_HEIGHT})")
    c.add_argument("--buffer-scale", type=int, default=DEFAULT_REDUCTION,
                   help="depth buffer: screen pixels per buffer pixel along each side "
                        f"(default {DEFAULT_REDUCTION}: 640 x 360 at 1280 x 720; 4 is "
                        "a quarter per side, faster and less tight)")
    c.add_argument("--active", type=int, default=15,
                   help="frusta runtimes: active occluders per frame (default 15)")
    c.add_argument("--frusta-method", default=None,
                   help="generator whose convex solids (or boxes) feed planar-frusta and "
                        f"solid-frusta (default {frusta_method()})")
    c.add_argument("--cap", choices=["front-faces", "eq2"], default="front-faces",
                   help="near cap of the solid frusta: the planes of the faces the eye sees "
                        "(default; the exact shadow) or the paper's eq. 2 plane")
    c.add_argument("--rank", choices=["faces", "eq4"], default="faces",
                   help="ranking of the solids: as their best face by eq. 3 (default) or the "
                        "paper's f_solid of eq. 4")
    c.add_argument("--bounds", default=DEFAULT_BOUNDS,
                   metavar="triangles|meshlets[:T]|auto|box|clusters[:N]",
                   help="what a runtime tests of an object, culled when all of them are "
                        f"hidden: {DEFAULT_BOUNDS} (the default): its own triangles, pixel by "
                        "pixel in the depth buffer (tighter than their boxes, as "
                        "conservative; the other runtimes get the triangles' boxes); "
                        "meshlets: the boxes of clusters of about T triangles "
                        f"(default T {MESHLET_TRIANGLES}), as engines test meshlets; "
                        "meshlets:1: its triangles' boxes, at most "
                        f"{MAX_CLUSTERS} per object, the finest of these (a smaller box is "
                        "no harder to cull, and an object only its box puts in view is left "
                        "out of view); box: its box (as an engine tests an instance, "
                        "and as the paper does); clusters: the boxes of up to N clusters of "
                        f"its triangles (default N {DEFAULT_CLUSTERS}); auto: clusters for "
                        f"objects of at least {AUTO_MIN_SIZE:g} of the level's diagonal, the "
                        "box for the others")
    c.add_argument("--per-object", action="store_true",
                   help="make every method's occluders object by object; by default "
                        f"{', '.join(JOINED_METHODS)} is made once over the occluder objects "
                        "together, so that a roof or wall continuing across objects is one "
                        "planar region, not one per object with a gap at every seam")
    c.add_argument("--report-frames", default=None, metavar="all|N,A-B",
                   help="frames drawn in report.html: 'all', or frames and ranges such as "
                        "3,10-14 (default: all of a walk of up to 16 frames, else 16 spread "
                        "over it)")
    run = c.add_mutually_exclusive_group()
    run.add_argument("--jobs", type=int, default=1,
                     help=f"processes the frames are spread over, at most {JOBS_PER_CORE} per "
                          "core (default 1); the same figures as one process")
    run.add_argument("--scheduler", default=None,
                     help="dask.distributed scheduler address: spread the frames over that "
                          "cluster's workers (the same figures as one process)")
    c.add_argument("--out", default="viscore-cull",
                   help="output folder, created if missing; its parent must exist "
                        "(default ./viscore-cull)")
    c.set_defaults(run=run_cull)


def _names(text: str | None, option: str) -> list[str] | None:
    if text is None:
        return None
    names = list(dict.fromkeys(n.strip() for n in str(text).split(",") if n.strip()))
    if not names:
        raise InputError(f"{option}: expected comma-separated names, got {text!r}")
    return names


def _methods(text: str | None, option: str = "--methods") -> list[str]:
    methods = _names(_default_methods() if text is None else text, option)
    return list(dict.fromkeys(check_method(m, option).label for m in methods))


def _bounds(text: str) -> tuple[str, int]:
    """``--bounds``: its kind (``box``, ``clusters``, ``auto``, ``meshlets``, ``triangles``)
    and its count."""
    return parse_bounds(text, "--bounds")


def _out_dir(text: str) -> Path:
    """The output folder, refused before any work unless files can be made in it.

    The set of files is swapped in as a whole folder, so the folder may not be
    the working directory or one holding it (that folder would be swapped away).
    """
    out = check_output_folder(text)
    here = Path.cwd().resolve()
    if out.resolve() == here or out.resolve() in here.parents:
        raise InputError(f"--out {text}: the working directory or a folder holding it; the "
                         f"cull writes its files by replacing the folder, name a folder of its own")
    return out


def _table(doc: dict) -> str:
    s = doc["settings"]
    gt = doc["ground_truth"]
    lines = [f"{doc['scene']}: {s['objects']:,} objects ({s['triangles']:,} triangles), "
             f"{doc['occluder_objects']} with occluders, "
             + (f"{len(doc['see_through_objects']):,} see-through (the truth's rays pass "
                "them; no occluders), " if doc.get("see_through_objects") else "")
             + f"{s['frames']} frames at "
             f"{s['width']} x {s['height']} (frusta from {doc['frusta_method']}"
             + ("" if doc["bounds"]["kind"] == "box" else
                f"; {doc['bounds']['split_objects']:,} objects tested by their triangles, "
                f"{doc['bounds']['boxes']:,} in all" if doc["bounds"]["kind"] == "triangles"
                else f"; {doc['bounds']['split_objects']:,} objects tested by their clusters, "
                f"{doc['bounds']['boxes']:,} boxes in all") + ")",
             f"{'runtime':<28} {'culled':>7} {'95% interval':>14} {'false':>6} "
             f"{'triangles/frame':>16} {'overhead ms':>12} {'conservative':>12}"]
    for name, t in doc["totals"].items():
        made = None if name == "none" else doc.get("runtimes", {}).get(name, {}).get("occluders")
        lines.append(f"{name:<28} {t['culled_share']:>7.1%} "
                     f"{_interval_cell(t.get('culled_share_ci')):>14} {t['false_culls']:>6} "
                     f"{t['triangles_rendered_per_frame']:>16,.0f} {t['overhead_ms']:>12.2f} "
                     f"{_conservative_cell(t, made):>12}")
    frames = max(1, s["frames"])
    lines.append(f"{'ray-cast truth (hidden)':<28} {gt['hidden_share']:>7.1%} "
                 f"{_interval_cell(gt.get('hidden_share_ci')):>14} {0:>6} "
                 f"{gt['triangles_visible'] / frames:>16,.0f} {'-':>12} {'-':>12}")
    lines.append("culled: share of the objects in the view frustum (view frustum culling "
                 "first, the same for all); false: culled objects visible in the ray-cast "
                 "object-id image, summed over frames; overhead: mean per frame; "
                 "conservative: the runtime's guarantee, '-' where it culled nothing, "
                 "'no occluder' where it made none; the truth row: the share of the objects "
                 "in view that no pixel sees; " + _interval_note(doc))
    w = doc.get("walk")
    if w:
        lines.append(f"walk: {w['standing']} of {w['frames']} frames stand well "
                     f"(eye height {w['eye_height']:.4g}, {w['eye_height_reason']}); "
                     f"{w['moved']} moved, {w['dropped']} of {w['frames_asked']} dropped"
                     + (f", {w['far']} far views" if w.get("far") else ""))
    hint = _bounds_hint(doc)
    if hint:
        lines.append(hint)
    return "\n".join(lines)


def _bounds_hint(doc: dict) -> str | None:
    """A line suggesting the default ``--bounds`` when the boxes (``box``, or ``auto``'s
    unsplit objects; never after ``clusters``, ``meshlets`` or ``triangles``) leave more
    than half of what the truth hides (over 20%) to every guaranteed runtime, else None.

    A level exported as a few big chunks is the usual cause: a chunk's box holds the eye
    or reaches past every occluder. On the dust map (20 frames) the best guaranteed
    runtime culls 6.2% of the objects with boxes and 19.7% with clusters, the truth hiding
    41.0% and 36.5%; even the level's own triangles cull 6.2% with boxes.
    """
    if doc["bounds"]["kind"] in ("clusters", "meshlets", "triangles"):  # split already
        return None
    hidden = doc["ground_truth"]["hidden_share"]
    made = {name: info.get("occluders") for name, info in doc.get("runtimes", {}).items()}
    best = max((t["culled_share"] for name, t in doc["totals"].items()
                if name != "none" and t["conservative"] and made.get(name) != 0),
               default=0.0)
    if hidden <= 0.2 or best >= 0.5 * hidden:
        return None
    return (f"hint: the guaranteed runtimes cull at most {best:.1%} of the objects where the "
            f"truth hides {hidden:.1%}; if the level's objects are a few big chunks, "
            f"--bounds {DEFAULT_BOUNDS} (the default) tests each through its own "
            "triangles")


def _interval_cell(interval) -> str:
    """``[a, b]`` percentages of a share's interval; ``-`` where undefined (one frame)."""
    if not interval or any(v is None or not np.isfinite(v) for v in interval):
        return "-"
    return f"[{100 * interval[0]:.1f}, {100 * interval[1]:.1f}]"


def _interval_note(doc: dict) -> str:
    iv = doc.get("intervals") or {}
    return (f"95% intervals: block bootstrap over frames (blocks of {iv.get('block', '?')} "
            f"frames, seed {iv.get('seed', '?')})")


def _conservative_cell(total: dict, occluders: int | None = None) -> str:
    """``yes``/``no``: the runtime's guarantee; ``no occluder`` where it made none, ``-``
    where it culled nothing (nothing to guard)."""
    if occluders == 0:
        return "no occluder"
    if not total.get("culled", total.get("culled_share", 0)):
        return "-"
    return "yes" if total["conservative"] else "no"


def run_cull(args) -> int:
    # 1. every argument, before any work
    seed = as_seed(args.seed, "--seed")
    width = as_positive_int(args.width, "--width", maximum=MAX_SIDE)
    height = as_positive_int(args.height, "--height", maximum=MAX_SIDE)
    reduction = as_positive_int(args.buffer_scale, "--buffer-scale",
                                maximum=min(width, height))
    active = as_positive_int(args.active, "--active")
    frames = None if args.frames is None else as_positive_int(args.frames, "--frames",
                                                             maximum=MAX_FRAMES)
    threshold = None if args.size_threshold is None else as_positive(args.size_threshold,
                                                                      "--size-threshold")
    methods = _methods(args.methods)
    source = _methods(args.frusta_method or frusta_method(), "--frusta-method")
    if len(source) != 1:
        raise InputError(f"--frusta-method: expected one method, got {args.frusta_method!r}")
    source = source[0]
    names = _names(args.occluders, "--occluders")
    bound_kind, clusters = _bounds(args.bounds)
    files = _occluder_files(args.occluder_files, methods)
    out = _out_dir(args.out)
    jobs = check_jobs(args.jobs) if args.scheduler is None else 1
    if args.scheduler is not None:  # an address refused at once, not after the occluders
        check_scheduler(args.scheduler)
    check_culling_memory(width, height)
    if args.path is None:
        _check_frames_memory(frames or DEFAULT_FRAMES, f"--frames {frames or DEFAULT_FRAMES}")
    eye_given = (None if args.eye_height is None
                 else as_positive(args.eye_height, "--eye-height"))
    started = time.perf_counter()
    level = level_objects(args.scene, up=args.up, names=names if threshold is None else None)
    objects = level.objects
    if len(objects) >= MANY_OBJECTS:
        read = time.perf_counter() - started
        _log.warning("cull: %s objects, read in %s; the work before the first frame (the "
                     "walk, the occludees' boxes, the runtimes) takes about %s more, then each "
                     "frame is timed", f"{len(objects):,}", format_duration(read),
                     format_duration(_SETUP_PER_READ * read))
    if level.kind != "gltf":
        mesh = "its one mesh" if level.kind == "gltf-mesh" else "the mesh"
        if len(objects) == 1:
            _log.warning("%s: %s stays one object (its %d connected components join into one "
                         "part), %s up (%s): there is nothing else to cull behind it",
                         args.scene, mesh, level.components, level.up, level.up_reason)
        else:
            _log.info("%s: %s split into %d objects by %s (%d connected components), %s up "
                      "(%s)", args.scene, mesh, len(objects), SPLIT_RULES[level.split_rule],
                      level.components, level.up, level.up_reason)
    if args.path is not None:
        # capped before any camera is checked: checking one takes about 0.5 ms
        path = read_camera_path(args.path, up=objects.up, frames=frames, maximum=MAX_FRAMES)
        _check_frames_memory(len(path), f"--path {args.path} ({len(path):,} cameras)")
        check_camera_path(objects, path)
    else:
        path = None
    # after the path is read and checked: a bad one is one line on stderr, nothing before
    eye = guess_eye_height(objects, metres=level.kind.startswith("gltf"),
                           eye_height=eye_given)
    _log.info("%s: %s up (%s); eye height %.4g (%s)", args.scene, level.up,
              level.up_reason, eye.value, eye.reason)
    if threshold is not None:
        indices = occluder_objects(objects, size_threshold=threshold, names=names)
    else:
        indices = level.chosen
    shown = report_frames(len(path) if path is not None else frames or DEFAULT_FRAMES,
                          args.report_frames)
    check_report_memory(width, height)
    # bars only on a terminal: redirected to a file, each redraw is another line of it
    progress = not (args.quiet or args.json) and sys.stderr.isatty()
    with connect_scheduler(args.scheduler) as client, LockedFolder(
            out, busy=f"--out {out}: another cull is writing this folder; wait for it to "
            "finish or choose another --out", outputs=_OUTPUTS, tag="cull") as folder:
        # this process alone, from here to the files
        doc = _simulate(args, objects, indices, path, folder, progress=progress, seed=seed,
                        frames=frames, methods=methods, source=source, active=active,
                        reduction=reduction, width=width, height=height, files=files,
                        flat=level.flat, clusters=clusters,
                        bound_kind=bound_kind, shown=shown, jobs=jobs, scheduler=client,
                        eye=eye, split_rule=level.split_rule)
    emit(doc, args.json, _table(doc) + f"\nwrote {out}/cull.json, triangles.png, cameras.json "
         "(replay with --path), report.html (open it in a browser)")
    return 0


def _occluder_file_paths(text: str) -> list[Path]:
    """The files of ``--occluder-files``: each path a file, or a folder's ``*.tscn``."""
    paths = []
    for item in _names(text, "--occluder-files"):
        p = Path(item)
        if p.is_dir():
            found = sorted(q for q in p.glob("*.tscn") if not q.name.startswith("."))
            if not found:
                raise InputError(f"--occluder-files {item}: a folder without *.tscn files "
                                 "(expected a folder written by 'viscore occlude', or name "
                                 "the occluder files themselves)")
            paths += found
        else:
            paths.append(p)
    return paths


def _occluder_files(text: str | None, methods: list[str]) -> dict:
    """``--occluder-files`` read before any work: runtime name (file stem) -> Occluder."""
    if text is None:
        return {}
    files: dict = {}
    where: dict[str, Path] = {}
    for p in _occluder_file_paths(text):
        name = p.stem
        if name in where:
            raise InputError(f"--occluder-files: {where[name]} and {p} both name the runtime "
                             f"depth-buffer:{name}; rename one of them")
        if name in methods:
            raise InputError(f"--occluder-files {p}: depth-buffer:{name} is also the runtime "
                             f"of --methods {name}; drop {name} from --methods or rename the "
                             "file")
        try:
            files[name] = file_occluder(p)
        except InputError as exc:
            raise InputError(f"--occluder-files {exc}") from None
        where[name] = p
    return files


def _check_frames_memory(frames: int, what: str) -> None:
    """The memory the walk's frames hold until the end (:data:`_BYTES_PER_FRAME` each)."""
    check_memory(float(frames) * _BYTES_PER_FRAME, what)


def _simulate(args, objects, indices, path, folder: LockedFolder, *, progress: bool, seed: int,
              frames, methods, source, active, reduction, width, height,
              files: dict | None = None, flat=None, clusters: int = 1,
              bound_kind: str = "box", shown: list[int] | None = None, jobs: int = 1,
              scheduler=None, eye=None, split_rule: str = "nodes") -> dict:
    """The work and the files of :func:`run_cull`; returns the JSON document."""
    from tqdm import tqdm

    if path is None:
        walk = camera_walk(objects, frames=frames or DEFAULT_FRAMES, seed=seed, eye=eye)
        path, stances, walk_doc = list(walk.cameras), walk.stances, walk.to_json()
        if walk.dropped or walk.moved:
            _log.warning("%s: the walk moved %d camera(s) and dropped %d of %d frames where "
                         "no place of their stretch stands well", args.scene, walk.moved,
                         walk.dropped, walk.asked)
    else:
        stances = camera_stances(objects, path, eye_height=eye.value, sign=eye.sign)
        standing = sum(st.standing for st in stances)
        walk_doc = {"up": [float(x) for x in objects.up], **eye.to_json(),
                    "frames_asked": len(path), "frames": len(path), "standing": standing,
                    "standing_share": standing / len(path), "moved": 0, "dropped": 0,
                    "far": 0, "kinds": {"given": len(path)}, "on": "--path"}
    todo = sum(len(set(objects.mesh_ids[method_indices(m, indices, flat)].tolist()))
               for m in set(methods) | {source})  # meshes each method generates
    with tqdm(total=todo, desc="occluders", unit="mesh", disable=not progress,
              leave=False) as bar:
        tick = RateEstimate(f"cull: occluders of {todo:,} meshes", todo, "meshes", bar.update)
        # the generators' warnings held, then each kind said once with its count (the same
        # one about the city's ground from aabb-skins and from solid-frusta is one line);
        # their details only with --verbose, which says every record as it comes
        options = dict(active=active, reduction=reduction, seed=seed, frusta_source=source,
                       cap=args.cap, rank=args.rank, progress=tick, files=files,
                       joined=() if args.per_object else None, flat=flat)
        if logging.getLogger("viscore").isEnabledFor(logging.DEBUG):
            runtimes, info = culling_runtimes(objects, indices, methods, **options)
            held = []
        else:
            (runtimes, info), held = call_held(culling_runtimes, objects, indices, methods,
                                               **options)
    report_kinds(held, labels=list(dict.fromkeys([*methods, source])))
    bounds, bound_kind, split = occludee_boxes(objects, bound_kind, clusters)
    with tqdm(total=len(path), desc="frames", unit="frame", disable=not progress,
              leave=False) as bar:
        tick = RateEstimate(f"cull: {len(path):,} frames", len(path), "frames", bar.update)
        result = simulate_culling(objects, runtimes, path, width=width, height=height,
                                  progress=tick, bounds=bounds, keep_frames=shown or (),
                                  jobs=jobs, scheduler=scheduler, stances=stances)
    doc = {"scene": args.scene, "occluder_objects": len(indices),
           "objects_rule": split_rule, "objects_rule_text": SPLIT_RULES[split_rule],
           "see_through_objects": [objects.names[i] for i in np.flatnonzero(objects.see_through)],
           "frusta_method": source, "methods": methods,
           "occluder_files": {name: occ.params["file"] for name, occ in (files or {}).items()},
           "seed": seed, "per_object": bool(args.per_object),
           "bounds": ({"kind": "box"} if bounds is None else
                      {"kind": bound_kind, "clusters": clusters, "boxes": len(bounds[2]),
                       "split_objects": split,
                       **({"min_size": AUTO_MIN_SIZE} if bound_kind == "auto" else {})}),
           "walk": walk_doc,
           "active": active, "buffer_scale": reduction, "cap": args.cap, "rank": args.rank,
           # the intervals' resampling: its own stream of --seed, as every bootstrap's
           **result.to_json(seed=stream_seed(seed, "bootstrap")),
           "runtimes": info, "provenance": provenance()}
    doc["intervals"]["stream"] = "bootstrap"  # seed = stream_seed(--seed, 'bootstrap')
    # the files, all or none (the page shows the plot written before it)
    with tqdm(total=len(shown or ()), desc="report", unit="frame", disable=not progress,
              leave=False) as bar:
        folder.write_set({
            "triangles.png": lambda p: culling_plot(
                result, p, title=f"{printable(args.scene)}: triangles rendered per frame"),
            "report.html": lambda p: p.write_bytes(cull_report_html(
                result, objects, runtimes, doc, scene=Path(str(args.scene)).stem,
                frames=shown or [], triangles_png=p.with_name("triangles.png").read_bytes(),
                highlight=indices, hint=_bounds_hint(doc), progress=bar.update)),
            "cameras.json": camera_path_json(path).encode(),
            "cull.json": dumps(doc).encode()})
    return doc
