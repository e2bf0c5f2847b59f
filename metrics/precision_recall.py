"""Result type of the quad precision/recall protocols (orbit and volume).

Precision P = Nt / (Nt + Nf) and recall R = Nt / (Nt + Pf), Silvennoinen et
al. 2014, sec. 6.1 [1]_; per position and averaged over the domain in
Wu et al. 2022, sec. 3.2, eqs. 4-7 [2]_.

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

import math
import os
import typing
from dataclasses import dataclass, field, fields

import numpy as np

__all__ = ["PrecisionRecall"]

# Shared with the sibling modules (not user API): ratio, pooled_parts, pooled_ratio,
# record_to_json, record_from_json, PER_VIEW_ARRAYS.


def ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """Elementwise num / den with NaN where den == 0."""
    num = np.asarray(num, dtype=np.float64)
    den = np.asarray(den, dtype=np.float64)
    out = np.full(np.broadcast(num, den).shape, np.nan)
    np.divide(num, den, out=out, where=den > 0)
    return out


def pooled_parts(per_view: dict, protocol: str, which: str) -> tuple[np.ndarray, np.ndarray]:
    """Per-view (numerator, denominator) of pooled ``which`` ('precision' or 'recall')."""
    if protocol == "orbit":
        nt = np.asarray(per_view["nt"], dtype=np.float64)
        other = np.asarray(per_view["nf" if which == "precision" else "pf"], dtype=np.float64)
        return nt, nt + other
    value = np.asarray(per_view[which], dtype=np.float64)
    weight = np.asarray(per_view["weight"], dtype=np.float64)
    ok = np.isfinite(value)
    return np.where(ok, value, 0.0) * weight, np.where(ok, weight, 0.0)


#: Field metadata marking a dict of per-view arrays (lists in JSON, one entry per view).
PER_VIEW_ARRAYS = {"per_view_arrays": True}


def jsonable(value):
    """Plain JSON values: arrays and tuples to lists, numpy scalars to Python, NaN/inf to
    None, paths to strings (the one converter of results and command-line documents)."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [jsonable(v) for v in value]
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        value = float(value)
        return value if math.isfinite(value) else None
    return value


def _array(values: list) -> np.ndarray:
    """A per-view list back to an array: None (NaN in JSON) to NaN."""
    arr = np.asarray(values, dtype=object)
    if arr.size and any(v is None for v in arr.flat):
        return np.asarray(np.where(arr == None, np.nan, arr), dtype=np.float64)  # noqa: E711
    return np.asarray(values)


def record_to_json(record) -> dict:
    """JSON document of a result dataclass: every field under its own name."""
    return {f.name: jsonable(getattr(record, f.name)) for f in fields(record)}


def record_from_json(cls, document: dict):
    """The result dataclass ``cls`` from :func:`record_to_json`'s document.

    Generic over the fields: ``float`` fields take None as NaN, lists of
    floats likewise, fields marked ``PER_VIEW_ARRAYS`` become dicts of
    arrays; keys that are not fields are ignored; a missing field without a
    default raises KeyError.
    """
    hints = typing.get_type_hints(cls)
    values = {}
    for f in fields(cls):
        if f.name not in document:
            continue  # its default applies (or the constructor says it is missing)
        v = document[f.name]
        hint = hints.get(f.name)
        if f.metadata.get("per_view_arrays"):
            v = {k: _array(x) for k, x in v.items()}
        elif hint is float:
            v = math.nan if v is None else float(v)
        elif hint is list and isinstance(v, list):
            v = [math.nan if x is None else x for x in v]
        values[f.name] = v
    return cls(**values)


def pooled_ratio(per_view: dict, protocol: str, which: str) -> float:
    """The pooled ``which`` ('precision' or 'recall'): sum of numerators / sum of denominators.

    The one ratio of every protocol: orbit sum Nt / (sum Nt + sum Nf) (or
    + sum Pf), volume the weighted mean of the per-position values where
    defined; NaN when undefined.
    """
    num, den = pooled_parts(per_view, protocol, which)
    return float(ratio(num.sum(), den.sum()))


@dataclass(frozen=True)
class PrecisionRecall:
    """Precision and recall of an occluder against its original, with per-view counts.

    Attributes
    ----------
    precision, recall : float
        Orbit: pooled over views. Volume: volume-weighted mean of the
        per-position values where defined (Wu et al. 2022, eqs. 5 and 7). NaN when
        undefined.
    precision_ci, recall_ci : list of 2 float
        95% percentile bootstrap intervals over views (positions).
    per_view : dict of lists
        ``nt``, ``pf``, ``nf`` (pixel counts), ``precision``, ``recall``
        (NaN where undefined), ``weight`` (block volume in voxels of the
        finest grid; 1 for orbit views), ``direction`` (orbit) or
        ``position`` (volume), and the quad tallies ``quads_orig``,
        ``quads_occ``, ``quads_both`` (see :class:`metrics.QuadCounts`),
        one entry per view.
    protocol : {'orbit', 'volume'}
    depth_aware : bool
    seed : int
    params : dict
        Resolution, views, quads and the protocol's other settings.
    seconds : float
        Wall time of the evaluation.
    timing : dict
        ``seconds_rays`` and ``seconds_quads``, and ``rays`` cast.
    """

    precision: float
    recall: float
    precision_ci: list
    recall_ci: list
    per_view: dict = field(metadata=PER_VIEW_ARRAYS)
    protocol: str = "orbit"
    depth_aware: bool = False
    seed: int = 0
    params: dict = field(default_factory=dict)
    seconds: float = math.nan
    timing: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """JSON document: every field under its name, arrays as lists, NaN as None."""
        return record_to_json(self)

    @classmethod
    def from_json(cls, document: dict) -> PrecisionRecall:
        """The result of :meth:`to_json` (or any document with these keys; others ignored)."""
        return record_from_json(cls, document)

    @property
    def views(self) -> int:
        """Number of views (positions) evaluated."""
        return len(self.per_view["nt"])

    def ratio_parts(self, which: str) -> tuple[np.ndarray, np.ndarray]:
        """Per-view numerator and denominator whose sums' ratio is the pooled figure.

        Orbit: Nt and Nt + Nf (precision) or Nt + Pf (recall). Volume: w x P_x
        and w where P_x is defined, 0 elsewhere (the weighted mean of eq. 7).
        Resampling views and summing both gives the bootstrap replicates.
        """
        return pooled_parts(self.per_view, self.protocol, which)
