"""Threads per stage (issue: production dynamics, small scenes fast): a stage too small
to share runs on one thread, a big one on numba's count, and the thread choice never
changes a simulation's bytes. The speeds are in benchmarks/sim_threads.py."""

from __future__ import annotations

import numba
import numpy as np
import pytest

import follicle.sim.simulator as simulator
import follicle.sim.volume as volume
from follicle import Simulator
from follicle.pipeline import groom_scene
from follicle.scene import Scene
from follicle.threads import threads_for


def test_threads_follow_the_work_and_come_back():
    most = numba.get_num_threads()
    with threads_for(100, 1_000) as n:
        assert n == 1 and numba.get_num_threads() == 1
    assert numba.get_num_threads() == most
    with threads_for(10**9, 1_000) as n:
        assert n == most and numba.get_num_threads() == most
    with pytest.raises(RuntimeError), threads_for(0, 10):
        raise RuntimeError("a failing stage")
    assert numba.get_num_threads() == most  # put back after a failure too


def _simulate(frames: int = 6) -> np.ndarray:
    groom = groom_scene(Scene())
    sim = Simulator(groom.guides, groom.mesh)
    for _ in range(frames):
        sim.step(1 / 24)
    return sim.positions.copy()


@pytest.mark.slow
def test_the_small_scene_keeps_to_one_thread(monkeypatch):
    """300 guides × 24 vertices (7,200) is below every grain: each stage's kernels are
    launched with one thread (numba's count is read inside them)."""
    seen = []
    real = simulator.Solver.substep

    def spy(self, *args, **kwargs):
        seen.append(numba.get_num_threads())
        return real(self, *args, **kwargs)

    monkeypatch.setattr(simulator.Solver, "substep", spy)
    groom = groom_scene(Scene())
    sim = Simulator(groom.guides, groom.mesh)
    assert sim.state.x.shape[0] * sim.state.x.shape[1] < simulator.SUBSTEP_GRAIN * 2
    sim.step(1 / 24)
    assert seen == [1] * 5  # five substeps of 1/120 s, each on one thread


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two numba threads")
@pytest.mark.slow
def test_the_same_bytes_serial_or_parallel(monkeypatch):
    serial = _simulate()
    monkeypatch.setattr(simulator, "SUBSTEP_GRAIN", 1)
    monkeypatch.setattr(volume, "PARTICLE_GRAIN", 1)
    monkeypatch.setattr(volume, "CELL_GRAIN", 1)
    numba.set_num_threads(2)
    parallel = _simulate()
    assert np.array_equal(serial, parallel) and not np.array_equal(serial, _rest())


def _rest() -> np.ndarray:
    groom = groom_scene(Scene())
    return Simulator(groom.guides, groom.mesh).positions.copy()
