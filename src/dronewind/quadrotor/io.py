r"""Readers for quadrotor (SWUF-3D) flight logs and the tower reference.

Three L0 formats of the data contract (``../shared/DESIGN.md``, "Quadrotor file" and
"Tower reference") are read here (and, through :func:`read_quadrotor`, ArduPilot DataFlash
logs, :mod:`dronewind.quadrotor.ardupilot`, and delimited text by a column mapping,
:mod:`dronewind.quadrotor.delimited`):

* quadrotor CSV, at 10 Hz or more::

      time_utc,roll_deg,pitch_deg,yaw_deg,vel_n_ms,vel_e_ms,vel_d_ms,lat_deg,lon_deg,alt_m

  ``time_utc`` is ISO 8601 UTC with a trailing ``Z``, with or without fractional seconds;
* PX4 ULog (``.ulg``), read with :mod:`pyulog`: attitude from the ``vehicle_attitude``
  quaternion, velocity (NED) and position from ``vehicle_global_position`` (if logged)
  or ``vehicle_local_position`` (NED position relative to ``ref_lat``/``ref_lon``/
  ``ref_alt``); UTC from the GNSS receiver (``vehicle_gps_position`` or ``sensor_gps``,
  field ``time_utc_usec``);
* tower reference CSV (1 Hz or 1-min means)::

      time_utc,height_m,wind_speed_ms,wind_from_deg

  in long form (one row per time and height) or wide form (``time_utc`` plus one
  ``wind_speed_ms_<h>m`` and one ``wind_from_deg_<h>m`` column per height ``h``).

Every reader returns an :class:`xarray.Dataset` with a ``time`` dimension
(``datetime64[ns]``, naive, meaning UTC), CF attributes, removed-sample counts ``n_*`` and a
``processing_log``. Bad input raises :class:`dronewind.errors.InputError` naming the file,
line or variable and what was expected.

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F.: Distributed wind measurements with multiple
   quadrotor UAVs in the atmospheric boundary layer (SWUF-3D), Wetz et al. (2021)
  , Sects. 2-5.
.. [2] PX4 ULog file format, https://docs.px4.io/main/en/dev_log/ulog_file_format.html
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.core import textscan
from dronewind.core.geo import from_local_tangent_plane
from dronewind.core.rowfaults import split_csv_line, split_csv_lines, text_lines
from dronewind.errors import InputError
from dronewind.quadrotor.columns import QUADROTOR_COLUMNS, REFERENCE_COLUMNS

__all__ = [
    "QUADROTOR_COLUMNS",
    "REFERENCE_COLUMNS",
    "parse_time_utc",
    "quaternion_to_euler_deg",
    "read_quadrotor",
    "read_quadrotor_csv",
    "read_quadrotor_ulog",
    "read_tower_reference",
]



_ISO_Z = re.compile(r"^\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}(\.\d{1,9})?Z$")

_VAR_ATTRS: dict[str, dict[str, str]] = {
    "roll_deg": {"units": "degree", "standard_name": "platform_roll"},
    "pitch_deg": {"units": "degree", "standard_name": "platform_pitch"},
    "yaw_deg": {"units": "degree", "standard_name": "platform_yaw",
                "comment": "clockwise from true north, as logged"},
    "vel_n_ms": {"units": "m s-1", "long_name": "platform northward velocity (GNSS/EKF)"},
    "vel_e_ms": {"units": "m s-1", "long_name": "platform eastward velocity (GNSS/EKF)"},
    "vel_d_ms": {"units": "m s-1", "long_name": "platform downward velocity (GNSS/EKF)"},
    "lat_deg": {"units": "degrees_north", "standard_name": "latitude"},
    "lon_deg": {"units": "degrees_east", "standard_name": "longitude"},
    "alt_m": {"units": "m", "standard_name": "altitude",
              "comment": "above mean sea level"},
}


def _quoted_time(field: Any) -> str:
    """A time field for a message: quoted if it looks like a time stamp, else only described.

    What a reader echoes from a file is limited to what it expected there (a time stamp).
    """
    text = "" if field is None or field is pd.NA else str(field)
    if re.fullmatch(r"[0-9TZ:.+\- ]{1,40}", text):
        return repr(text)
    return f"(a field of {len(text)} characters that is not a time stamp)"


def parse_time_utc(values: pd.Series | np.ndarray | list[str], where: str | Path,
                   first_line: int = 2) -> np.ndarray:
    """Parse ISO 8601 UTC strings with a trailing ``Z`` into ``datetime64[ns]``.

    Parameters
    ----------
    values : array of str
        Time stamps such as ``2020-07-24T10:19:30Z`` or ``2020-07-24T10:19:30.125Z``.
    where : str or Path
        File name used in error messages.
    first_line : int
        Line number of ``values[0]`` in the file (1-based; header is line 1).

    Returns
    -------
    numpy.ndarray
        ``datetime64[ns]``, naive, meaning UTC.

    Raises
    ------
    InputError
        If a stamp is missing, lacks the trailing ``Z`` or is not ISO 8601; the message
        names the first bad line.
    """
    text = pd.Series(values, dtype="string").str.strip()
    ok = text.str.match(_ISO_Z.pattern).fillna(False).to_numpy(dtype=bool)
    if not ok.all():
        i = int(np.flatnonzero(~ok)[0])
        raise InputError(
            f"{where}:{first_line + i}",
            f"time_utc {_quoted_time(text.iloc[i])} is not ISO 8601 UTC with a trailing 'Z' "
            "(expected e.g. 2020-07-24T10:19:30Z or 2020-07-24T10:19:30.25Z)",
        )
    stamps = pd.to_datetime(text.str.slice(0, -1), format="ISO8601", errors="coerce")
    if stamps.isna().any():
        i = int(np.flatnonzero(stamps.isna().to_numpy())[0])
        raise InputError(f"{where}:{first_line + i}",
                         f"time_utc {_quoted_time(text.iloc[i])} is not a valid date/time")
    return stamps.to_numpy(dtype="datetime64[ns]")


_N_LOGGED = 5


def _time_problem(text: str) -> str | None:
    """Why a time_utc field is not a time stamp of the contract, or None."""
    if not _ISO_Z.match(text):
        return (f"time_utc {_quoted_time(text)} is not ISO 8601 UTC with a trailing 'Z' "
                "(expected e.g. 2020-07-24T10:19:30Z or 2020-07-24T10:19:30.25Z)")
    if pd.isna(pd.to_datetime(text[:-1], format="ISO8601", errors="coerce")):
        return f"time_utc {_quoted_time(text)} is not a valid date/time"
    return None


def _csv_rows(path: Path, not_found: str, required: tuple[str, ...] = ("time_utc",), exact: bool = True,
              ) -> tuple[list[str], pd.DataFrame, np.ndarray, np.ndarray, list[str], int]:
    """The rows of a CSV log line by line: header, fields of the good rows, their times and lines.

    A data line is corrupt when it has another number of fields than the header (with
    ``exact`` False: fewer than up to the last ``required`` column, or more than the
    header's; the missing ones are empty) or a ``time_utc`` that is not a contract time stamp
    (:func:`parse_time_utc`); blank lines are skipped.

    Returns
    -------
    header : list of str
        The field names (stripped).
    frame : pandas.DataFrame
        The good rows' fields as text, columns named by the header.
    time : numpy.ndarray
        datetime64[ns] of the good rows.
    line_no : numpy.ndarray
        1-based file line of the good rows.
    bad : list of str
        ``"<line>: <what>"`` of every corrupt line, in file order.
    n_lines : int
        Non-blank data lines.

    Raises
    ------
    InputError
        Missing file, empty file, a header without the ``required`` columns, no data rows.
    """
    if not path.is_file():
        raise InputError(path, not_found)
    lines = text_lines(path.read_bytes())
    if not lines:
        raise InputError(path, "empty file; expected a header line")
    header = [h.strip() for h in split_csv_line(lines[0]) or []]
    missing = [c for c in required if c not in header]
    if missing:
        raise InputError(f"{path}:1", f"missing column(s) {missing}; expected header {','.join(required)}")
    split = split_csv_lines(lines[1:])
    ncol = len(header)
    # fields a row must have: up to the last required column, or all of the header's
    n_needed = ncol if exact else 1 + max(header.index(c) for c in required)
    good_rows: list[list[str]] = []
    good_lines: list[int] = []
    bad: list[str] = []
    n_lines = 0
    for ln, row in enumerate(split, start=2):
        if row is not None and not any(f.strip() for f in row):
            continue
        n_lines += 1
        if row is None or not n_needed <= len(row) <= ncol:
            bad.append(f"{ln}: {0 if row is None else len(row)} fields, expected {ncol}")
        else:
            good_rows.append(row + [""] * (ncol - len(row)))
            good_lines.append(ln)
    if n_lines == 0:
        raise InputError(path, "no data rows")
    frame = pd.DataFrame(good_rows, columns=header, dtype=object) if good_rows else pd.DataFrame(columns=header)
    text = frame["time_utc"].astype(str).str.strip() if good_rows else pd.Series([], dtype=object)
    ok = text.str.match(_ISO_Z.pattern).fillna(False).to_numpy(dtype=bool)
    stamps = pd.to_datetime(text.where(ok, "1970-01-01T00:00:00Z").str.slice(0, -1), format="ISO8601",
                            errors="coerce")
    ok = ok & ~stamps.isna().to_numpy()
    line_no = np.asarray(good_lines, dtype=np.int64)
    for i in np.flatnonzero(~ok):
        bad.append(f"{int(line_no[i])}: {_time_problem(str(text.iloc[i]))}")
    bad.sort(key=lambda b: int(b.split(":", 1)[0]))
    return header, frame.loc[ok].reset_index(drop=True), stamps.to_numpy(dtype="datetime64[ns]")[ok], \
        line_no[ok], bad, n_lines


def _corrupt_check(path: Path, bad: list[str], n_lines: int, max_corrupt_fraction: float, what: str) -> None:
    """Raise InputError at the first corrupt line when more than ``max_corrupt_fraction`` of the lines are."""
    if len(bad) > max_corrupt_fraction * n_lines:
        line, reason = bad[0].split(": ", 1)
        raise InputError(f"{path}:{line}", f"{reason} ({len(bad)} of {n_lines} data lines corrupt, "
                         f"> {100 * max_corrupt_fraction:g} %: {what}; first at lines "
                         f"{[int(b.split(':', 1)[0]) for b in bad[:_N_LOGGED]]})")


def _corrupt_log(path: Path, bad: list[str], n_lines: int) -> str:
    """The processing-log line of the corrupt lines of a file."""
    lines = [int(b.split(":", 1)[0]) for b in bad]
    return (f"read: {path.name}: {len(bad)} of {n_lines} data lines corrupt removed"
            + (f" (lines {lines[:_N_LOGGED]}{', ...' if len(lines) > _N_LOGGED else ''})" if bad else ""))


def _sort_dedupe(ds: xr.Dataset, log: list[str]) -> xr.Dataset:
    """Sort by time, drop exact duplicate rows and every row of a time stamp repeated with other values.

    Rows repeating a time stamp with other values conflict (a mangled time stamp, a clock
    set back): no rule says which one is right, so all of them are dropped and counted in
    ``n_time_conflicts``.
    """
    t = ds["time"].to_numpy()
    n_unsorted = int(np.sum(np.diff(t.astype("int64")) < 0)) if t.size > 1 else 0
    if n_unsorted:
        ds = ds.sortby("time")
        log.append(f"sort: {n_unsorted} out-of-order time stamps sorted")
    t = ds["time"].to_numpy()
    if t.size < 2 or bool(np.all(t[1:] > t[:-1])):  # no repeated time stamp (every well-formed log)
        ds.attrs.update(n_out_of_order=n_unsorted, n_duplicates=0, n_time_conflicts=0)
        return ds
    frame = ds.to_dataframe().reset_index()
    exact = frame.duplicated(keep="first").to_numpy()
    conflict = frame.loc[~exact].duplicated(subset=["time"], keep=False).to_numpy()
    keep = np.flatnonzero(~exact)[~conflict]
    n_dup, n_conflict = int(exact.sum()), int(conflict.sum())
    if n_dup or n_conflict:
        ds = ds.isel(time=keep)
    if n_dup:
        log.append(f"dedupe: {n_dup} duplicated time stamps removed (first kept)")
    if n_conflict:
        log.append(f"dedupe: {n_conflict} rows repeating a time stamp with other values removed, none trusted")
    ds.attrs["n_out_of_order"] = n_unsorted
    ds.attrs["n_duplicates"] = n_dup
    ds.attrs["n_time_conflicts"] = n_conflict
    return ds


def _finish(ds: xr.Dataset, source: Path, log: list[str]) -> xr.Dataset:
    for name, attrs in _VAR_ATTRS.items():
        if name in ds:
            ds[name].attrs.update(attrs)
    ds["time"].attrs.update({"standard_name": "time", "long_name": "time (UTC)"})
    dt_s = np.diff(ds["time"].to_numpy().astype("int64")) / 1e9
    ds.attrs["sampling_rate_hz"] = float(1.0 / np.median(dt_s)) if dt_s.size else float("nan")
    ds.attrs["source_file"] = str(source)
    ds.attrs["processing_log"] = "\n".join(log)
    return ds


def read_quadrotor_csv(path: str | Path, max_corrupt_fraction: float = 0.05) -> xr.Dataset:
    """Read a quadrotor CSV log (data contract, Wetz et al. (2021), Sect. 2).

    Parameters
    ----------
    path : str or Path
        CSV file with the columns of :data:`QUADROTOR_COLUMNS` (more are ignored).
    max_corrupt_fraction : float, optional
        Largest tolerated fraction of corrupt data lines (another number of fields than
        the header, a time stamp that is not ISO 8601 UTC with a trailing ``Z``) [1].

    Returns
    -------
    xarray.Dataset
        Dimension ``time`` (UTC); variables ``roll_deg``, ``pitch_deg``, ``yaw_deg``
        [degree], ``vel_n_ms``, ``vel_e_ms``, ``vel_d_ms`` [m s-1], ``lat_deg``,
        ``lon_deg`` [degree], ``alt_m`` [m above MSL]. attrs ``n_lines``,
        ``n_corrupt_lines`` (removed; their lines in the log), ``n_out_of_order``,
        ``n_duplicates``, ``n_time_conflicts``, ``n_nonfinite`` (values not numeric or
        missing; kept as NaN), ``yaw_known`` (0 when no row has a yaw: yaw is then set to 0 and
        only the speed holds), ``sampling_rate_hz``, ``processing_log``.

    Raises
    ------
    InputError
        Missing file or columns, an empty file, more than ``max_corrupt_fraction`` of the
        lines corrupt (names the first) or a sampling rate below 1 Hz.
    """
    path = Path(path)
    time, columns, line_no, counts = _quadrotor_rows(path, max_corrupt_fraction)
    log = [f"read: {time.size} rows from {path.name}"]
    if counts["n_corrupt_lines"]:
        log.append(counts.pop("_log"))
    counts.pop("_log", None)
    ds = xr.Dataset({col: ("time", values) for col, values in columns.items()}, coords={"time": time})
    n_nonfinite = counts["n_nonfinite"]
    if n_nonfinite:
        log.append(f"parse: {n_nonfinite} non-numeric or missing values set to NaN")
    ds.attrs.update(counts)
    ds.attrs["yaw_known"] = int(bool(np.isfinite(ds["yaw_deg"].to_numpy()).any()))
    if not ds.attrs["yaw_known"]:
        # a record whose yaw is unknown throughout (e.g. converted by hand from a vehicle log):
        # the speed of a hovering vehicle holds without it, the direction does not
        ds["yaw_deg"] = xr.zeros_like(ds["yaw_deg"])
        log.append("yaw: missing in every row; set to 0: the wind speed holds, its direction is relative to the nose")
    ds = _sort_dedupe(ds, log)
    ds = _finish(ds, path, log)
    if ds.sizes["time"] > 1 and ds.attrs["sampling_rate_hz"] < 1.0:
        raise InputError(path, f"median sampling rate {ds.attrs['sampling_rate_hz']:.3g} Hz; "
                               "expected 10 Hz or more (at least 1 Hz)")
    return ds


def _quadrotor_rows(path: Path, max_corrupt_fraction: float = 0.05,
                    ) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray, dict[str, Any]]:
    """Time stamps, numeric columns and file lines of the good rows of a quadrotor CSV, and counts.

    Plain files take the byte-level path (:func:`_quadrotor_columns_fast`), the others are
    read line by line (:func:`_csv_rows`): corrupt lines removed and counted.

    Returns
    -------
    time, columns, line_no
        Of the good rows in file order.
    counts : dict
        ``n_lines``, ``n_corrupt_lines``, ``n_nonfinite`` and ``_log`` (the log line of the
        corrupt lines).
    """
    fast = _quadrotor_columns_fast(path)
    if fast is not None:
        n = fast[0].size
        return fast[0], fast[1], np.arange(2, n + 2), {"n_lines": n, "n_corrupt_lines": 0, "n_nonfinite": 0,
                                                       "_log": ""}
    time, columns, n_nonfinite, line_no, bad, n_lines = _careful_rows(path, max_corrupt_fraction)
    return time, columns, line_no, {"n_lines": n_lines, "n_corrupt_lines": len(bad), "n_nonfinite": n_nonfinite,
                                    "_log": _corrupt_log(path, bad, n_lines)}


def _careful_rows(path: Path, max_corrupt_fraction: float,
                  ) -> tuple[np.ndarray, dict[str, np.ndarray], int, np.ndarray, list[str], int]:
    """:func:`_quadrotor_columns_careful` with the good rows' lines, the corrupt lines and the data lines."""
    _, frame, time, line_no, bad, n_lines = _csv_rows(path, "quadrotor log not found", QUADROTOR_COLUMNS,
                                                      exact=False)
    _corrupt_check(path, bad, n_lines, max_corrupt_fraction, "another number of fields than the header or a "
                   "time_utc that is not ISO 8601 UTC with a trailing 'Z'")
    if time.size == 0:
        raise InputError(path, "no data rows")
    columns = {}
    n_nonfinite = 0
    for col in QUADROTOR_COLUMNS[1:]:
        values = pd.to_numeric(frame[col].astype(str).str.strip(), errors="coerce").to_numpy(dtype=float)
        n_nonfinite += int((~np.isfinite(values)).sum())
        columns[col] = values
    return time, columns, n_nonfinite, line_no, bad, n_lines


def _quadrotor_columns_careful(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray], int]:
    """Time stamps, numeric columns and non-finite values of a quadrotor CSV, line by line (the reference).

    Every cell is read as text and stripped; numbers are converted with ``pandas.to_numeric``
    (non-numeric fields become NaN and are counted); corrupt lines are removed
    (:func:`_csv_rows`); errors name the file and line.
    """
    time, columns, n_nonfinite, _, _, _ = _careful_rows(path, 0.05)
    return time, columns, n_nonfinite


def _quadrotor_columns_fast(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray], int] | None:
    """What :func:`_quadrotor_columns_careful` gives for a plain file, from a byte-level scan; None otherwise.

    Hand-written rather than one ``pandas.read_csv`` call with numeric types because the result
    must be the careful parse's exactly, and ``read_csv`` rounds long and exponent literals
    differently from ``pandas.to_numeric`` (:mod:`dronewind.core.textscan`). The scan vouches
    for a file whose header is exactly :data:`QUADROTOR_COLUMNS`, whose every line is plain
    (printable ASCII without spaces or quotes, no blank line) with one field per column, whose
    numbers are finite literals of at most :data:`~dronewind.core.textscan.FLOAT_FAST_MAX_CHARS`
    characters without exponent, and whose time stamps have the fixed ISO 8601 form with a
    trailing ``Z`` and a real date. Anything else (a NaN, a corrupt field, extra columns, a
    bad time stamp) goes the careful way, which also gives the named errors.
    """
    body = textscan.csv_body(path, QUADROTOR_COLUMNS)
    if body is None:
        return None
    raw, buf, starts, ends, unusual = body
    if starts.size == 0 or bool((ends == starts).any()) \
            or textscan.lines_holding(raw, buf, starts, textscan.PLAIN_CSV, unusual).any():  # fmt: skip
        return None
    ncol = len(QUADROTOR_COLUMNS)
    every = np.ones(starts.size, dtype=bool)
    commas = np.flatnonzero(buf == ord(","))
    rows, cpos, first_comma = textscan.comma_grid(commas, starts, ends, every, ncol)
    if rows.size != starts.size or textscan.exponent_fields(raw, buf, commas, starts, first_comma, every):
        return None
    time, ok = textscan.fixed_width_times(buf, starts, cpos[:, 0] - starts, sep=b"T", suffix=b"Z")
    if not ok.all():
        return None
    numeric = list(QUADROTOR_COLUMNS[1:])
    frame = textscan.read_numeric_columns(raw, list(QUADROTOR_COLUMNS), numeric, {}, quoting=False)
    if len(frame) != starts.size:
        return None
    columns = {}
    for j, col in enumerate(numeric, start=1):
        field_chars = (cpos[:, j] if j < ncol - 1 else ends) - (cpos[:, j - 1] + 1)
        if frame[col].dtype not in (np.float64, np.int64) or int(field_chars.max()) > textscan.FLOAT_FAST_MAX_CHARS:
            return None
        values = frame[col].to_numpy(dtype=float)
        if not np.isfinite(values).all():
            return None
        columns[col] = values
    return time, columns, 0


def quaternion_to_euler_deg(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Convert PX4 attitude quaternions (body to NED, Hamilton, ``[w, x, y, z]``) to Euler angles.

    Parameters
    ----------
    q : numpy.ndarray, shape (n, 4)
        Quaternion components ``q[0]`` (scalar) to ``q[3]``.

    Returns
    -------
    roll_deg, pitch_deg, yaw_deg : numpy.ndarray
        Z-Y-X (yaw, pitch, roll) Euler angles [degree]; yaw in (-180, 180], clockwise
        from north.

    Notes
    -----
    The rotation matrix is that of Wetz et al. (2021), Eq. D1, so that

    .. math::
        \phi = \operatorname{atan2}(2(q_0q_1+q_2q_3),\,1-2(q_1^2+q_2^2)),\quad
        \theta = \arcsin(2(q_0q_2-q_3q_1)),\quad
        \psi = \operatorname{atan2}(2(q_0q_3+q_1q_2),\,1-2(q_2^2+q_3^2)).

    The quaternion is normalised first.
    """
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    q0, q1, q2, q3 = q.T
    roll = np.arctan2(2 * (q0 * q1 + q2 * q3), 1 - 2 * (q1**2 + q2**2))
    pitch = np.arcsin(np.clip(2 * (q0 * q2 - q3 * q1), -1.0, 1.0))
    yaw = np.arctan2(2 * (q0 * q3 + q1 * q2), 1 - 2 * (q2**2 + q3**2))
    return np.degrees(roll), np.degrees(pitch), np.degrees(yaw)


def _topic(ulog: Any, name: str) -> dict[str, np.ndarray] | None:
    """Fields of the first instance of a ULog topic, or None."""
    for d in ulog.data_list:
        if d.name == name and d.multi_id == 0:
            return d.data
    return None


def _open_ulog(path: Path) -> Any:
    """Parse a ULog file with :mod:`pyulog` (errors name the file)."""
    from pyulog import ULog  # imported here: only needed for .ulg files

    if not path.is_file():
        raise InputError(path, "ULog file not found")
    try:
        return ULog(str(path))
    except Exception as exc:  # pyulog raises plain exceptions on corrupt files
        raise InputError(path, f"not a readable PX4 ULog file ({exc})") from exc


def _ulog_attitude(ulog: Any, path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Boot-time stamps [us] and roll, pitch, yaw [degree] of ``vehicle_attitude``."""
    att = _topic(ulog, "vehicle_attitude")
    if att is None or len(att["timestamp"]) == 0:
        raise InputError(f"{path} [vehicle_attitude]",
                         "the log holds no vehicle_attitude topic; attitude is needed to "
                         "measure wind from the quadrotor's tilt (Wetz et al. (2021), Sect. 4.2)")
    t_us = att["timestamp"].astype(np.int64)
    q = np.column_stack([att[f"q[{i}]"] for i in range(4)])
    roll, pitch, yaw = quaternion_to_euler_deg(q)
    return t_us, roll, pitch, yaw


def _ulog_utc_offset_us(ulog: Any, utc_start: str | None, log: list[str]) -> tuple[int, int]:
    """UTC minus boot time [us] (median over GNSS fixes) and whether it is a real UTC (1/0)."""
    for name in ("vehicle_gps_position", "sensor_gps"):
        gps = _topic(ulog, name)
        if gps is not None and "time_utc_usec" in gps:
            good = gps["time_utc_usec"] > 0
            if good.any():
                offset = int(np.median(gps["time_utc_usec"][good].astype(np.int64)
                                       - gps["timestamp"][good].astype(np.int64)))
                log.append(f"utc: from {name}.time_utc_usec ({int(good.sum())} fixes)")
                return offset, 1
    if utc_start is not None:
        origin = parse_time_utc([utc_start], "utc_start")[0]
        log.append(f"utc: no GNSS time in log; origin set to {utc_start}")
        return int(origin.astype("datetime64[us]").astype(np.int64)), 1
    log.append("utc: no GNSS time in log and no utc_start; times are boot time "
               "counted from 1970-01-01 (utc_valid = 0)")
    return 0, 0


def _interp_at(t_us: np.ndarray, src_t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Linear interpolation of a topic field to the attitude times (NaN outside its span)."""
    src_t = src_t.astype(np.int64)
    return np.interp(t_us, src_t, values.astype(float), left=np.nan, right=np.nan)


def _ulog_track(ulog: Any, t_us: np.ndarray) -> tuple[dict[str, np.ndarray], str]:
    """GNSS/EKF velocity (NED) and position at the attitude times, and where they came from.

    Local NED position is converted to latitude/longitude with a local flat-earth
    approximation about (``ref_lat``, ``ref_lon``) (error < 1 mm over a few hundred
    metres); altitude is ``ref_alt - z``.
    """
    nan = np.full(t_us.size, np.nan)
    tr = {k: nan.copy() for k in ("vel_n_ms", "vel_e_ms", "vel_d_ms", "lat_deg", "lon_deg", "alt_m")}
    source = "none"
    lpos = _topic(ulog, "vehicle_local_position")
    gpos = _topic(ulog, "vehicle_global_position")
    if lpos is not None and len(lpos["timestamp"]):
        for key, field in (("vel_n_ms", "vx"), ("vel_e_ms", "vy"), ("vel_d_ms", "vz")):
            tr[key] = _interp_at(t_us, lpos["timestamp"], lpos[field])
        ref_lat = float(np.median(lpos["ref_lat"]))
        ref_lon = float(np.median(lpos["ref_lon"]))
        ref_alt = float(np.median(lpos["ref_alt"]))
        x_n, y_e, z_d = (_interp_at(t_us, lpos["timestamp"], lpos[k]) for k in ("x", "y", "z"))
        tr["lat_deg"], tr["lon_deg"] = from_local_tangent_plane(y_e, x_n, ref_lat, ref_lon)
        tr["alt_m"] = ref_alt - z_d
        source = "vehicle_local_position"
    if gpos is not None and len(gpos["timestamp"]):
        for key, field in (("lat_deg", "lat"), ("lon_deg", "lon"), ("alt_m", "alt")):
            tr[key] = _interp_at(t_us, gpos["timestamp"], gpos[field])
        source = "vehicle_global_position" + ("+local velocity" if lpos is not None else "")
        if lpos is None and "vel_n" in gpos:
            for key, field in (("vel_n_ms", "vel_n"), ("vel_e_ms", "vel_e"), ("vel_d_ms", "vel_d")):
                tr[key] = _interp_at(t_us, gpos["timestamp"], gpos[field])
    lpos_global = lpos is not None and "xy_global" in lpos and bool(np.any(lpos["xy_global"]))
    if gpos is None and not lpos_global:
        source = _ulog_receiver_position(ulog, t_us, tr, source)
    return tr, source


def _ulog_receiver_position(ulog: Any, t_us: np.ndarray, track: dict[str, np.ndarray], source: str) -> str:
    """Position from the raw GNSS receiver (lat/lon in 1e-7 degree, alt in mm above MSL), if it
    has a fix: for a local frame without a global reference. Updates ``track``; returns the source."""
    for name in ("vehicle_gps_position", "sensor_gps"):
        gps = _topic(ulog, name)
        if gps is not None and "lat" in gps and np.any(gps["lat"] != 0):
            fix = gps["lat"] != 0
            track["lat_deg"] = _interp_at(t_us, gps["timestamp"][fix], gps["lat"][fix] * 1e-7)
            track["lon_deg"] = _interp_at(t_us, gps["timestamp"][fix], gps["lon"][fix] * 1e-7)
            track["alt_m"] = _interp_at(t_us, gps["timestamp"][fix], gps["alt"][fix] * 1e-3)
            return f"{name} position + {source} velocity"
    return source


def read_quadrotor_ulog(path: str | Path, utc_start: str | None = None) -> xr.Dataset:
    """Read a PX4 ULog file into the quadrotor dataset (same layout as the CSV reader).

    Parameters
    ----------
    path : str or Path
        ``.ulg`` file.
    utc_start : str, optional
        ISO 8601 UTC time of the log's boot-time origin, used only if the log holds no
        GNSS UTC time (bench logs). Without either, times count from 1970-01-01 and
        ``attrs['utc_valid'] = 0``.

    Returns
    -------
    xarray.Dataset
        As :func:`read_quadrotor_csv`, at the ``vehicle_attitude`` time stamps. Velocity
        and position are linearly interpolated from their topics to those times (NaN
        outside their time span). attrs: ``utc_valid`` (0/1), ``utc_offset_us``,
        ``position_source``, ``n_position_missing`` (attitude samples without position).

    Raises
    ------
    InputError
        Unreadable file, or no ``vehicle_attitude`` topic.

    Notes
    -----
    UTC is the median offset between the GNSS receiver's ``time_utc_usec`` and boot
    time. Position: ``vehicle_global_position`` if logged, else ``vehicle_local_position``
    about its reference point, else the raw receiver (see :func:`_ulog_track`).
    """
    path = Path(path)
    ulog = _open_ulog(path)
    log = [f"read: ULog {path.name} ({len(ulog.data_list)} topics)"]
    t_us, roll, pitch, yaw = _ulog_attitude(ulog, path)
    utc_offset_us, utc_valid = _ulog_utc_offset_us(ulog, utc_start, log)
    track, source = _ulog_track(ulog, t_us)
    n_pos_missing = int(np.sum(~np.isfinite(track["lat_deg"]) | ~np.isfinite(track["vel_n_ms"])))
    log.append(f"position: from {source}; {n_pos_missing} attitude samples without "
               "position or velocity (NaN)")
    time = (t_us + utc_offset_us).astype("datetime64[us]").astype("datetime64[ns]")
    data = {"roll_deg": roll, "pitch_deg": pitch, "yaw_deg": yaw, **track}
    ds = xr.Dataset({k: ("time", data[k]) for k in QUADROTOR_COLUMNS[1:]}, coords={"time": time})
    ds = _sort_dedupe(ds, log)
    ds.attrs.update({"utc_valid": utc_valid, "utc_offset_us": utc_offset_us,
                     "position_source": source, "n_position_missing": n_pos_missing,
                     "n_nonfinite": 0})
    return _finish(ds, path, log)


def read_quadrotor(path: str | Path, fmt: str | Mapping[str, Any] | None = None) -> xr.Dataset:
    """Read a quadrotor log: contract CSV, PX4 ULog or ArduPilot DataFlash (by format or file suffix).

    Parameters
    ----------
    path : str or Path
        ``.csv``, ``.ulg`` or ``.bin`` file.
    fmt : str or mapping, optional
        The manifest's ``format`` (a name or a mapping with ``name``): ``contract_csv``,
        ``ulog``, ``ardupilot_bin`` (:func:`dronewind.quadrotor.ardupilot.read_quadrotor_ardupilot`,
        setting ``ekf_core``) or ``delimited``
        (:func:`dronewind.quadrotor.delimited.read_quadrotor_delimited`). Default: by suffix.

    Returns
    -------
    xarray.Dataset
        See :func:`read_quadrotor_csv`.

    Raises
    ------
    InputError
        Unknown suffix or format, or a reader error.
    """
    path = Path(path)
    spec = {"name": fmt} if isinstance(fmt, str) else dict(fmt or {})
    name = spec.get("name") or {".csv": "contract_csv", ".ulg": "ulog", ".bin": "ardupilot_bin"}.get(
        path.suffix.lower())
    if name == "contract_csv":
        return read_quadrotor_csv(path)
    if name == "ulog":
        return read_quadrotor_ulog(path)
    if name == "ardupilot_bin":
        from dronewind.quadrotor.ardupilot import read_quadrotor_ardupilot

        return read_quadrotor_ardupilot(path, ekf_core=int(spec.get("ekf_core", 0)))
    if name == "delimited":
        from dronewind.quadrotor.delimited import read_quadrotor_delimited

        return read_quadrotor_delimited(path, spec)
    if name is None:
        raise InputError(path, f"unknown quadrotor log type {path.suffix.lower()!r}; expected .csv, .ulg or .bin "
                               "(or a declared format)")
    raise InputError(path, f"unknown quadrotor log format {name!r}; expected contract_csv, ulog, ardupilot_bin "
                           "or delimited")


_WIDE = re.compile(r"^(wind_speed_ms|wind_from_deg)_(\d+(?:\.\d+)?)m?$")


def _reference_long_form(df: pd.DataFrame, time: np.ndarray, line_no: np.ndarray) -> pd.DataFrame:
    """Long-form reference rows: ``time``, ``height_m``, ``wind_speed_ms``, ``wind_from_deg``, ``line``."""
    return pd.DataFrame({
        "time": time,
        "height_m": _numbers(df["height_m"]),
        "wind_speed_ms": _numbers(df["wind_speed_ms"]),
        "wind_from_deg": _numbers(df["wind_from_deg"]),
        "line": line_no,
    })


def _numbers(s: pd.Series) -> np.ndarray:
    """float64 of text fields (stripped; not a number -> NaN)."""
    return pd.to_numeric(s.astype(str).str.strip(), errors="coerce").to_numpy(dtype=float)


def _reference_wide_to_long(df: pd.DataFrame, time: np.ndarray, line_no: np.ndarray, path: Path) -> pd.DataFrame:
    """Wide-form reference (``wind_speed_ms_<h>m``, ``wind_from_deg_<h>m``) as long-form rows."""
    cols = {c: m for c in df.columns if (m := _WIDE.match(c))}
    heights = sorted({float(m.group(2)) for m in cols.values()})
    if not heights:
        raise InputError(path, "neither long form (time_utc,height_m,wind_speed_ms,"
                               "wind_from_deg) nor wide form (wind_speed_ms_<h>m, "
                               "wind_from_deg_<h>m columns)")
    parts = []
    for h in heights:
        sp = [c for c, m in cols.items() if m.group(1) == "wind_speed_ms" and float(m.group(2)) == h]
        di = [c for c, m in cols.items() if m.group(1) == "wind_from_deg" and float(m.group(2)) == h]
        if not sp:
            raise InputError(path, f"wide form: no wind_speed_ms column for height {h:g} m")
        parts.append(pd.DataFrame({
            "time": time, "height_m": h,
            "wind_speed_ms": _numbers(df[sp[0]]),
            "wind_from_deg": _numbers(df[di[0]]) if di else np.nan,
            "line": line_no,
        }))
    return pd.concat(parts, ignore_index=True)


def _reference_value_problems(long: pd.DataFrame) -> tuple[np.ndarray, list[str]]:
    """Rows with a bad height, speed or direction: their mask and ``"<line>: <what>"`` (a row's first problem)."""
    checks = [
        (~np.isfinite(long["height_m"]) | (long["height_m"] < 0), "height_m must be a number >= 0 (m above ground)"),
        (long["wind_speed_ms"] < 0, "wind_speed_ms must be >= 0"),
        ((long["wind_from_deg"] < 0) | (long["wind_from_deg"] > 360), "wind_from_deg must be within [0, 360]"),
    ]
    wrong = np.zeros(len(long), dtype=bool)
    what = np.full(len(long), "", dtype=object)
    for mask, text in checks:
        m = mask.to_numpy(dtype=bool) & ~wrong
        what[m] = text
        wrong |= m
    lines = long["line"].to_numpy()
    return wrong, [f"{int(lines[i])}: {what[i]}" for i in np.flatnonzero(wrong)]


def _reference_rows(path: Path, max_corrupt_fraction: float = 0.05) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The good long-form rows of a tower reference with their file lines, and counts.

    A line is corrupt when it has another number of fields than the header or a time stamp
    that is not ISO 8601 UTC with a trailing ``Z``; a (time, height) row when its height is
    not a number >= 0, its speed negative or its direction outside [0, 360].

    Returns
    -------
    long : pandas.DataFrame
        ``time``, ``height_m``, ``wind_speed_ms``, ``wind_from_deg``, ``line``.
    counts : dict
        ``form``, ``n_lines``, ``n_corrupt_lines`` (lines and rows), ``_log``.

    Raises
    ------
    InputError
        See :func:`read_tower_reference`.
    """
    header, frame, time, line_no, bad, n_lines = _csv_rows(path, "tower reference not found")
    if {"height_m", "wind_speed_ms", "wind_from_deg"} <= set(header):
        form, long = "long", _reference_long_form(frame, time, line_no)
    else:
        form, long = "wide", _reference_wide_to_long(frame, time, line_no, path)
    wrong, bad_values = _reference_value_problems(long)
    long = long.loc[~wrong]
    bad = sorted(bad + bad_values, key=lambda b: int(b.split(":", 1)[0]))
    _corrupt_check(path, bad, n_lines, max_corrupt_fraction, "another number of fields than the header, a "
                   "time_utc that is not ISO 8601 UTC with a trailing 'Z', or a height, speed or direction out "
                   "of range")
    if long.empty:
        raise InputError(path, "no data rows")
    return long.reset_index(drop=True), {"form": form, "n_lines": n_lines, "n_corrupt_lines": len(bad),
                                         "_log": _corrupt_log(path, bad, n_lines)}


def _reference_grid(long: pd.DataFrame) -> xr.Dataset:
    """Long-form rows on a (time, height) grid with CF attributes."""
    ds = long.drop(columns="line").set_index(["time", "height_m"]).to_xarray()
    ds = ds.rename({"height_m": "height"}).sortby("time").sortby("height")
    ds = ds.assign_coords(height_m=("height", ds["height"].to_numpy().astype(float)))
    ds = ds.drop_vars("height")
    ds["wind_speed_ms"].attrs.update({"units": "m s-1", "standard_name": "wind_speed"})
    ds["wind_from_deg"].attrs.update({"units": "degree",
                                      "standard_name": "wind_from_direction"})
    ds["height_m"].attrs.update({"units": "m", "standard_name": "height",
                                 "long_name": "height above ground"})
    ds["time"].attrs.update({"standard_name": "time", "long_name": "time (UTC)"})
    return ds


def read_tower_reference(path: str | Path, max_corrupt_fraction: float = 0.05) -> xr.Dataset:
    """Read the tower reference CSV (1 Hz or 1-min means; long or wide form).

    Parameters
    ----------
    path : str or Path
        Long form ``time_utc,height_m,wind_speed_ms,wind_from_deg`` (one row per time and
        height), or wide form ``time_utc,wind_speed_ms_<h>m,wind_from_deg_<h>m,...``.
    max_corrupt_fraction : float, optional
        Largest tolerated fraction of corrupt lines (:func:`_reference_rows`) [1].

    Returns
    -------
    xarray.Dataset
        Dimensions ``time`` (UTC, time stamp of each record) and ``height`` (coordinate
        ``height_m`` [m above ground]); variables ``wind_speed_ms`` [m s-1] and
        ``wind_from_deg`` [degree], NaN where a height has no record at a time. attrs
        ``sampling_interval_s`` (median spacing), ``n_lines``, ``n_corrupt_lines`` (removed,
        their lines in the log), ``n_nonfinite``, ``n_duplicates``, ``n_time_conflicts``,
        ``processing_log``.

    Raises
    ------
    InputError
        Missing file/columns, more than ``max_corrupt_fraction`` of the lines corrupt (bad
        times, negative speeds or heights, a direction outside [0, 360]; names the first),
        or no data.
    """
    path = Path(path)
    long, counts = _reference_rows(path, max_corrupt_fraction)
    form = counts["form"]
    log = [f"read: {len(long)} rows from {path.name}"]
    if counts["n_corrupt_lines"]:
        log.append(counts["_log"])
    n_nonfinite = int((~np.isfinite(long["wind_speed_ms"])).sum() + (~np.isfinite(long["wind_from_deg"])).sum())
    exact = long.drop(columns="line").duplicated(keep="first").to_numpy()
    long = long.loc[~exact]
    conflict = long.duplicated(["time", "height_m"], keep=False).to_numpy()
    long = long.loc[~conflict]
    n_dup, n_conflict = int(exact.sum()), int(conflict.sum())
    if n_dup:
        log.append(f"dedupe: {n_dup} duplicated (time, height) rows removed (first kept)")
    if n_conflict:
        log.append(f"dedupe: {n_conflict} rows repeating a (time, height) with other values removed, none trusted")
    if n_nonfinite:
        log.append(f"parse: {n_nonfinite} missing or non-numeric values kept as NaN")
    if long.empty:
        raise InputError(path, "no data rows left after removing conflicting time stamps")
    ds = _reference_grid(long)
    t_ns = ds["time"].to_numpy().astype("int64")
    ds.attrs.update({
        "sampling_interval_s": float(np.median(np.diff(t_ns)) / 1e9) if t_ns.size > 1 else float("nan"),
        "n_nonfinite": n_nonfinite, "n_duplicates": n_dup, "n_time_conflicts": n_conflict, "form": form,
        "n_lines": counts["n_lines"], "n_corrupt_lines": counts["n_corrupt_lines"],
        "source_file": str(path), "processing_log": "\n".join(log),
    })
    return ds
