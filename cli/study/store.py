"""The study folder: its SQLite store of finished jobs and its lock."""

from __future__ import annotations

import errno
import json
import os
import shutil
import sqlite3
from pathlib import Path

from viscore import InputError
from viscore._atomic import LockedFolder, lock_exclusive

from .._common import check_output_folder, dumps

__all__ = ["ResultStore", "StudyFolder", "check_study_dir", "lock_exclusive", "STORE_NAME",
           "LOCK_NAME", "OCCLUDER_DIR", "STORE_COLUMNS"]

#: File names inside a study folder.
STORE_NAME, LOCK_NAME, OCCLUDER_DIR = "results.sqlite", ".lock", "occluders"

#: Columns of the store's one table, in order.
STORE_COLUMNS = ("key", "mesh", "method", "row")


def _not_a_store(path: Path, problem: str) -> InputError:
    return InputError(f"{path}: {problem}; not a viscore study store (move it away or choose "
                      "another --out)")


class ResultStore:
    """One SQLite file per study directory; a row per finished job, committed at once.

    Opening checks the whole file before any work: a file that is not SQLite,
    a folder, another schema, a failed integrity check or a row that is not a
    JSON object of its key raises :class:`InputError` naming the file (no
    ``sqlite3`` or JSON traceback). An empty or missing file becomes a new
    store. Rows are read once, at opening.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        path = Path(path)
        self.path = path
        if os.path.lexists(path) and not path.is_file():
            kind = "a folder" if path.is_dir() else "not a regular file"
            raise _not_a_store(path, f"is {kind}, expected the study's SQLite file")
        self._db = None
        try:
            self._db = sqlite3.connect(path)
            self._rows = self._check()
        except sqlite3.DatabaseError as exc:
            self.close()
            raise _not_a_store(path, f"sqlite: {exc}") from None
        except BaseException:
            self.close()
            raise

    def _check(self) -> dict[str, dict]:
        db, path = self._db, self.path
        tables = [r[0] for r in db.execute(
            "SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")]
        if "results" not in tables:
            if tables:
                raise _not_a_store(path, f"holds other tables ({', '.join(tables)})")
            db.execute("CREATE TABLE results (key TEXT PRIMARY KEY, mesh TEXT, method TEXT, "
                       "row TEXT NOT NULL)")
            db.commit()
            return {}
        columns = tuple(r[1] for r in db.execute("PRAGMA table_info(results)"))
        if columns != STORE_COLUMNS:
            raise _not_a_store(path, f"its results table has the columns {', '.join(columns)}"
                                     f", expected {', '.join(STORE_COLUMNS)}")
        status = db.execute("PRAGMA quick_check").fetchone()[0]
        if status != "ok":
            raise _not_a_store(path, f"the integrity check failed ({status})")
        rows = {}
        for key, text in db.execute("SELECT key, row FROM results"):
            try:
                row = json.loads(text)
            except (TypeError, ValueError):
                raise _not_a_store(path, f"the row {key!r} is not JSON") from None
            if not isinstance(row, dict) or row.get("key") != key:
                raise _not_a_store(path, f"the row {key!r} is not a study row of that key")
            rows[key] = row
        return rows

    def get(self, key: str) -> dict | None:
        return self._rows.get(key)

    def put(self, key: str, row: dict) -> None:
        try:
            with self._db:  # one transaction: the row is there whole or not at all
                self._db.execute("INSERT OR REPLACE INTO results VALUES (?, ?, ?, ?)",
                                 (key, row["mesh"], row["method"], dumps(row)))
        except sqlite3.DatabaseError as exc:  # disk full, read-only: exit 2 naming the file
            raise OSError(errno.EIO, f"cannot write the study store ({exc})",
                          str(self.path)) from None
        self._rows[key] = row

    def __len__(self) -> int:
        return len(self._rows)

    def close(self) -> None:
        if self._db is not None:
            self._db.close()
            self._db = None


def _refuse_linked_subfolders(path: Path) -> None:
    """One line when a subfolder the study writes into is a symbolic link."""
    sub = path / OCCLUDER_DIR
    if sub.is_symlink():
        raise InputError(f"--out {path}: {sub} is a symbolic link (to "
                         f"{os.readlink(sub)!r}); a study writes only inside its folder "
                         f"(replace the link by a folder or choose another --out)")
    if os.path.lexists(sub) and not sub.is_dir():
        raise InputError(f"--out {path}: {sub} is not a folder")


def check_study_dir(path: str | os.PathLike) -> Path:
    """Refuse, before any work, a study folder that cannot be used.

    The folder may exist (a study to resume) or not; if not, its parent must
    exist (only the study folder itself is created, never a tree). Nothing is
    created or locked here (a temporary folder probes that files can be made).

    Raises
    ------
    InputError
        One line naming the path and the problem: among them a store that is
        not a file, and an ``occluders/`` that is a symbolic link (a study
        writes only inside its folder).
    """
    path = check_output_folder(path)
    store = path / STORE_NAME
    if os.path.lexists(store) and not store.is_file():
        raise _not_a_store(store, "is a folder" if store.is_dir() else "is not a file")
    _refuse_linked_subfolders(path)
    return path


class StudyFolder:
    """A study folder opened for writing by this process alone.

    ``with StudyFolder(path) as study:`` checks the path
    (:func:`check_study_dir`), creates the folder if missing, takes an
    exclusive advisory lock on ``path/.lock`` (``fcntl.flock``, released when
    the block ends or the process dies), opens and checks the store
    (:class:`ResultStore`, as ``study.store``), creates ``occluders/`` and
    removes temporary files a killed run left behind.

    Raises
    ------
    InputError
        If another process holds the lock ("another compare is writing
        ..."), the store is damaged or ``occluders/`` is a symbolic link:
        one line, and the folder is left as it was (but for the lock file).
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        self.store: ResultStore | None = None
        self._folder: LockedFolder | None = None

    @property
    def occluders(self) -> Path:
        return self.path / OCCLUDER_DIR

    def __enter__(self) -> StudyFolder:
        check_study_dir(self.path)
        folder = LockedFolder(
            self.path, lock_file=LOCK_NAME,
            busy=f"--out {self.path}: another compare is writing this study (it holds "
                 f"{self.path / LOCK_NAME}); wait for it to finish or choose another --out")
        self._folder = folder.__enter__()
        try:
            _refuse_linked_subfolders(self.path)  # again, under the lock
            self.store = ResultStore(self.path / STORE_NAME)
            self.occluders.mkdir(exist_ok=True)
            for stale in [*self.path.glob(".*.tmp"), *self.occluders.glob(".*.tmp")]:
                if stale.is_dir() and not stale.is_symlink():  # a killed run's views folder
                    shutil.rmtree(stale, ignore_errors=True)
                else:
                    stale.unlink(missing_ok=True)  # a killed run's half-written file
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def __exit__(self, *exc) -> None:
        if self.store is not None:
            self.store.close()
            self.store = None
        if self._folder is not None:
            self._folder.__exit__(*exc)  # releases the flock
            self._folder = None
