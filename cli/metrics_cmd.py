"""``viscore measure``, ``viscore evaluate`` and ``viscore validate``."""

from __future__ import annotations

from dataclasses import asdict

from viscore.metrics import check_conservative, evaluate, occlusion_measure

from viscore import load_mesh, provenance

from ._common import emit


def add_parser(sub, common) -> None:
    m = sub.add_parser("measure", parents=[common], help="total occlusion measure of a mesh")
    m.add_argument("mesh", help="mesh file or built-in scene name")
    m.add_argument("--directions", type=int, default=64)
    m.add_argument("--res", type=int, default=256)
    m.set_defaults(run=run_measure)

    e = sub.add_parser("evaluate", parents=[common],
                       help="quad precision/recall of an occluder against its mesh")
    e.add_argument("mesh")
    e.add_argument("occluder")
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
    v.add_argument("occluder")
    v.add_argument("--rays", type=int, default=100_000)
    v.add_argument("--confidence", type=float, default=0.95)
    v.add_argument("--max-rate", type=float, default=0.001,
                   help="fail above this bound on the violation rate; 0: fail on any violation")
    v.add_argument("--domain", choices=["orbit", "volume"], default="orbit")
    v.set_defaults(run=run_validate)


def run_measure(args) -> int:
    mesh = load_mesh(args.mesh)
    r = occlusion_measure(mesh, directions=args.directions, resolution=args.res, seed=args.seed)
    doc = {"mesh": args.mesh, **asdict(r), "provenance": provenance()}
    emit(doc, args.json,
         f"{args.mesh}: occlusion measure {r.occlusion_measure:.6g} +- "
         f"{r.occlusion_measure_se:.2g} (s.e., {args.directions} directions, {args.res} px); "
         f"surface-area measure {r.surface_area_measure:.6g}")
    return 0


def run_evaluate(args) -> int:
    mesh, occ = load_mesh(args.mesh), load_mesh(args.occluder)
    params = {"seed": args.seed, "depth_aware": args.depth_aware}
    if args.res is not None:
        params["resolution"] = args.res
    if args.quads is not None:
        params["quads"] = args.quads
    if args.protocol == "orbit":
        params["views"] = args.views
    else:
        params["spacing"] = args.spacing
        params["merge_views"] = not args.no_merge
    r = evaluate(mesh, occ, protocol=args.protocol, **params)
    doc = {"mesh": args.mesh, "occluder": args.occluder, "triangles": len(occ.faces),
           **asdict(r), "provenance": provenance()}
    emit(doc, args.json,
         f"{args.occluder} vs {args.mesh} ({r.protocol}{', depth-aware' if r.depth_aware else ''}"
         f", {r.views} views): precision {r.precision:.4f} [{r.precision_ci[0]:.4f}, "
         f"{r.precision_ci[1]:.4f}], recall {r.recall:.4f} [{r.recall_ci[0]:.4f}, "
         f"{r.recall_ci[1]:.4f}] (95% bootstrap over views), {r.seconds:.1f} s")
    return 0


def run_validate(args) -> int:
    mesh, occ = load_mesh(args.mesh), load_mesh(args.occluder)
    r = check_conservative(mesh, occ, rays=args.rays, confidence=args.confidence,
                           domain=args.domain, seed=args.seed)
    ok = r.passes(args.max_rate)
    doc = {"mesh": args.mesh, "occluder": args.occluder, "passed": ok,
           "max_rate": args.max_rate, **asdict(r), "provenance": provenance()}
    emit(doc, args.json, ("PASS: " if ok else "FAIL: ") + r.summary())
    return 0 if ok else 1
