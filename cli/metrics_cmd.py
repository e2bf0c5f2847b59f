"""``viscore measure``, ``viscore evaluate`` and ``viscore validate``."""

from __future__ import annotations

import logging
import time
from dataclasses import asdict

from viscore import InputError, load_mesh, load_occluder, provenance
from viscore._validate import as_fraction, as_positive, as_positive_int, as_seed, check_memory
from viscore.metrics import (
    check_conservative,
    conservativeness_bytes,
    evaluate,
    evaluation_bytes,
    measure_bytes,
    occlusion_measure,
)

from ._common import emit, format_duration, warn_estimate

_log = logging.getLogger("viscore.cli")

#: Pixels per side accepted (the metrics' own limit).
_MAX_RESOLUTION = 8192

#: Rays of ``validate``'s timed first batch: one casting batch of
#: :func:`viscore.metrics.check_conservative` (about 1 s at the 3e5 rays/s
#: measured on fat-torus on a busy 2-core machine).
_ETA_PROBE_RAYS = 262_144

#: ``--rays`` from which ``validate`` times a first batch: the batch then costs
#: under 7% of the run, and a smaller run takes seconds (13 s at 3e5 rays/s).
_ETA_MIN_RAYS = 4_000_000

#: Rays per second of ``validate``, measured on fat-torus on a busy 2-core machine:
#: the figure the ``--rays`` cap states its time at.
RAYS_PER_SECOND = 3e5

#: At most this many ``validate --rays``: 10^10, about 9 hours at
#: :data:`RAYS_PER_SECOND` (an overnight run; its bound on the violation rate
#: at 0 violations is 3e-10). More is refused before anything is loaded.
MAX_RAYS = 10**10


#: Help of the OCCLUDER argument (read by :func:`viscore.load_occluder`).
_OCCLUDER_HELP = ("occluder file: any mesh file, Godot 4 .tscn/.tres/.occ (ArrayOccluder3D, as "
                  "Godot's bake writes), or a glTF/GLB with -occonly nodes; world space")


def add_parser(sub, common) -> None:
    m = sub.add_parser("measure", parents=[common], help="total occlusion measure of a mesh")
    m.add_argument("mesh", help="mesh file or built-in scene name")
    m.add_argument("--directions", type=int, default=64, help="view directions (default 64)")
    m.add_argument("--res", type=int, default=256, help="pixels per side (default 256)")
    m.set_defaults(run=run_measure)

    e = sub.add_parser("evaluate", parents=[common],
                       help="quad precision/recall of an occluder against its mesh")
    e.add_argument("mesh")
    e.add_argument("occluder", help=_OCCLUDER_HELP)
    e.add_argument("--protocol", choices=["orbit", "volume"], default="orbit")
    e.add_argument("--depth-aware", action="store_true")
    e.add_argument("--views", type=int, default=256, help="orbit views (default 256)")
    e.add_argument("--quads", type=int, default=None,
                   help="quads per view (default 32000 orbit, 5000 volume)")
    e.add_argument("--res", type=int, default=None, help="pixels per side (default 256)")
    e.add_argument("--spacing", type=float, default=None,
                   help="volume: view spacing, world units (default 4%% of the diagonal)")
    e.add_argument("--no-merge", action="store_true", help="volume: no octree view merging")
    e.set_defaults(run=run_evaluate)

    v = sub.add_parser("validate", parents=[common],
                       help="ray-wise conservativeness; exit 1 when the bound exceeds --max-rate")
    v.add_argument("mesh")
    v.add_argument("occluder", help=_OCCLUDER_HELP)
    v.add_argument("--rays", type=int, default=100_000,
                   help=f"rays cast (default 100000; at most {MAX_RAYS:.0e}, about "
                        f"{format_duration(MAX_RAYS / RAYS_PER_SECOND)} at "
                        f"{RAYS_PER_SECOND:.0e} rays/s)")
    v.add_argument("--confidence", type=float, default=0.95,
                   help="of the upper bound on the violation rate, in (0, 1) (default 0.95)")
    v.add_argument("--max-rate", type=float, default=0.001,
                   help="fail above this bound on the violation rate, a fraction in [0, 1]; "
                        "0: fail on any violation (default 0.001)")
    v.add_argument("--domain", choices=["orbit", "volume"], default="orbit")
    v.set_defaults(run=run_validate)


def _resolution(value: int) -> int:
    return as_positive_int(value, "--res", maximum=_MAX_RESOLUTION)


def _note_dropped(*meshes) -> None:
    """After success: say how many degenerate faces each mesh lost (INFO, stderr)."""
    for mesh in meshes:
        dropped = mesh.metadata.get("dropped_degenerate_faces", 0)
        if dropped:
            _log.info("%s: dropped %d degenerate face(s)", mesh.metadata.get("name"), dropped)


def run_measure(args) -> int:
    seed = as_seed(args.seed, "--seed")
    directions = as_positive_int(args.directions, "--directions")
    res = _resolution(args.res)
    check_memory(measure_bytes(directions, res), f"--directions {directions} --res {res}")
    mesh = load_mesh(args.mesh)
    r = occlusion_measure(mesh, directions=directions, resolution=res, seed=seed)
    doc = {"mesh": args.mesh, **asdict(r), "provenance": provenance()}
    _note_dropped(mesh)
    emit(doc, args.json,
         f"{args.mesh}: occlusion measure {r.occlusion_measure:.6g} +- "
         f"{r.occlusion_measure_se:.2g} (s.e., {directions} directions, {res} px); "
         f"surface-area measure {r.surface_area_measure:.6g}")
    return 0


def run_evaluate(args) -> int:
    params = {"seed": as_seed(args.seed, "--seed"), "depth_aware": args.depth_aware}
    res = 256 if args.res is None else _resolution(args.res)
    if args.res is not None:
        params["resolution"] = res
    quads = 32_000 if args.protocol == "orbit" else 5_000
    if args.quads is not None:
        quads = params["quads"] = as_positive_int(args.quads, "--quads")
    if args.protocol == "orbit":
        if args.spacing is not None or args.no_merge:
            raise InputError("--spacing and --no-merge apply to --protocol volume only")
        views = params["views"] = as_positive_int(args.views, "--views")
        estimate = evaluation_bytes("orbit", views=views, quads=quads, resolution=res,
                                    depth_aware=args.depth_aware)
        check_memory(estimate, f"--views {views} --res {res} --quads {quads}")
    else:
        if args.spacing is not None:
            params["spacing"] = as_positive(args.spacing, "--spacing")
        params["merge_views"] = not args.no_merge
        # one frustum image at a time at least; the positions are counted by the library
        check_memory(evaluation_bytes("volume", quads=quads, resolution=res,
                                      depth_aware=args.depth_aware),
                     f"--res {res} --quads {quads}")
    mesh, occ = load_mesh(args.mesh), load_occluder(args.occluder)
    r = evaluate(mesh, occ, protocol=args.protocol, **params)
    doc = {"mesh": args.mesh, "occluder": args.occluder, "triangles": len(occ.faces),
           **asdict(r), "provenance": provenance()}
    _note_dropped(mesh, occ)
    emit(doc, args.json,
         f"{args.occluder} vs {args.mesh} ({r.protocol}{', depth-aware' if r.depth_aware else ''}"
         f", {r.views} views): precision {r.precision:.4f} [{r.precision_ci[0]:.4f}, "
         f"{r.precision_ci[1]:.4f}], recall {r.recall:.4f} [{r.recall_ci[0]:.4f}, "
         f"{r.recall_ci[1]:.4f}] (95% bootstrap over views), {r.seconds:.1f} s")
    return 0


def check_rays(value: object) -> int:
    """``validate --rays``: a positive integer up to :data:`MAX_RAYS`, or one line saying why.

    Examples
    --------
    >>> check_rays(10**6)
    1000000
    >>> try:
    ...     check_rays(10**12)
    ... except InputError as exc:
    ...     print(exc)
    --rays 1000000000000: at most 10000000000 (it would take about 39 days at 3e+05 rays/s, ...
    """
    rays = as_positive_int(value, "--rays")
    if rays > MAX_RAYS:
        raise InputError(f"--rays {rays}: at most {MAX_RAYS} (it would take about "
                         f"{format_duration(rays / RAYS_PER_SECOND)} at {RAYS_PER_SECOND:.0e} "
                         f"rays/s, the rate on a 2-core machine; the cap about "
                         f"{format_duration(MAX_RAYS / RAYS_PER_SECOND)})")
    return rays


def run_validate(args) -> int:
    seed = as_seed(args.seed, "--seed")
    rays = check_rays(args.rays)
    confidence = as_fraction(args.confidence, "--confidence", open_low=True)
    if confidence >= 1:
        raise InputError("--confidence: expected a number in (0, 1), got 1.0")
    max_rate = as_fraction(args.max_rate, "--max-rate")
    check_memory(conservativeness_bytes(rays), f"--rays {rays}")
    mesh, occ = load_mesh(args.mesh), load_occluder(args.occluder)
    settings = {"confidence": confidence, "domain": args.domain, "seed": seed}
    if rays >= _ETA_MIN_RAYS:  # a long run says how long first
        start = time.perf_counter()
        check_conservative(mesh, occ, rays=_ETA_PROBE_RAYS, **settings)
        per_ray = (time.perf_counter() - start) / _ETA_PROBE_RAYS
        warn_estimate(f"--rays {rays}", per_ray * rays,
                      f"{1 / per_ray:.3g} rays/s measured on a first batch of "
                      f"{_ETA_PROBE_RAYS:,}")
    r = check_conservative(mesh, occ, rays=rays, **settings)
    ok = r.passes(max_rate)
    doc = {"mesh": args.mesh, "occluder": args.occluder, "passed": ok,
           "max_rate": max_rate, **asdict(r), "provenance": provenance()}
    _note_dropped(mesh, occ)
    emit(doc, args.json, ("PASS: " if ok else "FAIL: ") + r.summary())
    return 0 if ok else 1
