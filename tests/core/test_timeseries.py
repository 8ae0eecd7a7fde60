"""Time-series helpers: the median step of a clock (dronewind.core.timeseries.median_step)."""

from __future__ import annotations

import numpy as np
import pytest

from dronewind.core.timeseries import median_step


def _clocks(rng: np.random.Generator) -> list[np.ndarray]:
    """Logger clocks as the readers meet them, and clocks built to defeat the candidate."""
    n = int(rng.integers(3, 5000))
    step = int(rng.choice([31250, 20000, 100000]))
    regular = step * np.arange(n, dtype=np.int64)
    jitter = np.cumsum(step + rng.integers(-2, 3, n)).astype(np.int64)
    gaps = regular.copy()
    for start in rng.integers(1, n, 5):  # missing rows
        gaps[start:] += step * int(rng.integers(1, 50))
    repeats = np.sort(np.concatenate([regular, regular[rng.integers(0, n, n // 10)]]))  # repeated stamps
    # two step values in nearly equal numbers: the median of every 64th step is often not the median
    two = np.cumsum(rng.permutation(np.r_[np.full(n // 2, 10), np.full(n - n // 2, 11)])).astype(np.int64)
    seconds = regular / 1e6 + rng.normal(0.0, 1e-7, n)  # float stamps
    return [regular, jitter, gaps, repeats, two, seconds, seconds.astype(np.float32)]


@pytest.mark.parametrize("seed", range(40))
def test_median_step_is_numpys_median_of_the_steps_bit_for_bit(seed):
    """Equal to ``np.median(np.diff(t))`` (the same float, odd and even counts), whichever path it takes."""
    for t in _clocks(np.random.default_rng(seed)):
        expected = float(np.median(np.diff(t)))
        assert median_step(t) == expected or (np.isnan(expected) and np.isnan(median_step(t)))


def test_median_step_known_answers_and_nan():
    assert median_step(np.array([0, 10, 20, 35])) == 10.0
    assert median_step(np.array([0, 10, 21, 33])) == 11.0  # even count: mean of the middle two steps
    assert median_step(np.array([0.0, 0.5])) == 0.5
    assert np.isnan(median_step(np.array([0.0, np.nan, 1.0, 2.0])))  # as np.median: a NaN step gives NaN
    assert np.isnan(median_step(np.array([5])))  # no step: NaN, as np.median of an empty array


@pytest.mark.parametrize("seed", range(40))
def test_unwrap_rad_is_numpys_unwrap_bit_for_bit(seed):
    """Series without a step of pi (the fast path), with wraps, with a NaN, a leading -0.0 and short ones."""
    from dronewind.core.timeseries import unwrap_rad

    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 3000))
    kind = seed % 4
    phase = np.cumsum(rng.normal(0.0, [0.01, 0.5, 2.0, 0.01][kind], n))
    if kind == 0:  # a yaw that crosses +/-180 degree: wrapped, so numpy unwraps it
        phase = np.mod(phase + np.pi, 2 * np.pi) - np.pi
    if kind == 3 and n > 5:
        phase[n // 2] = np.nan
    if seed % 7 == 0 and n:
        phase[0] = -0.0
    expected = np.unwrap(phase)
    got = unwrap_rad(phase)
    assert got.shape == expected.shape
    np.testing.assert_array_equal(got.view(np.uint64), expected.view(np.uint64))
    assert got is not phase
