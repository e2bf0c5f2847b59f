"""``viscore occlude LEVEL -o DIR``: occluders for every large object of a level, as Godot files."""

from __future__ import annotations

import logging
import sys

from viscore import InputError
from viscore._atomic import LockedFolder
from viscore._jobs import JOBS_PER_CORE, connect_scheduler
from viscore._validate import as_positive_int
from viscore.generators import REGISTRY, check_method, parse_method
from viscore.generators.levels import check_occlude_folder, default_methods, occlude_level
from viscore.level import MIN_SIZE, UP_AXES, level_objects

from ._common import check_jobs, check_output_folder, emit
from .report.occlude_page import write_occlude_report

_log = logging.getLogger(__name__)

#: Names shown on the line of a kind of refusal (the others are counted; all are in
#: ``occlude.json``, and each has a line of its own with ``--verbose``).
REFUSED_NAMES = 3


def add_parser(sub, common) -> None:
    c = sub.add_parser("occlude", parents=[common],
                       help="occluders for the objects of a level, as Godot 4 files")
    c.add_argument("level", metavar="LEVEL",
                   help="glTF/GLB scene (every mesh node an object, instancing honoured) or a "
                        "single mesh (OBJ, PLY, OFF, STL) split into parts")
    c.add_argument("-o", "--out", dest="out", required=True, metavar="DIR",
                   help="output folder; its parent must exist (a killed run resumes in it)")
    c.add_argument("--methods", default=None,
                   help="comma-separated methods or variants NAME:option=value (default: "
                        + ",".join(default_methods()) + ")")
    pick = c.add_mutually_exclusive_group()
    pick.add_argument("--min-size", type=float, default=None,
                      help="objects whose bounding-box diagonal is at least this fraction of "
                           f"the level's get occluders, in (0, 1] (default {MIN_SIZE})")
    pick.add_argument("--occluders", default=None, metavar="NAME,...",
                      help="exactly these objects get occluders")
    c.add_argument("--budget", type=int, default=None,
                   help="triangle budget per distinct mesh (default: each method's own)")
    run = c.add_mutually_exclusive_group()
    run.add_argument("--jobs", type=int, default=1,
                     help=f"parallel processes, at most {JOBS_PER_CORE} per core (default 1)")
    run.add_argument("--scheduler", default=None,
                     help="dask.distributed scheduler address: run the jobs on that cluster")
    c.add_argument("--up", choices=UP_AXES, default=None,
                   help="up axis of the level (default: guessed and printed for a single "
                        "mesh; +Y for glTF, as its specification says: give z for a file "
                        "written Z-up)")
    c.set_defaults(run=run_occlude)


def _methods(text: str | None) -> list[str]:
    names = default_methods() if text is None else [m.strip() for m in text.split(",")
                                                    if m.strip()]
    if not names:
        raise InputError(f"--methods: expected comma-separated methods, got {text!r} "
                         f"(registered: {', '.join(REGISTRY)})")
    return list(dict.fromkeys(check_method(m, "--methods").label for m in names))


def _check_budget(budget: int | None, methods: list[str]) -> int | None:
    if budget is None:
        return None
    budget = as_positive_int(budget, "--budget")
    for m in methods:
        parse_method(m, "--methods").spec.check_params({"budget": budget}, flags=True)
    return budget



class _Bar:
    """``progress(done, total, label, work=...)`` as a tqdm bar on stderr.

    The bar fills with the jobs' work (triangles plus a fixed part each, from
    :func:`viscore.generators.levels.occlude_level`), not their count: the
    biggest meshes run first, so counting jobs put the end up to 87 times too
    far at the start (sauer-zdm2). The time left is elapsed x work left / work done.
    """

    def __init__(self, enabled: bool) -> None:
        self.enabled, self.bar = enabled, None

    def __call__(self, done: int, total: int, label: str, *,
                 work: tuple[float, float] = (0.0, 0.0)) -> None:
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(total=max(work[1], 1.0), desc="occlude", smoothing=0.0,
                            disable=not self.enabled,
                            bar_format="{desc}: {percentage:3.0f}%|{bar}| "
                                       "[{elapsed}<{remaining}{postfix}]")
        self.bar.set_postfix_str(f"{done}/{total} jobs {label[:60]}".rstrip(),
                                 refresh=False)
        self.bar.update(work[0] - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def run_occlude(args) -> int:
    # 1. every option, before any work and before DIR is made
    methods = _methods(args.methods)
    budget = _check_budget(args.budget, methods)
    jobs = check_jobs(args.jobs) if args.scheduler is None else 1
    if args.min_size is not None and not 0.0 < args.min_size <= 1.0:
        raise InputError(f"--min-size: expected a fraction of the level's bounding-box "
                         f"diagonal in (0, 1], got {args.min_size}")
    names = None
    if args.occluders is not None:
        names = [n.strip() for n in args.occluders.split(",") if n.strip()]
        if not names:
            raise InputError(f"--occluders: expected comma-separated object names, got "
                             f"{args.occluders!r}")
    out = check_output_folder(args.out, "-o")
    check_occlude_folder(out)  # an occluders/ link: refused before the level is read
    quiet = args.quiet
    with connect_scheduler(args.scheduler) as client:
        level = level_objects(args.level, up=args.up, min_size=args.min_size, names=names)
        if level.up_guessed and not quiet:
            _log.info("%s: up axis guessed +%s (%s); pass --up to set it", args.level,
                      level.up.upper(), level.up_reason)
        # 2. the run, in a folder this process alone writes
        with LockedFolder(out, busy=f"-o {out}: another occlude is writing this folder; "
                                    "wait for it to finish or choose another -o"):
            bar = _Bar(enabled=not (quiet or args.json) and sys.stderr.isatty())  # a terminal
            try:
                made = occlude_level(level, out, methods=methods, budget=budget,
                                     seed=args.seed, jobs=jobs, scheduler=client, progress=bar)
                report = write_occlude_report(out, level, made.manifest)
            finally:
                bar.close()
    doc = made.manifest
    if not quiet:
        _refusals(doc)
    emit(doc, args.json, _summary(doc, out, made) + ", " + ", ".join(
        str(out / f) for f in report) + " (open report.html in a browser)")
    return 0


def _refusals(doc: dict) -> None:
    """One line on stderr per kind of refusal, with its count: the objects refused before
    any method (too small, not named: the kind is the reason's text before its first
    colon) and, per method, the objects it refused for one reason. Each refused object
    has a line of its own at DEBUG (``--verbose``)."""
    kinds: dict[str, list[tuple[str, str]]] = {}
    for name, row in doc["objects"].items():
        if row["refused"]:
            kinds.setdefault(row["refused"].split(":", 1)[0], []).append((name, row["refused"]))
            _log.debug("refused %s: %s", name, row["refused"])
    for kind, refused in kinds.items():
        if len(refused) == 1:
            _log.warning("refused %s: %s", *refused[0])
        else:
            _log.warning("refused %d objects as %s (listed in occlude.json): %s", len(refused),
                         kind, _shown([name for name, _ in refused]))
    # per method, the objects refused for one reason on one line (E1M1's 58 open meshes
    # that aabb-skins leaves empty were 58 lines)
    groups: dict[tuple[str, str], list[str]] = {}
    for name, row in doc["objects"].items():
        for method, occ in row["occluders"].items():
            if "refused" in occ:
                groups.setdefault((method, occ["refused"]), []).append(name)
    for (method, why), names in groups.items():
        if len(names) == 1:
            _log.warning("refused %s for %s: %s", names[0], method, why)
        else:
            _log.warning("refused %d objects for %s (%s; listed in occlude.json): %s",
                         len(names), method, _shown(names), why)


def _shown(names: list[str]) -> str:
    """The first :data:`REFUSED_NAMES` names, then ``...`` when there are more."""
    return ", ".join(names[:REFUSED_NAMES]) + (", ..." if len(names) > REFUSED_NAMES else "")


def _summary(doc: dict, out, made) -> str:
    lines = [f"{doc['level']}: {doc['objects_total']} objects, {doc['objects_chosen']} chosen "
             f"(up +{doc['up'].upper()}); {made.computed} jobs run, {made.reused} resumed", "",
             "| method | objects | refused | meshes | triangles | guaranteed | seconds |",
             "|---|---|---|---|---|---|---|"]
    for method, s in doc["methods"].items():
        lines.append(f"| {method} | {s['objects']} | {s['refused']} | {s['meshes']} | "
                     f"{s['triangles']} | {'yes' if s['conservative_guaranteed'] else 'no'} | "
                     f"{s['seconds']:.1f} |")
    lines += ["", f"wrote {', '.join(str(out / f) for f in made.files)}"]
    return "\n".join(lines)
