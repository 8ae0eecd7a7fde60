r"""Reader of quadrotor (SWUF-3D) flight logs: the quadrotor CSV, and every log format through :func:`read_quadrotor`.

The quadrotor CSV of the data contract (``docs/data-contract.md``, "Quadrotor file"), at
10 Hz or more::

    time_utc,roll_deg,pitch_deg,yaw_deg,vel_n_ms,vel_e_ms,vel_d_ms,lat_deg,lon_deg,alt_m

``time_utc`` is ISO 8601 UTC with a trailing ``Z``, with or without fractional seconds.
:func:`read_quadrotor` reads it and, by format, PX4 ULog (:mod:`dronewind.quadrotor.ulog`),
ArduPilot DataFlash logs (:mod:`dronewind.quadrotor.ardupilot`) and delimited text by a
column mapping (:mod:`dronewind.quadrotor.delimited`); the tower reference is read by
:mod:`dronewind.quadrotor.reference`.

Every reader returns an :class:`xarray.Dataset` with a ``time`` dimension
(``datetime64[ns]``, naive, meaning UTC), CF attributes, removed-sample counts ``n_*`` and a
``processing_log``. Bad input raises :class:`dronewind.errors.InputError` naming the file,
line or variable and what was expected.

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F.: Distributed wind measurements with multiple
   quadrotor UAVs in the atmospheric boundary layer (SWUF-3D), Wetz et al. (2021)
  , Sects. 2-5.
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
from dronewind.core.rowfaults import split_csv_line, split_csv_lines, text_lines
from dronewind.errors import InputError
from dronewind.quadrotor.columns import QUADROTOR_COLUMNS

__all__ = [
    "parse_time_utc",
    "read_quadrotor",
    "read_quadrotor_csv",
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
        from dronewind.quadrotor.ulog import read_quadrotor_ulog

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


