"""``viscore bench walks``: where each level's walk stands, and culling along it.

Figures, never timings: a closed room whose walk must stand on every frame, a box
outside it that no camera sees, and refusals before any work.
"""

import json

import numpy as np
import pytest
import trimesh

from viscore.cli.bench.walks import bench_walks, bench_walks_text
from viscore.cli.main import main


def _room_level(path):
    """A closed room 10 x 3 x 10 (floor, roof, four walls, a crate) and a box outside it."""
    parts = {"floor": [[0, -0.2, 0], [10, 0, 10]], "roof": [[0, 3, 0], [10, 3.2, 10]],
             "west": [[-0.2, 0, 0], [0, 3, 10]], "east": [[10, 0, 0], [10.2, 3, 10]],
             "south": [[0, 0, -0.2], [10, 3, 0]], "north": [[0, 0, 10], [10, 3, 10.2]],
             "crate": [[4, 0, 4], [5, 1, 5]], "outside": [[3, 0, 14], [7, 3, 16]]}
    scene = trimesh.Scene()
    for name, b in parts.items():
        scene.add_geometry(trimesh.creation.box(bounds=np.asarray(b, float)),
                           geom_name=name, node_name=name)
    scene.export(path)
    return str(path)


def test_bench_walks_room_every_frame_stands(tmp_path, capsys):
    level = _room_level(tmp_path / "room.glb")
    assert main(["bench", "walks", level, "--frames", "8", "--json", "--quiet"]) == 0
    doc = json.loads(capsys.readouterr().out)
    row = doc["levels"][0]
    assert row["objects"] == 8 and row["objects_rule"] == "nodes" and row["up"] == "y"
    assert row["eye_height"] == 1.7 and row["frames_asked"] == 8
    assert row["standing"] == row["frames"] == 8 and row["dropped"] == 0
    assert "cull" not in row


def test_bench_walks_cull_never_culls_what_is_seen(tmp_path):
    # the box outside the closed room is hidden whenever it is in view: the truth hides
    # something, and no guaranteed runtime culls more than the truth hides
    level = _room_level(tmp_path / "room.glb")
    r = bench_walks([level], frames=6, cull=True, width=160, height=90)
    c = r["levels"][0]["cull"]
    assert 0 < c["hidden_share"] <= 1
    assert c["false_culls_guaranteed"] == 0 and c["best_false_culls"] == 0
    assert c["best_culled_share"] <= c["hidden_share"] + 1e-12
    low, high = c["hidden_share_ci"]
    assert low <= c["hidden_share"] <= high
    if c["best_guaranteed"] is not None:
        assert c["best_over_hidden"] == pytest.approx(c["best_culled_share"]
                                                      / c["hidden_share"])
    text = bench_walks_text(r)
    assert "hidden" in text and "best guaranteed" in text


def test_bench_walks_gap_leaves_the_figures_and_adds_up(tmp_path):
    # the references run beside the runtimes: the level's figures are those without them,
    # no reference is a runtime of the level, and the misses by cause add up to the best
    # runtime's misses (its culled / hidden the same as best_over_hidden)
    level = _room_level(tmp_path / "room.glb")
    plain = bench_walks([level], frames=4, cull=True, width=160, height=90)
    both = bench_walks([level], frames=4, cull=True, width=160, height=90, gap=True)
    a, b = plain["levels"][0]["cull"], both["levels"][0]["cull"]
    assert not any(k.startswith("gap:") for k in b["runtimes"])
    for key in ("hidden_share", "best_guaranteed", "best_culled_share", "best_over_hidden"):
        assert a[key] == b[key]
    assert "gap" not in a and both["settings"]["gap"] is True
    g = b["gap"]
    assert {"gap:own", "gap:own-full"} <= set(g["reference_culled_share"])
    if b["best_guaranteed"] is not None:
        assert sum(g["causes"].values()) == g["hidden"] - g["culled"]
        assert g["hidden"] > 0
        assert g["culled"] / g["hidden"] == pytest.approx(b["best_over_hidden"])


def test_bench_walks_buffer_scale_reaches_every_depth_buffer(tmp_path, monkeypatch):
    # the runtimes and the --gap reference at the runtimes' resolution get the scale asked;
    # the full-resolution references get 1
    import viscore.generators as gens

    seen = []
    real = gens.culling_runtimes

    def spy(*args, **kwargs):
        seen.append(kwargs.get("reduction"))
        return real(*args, **kwargs)

    monkeypatch.setattr(gens, "culling_runtimes", spy)
    level = _room_level(tmp_path / "room.glb")
    r = bench_walks([level], frames=2, cull=True, width=160, height=90, gap=True,
                    buffer_scale=2)
    assert r["settings"]["buffer_scale"] == 2
    assert seen[0] == 2 and seen[1] == 2 and set(seen[2:]) == {1}


@pytest.mark.parametrize("argv, message", [
    (["bench", "walks", "/no/such/level.glb"], "/no/such/level.glb: no such file"),
    (["bench", "walks", "city", "--bounds", "box"], "--bounds: only with --cull"),
    (["bench", "walks", "city", "--gap"], "--gap: only with --cull"),
    (["bench", "walks", "city", "--buffer-scale", "2"], "--buffer-scale: only with --cull"),
    (["bench", "walks", "city", "--cull", "--buffer-scale", "0"], "--buffer-scale"),
    (["bench", "walks", "city", "--cull", "--bounds", "boxes"], "--bounds: expected"),
    (["bench", "walks", "city", "--frames", "0"], "--frames: expected a positive integer"),
    (["bench", "walks", "city", "--eye-height", "-1"], "--eye-height"),
])
def test_bench_walks_refuses_bad_options_before_work(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
