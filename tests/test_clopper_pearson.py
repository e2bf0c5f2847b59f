"""The one-sided Clopper-Pearson bound against scipy's exact binomial interval, k > 0 too.

A one-sided upper bound at confidence c is the c-quantile of Beta(k + 1, n - k)
(Clopper and Pearson 1934). The two-sided exact interval at confidence L puts
(1 - L) / 2 in each tail, so its upper end is the (1 + L) / 2 quantile of the
same Beta: the two coincide when (1 + L) / 2 = c, that is L = 2c - 1. So
``binomtest(k, n).proportion_ci(confidence_level=2c - 1).high`` is the
one-sided bound at c, computed by scipy's own code path, independent of
``clopper_pearson_upper``'s call of ``beta.ppf``.
"""

from __future__ import annotations

import pytest
from scipy.stats import binomtest

from viscore.metrics.conservativeness import clopper_pearson_upper

CASES = [(k, n, c) for k, n in ((1, 10), (3, 50), (7, 1000), (50, 100), (99, 100),
                                (1177, 2000), (0, 2000), (12, 100_000))
         for c in (0.9, 0.95, 0.99, 0.999)]


def _one_sided_upper(k: int, n: int, c: float) -> float:
    return binomtest(k, n).proportion_ci(confidence_level=2 * c - 1, method="exact").high


@pytest.mark.parametrize("k, n, c", CASES)
def test_clopper_pearson_upper_matches_exact_interval(k, n, c):
    assert clopper_pearson_upper(k, n, c) == pytest.approx(_one_sided_upper(k, n, c),
                                                           abs=1e-12, rel=0)


@pytest.mark.parametrize("n, c", [(10, 0.95), (2000, 0.99)])
def test_clopper_pearson_upper_all_violations(n, c):
    assert clopper_pearson_upper(n, n, c) == 1.0 == _one_sided_upper(n, n, c)


def test_clopper_pearson_upper_one_sided_not_two_sided():
    """At k > 0 the one-sided bound is strictly below the two-sided upper end at c."""
    k, n, c = 3, 50, 0.95
    two_sided = binomtest(k, n).proportion_ci(confidence_level=c, method="exact").high
    assert clopper_pearson_upper(k, n, c) < two_sided - 1e-3
