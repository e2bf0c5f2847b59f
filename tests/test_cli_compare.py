import json
import sqlite3

from cli.main import main


def test_compare_writes_outputs_and_resumes(tmp_path, capsys):
    out = tmp_path / "study"
    argv = ["compare", "buildings", "--methods", "original,bbox", "--views", "4", "--quads",
            "500", "--res", "32", "--rays", "2000", "--out", str(out), "--json"]
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    rows = {r["method"]: r for r in doc["rows"]}
    assert rows["original"]["precision"] == 1.0 and rows["original"]["recall"] == 1.0
    assert rows["bbox"]["triangles"] == 12 and rows["bbox"]["recall"] == 1.0
    for name in ("results.csv", "results.json", "results.md", "recall.png", "results.sqlite"):
        assert (out / name).is_file()
    # a re-run resumes: the stored rows are reused unchanged, none added
    with sqlite3.connect(out / "results.sqlite") as db:
        before = db.execute("SELECT key, row FROM results ORDER BY key").fetchall()
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    with sqlite3.connect(out / "results.sqlite") as db:
        after = db.execute("SELECT key, row FROM results ORDER BY key").fetchall()
    assert before == after and len(after) == 2
    assert again["rows"] == doc["rows"]


def test_compare_unknown_method_exit_2(tmp_path, capsys):
    assert main(["compare", "cow", "--methods", "magic", "--out", str(tmp_path)]) == 2
    assert "magic" in capsys.readouterr().err
