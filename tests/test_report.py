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
from viscore.cli.study.report import write_occluder_glb, write_report

from viscore import InputError

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

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.images.append(a)
        if tag == "a":
            self.links.append(a.get("href"))
        if tag == "tr" and a.get("class"):
            self.rows[a["class"]] = self.rows.get(a["class"], 0) + 1
        for key in ("src", "href"):
            if re.match(r"^(https?:|//)", a.get(key) or ""):
                self.external.append(a[key])
        if tag in ("script", "link", "iframe", "object"):
            self.external.append(tag)

    def handle_data(self, data):
        self.text.append(data)


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
    assert page.rows == {"result": 3, "paired": 1}
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
    assert page.rows == {"result": 3}  # no paired table without paired rows


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
  var out = document.createElement("pre");
  out.id = "report-check";
  out.textContent = JSON.stringify({
    images: imgs.length,
    widths: imgs.map(function (i) { return i.complete ? i.naturalWidth : 0; }),
    results: document.querySelectorAll("tr.result").length});
  document.body.appendChild(out);
});
</script>
"""


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
    # the check runs in a copy: the page itself carries no script
    probe = out / "probe.html"
    probe.write_text(page.read_text().replace("</body>", _CHECK + "</body>"))
    dom = subprocess.run([_chromium(), "--headless", "--no-sandbox", "--disable-gpu",
                          "--virtual-time-budget=10000", "--dump-dom", probe.as_uri()],
                         capture_output=True, text=True, timeout=180).stdout
    found = re.search(r'<pre id="report-check">(.*?)</pre>', dom, re.S)
    assert found, dom[-2000:]
    check = json.loads(found.group(1))
    assert check["images"] == 2
    assert all(w > 0 for w in check["widths"]), check
    assert check["results"] == len(rows)
