"""Chunks of work spread over threads, each running its numba kernels on one core; and
kernels kept on one thread when their problem is too small to share.

Many-chunk jobs (a million hairs in 32 k pieces) spend a good part of their time in
the NumPy and Python glue between kernels, which a ``prange`` inside each kernel does
not spread over the cores. Running whole chunks side by side on as many threads as
numba uses (every kernel they call releases the GIL: ``nogil=True``), each with
``numba.set_num_threads(1)``, keeps every core busy through the glue as well.
Results come back in chunk order, so the output does not depend on the thread count.

A parallel kernel on a small problem costs more than it saves: every ``prange`` forks
and joins the thread pool (OpenMP here), and when another process holds a core the join
waits for a descheduled thread (300 guides × 24 vertices simulated at 2.4–5.5 frames/s
on two threads, 22–36 on one). :func:`threads_for` gives a stage as many threads as it
has work for, ``grain`` items each (one below two grains: serial), a figure measured per
stage (``benchmarks/sim_threads.py``). Every kernel gives the same bytes with any thread
count, so the choice changes the time only.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from typing import TypeVar

__all__ = ["workers", "ordered_map", "chained", "threads_for"]

T = TypeVar("T")
R = TypeVar("R")
S = TypeVar("S")


def workers(tasks: int) -> int:
    """Threads worth using for ``tasks`` chunks: numba's thread count, at most one each."""
    import numba

    return max(1, min(int(tasks), numba.get_num_threads()))


def _one_core(fn: Callable[..., R]) -> Callable[..., R]:
    def run(*args: object) -> R:
        import numba

        numba.set_num_threads(1)  # thread-local: this worker's kernels stay on its core
        return fn(*args)

    return run


@contextmanager
def threads_for(size: int, grain: int) -> Iterator[int]:
    """Numba kernels launched inside run on at most ``size // grain`` threads (at least
    one, at most numba's count): a problem of ``size`` items shares out in pieces of
    ``grain`` or more. Yields the thread count; numba's is put back on leaving (it is
    per calling thread, so other threads are unaffected)."""
    import numba

    before = numba.get_num_threads()
    threads = max(1, min(before, int(size) // max(int(grain), 1)))
    if threads == before:
        yield threads
        return
    numba.set_num_threads(threads)
    try:
        yield threads
    finally:
        numba.set_num_threads(before)


@contextmanager
def _pool(threads: int) -> Iterator[ThreadPoolExecutor]:
    pool = ThreadPoolExecutor(threads, thread_name_prefix="follicle")
    try:
        yield pool
    finally:
        pool.shutdown(wait=True, cancel_futures=True)  # a failure stops the chunks not begun


def ordered_map(fn: Callable[[T], R], items: Sequence[T]) -> list[R]:
    """``[fn(x) for x in items]``, chunks side by side on :func:`workers` threads."""
    threads = workers(len(items))
    if threads == 1:
        return [fn(x) for x in items]
    with _pool(threads) as pool:
        return list(pool.map(_one_core(fn), items))


def chained(
    items: Sequence[T],
    prepare: Callable[[T], R],
    advance: Callable[[S, R], S],
    finish: Callable[[T, R, S], None],
    state: S,
    done: Callable[[int], None] | None = None,
) -> S:
    """For each item in order: ``r = prepare(item)``, then ``finish(item, r, s)`` with
    ``s`` the state before it, ``advance(s, r)`` the state after it.

    ``prepare`` and ``finish`` of different items run side by side on :func:`workers`
    threads; only ``advance`` (cheap: e.g. a running output offset) passes from one
    item to the next in order, so item k waits for nothing but item k−1's ``prepare``.
    ``done(k)`` is called in order as items complete. Returns the last state.
    """
    threads = workers(len(items))
    if threads == 1:
        for k, item in enumerate(items):
            r = prepare(item)
            finish(item, r, state)
            state = advance(state, r)
            if done is not None:
                done(k)
        return state
    links: list[Future] = [Future() for _ in range(len(items) + 1)]
    links[0].set_result(state)

    def task(k: int) -> None:
        try:
            r = prepare(items[k])
            before = links[k].result()
            links[k + 1].set_result(advance(before, r))
        except BaseException as exc:
            links[k + 1].set_exception(exc)  # the items after this one fail too
            raise
        finish(items[k], r, before)

    with _pool(threads) as pool:
        run = _one_core(task)
        futures = [pool.submit(run, k) for k in range(len(items))]
        for k, future in enumerate(futures):
            future.result()
            if done is not None:
                done(k)
    return links[-1].result()
