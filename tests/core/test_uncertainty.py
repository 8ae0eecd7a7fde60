"""Tests for dronewind.core.uncertainty (Ghirardelli et al. 2025, Sect. 4.2, Eqs 10-13) incl. Monte Carlo."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from dronewind.core import uncertainty
from dronewind.core.stats import detrend
from dronewind.errors import InputError

FS_HZ, T_S, DURATION_S, N_REAL = 10.0, 1.0, 600.0, 400


@pytest.fixture(scope="module")
def ensemble() -> tuple[np.ndarray, np.ndarray, float]:
    """400 seeded realisations of a correlated pair of AR(1) series (T = 1 s, 10 min).

    u is AR(1) with unit variance; w = rho u + sqrt(1 - rho^2) n with n an independent
    AR(1) of the same T, so both have autocorrelation exp(-tau/T) and corr(u, w) = rho.
    """
    rho = -0.4
    n = int(DURATION_S * FS_HZ)
    phi = np.exp(-1.0 / (FS_HZ * T_S))
    rng = np.random.default_rng(7)
    u = scipy.signal.lfilter([1.0], [1.0, -phi], rng.normal(size=(N_REAL, n)) * np.sqrt(1 - phi**2), axis=1)
    other = scipy.signal.lfilter([1.0], [1.0, -phi], rng.normal(size=(N_REAL, n)) * np.sqrt(1 - phi**2), axis=1)
    w = rho * u + np.sqrt(1 - rho**2) * other
    return detrend(u), detrend(w), rho


def test_variance_error_matches_monte_carlo(ensemble) -> None:
    """Spread of 400 variance estimates vs the ergodic formula with the fitted T_phi.

    Gaussian theory: eps = sqrt(2T/tau) = 0.0577. Measured: MC 0.062, formula 0.057
    (mean over 40 records). The MC relative spread itself has a 3.5 % standard error
    (1/sqrt(2*400)) and T_phi is fitted per record: tolerance 15 %.
    """
    up, _, _ = ensemble
    variances = np.mean(up**2, axis=1)
    mc = variances.std() / variances.mean()
    predicted = [uncertainty.relative_random_error(up[i] ** 2, DURATION_S, fs_hz=FS_HZ) for i in range(40)]
    values = np.array([p.value for p in predicted])
    assert np.all(np.isfinite(values))
    assert mc == pytest.approx(np.sqrt(2 * T_S / DURATION_S), rel=0.15)  # theory vs MC
    assert np.mean(values) == pytest.approx(mc, rel=0.15)  # formula vs MC
    # T_phi of a squared Gaussian AR(1) is T/2
    assert np.mean([p.time_scale_s for p in predicted]) == pytest.approx(T_S / 2, rel=0.15)
    assert all(p.below_threshold for p in predicted)


def test_flux_error_matches_monte_carlo(ensemble) -> None:
    """Same for the covariance u'w' (rho = -0.4): theory sqrt((T/tau)(1+rho^2)/rho^2) = 0.110.

    Measured: MC 0.107, formula 0.111; tolerance 15 %.
    """
    up, wp, rho = ensemble
    cov = np.mean(up * wp, axis=1)
    mc = cov.std() / abs(cov.mean())
    theory = np.sqrt(T_S / DURATION_S * (1 + rho**2) / rho**2)
    values = [uncertainty.relative_random_error(up[i] * wp[i], DURATION_S, fs_hz=FS_HZ).value for i in range(40)]
    assert mc == pytest.approx(theory, rel=0.15)
    assert np.mean(values) == pytest.approx(mc, rel=0.15)


def test_paper_form_hand_computed() -> None:
    # phi = [1, 3] -> mean 2, mean phi^2 = 5, var = 1
    phi = np.array([1.0, 3.0])
    # Eq. 12 form: a^2 = z/(tau U) * (5/4 - 1) = 30/(600*5) * 0.25 = 0.0025 -> a = 0.05
    r = uncertainty.paper_uncertainty(phi, 30.0, 600.0, 5.0, normaliser=2.0)
    assert r.value == pytest.approx(0.05)
    assert r.below_threshold and r.time_scale_s == pytest.approx(6.0)
    # Eq. 13 (variance, factor 4): a = 0.1
    assert uncertainty.paper_uncertainty(phi, 30.0, 600.0, 5.0, 2.0, variance=True).value == pytest.approx(0.1)
    # Eq. 10 with u*^2 = 0.5: a^2 = 0.01 * 1/0.25 -> a = 0.2
    assert uncertainty.paper_uncertainty(phi, 30.0, 600.0, 5.0, 0.5).value == pytest.approx(0.2)


def test_paper_form_gaussian_variance_equals_eq13() -> None:
    # kurtosis 3: a^2 = 4 z/(tau U) (3 - 1); z/(tau U) = 0.01 -> a = sqrt(0.08)
    x = detrend(np.random.default_rng(1).normal(size=400_000))
    r = uncertainty.paper_uncertainty(x * x, 30.0, 600.0, 5.0, float(np.mean(x * x)), variance=True)
    assert r.value == pytest.approx(np.sqrt(0.08), rel=0.01)


def test_threshold_and_undefined_cases() -> None:
    phi = np.random.default_rng(2).normal(1.0, 3.0, size=1000)
    big = uncertainty.paper_uncertainty(phi, 60.0, 300.0, 0.5, normaliser=1.0)  # low wind, short
    assert big.value > 0.5 and not big.below_threshold
    calm = uncertainty.paper_uncertainty(phi, 60.0, 300.0, 0.0, normaliser=1.0)
    assert np.isnan(calm.value) and "not positive" in calm.reason and not calm.below_threshold
    zero = uncertainty.relative_random_error(phi - phi.mean(), 100.0, time_scale_s=1.0)
    assert np.isnan(zero.value) and "zero" in zero.reason
    with pytest.raises(InputError):
        uncertainty.relative_random_error(phi, 100.0)  # neither time scale nor fs
    with pytest.raises(InputError):
        uncertainty.product_series(np.ones(3), np.ones(4))


def test_eq11_is_the_variance_of_the_vw_series_not_the_printed_form() -> None:
    """Eq. 11 as computed (and documented in paper_uncertainty): the variance of the v'w'
    product series over u*^4. The printed form (mean of (v'w')^2 over u*^4, minus 1) differs
    by 1 - mean(v'w')^2/u*^4 in the bracket and is negative here (weak v under a strong
    momentum flux), so it is no variance."""
    rng = np.random.default_rng(3)
    n = 20_000
    v, w = 0.3 * rng.standard_normal(n), rng.standard_normal(n)
    u = -1.0 * w + 0.5 * rng.standard_normal(n)  # u'w' < 0 strong, v'w' ~ 0 after a double rotation
    phi = v * w
    ustar2 = float(np.sqrt(np.mean(u * w) ** 2 + np.mean(v * w) ** 2))
    z, tau, speed = 30.0, 1800.0, 5.0
    got = uncertainty.paper_uncertainty(phi, z, tau, speed, ustar2).value
    expected = np.sqrt(z / (tau * speed) * (np.mean(phi**2) - np.mean(phi) ** 2) / ustar2**2)
    assert got == pytest.approx(expected, rel=1e-12)
    printed_bracket = np.mean(phi**2) / ustar2**2 - 1.0
    code_bracket = (np.mean(phi**2) - np.mean(phi) ** 2) / ustar2**2
    assert code_bracket - printed_bracket == pytest.approx(1.0 - np.mean(phi) ** 2 / ustar2**2, rel=1e-9)
    assert printed_bracket < 0 < code_bracket
