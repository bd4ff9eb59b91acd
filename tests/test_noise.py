"""Improved Perlin noise and noise3D (Šik 2012 §2.2.5)."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from follicle.errors import InputError
from follicle.noise import _CELLS, _SHIFT, noise3, noise3_array, perlin, perlin_array


def _random_points(n: int = 200_000, seed: int = 0, span: float = 40.0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-span, span, (n, 3))


def test_zero_on_integer_lattice():
    g = np.arange(-3, 4, dtype=np.float64)
    pts = np.stack(np.meshgrid(g, g, g), axis=-1).reshape(-1, 3)
    np.testing.assert_array_equal(perlin_array(pts), 0.0)
    assert perlin(250.0, -1000.0, 7.0) == 0.0


@pytest.mark.slow
def test_pinned_values():
    # fixed permutation table: these hold on every machine and run
    assert perlin(0.5, 0.5, 0.5) == pytest.approx(0.375, abs=1e-15)
    assert perlin(1.25, -3.5, 7.75) == pytest.approx(0.15808439254760742, abs=1e-14)
    assert perlin(0.3, 0.6, 0.9) == pytest.approx(0.5915437361071101, abs=1e-14)
    assert perlin(-10.1, 20.2, -30.3) == pytest.approx(0.31144649047613315, abs=1e-14)
    np.testing.assert_allclose(
        noise3(0.1, 0.2, 0.3),
        (0.08573393125869772, -0.30517770365828023, -0.3215177373887662),
        atol=1e-14,
    )


def test_bounded_and_varied():
    v = perlin_array(_random_points())
    assert np.all(np.abs(v) <= 1.0)
    assert 0.2 < v.std() < 0.4 and abs(v.mean()) < 0.01
    n3 = noise3_array(_random_points(50_000, seed=1))
    assert np.all(np.abs(n3) <= 1.0)
    # the three components are decorrelated
    corr = np.corrcoef(n3.T)
    assert np.all(np.abs(corr[np.triu_indices(3, 1)]) < 0.05)


def test_noise3_is_perlin_at_three_offsets():
    """Šik 2012 §2.2.5: noise3D(x) = [noise(a_i + x)]; the shared-cell evaluation matches it
    to rounding, and noise3D(0) is not the zero vector (the offsets avoid the lattice)."""
    p = _random_points(3_000, seed=5, span=50)
    offsets = _SHIFT + _CELLS
    expected = np.clip(np.stack([perlin_array(p + a) for a in offsets], axis=1), -1.0, 1.0)
    np.testing.assert_allclose(noise3_array(p), expected, rtol=0, atol=1e-13)
    assert np.linalg.norm(noise3(0.0, 0.0, 0.0)) > 0.1


def test_continuous():
    p = _random_points(5_000, seed=2, span=10)
    d = np.random.default_rng(3).normal(size=p.shape)
    d *= 1e-6 / np.linalg.norm(d, axis=1)[:, None]
    # gradient magnitude is bounded, so tiny steps give tiny changes (also across cells)
    assert np.abs(perlin_array(p + d) - perlin_array(p)).max() < 1e-5
    assert np.abs(noise3_array(p + d) - noise3_array(p)).max() < 1e-5
    x = np.linspace(0.999999, 1.000001, 11)  # across a lattice plane
    v = perlin_array(np.stack([x, np.full(11, 0.3), np.full(11, 0.7)], axis=-1))
    assert np.abs(np.diff(v)).max() < 1e-5


def test_arrays_match_scalars():
    p = _random_points(20, seed=4)
    np.testing.assert_array_equal(perlin_array(p), [perlin(*q) for q in p])
    np.testing.assert_array_equal(noise3_array(p), [noise3(*q) for q in p])


@pytest.mark.slow
def test_callable_from_kernels():
    @njit
    def kernel(x):
        a, b, c = noise3(x, 0.5, 0.25)
        return perlin(x, 0.5, 0.25) + a + b + c

    x = 0.37
    assert kernel(x) == pytest.approx(perlin(x, 0.5, 0.25) + sum(noise3(x, 0.5, 0.25)))


@pytest.mark.parametrize("bad", [np.zeros((3, 2)), np.zeros(3), [[0.0, np.nan, 0.0]]])
def test_bad_inputs_raise(bad):
    with pytest.raises(InputError, match="p:"):
        perlin_array(bad)
    with pytest.raises(InputError, match="p:"):
        noise3_array(bad)
