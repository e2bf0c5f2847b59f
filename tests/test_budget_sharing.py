"""Work the budgets of one mesh share, made once per process: the greedy search taken
further, planar sections' candidates, hybrid's candidates and volume views, the check
views. A kept result must be the one made anew (a hit and a miss give the same occluder),
and another mesh must not find it."""

import numpy as np
import pytest
import trimesh

from viscore import load_mesh
from viscore.cli.study import runner
from viscore.cli.study.runner import Job, StudySettings, _tasks
from viscore.generators._precision_check import _CHECK_VIEWS, check_views
from viscore.generators.hybrid import generator as hybrid
from viscore.generators.planar_sections import _single, generate_planar_sections
from viscore.generators.planar_sections._select import GreedySearch, select_greedy

#: Few bins and voxels given (no precision floor): the generator's speed is a benchmark's.
FAST = {"direction_bins": 6, "depth_bins": 2, "voxels": 24}


def _same(a, b) -> bool:
    return (np.array_equal(np.asarray(a.mesh.vertices), np.asarray(b.mesh.vertices))
            and np.array_equal(np.asarray(a.mesh.faces), np.asarray(b.mesh.faces)))


def _blobs(seed: int = 3) -> np.ndarray:
    """(30, 4, 24, 24) bitmaps of random rectangles: a search of many steps."""
    rng = np.random.default_rng(seed)
    bm = np.zeros((30, 4, 24, 24), bool)
    for i in range(30):
        for k in range(4):
            r, c = rng.integers(0, 18, 2)
            h, w = rng.integers(2, 7, 2)
            bm[i, k, r:r + h, c:c + w] = True
    return bm


def test_greedy_search_taken_further_equals_searches_made_anew():
    bm = _blobs()
    full, full_totals = select_greedy(bm, 0.5, alpha=0.0)
    assert len(full) > 8
    search = GreedySearch(bm, 0.5, alpha=0.0)
    for m in (3, 8, 5, None):  # further, then a shorter prefix, then to its end
        chosen, totals = search.result(m)
        fresh, fresh_totals = select_greedy(bm, 0.5, alpha=0.0, max_polygons=m)
        assert np.array_equal(chosen, fresh) and np.array_equal(totals, fresh_totals)
    assert np.array_equal(chosen, full) and np.array_equal(totals, full_totals)


def test_greedy_prefix_is_the_first_polygons_of_the_longer_search():
    bm = _blobs(5)
    long, _ = select_greedy(bm, 1.0, alpha=0.0, max_polygons=10)
    short, _ = select_greedy(bm, 1.0, alpha=0.0, max_polygons=4)
    assert len(long) == 10 and np.array_equal(short, long[:4])


@pytest.fixture(scope="module")
def torus():
    return load_mesh("fat-torus")


def test_planar_sections_kept_candidates_give_the_occluder_made_anew(torus):
    _single._CANDIDATES.clear()
    small_first = generate_planar_sections(torus, budget=16, **FAST)
    assert len(_single._CANDIDATES._items) == 1
    larger_after = generate_planar_sections(torus, budget=48, **FAST)  # a hit, searched further
    again = generate_planar_sections(torus, budget=16, **FAST)  # a hit, a prefix
    assert len(_single._CANDIDATES._items) == 1
    _single._CANDIDATES.clear()
    larger_alone = generate_planar_sections(torus, budget=48, **FAST)  # a miss
    assert larger_alone.triangles > small_first.triangles
    assert _same(larger_after, larger_alone) and _same(again, small_first)
    assert larger_after.info["measure_totals"] == larger_alone.info["measure_totals"]


def test_planar_sections_changed_mesh_misses(torus):
    _single._CANDIDATES.clear()
    generate_planar_sections(torus, budget=16, **FAST)
    moved = torus.copy()
    moved.vertices[0] += 0.05 * float(np.max(moved.extents))
    generate_planar_sections(moved, budget=16, **FAST)
    assert len(_single._CANDIDATES._items) == 2
    _single._CANDIDATES.clear()


def test_check_views_kept_per_mesh_and_seed():
    box = trimesh.creation.box()
    _CHECK_VIEWS.clear()
    first = check_views(box, 0, 4)
    assert check_views(box.copy(), 0, 4) is first  # the same content: a hit
    assert check_views(box, 1, 4) is not first  # another seed
    other = trimesh.creation.box(extents=(1, 1, 2))
    changed = check_views(other, 0, 4)
    assert changed is not first and changed.extent != first.extent
    _CHECK_VIEWS.clear()


def test_hybrid_kept_candidates_give_the_occluder_made_anew():
    box = trimesh.creation.box()
    box = trimesh.util.concatenate([box, trimesh.creation.box().apply_translation([2, 0, 0])])
    opts = {"mgos": False, "voxels": 16}
    hybrid._CANDIDATES.clear()
    made = hybrid.generate_hybrid(box, budget=40, **opts)
    kept = hybrid.generate_hybrid(box, budget=40, **opts)
    assert len(hybrid._CANDIDATES._items) == 1
    assert _same(made, kept) and made.info["faces"] == kept.info["faces"]
    moved = box.copy()
    moved.vertices[0] += 0.3
    hybrid.generate_hybrid(moved, budget=40, **opts)
    assert len(hybrid._CANDIDATES._items) == 2
    hybrid._CANDIDATES.clear()


def test_study_tasks_hold_a_methods_budgets_together():
    s = StudySettings(budgets=(64, 256))
    jobs = [Job("m", "qem", 64, s), Job("m", "bbox", None, s), Job("m", "qem", 256, s),
            Job("m", "f", None, s, source="a.obj", digest="1"),
            Job("m", "f", 64, s, source="b.obj", digest="2")]
    tasks = _tasks(jobs)
    assert [[(j.method, j.budget) for j in t] for t in tasks] == [
        [("qem", 256), ("qem", 64)], [("bbox", None)], [("f", None)], [("f", 64)]]


def test_study_task_cost_ranks_heavy_methods_first():
    s = StudySettings(budgets=(64, 256))
    pair = [Job("m", "planar-sections", 64, s), Job("m", "planar-sections", 256, s)]
    assert runner._task_cost(pair) == 2 * runner._task_cost(pair[:1])
    variant = [Job("m", "planar-sections:chain=greedy", 64, s)]
    assert runner._task_cost(variant) == runner._task_cost(pair[:1])
    qem = [Job("m", "qem", 64, s)]
    bbox = [Job("m", "bbox", None, s)]
    file = [Job("m", "planar-sections", 64, s, source="a.obj", digest="1")]
    assert runner._task_cost(pair[:1]) > runner._task_cost(qem) > runner._task_cost(bbox)
    assert runner._task_cost(file) == runner._task_cost(bbox) == runner._OTHER_COST


def test_local_study_starts_the_costliest_ready_task_first(tmp_path, monkeypatch):
    """One worker: every mesh's views first, then the tasks longest first, whatever the
    order of the jobs; each job committed once with its own task's result."""
    from concurrent.futures import ThreadPoolExecutor

    s = StudySettings(budgets=(64, 256))
    started: list = []
    monkeypatch.setattr(runner, "process_pool", lambda n: ThreadPoolExecutor(1))
    monkeypatch.setattr(runner, "_write_views",
                        lambda mesh, settings, workers, original, path: started.append(
                            ("views", mesh)) or path)
    monkeypatch.setattr(runner, "_run_jobs_on_file", lambda task, workers, path: started.append(
        (task[0].mesh, task[0].method)) or [(j.method, j.budget, path) for j in task])
    pending = [Job(mesh, method, b, s) for mesh in ("a", "b")
               for method, budgets in (("bbox", (None,)), ("qem", (64, 256)),
                                       ("hybrid", (64, 256)), ("planar-sections", (64, 256)))
               for b in budgets]
    committed = []
    runner._local(pending, 1, 1, lambda job, result: committed.append((job, result)),
                  scratch=tmp_path)
    assert started[:2] == [("views", "a"), ("views", "b")]
    assert started[2:] == [("a", "planar-sections"), ("b", "planar-sections"),
                           ("a", "hybrid"), ("b", "hybrid"), ("a", "qem"), ("b", "qem"),
                           ("a", "bbox"), ("b", "bbox")]
    assert sorted((j.mesh, j.method, j.budget or 0) for j, _ in committed) == sorted(
        (j.mesh, j.method, j.budget or 0) for j in pending)
    assert all(r[:2] == (j.method, j.budget) for j, r in committed)
    assert not list(tmp_path.iterdir())  # the views folder removed


def test_local_study_runs_extra_units_by_cost_and_their_followers(tmp_path, monkeypatch):
    """Other work in the study's pool (compare's culling column): a unit is taken when its
    cost is the largest ready, between the jobs' tasks; what its ``done`` returns becomes
    ready then, and runs though it costs the least."""
    from concurrent.futures import ThreadPoolExecutor

    s = StudySettings(budgets=(64,))
    started: list = []
    monkeypatch.setattr(runner, "process_pool", lambda n: ThreadPoolExecutor(1))
    monkeypatch.setattr(runner, "_write_views",
                        lambda mesh, settings, workers, original, path: path)
    monkeypatch.setattr(runner, "_run_jobs_on_file", lambda task, workers, path: started.append(
        task[0].method) or [None for _ in task])
    follower = runner.Unit(cost=0.0, fn=lambda x: started.append(x) or x * 2, args=("follow",),
                           done=lambda result: started.append(result) or [])
    piece = runner.Unit(cost=10.0, fn=lambda x: started.append(x) or x, args=("piece",),
                        done=lambda result: [follower])
    pending = [Job("a", m, b, s) for m, b in (("planar-sections", 64), ("bbox", None))]
    runner._local(pending, 1, 1, lambda job, result: None, scratch=tmp_path, extra=[piece])
    # planar-sections costs 32, the piece 10, bbox 1.5: the follower comes once the piece is in
    assert started == ["planar-sections", "piece", "bbox", "follow", "followfollow"]


def test_study_says_its_jobs_are_in_before_the_extra_work_ends(tmp_path, monkeypatch):
    """compare draws its figures while the culling column's last work runs: ``on_jobs_done``
    comes once, with the rows run_study returns, before a cheaper extra unit is done; on
    a study resumed with every row kept, at once."""
    from concurrent.futures import ThreadPoolExecutor

    monkeypatch.setattr(runner, "process_pool", lambda n: ThreadPoolExecutor(1))
    s = StudySettings(views=2, quads=100, resolution=16, directions=4, rays=200, budgets=(32,))
    said: list = []
    unit = runner.Unit(cost=0.0, fn=lambda: "column", args=(),
                       done=lambda result: said.append(result) or [])
    for _ in range(2):
        rows = runner.run_study(["building-house"], ["bbox"], s, tmp_path / "s", jobs=1,
                                progress=False, extra=[unit],
                                on_jobs_done=lambda r: said.append(r))
        assert said == [rows, "column"] and rows[0]["method"] == "bbox"
        said.clear()


def test_study_refuses_extra_work_on_a_scheduler(tmp_path):
    from viscore import InputError

    unit = runner.Unit(cost=1.0, fn=print, args=(), done=lambda result: [])
    with pytest.raises(InputError, match="local pool only"):
        runner.run_study([], [], StudySettings(), tmp_path / "s", scheduler=object(),
                         progress=False, extra=[unit])


def test_mgos_shared_state_gives_the_result_made_anew(torus, monkeypatch):
    """Budgets 100 then 30 sharing the prepared state (the second from where the first's
    recall step stopped on its budget), each equal to the call alone; another budget
    above the first's stop starts from the prepared state."""
    from viscore.generators.hybrid import metric_guided as mg
    from viscore.metrics import ReferenceViews

    cand = hybrid.generate_hybrid(torus, mgos=False).mesh
    views = ReferenceViews(torus, protocol="volume", spacing=0.25 * float(
        np.linalg.norm(torus.extents)), quads=200, resolution=16, seed=0)

    def run(budget, share):
        return mg.metric_guided_simplify(torus, cand, reference=views, max_faces=budget,
                                         share=share)

    def same(a, b):
        (ma, ia), (mb, ib) = a, b
        ia = {k: v for k, v in ia.items() if not k.startswith("seconds")}
        ib = {k: v for k, v in ib.items() if not k.startswith("seconds")}
        return (np.array_equal(ma.faces, mb.faces)
                and np.array_equal(ma.vertices, mb.vertices) and ia == ib)

    alone = {b: run(b, False) for b in (200, 100, 30)}
    assert alone[100][1]["faces_after"] < 100 and alone[30][1]["removed_budget"] > 0
    mg._SHARED.clear()
    made, removed = [], []
    init, remove = mg._State.__init__, mg._State.remove
    monkeypatch.setattr(mg._State, "__init__", lambda self, *a, **k: made.append(1) or init(
        self, *a, **k))
    monkeypatch.setattr(mg._State, "remove", lambda self, f: removed.append(f) or remove(
        self, f))
    first = run(100, True)
    fork = next(iter(mg._SHARED._items.values())).fork
    assert fork is not None and 30 < fork[0] <= 100  # where budget 100 stopped removing
    assert same(first, alone[100])
    before = len(removed)
    assert same(run(30, True), alone[30])  # from the fork: its removals only
    assert len(removed) - before == fork[0] - alone[30][1]["faces_after"]
    assert same(run(200, True), alone[200])  # from the prepared state
    assert same(run(30, True), alone[30])
    assert len(mg._SHARED._items) == 1 and len(made) == 1  # cast once
    mg._SHARED.clear()


def test_hybrid_keeps_its_metric_guided_state_only_inside_shared_budgets(torus):
    """Outside :func:`shared_budgets` (occlude, a single generate) no state is kept; inside,
    the second budget goes on from the first's state, each occluder the one made alone, and
    the state is released when the block ends (issue 44)."""
    from viscore.generators.hybrid import metric_guided as mg
    from viscore.generators.hybrid import shared_budgets

    opts = {"voxels": 24, "mgos_resolution": 16, "mgos_quads": 200}
    mg._SHARED.clear()
    alone = {b: hybrid.generate_hybrid(torus, budget=b, **opts) for b in (120, 40)}
    assert not mg._SHARED._items  # nothing kept by a call outside the block
    with shared_budgets():
        with shared_budgets():  # nested: released only when the outer block ends
            large = hybrid.generate_hybrid(torus, budget=120, **opts)
            assert len(mg._SHARED._items) == 1
        small = hybrid.generate_hybrid(torus, budget=40, **opts)
        assert len(mg._SHARED._items) == 1
    assert not mg._SHARED._items
    assert _same(large, alone[120]) and _same(small, alone[40])
