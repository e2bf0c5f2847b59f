"""Convergence ablation: spread of precision and recall over seeded repeats.

The ablation of Wu et al. 2022 [1]_, sec. 4.1 and Fig. 10: the standard deviation
of P and R over repeats against quads per view, views and view spacing.

References
----------
.. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import trimesh

from viscore._validate import as_fraction, as_positive_int, check_memory

from .orbit import orbit_precision_recall
from .reference_views import _BYTES_PER_QUAD, _BYTES_PER_RAY, ReferenceViews, _batch_images
from .volume import volume_precision_recall

__all__ = ["AblationResult", "convergence_ablation"]

_log = logging.getLogger(__name__)

#: Quads per view of Wu et al. 2022, sec. 4.1.
QUADS_LIST = (100, 1000, 5000, 10000, 20000, 30000, 100000)
#: View spacings of Wu et al. 2022, sec. 4.1, as fractions of the diagonal. The finer
#: ones cost 8x per halving; the default run stops at 4%.
SPACING_LIST = (0.16, 0.08, 0.04)
#: Orbit view counts.
VIEWS_LIST = (16, 32, 64, 128, 256)

#: Bytes kept per repeat and view (the per-view arrays of a result), and per repeat.
_BYTES_PER_REPEAT_VIEW, _BYTES_PER_REPEAT = 64, 4096


@dataclass(frozen=True)
class AblationResult:
    """Rows of the ablation table.

    Attributes
    ----------
    rows : list of dict
        ``factor`` ('quads', 'spacing' or 'views'), ``value``, ``protocol``,
        ``precision_mean``, ``precision_sd``, ``recall_mean``, ``recall_sd``
        (sample s.d. over repeats), ``repeats``, ``seconds``.
    seed : int
    params : dict
    """

    rows: list
    seed: int
    params: dict


def _summary(factor, value, protocol, ps, rs, seconds) -> dict:
    ps, rs = np.asarray(ps, float), np.asarray(rs, float)
    return {"factor": factor, "value": value, "protocol": protocol,
            "precision_mean": float(np.nanmean(ps)), "precision_sd": float(np.nanstd(ps, ddof=1)),
            "recall_mean": float(np.nanmean(rs)), "recall_sd": float(np.nanstd(rs, ddof=1)),
            "repeats": len(ps), "seconds": seconds}


def convergence_ablation(mesh: trimesh.Trimesh, occluder: trimesh.Trimesh, *,
                         factors: tuple[str, ...] = ("quads", "views", "spacing"),
                         quads_list: tuple[int, ...] = QUADS_LIST,
                         views_list: tuple[int, ...] = VIEWS_LIST,
                         spacing_list: tuple[float, ...] = SPACING_LIST, repeats: int = 10,
                         views: int = 64, quads: int = 5000, resolution: int = 128,
                         volume_resolution: int = 32, volume_quads: int = 1000,
                         seed: int = 0, progress=None) -> AblationResult:
    """Standard deviation of P and R over seeded repeats for each setting.

    Parameters
    ----------
    mesh, occluder : trimesh.Trimesh
    factors : tuple of {'quads', 'views', 'spacing'}, optional
        Which ablations to run (default all three).
    quads_list, views_list, spacing_list : tuples, optional
        Settings; spacings as fractions of the bounding-box diagonal.
    repeats : int, optional
        Seeded repeats per setting (Wu et al. 2022 use 10). Default 10.
    views, quads, resolution : int, optional
        Orbit settings held fixed while another factor varies (defaults 64
        views, 5,000 quads, 128 px).
    volume_resolution, volume_quads : int, optional
        Volume settings of the spacing ablation (defaults 32 px and 1,000
        quads per frustum: each halving of the spacing costs 8x).
    seed : int, optional
    progress : callable, optional
        Called with a short text after each setting.

    Returns
    -------
    AblationResult

    Raises
    ------
    InputError
        On a setting out of range, or settings whose memory (the largest
        quads setting's batch, the results kept over the repeats) exceeds the
        limit of :func:`viscore._validate.check_memory`; checked before any work.
    """
    repeats = as_positive_int(repeats, "repeats")
    if repeats < 2:
        from viscore import InputError

        raise InputError("repeats: at least 2 to estimate a standard deviation")
    views, quads = as_positive_int(views, "views"), as_positive_int(quads, "quads")
    resolution = as_positive_int(resolution, "resolution")
    quads_list = tuple(as_positive_int(q, "quads_list") for q in quads_list)
    views_list = tuple(as_positive_int(v, "views_list") for v in views_list)
    spacing_list = tuple(as_fraction(f, "spacing_list", open_low=True) for f in spacing_list)
    if "quads" in factors and quads_list:  # the largest setting's batch of images and quads
        check_memory(_batch_images(resolution) * (resolution**2 * _BYTES_PER_RAY
                                                  + max(quads_list) * float(_BYTES_PER_QUAD)),
                     f"quads_list up to {max(quads_list)}, resolution={resolution}")
    most_views = max((views, *views_list))
    check_memory(float(repeats) * (most_views * _BYTES_PER_REPEAT_VIEW + _BYTES_PER_REPEAT),
                 f"repeats={repeats} of up to {most_views} views")
    rows = []
    say = progress or (lambda text: _log.info("%s", text))
    if "quads" in factors:
        # the views' images are fixed (the original's kept, the occluder's cast once);
        # only the quads are drawn again, per repeat and view, through the one tally loop
        fixed = ReferenceViews(mesh, views=views, quads=quads, resolution=resolution, seed=seed,
                               cache=False)
        occluder_depths = fixed.depth_images(occluder)
        for q in quads_list:
            start = time.perf_counter()
            res = [fixed._score_images(  # noqa: SLF001 (sibling module)
                occluder_depths, quads=q,
                rng_of=lambda k, r=r, q=q: np.random.default_rng([seed, r, q, k]))
                for r in range(repeats)]
            rows.append(_summary("quads", q, "orbit", [x.precision for x in res],
                                 [x.recall for x in res], time.perf_counter() - start))
            say(f"quads {q}: sd P {rows[-1]['precision_sd']:.2e}, R {rows[-1]['recall_sd']:.2e}")
    if "views" in factors:
        for v in views_list:
            start = time.perf_counter()
            res = [orbit_precision_recall(mesh, occluder, views=v, quads=quads,
                                          resolution=resolution, seed=seed * 7919 + 101 * r + 1)
                   for r in range(repeats)]
            rows.append(_summary("views", v, "orbit", [x.precision for x in res],
                                 [x.recall for x in res], time.perf_counter() - start))
            say(f"views {v}: sd P {rows[-1]['precision_sd']:.2e}, R {rows[-1]['recall_sd']:.2e}")
    if "spacing" in factors:
        diag = float(np.linalg.norm(mesh.extents))
        for f in spacing_list:
            start = time.perf_counter()
            res = [volume_precision_recall(mesh, occluder, spacing=f * diag, quads=volume_quads,
                                           resolution=volume_resolution,
                                           seed=seed * 7919 + 101 * r + 2, jitter=True)
                   for r in range(repeats)]
            rows.append(_summary("spacing", f, "volume", [x.precision for x in res],
                                 [x.recall for x in res], time.perf_counter() - start))
            say(f"spacing {100 * f:g}%: sd P {rows[-1]['precision_sd']:.2e}, "
                f"R {rows[-1]['recall_sd']:.2e}")
    return AblationResult(rows=rows, seed=seed, params={
        "repeats": repeats, "views": views, "quads": quads, "resolution": resolution,
        "volume_resolution": volume_resolution, "volume_quads": volume_quads,
        "factors": list(factors)})
