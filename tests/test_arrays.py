"""Shared array helpers (follicle.arrays) not covered through their callers."""

import numpy as np

from follicle.arrays import budget_runs


def test_budget_runs_cover_every_item_in_order_and_keep_within_the_budget():
    """Runs under a budget: consecutive, covering, each within the budget unless one
    item alone passes it."""
    costs = np.array([3, 3, 10, 1, 1, 1, 0, 5])
    assert budget_runs(costs, 5) == [(0, 1), (1, 2), (2, 3), (3, 7), (7, 8)]
    assert budget_runs(costs, 100) == [(0, 8)] and budget_runs(np.array([], int), 5) == []
