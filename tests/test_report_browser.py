"""The cull and occlude pages in headless Chromium: at 1400 px nothing is clipped, every
image loads, and a screenshot shows the plan, the frames and the occluders (slow)."""

import json
import re
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image
from test_report_pages import _greenish, _street_scene  # the same small street

from viscore.cli import cull_cmd
from viscore.cli import main as cli_main


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome", "chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


#: Headless, as root, nothing fetched or written outside the run (a fresh profile each).
_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
          "--disable-background-networking", "--disable-component-update", "--disable-sync",
          "--hide-scrollbars")

#: Measures the page once loaded; the page itself carries no script (a copy gets this one).
_CHECK = """<script>
window.addEventListener("load", function () {
  var imgs = Array.from(document.images);
  var root = document.documentElement;
  var out = document.createElement("pre");
  out.id = "report-check";
  out.textContent = JSON.stringify({
    images: imgs.map(function (i) { return [i.complete, i.naturalWidth]; }),
    shown: imgs.filter(function (i) { return i.offsetWidth > 0; }).map(function (i) {
      var r = i.getBoundingClientRect(); return [r.left, r.right, i.alt]; }),
    viewport: root.clientWidth, page: root.scrollWidth,
    tables: Array.from(document.querySelectorAll("table")).map(function (t) {
      var box = t.parentElement;
      return {width: t.scrollWidth, right: t.getBoundingClientRect().right,
              box: box.clientWidth, boxScroll: box.scrollWidth}; })});
  document.body.appendChild(out);
});
</script>
"""


def _check(chromium, page, tmp_path, width=1400):
    probe = page.with_name("probe.html")
    probe.write_text(page.read_text(encoding="utf-8").replace("</body>", _CHECK + "</body>"),
                     encoding="utf-8")
    dom = subprocess.run([chromium, *_FLAGS, f"--user-data-dir={tmp_path / 'profile'}",
                          f"--window-size={width},1000", "--virtual-time-budget=20000",
                          "--dump-dom", probe.as_uri()],
                         capture_output=True, text=True, timeout=300).stdout
    found = re.search(r'<pre id="report-check">(.*?)</pre>', dom, re.S)
    assert found, dom[-2000:]
    return json.loads(found.group(1))


def _screenshot(chromium, page, tmp_path, height):
    shot = page.with_suffix(".png")
    subprocess.run([chromium, *_FLAGS, f"--user-data-dir={tmp_path / 'profile'}",
                    f"--window-size=1400,{height}", f"--screenshot={shot}", page.as_uri()],
                   capture_output=True, timeout=300, check=True)
    return np.asarray(Image.open(shot).convert("RGB")).astype(int)


def _assert_fits(check):
    assert check["images"] and all(ok and w > 0 for ok, w in check["images"]), check["images"]
    assert check["page"] <= check["viewport"], check  # no horizontal scroll
    for left, right, alt in check["shown"]:
        assert left >= 0 and right <= check["viewport"], alt  # no picture cut off
    for table in check["tables"]:
        assert table["width"] <= table["box"] and table["right"] <= check["viewport"], table


@pytest.mark.slow
@pytest.mark.skipif(_chromium() is None,
                    reason="no chromium binary (Debian: apt-get install chromium)")
def test_cull_and_occlude_pages_in_chromium(tmp_path, monkeypatch):
    if cull_cmd not in cli_main._COMMANDS:
        monkeypatch.setattr(cli_main, "_COMMANDS", [*cli_main._COMMANDS, cull_cmd])
    level = tmp_path / "street.glb"
    level.write_bytes(_street_scene().export(file_type="glb"))
    cameras = tmp_path / "cameras.json"
    cameras.write_text(json.dumps([
        {"position": [0, 1.5, -10], "forward": [0, 0, 1]},
        {"position": [20, 1.5, 5], "forward": [-1, 0, 0], "fov": 60},
        {"position": [-40, 12, -40], "forward": [1, -0.3, 1]}]))
    assert cli_main.main(["cull", str(level), "--path", str(cameras), "--occluders", "wall",
                          "--methods", "aabb-skins", "--frusta-method", "aabb-skins",
                          "--width", "128", "--height", "72", "--out",
                          str(tmp_path / "cull"), "--quiet"]) == 0
    assert cli_main.main(["occlude", str(level), "-o", str(tmp_path / "occ"), "--methods",
                          "bbox,aabb-skins", "--quiet"]) == 0
    chromium = _chromium()
    cull = _check(chromium, tmp_path / "cull" / "report.html", tmp_path)
    # the plan, 3 frames x 4 runtimes (one runtime's shown at a time), the triangles plot
    assert len(cull["images"]) == 1 + 3 * 4 + 1
    assert len(cull["shown"]) == 1 + 3 + 1
    _assert_fits(cull)
    occlude = _check(chromium, tmp_path / "occ" / "report.html", tmp_path)
    assert len(occlude["images"]) == 3 * 2  # three views x two methods
    _assert_fits(occlude)
    # what a user sees on the first screens: the table, the plan with the walk on it and
    # the frames, frame 0 showing the box its wall hides, culled (green through the wall)
    shot = _screenshot(chromium, tmp_path / "cull" / "report.html", tmp_path, 2400)
    assert _greenish(shot) > 300
    walk = (np.abs(shot - np.array([217, 26, 115])).sum(axis=2) < 60).sum()  # _WALK_RGB
    assert walk > 20
