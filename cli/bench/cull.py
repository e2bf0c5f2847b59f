"""``viscore bench cull``: per-frame overhead of the culling runtimes.

Papaioannou et al. 2006 [1]_ (Tables 1-2) and the occluder skins [2]_ (sec. 7)
are the references; figures, never assertions.

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006 (Plzen), UNION Agency,
   ISBN 80-86943-03-8 (Tables 1-2).
.. [2] "Occluder Skins" (occluder generation from axis-aligned boxes for a
   hierarchical-occlusion-map culler; authors and venue not in the text we
   have), sec. 5-7.
"""

from __future__ import annotations

import time

import numpy as np

from viscore._validate import as_positive_int, as_seed

#: Targets of issue 13, milliseconds per frame on one core.
FRUSTA_TARGET_MS = 2.0
DEPTH_BUFFER_TARGET_MS = 5.0

#: Occludee boxes tested per frame, and active occluders of the frusta runtime.
OCCLUDEES = 1000
ACTIVE = 15


def _occludees(objects, count: int) -> np.ndarray:
    """``count`` object indices: the small objects (cars, lamps, benches, trees) first."""
    size = np.linalg.norm(objects.upper - objects.lower, axis=1)
    order = np.argsort(size, kind="stable")
    return np.sort(order[:min(count, len(order))])


def _stats(ms: list[float]) -> dict:
    arr = np.asarray(ms)
    return {"median_ms": float(np.median(arr)), "mean_ms": float(arr.mean()),
            "p95_ms": float(np.percentile(arr, 95)), "max_ms": float(arr.max())}


def bench_cull(*, scene: str = "city", frames: int = 60, repeats: int = 3, seed: int = 0,
               method: str | None = None) -> dict:
    """Per-frame overhead of the frusta and depth-buffer runtimes, one core.

    Parameters
    ----------
    scene : str, optional
        Culling scene (default the built-in ``city``).
    frames : int, optional
        Cameras of its generated path (default 60).
    repeats : int, optional
        Each frame is timed this many times; the best counts (default 3).
    seed : int, optional
        Seed of the path and the generators.
    method : str, optional
        Generator of the occluders (solids for the frusta, pieces for the
        buffer); default ``solid-frusta`` when registered, else ``aabb-skins``.

    Returns
    -------
    dict
        ``frusta`` and ``depth_buffer``: median, mean, p95 and max ms per
        frame, the target and whether the median meets it; the settings
        (occludees, active, buffer size, occluder counts, workers = 1) and
        the machine's load average (timings on a busy machine are inflated).
    """
    from viscore import get_workers, set_workers
    from viscore.culling import ConservativeDepthBuffer, FrustumCuller, OccluderScene
    from viscore.generators import frusta_method, occluder_objects, scene_occluders
    from viscore.level import load_scene_objects
    from viscore.metrics import camera_path

    frames = as_positive_int(frames, "frames")
    repeats = as_positive_int(repeats, "repeats", maximum=100)
    seed = as_seed(seed)
    objects = load_scene_objects(scene)
    indices = occluder_objects(objects)
    method = frusta_method() if method is None else method
    occluders = list(scene_occluders(objects, indices, method, seed=seed).values())
    boxes = _occludees(objects, OCCLUDEES)
    lower, upper = objects.lower[boxes], objects.upper[boxes]
    path = camera_path(objects, frames=frames, seed=seed)
    before = get_workers()
    set_workers(1)
    try:
        culler = FrustumCuller.from_occluders(occluders, mode="solid", active=ACTIVE,
                                              cap="front-faces", rank="faces")
        prepared = OccluderScene(occluders, workers=1)
        frusta_ms, buffer_ms, culled_f, culled_b = [], [], 0, 0
        for pose in path:
            camera = pose.camera(1280, 720)
            best_f = best_b = np.inf
            for _ in range(repeats):
                t0 = time.perf_counter()
                mask_f = culler.cull(camera, lower, upper)
                t1 = time.perf_counter()
                buf = ConservativeDepthBuffer.from_occluders(prepared, camera, width=320,
                                                             height=180)
                mask_b = buf.occluded(lower, upper)
                t2 = time.perf_counter()
                best_f, best_b = min(best_f, t1 - t0), min(best_b, t2 - t1)
            frusta_ms.append(1e3 * best_f)
            buffer_ms.append(1e3 * best_b)
            culled_f += int(mask_f.sum())
            culled_b += int(mask_b.sum())
    finally:
        set_workers(before)
    f, b = _stats(frusta_ms), _stats(buffer_ms)
    import os

    return {
        "scene": scene, "frames": len(path), "occludees": len(boxes), "workers": 1,
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "occluder_method": method, "occluder_objects": len(indices),
        "frusta": {**f, "active": ACTIVE, "solids": culler.count,
                   "target_ms": FRUSTA_TARGET_MS, "meets_target": f["median_ms"] < FRUSTA_TARGET_MS,
                   "culled_per_frame": culled_f / max(1, len(path))},
        "depth_buffer": {**b, "buffer": [320, 180], "pieces": prepared.pieces,
                         "target_ms": DEPTH_BUFFER_TARGET_MS,
                         "meets_target": b["median_ms"] < DEPTH_BUFFER_TARGET_MS,
                         "culled_per_frame": culled_b / max(1, len(path))},
    }


def bench_cull_text(r: dict) -> str:
    """The human-readable lines of a :func:`bench_cull` result."""
    f, b = r["frusta"], r["depth_buffer"]
    return "\n".join([
        f"{r['scene']}: {r['frames']} frames, {r['occludees']} occludee boxes per frame, "
        f"occluders from {r['occluder_method']} on {r['occluder_objects']} objects, 1 core"
        + (f" (load average {r['load_average'][0]:.1f})" if r.get("load_average") else ""),
        f"  solid frusta, {f['active']} active of {f['solids']} solids: median "
        f"{f['median_ms']:.2f} ms, p95 {f['p95_ms']:.2f} ms per frame "
        f"(target < {f['target_ms']:.0f} ms: {'met' if f['meets_target'] else 'NOT met'}); "
        f"{f['culled_per_frame']:.0f} culled per frame",
        f"  depth buffer {b['buffer'][0]} x {b['buffer'][1]}, {b['pieces']} convex pieces: "
        f"median {b['median_ms']:.2f} ms, p95 {b['p95_ms']:.2f} ms per frame "
        f"(target < {b['target_ms']:.0f} ms: {'met' if b['meets_target'] else 'NOT met'}); "
        f"{b['culled_per_frame']:.0f} culled per frame"])
