"""Results kept by content (viscore._content_cache): by the arrays' bytes, once per key."""

import threading
import time

import numpy as np

from viscore._content_cache import ContentCache, content_key


def test_keys_follow_the_content_not_the_array():
    a = np.arange(6.0)
    assert content_key(a) == content_key(a.copy())
    assert content_key(a) != content_key(a.reshape(2, 3))  # the shape is part of it
    assert content_key(a) != content_key(a.astype(np.float32))  # and the dtype
    b = a.copy()
    b[3] = -1.0
    assert content_key(a) != content_key(b)
    assert content_key(a, 1) != content_key(a, 2)  # plain values as given


def test_the_oldest_result_is_dropped():
    cache, calls = ContentCache(2), []

    def get(x):
        return cache.get((np.array([x]),), lambda: calls.append(x) or x * 10)

    assert [get(1), get(2), get(1), get(3), get(2), get(1)] == [10, 20, 10, 30, 20, 10]
    assert calls == [1, 2, 3, 2, 1]  # 3 dropped 2 (1 had been asked since), 2 dropped 1


def test_threads_asking_for_one_result_compute_it_once():
    cache, calls = ContentCache(2), []
    start = threading.Barrier(4)
    got = []

    def slow():
        calls.append(1)
        time.sleep(0.2)
        return np.ones(3)

    def ask():
        start.wait()
        got.append(cache.get((np.arange(1000),), slow))

    threads = [threading.Thread(target=ask) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(calls) == 1 and len(got) == 4 and all(g is got[0] for g in got)


def test_a_failed_computation_is_not_kept_and_a_waiting_thread_computes_it():
    cache = ContentCache(2)
    first_in = threading.Event()
    outcome = {}

    def failing():
        first_in.set()
        time.sleep(0.2)
        raise RuntimeError("boom")

    def first():
        try:
            cache.get((np.zeros(4),), failing)
        except RuntimeError as exc:
            outcome["first"] = str(exc)

    def second():
        first_in.wait()
        outcome["second"] = cache.get((np.zeros(4),), lambda: "made by the second")

    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert outcome == {"first": "boom", "second": "made by the second"}
    assert cache.get((np.zeros(4),), failing) == "made by the second"  # kept, not redone
