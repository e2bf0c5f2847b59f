"""Small sorts for numba kernels, written out so that they compile in a fraction of a second.

numba compiles its own ``np.sort`` and ``np.argsort`` (quicksort, mergesort) from
library code that takes one to three seconds per kernel and process on a fresh
install, where its cache is empty; these loops give the same answers.
"""

from __future__ import annotations

from ._jit import njit_cached

__all__ = ["stable_order", "sort_prefix"]

#: Ciura's gap sequence for :func:`sort_prefix`, extended by x2.25.
_GAPS = (1750, 701, 301, 132, 57, 23, 10, 4, 1)


@njit_cached()
def stable_order(key, m, a, b):  # pragma: no cover - compiled
    """``np.argsort(key[:m], kind="stable")`` for keys without NaN: a bottom-up merge sort
    of indices (ties keep their order) in the scratch int64 arrays ``a`` and ``b`` (each at
    least ``m`` long); returns ``a[:m]`` or ``b[:m]``."""
    for i in range(m):
        a[i] = i
    src, dst = a, b
    width = 1
    while width < m:
        for lo in range(0, m, 2 * width):
            mid, hi = min(lo + width, m), min(lo + 2 * width, m)
            i, j, k = lo, mid, lo
            while i < mid and j < hi:
                if key[src[j]] < key[src[i]]:
                    dst[k] = src[j]
                    j += 1
                else:
                    dst[k] = src[i]
                    i += 1
                k += 1
            while i < mid:
                dst[k] = src[i]
                i += 1
                k += 1
            while j < hi:
                dst[k] = src[j]
                j += 1
                k += 1
        src, dst = dst, src
        width *= 2
    return src[:m]


@njit_cached()
def sort_prefix(values, n):  # pragma: no cover - compiled
    """Sort ``values[:n]`` ascending in place (a Shell sort; values without NaN), as
    ``values[:n] = np.sort(values[:n])``."""
    for gap in _GAPS:
        if gap >= n:
            continue
        for i in range(gap, n):
            v = values[i]
            j = i
            while j >= gap and values[j - gap] > v:
                values[j] = values[j - gap]
                j -= gap
            values[j] = v
