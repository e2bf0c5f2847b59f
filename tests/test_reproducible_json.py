"""The same command and seed give bit-identical JSON: across runs and across ``--workers``.

``generate --json`` (bbox, qem, aabb-skins, godot on a small scene of loose,
open parts, so that aabb-skins takes the multi-threaded ray-parity path) and
``uncertainty --json`` (tiny settings, with a paired ``--versus`` occluder),
each run with ``--workers 1``, with ``--workers 2`` (forced, so that even a
one-CPU runner compares one thread with two) and with the default worker
count; the provenance must show 1, 2 and the default. The
written occluder files are compared byte for byte too. Excluded from the
comparison: wall-clock times (``seconds`` and keys starting ``seconds_``) and
``provenance`` (it records the worker count, which differs by design).
``measure``, ``evaluate`` and ``validate`` are covered in
``tests/test_cli_metrics.py``, ``compare`` in ``tests/test_compare_robustness.py``.
"""

from __future__ import annotations

import contextlib
import io
import json

import pytest

from viscore import load_mesh
from viscore.cli.main import main
from viscore.generators import generate

#: The worker settings of the three runs: one thread, two threads, then the default.
WORKERS = (["--workers", "1"], ["--workers", "2"], [])


def _comparable(doc):
    if isinstance(doc, dict):
        return {k: _comparable(v) for k, v in doc.items()
                if k != "provenance" and k != "seconds" and not k.startswith("seconds_")}
    if isinstance(doc, list):
        return [_comparable(v) for v in doc]
    return doc


def _run(argv: list[str]) -> dict:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(argv)
    assert rc == 0, err.getvalue()
    return json.loads(out.getvalue())


def _assert_identical(docs: list[dict]) -> None:
    from viscore import cpu_cores

    # the runs really had one thread, two threads, and one per core
    assert [d["provenance"]["workers"] for d in docs] == [1, 2, cpu_cores()]
    first = json.dumps(_comparable(docs[0]), sort_keys=True)
    for other in docs[1:]:
        assert json.dumps(_comparable(other), sort_keys=True) == first


@pytest.mark.parametrize("method, options", [
    ("bbox", []), ("qem", ["--budget", "64"]), ("godot", []),
    ("aabb-skins", ["--voxels", "24", "--max-boxes", "8"]),
])
def test_generate_json_bit_identical(tmp_path, method, options):
    out = tmp_path / f"{method}.ply"
    docs, files = [], []
    for workers in WORKERS:
        docs.append(_run([*workers, "generate", method, "city-block", "-o", str(out), *options,
                          "--seed", "12345", "--json", "--quiet"]))
        files.append(out.read_bytes())
    _assert_identical(docs)
    assert "seconds" in docs[0] and docs[0]["triangles"] > 0  # the exclusion names a field
    assert files[1] == files[0] and files[2] == files[0]
    if method == "aabb-skins":  # open parts: candidates from ray-parity votes (all workers)
        assert docs[0]["inside"] == "ray-parity"


def test_uncertainty_json_bit_identical(tmp_path):
    mesh = load_mesh("fat-torus")
    occluder, versus = tmp_path / "qem.ply", tmp_path / "bbox.ply"
    generate("qem", mesh, budget=64).mesh.export(occluder)
    generate("bbox", mesh).mesh.export(versus)
    docs = []
    for workers in WORKERS:
        docs.append(_run([*workers, "uncertainty", "fat-torus", str(occluder), "--versus",
                          str(versus), "--views", "6", "--quads", "400", "--res", "32",
                          "--directions", "4", "--steps", "200", "--seed", "12345",
                          "--out", str(tmp_path / "out"), "--json", "--quiet"]))
    _assert_identical(docs)
    doc = docs[0]
    assert 0 < doc["recall"] < 1 and doc["paired"]["versus"] == str(versus)
    assert doc["bayes"]["recall"]["steps"] == 200  # the Beta models ran and are compared
