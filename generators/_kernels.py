"""The numba kernels of a study's jobs, compiled once before its worker processes start.

Left to themselves, the workers of ``viscore compare`` (and its culling
column's process) each compile the same kernels on a fresh install, where
numba's cache is empty. :func:`prepare_kernels` compiles them in the parent
(or loads them from the cache), half of them in a forked helper meanwhile, so
that the processes forked afterwards start with them.
"""

from __future__ import annotations

__all__ = ["prepare_kernels"]


def _ray_kernels() -> None:
    """Compile (or load from numba's cache) the ray core's kernels, without a scene.

    The kernels :class:`viscore.Scene` compiles on its first query and its
    packet scene on its first build (:mod:`viscore.ray.embree_scene`,
    :mod:`viscore.ray._embree4`), for the signatures they are pinned to. No
    Embree device or thread is made: a process may fork safely afterwards.
    """
    from viscore._jit import compile_kernels
    from viscore.ray import _embree4, embree_scene

    embree_scene._ready_kernels()
    _embree4._ready_kernels()
    compile_kernels({_embree4._mark_stacked: [
        "(float32[:, ::1], uint32[:, ::1], float64[:, ::1], float64[::1], int64[:, ::1], "
        "float64[:, ::1], int64[::1], int64[::1], float64[::1], float64, boolean[::1])"]})


def _measure_kernels() -> dict:
    """Polygon chains, the soup measure, box growth: kernel -> signatures (as the callers
    type their arrays: C-contiguous, writeable)."""
    from ._polygon_chain.optimal import _best_subsets
    from ._polygon_chain.simplify import _ear_chain
    from ._soup_measure import _fill_polygons, _images_measures, _soup_totals
    from .aabb_skins._growth import grow_boxes

    return {
        grow_boxes: ["(boolean[:, :, ::1], int64, int64, int64)"],
        _ear_chain: ["(float64[::1], float64[::1], boolean)"],
        _best_subsets: ["(float64[::1], float64[::1], boolean[:, ::1], int64)"],
        _fill_polygons: ["(float64[::1], float64[::1], int64[::1], boolean[:, :, :, ::1], "
                         "int64)"],
        _images_measures: ["(boolean[:, :, ::1], float64[::1])"],
        _soup_totals: ["(int64[::1], boolean[:, :, ::1], boolean[:, :, :, ::1], float64[::1], "
                       "boolean, float64[::1])"],
    }


def _selection_kernels() -> dict:
    """Planar sections' slices and hybrid's face tallies: kernel -> signatures."""
    from .hybrid._face_tallies import _all_pairs, _any_ray_near, _full_quads, _remove_face
    from .planar_sections._slices import _slice_counts, _slice_pixels

    b, i32, i64, f64 = "boolean[::1]", "int32[::1]", "int64[::1]", "float64[::1]"
    return {
        _slice_counts: [f"(boolean[:, :, ::1], {f64}, float64, {f64}, {f64}, {f64}, {f64}, "
                        "int64, int64, float64, float64, int64)"],
        _slice_pixels: [f"(boolean[:, :, ::1], {f64}, float64, {f64}, {f64}, {f64}, {f64}, "
                        "int64, int64, float64)"],
        _full_quads: [f"(int32[:, ::1], {i64}, {i64}, {i64}, {i32}, {i64}, {i64}, {i32})"],
        _any_ray_near: ["(float64[:, ::1], float64[::1], float64[:, ::1], float64[:, :, ::1], "
                        "float64[:, ::1], float64[:, ::1], float64[:, ::1], float64)"],
        _all_pairs: [f"(int32[:, ::1], {i64}, {b}, {i64}, {i32}, {i64}, {i64}, {i32}, {i64}, "
                     f"{i32}, {b}, {i32}, {i32}, {b}, boolean, int64, {i32})"],
        _remove_face: [f"(int64, {i64}, {b}, {i32}, {i32}, int32[:, ::1], {i64}, {i64}, {i64}, "
                       f"{i64}, {b}, {i64}, {i32}, {i64}, {i64}, {i32}, {i64}, {i32}, {b}, "
                       f"{i32}, {i32}, {b}, boolean, {f64}, {f64}, {f64}, {f64}, {i64}, {i64}, "
                       f"{i64}, {i32}, {i32}, {i64}, {i64}, int64)"],
    }


def _metric_kernels() -> dict:
    """The quad tally every occluder score runs (:func:`viscore.metrics.quads.occluder_counts`:
    the cached quads are int16): kernel -> signatures."""
    from viscore.metrics.quads import _coverage_tally

    return {_coverage_tally: ["(boolean[:, ::1], int16[:, ::1], int32[::1], int32[::1], "
                              "int64[::1])"]}


def prepare_kernels() -> None:
    """Compile (or load from numba's cache) the kernels every study job and the culling
    column use: the ray core's, box growth, the soup measure, polygon chains, planar
    sections' slices, hybrid's face tallies and the quad tally of every score.

    Called before forking workers: they start with the kernels compiled. Half
    is compiled in a forked helper (:func:`viscore._jobs.compile_ahead`) while
    this process compiles the other half, then loaded here from the cache. On a
    warm cache, a few seconds of loading, once instead of in every worker. The
    kernels keep compiling other versions for other argument types, as before.
    Nothing is run: results are those of kernels compiled in the workers.
    """
    from viscore._jit import compile_kernels
    from viscore._jobs import compile_ahead

    compile_ahead([_ray_kernels, lambda: compile_kernels(_selection_kernels())],
                  [lambda: compile_kernels(_measure_kernels()),
                   lambda: compile_kernels(_metric_kernels())])
