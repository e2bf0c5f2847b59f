"""``viscore bench cull-scale``: the culling simulation's time and memory against the level's size.

Issue 44's first target: a level of any size culled on one machine, the cost
at most linear in the level. :func:`bench_cull_scale` tiles the built-in
``city`` n x n in memory (:func:`tiled_city`: every object copied with offsets
of :data:`TILE_GAP` times the city's extent along the two horizontal axes, its
geometry shared, as an engine instances it) and runs ``viscore cull``'s work
on each (the objects chosen for occluders, the default runtimes, the occludee
bounds, a generated walk of a few frames against the ray-cast truth), each
size in a child process of its own, whose peak resident memory is read when
it ends. It prints per size the objects, triangles (instances counted each
time), seconds and peak memory, and their ratios to the 1 x 1 city measured in
the same run: figures, never assertions.
"""

from __future__ import annotations

import multiprocessing
import os
import resource
import sys
import time

import numpy as np

from viscore._validate import as_positive_int, as_seed

__all__ = ["tiled_city", "bench_cull_scale", "cull_scale_lines", "DEFAULT_SIZES",
           "TILE_GAP", "DEFAULT_FRAMES"]

#: Tiles along each side timed by default (``--large`` adds 4: 29,184 objects).
DEFAULT_SIZES = (1, 2)

#: Offset between tiles, times the city's extent along that axis (as the issue's tiles).
TILE_GAP = 1.02

#: Frames of the walk on each size (the issue's measure: ``cull --frames 4``).
DEFAULT_FRAMES = 4


def tiled_city(n: int):
    """The built-in culling ``city`` tiled ``n`` x ``n`` as a ``trimesh.Scene``.

    Every mesh node is copied to each tile, shifted by :data:`TILE_GAP` times
    the city's extent along x and z (its horizontal axes, glTF being +Y up),
    and named ``<node>_t<i><j>``; the geometries are the city's own, shared by
    every copy (a level's instancing kept).

    Examples
    --------
    >>> scene = tiled_city(2)
    >>> len(scene.graph.nodes_geometry) == 4 * len(tiled_city(1).graph.nodes_geometry)
    True
    """
    import trimesh

    from viscore.level import culling_scene_path

    n = as_positive_int(n, "n")
    city = trimesh.load(culling_scene_path("city"), force="scene")
    lo, hi = city.bounds
    step = TILE_GAP * (hi - lo)
    tiled = trimesh.Scene()
    for name, geometry in city.geometry.items():
        tiled.geometry[name] = geometry
    for node in city.graph.nodes_geometry:
        matrix, geometry = city.graph[node]
        for i in range(n):
            for j in range(n):
                moved = np.array(matrix, dtype=np.float64)
                moved[0, 3] += i * step[0]
                moved[2, 3] += j * step[2]
                tiled.graph.update(frame_to=f"{node}_t{i}{j}", frame_from=tiled.graph.base_frame,
                                   matrix=moved, geometry=geometry)
    return tiled


def _cull_tiles(n: int, frames: int, seed: int) -> dict:
    """``viscore cull``'s work with its defaults on :func:`tiled_city` ``(n)``: its figures."""
    from viscore.culling import DEFAULT_CLUSTERS, occludee_boxes
    from viscore.generators.levels import culling_runtimes, frusta_method, guaranteed_methods
    from viscore.level import level_objects
    from viscore.metrics import camera_path, simulate_culling

    start = time.perf_counter()
    level = level_objects(tiled_city(n))
    objects = level.objects
    path = camera_path(objects, frames=frames, seed=seed)
    runtimes, _ = culling_runtimes(objects, level.chosen, guaranteed_methods(),
                                   seed=seed, frusta_source=frusta_method(), flat=level.flat)
    bounds, _, _ = occludee_boxes(objects, "auto", DEFAULT_CLUSTERS)
    result = simulate_culling(objects, runtimes, path, bounds=bounds)
    seconds = time.perf_counter() - start
    return {"tiles": n, "objects": len(objects), "triangles": objects.total_triangles,
            "occluder_objects": len(level.chosen), "frames": len(path),
            "visible": int(result.visible.sum()), "seconds": seconds}


def _child(n: int, frames: int, seed: int, pipe) -> None:
    """In a child process: :func:`_cull_tiles`, then its own peak resident memory."""
    try:
        row = _cull_tiles(n, frames, seed)
        # ru_maxrss: kilobytes on Linux, bytes on macOS
        scale = 1 if sys.platform == "darwin" else 1024
        row["peak_bytes"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale
        pipe.send(row)
    except BaseException as exc:  # pragma: no cover - reported by the parent
        pipe.send({"error": f"{type(exc).__name__}: {exc}"})
    finally:
        pipe.close()


def bench_cull_scale(*, sizes=DEFAULT_SIZES, frames: int = DEFAULT_FRAMES,
                     seed: int = 0) -> dict:
    """Time and peak memory of the culling simulation on the city tiled n x n, per n.

    Parameters
    ----------
    sizes : sequence of int, optional
        Tiles along each side (default 1 and 2); 1 is added when missing, as
        the reference of the ratios.
    frames : int, optional
        Cameras of each walk (default 4).
    seed : int, optional
        Seed of the walks and the generators.

    Returns
    -------
    dict
        ``rows``: per size, ``tiles``, ``objects``, ``triangles``,
        ``occluder_objects``, ``frames``, ``visible`` (objects seen by the
        truth, summed over frames), ``seconds`` (wall, in the child process),
        ``peak_bytes`` (the child's peak resident memory, its interpreter and
        imports included), and ``ratios`` of objects, triangles, seconds and
        peak memory to the 1 x 1 row; ``load_average`` of the machine.

    Raises
    ------
    InputError
        A size or ``frames`` that is not a positive integer.
    RuntimeError
        A child process that failed (its error named).
    """
    sizes = sorted({1, *(as_positive_int(n, "sizes") for n in sizes)})
    frames = as_positive_int(frames, "frames", maximum=10_000)
    seed = as_seed(seed)
    context = multiprocessing.get_context("spawn")  # a fresh interpreter: its own peak
    rows = []
    for n in sizes:
        here, there = context.Pipe(duplex=False)
        child = context.Process(target=_child, args=(n, frames, seed, there))
        child.start()
        there.close()
        try:
            row = here.recv()
        except EOFError:
            row = {"error": f"the child process ended with code {child.exitcode}"}
        child.join()
        if "error" in row:
            raise RuntimeError(f"bench cull-scale, {n} x {n}: {row['error']}")
        rows.append(row)
    first = rows[0]
    for row in rows:
        row["ratios"] = {key: row[key] / first[key] if first[key] else float("nan")
                         for key in ("objects", "triangles", "seconds", "peak_bytes")}
    return {"rows": rows, "frames": frames, "seed": seed,
            "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None}


def cull_scale_lines(result: dict) -> list[str]:
    """The table of a :func:`bench_cull_scale` result, one line per size."""
    lines = [f"city tiled n x n, cull's work ({result['frames']} frames, seed "
             f"{result['seed']}), each size in a child process; ratios to 1 x 1",
             f"{'n':>3} {'objects':>9} {'triangles':>11} {'seconds':>8} {'peak GB':>8}   "
             f"{'x objects':>9} {'x tris':>7} {'x time':>7} {'x memory':>8}"]
    for row in result["rows"]:
        r = row["ratios"]
        lines.append(f"{row['tiles']:>3} {row['objects']:>9,} {row['triangles']:>11,} "
                     f"{row['seconds']:>8.1f} {row['peak_bytes'] / 2**30:>8.2f}   "
                     f"{r['objects']:>9.1f} {r['triangles']:>7.1f} {r['seconds']:>7.2f} "
                     f"{r['peak_bytes']:>8.2f}")
    if result.get("load_average"):
        lines.append("load average {:.1f} {:.1f} {:.1f}: times on a busy machine are "
                     "inflated".format(*result["load_average"]))
    return lines
