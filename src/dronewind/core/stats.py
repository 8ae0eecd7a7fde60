r"""One-point turbulence statistics of sonic-anemometer records.

Small, pure functions in the style of :mod:`metpy.calc.turbulence`: each takes plain
arrays (time along the last axis) and returns a number or an array. Fluctuations are
taken about a linear trend by default, as in Ghirardelli et al. (2025), Sect. 4.4 ("Integral and spectral
turbulence characteristics are studied using linearly detrended data"); ``detrend=
"constant"`` gives plain Reynolds (block-mean) fluctuations for comparison with other
software.

A non-finite sample makes the statistic NaN (NumPy semantics); callers that need a
number count and report missing samples first (see :func:`dronewind.compare.l4.flight_l4`).

References
----------
.. [1] Ghirardelli, M., Kral, S. T., Cheynet, E., Reuder, J., et al.: SAMURAI-S,
   Ghirardelli et al. (2025) of this project, Sects. 4.1-4.4.
.. [2] Kaimal, J. C. and Finnigan, J. J.: Atmospheric Boundary Layer Flows, Oxford
   University Press, 1994.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import scipy.stats

from dronewind.core.angles import rad2deg
from dronewind.core.constants import GRAVITY_MS2, KARMAN
from dronewind.errors import InputError

Detrend = Literal["linear", "constant", "none"]

__all__ = [
    "covariance",
    "detrend",
    "fluctuation",
    "friction_velocity",
    "kurtosis",
    "mean_wind",
    "obukhov_length",
    "skewness",
    "stability_parameter",
    "standard_deviation",
    "turbulence_intensity",
    "turbulent_kinetic_energy",
]


def detrend(x: np.ndarray, axis: int = -1) -> np.ndarray:
    r"""Remove a least-squares straight line from a series.

    Parameters
    ----------
    x : array-like
        Series [any unit], time along ``axis``; evenly sampled.
    axis : int, optional
        Time axis. Default -1.

    Returns
    -------
    numpy.ndarray
        ``x`` minus its linear trend (zero mean) [unit of ``x``]. All NaN if ``x`` holds a
        non-finite value along ``axis``.

    Notes
    -----
    .. math:: x'(t) = x(t) - (\alpha + \beta t),

    with :math:`\alpha, \beta` from ordinary least squares. Ghirardelli et al. (2025), Sect. 4.4. The line
    is fitted in closed form about the record's centre,
    :math:`\beta = \sum_k \tau_k x_k / \sum_k \tau_k^2` with
    :math:`\tau_k = k - (n-1)/2` and :math:`\alpha = \bar x` there, which is the solution
    ``scipy.signal.detrend(type="linear")`` finds with a singular-value decomposition
    (the same to within 2e-15 of the series' largest magnitude, tested) at a quarter to a
    ninth of its cost: the forward model detrends
    every series of every run.
    """
    arr = np.asarray(x, dtype=float)
    is_finite = np.isfinite(arr)
    if (arr.ndim <= 1 or axis in (-1, arr.ndim - 1)) and bool(is_finite.all()):
        # a finite series along the last axis (the usual case) is neither filled nor NaN'd
        # at the end: the same numbers without the two copies
        return _line_removed(arr)
    return _detrend_filled(arr, is_finite, axis)


def _detrend_filled(arr: np.ndarray, is_finite: np.ndarray, axis: int) -> np.ndarray:
    """:func:`detrend` of any float series: fitted with its non-finite samples as 0, NaN where one was."""
    finite = np.all(is_finite, axis=axis, keepdims=True)
    out = _line_removed(np.moveaxis(np.where(is_finite, arr, 0.0), axis, -1))
    return np.where(finite, np.moveaxis(out, -1, axis), np.nan)


def _line_removed(filled: np.ndarray) -> np.ndarray:
    """``filled`` (finite, time along the last axis) minus its least-squares line (:func:`detrend`, Notes)."""
    n = filled.shape[-1]
    if n == 0:
        return filled.copy()
    tau = np.arange(n, dtype=float) - 0.5 * (n - 1)
    # einsum, not the matrix product: BLAS may run a long dot product on threads that keep
    # spinning after it (their CPU counted against the job) where it is not set to one thread
    slope = np.einsum("...k,k->...", filled, tau) / float(np.sum(tau * tau)) if n > 1 else np.zeros(filled.shape[:-1])
    return filled - filled.mean(axis=-1, keepdims=True) - np.asarray(slope)[..., None] * tau


def fluctuation(x: np.ndarray, method: Detrend = "linear", axis: int = -1) -> np.ndarray:
    r"""Turbulent fluctuation :math:`x'` about a trend or the block mean.

    Parameters
    ----------
    x : array-like
        Series [any unit].
    method : {"linear", "constant", "none"}
        ``"linear"``: about a least-squares line (Ghirardelli et al. (2025), Sect. 4.4); ``"constant"``:
        about the block mean (Reynolds decomposition, Ghirardelli et al. (2025), Sect. 4.1); ``"none"``:
        ``x`` is already a fluctuation.
    axis : int, optional
        Time axis.

    Returns
    -------
    numpy.ndarray
        Fluctuation [unit of ``x``].
    """
    arr = np.asarray(x, dtype=float)
    if method == "linear":
        return detrend(arr, axis=axis)
    if method == "constant":
        return arr - np.mean(arr, axis=axis, keepdims=True)
    if method == "none":
        return arr
    raise InputError("fluctuation(method)", f"expected 'linear', 'constant' or 'none', got {method!r}")


def mean_wind(u_east_ms: np.ndarray, v_north_ms: np.ndarray, axis: int = -1) -> tuple[float, float]:
    r"""Mean horizontal wind speed and the direction the wind blows from.

    Parameters
    ----------
    u_east_ms, v_north_ms : array-like
        Eastward and northward wind [m s-1].
    axis : int, optional
        Time axis.

    Returns
    -------
    speed_ms : float or numpy.ndarray
        Speed of the mean vector :math:`\sqrt{\bar u^2 + \bar v^2}` [m s-1].
    wind_from_deg : float or numpy.ndarray
        Meteorological direction, clockwise from north, in [0, 360) [degree].

    Notes
    -----
    .. math:: \mathrm{dir} = (270^\circ - \operatorname{atan2}(\bar v, \bar u)) \bmod 360^\circ
    """
    ub = np.mean(np.asarray(u_east_ms, dtype=float), axis=axis)
    vb = np.mean(np.asarray(v_north_ms, dtype=float), axis=axis)
    speed = np.hypot(ub, vb)
    direction = np.mod(270.0 - rad2deg(np.arctan2(vb, ub)), 360.0)
    return speed, direction


def standard_deviation(x: np.ndarray, method: Detrend = "linear", axis: int = -1) -> np.ndarray:
    r"""Standard deviation :math:`\sigma_x` of the fluctuation (population form, 1/N).

    Parameters
    ----------
    x : array-like
        Series [any unit].
    method : {"linear", "constant", "none"}
        Detrending, see :func:`fluctuation`.
    axis : int, optional
        Time axis.

    Returns
    -------
    float or numpy.ndarray
        :math:`\sigma_x = \sqrt{\overline{x'^2}}` [unit of ``x``].
    """
    xp = fluctuation(x, method, axis)
    return np.sqrt(np.mean(xp**2, axis=axis))


def covariance(a: np.ndarray, b: np.ndarray, method: Detrend = "linear", axis: int = -1) -> np.ndarray:
    r"""Kinematic covariance :math:`\overline{a'b'}` (1/N), e.g. u'w' or w'θ_v'.

    Parameters
    ----------
    a, b : array-like
        Series of equal shape [units of a, b].
    method : {"linear", "constant", "none"}
        Detrending, see :func:`fluctuation`.
    axis : int, optional
        Time axis.

    Returns
    -------
    float or numpy.ndarray
        Covariance [unit a × unit b].
    """
    aa = np.asarray(a, dtype=float)
    bb = np.asarray(b, dtype=float)
    if aa.shape != bb.shape:
        raise InputError("covariance(a, b)", f"shapes differ: {aa.shape} vs {bb.shape}")
    return np.mean(fluctuation(aa, method, axis) * fluctuation(bb, method, axis), axis=axis)


def skewness(x: np.ndarray, method: Detrend = "linear", axis: int = -1) -> np.ndarray:
    r"""Skewness :math:`\gamma = \overline{x'^3}/\sigma^3` (Ghirardelli et al. (2025), Sect. 4.1, Table 5).

    Parameters
    ----------
    x : array-like
        Series [any unit].
    method : {"linear", "constant", "none"}
        Detrending, see :func:`fluctuation`.
    axis : int, optional
        Time axis.

    Returns
    -------
    float or numpy.ndarray
        Skewness [1]; 0 for a Gaussian process.
    """
    xp = fluctuation(x, method, axis)
    return scipy.stats.skew(xp, axis=axis, bias=True)


def kurtosis(x: np.ndarray, method: Detrend = "linear", axis: int = -1) -> np.ndarray:
    r"""Kurtosis :math:`\kappa = \overline{x'^4}/\sigma^4` (Pearson; 3 for a Gaussian).

    Ghirardelli et al. (2025), Sect. 4.1 and Table 5 use this (non-excess) definition.

    Parameters
    ----------
    x : array-like
        Series [any unit].
    method : {"linear", "constant", "none"}
        Detrending, see :func:`fluctuation`.
    axis : int, optional
        Time axis.

    Returns
    -------
    float or numpy.ndarray
        Kurtosis [1].
    """
    xp = fluctuation(x, method, axis)
    return scipy.stats.kurtosis(xp, axis=axis, fisher=False, bias=True)


def friction_velocity(uw_m2s2: float | np.ndarray, vw_m2s2: float | np.ndarray) -> np.ndarray:
    r"""Friction velocity from the two vertical momentum fluxes.

    Parameters
    ----------
    uw_m2s2, vw_m2s2 : float or array-like
        :math:`\overline{u'w'}`, :math:`\overline{v'w'}` [m2 s-2].

    Returns
    -------
    float or numpy.ndarray
        :math:`u_*` [m s-1].

    Notes
    -----
    .. math:: u_* = \left(\overline{u'w'}^2 + \overline{v'w'}^2\right)^{1/4}

    As in :func:`metpy.calc.friction_velocity` and Ghirardelli et al. (2025) (Eqs 4-10).
    """
    uw = np.asarray(uw_m2s2, dtype=float)
    vw = np.asarray(vw_m2s2, dtype=float)
    return np.sqrt(np.sqrt(uw**2 + vw**2))


def turbulent_kinetic_energy(
    sigma_u_ms: float | np.ndarray, sigma_v_ms: float | np.ndarray, sigma_w_ms: float | np.ndarray
) -> np.ndarray:
    r"""Specific turbulent kinetic energy from the three standard deviations.

    Parameters
    ----------
    sigma_u_ms, sigma_v_ms, sigma_w_ms : float or array-like
        Standard deviations of the velocity components [m s-1].

    Returns
    -------
    float or numpy.ndarray
        :math:`e` [m2 s-2] (CF ``specific_turbulent_kinetic_energy_of_air``).

    Notes
    -----
    .. math:: e = \tfrac12\left(\sigma_u^2 + \sigma_v^2 + \sigma_w^2\right)

    Ghirardelli et al. (2025), Sect. 3.3 (the TKE it minimises over the sonic-INS lag).
    """
    su, sv, sw = (np.asarray(s, dtype=float) for s in (sigma_u_ms, sigma_v_ms, sigma_w_ms))
    return 0.5 * (su**2 + sv**2 + sw**2)


def turbulence_intensity(sigma_u_ms: float | np.ndarray, speed_ms: float | np.ndarray) -> np.ndarray:
    r"""Streamwise turbulence intensity :math:`I_u = \sigma_u/\bar u` (Ghirardelli et al. (2025), Eq. 16).

    Parameters
    ----------
    sigma_u_ms : float or array-like
        Streamwise standard deviation [m s-1].
    speed_ms : float or array-like
        Mean wind speed [m s-1].

    Returns
    -------
    float or numpy.ndarray
        :math:`I_u` [1]; NaN where ``speed_ms`` is 0.
    """
    su = np.asarray(sigma_u_ms, dtype=float)
    sp = np.asarray(speed_ms, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(sp != 0.0, su / np.where(sp != 0.0, sp, 1.0), np.nan)


def obukhov_length(
    u_star_ms: float | np.ndarray,
    w_theta_v_kms: float | np.ndarray,
    theta_v_mean_k: float | np.ndarray,
    karman: float = KARMAN,
    gravity_ms2: float = GRAVITY_MS2,
) -> np.ndarray:
    r"""Obukhov length (Ghirardelli et al. (2025), Eq. 9).

    Parameters
    ----------
    u_star_ms : float or array-like
        Friction velocity [m s-1].
    w_theta_v_kms : float or array-like
        Buoyancy flux :math:`\overline{w'\theta_v'}` [K m s-1].
    theta_v_mean_k : float or array-like
        Mean virtual potential temperature [K]. Ghirardelli et al. (2025) approximates it by the mean
        *sonic* temperature, and so does :func:`dronewind.compare.l4.flight_l4` (``theta_v_k``).
    karman : float, optional
        von Karman constant [1]; 0.40 as in Ghirardelli et al. (2025).
    gravity_ms2 : float, optional
        Gravitational acceleration [m s-2]; 9.81.

    Returns
    -------
    float or numpy.ndarray
        :math:`L` [m] (CF ``atmosphere_obukhov_length``): negative when unstable
        (upward buoyancy flux), positive when stable; ±inf for zero flux; NaN if any
        input is NaN.

    Notes
    -----
    .. math:: L = -\frac{u_*^3\,\bar\theta_v}{g\,\kappa\,\overline{w'\theta_v'}}
    """
    us = np.asarray(u_star_ms, dtype=float)
    wt = np.asarray(w_theta_v_kms, dtype=float)
    th = np.asarray(theta_v_mean_k, dtype=float)
    if np.any(th <= 0):
        raise InputError("obukhov_length(theta_v_mean_k)", "expected an absolute temperature in K (> 0)")
    with np.errstate(divide="ignore", invalid="ignore"):
        return -(us**3) * th / (gravity_ms2 * karman * wt)


def stability_parameter(height_m: float | np.ndarray, obukhov_length_m: float | np.ndarray) -> np.ndarray:
    r"""Stability parameter :math:`\zeta = z/L` (Ghirardelli et al. (2025), Sect. 4.1 after Eq. 9).

    Parameters
    ----------
    height_m : float or array-like
        Measurement height above the surface [m].
    obukhov_length_m : float or array-like
        Obukhov length [m].

    Returns
    -------
    float or numpy.ndarray
        :math:`\zeta` [1]; 0 for an infinite L (neutral).
    """
    z = np.asarray(height_m, dtype=float)
    ell = np.asarray(obukhov_length_m, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return z / ell
