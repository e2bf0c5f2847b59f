"""The kernels' own sorts give NumPy's answers."""

import numpy as np
import pytest

from viscore._sort_kernels import sort_prefix, stable_order


@pytest.mark.parametrize("m", [0, 1, 2, 7, 64, 1000])
def test_stable_order_is_numpys_stable_argsort(m):
    rng = np.random.default_rng(m)
    key = rng.integers(0, 6, size=m + 5).astype(np.float64)  # many ties; a tail not sorted
    a, b = np.empty(m + 5, np.int64), np.empty(m + 5, np.int64)
    order = stable_order(key, m, a, b)
    assert np.array_equal(order, np.argsort(key[:m], kind="stable"))


@pytest.mark.parametrize("n", [0, 1, 2, 9, 160, 5000])
def test_sort_prefix_sorts_the_first_n_in_place(n):
    rng = np.random.default_rng(n)
    values = rng.normal(size=n + 3)
    values[: n // 2] = np.round(values[: n // 2])  # repeated values
    want = np.concatenate([np.sort(values[:n]), values[n:]])
    sort_prefix(values, n)
    assert np.array_equal(values, want)
