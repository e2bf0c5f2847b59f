"""``viscore compare [MESH ...]``: every registered method on every mesh, with intervals.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (orbit protocol, sec. 6.1).
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (volume protocol, sec. 3.2).
"""

from __future__ import annotations

import argparse
import json
import logging
from dataclasses import asdict
from pathlib import Path

from viscore import InputError, cpu_cores, load_mesh, provenance
from viscore._validate import as_positive_int, as_seed, check_memory
from viscore.generators import (
    REGISTRY,
    check_method,
    get_generator,
    parse_method,
    plugin_versions,
)

from ._common import check_utf8_name, dumps, emit, parse_list, write_atomic
from .study.report import CULLING_COLUMNS, write_occluder_glbs, write_report
from .study.runner import (
    JOBS_PER_CORE,
    StudySettings,
    connect_scheduler,
    resolve_occluder_files,
    run_study,
    study_memory,
)
from .study.store import StudyFolder, check_study_dir
from .study.tables import paired_markdown, paired_rows, table_csv, table_markdown

_log = logging.getLogger(__name__)

#: Pixels per side accepted by ``--res``.
MAX_RESOLUTION = 4096

#: Meshes of a study given none: a closed solid with a hole, a scan and a game building,
#: so that ``viscore compare`` runs every method in minutes (about 10 on a busy 2-core
#: machine; the hairball added 2 more).
DEFAULT_SCENES = ("fat-torus", "bunny", "building-house")

#: Frames of the culling column's walk through the built-in city.
CULLING_FRAMES = 24


def add_parser(sub, common) -> None:
    c = sub.add_parser("compare", parents=[common],
                       help="run every method on every mesh and compare (the main job)")
    c.add_argument("meshes", nargs="*", metavar="MESH",
                   help="mesh files or built-in scenes (default: "
                        + ", ".join(DEFAULT_SCENES) + "; 'viscore data list' names them all)")
    default_methods = [n for n, s in REGISTRY.items() if s.inputs == "any"]
    c.add_argument("--methods", default=",".join(default_methods),
                   help=f"comma-separated (default: all of {', '.join(default_methods)}; "
                        "methods for height fields only when named: "
                        + (", ".join(n for n, s in REGISTRY.items() if s.inputs != "any")
                           or "none") + "); a method with options fixed, "
                        "NAME:option=value[:option=value...], runs as a method of its own "
                        "(planar-sections:chain=greedy:reduce=area)")
    c.add_argument("--budget", default="64,256",
                   help="triangle budget(s), comma-separated (default 64,256)")
    c.add_argument("--protocol", choices=["orbit", "volume"], default="orbit")
    c.add_argument("--views", type=int, default=128, help="orbit views (default 128)")
    c.add_argument("--quads", type=int, default=16000, help="quads per view (default 16000)")
    c.add_argument("--res", type=int, default=256,
                   help=f"pixels per side, at most {MAX_RESOLUTION} (default 256)")
    c.add_argument("--rays", type=int, default=100_000,
                   help="conservativeness rays (default 100000)")
    c.add_argument("--jobs", type=int, default=1,
                   help=f"parallel jobs (processes), at most {JOBS_PER_CORE} per core "
                        "(default 1)")
    c.add_argument("--versus", default=None,
                   help="reference method of the paired comparisons, one of --methods "
                        "(default: qem when it runs, else no paired table)")
    c.add_argument("--scheduler", default=None,
                   help="dask.distributed scheduler address: run the jobs on that cluster")
    c.add_argument("--culling", action=argparse.BooleanOptionalAction, default=True,
                   help="culling column: each method's occluders feed a conservative depth "
                        "buffer along the built-in city's camera path (default on)")
    c.add_argument("--culling-methods", default=None,
                   help="methods of the culling column, comma-separated (default: the "
                        "compared methods except heavy ones: "
                        + (", ".join(n for n, s in REGISTRY.items() if s.heavy) or "none")
                        + ")")
    c.add_argument("--culling-frames", type=int, default=CULLING_FRAMES,
                   help=f"frames of that walk (default {CULLING_FRAMES})")
    c.add_argument("--occluder-files", action="append", default=[], metavar="NAME=PATH",
                   help="occluders made by other tools, assessed as the method row NAME "
                        "(repeatable): PATH a file every mesh uses (any format "
                        "viscore.load_occluder reads: .tscn, .tres, .occ, -occonly .glb, a "
                        "mesh), or a folder holding <mesh>.<ext> per mesh, or "
                        "<mesh>.<budget>.<ext> per budget; double-sided, not conservative "
                        "unless the file says so")
    c.add_argument("--out", default="viscore-study",
                   help="study folder; its parent must exist (default ./viscore-study)")
    c.set_defaults(run=run_compare)


def _methods(text: str, flag: str = "--methods") -> list[str]:
    """Canonical method labels: registered names, or variants ``name:option=value:...``
    (:func:`viscore.generators.parse_method`), each once, and each checked as its
    generator checks its options (:func:`viscore.generators.check_method`)."""
    names = [m.strip() for m in str(text).split(",") if m.strip()]
    if not names:
        raise InputError(f"{flag}: expected comma-separated methods, got {text!r} "
                         f"(registered: {', '.join(REGISTRY)})")
    return list(dict.fromkeys(check_method(m, flag).label for m in names))


def _file_specs(items: list[str]) -> list[tuple[str, str]]:
    """``--occluder-files NAME=PATH`` items as (NAME, PATH) pairs."""
    specs = []
    for item in items:
        name, sep, path = str(item).partition("=")
        if not sep or not name.strip() or not path.strip():
            raise InputError(f"--occluder-files {item!r}: expected NAME=PATH")
        specs.append((name.strip(), path.strip()))
    return specs


def _versus(text: str | None, methods: list[str], files: list[str] = ()) -> str | None:
    if text is None:
        return "qem" if "qem" in methods else None
    if text in files:  # an occluder-files row is a reference like any method
        return text
    text = parse_method(text, "--versus").label
    if text not in methods:
        raise InputError(f"--versus: {text} is not among the methods run "
                         f"({', '.join([*methods, *files])}); add it to --methods")
    return text


def _budgets(text: str, methods: list[str]) -> tuple[int, ...]:
    """The budgets, each checked against every budgeted method's registry entry.

    :meth:`viscore.generators.GeneratorSpec.check_params` refuses what a
    method cannot meet (``aabb-skins`` needs 12 triangles, one box), here
    rather than in a worker after the study started.
    """
    budgets = tuple(sorted(set(parse_list(text, int, "--budget"))))
    for method in methods:
        spec = get_generator(method)
        if not spec.budgeted:
            continue
        for budget in budgets:
            spec.check_params({"budget": budget}, flags=True)
    return budgets


def _jobs(value: object, scheduler) -> int:
    jobs = as_positive_int(value, "--jobs")
    if scheduler is None:
        cores = cpu_cores()
        if jobs > JOBS_PER_CORE * cores:
            raise InputError(f"--jobs {jobs}: at most {JOBS_PER_CORE * cores} "
                             f"({JOBS_PER_CORE} per core, {cores} cores)")
    return jobs


def run_compare(args) -> int:
    # 1. every argument, before any work and before the study folder is touched
    methods = _methods(args.methods)
    seed = as_seed(args.seed, "--seed")
    specs = _file_specs(getattr(args, "occluder_files", None) or [])
    versus = _versus(args.versus, methods, [name for name, _ in specs])
    views = as_positive_int(args.views, "--views")
    quads = as_positive_int(args.quads, "--quads")
    res = as_positive_int(args.res, "--res", maximum=MAX_RESOLUTION)
    rays = as_positive_int(args.rays, "--rays")
    jobs = _jobs(args.jobs, args.scheduler)
    workers = getattr(args, "workers", None)
    workers = None if workers is None else as_positive_int(workers, "--workers")
    culling_frames = as_positive_int(args.culling_frames, "--culling-frames", maximum=10_000)
    culling_methods = ([m for m in methods if not get_generator(m).heavy]
                       if args.culling_methods is None
                       else _methods(args.culling_methods, "--culling-methods"))
    out = check_study_dir(args.out)
    budgets = _budgets(args.budget, methods)
    settings = StudySettings(protocol=args.protocol, views=views, quads=quads, resolution=res,
                             rays=rays, budgets=budgets, seed=seed)
    meshes = list(dict.fromkeys(args.meshes or DEFAULT_SCENES))
    for m in meshes:  # the study stores its rows by the name (SQLite: UTF-8 text)
        check_utf8_name(m, "MESH")
    originals = {m: load_mesh(m) for m in meshes}
    # every occluder file found and read now: a missing or bad one leaves no folder behind
    files = resolve_occluder_files(specs, meshes, methods=methods)
    if args.scheduler is None:
        n_jobs = min(jobs, len(meshes) * len(methods) * len(budgets) + len(files))
        check_memory(study_memory(settings, originals, n_jobs),
                     f"--jobs {jobs} --views {views} --quads {quads} --res {res} --rays {rays}")
    # 2. the study, in a folder this process alone writes (the cluster reached first)
    with connect_scheduler(args.scheduler) as client, StudyFolder(out) as study:
        rows = run_study(meshes, methods, settings, study, jobs=jobs, workers=workers,
                         scheduler=client, progress=not (args.quiet or args.json),
                         originals=originals, files=files)
        paired = paired_rows(rows, versus) if versus else []
        culling = (_culling(culling_methods, out, frames=culling_frames, seed=seed,
                            quiet=args.quiet or args.json)
                   if args.culling and culling_methods else [])
        # plugin methods: their distribution and version beside the toolkit's
        plugins = plugin_versions(methods)
        doc = {"settings": asdict(settings), "rows": rows, "paired": paired,
               "provenance": provenance() | ({"plugins": plugins} if plugins else {})}
        md = table_markdown(rows)
        if paired:
            md += (f"\nPaired against {versus} on the same views (difference, 95% bootstrap "
                   "interval, bootstrap probability of being better):\n\n"
                   + paired_markdown(paired))
        if culling:
            doc["culling"] = {"scene": "city", "frames": culling_frames, "bounds": "auto",
                              "rows": culling}
            md += (f"\nCulling on the built-in city ({culling_frames} frames at 640 x 360; each "
                   "method's occluders feed a conservative depth buffer; objects are tested as "
                   "`viscore cull` tests them by default, `--bounds auto`; false culls are "
                   "objects culled yet visible in the ray-cast object-id image):\n\n"
                   + _culling_markdown(culling))
        write_atomic(out / "results.json", dumps(doc).encode())
        write_atomic(out / "results.csv", table_csv(rows).encode())
        write_atomic(out / "results.md", md.encode())
        images = _plots(rows, out, meshes, seed)
        write_occluder_glbs(rows, out, originals)
        write_report(out, rows, paired_rows=paired, settings=asdict(settings),
                     provenance=doc["provenance"], images=images, culling_rows=culling)
    emit(doc, args.json, md + f"\nintervals: 95% bootstrap over views; wrote {out}/results."
         "{csv,json,md}, report.html (open it in a browser), recall.png, budget.png, "
         f"silhouettes_*.png, and a .glb beside each occluder in {out}/occluders/ "
         "(original grey, occluder coloured)")
    return 0


def _plots(rows: list[dict], out: Path, meshes: list[str], seed: int) -> dict[str, str]:
    """The study's figures (:mod:`viscore.metrics.plots`); returns caption -> file in ``out``."""
    from viscore.metrics import budget_plot, recall_plot, silhouette_plot

    recall_plot(rows, out / "recall.png")
    budget_plot(rows, out / "budget.png")
    images = {"Recall per view, each method at its largest budget": "recall.png",
              "Recall (top) and precision as 1 - P on a log axis (bottom) against occluder "
              "triangles": "budget.png"}
    for mesh in meshes[:2]:
        name = f"silhouettes_{Path(mesh).stem}.png"
        silhouette_plot(rows, out, mesh, out / name, seed=seed)
        images[f"Silhouettes of {Path(mesh).stem}: black original only, yellow both, "
               "blue occluder only"] = name
    return images


def _culling(methods: list[str], out: Path, *, frames: int, seed: int,
             quiet: bool) -> list[dict]:
    """The culling column, one row per method, kept in ``out/culling.json``.

    Computed once per (methods, frames, seed, viscore version): running the
    study again reuses the file, as the study store reuses finished jobs.
    """
    from viscore.generators.levels import culling_column

    key = {"methods": methods, "frames": frames, "seed": seed, "bounds": "auto",
           "version": provenance().get("viscore")}
    path = out / "culling.json"
    try:
        cached = json.loads(path.read_text())
        if cached.get("key") == key:
            return cached["rows"]
    except (OSError, ValueError, AttributeError, KeyError):
        pass
    if not quiet:
        _log.info("culling column: %s on the built-in city, %d frames", ", ".join(methods),
                  frames)
    column = culling_column(methods, frames=frames, seed=seed)
    rows = [{"method": m, **{k: column[m][k] for k in ("culled_share", "false_culls",
                                                       "conservative", "overhead_ms")}}
            for m in methods]
    write_atomic(path, dumps({"key": key, "rows": rows}).encode())
    return rows


def _culling_markdown(rows: list[dict]) -> str:
    head = ("| " + " | ".join(h for _, h in CULLING_COLUMNS) + " |\n|"
            + "---|" * len(CULLING_COLUMNS) + "\n")
    body = []
    for r in rows:
        cells = [r["method"], f"{r['culled_share']:.3f}", str(r["false_culls"]),
                 "yes" if r["conservative"] else "no", f"{r['overhead_ms']:.1f}"]
        body.append("| " + " | ".join(cells) + " |\n")
    return head + "".join(body)
