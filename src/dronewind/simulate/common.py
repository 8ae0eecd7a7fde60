"""Helpers shared by the quadrotor and wind-tunnel simulators: settings merge and simple processes.

* :func:`merge_settings`: defaults overridden by a manifest's settings (nested mappings merged);
* :func:`first_order_lag`: exact discretisation of :math:`\\dot y = (x - y)/\\tau` (an
  attitude that follows the wind with a lag);
* :func:`ornstein_uhlenbeck`: a stationary Gauss-Markov series (hover wander, positional
  drift, stand-in turbulence).
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["merge_settings", "first_order_lag", "ornstein_uhlenbeck", "one_pole_filter"]


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
    x = np.asarray(x, float)
    return one_pole_filter(1 - a, a, x, a * x[0])


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
    return one_pole_filter(1.0, a, e, 0.0)


def one_pole_filter(b0: float, a: float, x: np.ndarray, z0: float) -> np.ndarray:
    """The one-pole recursion :math:`y_k = a\\,y_{k-1} + b_0 x_k`, with :math:`a\\,y_{-1} = z_0`.

    The same numbers, to the last bit, as ``scipy.signal.lfilter([b0], [1, -a], x, zi=[z0])[0]``
    (direct form II transposed: :math:`y_k = z + b_0 x_k`, then :math:`z = a y_k`).

    Parameters
    ----------
    b0 : float
        Input coefficient.
    a : float
        Pole (feedback coefficient).
    x : numpy.ndarray
        Input series (1-D, float).
    z0 : float
        Initial state, the feedback term of the first sample.

    Returns
    -------
    numpy.ndarray
        Filtered series, the shape of ``x``.

    Notes
    -----
    Importing :mod:`scipy.signal` costs about 0.9 CPU-s (it imports :mod:`scipy.stats`), more
    than a simulation job filters: when the process has not imported it, the recursion runs
    here, a loop over Python floats (about 70 ns per sample, 5 ms for the 65 000 samples of
    a quadrotor flight); when it has, :func:`scipy.signal.lfilter` runs it.
    """
    x = np.asarray(x, dtype=float)
    signal = sys.modules.get("scipy.signal")
    if signal is not None and hasattr(signal, "lfilter"):
        return np.asarray(signal.lfilter([b0], [1.0, -a], x, zi=[z0])[0])
    b0, a = float(b0), float(a)
    out = []
    z = float(z0)
    for xk in x.tolist():
        yk = z + b0 * xk
        out.append(yk)
        z = a * yk
    return np.asarray(out, dtype=float).reshape(x.shape)
