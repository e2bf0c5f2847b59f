"""The study's tables: Markdown and CSV of the rows, and the paired comparisons.

References
----------
.. [1] Efron, B. "Better Bootstrap Confidence Intervals". Journal of the
   American Statistical Association 82(397), 1987.
   :DOI:`10.1080/01621459.1987.10478410` (the paired bootstrap of
   :func:`paired_rows`).
"""

from __future__ import annotations

from viscore import stream_seed

__all__ = ["TABLE_COLUMNS", "table_markdown", "table_csv", "paired_rows", "paired_markdown"]

#: Columns of the printed and written table, in order.
TABLE_COLUMNS = ["mesh", "method", "budget", "triangles", "precision", "precision_ci", "recall",
                 "recall_ci", "occlusion_measure", "occlusion_measure_se",
                 "violation_upper_bound", "seconds"]


def _as_result(row: dict):
    """The PrecisionRecall of a stored row (for paired comparisons)."""
    from viscore.metrics import OccluderAssessment

    return OccluderAssessment.from_json(row).precision_recall()


def paired_rows(rows: list[dict], reference: str = "qem") -> list[dict]:
    """Each method against ``reference`` on the same mesh and views (paired bootstrap).

    Budgeted methods are paired with the reference at the same budget; the
    others with the reference at its largest budget.
    """
    from viscore.metrics import paired_difference

    out = []
    refs = {(r["mesh"], r["budget"]): r for r in rows if r["method"] == reference}
    for r in rows:
        if r["method"] == reference:
            continue
        ref = refs.get((r["mesh"], r["budget"]))
        if ref is None:
            cands = [v for (m, _), v in refs.items() if m == r["mesh"]]
            ref = max(cands, key=lambda v: v["budget"] or 0, default=None)
        if ref is None or "nt" not in r["per_view"]:
            continue
        d = paired_difference(_as_result(r), _as_result(ref),
                              seed=stream_seed(r["settings"]["seed"], "paired-bootstrap"))
        out.append({"mesh": r["mesh"], "method": r["method"], "budget": r["budget"],
                    "versus": reference, "versus_budget": ref["budget"],
                    "recall_diff": d.recall_diff, "recall_diff_ci": d.recall_diff_ci,
                    "prob_better_recall": d.prob_a_better_recall,
                    "precision_diff": d.precision_diff,
                    "precision_diff_ci": d.precision_diff_ci,
                    "prob_better_precision": d.prob_a_better_precision})
    return out


def paired_markdown(rows: list[dict]) -> str:
    """Paired differences as Markdown."""
    cols = ["mesh", "method", "budget", "versus", "versus_budget", "recall_diff",
            "recall_diff_ci", "prob_better_recall", "precision_diff", "precision_diff_ci",
            "prob_better_precision"]
    head = "| " + " | ".join(cols) + " |\n|" + "---|" * len(cols) + "\n"
    return head + "".join("| " + " | ".join(_fmt(r.get(c)) for c in cols) + " |\n"
                          for r in rows)


def _fmt(value, digits=4) -> str:
    if value is None:
        return "-"
    if isinstance(value, list):
        return "[" + ", ".join(_fmt(v, digits) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:.{digits}g}" if abs(value) >= 1e4 or 0 < abs(value) < 1e-3 else (
            f"{value:.{digits}f}")
    return str(value)


def table_markdown(rows: list[dict]) -> str:
    """The study table as GitHub Markdown."""
    head = "| " + " | ".join(TABLE_COLUMNS) + " |\n|" + "---|" * len(TABLE_COLUMNS) + "\n"
    return head + "".join("| " + " | ".join(_fmt(r.get(c)) for c in TABLE_COLUMNS) + " |\n"
                          for r in rows)


def table_csv(rows: list[dict]) -> str:
    """The study table as CSV (intervals as two columns each)."""
    import csv
    import io

    cols = []
    for c in TABLE_COLUMNS:
        cols += [c + "_lo", c + "_hi"] if c.endswith("_ci") else [c]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        line = []
        for c in TABLE_COLUMNS:
            v = r.get(c)
            line += (list(v) if v else ["", ""]) if c.endswith("_ci") else [v]
        w.writerow(["" if x is None else x for x in line])
    return buf.getvalue()
