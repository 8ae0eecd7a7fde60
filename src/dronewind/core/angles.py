"""Angle conversions and wraps that give numpy's results bit for bit, faster on long series.

A forward flight's runs convert and wrap the same kinds of series (attitude, heading,
longitude) a few hundred times, and numpy's loops for these are slow ones:

* ``np.deg2rad`` and ``np.rad2deg`` (also ``np.radians``, ``np.degrees``) call a scalar C
  function per element that multiplies by ``pi/180`` (``180/pi``), a constant the compiler
  folds. Multiplying by the same double, in the vectorised multiply, gives the same bits.
* ``np.mod(x, 360.0)`` takes C's ``fmod`` and corrects the sign per element. When every
  element is already in [0, 360) the result is the element itself (``fmod`` is exact
  there, and a zero becomes +0), so one check of the range and ``x + 0.0`` (which turns -0
  into +0 and leaves everything else as it is) give the same bits.

The wraps fall back to numpy's function when an element is out of the range, NaN or
infinite, so their results never depend on the shortcut; such a series pays the check on top
(the simulator's heading, unwrapped over its turns, therefore calls numpy directly). On the
series of a forward run the shortcuts take about a tenth of numpy's time.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["deg2rad", "rad2deg", "wrap_360", "wrap_180"]

#: Radians per degree and degrees per radian: the doubles numpy's ``deg2rad`` and ``rad2deg``
#: multiply by (``NPY_PI/180.0`` and ``180.0/NPY_PI``).
RAD_PER_DEG: float = np.pi / 180.0
DEG_PER_RAD: float = 180.0 / np.pi


def _times(x: Any, factor: float, numpy_function: np.ufunc) -> Any:
    """``x * factor`` for float64 input (the bits ``numpy_function`` gives), else ``numpy_function(x)``."""
    if isinstance(x, float) or getattr(x, "dtype", None) == np.float64:
        return np.multiply(x, factor)
    return numpy_function(x)


def deg2rad(angle_deg: Any) -> Any:
    """``np.deg2rad(angle_deg)``, bit for bit, by the vectorised multiply for float64 input.

    Parameters
    ----------
    angle_deg : array_like
        Angle [degree].

    Returns
    -------
    numpy.ndarray or scalar
        Angle [rad], of the type ``np.deg2rad`` gives (other dtypes than float64 go to it).
    """
    return _times(angle_deg, RAD_PER_DEG, np.deg2rad)


def rad2deg(angle_rad: Any) -> Any:
    """``np.rad2deg(angle_rad)``, bit for bit, by the vectorised multiply for float64 input.

    Parameters
    ----------
    angle_rad : array_like
        Angle [rad].

    Returns
    -------
    numpy.ndarray or scalar
        Angle [degree], of the type ``np.rad2deg`` gives.
    """
    return _times(angle_rad, DEG_PER_RAD, np.rad2deg)


def wrap_360(angle_deg: np.ndarray) -> np.ndarray:
    """``np.mod(angle_deg, 360.0)`` of a float64 array, bit for bit: the angle in [0, 360) [degree].

    Parameters
    ----------
    angle_deg : numpy.ndarray
        Angle [degree], float64.

    Returns
    -------
    numpy.ndarray
        A new array; without numpy's per-element work when the angle is in [0, 360) already.
    """
    a = np.asarray(angle_deg, dtype=float)
    if a.size and 0.0 <= a.min() and a.max() < 360.0:  # False for NaN
        return a + 0.0
    return np.mod(a, 360.0)


def wrap_180(angle_deg: np.ndarray) -> np.ndarray:
    """``(angle_deg + 180.0) % 360.0 - 180.0`` of a float64 array, bit for bit [degree].

    Parameters
    ----------
    angle_deg : numpy.ndarray
        Angle [degree], float64.

    Returns
    -------
    numpy.ndarray
        The angle in [-180, 180) (up to the rounding of the shift by 180, as numpy's
        expression: the same bits).
    """
    return wrap_360(np.asarray(angle_deg, dtype=float) + 180.0) - 180.0
