"""Halton sequences and counter-based random streams."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from numba import njit

from follicle.errors import InputError
from follicle.rng import (
    halton,
    mix64,
    purpose_id,
    stream_key,
    uniform,
    uniforms,
)

MASK = (1 << 64) - 1


def _mix64_ref(z: int) -> int:
    """splitmix64 finaliser in plain Python ints (the published constants)."""
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    return z ^ (z >> 31)


def test_halton_known_values():
    np.testing.assert_array_equal(
        halton(np.arange(8), 2), [0, 0.5, 0.25, 0.75, 0.125, 0.625, 0.375, 0.875]
    )
    np.testing.assert_allclose(halton(np.arange(5), 3), [0, 1 / 3, 2 / 3, 1 / 9, 4 / 9], rtol=1e-15)
    # base 5: 7 = 12 -> 0.21 = 2/5 + 1/25, 25 = 100 -> 0.001 = 1/125
    np.testing.assert_allclose(halton(np.array([[7, 25]]), 5), [[2 / 5 + 1 / 25, 1 / 125]])
    assert halton(np.arange(4), 2).dtype == np.float64


def test_mix64_matches_reference():
    for x in (0, 1, 2, 12345, 2**63, MASK):
        assert int(mix64(np.uint64(x))) == _mix64_ref(x)


def test_uniform_is_splitmix64_at_counter():
    key = int(stream_key(42, 7, purpose_id("kink")))
    for k in (0, 1, 1000):
        state = (key + (k + 1) * 0x9E3779B97F4A7C15) & MASK
        assert uniform(np.uint64(key), k) == (_mix64_ref(state) >> 11) / 2.0**53
    assert uniform(np.uint64(key), 3) == pytest.approx(0.2365976986280809, abs=0)


def test_purpose_id_is_stable_across_processes():
    assert purpose_id("kink") == 2877006152  # CRC-32, not hash()
    code = "from follicle.rng import purpose_id; print(purpose_id('kink'))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert int(out.stdout) == purpose_id("kink")


def test_uniforms_equals_scalar_stream_and_is_deterministic():
    ids = np.array([0, 5, 99])
    u = uniforms(3, ids, "frizz", 4)
    assert u.shape == (3, 4) and u.dtype == np.float64
    for row, i in enumerate(ids):
        key = stream_key(3, int(i), purpose_id("frizz"))
        assert list(u[row]) == [uniform(key, k) for k in range(4)]
    np.testing.assert_array_equal(u, uniforms(3, ids, purpose_id("frizz"), 4))


def test_chunked_generation_equals_whole_run():
    ids = np.arange(1000)
    whole = uniforms(11, ids, "roots", 8)
    by_ids = np.vstack([uniforms(11, ids[:300], "roots", 8), uniforms(11, ids[300:], "roots", 8)])
    by_counter = np.hstack([uniforms(11, ids, "roots", 3), uniforms(11, ids, "roots", 5, start=3)])
    np.testing.assert_array_equal(by_ids, whole)
    np.testing.assert_array_equal(by_counter, whole)


def test_statistics_and_independence():
    ids = np.arange(20_000)
    a = uniforms(1, ids, "a", 4)
    b = uniforms(1, ids, "b", 4)
    c = uniforms(2, ids, "a", 4)
    assert np.all((a >= 0) & (a < 1))
    for x in (a, b, c):
        assert abs(x.mean() - 0.5) < 0.01
        assert abs(x.var() - 1 / 12) < 0.005
    tol = 4 / np.sqrt(len(ids))  # ~4 sigma for independent samples
    assert abs(np.corrcoef(a[:, 0], b[:, 0])[0, 1]) < tol  # purposes
    assert abs(np.corrcoef(a[:, 0], c[:, 0])[0, 1]) < tol  # seeds
    assert abs(np.corrcoef(a[:-1, 0], a[1:, 0])[0, 1]) < tol  # neighbouring ids
    assert abs(np.corrcoef(a[:, 0], a[:, 1])[0, 1]) < tol  # neighbouring counters
    hist = np.histogram(a[:, 0], bins=10, range=(0, 1))[0]
    assert np.all(np.abs(hist - 2000) < 250)


def test_usable_in_kernels():
    @njit
    def kernel(seed, n):
        out = np.empty(n)
        for i in range(n):
            out[i] = uniform(stream_key(seed, i, 17), 0)
        return out

    np.testing.assert_array_equal(kernel(5, 10), uniforms(5, np.arange(10), 17, 1)[:, 0])


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: halton(np.arange(3), 1), "base"),
        (lambda: halton(np.array([-1]), 2), "index"),
        (lambda: halton(np.array([0.5]), 2), "index"),
        (lambda: uniforms(1, np.zeros((2, 2), int), "a", 2), "ids"),
        (lambda: uniforms(1, [0.5], "a", 2), "ids"),
        (lambda: uniforms(1, [0], "a", -1), "count"),
        (lambda: uniforms(1.5, [0], "a", 1), "seed"),
        (lambda: uniforms(1, [0], 2.0, 1), "purpose"),
        (lambda: purpose_id(3), "name"),
    ],
)
def test_bad_inputs_raise(call, match):
    with pytest.raises(InputError, match=match):
        call()
