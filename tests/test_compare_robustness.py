"""``viscore compare`` under hostile conditions: damaged stores, two runs at once, Ctrl-C,
SIGKILL at several moments, and bit-identical results across runs and thread counts.

The subprocess tests run the real command line (``python -m viscore.cli.main``) in
its own session, so that every process it starts can be found and shown gone.
"""

import fcntl
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time

import pytest

from viscore.cli.main import main
from viscore.cli.study.runner import TIMING_FIELDS

#: Tiny evaluation settings: a job takes a fraction of a second.
TINY = ["--views", "4", "--quads", "300", "--res", "32", "--rays", "1000", "--no-culling"]
#: Four methods, two budgets: 6 jobs (aabb-skins and qem at each budget, bbox, original).
STUDY = ["cow", "--methods", "qem,aabb-skins,bbox,original", "--budget", "32,64", *TINY]
JOBS = 6


def _command(out, *extra):
    return [sys.executable, "-m", "viscore.cli.main", "compare", *STUDY, "--quiet",
            "--out", str(out), *extra]


def _default_sigint() -> None:
    """In the child before exec: SIGINT as a terminal's shell starts a command (default
    action). A disposition of SIG_IGN is inherited through exec, and then Python never
    raises KeyboardInterrupt: the compare ignored the test's Ctrl-C in full runs, where
    the pytest worker had been left with SIGINT ignored."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start(out, *extra):
    return subprocess.Popen(_command(out, *extra), stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=_default_sigint)


def _stored(out) -> set:
    """Keys of the rows committed to the study store (read-only, as another reader would)."""
    path = out / "results.sqlite"
    for _ in range(50):
        if not path.is_file():
            return set()
        try:
            with sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=5) as db:
                return {k for (k,) in db.execute("SELECT key FROM results")}
        except sqlite3.OperationalError:  # the table is not there yet, or a writer holds it
            time.sleep(0.05)
    raise AssertionError(f"{path}: unreadable")


def _wait_for_rows(proc, out, count: int, timeout: float = 120) -> set:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        keys = _stored(out)
        if len(keys) >= count or proc.poll() is not None:
            return keys
        time.sleep(0.02)
    raise AssertionError(f"no {count} rows in {out} after {timeout} s")


def _session_left(sid: int, timeout: float = 10) -> list[int]:
    """Processes still in session ``sid`` (the command and everything it started)."""
    end = time.monotonic() + timeout
    while True:
        left = []
        for pid in filter(str.isdigit, os.listdir("/proc")):
            try:
                with open(f"/proc/{pid}/stat") as fh:
                    fields = fh.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if fields[0] != "Z" and int(fields[3]) == sid:
                left.append(int(pid))
        if not left or time.monotonic() > end:
            return left
        time.sleep(0.1)


def _table(out) -> str:
    """The final table of ``out/results.json`` without wall times and provenance."""
    doc = json.loads((out / "results.json").read_text())
    rows = [{k: v for k, v in r.items() if k not in TIMING_FIELDS} for r in doc["rows"]]
    return json.dumps({"settings": doc["settings"], "rows": rows, "paired": doc["paired"]},
                      sort_keys=True)


def _clean_run(out, capsys, *extra) -> str:
    assert main(["compare", *STUDY, "--quiet", "--out", str(out), *extra]) == 0
    capsys.readouterr()
    return _table(out)


# --------------------------------------------------------------------------- damaged stores
def _random_bytes(path):
    path.write_bytes(bytes(range(256)) * 20)


def _other_table(path):
    with sqlite3.connect(path) as db:
        db.execute("CREATE TABLE notes (text TEXT)")


def _other_columns(path):
    with sqlite3.connect(path) as db:
        db.execute("CREATE TABLE results (id INTEGER, value REAL)")


def _row(text):
    def make(path):
        with sqlite3.connect(path) as db:
            db.execute("CREATE TABLE results (key TEXT PRIMARY KEY, mesh TEXT, method TEXT, "
                       "row TEXT NOT NULL)")
            db.execute("INSERT INTO results VALUES ('k1', 'cow', 'bbox', ?)", (text,))
    return make


@pytest.mark.parametrize("damage, expected", [
    (_random_bytes, "file is not a database"),
    (lambda p: p.mkdir(), "is a folder"),
    (_other_table, "holds other tables (notes)"),
    (_other_columns, "has the columns id, value"),
    (_row("{not json"), "the row 'k1' is not JSON"),
    (_row("[1, 2]"), "the row 'k1' is not a study row"),
    (_row('{"key": "other"}'), "the row 'k1' is not a study row"),
], ids=["random-bytes", "folder", "other-table", "other-columns", "not-json", "not-a-dict",
        "wrong-key"])
def test_damaged_store_exit_2_one_line_naming_it(tmp_path, capsys, damage, expected):
    out = tmp_path / "study"
    out.mkdir()
    store = out / "results.sqlite"
    damage(store)
    before = store.read_bytes() if store.is_file() else None
    assert main(["compare", "cow", "--methods", "bbox", *TINY, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert str(store) in err and expected in err and "not a viscore study store" in err
    assert (store.read_bytes() if store.is_file() else None) == before  # left as it was
    assert not (out / "occluders").exists()


# --------------------------------------------------------------------------- two runs at once
def test_a_locked_study_is_refused_with_one_line(tmp_path, capsys):
    out = tmp_path / "study"
    out.mkdir()
    with open(out / ".lock", "w") as held:  # another compare holds the study
        fcntl.flock(held, fcntl.LOCK_EX)
        assert main(["compare", "cow", "--methods", "bbox", *TINY, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "another compare is writing" in err
    assert not (out / "results.sqlite").exists()
    # released: the same command now runs
    assert main(["compare", "cow", "--methods", "bbox", *TINY, "--out", str(out),
                 "--quiet"]) == 0


def test_two_compares_on_one_study_never_corrupt_it(tmp_path, capsys):
    out = tmp_path / "study"
    first = _start(out)
    _wait_for_rows(first, out, 1)
    second = _start(out)
    err2 = second.communicate(timeout=120)[1]
    first_running = first.poll() is None
    err1 = first.communicate(timeout=300)[1]
    assert first.returncode == 0, err1
    if first_running:  # the usual case: refused at once, with one line
        assert second.returncode == 2
        assert err2.count("\n") == 1 and "another compare is writing" in err2
    else:  # the first had finished: the second resumed its whole study
        assert second.returncode == 0, err2
    assert len(_stored(out)) == JOBS
    rows = json.loads((out / "results.json").read_text())["rows"]
    assert len(rows) == JOBS and {r["key"] for r in rows} == _stored(out)


# --------------------------------------------------------------------------- Ctrl-C
def test_ctrl_c_stops_at_once_and_keeps_every_finished_row(tmp_path):
    out = tmp_path / "study"
    proc = _start(out)
    before = _wait_for_rows(proc, out, 1)
    assert proc.poll() is None and 1 <= len(before) < JOBS
    os.killpg(proc.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole process group
    err = proc.communicate(timeout=15)[1]  # 27.9 s before the fix, under 1 s after
    assert proc.returncode == 130
    assert err.splitlines() == ["viscore: interrupted"]
    after = _stored(out)
    assert before <= after and len(after) < JOBS  # finished rows kept; the rest cancelled
    assert _session_left(proc.pid) == []  # no worker left computing
    assert not list(out.rglob("*.tmp"))


# --------------------------------------------------------------------------- SIGKILL
def test_sigkill_at_several_moments_resumes_to_the_uninterrupted_table(tmp_path, capsys):
    out = tmp_path / "study"
    seen = set()
    for target in (1, 3):  # killed after the first row, then after two more
        proc = _start(out)
        seen = _wait_for_rows(proc, out, target)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
        assert _session_left(proc.pid) == []  # the workers died with their parent
        assert len(_stored(out)) >= len(seen)  # nothing committed was lost
    assert len(seen) < JOBS
    resumed = _clean_run(out, capsys)
    assert len(_stored(out)) == JOBS
    assert resumed == _clean_run(tmp_path / "clean", capsys)


# --------------------------------------------------------------------------- determinism
def test_bit_identical_json_across_runs_and_thread_counts(tmp_path, capsys):
    """Same command and seed: the same results.json but for wall times and provenance.

    Excluded: the rows' ``seconds``, ``seconds_evaluate``, ``seconds_measure`` and
    ``seconds_validate`` (:data:`viscore.cli.study.runner.TIMING_FIELDS`) and the document's
    ``provenance`` (it records the thread count).
    """
    argv = ["compare", "fat-torus", "--methods", "aabb-skins,qem,bbox", "--budget", "48",
            *TINY, "--seed", "7", "--quiet"]
    tables = []
    for name, head in (("a", []), ("b", []), ("one-thread", ["--workers", "1"])):
        assert main([*head, *argv, "--out", str(tmp_path / name)]) == 0
        tables.append(_table(tmp_path / name))
    capsys.readouterr()
    assert tables[0] == tables[1] == tables[2]
    assert json.loads(tables[0])["rows"][0]["settings"]["seed"] == 7
