"""generators/_held_logs.py: log lines held back during repeated builds, then said once."""

import logging
import threading

import pytest
from viscore.generators._held_logs import held_records, release, report_parts

_LOG = logging.getLogger("viscore.generators.test_held_logs")


@pytest.fixture(autouse=True)
def _levels(caplog):
    """INFO for every logger here (a CLI run with --quiet earlier leaves them at ERROR)."""
    caplog.set_level(logging.INFO)
    caplog.set_level(logging.INFO, logger="viscore")


def test_held_records_stop_this_threads_lines_until_released(caplog):
    with held_records() as records:
        _LOG.warning("held %d", 1)
        logging.getLogger("viscore").info("held too")
        logging.getLogger("elsewhere").warning("not ours: passes")
        other = threading.Thread(target=_LOG.warning, args=("another thread: passes",))
        other.start()
        other.join()
    assert [r.getMessage() for r in records] == ["held 1", "held too"]
    assert [r.getMessage() for r in caplog.records] == ["not ours: passes",
                                                        "another thread: passes"]
    caplog.clear()
    release(records)
    assert [(r.name, r.getMessage()) for r in caplog.records] == [
        (_LOG.name, "held 1"), ("viscore", "held too")]
    _LOG.warning("after the block")  # the hold is gone
    assert caplog.records[-1].getMessage() == "after the block"


def test_a_logger_made_during_the_block_is_held_too(caplog):
    with held_records() as records:
        logging.getLogger("viscore.generators.test_held_logs.made_now").warning("late")
    assert [r.getMessage() for r in records] == ["late"] and caplog.records == []


def test_an_inner_hold_sees_the_lines_first():
    with held_records() as outer:
        with held_records() as inner:
            _LOG.warning("inner")
        _LOG.warning("outer")
    assert [r.getMessage() for r in inner] == ["inner"]
    assert [r.getMessage() for r in outer] == ["outer"]


def test_report_parts_says_each_text_once_with_its_count(caplog):
    with held_records() as records:
        _LOG.info("open mesh")
        _LOG.warning("open mesh")  # the same text at a higher level: said at that level
        _LOG.warning("open mesh")
        _LOG.info("tiny at %d voxels", 3)
    report_parts(list(zip([0, 1, 2, 1], records, strict=True)), 5)
    said = [(r.levelno, r.getMessage()) for r in caplog.records]
    assert said == [(logging.WARNING, "hierarchy: 3 of 5 nodes: open mesh"),
                    (logging.INFO, "hierarchy node 1: tiny at 3 voxels")]
    caplog.clear()
    report_parts([], 5)
    assert caplog.records == []
