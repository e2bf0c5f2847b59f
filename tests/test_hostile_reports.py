"""Hostile input at the report pages and the options of ``cull``, ``occlude`` and ``compare``
(issue 46, last item): names that cannot be encoded or shown, huge names, absurd
``--report-frames``; each refused in one line with exit 2, or shown escaped and readable."""

from __future__ import annotations

import json
import os
import re
import struct

import numpy as np
import pytest
import trimesh
from test_report_pages import _street_scene  # the report pages' small street

from viscore import InputError
from viscore.cli import cull_cmd
from viscore.cli import main as cli_main
from viscore.cli.report.cull_page import (
    MAX_REPORT_FRAMES,
    check_report_memory,
    frame_size,
    report_frames,
)
from viscore.cli.report.occlude_page import NAME_CHARS, _object_rows
from viscore.cli.report.page import printable, render_page
from viscore.cli.report.pictures import FRAME_WIDTH


@pytest.fixture
def run(monkeypatch):
    if cull_cmd not in cli_main._COMMANDS:
        monkeypatch.setattr(cli_main, "_COMMANDS", [*cli_main._COMMANDS, cull_cmd])
    return lambda *argv: cli_main.main([*map(str, argv)])


def _street_glb() -> bytes:
    """A wall, a box behind it and a ground, as a GLB (the report pages' small street)."""
    return _street_scene().export(file_type="glb")


def _glb_with_json(glb: bytes, edit) -> bytes:
    """The GLB with its JSON chunk replaced by ``edit(json_text)`` (padded to 4 bytes)."""
    length = struct.unpack_from("<I", glb, 12)[0]
    text = edit(glb[20:20 + length].decode("utf-8").rstrip())
    data = text.encode("ascii")
    data += b" " * (-len(data) % 4)
    rest = glb[20 + length:]
    return (b"glTF" + struct.pack("<II", 2, 12 + 8 + len(data) + len(rest))
            + struct.pack("<I", len(data)) + b"JSON" + data + rest)


# ------------------------------------------------------------ text a page cannot hold
def test_printable_replaces_surrogates_and_control_characters():
    assert printable("a\udcffb\x00c\x1bd\x85e") == "a\ufffdb\ufffdc\ufffdd\ufffde"
    assert printable("tab\tline\nreturn\r<&>\"'ü€😀") == "tab\tline\nreturn\r<&>\"'ü€😀"


def test_render_page_holds_undecodable_and_control_characters():
    html = render_page("base.html.j2", heading="bad\udcffname", lead="nul\x00esc\x1b",
                       settings={"scene": "x\udcfe"})
    data = html.encode("utf-8")  # a surrogate would raise here
    assert b"\x00" not in data and b"\x1b" not in data
    assert "bad\ufffdname" in html and "nul\ufffdesc\ufffd" in html and "x\ufffd" in html


def _non_utf8_level(tmp_path) -> str:
    path = tmp_path / os.fsdecode(b"st\xffreet.glb")  # '\udcff' in Python
    path.write_bytes(_street_glb())
    return str(path)


def test_occlude_page_of_a_file_named_in_bytes_that_are_not_utf8(run, tmp_path, capsys):
    level = _non_utf8_level(tmp_path)
    out = tmp_path / "occ"
    assert run("occlude", level, "-o", out, "--methods", "bbox", "--quiet") == 0, \
        capsys.readouterr().err
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "<title>viscore occlude: st\ufffdreet</title>" in html


def test_cull_page_of_a_file_named_in_bytes_that_are_not_utf8(run, tmp_path, capsys):
    level = _non_utf8_level(tmp_path)
    out = tmp_path / "cull"
    assert run("cull", level, "--frames", 2, "--methods", "bbox", "--frusta-method", "bbox",
               "--width", 32, "--height", 18, "--out", out, "--quiet") == 0, \
        capsys.readouterr().err
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "<title>viscore cull: st\ufffdreet</title>" in html


@pytest.mark.parametrize("command", ["occlude", "cull"])
def test_gltf_name_with_a_lone_surrogate_is_refused(run, tmp_path, capsys, command):
    level = tmp_path / "lone.glb"
    level.write_bytes(_glb_with_json(_street_glb(),
                                     lambda t: t.replace('"box"', '"bad\\ud800box"')))
    out = tmp_path / "out"
    option = "-o" if command == "occlude" else "--out"
    assert run(command, level, option, out, "--quiet", "--methods", "bbox") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "lone.glb" in err[0] and "surrogate" in err[0]
    assert ".name" in err[0]
    assert not out.exists()


def test_gltf_surrogate_pair_escape_is_read(tmp_path):
    from viscore.level import level_objects

    level = tmp_path / "pair.glb"
    level.write_bytes(_glb_with_json(_street_glb(),
                                     lambda t: t.replace('"box"', '"\\ud83d\\ude00box"')))
    assert "\U0001f600box" in level_objects(level).objects.names


# -------------------------------------------------------------------- huge names
def test_occlude_page_cuts_huge_names():
    name = "N" * 100_000
    manifest = {"objects": {name: {"chosen": True, "size": 1.0, "mesh": "M" * 5000,
                                   "refused": None, "occluders": {}},
                            "short": {"chosen": False, "size": 0.1, "mesh": "m",
                                      "refused": "too small", "occluders": {}}}}
    rows, more = _object_rows(manifest, [])
    assert more == 0
    assert len(rows[0]["object"]) == NAME_CHARS and rows[0]["object"].endswith("\u2026")
    assert rows[0]["object"].startswith("N" * (NAME_CHARS - 1))
    assert len(rows[0]["mesh"]) == NAME_CHARS
    assert rows[1]["object"] == "short" and rows[1]["mesh"] == "m"
    assert json.dumps(rows)  # plain data
    assert np.all([len(r["object"]) <= NAME_CHARS for r in rows])


# ------------------------------------------------------------------ --report-frames
@pytest.mark.parametrize("text", ["+1", "1_0", "\u0663", " 1 - 2", "0x1"])
def test_report_frames_takes_ascii_digits_only(text):
    with pytest.raises(InputError, match="expected 'all' or frames and ranges"):
        report_frames(50, text)


def test_report_frames_says_a_backward_range_runs_backwards():
    with pytest.raises(InputError, match="range 3-1 runs backwards"):
        report_frames(50, "3-1")


def test_report_frames_refuses_more_frames_than_a_page_draws():
    count = 10 * MAX_REPORT_FRAMES
    assert len(report_frames(count, f"0-{MAX_REPORT_FRAMES - 1}")) == MAX_REPORT_FRAMES
    # overlapping ranges count their frames once
    assert len(report_frames(count, f"0-{MAX_REPORT_FRAMES - 1},5-9")) == MAX_REPORT_FRAMES
    for text in ("all", f"0-{MAX_REPORT_FRAMES}", f"0-{count - 1}",
                 f"0-{MAX_REPORT_FRAMES // 2},{MAX_REPORT_FRAMES}-{2 * MAX_REPORT_FRAMES}"):
        with pytest.raises(InputError, match=f"more than the {MAX_REPORT_FRAMES:,}"):
            report_frames(count, text)
    assert len(report_frames(MAX_REPORT_FRAMES, "all")) == MAX_REPORT_FRAMES


def test_cull_report_frames_all_of_a_long_walk_exit_2_before_any_work(run, tmp_path, capsys):
    level = tmp_path / "street.glb"
    level.write_bytes(_street_glb())
    out = tmp_path / "out"
    assert run("cull", level, "--frames", 2 * MAX_REPORT_FRAMES, "--report-frames", "all",
               "--methods", "bbox", "--out", out, "--quiet") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--report-frames all" in err[0] and "2,000 frames" in err[0]
    assert not out.exists()


# ------------------------------------------------------------------------- compare
def test_compare_of_a_mesh_file_named_in_bytes_that_are_not_utf8_exit_2(tmp_path, capsys):
    # the study's SQLite store could not hold the name: exit 3 with the folder half made
    mesh = tmp_path / os.fsdecode(b"b\xffx.obj")
    trimesh.creation.box(extents=(1, 2, 3)).export(str(mesh), file_type="obj")
    out = tmp_path / "study"
    assert cli_main.main(["compare", str(mesh), "--methods", "bbox", "--no-culling",
                          "--views", "4", "--quads", "50", "--res", "32", "--out", str(out),
                          "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "MESH" in err[0] and "b\\xffx.obj" in err[0]
    assert "not UTF-8" in err[0]
    assert not out.exists()


# ------------------------------------------------------------ pictures of tall views
def test_frame_pictures_fit_a_square_whatever_the_aspect():
    assert frame_size(1280, 720) == (FRAME_WIDTH, round(FRAME_WIDTH * 720 / 1280))
    assert frame_size(720, 1280) == (round(FRAME_WIDTH * 720 / 1280), FRAME_WIDTH)
    assert frame_size(1, 8192) == (1, FRAME_WIDTH)
    assert frame_size(8192, 1) == (FRAME_WIDTH, 1)
    # a 1 x 8192 view was a 480 x 3.9 million picture: 562 GiB, refused
    check_report_memory(1, 8192)


def test_cull_page_of_a_tall_view(run, tmp_path, capsys):
    level = tmp_path / "street.glb"
    level.write_bytes(_street_glb())
    out = tmp_path / "out"
    assert run("cull", level, "--frames", 1, "--width", 18, "--height", 32, "--buffer-scale",
               1, "--methods", "bbox", "--frusta-method", "bbox", "--out", out,
               "--quiet") == 0, capsys.readouterr().err
    html = (out / "report.html").read_text(encoding="utf-8")
    sizes = set(re.findall(r'<img src="data:image/png;base64,[^"]*" alt="frame 0, [^"]*" '
                           r'width="(\d+)" height="(\d+)"', html))
    assert sizes == {(str(round(FRAME_WIDTH * 18 / 32)), str(FRAME_WIDTH))}
