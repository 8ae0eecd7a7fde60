"""Known-answer tests for dronewind.core.stats (Ghirardelli et al. 2025, Sect. 4.1, Eq. 9, Table 4-5)."""

from __future__ import annotations

import numpy as np
import pytest

from dronewind.core import stats
from dronewind.core.constants import GRAVITY_MS2, KARMAN
from dronewind.errors import InputError


def test_variance_of_sine_is_half_amplitude_squared() -> None:
    # 100 whole periods: block-mean fluctuation gives exactly A^2/2 (up to rounding)
    amp, period_s, fs_hz = 2.5, 10.0, 20.0
    t = np.arange(int(100 * period_s * fs_hz)) / fs_hz
    x = 7.0 + amp * np.sin(2 * np.pi * t / period_s)
    assert stats.standard_deviation(x, "constant") ** 2 == pytest.approx(amp**2 / 2, rel=1e-10)
    # a linear detrend also removes the small regression of the sine on t:
    # slope ~ -A P/(pi T^2) -> relative variance loss ~ 6/(pi^2 k^2) = 6e-5 for k = 100 periods
    assert stats.standard_deviation(x, "linear") ** 2 == pytest.approx(amp**2 / 2, rel=1e-4)


def test_linear_trend_is_removed() -> None:
    t = np.arange(1000.0)
    x = 3.0 + 0.01 * t + np.sin(t)
    xp = stats.detrend(x)
    assert abs(np.polyfit(t, xp, 1)[0]) < 1e-12
    assert abs(xp.mean()) < 1e-12
    assert np.all(np.isnan(stats.detrend(np.array([1.0, np.nan, 3.0]))))


def test_detrend_is_scipys_least_squares_line() -> None:
    """The closed-form line (core.stats.detrend) is the one scipy.signal.detrend fits by SVD.

    Random walks (the worst case: a large trend and slow wander) of 2 to 54 000 samples, 1-D
    and 2-D along either axis; bound 2e-15 of the series' largest magnitude (measured: at
    most 7e-16, a few units of the last place of float64: the two solutions differ only in
    rounding).
    """
    import scipy.signal

    rng = np.random.default_rng(7)
    for n in (2, 3, 17, 256, 13_440, 53_760):
        x = 5.0 + np.cumsum(rng.standard_normal(n))
        ref = scipy.signal.detrend(x, type="linear")
        assert np.max(np.abs(stats.detrend(x) - ref)) <= 2e-15 * np.max(np.abs(x))
    m = np.cumsum(rng.standard_normal((6, 500)), axis=1)
    for axis, arr in ((-1, m), (0, m.T)):
        ref = scipy.signal.detrend(arr, axis=axis, type="linear")
        assert np.max(np.abs(stats.detrend(arr, axis=axis) - ref)) <= 2e-15 * np.max(np.abs(m))
    # a NaN makes only its own series NaN
    m[2, 10] = np.nan
    out = stats.detrend(m)
    assert np.all(np.isnan(out[2])) and np.all(np.isfinite(np.delete(out, 2, axis=0)))


def test_tiny_array_moments_and_covariance() -> None:
    # MetPy-style hand-computed values
    a = np.array([1.0, 2.0, 3.0, 4.0])
    b = np.array([2.0, 1.0, 4.0, 3.0])
    # means 2.5; a' = [-1.5,-.5,.5,1.5], b' = [-.5,-1.5,1.5,.5]; sum a'b' = .75+.75+.75+.75 = 3
    assert stats.covariance(a, b, "constant") == pytest.approx(0.75)
    assert stats.standard_deviation(a, "constant") == pytest.approx(np.sqrt(1.25))
    assert stats.skewness(a, "constant") == pytest.approx(0.0, abs=1e-15)
    # kurtosis of [-1.5,-.5,.5,1.5]: mean x^4 = (2*5.0625+2*.0625)/4 = 2.5625 ; / 1.25^2 = 1.64
    assert stats.kurtosis(a, "constant") == pytest.approx(1.64)
    # linear detrend of an exact line leaves zero
    assert stats.standard_deviation(a, "linear") == pytest.approx(0.0, abs=1e-14)
    with pytest.raises(InputError):
        stats.covariance(a, b[:3])
    with pytest.raises(InputError):
        stats.fluctuation(a, "quadratic")  # type: ignore[arg-type]


def test_gaussian_moments() -> None:
    x = np.random.default_rng(1).normal(size=200_000)
    # standard errors: skew sqrt(6/N)=0.0055, kurtosis sqrt(24/N)=0.011 -> 4 sigma tolerances
    assert stats.skewness(x) == pytest.approx(0.0, abs=0.022)
    assert stats.kurtosis(x) == pytest.approx(3.0, abs=0.045)


def test_mean_wind_direction_convention() -> None:
    # wind blowing towards north-east comes from the south-west (225 deg)
    speed, direction = stats.mean_wind(np.full(10, 3.0), np.full(10, 3.0))
    assert speed == pytest.approx(3 * np.sqrt(2))
    assert direction == pytest.approx(225.0)
    _, d_west = stats.mean_wind(np.full(3, 5.0), np.zeros(3))  # towards east = from west
    assert d_west == pytest.approx(270.0)
    _, d_north = stats.mean_wind(np.zeros(3), np.full(3, -2.0))  # towards south = from north
    assert d_north == pytest.approx(0.0)


def test_friction_velocity_tke_intensity() -> None:
    assert stats.friction_velocity(-0.3, 0.4) == pytest.approx(np.sqrt(0.5))
    assert stats.turbulent_kinetic_energy(1.0, 2.0, 2.0) == pytest.approx(4.5)
    assert stats.turbulence_intensity(1.0, 4.0) == pytest.approx(0.25)
    assert np.isnan(stats.turbulence_intensity(1.0, 0.0))


def test_obukhov_length_hand_computed() -> None:
    # L = -u*^3 theta / (g kappa w'theta'), g = 9.81, kappa = 0.40
    # unstable: u* = 0.3, w'T' = 0.1, 300 K -> -0.027*300/(9.81*0.4*0.1) = -20.642 m
    ell = stats.obukhov_length(0.3, 0.1, 300.0)
    assert ell == pytest.approx(-20.6422018, rel=1e-7)
    # stable: u* = 0.5, w'T' = -0.02, 280 K -> +0.125*280/(0.07848) = 445.974 m
    assert stats.obukhov_length(0.5, -0.02, 280.0) == pytest.approx(445.9734964, rel=1e-7)
    assert stats.stability_parameter(30.0, -20.6422018) == pytest.approx(-1.4533333, rel=1e-6)
    assert np.isinf(stats.obukhov_length(0.3, 0.0, 300.0))
    with pytest.raises(InputError):
        stats.obukhov_length(0.3, 0.1, 20.0 - 273.15)


def test_published_stability_consistent_with_table5() -> None:
    """Ghirardelli et al. (2025): Table 4 zeta vs Table 5 fluxes (rounded to 0.1), mast sensor.

    s7 (60 m, zeta = 0.1, u'w' = -0.5, w'T' printed as 0.0): zeta and u* imply a
    buoyancy flux that must round to 0.0 (|w'T'| < 0.05 K m/s); December, ~280 K.
    s1 (30 m, zeta = -0.46, u'w' = -0.1, w'T' = 0.1): the published zeta must lie within
    the range Eq. 9 gives for the rounding intervals of u'w' and w'T' (v'w' = 0 assumed).
    """
    z7, zeta7, u_star7, theta7 = 60.0, 0.1, np.sqrt(0.5), 280.0
    wt7 = -(u_star7**3) * theta7 / (GRAVITY_MS2 * KARMAN * (z7 / zeta7))
    assert abs(wt7) < 0.05
    assert wt7 < 0  # stable
    zetas = [
        stats.stability_parameter(30.0, stats.obukhov_length(np.sqrt(abs(uw)), wt, 300.0))
        for uw in (-0.05, -0.15)
        for wt in (0.05, 0.15)
    ]
    assert min(zetas) <= -0.46 <= max(zetas)
