"""Hostile input, third round (issue 46, items 5, 10, 12, 13): plugins cannot take the
command line down while they are imported.

A plugin here is a real installed distribution as far as ``importlib.metadata`` can
tell: a module and a ``.dist-info`` folder (``METADATA``, ``entry_points.txt``) on
``PYTHONPATH``, read by a child ``viscore`` process (discovery runs once per
process). A plugin that hangs is tried in-process instead, with the import bounds
shortened (:data:`viscore.generators.plugins.IMPORT_WARN_SECONDS`), through fake
entry points as in ``tests/test_plugins.py``.
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import os
import signal
import subprocess
import sys
import time
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest

from viscore.cli import main as cli_main
from viscore.generators import REGISTRY, plugins, registry

#: Wall-clock guard of one child command (a hang fails the test, not the suite).
TIMEOUT = 600

_PLUGIN = '''
import os, sys, time
mode = os.environ.get("VC_HOSTILE_PLUGIN", "")
if mode == "print":
    print("hello from a plugin at import")
elif mode == "exit":
    sys.exit(0)
elif mode == "interrupt":
    raise KeyboardInterrupt
elif mode == "hang":
    open(os.environ["VC_HOSTILE_READY"], "w").close()
    time.sleep(3600)


def hostile(mesh, *, budget=None, seed=0):
    return mesh.copy()
'''


@pytest.fixture
def installed(tmp_path):
    """A distribution ``vc-hostile 1.0`` with the method ``hostile`` on ``PYTHONPATH``."""
    site = tmp_path / "site"
    site.mkdir()
    (site / "vc_hostile_plugin.py").write_text(_PLUGIN)
    info = site / "vc_hostile-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: vc-hostile\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(
        "[viscore.generators]\nhostile = vc_hostile_plugin:hostile\n")
    return site


def _env(site: Path, mode: str, **extra: str) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "VISCORE_NO_PLUGINS"}
    path = os.pathsep.join([str(site), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return {**env, "PYTHONPATH": path, "VC_HOSTILE_PLUGIN": mode, **extra}


def _viscore(site: Path, mode: str, *argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "viscore.cli.main", *argv],
                          env=_env(site, mode), capture_output=True, text=True,
                          timeout=TIMEOUT)


def test_plugin_is_discovered_as_installed(installed):
    """The fixture is a real plugin: a quiet one is listed among the methods."""
    proc = _viscore(installed, "", "generate", "--help")
    assert proc.returncode == 0, proc.stderr
    assert "hostile" in proc.stdout


def test_plugin_printing_at_import_keeps_json_clean(installed):
    """Item 13: what a plugin prints while imported goes to stderr; stdout is the JSON."""
    proc = _viscore(installed, "print", "data", "list", "--json")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert "fat-torus" in {s["name"] for s in doc["scenes"]}
    assert "hello from a plugin at import" in proc.stderr


def test_plugin_exiting_at_import_is_left_out(installed, tmp_path):
    """Item 12: ``sys.exit(0)`` at import made every command exit 0 silently; the plugin is
    left out with one warning line and the command does its work."""
    out = tmp_path / "x.ply"
    proc = _viscore(installed, "exit", "generate", "aabb-skins", "fat-torus", "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    assert out.is_file() and out.stat().st_size > 0
    said = [line for line in proc.stderr.splitlines() if "'hostile'" in line]
    assert said == ["viscore: plugin 'hostile' (vc-hostile 1.0, vc_hostile_plugin:hostile): "
                    "its import called sys.exit(0); left out"]


def test_plugin_raising_keyboard_interrupt_at_import_is_left_out(installed):
    """Item 10: a plugin's own KeyboardInterrupt at import: a warning, not a traceback on
    every command."""
    proc = _viscore(installed, "interrupt", "data", "list", "--json")
    assert proc.returncode == 0, proc.stderr
    json.loads(proc.stdout)
    assert "Traceback" not in proc.stderr
    assert "its import raised KeyboardInterrupt; left out" in proc.stderr


def test_ctrl_c_while_a_plugin_imports_is_an_interruption(installed, tmp_path):
    """Item 10: a real Ctrl-C while plugins import: exit 130, one line, no traceback."""
    ready = tmp_path / "importing"
    proc = subprocess.Popen([sys.executable, "-m", "viscore.cli.main", "data", "list"],
                            env=_env(installed, "hang", VC_HOSTILE_READY=str(ready)),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + TIMEOUT
        while not ready.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)
        assert ready.exists(), "the plugin's import never started"
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=TIMEOUT)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == "viscore: interrupted"


def test_interrupt_while_the_parser_is_built_is_one_line(monkeypatch):
    """Item 10: ``build_parser`` (plugin discovery) runs inside main's handling."""
    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_main, "build_parser", interrupted)
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert cli_main.main(["data", "list"]) == 130
    assert err.getvalue() == "viscore: interrupted\n"


@pytest.fixture
def hanging_plugin(tmp_path, monkeypatch):
    """A plugin whose import sleeps, on fake entry points; the bounds shortened."""
    name = f"vc_hanging_{abs(hash(tmp_path)) % 10**8}"
    (tmp_path / f"{name}.py").write_text("import time\ntime.sleep(60)\n"
                                         "def m(mesh, *, budget=None, seed=0):\n"
                                         "    return mesh.copy()\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delenv("VISCORE_NO_PLUGINS", raising=False)
    monkeypatch.setattr(plugins, "IMPORT_WARN_SECONDS", 0.3)
    monkeypatch.setattr(plugins, "IMPORT_LIMIT_SECONDS", 1.0)
    eps = [EntryPoint(name="hanging", value=f"{name}:m", group=registry.PLUGIN_GROUP)]
    monkeypatch.setattr(plugins, "_entry_points", lambda: eps)
    saved = (dict(REGISTRY._specs), REGISTRY._state)
    REGISTRY._rediscover()
    yield
    REGISTRY._specs, REGISTRY._state = saved
    sys.modules.pop(name, None)


def test_plugin_hanging_at_import_is_bounded(hanging_plugin, caplog):
    """Items 5 and 13: an import that hangs is said after IMPORT_WARN_SECONDS, naming
    VISCORE_NO_PLUGINS, and left out after IMPORT_LIMIT_SECONDS; the toolkit's methods
    stay."""
    alarm = signal.getsignal(signal.SIGALRM)
    with caplog.at_level(logging.WARNING):
        names = list(REGISTRY)
    assert "hanging" not in names and "bbox" in names
    lines = [r.getMessage() for r in caplog.records if r.name == plugins.__name__]
    assert len(lines) == 2, lines
    assert "is still importing after 0.3 s" in lines[0] and "VISCORE_NO_PLUGINS=1" in lines[0]
    assert "did not finish in 1 s" in lines[1] and lines[1].endswith("left out")
    # the timer and the handlers are as they were
    assert signal.getsignal(signal.SIGALRM) == alarm
    assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
