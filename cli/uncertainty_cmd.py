"""``viscore uncertainty MESH OCCLUDER`` and ``viscore uncertainty ablation MESH OCCLUDER``."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

from viscore.metrics import (
    ablation_plot,
    convergence_ablation,
    distribution_plot,
    evaluate,
    paired_difference,
    uncertainty_report,
)

from viscore import InputError, load_mesh, provenance

from ._common import dumps, emit, parse_list, write_atomic


def add_parser(sub, common) -> None:
    u = sub.add_parser(
        "uncertainty", parents=[common],
        help="intervals, Bayesian summaries and diagnostics; or 'ablation MESH OCCLUDER'",
        description="viscore uncertainty MESH OCCLUDER: bootstrap intervals (percentile, BCa), "
                    "hierarchical Beta models with emcee diagnostics, plots. "
                    "viscore uncertainty ablation MESH OCCLUDER: s.d. of P and R over seeded "
                    "repeats against quads per view, view spacing and number of views.")
    u.add_argument("items", nargs="+", metavar="[ablation] MESH OCCLUDER")
    u.add_argument("--protocol", choices=["orbit", "volume"], default="orbit")
    u.add_argument("--views", type=int, default=256)
    u.add_argument("--quads", type=int, default=None)
    u.add_argument("--res", type=int, default=256)
    u.add_argument("--directions", type=int, default=64, help="occlusion-measure directions")
    u.add_argument("--threshold", type=float, default=0.9,
                   help="tail probability P(rate < threshold) of the Beta models")
    u.add_argument("--steps", type=int, default=4000, help="emcee steps per walker")
    u.add_argument("--repeats", type=int, default=10, help="ablation: repeats per setting")
    u.add_argument("--factors", default="quads,views,spacing", help="ablation: which factors")
    u.add_argument("--quads-list", default=None,
                   help="ablation: quads per view, e.g. 100,1000,5000,10000,20000,30000,100000")
    u.add_argument("--views-list", default=None, help="ablation: orbit views, e.g. 16,64,256")
    u.add_argument("--spacings", default=None,
                   help="ablation: view spacings as fractions of the diagonal (default "
                        "0.16,0.08,0.04; seed 001 goes to 0.005, each halving costs 8x)")
    u.add_argument("--versus", default=None, metavar="OCCLUDER_B",
                   help="paired comparison: a second occluder of the same mesh, same views")
    u.add_argument("--out", default="viscore-uncertainty", help="folder for tables and plots")
    u.set_defaults(run=run_uncertainty)


def run_uncertainty(args) -> int:
    items = list(args.items)
    ablation = items[0] == "ablation"
    if ablation:
        items = items[1:]
    if len(items) != 2:
        raise InputError("usage: viscore uncertainty [ablation] MESH OCCLUDER")
    mesh, occ = load_mesh(items[0]), load_mesh(items[1])
    out = Path(args.out)
    if ablation:
        return _ablation(args, mesh, occ, items, out)
    report, result, models = uncertainty_report(
        mesh, occ, protocol=args.protocol, views=args.views, quads=args.quads,
        resolution=args.res, directions=args.directions, threshold=args.threshold,
        steps=args.steps, seed=args.seed)
    paired = None
    if args.versus:
        other = evaluate(mesh, load_mesh(args.versus), protocol=args.protocol,
                         **{k: v for k, v in result.params.items()
                            if k in ("views", "quads", "resolution", "spacing")},
                         seed=args.seed)
        paired = asdict(paired_difference(result, other, seed=args.seed))
        paired["versus"] = args.versus
    doc = {"mesh": items[0], "occluder": items[1], **report, "paired": paired,
           "per_view": {k: result.per_view[k] for k in
                        ("precision", "recall", "quads_orig", "quads_occ", "quads_both")},
           "provenance": provenance()}
    out.mkdir(parents=True, exist_ok=True)
    write_atomic(out / "uncertainty.json", dumps(doc).encode())
    distribution_plot(result, models, out / "per_view.png")
    lines = [f"{items[1]} vs {items[0]} ({report['protocol']}, {report['views']} views, "
             f"seed {args.seed})",
             f"  precision {report['precision']:.4f}  95% percentile "
             f"{_iv(report['precision_ci'])}  BCa {_iv(report['precision_ci_bca'])}",
             f"  recall    {report['recall']:.4f}  95% percentile {_iv(report['recall_ci'])}"
             f"  BCa {_iv(report['recall_ci_bca'])}",
             f"  occlusion measure {report['occlusion_measure']:.5g} +- "
             f"{report['occlusion_measure_se']:.2g}  95% {_iv(report['occlusion_measure_ci'], 5)}"]
    for q, m in models.items():
        lines.append(
            f"  {q} per view (hierarchical Beta, per quad): mean {m.mean:.4f} "
            f"{_iv(m.mean_ci)}, between-view s.d. {m.spread:.4f}, share of views below "
            f"{m.threshold:g}: {m.tail_probability:.3g} {_iv(m.tail_probability_ci, 3)}; "
            f"acceptance {m.acceptance_fraction:.2f}, tau {max(m.autocorr_time):.1f}, "
            f"ESS {m.effective_samples:.0f}" + ("" if m.converged else
                                                 "  WARNING: " + "; ".join(m.warnings)))
    if paired:
        lines.append(
            f"  vs {args.versus} (same views): recall {paired['recall_diff']:+.4f} "
            f"{_iv(paired['recall_diff_ci'])}, P(better) {paired['prob_a_better_recall']:.3f}; "
            f"precision {paired['precision_diff']:+.4f} {_iv(paired['precision_diff_ci'])}, "
            f"P(better) {paired['prob_a_better_precision']:.3f}")
    lines.append(f"wrote {out}/uncertainty.json and per_view.png")
    emit(doc, args.json, "\n".join(lines))
    return 0


def _iv(pair, digits: int = 4) -> str:
    return "[" + ", ".join("nan" if v is None or v != v else f"{v:.{digits}g}"
                           for v in pair) + "]"


def _ablation(args, mesh, occ, items, out) -> int:
    import sys

    factors = tuple(f.strip() for f in args.factors.split(",") if f.strip())
    bad = [f for f in factors if f not in ("quads", "views", "spacing")]
    if bad or not factors:
        raise InputError(f"--factors: expected some of quads,views,spacing, got {args.factors!r}")
    quiet = args.quiet or args.json
    lists = {name: parse_list(arg, kind, option) for name, arg, kind, option in (
        ("quads_list", args.quads_list, int, "--quads-list"),
        ("views_list", args.views_list, int, "--views-list"),
        ("spacing_list", args.spacings, float, "--spacings")) if arg}
    result = convergence_ablation(
        mesh, occ, factors=factors, repeats=args.repeats, seed=args.seed, **lists,
        progress=None if quiet else (lambda text: print(f"ablation: {text}", file=sys.stderr)))
    out.mkdir(parents=True, exist_ok=True)
    doc = {"mesh": items[0], "occluder": items[1], **asdict(result), "provenance": provenance()}
    write_atomic(out / "ablation.json", dumps(doc).encode())
    head = "factor,value,protocol,precision_mean,precision_sd,recall_mean,recall_sd,repeats\n"
    csv = head + "".join(
        f"{r['factor']},{r['value']},{r['protocol']},{r['precision_mean']},"
        f"{r['precision_sd']},{r['recall_mean']},{r['recall_sd']},{r['repeats']}\n"
        for r in result.rows)
    write_atomic(out / "ablation.csv", csv.encode())
    ablation_plot(result, out / "ablation.png")
    lines = [f"{'factor':<8} {'value':>8} {'sd(P)':>10} {'sd(R)':>10} {'mean P':>8} {'mean R':>8}"]
    lines += [f"{r['factor']:<8} {r['value']:>8g} {r['precision_sd']:>10.2e} "
              f"{r['recall_sd']:>10.2e} {r['precision_mean']:>8.4f} {r['recall_mean']:>8.4f}"
              for r in result.rows]
    lines.append(f"wrote {out}/ablation.csv, ablation.json and ablation.png")
    emit(doc, args.json, "\n".join(lines))
    return 0
