"""``viscore uncertainty MESH OCCLUDER`` and ``viscore uncertainty ablation MESH OCCLUDER``.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from dataclasses import asdict
from pathlib import Path

from viscore import InputError, load_mesh, load_occluder, provenance, stream_seed
from viscore._validate import as_fraction, as_positive_int, as_seed
from viscore.metrics import (
    ablation_plot,
    convergence_ablation,
    distribution_plot,
    evaluate,
    paired_difference,
    uncertainty_report,
)

from ._common import check_output_folder, dumps, emit, file_mode, parse_list

#: Factors of the convergence ablation.
ABLATION_FACTORS = ("quads", "views", "spacing")

#: Largest image side, pixels (the limit of the evaluation functions).
_MAX_RESOLUTION = 8192


def add_parser(sub, common) -> None:
    u = sub.add_parser(
        "uncertainty", parents=[common],
        help="intervals, Bayesian summaries and diagnostics; or 'ablation MESH OCCLUDER'",
        description="viscore uncertainty MESH OCCLUDER: bootstrap intervals (percentile, BCa), "
                    "hierarchical Beta models with emcee diagnostics, plots. "
                    "viscore uncertainty ablation MESH OCCLUDER: s.d. of P and R over seeded "
                    "repeats against quads per view, view spacing and number of views.")
    u.add_argument("items", nargs="+", metavar="[ablation] MESH OCCLUDER")
    u.add_argument("--protocol", choices=["orbit", "volume"], default=None,
                   help="default orbit (not used by ablation)")
    u.add_argument("--views", type=int, default=None,
                   help="orbit views (default 256; ablation: held fixed, default 64)")
    u.add_argument("--quads", type=int, default=None,
                   help="quads per view (default: the protocol's; ablation: held fixed, "
                        "default 5000)")
    u.add_argument("--res", type=int, default=None,
                   help="pixels per side (default 256; ablation: default 128)")
    u.add_argument("--directions", type=int, default=None,
                   help="occlusion-measure directions (default 64; not used by ablation)")
    u.add_argument("--threshold", type=float, default=None,
                   help="tail probability P(rate < threshold) of the Beta models (default 0.9; "
                        "not used by ablation)")
    u.add_argument("--steps", type=int, default=None,
                   help="emcee steps per walker (default 4000; not used by ablation)")
    u.add_argument("--repeats", type=int, default=10, help="ablation: repeats per setting")
    u.add_argument("--factors", default="quads,views,spacing", help="ablation: which factors")
    u.add_argument("--quads-list", default=None,
                   help="ablation: quads per view, e.g. 100,1000,5000,10000,20000,30000,100000")
    u.add_argument("--views-list", default=None, help="ablation: orbit views, e.g. 16,64,256")
    u.add_argument("--spacings", default=None,
                   help="ablation: view spacings as fractions of the diagonal (default "
                        "0.16,0.08,0.04; Wu et al. 2022 go down to 0.005; each halving "
                        "costs 8x)")
    u.add_argument("--versus", default=None, metavar="OCCLUDER_B",
                   help="paired comparison: a second occluder of the same mesh, same views")
    u.add_argument("--out", default="viscore-uncertainty", help="folder for tables and plots")
    u.set_defaults(run=run_uncertainty)


def run_uncertainty(args) -> int:
    items = list(args.items)
    ablation = bool(items) and items[0] == "ablation"
    if ablation:
        items = items[1:]
    if len(items) != 2:
        raise InputError("usage: viscore uncertainty [ablation] MESH OCCLUDER")
    # every argument is checked, and every mesh loaded, before any work
    seed = as_seed(args.seed, "--seed")
    out = _check_out(Path(args.out))
    if ablation:
        if args.versus is not None:
            raise InputError("--versus: not used by 'uncertainty ablation'")
        options = _ablation_options(args)
        mesh, occ = load_mesh(items[0]), load_occluder(items[1])
        return _ablation(args, mesh, occ, items, out, seed, options)
    def given(value, default):
        return default if value is None else value

    options = {"protocol": given(args.protocol, "orbit"),
               "views": as_positive_int(given(args.views, 256), "--views"),
               "quads": None if args.quads is None else as_positive_int(args.quads, "--quads"),
               "resolution": as_positive_int(given(args.res, 256), "--res",
                                             maximum=_MAX_RESOLUTION),
               "directions": as_positive_int(given(args.directions, 64), "--directions"),
               "threshold": as_fraction(given(args.threshold, 0.9), "--threshold"),
               "steps": as_positive_int(given(args.steps, 4000), "--steps")}
    mesh, occ = load_mesh(items[0]), load_occluder(items[1])
    versus = load_occluder(args.versus) if args.versus is not None else None
    report, result, models = uncertainty_report(mesh, occ, seed=seed, **options)
    paired = None
    if versus is not None:
        other = evaluate(mesh, versus, protocol=options["protocol"],
                         **{k: v for k, v in result.params.items()
                            if k in ("views", "quads", "resolution", "spacing")},
                         seed=seed)
        paired = asdict(paired_difference(result, other,
                                          seed=stream_seed(seed, "paired-bootstrap")))
        paired["versus"] = args.versus
    doc = {"mesh": items[0], "occluder": items[1], **report, "paired": paired,
           "per_view": {k: result.per_view[k] for k in
                        ("precision", "recall", "weight", "quads_orig", "quads_occ",
                         "quads_both") if k in result.per_view},
           "provenance": provenance()}
    _write_outputs(out, {"per_view.png": lambda path: distribution_plot(result, models, path),
                         "uncertainty.json": dumps(doc).encode()})
    lines = [f"{items[1]} vs {items[0]} ({report['protocol']}, {report['views']} views, "
             f"seed {seed})",
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


def _check_out(out: Path) -> Path:
    """The output folder, refused (InputError) unless it is or can be made a writable folder.

    Only the last component is created, later; a missing parent is an error.
    Writability is probed (:func:`viscore.cli._common.check_output_folder`).
    """
    return check_output_folder(out)


def _write_outputs(out: Path, files: dict) -> None:
    """Write every output to a temporary file in ``out``, then move all of them in place.

    ``files`` maps a file name to its bytes or to a function writing that
    file at a given path (a plot). Nothing is moved unless every file was
    written; the files are moved in the given order (put the main document
    last). On failure the temporary files, and ``out`` if this call created
    it and it is empty, are removed; an OSError names the output file.
    """
    created = not out.exists()
    out.mkdir(exist_ok=True)
    mode = file_mode()
    temps: dict[str, Path] = {}
    name = None
    try:
        for name, content in files.items():
            stem, dot, suffix = name.rpartition(".")
            fd, tmp = tempfile.mkstemp(dir=out, prefix=f".{stem}.", suffix=f"{dot}{suffix}")
            temps[name] = Path(tmp)
            if callable(content):
                os.close(fd)
                content(Path(tmp))
            else:
                with os.fdopen(fd, "wb") as fh:
                    fh.write(content)
                    fh.flush()
                    os.fsync(fh.fileno())
            os.chmod(tmp, mode)
        for name, tmp in temps.items():
            os.replace(tmp, out / name)
    except BaseException as exc:
        for tmp in temps.values():
            tmp.unlink(missing_ok=True)
        if created:
            with contextlib.suppress(OSError):
                out.rmdir()
        if isinstance(exc, OSError) and name is not None:
            raise OSError(exc.errno, exc.strerror or str(exc), str(out / name)) from exc
        raise


def _iv(pair, digits: int = 4) -> str:
    return "[" + ", ".join("nan" if v is None or v != v else f"{v:.{digits}g}"
                           for v in pair) + "]"


def _ablation_options(args) -> dict:
    """Checked options of ``uncertainty ablation``; the options it does not use are refused."""
    for name in ("protocol", "directions", "threshold", "steps"):
        if getattr(args, name) is not None:
            raise InputError(f"--{name}: not used by 'uncertainty ablation'")
    fixed = {"views": None if args.views is None else as_positive_int(args.views, "--views"),
             "quads": None if args.quads is None else as_positive_int(args.quads, "--quads"),
             "resolution": None if args.res is None else
             as_positive_int(args.res, "--res", maximum=_MAX_RESOLUTION)}
    factors = tuple(f.strip() for f in args.factors.split(",") if f.strip())
    bad = [f for f in factors if f not in ABLATION_FACTORS]
    if bad or not factors:
        raise InputError(f"--factors: expected some of {','.join(ABLATION_FACTORS)}, "
                         f"got {args.factors!r}")
    repeats = as_positive_int(args.repeats, "--repeats")
    if repeats < 2:
        raise InputError(f"--repeats: at least 2 to estimate a standard deviation, got {repeats}")
    lists = {name: parse_list(arg, kind, option) for name, arg, kind, option in (
        ("quads_list", args.quads_list, int, "--quads-list"),
        ("views_list", args.views_list, int, "--views-list"),
        ("spacing_list", args.spacings, float, "--spacings")) if arg is not None}
    for value in lists.get("spacing_list", ()):
        as_fraction(value, "--spacings")
    return {"factors": factors, "repeats": repeats, **lists,
            **{k: v for k, v in fixed.items() if v is not None}}


def _ablation(args, mesh, occ, items, out, seed, options) -> int:
    import sys

    quiet = args.quiet or args.json
    result = convergence_ablation(
        mesh, occ, seed=seed, **options,
        progress=None if quiet else (lambda text: print(f"ablation: {text}", file=sys.stderr)))
    doc = {"mesh": items[0], "occluder": items[1], **asdict(result), "provenance": provenance()}
    head = "factor,value,protocol,precision_mean,precision_sd,recall_mean,recall_sd,repeats\n"
    csv = head + "".join(
        f"{r['factor']},{r['value']},{r['protocol']},{r['precision_mean']},"
        f"{r['precision_sd']},{r['recall_mean']},{r['recall_sd']},{r['repeats']}\n"
        for r in result.rows)
    _write_outputs(out, {"ablation.png": lambda path: ablation_plot(result, path),
                         "ablation.csv": csv.encode(),
                         "ablation.json": dumps(doc).encode()})
    lines = [f"{'factor':<8} {'value':>8} {'sd(P)':>10} {'sd(R)':>10} {'mean P':>8} {'mean R':>8}"]
    lines += [f"{r['factor']:<8} {r['value']:>8g} {r['precision_sd']:>10.2e} "
              f"{r['recall_sd']:>10.2e} {r['precision_mean']:>8.4f} {r['recall_mean']:>8.4f}"
              for r in result.rows]
    lines.append(f"wrote {out}/ablation.csv, ablation.json and ablation.png")
    emit(doc, args.json, "\n".join(lines))
    return 0
