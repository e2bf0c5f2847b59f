"""generators/_held_logs.py: log lines held back during repeated builds, then said once."""

import logging
import threading

import pytest

from viscore.generators._held_logs import (
    held_records,
    portable,
    release,
    report_kinds,
    report_parts,
    restored,
)

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


def test_report_parts_groups_texts_that_name_their_own_part(caplog):
    """A warning each mesh gives with its own name in it (a level's 30 open meshes) is said
    once with the count; a text naming another part, or one part alone, is said as made."""
    names = {0: "town.gltf:GLTF_19", 1: "town.gltf:GLTF_22", 2: "town.gltf:GLTF_2"}
    with held_records() as records:
        for part in range(3):
            _LOG.warning("aabb-skins: %s is not closed", names[part])
        _LOG.warning("%s is tiny", names[1])
    held = list(zip([0, 1, 2, 1], records, strict=True))
    report_parts(held, 4, what="meshes", label="aabb-skins", one="mesh", names=names)
    said = [r.getMessage() for r in caplog.records]
    assert said == ["aabb-skins: 3 of 4 meshes: each of them is not closed",
                    "aabb-skins: town.gltf:GLTF_22 is tiny"]
    caplog.clear()
    report_parts(held, 4, what="meshes", label="aabb-skins", one="mesh")  # names unknown
    assert len(caplog.records) == 4
    # one part whose text does not name it: named by its name, not its index
    caplog.clear()
    with held_records() as records:
        _LOG.warning("no inside voxel")
    report_parts([(2, records[0])], 4, what="meshes", label="aabb-skins", one="mesh",
                 names=names)
    assert [r.getMessage() for r in caplog.records] == [
        "aabb-skins mesh town.gltf:GLTF_2: no inside voxel"]


def test_texts_differing_by_their_numbers_are_one_line_with_ranges(caplog):
    """A lake map's 74 meshes gave 10 lines of one warning whose voxel sizes differed mesh
    by mesh: one line now, each differing number said as its range, the shared ones as
    they were; numbers inside names (Plane.086, GLTF_19) are no numbers."""
    names = {0: "city.gltf:Plane.086", 1: "city.gltf:Plane.101", 2: "city.gltf:GLTF_19"}
    with held_records() as records:
        for part, voxel in ((0, "0.01315"), (1, "0.004005"), (2, "0.011")):
            _LOG.warning("%s: walls of 0.006096 (20%% quantile) need voxels under 0.002743, "
                         "grid of 16,000,000 cells has %s", names[part], voxel)
        _LOG.warning("%s: 3 triangles dropped", names[1])
        _LOG.warning("%s: 12 triangles dropped", names[1])
    held = list(zip([0, 1, 2, 1, 1], records, strict=True))
    report_parts(held, 74, what="meshes", label="aabb-skins", one="mesh", names=names)
    assert [r.getMessage() for r in caplog.records] == [
        "aabb-skins: 3 of 74 meshes: each of them: walls of 0.006096 (20% quantile) need "
        "voxels under 0.002743, grid of 16,000,000 cells has 0.004005 to 0.01315",
        "aabb-skins: city.gltf:Plane.101: 3 to 12 triangles dropped"]
    caplog.clear()
    with held_records() as records:
        _LOG.warning("aabb-skins: GLTF_19 has 2 holes")
        _LOG.warning("aabb-skins: GLTF_22 has 2 holes")
        _LOG.warning("solid-frusta: GLTF_19 has 5 holes")
    assert report_kinds(records, labels=("aabb-skins", "solid-frusta")) == 2
    assert [r.getMessage() for r in caplog.records] == [
        "aabb-skins, solid-frusta: GLTF_19 has 2 to 5 holes (2 times)",
        "aabb-skins: GLTF_22 has 2 holes"]


def test_report_parts_says_its_label_once():
    log = logging.getLogger("viscore.example")
    log.setLevel(logging.INFO)
    with held_records() as records:
        log.warning("aabb-skins: mesh is not closed")
        log.warning("aabb-skins: mesh is not closed")
        log.warning("solid-frusta: aabb-skins: tiny")
    with held_records() as said:
        report_parts(list(zip([0, 1, 1], records, strict=True)), 3, what="meshes",
                     label="aabb-skins", one="mesh")
    assert [r.getMessage() for r in said] == [
        "aabb-skins: 2 of 3 meshes: mesh is not closed",
        "aabb-skins mesh 1: solid-frusta: aabb-skins: tiny"]


def test_report_kinds_says_each_warning_once_with_its_count(caplog):
    """A study's jobs give the same warning per budget, and two methods the same one about
    the city's ground: one line each, with the count; details under WARNING are not said."""
    with held_records() as records:
        for _ in range(2):
            _LOG.warning("aabb-skins: house is not closed")
        _LOG.warning("aabb-skins: ground: walls too thin")
        _LOG.error("solid-frusta: ground: walls too thin")  # the higher level wins
        _LOG.info("planar-sections: closing adds 139%")
        _LOG.warning("qem: once only")
    said = report_kinds(records, labels=("aabb-skins", "solid-frusta", "qem"))
    assert said == 3
    assert [(r.levelno, r.getMessage()) for r in caplog.records] == [
        (logging.WARNING, "aabb-skins: house is not closed (2 times)"),
        (logging.ERROR, "aabb-skins, solid-frusta: ground: walls too thin (2 times)"),
        (logging.WARNING, "qem: once only")]
    caplog.clear()
    assert report_kinds(records, level=logging.INFO, what="jobs",
                        labels=("aabb-skins", "solid-frusta")) == 4
    assert caplog.records[0].getMessage() == "aabb-skins: house is not closed (2 jobs)"


def test_portable_records_pickle_and_read_back_formatted():
    import pickle

    class Unpicklable:
        def __reduce__(self):
            raise TypeError("no")

        def __str__(self):
            return "thing"

    with held_records() as records:
        _LOG.warning("%s at %d", Unpicklable(), 3)
    back = restored(pickle.loads(pickle.dumps(portable(records))))
    assert [(r.name, r.levelno, r.getMessage()) for r in back] == [
        (_LOG.name, logging.WARNING, "thing at 3")]


def test_a_record_marked_unheld_passes_a_hold(caplog):
    """A long run's estimate is said when it comes, while the generators' records wait."""
    from viscore.generators._held_logs import UNHELD

    with caplog.at_level(logging.INFO), held_records() as records:
        _LOG.warning("held")
        _LOG.warning("estimated 2 h", extra={UNHELD: True})
    assert [r.getMessage() for r in records] == ["held"]
    assert [r.getMessage() for r in caplog.records] == ["estimated 2 h"]
