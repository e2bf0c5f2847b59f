"""Kernels compiled before a study forks: the helper's steps run in another process, and
the prepared signatures are the ones the callers use (a call compiles nothing new)."""

import os

import numpy as np
import pytest
import trimesh

from viscore import Scene
from viscore._jobs import compile_ahead
from viscore.generators._kernels import _ray_kernels


def _note(path, what):
    with open(path, "a") as fh:
        fh.write(f"{what} {os.getpid()}\n")


def test_compile_ahead_runs_beside_in_a_helper_then_here(tmp_path):
    log = tmp_path / "log"
    compile_ahead([lambda: _note(log, "here")], [lambda: _note(log, "beside")])
    lines = [line.split() for line in log.read_text().splitlines()]
    me = str(os.getpid())
    assert ["here", me] in lines and ["beside", me] in lines
    helper = [pid for what, pid in lines if what == "beside" and pid != me]
    assert len(helper) == 1 and len(lines) == 3
    assert lines[-1] == ["beside", me]  # here again after the helper ended


def test_compile_ahead_stops_the_helper_when_a_step_fails(tmp_path):
    log = tmp_path / "log"

    def fail():
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        compile_ahead([fail], [lambda: _note(log, "beside")])
    assert not log.exists() or str(os.getpid()) not in log.read_text()


def _versions(kernel) -> int:
    return len(getattr(kernel, "signatures", ()))


@pytest.mark.skipif(os.environ.get("NUMBA_DISABLE_JIT") == "1", reason="kernels not compiled")
def test_ray_kernels_prepared_are_those_a_scene_uses():
    from viscore.ray import _embree4

    _ray_kernels()
    before = _versions(_embree4._mark_stacked)
    assert before >= 1
    scene = Scene(trimesh.creation.box())
    o = np.tile([0.1, 0.2, -5.0], (64, 1))
    d = np.tile([0.0, 0.0, 1.0], (64, 1))
    t, tri = scene.first_hit(o, d)
    assert np.allclose(t, 4.5) and (tri >= 0).all()
    assert _versions(_embree4._mark_stacked) == before


@pytest.mark.skipif(os.environ.get("NUMBA_DISABLE_JIT") == "1", reason="kernels not compiled")
def test_generator_kernels_prepared_are_those_the_generators_use():
    from viscore._jit import compile_kernels
    from viscore.generators import generate_aabb_skins
    from viscore.generators._kernels import _measure_kernels
    from viscore.generators.aabb_skins._growth import grow_boxes

    compile_kernels(_measure_kernels())
    before = _versions(grow_boxes)
    occ = generate_aabb_skins(trimesh.creation.box(extents=(2, 1, 1)), voxels=8)
    assert occ.triangles == 12  # one box: the whole solid
    assert _versions(grow_boxes) == before


def test_metric_kernel_prepared_is_the_one_a_score_uses():
    from viscore._jit import compile_kernels
    from viscore.generators._kernels import _metric_kernels
    from viscore.metrics.quads import _coverage_tally
    from viscore.metrics.reference_views import ReferenceViews

    compile_kernels(_metric_kernels())
    before = _versions(_coverage_tally)
    assert before >= 1
    box = trimesh.creation.box()
    pr = ReferenceViews(box, protocol="orbit", views=4, resolution=32, seed=0).score(box)
    assert pr.precision == 1.0 and pr.recall == 1.0  # the mesh itself: P = R = 1
    assert _versions(_coverage_tally) == before


def test_kernels_compiled_ahead_are_found_by_a_later_call(tmp_path):
    """A kernel compiled ahead from a signature string is loaded, not compiled again, by
    the next process that calls it (numba files its cache by the form compile is given)."""
    import subprocess
    import sys
    import textwrap

    (tmp_path / "kernel_mod.py").write_text(textwrap.dedent("""
        from viscore._jit import njit_cached

        @njit_cached()
        def twice(a):
            return 2.0 * a.sum()
    """))
    ahead = ("from viscore._jit import compile_kernels; import kernel_mod; "
             "compile_kernels({kernel_mod.twice: ['(float64[::1],)']})")
    call = ("import numpy as np, kernel_mod; assert kernel_mod.twice(np.ones(3)) == 6.0; "
            "s = kernel_mod.twice.stats; print(len(s.cache_hits), len(s.cache_misses))")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    for code in (ahead, call):
        done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["1", "0"]  # one version loaded, none compiled
