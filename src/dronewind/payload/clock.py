"""The payload logger's clock converted to UTC: a robust straight-line fit on the INS's GNSS time.

Both payload files are stamped by the logger's clock (``rpi_time_us``, not UTC). The INS
also logs GNSS UTC, so the logger clock is converted to UTC by a robust straight-line fit
``utc = a + b * rpi_time`` over the INS rows with a stable valid GNSS time (Ghirardelli et
al. 2025, Sect. 3.2), which is then applied to the sonic. A step in the relation
``utc - rpi_time`` larger than ``relation_jump_tol_s`` raises
:class:`~dronewind.payload.reader.ClockJumpError`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core.timeseries import median_step
from dronewind.errors import InputError
from dronewind.payload.reader import _US

__all__ = [
    "ClockFit",
    "fit_logger_clock",
]


@dataclass(frozen=True)
class ClockFit:
    """Straight-line map from logger time to UTC, ``utc = utc0 + offset + slope*(rpi - rpi0)``.

    Attributes
    ----------
    rpi0_us : int
        Reference logger time [us].
    utc0 : numpy.datetime64
        Reference UTC (ns).
    offset_s : float
        Fitted UTC at `rpi0_us` minus `utc0` [s].
    slope : float
        UTC seconds per logger second [1]; ``(slope - 1) * 1e6`` is the drift in ppm.
    residual_std_s : float
        Standard deviation of the residuals of the inlier rows [s].
    n_used : int
        Rows used in the final fit.
    n_outliers : int
        Rows rejected as outliers.
    rpi_first_us, rpi_last_us : int
        Span of logger times covered by the fit [us].
    """

    rpi0_us: int
    utc0: np.datetime64
    offset_s: float
    slope: float
    residual_std_s: float
    n_used: int
    n_outliers: int
    rpi_first_us: int
    rpi_last_us: int

    @property
    def drift_ppm(self) -> float:
        """Logger clock drift against UTC [ppm] (positive: UTC runs faster)."""
        return (self.slope - 1.0) * 1e6

    def to_utc(self, rpi_time_us: np.ndarray, resolution_ns: int = 1) -> np.ndarray:
        """Convert logger times [us] to UTC (datetime64[ns]).

        Parameters
        ----------
        rpi_time_us : numpy.ndarray
            Logger times [us].
        resolution_ns : int, optional
            Round the result to this many ns (1000: whole microseconds, the resolution of
            the INS UTC strings and of the NetCDF time encoding).
        """
        dx_s = (np.asarray(rpi_time_us, dtype=np.int64) - self.rpi0_us) / _US
        dy_ns = np.round((self.offset_s + self.slope * dx_s) * 1e9).astype(np.int64)
        utc_ns = self.utc0.astype("datetime64[ns]").astype(np.int64) + dy_ns
        if resolution_ns > 1:
            utc_ns = np.round(utc_ns / resolution_ns).astype(np.int64) * resolution_ns
        return utc_ns.astype("datetime64[ns]")

    def attrs(self) -> dict[str, Any]:
        """Dataset attributes describing the fit."""
        return {
            "clock_fit": "utc = clock_utc0 + clock_offset_s + clock_slope*(rpi_time_us - "
            "clock_rpi0_us)*1e-6 s",
            "clock_rpi0_us": int(self.rpi0_us),
            "clock_utc0": str(np.datetime_as_string(self.utc0, unit="us")) + "Z",
            "clock_offset_s": float(self.offset_s),
            "clock_slope": float(self.slope),
            "clock_drift_ppm": float(self.drift_ppm),
            "clock_residual_std_s": float(self.residual_std_s),
            "n_clock_fit_rows": int(self.n_used),
            "n_clock_fit_outliers": int(self.n_outliers),
        }


def fit_logger_clock(
    rpi_time_us: np.ndarray,
    utc: np.ndarray,
    n_iter: int = 5,
    clip_n_sigma: float = 5.0,
    min_clip_s: float = 2e-6,
) -> ClockFit:
    """Robust straight-line fit of GNSS UTC against the logger clock.

    Parameters
    ----------
    rpi_time_us : numpy.ndarray
        Logger times [us] (int64) of rows with a valid GNSS time.
    utc : numpy.ndarray
        Their UTC (datetime64).
    n_iter : int, optional
        Number of clip-and-refit iterations.
    clip_n_sigma : float, optional
        Rows whose residual exceeds `clip_n_sigma` robust standard deviations (1.4826 MAD)
        are rejected [1].
    min_clip_s : float, optional
        Floor of the clipping threshold [s] (the UTC strings have 1 us resolution).

    Returns
    -------
    ClockFit

    Notes
    -----
    Least squares on centred variables :math:`x = (r - r_0)\\,10^{-6}` s and
    :math:`y = (t - t_0)` s, iteratively re-fitted on rows with
    :math:`|y - a - b x| \\le \\max(5 \\cdot 1.4826\\,\\mathrm{MAD}, 2\\,\\mu s)`:

    .. math:: t = t_0 + a + b\\,(r - r_0)\\,10^{-6}, \\qquad
              \\mathrm{drift} = (b - 1)\\,10^{6}\\ \\mathrm{ppm}.

    Centring keeps float64 rounding below 1 ns for records of hours.

    References
    ----------
    Ghirardelli et al. (2025), Sect. 3.2 (sonic stamped by the logger clock, INS stamped in UTC).
    """
    r = np.asarray(rpi_time_us, dtype=np.int64)
    u = np.asarray(utc).astype("datetime64[ns]")
    if r.size < 2:
        raise InputError("rpi_time_us", f"clock fit needs >= 2 rows with valid UTC, got {r.size}")
    r0 = int(r[0])
    u0 = u[0]
    x = (r - r0) / _US
    y = (u - u0).astype(np.int64) / 1e9
    use = np.ones(r.size, dtype=bool)
    a = b = 0.0
    for _ in range(max(1, n_iter)):
        if np.ptp(x[use]) <= 0:
            raise InputError("rpi_time_us", "clock fit needs rows at >= 2 distinct logger times")
        b, a = np.polyfit(x[use], y[use], 1)
        res = y - (a + b * x)
        mad = float(np.median(np.abs(res[use] - np.median(res[use]))))
        thr = max(clip_n_sigma * 1.4826 * mad, min_clip_s)
        new_use = np.abs(res) <= thr
        if np.array_equal(new_use, use) or new_use.sum() < 2:
            break
        use = new_use
    b, a = np.polyfit(x[use], y[use], 1)
    res = y[use] - (a + b * x[use])
    return ClockFit(
        rpi0_us=r0,
        utc0=u0,
        offset_s=float(a),
        slope=float(b),
        residual_std_s=float(np.std(res)),
        n_used=int(use.sum()),
        n_outliers=int((~use).sum()),
        rpi_first_us=int(r.min()),
        rpi_last_us=int(r.max()),
    )


def _stable_valid_start(
    rpi_time_us: np.ndarray, time_valid: np.ndarray, min_stable_s: float
) -> int | None:
    """Index of the first row from which time_valid stays 1 for >= min_stable_s."""
    valid = time_valid.astype(bool)
    if not valid.any():
        return None
    edges = np.diff(np.concatenate([[0], valid.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)  # exclusive
    for s, e in zip(starts, ends, strict=True):
        # The run lasts until the next row with time_valid = 0 (or the file's last row).
        t_end = rpi_time_us[e] if e < rpi_time_us.size else rpi_time_us[e - 1]
        if (t_end - rpi_time_us[s]) >= min_stable_s * _US:
            return int(s)
    return None


def _nominal_rate(rpi_time_us: np.ndarray) -> float:
    """Sampling rate from the median step [Hz], rounded to an integer if within 2 %."""
    if rpi_time_us.size < 2:
        return float("nan")
    dt = median_step(rpi_time_us) / _US
    if dt <= 0:
        return float("nan")
    fs = 1.0 / dt
    return float(round(fs)) if abs(fs - round(fs)) <= 0.02 * fs else fs


def _finish_attrs(ds: xr.Dataset, counts: dict[str, int], log: list[str], fit: ClockFit,
                  fs_hz: float, source: str, rpi_time_us: np.ndarray) -> None:  # fmt: skip
    for k, v in counts.items():
        ds.attrs[k] = int(v)
    ds.attrs.update(fit.attrs())
    ds.attrs["sampling_rate_hz"] = float(fs_hz)
    if rpi_time_us.size >= 2:
        ds.attrs["sampling_rate_measured_hz"] = float(_US / median_step(rpi_time_us))
    ds.attrs["source_file"] = source
    ds.attrs["processing_log"] = "\n".join(log)
