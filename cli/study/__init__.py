"""The study runner behind ``viscore compare``: jobs, their store, tables and report.

- :mod:`.store`: :class:`ResultStore` (the SQLite file of finished jobs),
  :class:`StudyFolder` (the folder opened and locked by one process),
  :func:`check_study_dir`.
- :mod:`.runner`: :class:`StudySettings`, :class:`Job`, :func:`run_study` (the
  local process pool, each mesh's views reaching each worker once; or dask),
  :func:`study_memory` (from :mod:`viscore.metrics.estimates`).
- :mod:`.tables`: the Markdown and CSV tables and the paired comparisons.
- :mod:`.report`: ``report.html`` and the ``.glb`` beside each occluder.

The names below are re-exported so that ``viscore.cli.study.StudySettings``
and the other paths of the former single module keep working.
"""

from .report import CULLING_COLUMNS, write_occluder_glb, write_occluder_glbs, write_report
from .runner import (
    JOBS_PER_CORE,
    TIMING_FIELDS,
    Job,
    StudySettings,
    build_views,
    run_job,
    run_study,
    study_jobs,
    study_memory,
    view_settings,
)
from .store import (
    LOCK_NAME,
    OCCLUDER_DIR,
    STORE_COLUMNS,
    STORE_NAME,
    ResultStore,
    StudyFolder,
    check_study_dir,
)
from .tables import TABLE_COLUMNS, paired_markdown, paired_rows, table_csv, table_markdown

__all__ = ["StudySettings", "Job", "run_study", "study_jobs", "study_memory", "view_settings",
           "build_views", "run_job", "ResultStore", "StudyFolder", "check_study_dir",
           "table_markdown", "table_csv", "paired_rows", "paired_markdown", "write_report",
           "write_occluder_glb", "write_occluder_glbs", "TABLE_COLUMNS", "TIMING_FIELDS",
           "JOBS_PER_CORE", "STORE_NAME", "LOCK_NAME", "OCCLUDER_DIR", "STORE_COLUMNS",
           "CULLING_COLUMNS"]
