"""Per-frame cost of the culling runtimes, on one core, beside references from the same run.

Papaioannou et al. [1]_, sec. 3 and Tables 1-2, are the reference for the
frusta; figures, never assertions.

Behind ``viscore bench cull``. A procedural city of box buildings (one to
three boxes each, as convex solids) and street-level occludees (small boxes)
is walked by a camera at eye height; each frame is timed for

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006, Plzen, UNION Agency - Science
   Press, ISBN 80-86943-03-8.
.. [2] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
   Bursztyn, A. P. M. "Implementing software occlusion culling for real-time
   applications". CACIC 2012, WCGIV, 2012.
   http://sedici.unlp.edu.ar/handle/10915/23640 (the "Occluder Skins" paper)
"""

from __future__ import annotations

import os
import time

import numpy as np
import trimesh

from viscore import PerspectiveCamera
from viscore._validate import as_positive_int, as_seed
from viscore.culling import (
    ACTIVE_OCCLUDERS,
    ConservativeDepthBuffer,
    FrustumCuller,
    OccluderScene,
)
from viscore.metrics import view_frustum_mask

from .core import bare_embree

__all__ = ["bench_cull_runtimes", "bench_city", "KEYS"]

#: Street grid of the benchmark city: blocks per side, block pitch and street
#: width (world units, metres).
_BLOCKS, _PITCH, _STREET = 12, 30.0, 10.0


def bench_city(*, occludees: int = 1000, blocks: int = _BLOCKS, seed: int = 0
               ) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray, np.ndarray]:
    """A procedural city: building solids and street-level occludee boxes.

    Parameters
    ----------
    occludees : int, optional
        Occludee boxes (cars, benches, lamps: 0.5 to 4.5 m), default 1000.
    blocks : int, optional
        Blocks per side of the street grid, default 12.
    seed : int, optional
        Default 0.

    Returns
    -------
    solids : list of (vertices (8, 3) float64, faces (12, 3) int64)
        One to three stacked boxes per block, blocks x blocks, 8 to 60 m tall.
    lower, upper : (occludees, 3) float64
        Occludee boxes on the streets, world units.
    """
    occludees = as_positive_int(occludees, "occludees")
    blocks = as_positive_int(blocks, "blocks", maximum=1000)
    rng = np.random.default_rng(as_seed(seed))
    unit = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    uv, uf = np.asarray(unit.vertices), np.asarray(unit.faces)
    solids = []
    size = _PITCH - _STREET
    for i in range(blocks):  # loops over blocks (scene construction)
        for j in range(blocks):
            lo = np.array([i * _PITCH, j * _PITCH, 0.0])
            height = rng.uniform(8, 60)
            parts = rng.integers(1, 4)
            for k in range(parts):  # stacked set-backs
                inset = k * size * 0.15
                b_lo = lo + [inset, inset, height * k / parts]
                b_hi = lo + [size - inset, size - inset, height * (k + 1) / parts]
                solids.append((b_lo + uv * (b_hi - b_lo), uf.copy()))
    # occludees in the streets: along x or along y
    along_x = rng.random(occludees) < 0.5
    street = rng.integers(0, blocks, occludees) * _PITCH - 0.5 * _STREET
    run = rng.uniform(0, blocks * _PITCH, occludees)
    across = street + rng.uniform(-0.4, 0.4, occludees) * _STREET
    x = np.where(along_x, run, across)
    y = np.where(along_x, across, run)
    ext = rng.uniform(0.5, 4.5, (occludees, 3))
    lower = np.stack([x, y, np.zeros(occludees)], axis=1)
    return solids, lower, lower + ext


def _path(frames: int, rng: np.random.Generator, blocks: int = _BLOCKS
          ) -> list[PerspectiveCamera]:
    """Cameras at eye height along the streets, looking along and across them."""
    cams = []
    extent = blocks * _PITCH
    for k in range(frames):
        street = (k % blocks) * _PITCH - 0.5 * _STREET
        s = (k + 0.5) / frames * extent
        eye = np.array([s, street, 1.7]) if k % 2 == 0 else np.array([street, s, 1.7])
        heading = rng.uniform(0, 2 * np.pi)
        forward = (np.cos(heading), np.sin(heading), -0.05)
        cams.append(PerspectiveCamera(eye, forward, fov=90, resolution=1280, height=720))
    return cams


def _timed(fn) -> tuple[float, float, object]:
    """Wall and this thread's CPU milliseconds of one call, and its result."""
    wall, cpu = time.perf_counter(), time.thread_time()
    out = fn()
    return (time.perf_counter() - wall) * 1e3, (time.thread_time() - cpu) * 1e3, out


#: The timed quantities, in print order.
KEYS = ("frusta_solid", "frusta_solid_exact", "frusta_planar", "depth_buffer_build",
        "depth_buffer_test", "depth_buffer", "reference_numpy_boxes",
        "reference_embree_corner_rays")


def bench_cull_runtimes(*, frames: int = 40, occludees: int = 1000,
                        active: int = ACTIVE_OCCLUDERS, width: int = 320, height: int = 180,
                        blocks: int = _BLOCKS, seed: int = 0) -> dict:
    """Per-frame milliseconds of the frusta and depth-buffer runtimes on one core.

    Parameters
    ----------
    frames : int, optional
        Camera positions along the streets, default 40.
    occludees : int, optional
        Occludee boxes tested per frame, default 1000.
    active : int, optional
        Active occluders of the frusta runtime, default 15.
    width, height : int, optional
        Depth-buffer pixels, default 320 x 180 (a quarter of 1280 x 720 per side).
    blocks : int, optional
        Blocks per side of the city (:func:`bench_city`), default 12.
    seed : int, optional
        Seed of the city and the path, default 0.

    Returns
    -------
    result : dict
        For each of :data:`KEYS` a dict with ``median_ms`` and ``best_ms``
        (wall clock over the frames) and ``median_cpu_ms`` (this thread's CPU
        time: less sensitive to other processes on a shared machine):

        - ``frusta_solid``: :class:`~viscore.culling.FrustumCuller`, 'solid'
          mode with the paper's eq. 2 cap and eq. 4 ranking;
        - ``frusta_solid_exact``: 'solid' with ``cap='front-faces'``,
          ``rank='faces'`` (culls a superset of 'planar' every frame);
        - ``frusta_planar``: every face its own frustum;
        - ``depth_buffer_build``, ``depth_buffer_test``, ``depth_buffer``
          (their sum): :class:`~viscore.culling.depth_buffer.ConservativeDepthBuffer`;
        - ``reference_numpy_boxes``: projecting the occludees' 8 corners;
        - ``reference_embree_corner_rays``: a bare ``EmbreeScene.run`` on the
          buffer's (W+1)(H+1) corner rays.

        Also ``culled_share`` (mean share of the occludees culled, per
        runtime), ``culled_share_in_view`` (the same among the occludees that
        meet the view frustum: the depth buffer never culls outside it,
        frusta may), ``depth_buffer_rays`` (``median`` and ``max`` rays the
        buffer casts per frame, beside its ``corners``, (W + 1)(H + 1), one ray
        per pixel corner), ``frames_solid_below_planar`` (frames on which each solid
        variant culls fewer boxes than 'planar'), the settings, ``solids``,
        ``targets_ms`` ({'frusta': 2, 'depth_buffer': 5}), ``workers`` (1) and
        ``load_average`` (the machine's 1-minute load when the run ended).

    Raises
    ------
    InputError
        On a bad setting.
    """
    frames = as_positive_int(frames, "frames", maximum=10_000)
    active = as_positive_int(active, "active")
    width = as_positive_int(width, "width", maximum=4096)
    height = as_positive_int(height, "height", maximum=4096)
    solids, lower, upper = bench_city(occludees=occludees, blocks=blocks, seed=seed)
    rng = np.random.default_rng(as_seed(seed) + 1)
    cams = _path(frames, rng, blocks)
    cullers = {"frusta_solid": FrustumCuller(solids, mode="solid", active=active),
               "frusta_solid_exact": FrustumCuller(solids, mode="solid", active=active,
                                                   cap="front-faces", rank="faces"),
               "frusta_planar": FrustumCuller(solids, mode="planar", active=active)}
    occ = OccluderScene([(v, f) for v, f in solids], workers=1)
    occ.scene.build()
    bare, offset = bare_embree(trimesh.Trimesh(occ.scene.vertices, occ.scene.faces,
                                                process=False))
    wall: dict[str, list[float]] = {k: [] for k in KEYS}
    cpu: dict[str, list[float]] = {k: [] for k in KEYS}
    culled: dict[str, list[np.ndarray]] = {k: [] for k in (*cullers, "depth_buffer")}
    corners = np.stack([np.where(np.array(m, bool), upper, lower)
                        for m in np.ndindex(2, 2, 2)], axis=1).reshape(-1, 3)

    rays: list[int] = []

    def record(key, w, c):
        wall[key].append(w)
        cpu[key].append(c)

    for cam in cams:  # a loop over frames
        for key, culler in cullers.items():
            w, c, out = _timed(lambda cam=cam, culler=culler: culler.cull(cam, lower, upper))
            record(key, w, c)
            culled[key].append(out)
        wb, cb, buf = _timed(lambda cam=cam: ConservativeDepthBuffer.from_occluders(
            occ, cam, width=width, height=height))
        wt, ct, out = _timed(lambda buf=buf: buf.occluded(lower, upper))
        record("depth_buffer_build", wb, cb)
        record("depth_buffer_test", wt, ct)
        record("depth_buffer", wb + wt, cb + ct)
        culled["depth_buffer"].append(out)
        rays.append(buf.rays)
        w, c, _ = _timed(lambda cam=cam: cam.project(corners))
        record("reference_numpy_boxes", w, c)
        o32, d32 = _corner_rays(cam, width, height, offset)
        w, c, _ = _timed(lambda o32=o32, d32=d32: bare.run(o32, d32, output=1))
        record("reference_embree_corner_rays", w, c)
    out = {k: {"median_ms": float(np.median(wall[k])), "best_ms": float(np.min(wall[k])),
               "median_cpu_ms": float(np.median(cpu[k]))} for k in KEYS}
    planar = [c.sum() for c in culled["frusta_planar"]]
    views = [view_frustum_mask(cam, lower, upper) for cam in cams]
    out.update({
        "culled_share": {k: float(np.mean([c.mean() for c in v])) for k, v in culled.items()},
        "culled_share_in_view": {
            k: float(np.sum([(c & m).sum() for c, m in zip(v, views, strict=True)])
                     / max(1, np.sum([m.sum() for m in views]))) for k, v in culled.items()},
        "frames_solid_below_planar": {
            k: int(sum(c.sum() < p for c, p in zip(culled[k], planar, strict=True)))
            for k in ("frusta_solid", "frusta_solid_exact")},
        "depth_buffer_rays": {"median": float(np.median(rays)), "max": int(np.max(rays)),
                              "corners": (width + 1) * (height + 1)},
        "frames": frames, "occludees": len(lower), "active": active,
        "buffer": [width, height], "screen": [1280, 720], "solids": len(solids),
        "blocks": blocks,
        "workers": 1, "targets_ms": {"frusta": 2.0, "depth_buffer": 5.0},
        "load_average": _load_average()})
    return out


def _load_average() -> float | None:
    try:
        return float(os.getloadavg()[0])
    except (AttributeError, OSError):  # pragma: no cover - not available
        return None


def _corner_rays(cam: PerspectiveCamera, width: int, height: int, offset: np.ndarray):
    """The buffer's corner rays, float32, origins relative to the bare scene's ``offset``."""
    f, r, u = cam.basis
    hx, hy = cam._half, cam._half_vertical
    xs = (np.arange(width + 1) / width - 0.5) * (2 * hx)
    ys = (0.5 - np.arange(height + 1) / height) * (2 * hy)
    d = (f + xs[None, :, None] * r + ys[:, None, None] * u).reshape(-1, 3)
    d /= np.linalg.norm(d, axis=1)[:, None]
    o = cam.position - offset
    return (np.ascontiguousarray(np.broadcast_to(o, d.shape), dtype=np.float32),
            np.ascontiguousarray(d, dtype=np.float32))


def main() -> None:  # pragma: no cover - manual run: python -m viscore.cli.bench.cull_runtimes
    res = bench_cull_runtimes()
    for key in KEYS:
        r = res[key]
        print(f"{key:30s} median {r['median_ms']:8.3f} ms   best {r['best_ms']:8.3f} ms   "
              f"cpu median {r['median_cpu_ms']:8.3f} ms")
    print("culled share:", {k: round(v, 3) for k, v in res["culled_share"].items()})
    print("culled share in view:", {k: round(v, 3)
                                    for k, v in res["culled_share_in_view"].items()})
    rays = res["depth_buffer_rays"]
    print(f"depth buffer rays per frame: median {rays['median']:.0f}, max {rays['max']} "
          f"(pixel corners: {rays['corners']})")
    print("frames where solid culls fewer than planar:", res["frames_solid_below_planar"])
    print("load average:", res["load_average"])


if __name__ == "__main__":  # pragma: no cover
    main()
