"""Memory estimates of the evaluations, from their settings alone (before any work).

Examples
--------
>>> evaluation_bytes("orbit", views=8, quads=1000, resolution=64) > 0
True
>>> conservativeness_bytes(1000)
160000
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = [
    "PROCESS_BYTES", "BYTES_PER_STORED_QUAD", "BYTES_PER_STORED_VIEW", "BYTES_PER_BATCH_RAY",
    "STUDY_RAYS_PER_BATCH", "BYTES_PER_CHECK_RAY", "BYTES_PER_MEASURE_PIXEL", "BYTES_PER_FACE",
    "BYTES_PER_RESULT_VIEW", "BYTES_PER_ORBIT_PIXEL", "BYTES_PER_DEPTH_AWARE_PIXEL",
    "BYTES_PER_SCORED_QUAD", "RAYS_PER_BATCH", "BYTES_PER_BENCH_RAY",
    "evaluation_bytes", "conservativeness_bytes", "measure_bytes", "study_bytes",
    "ray_bench_bytes",
]

# ---------------------------------------------------------------- per process
#: Bytes, resident size of a worker process before any job (the imports): peak
#: RSS (``resource.getrusage``) of a worker on 2 cores was 226 MB after the
#: imports, rounded up to 256 MiB.
PROCESS_BYTES = 256 * 2**20

# ---------------------------------------------------------------- per quad
#: Bytes per quad kept by the reference views, every view (four int16 corners,
#: int32 pixel and original counts, int16 depth level): the library's own
#: figure; the pickled views of the bunny at 128 views x 16,000 quads are
#: 35 MiB = 128 x 16,000 x 18 B.
BYTES_PER_STORED_QUAD = 8 + 4 + 4 + 2
#: Bytes, peak per quad of the one view being scored (draws, lookups, masks):
#: ``evaluate --quads 1000`` vs ``--quads 1000000``, ~75 B, rounded up.
BYTES_PER_SCORED_QUAD = 128

# ---------------------------------------------------------------- per view
#: Bytes per view of the reference views besides its quads (direction, box,
#: per-view counts).
BYTES_PER_STORED_VIEW = 200
#: Bytes per view kept for a result (per-view lists, directions and their JSON
#: text): ~0.5 KB, rounded up.
BYTES_PER_RESULT_VIEW = 1024

# ---------------------------------------------------------------- per pixel
#: Bytes, peak per pixel of one occlusion-measure image (rays, hits, coverage,
#: distance transform): ``measure --directions 2 --res 256`` vs ``--res 1024``,
#: ~83 B, rounded up.
BYTES_PER_MEASURE_PIXEL = 128
#: Bytes, peak per pixel and view of an orbit batch (two depth images of up to
#: 8 views cast together): ``evaluate --views 8 --res 256`` vs ``--res 1024``,
#: ~122 B, rounded up.
BYTES_PER_ORBIT_PIXEL = 160
#: Extra bytes per pixel with ``depth_aware`` (32 levels of int32 tables and a
#: bool mask per level).
BYTES_PER_DEPTH_AWARE_PIXEL = 32 * 5

# ---------------------------------------------------------------- per ray
#: Rays per Embree batch as the commands count it: images of R x R pixels are
#: cast ``max(1, 2**18 // R**2)`` at a time, and validate's rays 2**18 at a
#: time, so memory does not grow with views or rays beyond one batch.
RAYS_PER_BATCH = 1 << 18
#: Rays per ray-casting batch of a study's job (eight 256 x 256 images, the
#: reference views' batch).
STUDY_RAYS_PER_BATCH = 8 * 256 * 256
#: Bytes per ray of one ray-casting batch of a study's job (float64 origins and
#: directions, their float32 copies, distances, triangle ids).
BYTES_PER_BATCH_RAY = 88
#: Bytes, peak per conservativeness ray (``validate --rays 100000`` vs
#: ``--rays 2000000``, ~106 B, rounded up).
BYTES_PER_CHECK_RAY = 160
#: Bytes, peak per ray of ``bench rays`` (three float64 (n, 3) arrays, their
#: float32 copies and the hit results).
BYTES_PER_BENCH_RAY = 128

# ---------------------------------------------------------------- per face
#: Bytes per triangle of a mesh in a worker (trimesh caches, the Embree BVH, the
#: generators' copies): the bunny's 56k faces add about 56 MB.
BYTES_PER_FACE = 1024


def measure_bytes(directions: int, resolution: int) -> int:
    """Peak bytes of an occlusion measure: one image, and a result entry per direction.

    Examples
    --------
    >>> measure_bytes(1, 2)
    1536
    """
    return resolution * resolution * BYTES_PER_MEASURE_PIXEL + directions * BYTES_PER_RESULT_VIEW


def evaluation_bytes(protocol: str, *, views: int | None = None, quads: int, resolution: int,
                     depth_aware: bool = False) -> int:
    """Peak bytes of an evaluation besides what the library checks itself.

    Orbit: one batch of depth images (``min(views, max(1, 2**18 // R**2))``
    views of R x R pixels), one view's quads and a result entry per view.
    Volume: one frustum cube's six images and one frustum's quads (the
    positions are counted by the library).

    Examples
    --------
    >>> evaluation_bytes("volume", quads=10, resolution=1)
    2240
    """
    per_pixel = BYTES_PER_ORBIT_PIXEL + (BYTES_PER_DEPTH_AWARE_PIXEL if depth_aware else 0)
    if protocol == "orbit":
        batch = min(views, max(1, RAYS_PER_BATCH // (resolution * resolution)))  # type: ignore[type-var]
        return (batch * resolution * resolution * per_pixel  # type: ignore[operator]
                + quads * BYTES_PER_SCORED_QUAD + views * BYTES_PER_RESULT_VIEW)  # type: ignore[operator]
    return 6 * resolution * resolution * per_pixel + quads * BYTES_PER_SCORED_QUAD


def conservativeness_bytes(rays: int) -> int:
    """Peak bytes of a conservativeness check of ``rays`` rays (one batch at most)."""
    return min(rays, RAYS_PER_BATCH) * BYTES_PER_CHECK_RAY


def ray_bench_bytes(rays: int) -> float:
    """Peak bytes of ``bench rays`` with ``rays`` rays per call."""
    return float(rays) * BYTES_PER_BENCH_RAY


def study_bytes(protocol: str, *, views: int, quads: int, resolution: int, rays: int,
                meshes: Mapping, jobs: int) -> float:
    """Estimated peak bytes of a local study, from its settings and meshes alone.

    Each of ``jobs`` workers holds a process (:data:`PROCESS_BYTES`), the
    reference views of its mesh (stored quads and per-view data), one
    ray-casting batch, the conservativeness rays, a measure image and the
    mesh; one copy of every mesh's views is counted once more (the views
    handed to the workers). The volume protocol's positions are estimated per
    mesh (:func:`viscore.metrics.volume.volume_positions_bytes`); its views are
    cached only where they fit, so they are not counted.

    Parameters
    ----------
    protocol : {'orbit', 'volume'}
    views, quads, resolution, rays : int
        The study's settings.
    meshes : mapping of str -> trimesh.Trimesh
        The study's meshes, loaded.
    jobs : int
        Local worker processes.

    Returns
    -------
    float
        Bytes (a float: it may exceed int64 for absurd settings).
    """
    res2 = float(resolution) ** 2
    batch = max(1.0, STUDY_RAYS_PER_BATCH // res2) * res2 * BYTES_PER_BATCH_RAY
    fixed = (PROCESS_BYTES + batch + float(rays) * BYTES_PER_CHECK_RAY
             + res2 * BYTES_PER_MEASURE_PIXEL)
    views_bytes = {}
    for name, mesh in meshes.items():
        if protocol == "orbit":
            views_bytes[name] = float(views) * (quads * BYTES_PER_STORED_QUAD
                                                + BYTES_PER_STORED_VIEW)
        else:
            from .volume import volume_positions_bytes

            views_bytes[name] = volume_positions_bytes(mesh)
    worst = max(views_bytes[n] + len(m.faces) * BYTES_PER_FACE for n, m in meshes.items())
    return jobs * (fixed + worst) + sum(views_bytes.values())
