"""``viscore bench walks LEVEL...``: where the walk stands on each level, and what culling gets.

Per level, the figures a result measured on that level rests on: the walk
:func:`viscore.metrics.camera_paths.camera_walk` makes (the up axis, the eye
height it guessed and why, the frames kept of those asked, how many stand by
the library's own camera check, :func:`~viscore.metrics.camera_paths.camera_stances`,
moved and dropped), and with ``cull=True`` the culling simulation along that
walk as ``viscore cull`` runs it by default
(:func:`viscore.metrics.culling.simulate_culling`): the share of the objects in
view that the ray-cast truth hides, the best culled share of a guaranteed
runtime that made occluders, that runtime's false culls, and their ratio, each
share with a bootstrap interval over the frames (the frames are the
independent units). Figures, never assertions: levels are the user's files.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np

from viscore._validate import as_positive, as_positive_int, as_seed
from viscore.culling import DEFAULT_REDUCTION

#: Two-sided level of the bootstrap intervals over frames.
CONFIDENCE = 0.95

#: Ground-truth image of the culling simulation (``viscore cull``'s default).
WIDTH, HEIGHT = 1280, 720

#: The reference runtimes of ``--gap`` (:func:`viscore.metrics.culling_gap.culling_gap`):
#: the occluder objects' own triangles at the default buffer resolution and at full
#: resolution, and every object's at full resolution. Never a guaranteed runtime of the
#: level: they are its whole mesh.
GAP_OWN, GAP_OWN_FULL, GAP_EVERY_FULL = "gap:own", "gap:own-full", "gap:every-full"


def _interval(num: np.ndarray, den: np.ndarray, seed: int) -> list[float]:
    from viscore.metrics import bootstrap_ratio

    low, high = bootstrap_ratio(np.asarray(num, float), np.asarray(den, float),
                                confidence=CONFIDENCE, seed=seed)
    return [float(low), float(high)]


def _share(num: np.ndarray, den: np.ndarray) -> float | None:
    total = float(np.sum(den))
    return float(np.sum(num)) / total if total > 0 else None


def _gap_runtimes(level, seed: int, reduction: int) -> dict:
    """The reference runtimes of :func:`viscore.metrics.culling_gap.culling_gap`: the
    occluder objects' own triangles at the runtimes' resolution (``reduction``) and at full
    resolution, and every object's at full resolution when some object gets no occluder."""
    from viscore.generators import culling_runtimes

    objects, chosen = level.objects, level.chosen
    out = {}
    for name, indices, scale in (
            (GAP_OWN, chosen, reduction), (GAP_OWN_FULL, chosen, 1),
            (GAP_EVERY_FULL, np.arange(len(objects)), 1)):
        if name == GAP_EVERY_FULL and len(chosen) == len(objects):
            continue
        rts, _ = culling_runtimes(objects, indices, ["original"], seed=seed, frusta=False,
                                  flat=level.flat, reduction=scale)
        out[name] = rts["depth-buffer:original"]
    return out


def _cull_figures(level, walk, *, seed: int, bounds: str, methods: Sequence[str] | None,
                  width: int, height: int, gap: bool = False,
                  reduction: int = DEFAULT_REDUCTION) -> dict:
    """The culling simulation along ``walk``: truth, best guaranteed runtime, false culls
    (with ``gap``, where the best runtime's misses go)."""
    from viscore.culling import occludee_boxes, parse_bounds
    from viscore.generators import REGISTRY, culling_runtimes
    from viscore.metrics import simulate_culling

    kind, clusters = parse_bounds(bounds, "--bounds")
    objects = level.objects
    if methods is None:  # cull's default: the methods that can be guaranteed
        methods = [m for m, spec in REGISTRY.items() if spec.conservative]
    runtimes, info = culling_runtimes(objects, level.chosen, list(methods), seed=seed,
                                      flat=level.flat, reduction=reduction)
    references = _gap_runtimes(level, seed, reduction) if gap else {}
    boxes, kind, split = occludee_boxes(objects, kind, clusters)
    result = simulate_culling(objects, {**runtimes, **references}, list(walk.cameras),
                              width=width, height=height, bounds=boxes, stances=walk.stances,
                              keep_frames=range(len(walk.cameras)) if gap else ())
    in_view = result.in_view.astype(float)
    hidden = in_view - result.visible
    totals = {k: t for k, t in result.totals().items() if k not in references}
    guaranteed = {k: t for k, t in totals.items()
                  if k != "none" and t["conservative"] and info[k].get("occluders", 0)}
    best = max(guaranteed, key=lambda k: (guaranteed[k]["culled_share"], k), default=None)
    out = {"bounds": kind, "split_objects": split, "methods": list(methods),
           "hidden_share": _share(hidden, in_view),
           "hidden_share_ci": _interval(hidden, in_view, seed),
           "runtimes": {k: {"culled_share": t["culled_share"], "false_culls": t["false_culls"],
                            "conservative": t["conservative"],
                            "occluders": info[k].get("occluders", 0),
                            "overhead_ms": t["overhead_ms"]}
                        for k, t in totals.items()},
           "best_guaranteed": best, "false_culls_guaranteed":
           int(sum(t["false_culls"] for t in guaranteed.values()))}
    if best is None:  # nothing guaranteed culls
        out.update(best_culled_share=0.0, best_culled_share_ci=None, best_false_culls=0,
                   best_over_hidden=0.0 if hidden.sum() > 0 else None,
                   best_over_hidden_ci=None)
    else:
        culled = result.runtimes[best].culled.astype(float)
        out.update(best_culled_share=totals[best]["culled_share"],
                   best_culled_share_ci=_interval(culled, in_view, seed),
                   best_false_culls=totals[best]["false_culls"],
                   best_over_hidden=_share(culled, hidden),
                   best_over_hidden_ci=_interval(culled, hidden, seed))
    if gap:
        from viscore.metrics import culling_gap

        every = GAP_EVERY_FULL if GAP_EVERY_FULL in references else None
        shares = result.totals()
        out["gap"] = {"reference_culled_share": {k: shares[k]["culled_share"]
                                                 for k in references}}
        if best is not None:
            out["gap"].update(culling_gap(result, objects.lower, objects.upper,
                                          list(objects.names), best, own=GAP_OWN,
                                          own_full=GAP_OWN_FULL, every_full=every).to_json())
    return out


def bench_walks(levels: Sequence[str], *, frames: int = 20, seed: int = 0,
                up: str | None = None, eye_height: float | None = None, cull: bool = False,
                bounds: str | None = None, methods: Sequence[str] | None = None,
                width: int = WIDTH, height: int = HEIGHT, gap: bool = False,
                buffer_scale: int = DEFAULT_REDUCTION,
                progress: Callable[[dict], None] | None = None) -> dict:
    """The walk on each level, and with ``cull`` the culling along it.

    Parameters
    ----------
    levels : sequence of str
        Level files (glTF/GLB, or a single mesh split into objects) or built-in
        culling scenes, as ``viscore cull`` takes them.
    frames : int, optional
        Frames asked of each walk (default 20).
    seed : int, optional
        Seed of the walks, the generators and the bootstrap (default 0).
    up : {'x', 'y', 'z'}, optional
        The up axis of every level (default: guessed for a single mesh, +Y for glTF).
    eye_height : float, optional
        The eye height of every level, in its units (default: guessed per level).
    cull : bool, optional
        Also run the culling simulation along each walk (default False).
    bounds : str, optional
        The occludee bounds, as ``cull --bounds`` (default
        :data:`~viscore.culling.occludee_bounds.DEFAULT_BOUNDS`, as ``cull``'s).
    methods : sequence of str, optional
        Occluder methods of the depth-buffer runtimes (default: cull's, those
        that can be guaranteed).
    width, height : int, optional
        Ground-truth image, pixels (default 1280 x 720).
    gap : bool, optional
        With ``cull``: also run the reference runtimes :data:`GAP_OWN`,
        :data:`GAP_OWN_FULL` and :data:`GAP_EVERY_FULL` along the walk and sort the
        best guaranteed runtime's misses by cause (the key ``gap`` of ``cull``:
        :meth:`~viscore.metrics.culling_gap.CullingGap.to_json` and the references'
        culled shares); default False. Several times the work of ``cull`` alone.
    buffer_scale : int, optional
        With ``cull``: screen pixels per depth-buffer pixel along each side, as ``cull
        --buffer-scale`` (default :data:`viscore.culling.DEFAULT_REDUCTION`, 2: 640 x 360
        at 1280 x 720).
    progress : callable, optional
        Called with each level's row when it is done.

    Returns
    -------
    dict
        ``levels``: one row per level (``level``, ``objects``, ``objects_rule``,
        ``up``, the walk's summary of :meth:`~viscore.metrics.camera_paths.Walk.to_json`,
        ``seconds``, and with ``cull`` the key ``cull``: ``hidden_share``, the
        ``best_guaranteed`` runtime, ``best_culled_share``, ``best_false_culls``,
        ``best_over_hidden``, each share with a ``_ci`` bootstrap interval over
        the frames); ``settings``.

    Raises
    ------
    InputError
        A bad option or level (before that level's work).
    """
    from viscore.level import level_objects
    from viscore.metrics import camera_walk, guess_eye_height

    frames = as_positive_int(frames, "--frames", maximum=100_000)
    seed = as_seed(seed)
    width = as_positive_int(width, "--width", maximum=16384)
    height = as_positive_int(height, "--height", maximum=16384)
    buffer_scale = as_positive_int(buffer_scale, "--buffer-scale", maximum=min(width, height))
    if eye_height is not None:
        eye_height = as_positive(eye_height, "--eye-height")
    if cull:
        from viscore.culling import DEFAULT_BOUNDS, parse_bounds

        bounds = DEFAULT_BOUNDS if bounds is None else bounds
        from viscore.metrics import check_culling_memory

        parse_bounds(bounds, "--bounds")
        check_culling_memory(width, height)
    from pathlib import Path

    from viscore import InputError
    from viscore.level import culling_scene_names

    for name in levels:  # every level named, before the first one's work
        if str(name) not in culling_scene_names() and not Path(name).is_file():
            raise InputError(f"{name}: no such file (nor a built-in culling scene: "
                             f"{', '.join(culling_scene_names())})")
    rows = []
    for name in levels:
        start = time.perf_counter()
        level = level_objects(name, up=up)
        objects = level.objects
        eye = guess_eye_height(objects, metres=level.kind.startswith("gltf"),
                               eye_height=eye_height)
        walk = camera_walk(objects, frames=frames, seed=seed, eye=eye)
        row = {"level": str(name), "objects": len(objects), "objects_rule": level.split_rule,
               "occluder_objects": len(level.chosen), **walk.to_json(),
               "up": level.up, "up_reason": level.up_reason}
        if cull:
            row["cull"] = _cull_figures(level, walk, seed=seed, bounds=bounds, methods=methods,
                                        width=width, height=height, gap=gap,
                                        reduction=buffer_scale)
        row["seconds"] = time.perf_counter() - start
        rows.append(row)
        if progress is not None:
            progress(row)
    return {"levels": rows, "settings": {"frames": frames, "seed": seed, "up": up,
                                         "eye_height": eye_height, "cull": bool(cull),
                                         "bounds": bounds if cull else None,
                                         "gap": bool(cull and gap),
                                         "buffer_scale": buffer_scale if cull else None,
                                         "width": width, "height": height,
                                         "confidence": CONFIDENCE}}


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.1f}%"


def walk_row_text(row: dict) -> str:
    """One level's line (two with ``cull``) of ``bench walks``."""
    head = (f"{row['level']}: {row['objects']:,} objects ({row['objects_rule']}), up "
            f"{row['up']}, eye {row['eye_height']:.4g} ({row['eye_height_reason']}); "
            f"{row['standing']}/{row['frames_asked']} frames standing"
            f" ({row['frames']} kept, {row['moved']} moved, {row['dropped']} dropped; on "
            f"{row['on']}, faces {row['faces']})")
    if "cull" not in row:
        return head
    c = row["cull"]
    best = c.get("best_guaranteed")
    tail = (f"  hidden {_pct(c['hidden_share'])}{_ci(c['hidden_share_ci'])}; best guaranteed "
            + ("none (no guaranteed runtime made occluders)" if best is None else
               f"{best} {_pct(c['best_culled_share'])}{_ci(c['best_culled_share_ci'])}, "
               f"{c['best_false_culls']} false culls, best/hidden "
               f"{'-' if c['best_over_hidden'] is None else format(c['best_over_hidden'], '.2f')}"
               f"{'' if c['best_over_hidden'] is None else _ci_ratio(c['best_over_hidden_ci'])}")
            + f"; bounds {c['bounds']}")
    g = c.get("gap")
    if g and "causes" in g:
        tail += (f"\n  misses (hidden, not culled) {g['hidden'] - g['culled']} of "
                 f"{g['hidden']} object-frames: "
                 + ", ".join(f"{k} {v}" for k, v in g["causes"].items()))
    return head + "\n" + tail


def _ci(x: list | None) -> str:
    return "" if not x or not np.isfinite(x).all() else f" [{100 * x[0]:.0f}-{100 * x[1]:.0f}%]"


def _ci_ratio(x: list | None) -> str:
    return "" if not x or not np.isfinite(x).all() else f" [{x[0]:.2f}-{x[1]:.2f}]"


def bench_walks_text(r: dict) -> str:
    """The human-readable lines of :func:`bench_walks`."""
    s = r["settings"]
    lines = [f"walks of {s['frames']} frames (seed {s['seed']})"
             + (f", culling at {s['width']} x {s['height']}, bounds {s['bounds']}; intervals "
                f"{s['confidence']:.0%} bootstrap over frames" if s["cull"] else "")]
    lines += [walk_row_text(row) for row in r["levels"]]
    shares = [row["cull"]["best_over_hidden"] for row in r["levels"]
              if "cull" in row and (row["cull"]["hidden_share"] or 0) > 0.2
              and row["cull"].get("best_over_hidden") is not None]
    if shares:
        lines.append(f"mean best guaranteed / hidden over the {len(shares)} level(s) whose "
                     f"truth hides over 20%: {np.mean(shares):.2f}")
    return "\n".join(lines)
