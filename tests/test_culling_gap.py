"""``metrics.culling_gap``: the misses of a runtime sorted by cause, on a hand-built result
(``bench walks --gap`` on a level: tests/test_bench_walks.py)."""

import numpy as np
import pytest

from viscore import InputError
from viscore.metrics.camera_paths import PathCamera
from viscore.metrics.culling import CullingResult, FrameObjects, RuntimeFrames
from viscore.metrics.culling_gap import GAP_CAUSES, SUBPIXEL_PIXELS, culling_gap

# one camera at the origin looking down +z, 90 degrees across 100 pixels: a focal
# length of 50 pixels, so a box of diagonal d whose nearest point is 10 away spans 5 d
WIDTH = 100
DIST = 10.0


def _box(diag: float) -> tuple[np.ndarray, np.ndarray]:
    """A cube of diagonal ``diag`` whose nearest face is DIST ahead of the camera."""
    side = diag / np.sqrt(3)
    lo = np.array([-side / 2, -side / 2, DIST])
    return lo, lo + side


def _result(culled: dict, diags: list[float]) -> tuple[CullingResult, np.ndarray, np.ndarray]:
    n = len(diags)
    lower, upper = map(np.array, zip(*[_box(d) for d in diags], strict=True))
    one = np.zeros(1, dtype=np.int64)
    runtimes = {k: RuntimeFrames(culled=one + len(v), false_culls=one, triangles_rendered=one,
                                 overhead_ms=np.zeros(1), conservative=True)
                for k, v in culled.items()}
    kept = {0: FrameObjects(in_view=np.arange(n), visible=np.array([0]),
                            culled={k: np.array(sorted(v), dtype=np.int64)
                                    for k, v in culled.items()})}
    cam = PathCamera(position=np.zeros(3), forward=np.array([0, 0, 1.0]),
                     up=np.array([0, 1.0, 0]), fov=90.0)
    result = CullingResult(cameras=(cam,), width=WIDTH, height=50, objects=n, triangles=12 * n,
                           in_view=one + n, in_view_triangles=one + 12 * n, visible=one + 1,
                           visible_triangles=one + 12, runtimes=runtimes, kept=kept)
    return result, lower, upper


def test_culling_gap_each_cause_once():
    # object 0 is seen; 1 the runtime culls; 2 only the own triangles (and every reference);
    # 3 only at full resolution; 4 only every object's triangles; 5 (5 pixels) and 6
    # (0.5 pixels) nothing culls
    culled = {"best": {1}, "own": {1, 2}, "own-full": {1, 2, 3},
              "every-full": {1, 2, 3, 4}}
    result, lower, upper = _result(culled, [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.1])
    names = [f"o{i}" for i in range(7)]
    gap = culling_gap(result, lower, upper, names, "best", own="own", own_full="own-full",
                      every_full="every-full")
    assert gap.hidden == 6 and gap.culled == 1
    assert gap.causes == {"occluders": 1, "resolution": 1, "unchosen": 1, "subpixel": 1,
                          "unexplained": 1}
    assert gap.objects["occluders"] == [("o2", 1)] and gap.objects["subpixel"] == [("o6", 1)]
    assert gap.objects["unexplained"] == [("o5", 1)]
    doc = gap.to_json()
    assert sum(doc["causes"].values()) == doc["hidden"] - doc["culled"]
    assert list(doc["causes"]) == list(GAP_CAUSES)


@pytest.mark.parametrize("pixels, cause", [(0.9 * SUBPIXEL_PIXELS, "subpixel"),
                                           (1.1 * SUBPIXEL_PIXELS, "unexplained")])
def test_culling_gap_subpixel_by_the_focal_length(pixels, cause):
    # a box spanning just under / over the threshold at the camera's focal length of 50
    # pixels (half the width over tan 45 degrees)
    culled = {"best": set(), "own": set(), "own-full": set()}
    result, lower, upper = _result(culled, [1.0, pixels * DIST / (WIDTH / 2)])
    gap = culling_gap(result, lower, upper, ["seen", "far"], "best", own="own",
                      own_full="own-full")
    assert gap.causes[cause] == 1 and sum(gap.causes.values()) == 1


def test_culling_gap_without_every_full_unchosen_is_never_given():
    # every object an occluder: own-full stands for every object's triangles, and what it
    # culls is a resolution miss
    culled = {"best": set(), "own": set(), "own-full": {1}}
    result, lower, upper = _result(culled, [1.0, 1.0])
    gap = culling_gap(result, lower, upper, ["a", "b"], "best", own="own", own_full="own-full")
    assert gap.causes["resolution"] == 1 and gap.causes["unchosen"] == 0


def test_culling_gap_invalid_input():
    culled = {"best": set(), "own": set(), "own-full": set()}
    result, lower, upper = _result(culled, [1.0, 1.0])
    with pytest.raises(InputError, match="no runtime 'nope'"):
        culling_gap(result, lower, upper, ["a", "b"], "nope", own="own", own_full="own-full")
    with pytest.raises(InputError, match="2 boxes and names"):
        culling_gap(result, lower, upper, ["a"], "best", own="own", own_full="own-full")
    bare = CullingResult(**{**result.__dict__, "kept": {}})
    with pytest.raises(InputError, match="frame 0 were not kept"):
        culling_gap(bare, lower, upper, ["a", "b"], "best", own="own", own_full="own-full")
