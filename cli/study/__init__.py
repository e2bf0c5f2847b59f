"""The study runner behind ``viscore compare``: jobs, their store, tables and report."""

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
