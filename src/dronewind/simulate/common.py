"""Helpers shared by the quadrotor and wind-tunnel simulators: settings merge and simple processes.

* :func:`merge_settings`: defaults overridden by a manifest's settings (nested mappings merged);
* :func:`first_order_lag`: exact discretisation of :math:`\\dot y = (x - y)/\\tau` (an
  attitude that follows the wind with a lag);
* :func:`ornstein_uhlenbeck`: a stationary Gauss-Markov series (hover wander, positional
  drift, stand-in turbulence).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import scipy.signal

__all__ = ["merge_settings", "first_order_lag", "ornstein_uhlenbeck"]


def merge_settings(base: Mapping[str, Any], over: Mapping[str, Any] | None) -> dict[str, Any]:
    """``base`` with the keys of ``over`` replaced; mappings present in both are merged recursively."""
    out = dict(base)
    for k, v in (over or {}).items():
        out[k] = merge_settings(base[k], v) if isinstance(v, Mapping) and isinstance(base.get(k), Mapping) else v
    return out


def first_order_lag(x: np.ndarray, tau_s: float, fs_hz: float) -> np.ndarray:
    """First-order low-pass (exact discretisation of dy/dt = (x - y)/tau), y[0] = x[0].

    Parameters
    ----------
    x : numpy.ndarray
        Input series.
    tau_s : float
        Time constant [s]; 0 or less returns a copy of ``x``.
    fs_hz : float
        Sampling rate [Hz].

    Returns
    -------
    numpy.ndarray
        Lagged series.
    """
    if tau_s <= 0:
        return np.asarray(x, float).copy()
    a = np.exp(-1.0 / (fs_hz * tau_s))
    y, _ = scipy.signal.lfilter([1 - a], [1, -a], x, zi=[a * x[0]])
    return y


def ornstein_uhlenbeck(rng: np.random.Generator, n: int, sd: float, tau_s: float, fs_hz: float) -> np.ndarray:
    """Ornstein-Uhlenbeck series with standard deviation ``sd`` and time scale ``tau_s``.

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source (``n + 1`` standard normal draws; none when ``sd <= 0``).
    n : int
        Number of samples.
    sd : float
        Stationary standard deviation.
    tau_s : float
        Correlation time [s].
    fs_hz : float
        Sampling rate [Hz].

    Returns
    -------
    numpy.ndarray
        The series, started from its stationary distribution.
    """
    if sd <= 0:
        return np.zeros(n)
    a = np.exp(-1.0 / (fs_hz * tau_s))
    e = rng.standard_normal(n) * sd * np.sqrt(1 - a * a)
    e[0] = rng.standard_normal() * sd
    y, _ = scipy.signal.lfilter([1.0], [1, -a], e, zi=[0.0])
    return y
