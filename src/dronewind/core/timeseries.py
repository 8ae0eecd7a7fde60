"""Small time-series helpers shared by the processing chains.

Time stamps of the products are ``datetime64[ns]``; the chains compute in float seconds
since a reference stamp, obtained by subtracting int64 nanoseconds before converting (so a
flight keeps sub-microsecond resolution). These helpers check the time axis and the
variables of an input dataset, fill NaN by linear interpolation in time, find the
longest run of a mask, the median step of a clock and unwrap an angle's series.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr

from dronewind.errors import InputError

__all__ = ["NS_PER_S", "fill_nan_by_time", "longest_true_run", "median_of_steps", "median_step", "require_variables",
           "time_ns", "unwrap_rad"]

#: Nanoseconds per second.
NS_PER_S: int = 1_000_000_000


def time_ns(ds: xr.Dataset, where: str) -> np.ndarray:
    """The ``time`` coordinate of a dataset as int64 nanoseconds, checked.

    Parameters
    ----------
    ds : xarray.Dataset
        Dataset with a ``time`` coordinate (or variable).
    where : str
        Name of the dataset in error messages.

    Returns
    -------
    numpy.ndarray
        int64 nanoseconds since 1970-01-01 [ns], strictly increasing, at least 2 values.

    Raises
    ------
    InputError
        No ``time``, fewer than 2 samples, or time not strictly increasing.
    """
    if "time" not in ds.coords and "time" not in ds.variables:
        raise InputError(where, "dataset has no 'time' coordinate")
    t = np.asarray(ds["time"].values).astype("datetime64[ns]").astype(np.int64)
    if t.size < 2:
        raise InputError(f"{where}:time", f"need at least 2 samples, got {t.size}")
    if np.any(np.diff(t) <= 0):
        raise InputError(f"{where}:time", "time must be strictly increasing (L1 removes duplicates and sorts)")
    return t


def require_variables(ds: xr.Dataset, names: Sequence[str], where: str) -> None:
    """Raise :class:`~dronewind.errors.InputError` unless ``ds`` holds every variable of ``names``.

    Parameters
    ----------
    ds : xarray.Dataset
        Input dataset.
    names : sequence of str
        Required variable names.
    where : str
        Name of the dataset in the error message.
    """
    missing = [n for n in names if n not in ds.variables]
    if missing:
        raise InputError(where, f"missing variables {missing}; expected {list(names)}")


def fill_nan_by_time(t_s: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, int]:
    """Linear interpolation in time over NaNs (the ends held at the nearest valid value).

    Parameters
    ----------
    t_s : numpy.ndarray
        Sample times [s], increasing.
    x : numpy.ndarray
        Series on ``t_s`` [any unit].

    Returns
    -------
    filled : numpy.ndarray
        ``x`` with its non-finite samples interpolated (``x`` itself when there is nothing
        to fill, or when no sample is finite).
    n_filled : int
        Number of samples filled (0 when no sample is finite).
    """
    bad = ~np.isfinite(x)
    n_bad = int(bad.sum())
    if n_bad == 0:
        return x, 0
    if n_bad == x.size:
        return x, 0
    out = x.copy()
    out[bad] = np.interp(t_s[bad], t_s[~bad], x[~bad])
    return out, n_bad


def longest_true_run(mask: np.ndarray) -> tuple[int, int, int]:
    """The longest run of True values of a mask.

    Parameters
    ----------
    mask : numpy.ndarray
        1-D boolean mask.

    Returns
    -------
    start, stop : int
        Index of the run's first sample and one past its last; (0, 0) if there is no True.
    n_runs : int
        Number of runs of True (0 if none).
    """
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    d = np.diff(m.astype(np.int8))
    starts = np.flatnonzero(d == 1)
    stops = np.flatnonzero(d == -1)
    if starts.size == 0:
        return 0, 0, 0
    k = int(np.argmax(stops - starts))
    return int(starts[k]), int(stops[k]), int(starts.size)


#: Every how many steps :func:`median_step` takes one for its candidate.
_STEP_SUBSAMPLE = 64


def median_step(t: np.ndarray) -> float:
    """Median of the steps between consecutive time stamps: ``np.median(np.diff(t))``, bit for bit.

    Parameters
    ----------
    t : numpy.ndarray
        1-D time stamps [any unit], integer or float.

    Returns
    -------
    float
        The median step [unit of ``t``]; NaN where ``np.median`` gives NaN (a NaN step, fewer
        than 2 stamps). :func:`median_of_steps` of ``np.diff(t)``.
    """
    return median_of_steps(np.diff(np.asarray(t)))


def median_of_steps(steps: np.ndarray) -> float:
    """``np.median(steps)`` bit for bit, for a clock's steps (nearly all the same).

    Parameters
    ----------
    steps : numpy.ndarray
        1-D steps between time stamps [any unit], integer or float.

    Returns
    -------
    float
        Their median [unit of ``steps``]; NaN for no step or a NaN step, as ``np.median``.

    Notes
    -----
    A logger's steps are nearly all the same, so the median of every 64th step is almost
    always the median of all: it is taken as a candidate :math:`c` and verified by counting,
    which is exact. With :math:`n` steps, fewer than :math:`n/2` of them below :math:`c` and
    fewer than :math:`n/2` above, both middle elements of the sorted steps equal :math:`c`,
    so the median is :math:`c`; otherwise (or with a NaN step) ``np.median`` of all steps is
    taken. Two counting passes replace a selection, whose cost varies with the steps' order
    (up to 10.8 ms for 92,000 INS steps), at about a fifth of its cost on a forward run's
    series.
    """
    n = steps.size
    if n == 0:
        return float("nan")  # as np.median of no steps, without its warning
    if steps.dtype.kind in "iu" or (steps.dtype.kind == "f" and not np.isnan(steps).any()):
        candidate = np.median(steps[::_STEP_SUBSAMPLE])
        if 2 * np.count_nonzero(steps < candidate) < n and 2 * np.count_nonzero(steps > candidate) < n:
            return float(candidate)
    return float(np.median(steps))


def unwrap_rad(phase_rad: np.ndarray) -> np.ndarray:
    """``np.unwrap(phase_rad)`` bit for bit: a series of angles without its jumps of 2 pi.

    Parameters
    ----------
    phase_rad : numpy.ndarray
        1-D series of angles [rad].

    Returns
    -------
    numpy.ndarray
        The series with multiples of :math:`2\\pi` added where consecutive samples differ by
        more than :math:`\\pi` (float64, a new array).

    Notes
    -----
    Where no step reaches :math:`\\pi` (a hovering payload's yaw between wraps, a series
    unwrapped before) ``np.unwrap`` adds a cumulative sum of zero corrections, so the result
    is the series plus 0.0 after its first sample; that is returned after one check of the
    steps instead of numpy's passes over the series. Otherwise (or with a NaN) numpy's
    function is called, after the check: a logged yaw that wraps at +/-180 degree costs 4 %
    more; on a forward run's series the check costs about a fifth of numpy's passes.
    """
    p = np.asarray(phase_rad, dtype=float)
    if p.ndim == 1 and p.size > 1:
        steps = np.diff(p)
        if bool(np.all(np.abs(steps) < np.pi)):
            out = p.copy()
            out[1:] = p[1:] + 0.0
            return out
    return np.unwrap(p)
