"""``viscore cull [SCENE]``: how many objects each occluder set culls along a walk, and is it safe.

Parse, call the library, format: the scene's objects
(:func:`viscore.scene_graph.load_scene_objects`), the objects that get
occluders (:func:`viscore.generators.occluder_objects`), the
runtimes (:func:`viscore.generators.culling_runtimes`: ``none``,
``planar-frusta``, ``solid-frusta``, ``depth-buffer:<method>``), the camera
path (:func:`viscore.metrics.culling.camera_path` or ``--path``) and the
simulation against the ray-cast ground truth
(:func:`viscore.metrics.culling.simulate_culling`). Every argument is checked
before any work (the scene and the camera path are read, the output folder
checked); the output folder is created only when the simulation is done.

Outputs in ``--out`` (default ``./viscore-cull``; its parent must exist):
``cull.json`` (the ``--json`` document), ``triangles.png`` (triangles
rendered per frame for every runtime, as Papaioannou et al. 2006, Figs. 5-6)
and ``cameras.json`` (the path, replayable with ``--path``), each written
atomically.

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006 (Plzen), UNION Agency,
   ISBN 80-86943-03-8 (Tables 1-2, Figures 5-6).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from viscore.generators import (
    REGISTRY,
    culling_runtimes,
    frusta_method,
    occluder_objects,
    parse_method,
)
from viscore.metrics.culling import (
    DEFAULT_HEIGHT,
    DEFAULT_WIDTH,
    camera_path,
    camera_path_json,
    check_camera_path,
    check_culling_memory,
    culling_plot,
    read_camera_path,
    simulate_culling,
)

from viscore import InputError, provenance
from viscore._validate import as_positive, as_positive_int, as_seed
from viscore.scene_graph import load_scene_objects

from ._common import check_output_folder, dumps, emit, file_mode

#: Frames of a generated camera path when ``--frames`` is not given.
DEFAULT_FRAMES = 100

#: Largest image side accepted by ``--width`` and ``--height``, pixels.
MAX_SIDE = 8192


def _default_methods() -> str:
    """Registered methods that carry the conservativeness guarantee, comma-separated."""
    return ",".join(m for m, spec in REGISTRY.items() if spec.conservative) or "aabb-skins"


def add_parser(sub, common) -> None:
    c = sub.add_parser(
        "cull", parents=[common],
        help="simulate occlusion culling along a camera path against ray-cast truth",
        description="Walk a camera through a scene of objects and report, per runtime "
                    "(none, planar-frusta, solid-frusta, depth-buffer:<method>), the objects "
                    "culled, the false culls (culled yet visible in a ray-cast object-id "
                    "image), the triangles rendered and the overhead per frame.")
    c.add_argument("scene", nargs="?", default="city", metavar="SCENE",
                   help="glTF/GLB file (every mesh node is an object), another mesh file "
                        "(one object), or a built-in culling scene: city, city-dense "
                        "(default city)")
    c.add_argument("--frames", type=int, default=None,
                   help=f"cameras of the generated path (default {DEFAULT_FRAMES}); with "
                        "--path, the first N of the file (default all)")
    c.add_argument("--methods", default=None,
                   help="generators whose occluders feed a depth-buffer runtime each, "
                        "comma-separated (default: the conservative ones, "
                        f"{_default_methods()})")
    c.add_argument("--occluders", default=None,
                   help="comma-separated object names that get occluders (default: the "
                        "objects above --size-threshold)")
    c.add_argument("--size-threshold", type=float, default=None,
                   help="bounding-box diagonal, world units, from which an object gets "
                        "occluders (default 2.5 x the median object's)")
    c.add_argument("--path", default=None, metavar="CAMERAS.JSON",
                   help='camera path: a JSON list of {"position": [x,y,z], "forward": '
                        '[x,y,z], "up"?: [x,y,z], "fov"?: horizontal degrees} (default: '
                        "generated through the scene's free space)")
    c.add_argument("--width", type=int, default=DEFAULT_WIDTH,
                   help=f"ground-truth image width, pixels (default {DEFAULT_WIDTH})")
    c.add_argument("--height", type=int, default=DEFAULT_HEIGHT,
                   help=f"ground-truth image height, pixels (default {DEFAULT_HEIGHT})")
    c.add_argument("--buffer-scale", type=int, default=4,
                   help="depth buffer: screen pixels per buffer pixel along each side "
                        "(default 4: 320 x 180 at 1280 x 720)")
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
    return list(dict.fromkeys(parse_method(m, option).label for m in methods))


def _out_dir(text: str) -> Path:
    """The output folder, refused before any work unless files can be made in it."""
    return check_output_folder(text)


def _write_all(out: Path, files: dict) -> None:
    """Write the files into ``out`` (made if missing), all or none.

    ``files`` maps a name to its bytes or to a function writing that file at a
    given path (a plot). Each goes to a temporary file in ``out`` first; they
    are moved in place only when all are written, in the given order (the main
    document last). On any failure or interruption the temporary files go and,
    if this call made ``out``, the moved files and ``out`` too.
    """
    created = not os.path.lexists(out)
    out.mkdir(exist_ok=True)
    mode = file_mode()
    temps: dict[str, Path] = {}
    moved: list[Path] = []
    try:
        for name, content in files.items():
            stem, _, suffix = name.rpartition(".")
            fd, tmp = tempfile.mkstemp(dir=out, prefix=f".{stem}.", suffix=f".{suffix}")
            temps[name] = Path(tmp)
            with os.fdopen(fd, "wb") as fh:
                if not callable(content):
                    fh.write(content)
            if callable(content):
                content(Path(tmp))
            os.chmod(tmp, mode)
        for name in list(temps):
            os.replace(temps[name], out / name)
            moved.append(out / name)
            del temps[name]
    except BaseException:
        for tmp in temps.values():
            tmp.unlink(missing_ok=True)
        if created:
            for path in moved:
                path.unlink(missing_ok=True)
            with contextlib.suppress(OSError):
                out.rmdir()
        raise


def _table(doc: dict) -> str:
    s = doc["settings"]
    gt = doc["ground_truth"]
    lines = [f"{doc['scene']}: {s['objects']:,} objects ({s['triangles']:,} triangles), "
             f"{doc['occluder_objects']} with occluders, {s['frames']} frames at "
             f"{s['width']} x {s['height']} (frusta from {doc['frusta_method']})",
             f"{'runtime':<28} {'culled':>7} {'false':>6} {'triangles/frame':>16} "
             f"{'overhead ms':>12} {'conservative':>12}"]
    for name, t in doc["totals"].items():
        lines.append(f"{name:<28} {t['culled_share']:>7.1%} {t['false_culls']:>6} "
                     f"{t['triangles_rendered_per_frame']:>16,.0f} {t['overhead_ms']:>12.2f} "
                     f"{'yes' if t['conservative'] else 'no':>12}")
    frames = max(1, s["frames"])
    lines.append(f"{'ray-cast truth (visible)':<28} {gt['hidden_share']:>7.1%} {0:>6} "
                 f"{gt['triangles_visible'] / frames:>16,.0f} {'-':>12} {'-':>12}")
    lines.append("culled: share of the objects in the view frustum (view frustum culling "
                 "first, the same for all); false: culled objects visible in the ray-cast "
                 "object-id image, summed over frames; overhead: mean per frame")
    return "\n".join(lines)


def run_cull(args) -> int:
    # 1. every argument, before any work
    seed = as_seed(args.seed, "--seed")
    width = as_positive_int(args.width, "--width", maximum=MAX_SIDE)
    height = as_positive_int(args.height, "--height", maximum=MAX_SIDE)
    reduction = as_positive_int(args.buffer_scale, "--buffer-scale",
                                maximum=min(width, height))
    active = as_positive_int(args.active, "--active")
    frames = None if args.frames is None else as_positive_int(args.frames, "--frames",
                                                             maximum=100_000)
    threshold = None if args.size_threshold is None else as_positive(args.size_threshold,
                                                                      "--size-threshold")
    methods = _methods(args.methods)
    source = _methods(args.frusta_method or frusta_method(), "--frusta-method")
    if len(source) != 1:
        raise InputError(f"--frusta-method: expected one method, got {args.frusta_method!r}")
    source = source[0]
    names = _names(args.occluders, "--occluders")
    out = _out_dir(args.out)
    check_culling_memory(width, height)
    objects = load_scene_objects(args.scene)
    if args.path is not None:
        path = read_camera_path(args.path, up=objects.up)
        if frames is not None:
            path = path[:frames]
        check_camera_path(objects, path)
    else:
        path = None
    try:
        indices = occluder_objects(objects, size_threshold=threshold, names=names)
    except InputError as exc:
        if names is not None or threshold is not None:
            raise
        raise InputError(f"{exc}; give --size-threshold or --occluders") from None
    progress = not (args.quiet or args.json)
    # 2. the work
    from tqdm import tqdm

    if path is None:
        path = camera_path(objects, frames=frames or DEFAULT_FRAMES, seed=seed)
    distinct = len(set(objects.mesh_ids[indices].tolist()))
    todo = distinct * (len(set(methods) | {source}))
    with tqdm(total=todo, desc="occluders", unit="mesh", disable=not progress,
              leave=False) as bar:
        runtimes, info = culling_runtimes(objects, indices, methods, active=active,
                                          reduction=reduction, seed=seed,
                                          frusta_source=source, cap=args.cap,
                                          rank=args.rank, progress=bar.update)
    with tqdm(total=len(path), desc="frames", unit="frame", disable=not progress,
              leave=False) as bar:
        result = simulate_culling(objects, runtimes, path, width=width, height=height,
                                  progress=bar.update)
    doc = {"scene": args.scene, "occluder_objects": len(indices),
           "frusta_method": source, "methods": methods, "seed": seed,
           "active": active, "buffer_scale": reduction, "cap": args.cap, "rank": args.rank,
           **result.to_json(),
           "runtimes": info, "provenance": provenance()}
    # 3. the files, all or none (cull.json, the main document, last)
    _write_all(out, {
        "triangles.png": lambda p: culling_plot(
            result, p, title=f"{args.scene}: triangles rendered per frame"),
        "cameras.json": camera_path_json(path).encode(),
        "cull.json": dumps(doc).encode()})
    emit(doc, args.json, _table(doc) + f"\nwrote {out}/cull.json, triangles.png, cameras.json "
         "(replay with --path)")
    return 0
