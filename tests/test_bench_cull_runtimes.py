"""bench_cull_runtimes: structure and the invariants it reports (no timing assertions)."""

import numpy as np
import pytest

from viscore import InputError
from viscore.cli.bench.cull_runtimes import KEYS, bench_city, bench_cull_runtimes


def test_bench_cull_runtimes_small_run():
    res = bench_cull_runtimes(frames=3, occludees=200, width=64, height=36, blocks=4)
    for key in KEYS:
        assert res[key]["best_ms"] > 0 and res[key]["median_ms"] >= res[key]["best_ms"]
    for share in (*res["culled_share"].values(), *res["culled_share_in_view"].values()):
        assert 0.0 <= share <= 1.0
    assert res["frames_solid_below_planar"]["frusta_solid_exact"] == 0
    assert res["workers"] == 1 and res["buffer"] == [64, 36]
    rays = res["depth_buffer_rays"]
    assert rays["corners"] == 65 * 37
    assert 0 < rays["median"] <= rays["max"] <= 65 * 49  # tiles of 16 pad 36 rows to 48


def test_bench_city_shapes():
    solids, lo, hi = bench_city(occludees=10, blocks=3, seed=3)
    assert 9 <= len(solids) <= 27 and lo.shape == hi.shape == (10, 3)
    assert (hi > lo).all() and np.allclose(lo[:, 2], 0)


def test_bench_cull_runtimes_invalid_input():
    with pytest.raises(InputError, match="frames"):
        bench_cull_runtimes(frames=0)
    with pytest.raises(InputError, match="occludees"):
        bench_city(occludees=0)
