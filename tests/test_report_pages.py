"""The report pages of ``cull`` and ``occlude`` (viscore.cli.report): answer first, pictures
by the ray caster, every picture named, nothing loaded from outside the page."""

import base64
import io
import json
import re
from html.parser import HTMLParser

import numpy as np
import pytest
import trimesh
from PIL import Image

from viscore import InputError, stream_seed
from viscore.cli import cull_cmd
from viscore.cli import main as cli_main
from viscore.cli.report.cull_page import REPORT_FRAMES, cull_report_html, report_frames
from viscore.cli.report.page import cite_name, format_interval, render_page
from viscore.cli.report.pictures import FRAME_WIDTH
from viscore.level.scene_graph import load_scene_objects
from viscore.metrics.culling import PathCamera, Runtime, no_culling, simulate_culling

UP = np.array([0.0, 1.0, 0.0])


class _Page(HTMLParser):
    """Images (by figure id), table rows by class, section ids in order, outside loads."""

    def __init__(self):
        super().__init__()
        self.figures, self.rows, self.ids, self.external, self.cells = {}, {}, [], [], {}
        self._figure = self._row = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id"):
            self.ids.append(a["id"])
        if tag == "figure":
            self._figure = a.get("id")
        if tag == "img":
            self.figures[self._figure] = a
        if tag == "tr" and a.get("class"):
            self.rows[a["class"]] = self.rows.get(a["class"], 0) + 1
            self._row = a["class"]
            self.cells.setdefault(self._row, []).append([])
        if tag == "td" and self._row:
            self.cells[self._row][-1].append(a.get("class") or "")
        for key in ("src", "href"):
            if re.match(r"^(https?:|//)", a.get(key) or ""):
                self.external.append(a[key])
        if tag in ("script", "link", "iframe", "object"):
            self.external.append(tag)

    def handle_endtag(self, tag):
        if tag == "tr":
            self._row = None


def _parse(html: str) -> _Page:
    page = _Page()
    page.feed(html)
    page.close()
    return page


def _pixels(img_attrs) -> np.ndarray:
    prefix = "data:image/png;base64,"
    assert img_attrs["src"].startswith(prefix)
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(img_attrs["src"][len(prefix):])))
                      .convert("RGB")).astype(int)


def _greenish(rgb):
    return int(((rgb[..., 1] > rgb[..., 0] + 30) & (rgb[..., 1] > rgb[..., 2] + 15)).sum())


def _orange(rgb):
    return int(((rgb[..., 0] > rgb[..., 2] + 70) & (rgb[..., 1] > rgb[..., 2] + 20)).sum())


def _red(rgb):  # the false-cull red, however shaded: green and blue far under red
    r = rgb[..., 0]
    return int(((r > 60) & (rgb[..., 1] < 0.35 * r) & (rgb[..., 2] < 0.35 * r)).sum())


@pytest.fixture
def run(monkeypatch):
    if cull_cmd not in cli_main._COMMANDS:
        monkeypatch.setattr(cli_main, "_COMMANDS", [*cli_main._COMMANDS, cull_cmd])
    return lambda *argv: cli_main.main([*map(str, argv)])


def _street_scene():
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(bounds=[[-5, 0, -0.5], [5, 6, 0.5]]),
                       geom_name="wall", node_name="wall")
    scene.add_geometry(trimesh.creation.box(bounds=[[-1.5, 0, 4.5], [1.5, 2, 5.5]]),
                       geom_name="box", node_name="box")
    scene.add_geometry(trimesh.creation.box(bounds=[[-30, -0.2, -30], [30, 0, 30]]),
                       geom_name="ground", node_name="ground")
    return scene


@pytest.fixture
def street(tmp_path):
    """A GLB: a wall hiding a box from the first camera, on a ground; two cameras."""
    path = tmp_path / "street.glb"
    path.write_bytes(_street_scene().export(file_type="glb"))
    cameras = tmp_path / "cameras.json"
    cameras.write_text(json.dumps([
        {"position": [0, 1.5, -10], "forward": [0, 0, 1]},
        {"position": [20, 1.5, 5], "forward": [-1, 0, 0], "fov": 60}]))
    return path, cameras


def _cull(run, street, out, *extra):
    scene, cameras = street
    return run("cull", scene, "--path", cameras, "--occluders", "wall", "--methods",
               "aabb-skins", "--frusta-method", "aabb-skins", "--width", 64, "--height", 36,
               "--out", out, "--quiet", *extra)


def test_cull_writes_a_page_that_leads_with_the_intervals(run, street, tmp_path, capsys):
    out = tmp_path / "out"
    assert _cull(run, street, out) == 0, capsys.readouterr().err
    doc = json.loads((out / "cull.json").read_text())
    html = (out / "report.html").read_text(encoding="utf-8")
    page = _parse(html)
    assert page.external == []  # opens offline: nothing from elsewhere, no script
    assert page.ids.index("answer") < page.ids.index("walk") < page.ids.index("frames")
    runtimes = list(doc["totals"])
    assert page.rows == {"runtime": len(runtimes), "truth": 1}
    for name, t in doc["totals"].items():  # every share with its interval, as cull.json
        assert f"<td>{name}</td>" in html
        assert format_interval(t["culled_share_ci"]) in html
    assert format_interval(doc["ground_truth"]["hidden_share_ci"]) in html
    assert f"blocks of {doc['intervals']['block']} consecutive frames" in html
    # resampled from the bootstrap's own stream of --seed, recorded in cull.json
    assert doc["intervals"]["seed"] == stream_seed(0, "bootstrap")
    assert doc["intervals"]["stream"] == "bootstrap" and doc["seed"] == 0
    # the plan, each frame per runtime, the triangles: named to be cited
    names = set(page.figures)
    assert {"street-plan", "street-triangles"} <= names
    frames = {n for n in names if "-frame-" in n}
    assert frames == {cite_name("street", f"frame-{f:03d}", r) for f in (0, 1)
                      for r in runtimes}
    for name in frames:
        assert _pixels(page.figures[name]).shape == (round(FRAME_WIDTH * 36 / 64),
                                                     FRAME_WIDTH, 3)
    # frame 0: the wall hides the box; the frusta cull it (drawn green through the wall),
    # 'none' does not (orange), and nobody culled the visible wall (no red)
    culled = _pixels(page.figures["street-frame-000-solid-frusta"])
    kept = _pixels(page.figures["street-frame-000-none"])
    assert doc["frames"][0]["solid-frusta"]["culled"] == 1
    assert _greenish(culled) > 500 and _orange(culled) == 0
    assert _orange(kept) > 500 and _greenish(kept) == 0
    assert _red(culled) == 0 and _red(kept) == 0


def test_cull_report_frames_picks_the_frames(run, street, tmp_path, capsys):
    out = tmp_path / "out"
    assert _cull(run, street, out, "--report-frames", "1") == 0, capsys.readouterr().err
    page = _parse((out / "report.html").read_text(encoding="utf-8"))
    assert {n.split("-frame-")[1][:3] for n in page.figures if "-frame-" in n} == {"001"}


@pytest.mark.parametrize("text", ["2", "0-5", "x", "1,,", "-1"])
def test_cull_report_frames_bad_exit_2_before_any_work(run, street, tmp_path, capsys, text):
    out = tmp_path / "out"
    assert _cull(run, street, out, "--report-frames", text) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--report-frames" in err[0]
    assert not out.exists()


def test_report_frames():
    assert report_frames(5) == [0, 1, 2, 3, 4]
    many = report_frames(1000)
    assert len(many) == REPORT_FRAMES and many[0] == 0 and many[-1] == 999
    assert np.ptp(np.diff(many)) <= 1  # evenly spread
    assert report_frames(50, "all") == list(range(50))
    assert report_frames(50, " 7, 3-5 ,7") == [3, 4, 5, 7]
    for bad in ("50", "3-2", "a-b", "", "all,1"):
        with pytest.raises(InputError, match="--report-frames"):
            report_frames(50, bad)


def _pose(position, forward):
    return PathCamera(position=np.asarray(position, float), forward=np.asarray(forward, float),
                      up=UP, fov=90.0)


def _cull_all(camera, lower, upper):
    return np.ones(len(lower), dtype=bool)


def test_cull_page_shows_false_culls_in_red_and_flags_the_guarantee():
    objects = load_scene_objects(_street_scene())
    runtimes = {"none": no_culling(), "liar": Runtime(cull=_cull_all, conservative=True)}
    poses = [_pose((0, 1.5, -10), (0, 0, 1)), _pose((0, 1.5, -9), (0, 0, 1))]
    result = simulate_culling(objects, runtimes, poses, width=64, height=36,
                              keep_frames=[0, 1])
    doc = {**result.to_json(seed=3), "seed": 3, "provenance": {"viscore": "test"}}
    html = cull_report_html(result, objects, runtimes, doc, scene="street",
                            frames=[0]).decode()
    page = _parse(html)
    liar = _pixels(page.figures["street-frame-000-liar"])
    assert _red(liar) > 0.2 * liar.shape[0] * liar.shape[1]  # the wall and ground, culled
    assert _red(_pixels(page.figures["street-frame-000-none"])) == 0
    # the liar's row: its false culls and its guarantee marked bad
    names = list(runtimes)
    assert "bad" in page.cells["runtime"][names.index("liar")][3]
    assert "bad" not in page.cells["runtime"][names.index("none")][3]
    with pytest.raises(InputError, match="kept"):
        cull_report_html(result, objects, runtimes, doc, scene="street", frames=[1, 5])


def test_occlude_writes_preview_and_page(run, street, tmp_path, capsys):
    scene, _ = street
    out = tmp_path / "occ"
    code = run("occlude", scene, "-o", out, "--methods", "bbox,aabb-skins", "--quiet")
    assert code == 0, capsys.readouterr().err
    manifest = json.loads((out / "occlude.json").read_text())
    preview = np.asarray(Image.open(out / "preview.png").convert("RGB")).astype(int)
    assert preview.shape[1] > 2 * 480 and _orange(preview) > 1000  # two methods' occluders
    page = _parse((out / "report.html").read_text(encoding="utf-8"))
    assert page.external == []
    views = {n for n in page.figures if n.startswith("street-")}
    assert views == {f"street-{v}-{m}" for v in ("above", "from_south-west",
                                                   "from_north-east")
                     for m in ("bbox", "aabb-skins")}
    assert page.rows["method"] == 2 and page.rows["object"] == len(manifest["objects"])
    # the pictures show the occluders: orange over the level, none without a method's
    for name in views:
        assert _orange(_pixels(page.figures[name])) > 100, name


def test_render_page_escapes_text():
    html = render_page("base.html.j2", heading="<i>h</i>", lead="a & b")
    assert "&lt;i&gt;h&lt;/i&gt;" in html and "a &amp; b" in html
    assert "<i>" not in html
