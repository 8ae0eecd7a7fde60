r"""A rigid-mount vehicle's own log as the platform state of its sonic record.

A rigid-mount flight (``platform: rigid_mount``) whose record holds the sonic but not (all
of) the vehicle's attitude, velocity and position declares the vehicle's log as its
``platform_log`` (``docs/input-formats.md``, "Rigid-mount flights"). :func:`read_platform_state`
reads the log by its format (``ardupilot_bin``: :func:`dronewind.core.dataflash.read_dataflash`);
:func:`merge_platform_state` puts the platform variables the record lacks on the sonic's
time axis:

* linear interpolation in time of every variable between the log's finite samples; the
  yaw is unwrapped before and wrapped to [0, 360) after, so a heading through north is not
  turned the long way round;
* a sonic sample outside the log's coverage (before its first or after its last finite
  sample of a variable, or inside a gap of the log longer than ``max_gap_s``) gets no
  platform value (NaN): such samples are counted, flagged and reported, never filled from
  the nearest log sample.

Which source wins: a platform variable declared as a column of the record is read from the
record; the log gives the others (:func:`dronewind.core.columns.log_platform_variables`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core.angles import deg2rad, rad2deg, wrap_360
from dronewind.core.cf import sha256_file
from dronewind.core.timeseries import unwrap_rad
from dronewind.errors import InputError

__all__ = ["PLATFORM_LOG_FORMATS", "read_platform_state", "PlatformMerge", "merge_platform_state"]

#: Formats a platform log may be read in.
PLATFORM_LOG_FORMATS: tuple[str, ...] = ("ardupilot_bin",)
_NS = 1_000_000_000


def read_platform_state(path: str | os.PathLike[str], fmt: str | Mapping[str, Any]) -> xr.Dataset:
    """Platform state of a rigid-mount vehicle from its own log, by the log's format.

    Parameters
    ----------
    path : str or Path
        The vehicle's log.
    fmt : str or mapping
        Its format: ``ardupilot_bin`` (:func:`dronewind.core.dataflash.read_dataflash`; a
        mapping may set ``ekf_core``).

    Returns
    -------
    xarray.Dataset
        ``roll_deg``, ``pitch_deg``, ``yaw_deg`` [degree], ``vel_n_ms``, ``vel_e_ms``,
        ``vel_d_ms`` [m s-1], ``lat_deg``, ``lon_deg`` [degree], ``alt_m`` [m above mean sea
        level] on the log's times (UTC, increasing, each once), with the reader's attrs
        and ``format``, ``sha256`` (of the file) and ``source_file``.

    Raises
    ------
    InputError
        A format without a platform-state reader, a missing file, or a reader error (each
        naming the file).
    """
    spec = {"name": fmt} if isinstance(fmt, str) else dict(fmt)
    p = Path(path)
    if spec.get("name") not in PLATFORM_LOG_FORMATS:
        raise InputError(str(p), f"format {spec.get('name')!r} has no platform-state reader; expected "
                         f"{', '.join(PLATFORM_LOG_FORMATS)} (or the platform columns of the record's delimited "
                         "mapping)")
    if not p.is_file():
        raise InputError(str(p), "platform log not found; expected the vehicle's own log (platform_log.file)")
    from dronewind.core.dataflash import PLATFORM_VARIABLES, read_dataflash

    try:
        ds = read_dataflash(p, ekf_core=int(spec.get("ekf_core", 0)))
    except InputError:
        raise
    except Exception as exc:  # a damaged log: pymavlink's own error, named with the file
        raise InputError(str(p), f"not readable as an ArduPilot DataFlash log ({type(exc).__name__}: {exc})") from exc
    ds = ds[list(PLATFORM_VARIABLES)].sortby("time")
    t = ds["time"].values
    ds = ds.isel(time=np.r_[True, t[1:] > t[:-1]])  # a time stamp logged twice: its first row
    ds.attrs.update({"format": spec["name"], "sha256": sha256_file(p), "source_file": str(p)})
    return ds


@dataclass(frozen=True)
class PlatformMerge:
    """Platform variables of a log on a record's time axis.

    Attributes
    ----------
    values : dict of numpy.ndarray
        Each merged variable on the record's times (every one NaN where any lies outside
        the log's coverage); the yaw wrapped to [0, 360) [degree].
    outside : numpy.ndarray
        Boolean mask of the record's samples outside the coverage of any merged variable.
    coverage : (numpy.datetime64, numpy.datetime64)
        First and last time of the log (UTC).
    n_gaps : int
        Gaps of the log longer than ``max_gap_s`` inside its span.
    log : str
        The merge in one line.
    """

    values: dict[str, np.ndarray]
    outside: np.ndarray
    coverage: tuple[np.datetime64, np.datetime64]
    n_gaps: int
    log: str

    @property
    def n_outside(self) -> int:
        """Samples of the record outside the log's coverage."""
        return int(self.outside.sum())


def _interp_covered(t_ns: np.ndarray, src_ns: np.ndarray, x: np.ndarray, max_gap_ns: int
                    ) -> tuple[np.ndarray, np.ndarray, int]:
    """Linear interpolation of ``x`` from its finite samples; NaN and True outside their coverage."""
    ok = np.isfinite(x)
    if ok.sum() < 2:
        return np.full(t_ns.size, np.nan), np.ones(t_ns.size, dtype=bool), 0
    s, v = src_ns[ok], x[ok]
    ref = s[0]
    out = np.interp((t_ns - ref).astype(float), (s - ref).astype(float), v)
    k = np.searchsorted(s, t_ns, side="right")
    inside = (k > 0) & (k < s.size) | (t_ns == s[-1])
    gap = np.diff(s) > max_gap_ns
    kk = np.clip(k, 1, s.size - 1)
    in_gap = inside & gap[kk - 1] & (t_ns != s[-1]) & (t_ns != s[kk - 1])  # a log sample itself is covered
    outside = ~inside | in_gap
    out[outside] = np.nan
    return out, outside, int(gap.sum())


def merge_platform_state(times: np.ndarray, state: xr.Dataset, variables: Sequence[str], *,
                         max_gap_s: float = 1.0) -> PlatformMerge:
    """Platform variables of a vehicle's log interpolated to a record's times.

    Parameters
    ----------
    times : numpy.ndarray
        The record's times (``datetime64``, UTC, increasing).
    state : xarray.Dataset
        :func:`read_platform_state` output (``time`` increasing).
    variables : sequence of str
        The variables to merge (``roll_deg``, ..., ``alt_m``).
    max_gap_s : float
        Longest gap between two log samples interpolated across [s]; a record sample inside
        a longer gap lies outside the log's coverage.

    Returns
    -------
    PlatformMerge

    Raises
    ------
    InputError
        A variable the log does not hold, or a log and a record that do not overlap in time
        (both spans given, UTC).

    Notes
    -----
    The yaw is unwrapped (degree) on the log's times before the interpolation and wrapped to
    [0, 360) after it; roll and pitch, which stay well inside (-90, 90) degree in flight,
    are interpolated as they are.
    """
    src = state["time"].values.astype("datetime64[ns]").astype(np.int64)
    t_ns = np.asarray(times).astype("datetime64[ns]").astype(np.int64)
    where = str(state.attrs.get("source_file", "platform log"))
    if src.size < 2:
        raise InputError(where, f"{src.size} time stamps; expected a log of the flight")
    first, last = src[0].astype("datetime64[ns]"), src[-1].astype("datetime64[ns]")
    if t_ns.size and (t_ns[-1] < src[0] or t_ns[0] > src[-1]):
        raise InputError(where, f"the log covers {first} to {last} UTC and the record "
                         f"{t_ns[0].astype('datetime64[ns]')} to {t_ns[-1].astype('datetime64[ns]')} UTC: they do "
                         "not overlap (a record on local time without its zone, or the log of another flight?)")
    values: dict[str, np.ndarray] = {}
    outside = np.zeros(t_ns.size, dtype=bool)
    n_gaps = 0
    max_gap_ns = int(round(max_gap_s * _NS))
    for name in variables:
        if name not in state:
            raise InputError(where, f"no {name} in the platform log; it holds {', '.join(map(str, state.data_vars))}")
        x = np.asarray(state[name].values, dtype=float)
        if name == "yaw_deg":
            ok = np.isfinite(x)
            x = x.copy()
            x[ok] = rad2deg(unwrap_rad(deg2rad(x[ok])))
        v, out, gaps = _interp_covered(t_ns, src, x, max_gap_ns)
        if name == "yaw_deg":
            v = wrap_360(v)
        values[name] = v
        outside |= out
        n_gaps = max(n_gaps, gaps)
    for v in values.values():  # outside any variable's coverage: no platform state at all
        v[outside] = np.nan
    n_out = int(outside.sum())
    log = (f"platform_log: {Path(where).name} ({state.attrs.get('format', '?')}, sha256 "
           f"{str(state.attrs.get('sha256', '?'))[:12]}...): {', '.join(variables)} interpolated to the record's "
           f"{t_ns.size} samples (yaw unwrapped); the log covers {first} to {last} UTC with {n_gaps} gaps longer than "
           f"{max_gap_s:g} s; {n_out} record samples outside its coverage have no platform state (NaN, not used)")
    return PlatformMerge(values, outside, (first, last), n_gaps, log)
