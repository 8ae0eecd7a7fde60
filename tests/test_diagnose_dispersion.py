"""The empirical overdispersion of the campaign error model (campaign._calibrated_errors).

Known answers: a common offset in a feature's units (a sonic pitch adds its angle to the
tilt difference of every flight), with errors that differ fourfold between flights, does
not widen the errors; residuals that scatter three times their errors widen them three
times; residuals within their errors leave the k_min floor.
"""

from __future__ import annotations

import numpy as np
import pytest

from dronewind.diagnose import campaign as dc

N_SEEDS = 5


def _errors(y: np.ndarray, sigma_i: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Scale factors of one feature: forward seeds scattering exactly by their analytic errors."""
    n = len(sigma_i)
    runs = rng.normal(0.0, 1.0, (n, N_SEEDS, 1)) * sigma_i[:, None, None]
    run_sigma = np.broadcast_to(sigma_i[:, None, None], runs.shape).copy()
    _, _, scale = dc._calibrated_errors(y[:, None], sigma_i[:, None], runs, run_sigma)
    return scale


@pytest.mark.parametrize("offset", [0.0, 2.0, 8.0, -20.0])
def test_a_common_offset_in_feature_units_does_not_widen_the_errors(offset):
    rng = np.random.default_rng(11)
    sigma_i = np.array([0.8, 0.6, 0.45, 0.3, 0.8, 0.6, 0.45, 0.3])  # low to high wind, fourfold
    total = sigma_i * np.sqrt(1.0 + 1.0 / N_SEEDS)
    y = offset + rng.normal(0.0, 1.0, len(sigma_i)) * total
    scale = _errors(y, sigma_i, rng)
    # the offset is removed before the scatter is taken (chi2 on 7 dof / 7 with this draw:
    # the k_min = 1 floor or just above it; the scatter about the mean z-score instead gave
    # 1.95 for an offset of 2, 6.4 for 8 and 15.0 for -20)
    assert 1.0 <= scale[0] < 1.6, scale


def test_the_offset_is_the_same_for_every_offset_size():
    sigma_i = np.array([0.8, 0.6, 0.45, 0.3, 0.8, 0.6, 0.45, 0.3])
    noise = np.random.default_rng(3).normal(0.0, 1.0, len(sigma_i)) * sigma_i * 1.5
    scales = [_errors(offset + noise, sigma_i, np.random.default_rng(4))[0] for offset in (0.0, 1.0, 5.0, 40.0)]
    np.testing.assert_allclose(scales, scales[0], rtol=1e-9)


def test_residuals_scattering_three_times_their_errors_widen_them_three_times():
    rng = np.random.default_rng(5)
    sigma_i = rng.uniform(0.2, 0.8, 400)
    total = sigma_i * np.sqrt(1.0 + 1.0 / N_SEEDS)
    y = 1.5 + 3.0 * rng.normal(0.0, 1.0, len(sigma_i)) * total
    scale = _errors(y, sigma_i, rng)
    # 399 dof: the variance ratio has a relative standard error sqrt(2/399) = 7 %, the scale 3.5 %
    assert scale[0] == pytest.approx(3.0, rel=0.12)


def test_fewer_flights_than_the_minimum_are_not_used():
    sigma_i = np.array([0.8, 0.3, 0.5])
    wild = np.array([5.0, -5.0, 3.0])  # scattered far beyond the errors, but only 3 flights
    assert _errors(wild, sigma_i, np.random.default_rng(6))[0] == _errors(np.zeros(3), sigma_i,
                                                                          np.random.default_rng(6))[0]


def test_an_effect_constant_in_error_units_does_not_widen_the_errors():
    """A downdraft decays with wind speed as the tilt errors do: its effect is a constant
    number of errors at every flight, the second shape of the fitted common effect (the
    weighted mean in units alone left a scale of 5.8 on a hidden downdraft)."""
    rng = np.random.default_rng(12)
    sigma_i = np.array([0.8, 0.6, 0.45, 0.3, 0.8, 0.6, 0.45, 0.3])
    total = sigma_i * np.sqrt(1.0 + 1.0 / N_SEEDS)
    noise = rng.normal(0.0, 1.0, len(sigma_i)) * total
    scales = [_errors(k * total + 1.5 + noise, sigma_i, np.random.default_rng(13))[0] for k in (0.0, 4.0, -10.0)]
    np.testing.assert_allclose(scales, scales[0], rtol=1e-9)
    assert 1.0 <= scales[0] < 1.6, scales
