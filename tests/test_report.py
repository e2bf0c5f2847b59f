"""viscore.cli.study.report: a self-contained report.html and the occluder .glb."""

import base64
import io
import json
import re
import shutil
import struct
import subprocess
from html.parser import HTMLParser

import numpy as np
import pytest
import trimesh
from PIL import Image

from viscore import InputError
from viscore.cli.study.report import (
    SUMMARY_PRECISION,
    best_at_precision,
    write_occluder_glb,
    write_report,
)

_PNG = b"\x89PNG\r\n\x1a\n"


def _png(path, size=(40, 30), colour=(200, 30, 30)):
    Image.new("RGB", size, colour).save(path, format="PNG")
    return path


def _rows():
    return [
        {"mesh": "fat-torus", "method": "qem", "budget": 64, "triangles": 64, "precision": 0.998,
         "precision_ci": [0.997, 0.999], "recall": 0.92, "recall_ci": [0.90, 0.93],
         "occlusion_measure": 21.7, "occlusion_measure_se": 1.03,
         "violation_upper_bound": 0.21, "seconds": 0.03, "occluder_file": "t__qem.ply"},
        {"mesh": "fat-torus", "method": "bbox", "budget": None, "triangles": 12,
         "precision": 0.90, "precision_ci": [0.87, 0.93], "recall": 1.0, "recall_ci": [1, 1],
         "occlusion_measure": 53.6, "occlusion_measure_se": 3.6,
         "violation_upper_bound": 0.61, "seconds": 0.001},
        {"mesh": "<b>odd & name</b>", "method": "none", "budget": None, "triangles": 0,
         "precision": None, "precision_ci": None, "recall": 0.0, "recall_ci": [0.0, 0.0]},
    ]


def _paired():
    return [{"mesh": "fat-torus", "method": "bbox", "budget": None, "versus": "qem",
             "versus_budget": 64, "recall_diff": 0.08, "recall_diff_ci": [0.065, 0.095],
             "prob_better_recall": 1.0, "precision_diff": -0.097,
             "precision_diff_ci": [-0.124, -0.07], "prob_better_precision": 0.0}]


class _Page(HTMLParser):
    """Tags of interest: images, table rows by class, links, text."""

    def __init__(self):
        super().__init__()
        self.images, self.links, self.rows, self.text = [], [], {}, []
        self.external = []
        self.cells = {}  # row class -> rows -> [text, class] per cell
        self._row = None

    def handle_endtag(self, tag):
        if tag == "tr":
            self._row = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.images.append(a)
        if tag == "a":
            self.links.append(a.get("href"))
        if tag == "tr" and a.get("class"):
            self.rows[a["class"]] = self.rows.get(a["class"], 0) + 1
            self.cells.setdefault(a["class"], []).append([])
            self._row = a["class"]
        if tag == "td" and self._row:
            self.cells[self._row][-1].append(["", a.get("class") or ""])
        for key in ("src", "href"):
            if re.match(r"^(https?:|//)", a.get(key) or ""):
                self.external.append(a[key])
        if tag in ("script", "link", "iframe", "object"):
            self.external.append(tag)

    def handle_data(self, data):
        self.text.append(data)
        if self._row and self.cells[self._row][-1]:
            self.cells[self._row][-1][-1][0] += data


def _parse(path):
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    page.close()
    return page


def _study(tmp_path):
    out = tmp_path / "study"
    (out / "occluders").mkdir(parents=True)
    (out / "occluders" / "t__qem.ply").write_bytes(b"ply")
    _png(out / "a.png")
    _png(tmp_path / "b.png", size=(64, 16))
    return out


def test_write_report_structure(tmp_path):
    out = _study(tmp_path)
    settings = {"protocol": "orbit", "views": 16, "budgets": [64]}
    prov = {"viscore": "0.1.0", "embree": "4.4.0"}
    path = write_report(out, _rows(), paired_rows=_paired(), settings=settings,
                        provenance=prov, images={"recall": "a.png", "other": tmp_path / "b.png"})
    assert path == out / "report.html"
    page = _parse(path)
    assert page.rows == {"summary": 2, "result": 3, "paired": 1}  # 2 meshes, budget 64
    assert len(page.images) == 2
    for img, size in zip(page.images, [(40, 30), (64, 16)], strict=True):
        prefix = "data:image/png;base64,"
        assert img["src"].startswith(prefix)
        data = base64.b64decode(img["src"][len(prefix):], validate=True)
        assert data.startswith(_PNG)
        assert Image.open(io.BytesIO(data)).size == size
    assert [i["alt"] for i in page.images] == ["recall", "other"]
    assert page.external == []  # nothing loaded from outside the page
    assert page.links == ["occluders/t__qem.ply"]  # only files that exist
    text = "".join(page.text)
    assert "<b>odd & name</b>" in text  # escaped, so it reads back as text
    assert "[0.9970, 0.9990]" in text and "orbit" in text and "4.4.0" in text


def test_write_report_deterministic_sequence_images(tmp_path):
    out = _study(tmp_path)
    first = write_report(out, _rows(), images=["a.png"]).read_bytes()
    second = write_report(out, _rows(), images=["a.png"]).read_bytes()
    assert first == second
    page = _parse(out / "report.html")
    assert [i["alt"] for i in page.images] == ["a"]
    assert page.rows == {"summary": 2, "result": 3}  # no paired table without paired rows


def test_write_report_invalid_input(tmp_path):
    out = _study(tmp_path)
    with pytest.raises(InputError, match="rows"):
        write_report(out, [])
    with pytest.raises(InputError, match="no such file"):
        write_report(out, _rows(), images=["missing.png"])
    (out / "fake.png").write_text("not an image")
    with pytest.raises(InputError, match="not a PNG"):
        write_report(out, _rows(), images=["fake.png"])
    with pytest.raises(InputError, match="settings"):
        write_report(out, _rows(), settings=[1, 2])
    assert not (out / "report.html").exists()


def _summary_rows():
    """A hand-made study: two meshes, budgets 64 and 256, every rule of the summary in play."""
    def row(mesh, method, budget, triangles, precision, recall, **extra):
        return {"mesh": mesh, "method": method, "budget": budget, "triangles": triangles,
                "precision": precision, "recall": recall, "recall_ci": [recall - 0.01, recall],
                "violation_upper_bound": 0.01, **extra}

    return [
        row("torus", "qem", 64, 64, 0.996, 0.90),
        row("torus", "planar-sections", 64, 64, 0.994, 0.95),  # best recall, below the floor
        row("torus", "bbox", None, 12, 0.90, 1.0),  # recall 1 but precision 0.9
        row("torus", "aabb-skins", 64, 60, 1.0, 0.90,  # ties qem, fewer triangles
            info={"conservative_guaranteed": True}),
        row("torus", "godot", None, 200, 0.9999, 0.97),  # over 64; competes at 256
        row("torus", "qem", 256, 256, 0.9995, 0.96),
        row("torus", "planar-sections", 256, 256, SUMMARY_PRECISION, 0.965),  # exactly at it
        row("torus", "aabb-skins", 256, 300, 1.0, 0.99,  # over its budget: does not compete
            info={"conservative_guaranteed": True, "over_budget": True}),
        row("torus", "nameless", 256, 100, None, 0.999),  # precision undefined
        row("house", "qem", 64, 64, 0.99, 0.80),
        row("house", "bbox", None, 12, 0.95, 1.0),
        row("house", "hybrid", 256, 250, 0.999, 0.70, info={"conservative_guaranteed": False}),
        row("house", "mystery", 256, 250, 0.999, 0.70),  # a tie with a method nobody knows
    ]


def test_best_at_precision_rules():
    rows = _summary_rows()
    summary = best_at_precision(rows, budgets=[256, 64])
    got = {(e["mesh"], e["budget"]): (e["method"], e.get("recall"), e.get("guaranteed"))
           for e in summary}
    assert list(got) == [("torus", 64), ("torus", 256), ("house", 64), ("house", 256)]
    # tie at 0.90 between qem (64 tris) and aabb-skins (60): both, fewest triangles first
    assert got["torus", 64] == ("aabb-skins = qem", 0.90, "yes / no")
    # godot (no budget, 200 tris) beats qem and planar-sections at 256; aabb-skins is over
    assert got["torus", 256] == ("godot", 0.97, "no")
    assert summary[1]["candidates"] == 5  # godot, bbox, qem, planar-sections, nameless
    assert got["house", 64][0] is None and summary[2]["winners"] == []
    assert got["house", 256] == ("hybrid = mystery", 0.70, "no / unknown")
    # brute force: the named methods are exactly the highest recall of the qualifiers
    for e in summary:
        pool = [r for r in rows if r["mesh"] == e["mesh"]
                and r["budget"] in (None, e["budget"]) and r["triangles"] <= e["budget"]
                and r["precision"] is not None and r["precision"] >= SUMMARY_PRECISION]
        top = max((r["recall"] for r in pool), default=None)
        assert {rows[i]["method"] for i in e["winners"]} == {
            r["method"] for r in pool if r["recall"] == top}


def test_best_at_precision_without_budgets():
    rows = [{"mesh": "m", "method": "a", "budget": None, "triangles": 10, "precision": 1.0,
             "recall": 0.5}, {"mesh": "m", "method": "b", "budget": None, "triangles": 9000,
                              "precision": 0.999, "recall": 0.7}]
    summary = best_at_precision(rows)  # no budget anywhere: one group, all rows compete
    assert [(e["budget"], e["method"]) for e in summary] == [(None, "b")]
    assert best_at_precision(rows, precision=0.9995)[0]["method"] == "a"


def test_write_report_summary_names_a_method_per_mesh_and_budget(tmp_path):
    rows = _summary_rows()
    page = _parse(write_report(tmp_path, rows, settings={"budgets": [64, 256]}))
    summary = [[text for text, _ in cells] for cells in page.cells["summary"]]
    assert [(r[0], r[1], r[2]) for r in summary] == [
        ("torus", "64", "aabb-skins = qem"), ("torus", "256", "godot"),
        ("house", "64", "none reaches precision 0.995 (2 eligible results)"),
        ("house", "256", "hybrid = mystery")]
    assert summary[1][7] == "no" and summary[0][7] == "yes / no"
    html = (tmp_path / "report.html").read_text()
    assert html.index('id="summary"') < html.index('id="results"')  # the page leads with it
    # best values marked in the results table: method and recall of each winner, only those
    marked = [(cells[1][0], cells[2][0]) for cells in page.cells["result"]
              if any("best" in cls for _, cls in cells)]
    assert sorted(marked) == [("aabb-skins", "64"), ("godot", "-"), ("hybrid", "256"),
                              ("mystery", "256"), ("qem", "64")]
    for cells in page.cells["result"]:
        best = [k for k, (_, cls) in enumerate(cells) if "best" in cls]
        assert best in ([], [1, 6])  # method and recall columns


def _glb_json(path):
    data = path.read_bytes()
    assert data[:4] == b"glTF"
    length, kind = struct.unpack("<I4s", data[12:20])
    assert kind == b"JSON"
    return json.loads(data[20:20 + length])


def test_write_occluder_glb_round_trip(tmp_path):
    original = trimesh.creation.icosphere(subdivisions=2)
    occluder = trimesh.creation.box(extents=(1.2, 1.2, 1.2))
    before = original.vertices.copy()
    path = write_occluder_glb(original, occluder, tmp_path / "occ.glb")
    assert np.array_equal(original.vertices, before)  # inputs untouched
    scene = trimesh.load(path)
    assert isinstance(scene, trimesh.Scene)
    assert len(scene.geometry) == 2
    orig, occ = scene.geometry["original"], scene.geometry["occluder"]
    assert len(orig.faces) == len(original.faces) == 320
    assert len(occ.faces) == len(occluder.faces) == 12
    assert np.allclose(occ.bounds, occluder.bounds, atol=1e-6)
    assert orig.visual.material.alphaMode == "BLEND"
    assert occ.visual.material.alphaMode == "OPAQUE"
    assert orig.visual.material.baseColorFactor[3] < 128  # translucent
    assert occ.visual.material.baseColorFactor[3] == 255
    doc = _glb_json(path)  # the file itself, independent of trimesh's loader
    modes = {m["name"]: m["alphaMode"] for m in doc["materials"]}
    assert modes == {"original": "BLEND", "occluder": "OPAQUE"}


def test_write_occluder_glb_invalid_input(tmp_path):
    box = trimesh.creation.box()
    with pytest.raises(InputError, match=r"\.glb"):
        write_occluder_glb(box, box, tmp_path / "occ.ply")
    empty = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=int))
    with pytest.raises(InputError, match="occluder"):
        write_occluder_glb(box, empty, tmp_path / "occ.glb")
    with pytest.raises(InputError, match="original"):
        write_occluder_glb("box", box, tmp_path / "occ.glb")
    assert not (tmp_path / "occ.glb").exists()


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome", "chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


_CHECK = """<script>
window.addEventListener("load", function () {
  var imgs = Array.from(document.images);
  var root = document.documentElement;
  var out = document.createElement("pre");
  out.id = "report-check";
  out.textContent = JSON.stringify({
    images: imgs.length,
    widths: imgs.map(function (i) { return i.complete ? i.naturalWidth : 0; }),
    results: document.querySelectorAll("tr.result").length,
    viewport: root.clientWidth,
    page: root.scrollWidth,
    tables: Array.from(document.querySelectorAll("table")).map(function (t) {
      var box = t.parentElement;
      return {cls: t.className, width: t.scrollWidth, right: t.getBoundingClientRect().right,
              box: box.clientWidth, boxScroll: box.scrollWidth};
    }),
    summary: Array.from(document.querySelectorAll("tr.summary")).map(function (r) {
      return Array.from(r.cells).slice(0, 3).map(function (c) { return c.textContent; });
    })});
  document.body.appendChild(out);
});
</script>
"""

#: Chromium's flags: headless, as root, nothing fetched or written outside the run.
_CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu",
                   "--disable-background-networking", "--disable-component-update",
                   "--disable-sync", "--no-first-run")

_EIGHT = ("aabb-skins", "planar-sections", "hybrid", "solid-frusta", "qem", "godot", "bbox",
          "original")


def _default_study_rows():
    """39 rows shaped as the default study's: 3 meshes, 8 methods, budgets 64 and 256."""
    rng = np.random.default_rng(0)
    rows = []
    for mesh in ("fat-torus", "bunny", "building-house"):
        for method in _EIGHT:
            budgeted = method not in ("godot", "bbox", "original")
            for budget in ((64, 256) if budgeted else (None,)):
                if len([r for r in rows if r["mesh"] == mesh]) == 13:
                    break
                p = float(rng.uniform(0.99, 1.0))
                r = float(rng.uniform(0.5, 0.999))
                rows.append({
                    "mesh": mesh, "method": method, "budget": budget,
                    "triangles": budget or int(rng.integers(12, 3000)),
                    "precision": p, "precision_ci": [p - 0.0012345, min(1.0, p + 0.0012345)],
                    "recall": r, "recall_ci": [r - 0.0123456, r + 0.0123456],
                    "occlusion_measure": float(rng.uniform(10, 60)),
                    "occlusion_measure_se": float(rng.uniform(0.5, 4)),
                    "violation_upper_bound": float(rng.uniform(0, 0.7)),
                    "seconds": float(rng.uniform(0, 300)),
                    "occluder_file": f"{mesh}__{method}__{budget}__0123abcd.ply",
                    "per_view": {"recall": rng.uniform(0.4, 1.0, 16).tolist()}})
    return rows


def _dom(page, out, width=1400):
    """The page's DOM after the measuring script ran, at ``width`` pixels of window."""
    probe = out / "probe.html"  # the check runs in a copy: the page itself carries no script
    probe.write_text(page.read_text().replace("</body>", _CHECK + "</body>"))
    dom = subprocess.run([_chromium(), *_CHROMIUM_FLAGS, f"--user-data-dir={out / 'chrome'}",
                          f"--window-size={width},1000", "--virtual-time-budget=10000",
                          "--dump-dom", probe.as_uri()],
                         capture_output=True, text=True, timeout=180).stdout
    found = re.search(r'<pre id="report-check">(.*?)</pre>', dom, re.S)
    assert found, dom[-2000:]
    return json.loads(found.group(1))


@pytest.mark.slow
@pytest.mark.skipif(_chromium() is None,
                    reason="no chromium binary (Debian: apt-get install chromium)")
def test_write_report_loads_in_headless_chromium(tmp_path):
    from viscore.metrics.plots import budget_plot, recall_plot

    out = _study(tmp_path)
    rows = _rows()[:2]
    for r in rows:
        r["per_view"] = {"recall": [0.5, 0.7, 0.9, None]}
    recall_plot(rows, out / "recall.png")
    budget_plot(rows, out / "budget.png")
    page = write_report(out, rows, paired_rows=_paired(), settings={"views": 16},
                        images={"recall": "recall.png", "budget": "budget.png"})
    check = _dom(page, out)
    assert check["images"] == 2
    assert all(w > 0 for w in check["widths"]), check
    assert check["results"] == len(rows)


@pytest.mark.slow
@pytest.mark.skipif(_chromium() is None,
                    reason="no chromium binary (Debian: apt-get install chromium)")
def test_write_report_default_study_fits_1400_px(tmp_path):
    """A default-sized study at 1400 px: no table clipped or scrolled, a summary row each."""
    rows = _default_study_rows()
    assert len(rows) == 39
    out = tmp_path / "study"
    out.mkdir()
    page = write_report(out, rows, settings={"protocol": "orbit", "budgets": [64, 256]},
                        provenance={"viscore": "0.1.0"})
    check = _dom(page, out)
    assert check["results"] == 39
    assert check["page"] <= check["viewport"], check  # no horizontal scroll of the page
    for table in check["tables"]:
        assert table["width"] <= table["box"] and table["boxScroll"] <= table["box"], table
        assert table["right"] <= check["viewport"], table  # nothing cut at the right edge
    expected = {(r["mesh"], str(r["budget"])) for r in rows if r["budget"]}
    named = {(m, b): method for m, b, method in check["summary"]}
    assert set(named) == expected
    methods = set(_EIGHT)
    for method in named.values():  # a method (or tied methods) named for every pair
        assert method and set(method.split(" = ")) <= methods, named
