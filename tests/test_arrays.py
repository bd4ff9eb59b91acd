"""Shared array helpers (follicle.arrays) not covered through their callers."""

import numpy as np

from follicle.arrays import budget_runs


def test_budget_runs_cover_every_item_in_order_and_keep_within_the_budget():
    """Runs under a budget: consecutive, covering, each within the budget unless one
    item alone passes it."""
    costs = np.array([3, 3, 10, 1, 1, 1, 0, 5])
    assert budget_runs(costs, 5) == [(0, 1), (1, 2), (2, 3), (3, 7), (7, 8)]
    assert budget_runs(costs, 100) == [(0, 8)] and budget_runs(np.array([], int), 5) == []


def test_all_finite_finds_one_bad_value_small_or_large():
    """numpy below SCAN_IN_PARALLEL elements, the parallel kernel from it: both find one
    NaN or inf anywhere, at the ends too, and pass an array with none."""
    from follicle.arrays import SCAN_IN_PARALLEL, all_finite

    for size in (7, SCAN_IN_PARALLEL + 5):
        arr = np.linspace(-1.0, 1.0, size, dtype=np.float32)
        assert all_finite(arr)
        for where in (0, size // 2, size - 1):
            for bad in (np.nan, np.inf, -np.inf):
                broken = arr.copy()
                broken[where] = bad
                assert not all_finite(broken.reshape(-1, 1)), (size, where, bad)
