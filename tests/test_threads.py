"""Chunks side by side on threads: same results as in order, errors surface, nothing hangs."""

from __future__ import annotations

import threading

import numba
import pytest

from follicle.threads import chained, ordered_map, workers


def test_workers_never_more_than_tasks_or_numba_threads() -> None:
    assert workers(1) == 1
    assert workers(0) == 1
    assert workers(100) == numba.get_num_threads()


def test_ordered_map_keeps_order_and_runs_workers_on_one_numba_thread() -> None:
    seen = []

    def square(x: int) -> int:
        seen.append(numba.get_num_threads())
        return x * x

    assert ordered_map(square, list(range(50))) == [x * x for x in range(50)]
    assert set(seen) == ({1} if workers(50) > 1 else {numba.get_num_threads()})


def test_chained_passes_state_in_order_and_finishes_every_item() -> None:
    """A running offset, as the generator uses it: each item is written at the sum of
    the sizes before it, whatever thread prepares or finishes it."""
    sizes = [3, 0, 5, 1, 7, 2, 0, 4]
    written: dict[int, int] = {}
    done: list[int] = []
    lock = threading.Lock()

    def finish(item: int, size: int, at: int) -> None:
        with lock:
            written[item] = at

    last = chained(
        list(range(len(sizes))),
        lambda k: sizes[k],
        lambda at, size: at + size,
        finish,
        10,
        done.append,
    )
    assert last == 10 + sum(sizes)
    assert written == {k: 10 + sum(sizes[:k]) for k in range(len(sizes))}
    assert done == list(range(len(sizes)))


def test_chained_error_in_one_item_is_raised_and_later_items_do_not_hang() -> None:
    finished = []

    def prepare(k: int) -> int:
        if k == 3:
            raise ValueError("bad chunk 3")
        return 1

    with pytest.raises(ValueError, match="bad chunk 3"):
        chained(
            list(range(12)),
            prepare,
            lambda at, r: at + r,
            lambda k, r, at: finished.append(k),
            0,
        )
    assert sorted(finished) == [0, 1, 2]  # the items before it, never one after
