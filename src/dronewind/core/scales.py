r"""Integral time and length scales of turbulence (Ghirardelli et al. (2025), Sect. 4.3, Eqs 14-17).

Two steps, as in the paper: an exponential is fitted by least squares to the
autocovariance of the (linearly detrended) fluctuations, giving the integral time scale
:math:`T_\xi`; Taylor's frozen-turbulence hypothesis then gives the length scale
:math:`L_\xi = \bar u T_\xi` where it holds (:math:`I_u < 0.5` and :math:`\bar u > 1`
m s-1), and NaN with a reason where it does not.

References
----------
.. [1] Ghirardelli et al. (2025), Sect. 4.3, Eqs 14-17.
.. [2] Kaimal, J. C. and Finnigan, J. J.: Atmospheric Boundary Layer Flows, 1994.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
import scipy.signal

from dronewind.core.stats import Detrend, fluctuation
from dronewind.errors import InputError

__all__ = [
    "IntegralTimeScale",
    "LengthScale",
    "autocovariance",
    "integral_length_scale",
    "integral_time_scale",
]

#: Ghirardelli et al. (2025), Eq. 16: Taylor's hypothesis is used only below this turbulence intensity ...
MAX_TURBULENCE_INTENSITY: float = 0.5
#: ... and above this mean speed [m s-1].
MIN_TAYLOR_SPEED_MS: float = 1.0


@dataclass(frozen=True)
class IntegralTimeScale:
    """Result of :func:`integral_time_scale`.

    Attributes
    ----------
    time_scale_s : float
        :math:`T_\\xi` [s]; NaN when ``converged`` is False.
    converged : bool
        True when the least-squares fit converged to a finite, positive value inside the
        fitted lag range's plausible bounds.
    max_lag_fitted_s : float
        Largest lag used in the fit [s].
    n_lags_fitted : int
        Number of lags in the fit.
    reason : str
        Empty when converged, else why not.
    """

    time_scale_s: float
    converged: bool
    max_lag_fitted_s: float
    n_lags_fitted: int
    reason: str = ""


@dataclass(frozen=True)
class LengthScale:
    """Result of :func:`integral_length_scale`.

    Attributes
    ----------
    length_scale_m : float
        :math:`L_\\xi` [m]; NaN when ``valid`` is False.
    valid : bool
        True when Taylor's hypothesis holds (Ghirardelli et al. (2025), Eq. 16) and T is finite.
    reason : str
        Empty when valid, else why not.
    """

    length_scale_m: float
    valid: bool
    reason: str = ""


def autocovariance(
    x: np.ndarray, fs_hz: float, max_lag_s: float | None = None, method: Detrend = "linear"
) -> tuple[np.ndarray, np.ndarray]:
    r"""Autocovariance of the fluctuation of a series (Ghirardelli et al. (2025), Eq. 14).

    Parameters
    ----------
    x : array-like
        Evenly sampled 1-D series [any unit], finite.
    fs_hz : float
        Sampling rate [Hz].
    max_lag_s : float, optional
        Largest lag returned [s]; default half the record.
    method : {"linear", "constant", "none"}
        Detrending before the estimate (see :func:`dronewind.core.stats.fluctuation`).

    Returns
    -------
    lag_s : numpy.ndarray
        Lags 0, 1/fs, ... [s].
    r_xx : numpy.ndarray
        :math:`R_{\xi\xi}(\tau)` [unit²].

    Notes
    -----
    The biased estimator (divided by N, not N - k) is used: it is positive
    semi-definite and has the smaller mean-square error at large lags.

    .. math:: R_{\xi\xi}(\tau_k) = \frac1N \sum_{n=0}^{N-1-k} \xi'_n \xi'_{n+k}

    Computed with ``scipy.signal.correlate(method="fft")``.
    """
    arr = np.asarray(x, dtype=float)
    if arr.ndim != 1:
        raise InputError("autocovariance(x)", f"expected a 1-D series, got shape {arr.shape}")
    if fs_hz <= 0 or not np.isfinite(fs_hz):
        raise InputError("autocovariance(fs_hz)", f"expected a positive sampling rate, got {fs_hz}")
    if arr.size < 2 or not np.all(np.isfinite(arr)):
        raise InputError("autocovariance(x)", "expected at least 2 finite samples (no NaN)")
    xp = fluctuation(arr, method)
    n = xp.size
    full = scipy.signal.correlate(xp, xp, mode="full", method="fft")[n - 1 :] / n
    max_k = n // 2 if max_lag_s is None else min(n - 1, int(round(max_lag_s * fs_hz)))
    lag_s = np.arange(max_k + 1) / fs_hz
    return lag_s, full[: max_k + 1]


def integral_time_scale(
    x: np.ndarray,
    fs_hz: float,
    max_lag_s: float | None = None,
    method: Detrend = "linear",
) -> IntegralTimeScale:
    r"""Integral time scale by a least-squares exponential fit (Ghirardelli et al. (2025), Eqs 14-15).

    Parameters
    ----------
    x : array-like
        Evenly sampled 1-D series [any unit].
    fs_hz : float
        Sampling rate [Hz].
    max_lag_s : float, optional
        Upper bound of the lags fitted [s]. Default: the first zero crossing of the
        autocovariance (at most half the record).
    method : {"linear", "constant", "none"}
        Detrending before the autocovariance.

    Returns
    -------
    IntegralTimeScale
        :math:`T_\xi` with a convergence flag and a reason. Never raises for
        data problems (too short, constant, no decay): it returns NaN with a reason.

    Notes
    -----
    .. math:: R_{\xi\xi}(\tau) \approx R_{\xi\xi}(0)\,\exp(-\tau/T_\xi)

    The fit (``scipy.optimize.curve_fit``, one parameter) uses the normalised
    autocovariance from lag 0 to the first zero crossing: beyond it the estimate is
    dominated by sampling noise. The paper does not state its lag range; this choice is
    ours. The starting value is the lag where :math:`R/R(0)` first drops below 1/e.
    """
    arr = np.asarray(x, dtype=float)
    if arr.ndim != 1 or arr.size < 8 or not np.all(np.isfinite(arr)):
        return IntegralTimeScale(np.nan, False, np.nan, 0, "record shorter than 8 finite samples or has NaN")
    lag_s, r = autocovariance(arr, fs_hz, None, method)
    scale = float(np.max(np.abs(arr))) or 1.0
    if not r[0] > (1e-10 * scale) ** 2:  # relative: detrending a constant leaves rounding noise
        return IntegralTimeScale(np.nan, False, np.nan, 0, "zero variance")
    rho = r / r[0]
    negative = np.nonzero(rho <= 0.0)[0]
    k_end = int(negative[0]) if negative.size else rho.size
    if max_lag_s is not None:
        k_end = min(k_end, int(round(max_lag_s * fs_hz)) + 1)
    if k_end < 3:
        return IntegralTimeScale(
            np.nan, False, float(lag_s[max(k_end - 1, 0)]), k_end,
            "autocovariance reaches zero within 2 lags: time scale not resolved at this sampling rate",
        )
    tau = lag_s[:k_end]
    y = rho[:k_end]
    below = np.nonzero(y < np.exp(-1.0))[0]
    t0 = float(tau[below[0]]) if below.size else float(tau[-1])
    t0 = max(t0, 1.0 / fs_hz)

    # The parameter is ln T: the time scale stays positive without bounds, so curve_fit uses
    # MINPACK's Levenberg-Marquardt, about 7x faster here than its bounded trust-region solver
    # (the same least-squares minimum; time scales agree to 1e-5, far inside their sampling error).
    def model(t: np.ndarray, log_scale: float) -> np.ndarray:
        return np.exp(-t * np.exp(-log_scale))

    try:
        popt, _ = scipy.optimize.curve_fit(model, tau, y, p0=[np.log(t0)])
    except (RuntimeError, ValueError) as exc:  # curve_fit raises RuntimeError on non-convergence
        return IntegralTimeScale(np.nan, False, float(tau[-1]), k_end, f"exponential fit did not converge: {exc}")
    with np.errstate(over="ignore"):
        t_s = float(np.exp(popt[0]))
    record_s = arr.size / fs_hz
    if not np.isfinite(t_s) or t_s < 1e-3 / fs_hz:
        return IntegralTimeScale(np.nan, False, float(tau[-1]), k_end,
                                 "fit gave a time scale below a thousandth of the sampling interval")
    if t_s > record_s / 2:
        return IntegralTimeScale(
            np.nan, False, float(tau[-1]), k_end,
            f"fitted time scale {t_s:.3g} s exceeds half the record ({record_s / 2:.3g} s): not resolved",
        )
    return IntegralTimeScale(t_s, True, float(tau[-1]), k_end, "")


def integral_length_scale(
    time_scale_s: float,
    speed_ms: float,
    sigma_u_ms: float,
    max_intensity: float = MAX_TURBULENCE_INTENSITY,
    min_speed_ms: float = MIN_TAYLOR_SPEED_MS,
) -> LengthScale:
    r"""Integral length scale by Taylor's hypothesis (Ghirardelli et al. (2025), Eqs 16-17).

    Parameters
    ----------
    time_scale_s : float
        Integral time scale :math:`T_\xi` [s].
    speed_ms : float
        Mean wind speed :math:`\bar u` [m s-1].
    sigma_u_ms : float
        Streamwise standard deviation [m s-1], for :math:`I_u`.
    max_intensity : float, optional
        Upper bound of :math:`I_u` (0.5 in the paper).
    min_speed_ms : float, optional
        Lower bound of :math:`\bar u` [m s-1] (1 in the paper).

    Returns
    -------
    LengthScale
        :math:`L_\xi` [m], or NaN with the reason when the conditions fail.

    Notes
    -----
    .. math:: L_\xi = \bar u\,T_\xi \quad\text{if}\quad I_u = \sigma_u/\bar u < 0.5
              \ \text{and}\ \bar u > 1\ \mathrm{m\,s^{-1}}
    """
    if not np.isfinite(speed_ms) or speed_ms <= min_speed_ms:
        return LengthScale(np.nan, False, f"mean speed {speed_ms:.3g} m/s not above {min_speed_ms} m/s (Eq. 16)")
    intensity = sigma_u_ms / speed_ms
    if not np.isfinite(intensity) or intensity >= max_intensity:
        return LengthScale(np.nan, False,
                           f"turbulence intensity I_u={intensity:.3g} not below {max_intensity} (Eq. 16)")
    if not np.isfinite(time_scale_s):
        return LengthScale(np.nan, False, "integral time scale undefined")
    return LengthScale(float(speed_ms * time_scale_s), True, "")
