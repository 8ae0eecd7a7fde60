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


def _csv_header(path: Path, not_found: str, required: tuple[str, ...]) -> tuple[bytes, list[str]]:
    """The content of a CSV log and its header's field names (stripped).

    Raises
    ------
    InputError
        Missing file, empty file, a header without the ``required`` columns.
    """
    if not path.is_file():
        raise InputError(path, not_found)
    raw = path.read_bytes()
    first = textscan.first_line(raw)
    if first is None:
        raise InputError(path, "empty file; expected a header line")
    header = [h.strip() for h in split_csv_line(first) or []]
    missing = [c for c in required if c not in header]
    if missing:
        raise InputError(f"{path}:1", f"missing column(s) {missing}; expected header {','.join(required)}")
    return raw, header


def _irregular_csv_rows(lines: list[str], line_no: np.ndarray, header: list[str], required: tuple[str, ...],
                        exact: bool) -> tuple[pd.DataFrame, np.ndarray, np.ndarray, list[str], int]:
    """The fault handling of CSV log lines, one by one: fields, time stamps and what is wrong with each line.

    A data line is corrupt when it has another number of fields than the header (with
    ``exact`` False: fewer than up to the last ``required`` column, or more than the
    header's; the missing ones are empty) or a ``time_utc`` that is not a contract time stamp
    (:func:`parse_time_utc`); blank lines are skipped.

    Parameters
    ----------
    lines : list of str
        Data lines.
    line_no : numpy.ndarray
        Their 1-based file lines.
    header : list of str
        The field names.
    required : tuple of str
        Columns a row must reach (with ``exact`` False).
    exact : bool
        Rows must have one field per header name.

    Returns
    -------
    frame : pandas.DataFrame
        The good rows' fields as text, columns named by the header.
    time : numpy.ndarray
        datetime64[ns] of the good rows.
    good_lines : numpy.ndarray
        1-based file line of the good rows.
    bad : list of str
        ``"<line>: <what>"`` of every corrupt line, in file order.
    n_lines : int
        Non-blank lines.
    """
    split = split_csv_lines(lines)
    ncol = len(header)
    # fields a row must have: up to the last required column, or all of the header's
    n_needed = ncol if exact else 1 + max(header.index(c) for c in required)
    good_rows: list[list[str]] = []
    good_lines: list[int] = []
    bad: list[str] = []
    n_lines = 0
    for ln, row in zip(line_no.tolist(), split, strict=True):
        if row is not None and not any(f.strip() for f in row):
            continue
        n_lines += 1
        if row is None or not n_needed <= len(row) <= ncol:
            bad.append(f"{ln}: {0 if row is None else len(row)} fields, expected {ncol}")
        else:
            good_rows.append(row + [""] * (ncol - len(row)))
            good_lines.append(ln)
    frame = pd.DataFrame(good_rows, columns=header, dtype=object) if good_rows else pd.DataFrame(columns=header)
    text = frame["time_utc"].astype(str).str.strip() if good_rows else pd.Series([], dtype=object)
    ok = text.str.match(_ISO_Z.pattern).fillna(False).to_numpy(dtype=bool)
    stamps = pd.to_datetime(text.where(ok, "1970-01-01T00:00:00Z").str.slice(0, -1), format="ISO8601",
                            errors="coerce")
    ok = ok & ~stamps.isna().to_numpy()
    good = np.asarray(good_lines, dtype=np.int64)
    for i in np.flatnonzero(~ok):
        bad.append(f"{int(good[i])}: {_time_problem(str(text.iloc[i]))}")
    bad.sort(key=lambda b: int(b.split(":", 1)[0]))
    return frame.loc[ok].reset_index(drop=True), stamps.to_numpy(dtype="datetime64[ns]")[ok], good[ok], bad, n_lines


def _csv_rows(path: Path, not_found: str, required: tuple[str, ...] = ("time_utc",), exact: bool = True,
              ) -> tuple[list[str], pd.DataFrame, np.ndarray, np.ndarray, list[str], int]:
    """The rows of a CSV log, every line through :func:`_irregular_csv_rows` (the tower reference's reader).

    Returns
    -------
    header : list of str
        The field names (stripped).
    frame, time, line_no, bad, n_lines
        As :func:`_irregular_csv_rows`.

    Raises
    ------
    InputError
        Missing file, empty file, a header without the ``required`` columns, no data rows.
    """
    raw, header = _csv_header(path, not_found, required)
    lines = text_lines(raw)[1:]
    frame, time, line_no, bad, n_lines = _irregular_csv_rows(lines, np.arange(2, len(lines) + 2), header, required,
                                                             exact)  # fmt: skip
    if n_lines == 0:
        raise InputError(path, "no data rows")
    return header, frame, time, line_no, bad, n_lines


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

    The parser of the quadrotor CSV. The regular lines (printable ASCII without spaces or
    quotes, one field per header name, numbers of at most
    :data:`~dronewind.core.textscan.FLOAT_FAST_MAX_CHARS` characters without exponent or
    NaN literals, time stamps of the fixed ISO 8601 form with a trailing ``Z``) are found
    and converted in bulk by a byte-level scan; every other line goes, with its line number,
    to the line-by-line fault handling (:func:`_irregular_csv_rows`): corrupt lines removed
    and counted, blank lines skipped. The rows of both are put back in line order.

    The scan is written by hand because the rows must be those of the line-by-line parse
    bit for bit (``pandas.to_numeric`` of every stripped field, whose rounding of long and
    exponent literals ``read_csv`` does not share: :mod:`dronewind.core.textscan`), at a
    fraction of its cost (400,000 rows, 36 MB: 0.3 s of CPU by the scan, 4 s line by line).

    Returns
    -------
    time, columns, line_no
        Of the good rows in file order.
    counts : dict
        ``n_lines``, ``n_corrupt_lines``, ``n_nonfinite`` and ``_log`` (the log line of the
        corrupt lines).

    Raises
    ------
    InputError
        Missing file or columns, an empty file, no data rows, more than
        ``max_corrupt_fraction`` of the lines corrupt (names the first).
    """
    raw, header = _csv_header(path, "quadrotor log not found", QUADROTOR_COLUMNS)
    _, body, buf, starts, ends, unusual = textscan.text_body(raw, 1)
    ncol, n = len(header), int(starts.size)
    j_time = header.index("time_utc")
    j_num = [header.index(c) for c in QUADROTOR_COLUMNS[1:]]
    candidate = (ends > starts) & ~textscan.lines_holding(body, buf, starts, textscan.PLAIN_CSV, unusual) \
        & ~textscan.lines_with(body, buf, starts, b"eE")  # fmt: skip
    rows, cpos, _ = textscan.comma_grid(np.flatnonzero(buf == ord(",")), starts, ends, candidate, ncol)

    row_start, row_end = (starts, ends) if rows.size == n else (starts[rows], ends[rows])

    def span(j: int) -> tuple[np.ndarray, np.ndarray]:
        return (row_start if j == 0 else cpos[:, j - 1] + 1), (cpos[:, j] if j < ncol - 1 else row_end)

    provable = np.ones(rows.size, dtype=bool)
    values: dict[str, np.ndarray] = {}
    time = np.zeros(0, dtype="datetime64[ns]")
    if rows.size:
        t0, t1 = span(j_time)
        time, provable = textscan.fixed_width_times(buf, t0, t1 - t0, sep=b"T", suffix=b"Z")
        scanned = np.zeros(n, dtype=bool)
        scanned[rows] = True
        names = [str(k) for k in range(ncol)]
        frame = textscan.read_numeric_columns(textscan.kept_lines(body, starts, scanned), names,
                                              [names[j] for j in j_num],
                                              {names[j]: textscan.NAN_LITERALS for j in j_num}, quoting=False)
        for col, j in zip(QUADROTOR_COLUMNS[1:], j_num, strict=True):
            f0, f1 = span(j)
            values[col], ok = textscan.float_fields(frame[names[j]], f1 - f0)
            provable &= ok
    regular = np.zeros(n, dtype=bool)
    regular[rows[provable]] = True
    irregular = np.flatnonzero(~regular)
    frame_i, time_i, lines_i, bad, n_lines_i = _irregular_csv_rows(
        textscan.line_text(body, starts, ends, irregular), irregular + 2, header, QUADROTOR_COLUMNS, exact=False)
    n_lines = int(regular.sum()) + n_lines_i
    if n_lines == 0:
        raise InputError(path, "no data rows")
    _corrupt_check(path, bad, n_lines, max_corrupt_fraction, "another number of fields than the header or a "
                   "time_utc that is not ISO 8601 UTC with a trailing 'Z'")
    line_no = np.concatenate([np.flatnonzero(regular) + 2, lines_i])
    if line_no.size == 0:
        raise InputError(path, "no data rows")  # every data line corrupt
    if not provable.all():
        values = {col: v[provable] for col, v in values.items()}
        time = time[provable]
    columns: dict[str, np.ndarray] = {}
    if lines_i.size:  # rows of both, in line order
        order = np.argsort(line_no, kind="stable")
        line_no = line_no[order]
        for col in QUADROTOR_COLUMNS[1:]:
            by_line = pd.to_numeric(frame_i[col].astype(str).str.strip(), errors="coerce").to_numpy(dtype=float)
            columns[col] = np.concatenate([values.get(col, np.zeros(0)), by_line])[order]
        time = np.concatenate([time, time_i])[order]
    else:
        columns = values
    n_nonfinite = sum(int((~np.isfinite(v)).sum()) for v in columns.values())
    return time, columns, line_no, {"n_lines": n_lines, "n_corrupt_lines": len(bad), "n_nonfinite": n_nonfinite,
                                    "_log": _corrupt_log(path, bad, n_lines) if bad else ""}


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


