r"""Readers for the SAMURAI-S-type payload: sonic CSV and INS CSV to L1 datasets.

L0 formats (``../shared/DESIGN.md``, "Payload sonic file" and "INS file")::

    rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c
    rpi_time_us,utc,time_valid,ekf_valid,lat_deg,lon_deg,alt_m,vel_n_ms,vel_e_ms,vel_d_ms,roll_deg,pitch_deg,yaw_deg

Both files are stamped by the logger's clock (``rpi_time_us``, not UTC). The INS also logs
GNSS UTC, so the logger clock is converted to UTC by a robust straight-line fit
``utc = a + b * rpi_time`` over the INS rows with a stable valid GNSS time (Ghirardelli et al. 2025,
Sect. 3.2), which is then applied to the sonic.

Bad input policy (every removal is counted in ``ds.attrs["n_*"]`` and described in
``ds.attrs["processing_log"]``):

* header not exactly the expected one -> :class:`~dronewind.errors.InputError` naming line 1;
* corrupt lines (wrong column count, non-numeric field, unparsable UTC while
  ``time_valid`` = 1): removed, counted (``n_corrupt_lines``), the first few line numbers
  logged; more than 5 % corrupt lines -> InputError naming the file and the first bad line;
* exact duplicate rows: dropped (``n_duplicates``); rows repeating a time stamp with other
  values: all of them dropped, none trusted (``n_time_conflicts``, lines logged; more than
  5 % -> InputError);
* rows out of order by less than ``clock_jump_tol_s`` (1 s): sorted (``n_out_of_order``);
* an isolated row whose time stamp is more than ``clock_jump_tol_s`` from both neighbours
  while the neighbours agree: a corrupt time stamp, removed (``n_time_outliers``);
* clock jumps -> :class:`ClockJumpError` (an InputError), never corrected: (a) a backward
  step of ``rpi_time_us`` in row order larger than ``clock_jump_tol_s`` (cannot be a late
  row; the logger clock was set back, and rows of the two clock epochs cannot be told
  apart once sorted), (b) a step in the INS relation ``utc - rpi_time`` larger than
  ``relation_jump_tol_s`` (0.1 s; the logger clock or GNSS time stepped). Correction was
  rejected: it needs the segment of every sonic row, which a backward step makes ambiguous,
  and a silently mis-corrected clock biases every later step (sync, motion correction).
  A forward step of the sonic's ``rpi_time_us`` with no step in the INS relation is a data
  gap (the shared clock ran on): its samples are inserted as missing (``n_missing``), up
  to ``max_gap_s`` (60 s); a longer forward step raises ClockJumpError;
* values out of the instrument's range (:data:`dronewind.core.filtering.INSTRUMENT_LIMITS`),
  NaN values and spikes are flagged in the QC bitmask and set to NaN (not filled).

QC bitmask (``qc_sonic``, ``qc_ins``; bits of :mod:`dronewind.core.qc`): 1 out of range,
2 spike, 4 missing/corrupt, 8 gap-filled (set by later stages).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import bottleneck as bn
import numpy as np
import pandas as pd
import xarray as xr

from dronewind.core import textscan
from dronewind.core.angles import deg2rad, rad2deg
from dronewind.core.cf import variable_attrs
from dronewind.core.constants import ZERO_CELSIUS_K
from dronewind.core.filtering import INSTRUMENT_LIMITS, despike_moving_mad, range_mask
from dronewind.core.qc import QC_MISSING, QC_OUT_OF_RANGE, QC_SPIKE, qc_flag_attrs
from dronewind.core.raw import RawRecord
from dronewind.core.reuse import reused
from dronewind.core.rowfaults import text_lines
from dronewind.core.timeseries import median_of_steps, median_step, unwrap_rad
from dronewind.errors import InputError, describe_header
from dronewind.payload.columns import INS_COLUMNS, SONIC_COLUMNS

__all__ = [
    "ClockFit",
    "ClockJumpError",
    "INS_COLUMNS",
    "InsTable",
    "SONIC_COLUMNS",
    "fit_logger_clock",
    "ins_l1",
    "load_ins_table",
    "payload_sonic_l1",
    "read_ins_csv",
    "read_sonic_csv",
]


_N_LOGGED_LINES = 5  # how many corrupt line numbers are quoted in the log
_US = 1_000_000


class ClockJumpError(InputError):
    """A step of the logger clock (or of its relation to GNSS UTC) that cannot be explained.

    Parameters
    ----------
    where : str or Path
        File and line of the first row after the step.
    what : str
        Size and kind of the step.
    """


# --------------------------------------------------------------------------- CSV parsing


@dataclass
class _Table:
    """Parsed CSV: column arrays (good rows only), their file line numbers and counts."""

    path: str
    columns: dict[str, np.ndarray]
    line_no: np.ndarray
    n_data_lines: int
    n_blank_lines: int
    corrupt_lines: list[int]
    log: list[str] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)

    def take(self, index: np.ndarray) -> None:
        """Keep rows `index` (in that order)."""
        self.columns = {k: v[index] for k, v in self.columns.items()}
        self.line_no = self.line_no[index]


def _read_text(path: str | os.PathLike[str]) -> bytes:
    p = Path(path)
    if not p.is_file():
        raise InputError(p, "file not found")
    # Binary garbage in a line must not stop the reader: it becomes a corrupt line.
    return p.read_bytes()


def _split_lines(path: str | os.PathLike[str], expected: tuple[str, ...]) -> tuple[list[str], np.ndarray, int]:
    """Read a CSV, check its header and drop blank lines.

    Parameters
    ----------
    path : str or Path
        CSV file.
    expected : tuple of str
        Expected header fields.

    Returns
    -------
    body : list of str
        Non-blank data lines.
    line_numbers : numpy.ndarray
        Their file line numbers (1-based, the header is line 1).
    n_blank : int
        Number of blank lines dropped.
    """
    lines = text_lines(_read_text(path))
    if not lines:
        raise InputError(path, f"empty file; expected header {','.join(expected)!r}")
    header = tuple(h.strip() for h in lines[0].split(","))
    if header != expected:
        raise InputError(f"{path}:1", describe_header(header, expected))
    body = lines[1:]
    line_numbers = np.arange(2, len(body) + 2)
    blank = np.fromiter((not ln.strip() for ln in body), dtype=bool, count=len(body))
    n_blank = int(blank.sum())
    body = [ln for ln, b in zip(body, blank, strict=True) if not b]
    line_numbers = line_numbers[~blank]
    if len(body) == 0:
        raise InputError(path, "no data lines after the header")
    return body, line_numbers, n_blank


def _parse_field(s: pd.Series, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Values of one column and the mask of its corrupt fields.

    Parameters
    ----------
    s : pandas.Series
        The column's stripped text fields.
    kind : {"int", "float", "flag", "utc"}
        Integer literal; number or nan literal; 0 or 1; ISO 8601 (optional trailing Z, may
        be empty -> NaT).

    Returns
    -------
    values : numpy.ndarray
        int64, float64 or datetime64[ns].
    bad : numpy.ndarray
        True where the field is corrupt.
    """
    if kind in ("int", "flag"):
        ok = s.str.fullmatch(r"[+-]?\d+").to_numpy(dtype=bool)
        vals = np.zeros(len(s), dtype=np.int64)
        if ok.any():
            vals[ok] = s[ok].astype(np.int64).to_numpy()
        if kind == "flag":
            ok = ok & ((vals == 0) | (vals == 1))
        return vals, ~ok
    if kind == "float":
        fvals = pd.to_numeric(s, errors="coerce").to_numpy(dtype=float)
        nan_literal = s.str.lower().isin(["nan", "+nan", "-nan"]).to_numpy(dtype=bool)
        return fvals, np.isnan(fvals) & ~nan_literal
    if kind == "utc":
        empty = (s == "").to_numpy(dtype=bool)
        t = pd.to_datetime(s.str.removesuffix("Z"), format="ISO8601", errors="coerce")
        tvals = t.to_numpy().astype("datetime64[ns]")
        return tvals, np.isnat(tvals) & ~empty
    raise ValueError(kind)  # pragma: no cover - programming error


def _parse_rows(rows: list[list[str]], expected: tuple[str, ...], kinds: dict[str, str],
                ) -> tuple[dict[str, np.ndarray], np.ndarray, dict[str, int]]:
    """Column arrays of the rows with the right field count, the mask of corrupt rows and bad fields per column."""
    bad = np.zeros(len(rows), dtype=bool)
    cols: dict[str, np.ndarray] = {}
    per_column: dict[str, int] = {}
    frame = pd.DataFrame(rows, columns=list(expected), dtype=object) if rows else None
    for name in expected:
        if frame is None:
            cols[name] = np.zeros(0)
            continue
        cols[name], bad_field = _parse_field(frame[name].astype(str).str.strip(), kinds[name])
        bad |= bad_field
        if bad_field.any():
            per_column[name] = int(bad_field.sum())
    return cols, bad, per_column


@dataclass
class _Rows:
    """Lines of a CSV split into fields and parsed, before the corrupt ones are removed.

    Attributes
    ----------
    line_numbers : numpy.ndarray
        File line numbers of the non-blank data lines.
    n_blank : int
        Blank lines dropped.
    good_count : numpy.ndarray
        True for the non-blank lines with the expected number of fields.
    cols : dict of numpy.ndarray
        Values of those lines, per column.
    bad : numpy.ndarray
        True for those lines with a corrupt field.
    per_column : dict of int
        Corrupt fields per column (columns without any left out).
    """

    line_numbers: np.ndarray
    n_blank: int
    good_count: np.ndarray
    cols: dict[str, np.ndarray]
    bad: np.ndarray
    per_column: dict[str, int]


def _rows_careful(path: str | os.PathLike[str], expected: tuple[str, ...], kinds: dict[str, str]) -> _Rows:
    """Split and parse the CSV line by line (the reference; names every header error)."""
    body, line_numbers, n_blank = _split_lines(path, expected)
    ncol = len(expected)
    split = [ln.split(",") for ln in body]
    good_count = np.fromiter((len(f) == ncol for f in split), dtype=bool, count=len(body))
    rows = [f for f, g in zip(split, good_count, strict=True) if g]
    cols, bad, per_column = _parse_rows(rows, expected, kinds)
    return _Rows(line_numbers, n_blank, good_count, cols, bad, per_column)


def _rows_fast(path: str | os.PathLike[str], expected: tuple[str, ...], kinds: dict[str, str]) -> _Rows | None:
    """The same as :func:`_rows_careful`, from a byte-level scan, or None when it cannot vouch for that.

    Hand-written rather than one ``pandas.read_csv`` call because the careful parse's
    results must be reproduced exactly: its line numbers (blank lines skipped but counted,
    lines with a wrong field count kept as corrupt lines), its NaN literals, its corrupt
    fields per column and its float rounding (:mod:`dronewind.core.textscan`). The scan
    finds lines and fields with numpy; ``read_csv`` converts the numbers of the plain lines;
    the ``utc`` column is parsed at fixed width. A column that is not plain (a corrupt
    field, a long or exponent float, an unusual time stamp) is parsed by the careful
    :func:`_parse_field`, on the same strings as the careful path; a non-plain line with
    the right field count (spaces, quotes, non-ASCII bytes), an unusual line break or
    header, or an empty body makes the whole file go the careful way (returns None).
    """
    body = textscan.csv_body(path, expected)
    if body is None:
        return None
    raw, buf, starts, ends, unusual = body
    ncol = len(expected)
    odd = textscan.lines_holding(raw, buf, starts, textscan.PLAIN_CSV, unusual)
    blank = ends == starts
    for i in np.flatnonzero(odd):
        line = raw[starts[i]:ends[i]].decode("utf-8", errors="replace")
        if not line.strip():
            blank[i] = True
        elif len(line.split(",")) == ncol:
            return None
    commas = np.flatnonzero(buf == ord(","))
    rows, cpos, first_comma = textscan.comma_grid(commas, starts, ends, ~odd & ~blank, ncol)
    if rows.size == 0:
        return None
    good = np.zeros(starts.size, dtype=bool)
    good[rows] = True
    if rows.size == starts.size:
        plain = raw
    else:
        next_start = np.concatenate([starts[1:], [buf.size]])
        plain = buf[np.repeat(good, next_start - starts)].tobytes()
    numeric = [c for c in expected if kinds[c] != "utc"]
    frame = textscan.read_numeric_columns(plain, list(expected), numeric,
                                          {c: textscan.NAN_LITERALS for c in numeric if kinds[c] == "float"},
                                          quoting=False)  # fmt: skip
    if len(frame) != rows.size:
        return None
    exponent = textscan.exponent_fields(raw, buf, commas, starts, first_comma, good)
    cols: dict[str, np.ndarray] = {}
    bad = np.zeros(rows.size, dtype=bool)
    per_column: dict[str, int] = {}
    for j, name in enumerate(expected):
        fstart = starts[rows] if j == 0 else cpos[:, j - 1] + 1
        fend = cpos[:, j] if j < ncol - 1 else ends[rows]
        fast = _fast_field(frame[name] if name in frame else None, kinds[name], buf, fstart, fend, j in exponent)
        if fast is None:  # not plain: the careful conversion of the same strings
            text = pd.Series(textscan.field_strings(raw, fstart, fend), dtype=object)
            fast = _parse_field(text.astype(str).str.strip(), kinds[name])
        cols[name], bad_field = fast
        bad |= bad_field
        if bad_field.any():
            per_column[name] = int(bad_field.sum())
    nonblank = ~blank
    return _Rows(np.arange(2, starts.size + 2)[nonblank], int(blank.sum()), good[nonblank], cols, bad, per_column)


def _fast_field(values: pd.Series | None, kind: str, buf: np.ndarray, start: np.ndarray, end: np.ndarray,
                has_exponent: bool) -> tuple[np.ndarray, np.ndarray] | None:
    """Values and corrupt mask of a plain column as :func:`_parse_field` gives them, or None if not plain.

    Parameters
    ----------
    values : pandas.Series or None
        The column as ``read_csv`` read it (None for ``utc``).
    kind : str
        As :func:`_parse_field`.
    buf : numpy.ndarray
        The bytes of the data lines.
    start, end : numpy.ndarray
        Byte span of the column's field in every line.
    has_exponent : bool
        A field of the column holds an ``e`` or ``E``.
    """
    n = start.size
    if kind == "utc":
        length = end - start
        empty = length == 0
        times, ok = textscan.fixed_width_times(buf, start, length, sep=b"T", suffix=b"Z")
        return (times, np.zeros(n, dtype=bool)) if bool((ok | empty).all()) else None
    assert values is not None
    if kind in ("int", "flag"):
        if values.dtype != np.int64:
            return None
        vals = values.to_numpy(dtype=np.int64)
        bad = ~((vals == 0) | (vals == 1)) if kind == "flag" else np.zeros(n, dtype=bool)
        return vals, bad
    if values.dtype not in (np.float64, np.int64) or has_exponent \
            or int((end - start).max()) > textscan.FLOAT_FAST_MAX_CHARS:  # fmt: skip
        return None
    fvals = values.to_numpy(dtype=float)
    if np.isinf(fvals).any():
        return None
    return fvals, np.zeros(n, dtype=bool)  # NaN only from the nan literals


def _parse_csv(
    path: str | os.PathLike[str],
    expected: tuple[str, ...],
    kinds: dict[str, str],
    max_corrupt_fraction: float,
    extra_bad: Any = None,
) -> _Table:
    """Parse a fixed-header CSV line by line, separating corrupt lines.

    kinds: column -> "int" (integer literal), "float" (number or nan literal), "flag"
    (0 or 1), "utc" (ISO 8601, optional trailing Z, may be empty).
    extra_bad: optional callable(columns) -> bool array of further corrupt rows.
    Plain files take the byte-level fast path (:func:`_rows_fast`), anything else the
    careful one (:func:`_rows_careful`); both give the same result.
    """
    parsed = _rows_fast(path, expected, kinds) or _rows_careful(path, expected, kinds)
    line_numbers, n_blank, good_count = parsed.line_numbers, parsed.n_blank, parsed.good_count
    cols, bad, per_column = parsed.cols, parsed.bad, parsed.per_column
    n_lines = len(line_numbers)
    ncol = len(expected)
    if extra_bad is not None and good_count.any():
        bad |= extra_bad(cols)
    good_lines = line_numbers[good_count]
    corrupt = np.sort(np.concatenate([line_numbers[~good_count], good_lines[bad]]))
    n_corrupt = int(corrupt.size)
    if n_corrupt > max_corrupt_fraction * n_lines:
        raise InputError(
            f"{path}:{int(corrupt[0])}",
            f"{n_corrupt} of {n_lines} data lines corrupt (> {100 * max_corrupt_fraction:g} %); "
            f"first corrupt lines {corrupt[:_N_LOGGED_LINES].tolist()}; "
            f"{int((~good_count).sum())} lines without {ncol} fields"
            + "".join(f", {n} bad {name} fields" for name, n in sorted(per_column.items(), key=lambda kv: -kv[1]))
            + f"; expected {ncol} comma-separated fields {','.join(expected)}",
        )
    keep = ~bad
    table = _Table(path=str(path), columns={k: v[keep] for k, v in cols.items()}, line_no=good_lines[keep],
                   n_data_lines=n_lines, n_blank_lines=n_blank, corrupt_lines=corrupt.tolist())
    table.counts.update(n_lines=n_lines, n_corrupt_lines=n_corrupt, n_blank_lines=n_blank)
    msg = f"parse: {n_lines} data lines, {n_corrupt} corrupt removed"
    if n_corrupt:
        msg += f" (first at lines {corrupt[:_N_LOGGED_LINES].tolist()})"
    if n_blank:
        msg += f", {n_blank} blank lines ignored"
    table.log.append(msg)
    if table.columns[expected[0]].size == 0:
        raise InputError(path, "no valid data rows")
    return table


def _table_of_record(rec: RawRecord, expected: tuple[str, ...], kinds: dict[str, str]) -> _Table:
    """The parsed-table form of an in-memory record (no text: no blank or corrupt lines)."""
    dtype_kind = {"int": "i", "flag": "i", "float": "f", "utc": "M"}
    cols = rec.checked(expected, {name: dtype_kind[kinds[name]] for name in expected})
    flag_bad = [name for name in expected if kinds[name] == "flag" and not np.isin(cols[name], (0, 1)).all()]
    if flag_bad:
        raise InputError(f"{rec.source}: {flag_bad[0]}", "values other than 0 and 1 in the in-memory record")
    n = rec.n_rows
    table = _Table(path=rec.source, columns=cols, line_no=rec.line_numbers(), n_data_lines=n, n_blank_lines=0,
                   corrupt_lines=[])
    table.counts.update(n_lines=n, n_corrupt_lines=0, n_blank_lines=0)
    table.log.append(f"parse: {n} data lines, 0 corrupt removed")
    return table


def _table(source: str | os.PathLike[str] | RawRecord, expected: tuple[str, ...], kinds: dict[str, str],
           max_corrupt_fraction: float) -> _Table:
    """Parse a file (:func:`_parse_csv`) or take an in-memory record (:mod:`dronewind.core.raw`)."""
    if isinstance(source, RawRecord):
        table = _table_of_record(source, expected, kinds)
        # a file read by its manifest mapping (dronewind.payload.delimited) brings its parsing's counts and log
        table.counts.update(getattr(source, "counts", {}))
        table.log[-1:] = list(getattr(source, "log", ())) or table.log[-1:]
        return table
    return _parse_csv(source, expected, kinds, max_corrupt_fraction)


def _check_backward_jump(path: str, line_no: np.ndarray, t: np.ndarray, clock_jump_tol_s: float,
                         allow_block: bool = False) -> None:
    """Raise :class:`ClockJumpError` at the first backward step in row order larger than the tolerance.

    A late row lies below the running maximum by less than the tolerance; a larger deficit
    means the clock was set back, unless ``allow_block`` and the rows are only a block out of
    order (:func:`_block_out_of_order`). ``line_no`` holds the file lines of the rows of ``t``.
    """
    deficit = np.maximum.accumulate(t) - t
    jump = np.flatnonzero(deficit > clock_jump_tol_s * _US)
    if jump.size and not (allow_block and _block_out_of_order(t)):
        i = int(jump[0])
        raise ClockJumpError(
            f"{path}:{int(line_no[i])}",
            f"rpi_time_us steps back by {deficit[i] / _US:.3f} s relative to earlier rows "
            f"(> {clock_jump_tol_s:g} s): logger clock jump; not corrected, fix or split the file",
        )


def _repeated(t: np.ndarray) -> np.ndarray:
    """Rows whose time stamp another row also has (all of them, as ``duplicated(keep=False)``).

    A log whose stamps already increase strictly (every well-formed one) has none: that is
    checked in one pass. Otherwise integer stamps are compared in sorted order (a stable
    sort of an almost sorted column is a few merges), which marks the same rows as pandas'
    hashing at a fifth of its cost for an INS record (0.8 against 3.9 ms for 94,000 rows,
    ``benchmarks/results/record_checks_s26.json``); a forward run reads its INS and sonic
    records, with their logged repeats and swaps, this way in every probe. Other dtypes go
    to pandas.
    """
    if t.size < 2 or bool(np.all(t[1:] > t[:-1])):
        return np.zeros(t.size, dtype=bool)
    if t.dtype.kind not in "iu":
        return pd.Series(t).duplicated(keep=False).to_numpy()
    order = np.argsort(t, kind="stable")
    same = t[order[1:]] == t[order[:-1]]
    in_order = np.zeros(t.size, dtype=bool)
    in_order[1:] |= same
    in_order[:-1] |= same
    out = np.empty(t.size, dtype=bool)
    out[order] = in_order
    return out


def _block_out_of_order(t: np.ndarray) -> bool:
    """Whether rows out of time order are only a block in the wrong place (reversed, moved), not a clock set back.

    A logger clock set back goes on from the earlier time: its rows fall between rows already
    logged, so in time order some follow each other by far less than the sampling interval.
    Rows of a block written in reverse (or elsewhere in the file) fit back on the sampling
    grid when sorted: no step of the sorted times is below a quarter of the median step.

    Parameters
    ----------
    t : numpy.ndarray
        int64 time stamps in row order, without repeats.

    Returns
    -------
    bool
        True when some rows are out of order and the sorted times interleave nowhere.
    """
    if t.size < 3 or bool(np.all(t[1:] > t[:-1])):
        return False
    step = np.diff(np.sort(t))
    return bool(step.min() >= 0.25 * np.median(step))


def _dedup_sort(table: _Table, value_cols: list[str], clock_jump_tol_s: float,
                max_conflict_fraction: float = 0.05) -> None:
    """Drop exact duplicates and time conflicts, check backward jumps, sort by rpi_time_us.

    Rows repeating a time stamp with other values conflict: every row of such a time stamp
    is dropped (counted in ``n_time_conflicts``, lines logged); more than
    ``max_conflict_fraction`` of the rows raises :class:`InputError`.
    """
    t = table.columns["rpi_time_us"]
    # Rows that repeat another row exactly share its time stamp, so only the rows of repeated
    # stamps are compared column by column (the same result as the whole table's
    # DataFrame.duplicated, whose factorising of every column was most of this step's cost).
    repeated = _repeated(t)
    dup = np.zeros(t.size, dtype=bool)
    if repeated.any():
        frame = pd.DataFrame({c: table.columns[c][repeated] for c in ["rpi_time_us", *value_cols]})
        dup[repeated] = frame.duplicated(keep="first").to_numpy()
    n_dup = int(dup.sum())
    # The rows kept are followed as indices into the table (with their stamps and lines) and
    # the table's columns taken once at the end: the same rows in the same order as taking
    # them after each step, without copying every column three or four times.
    rows = np.flatnonzero(~dup)
    t, line_no = t[rows], table.line_no[rows]
    conflict = _repeated(t)
    n_conf = int(conflict.sum())
    if n_conf:
        lines = line_no[conflict][:_N_LOGGED_LINES].tolist()
        if n_conf > max_conflict_fraction * t.size:
            # a clock set back repeats earlier stamps: a jump
            _check_backward_jump(table.path, line_no, t, clock_jump_tol_s)
            raise InputError(f"{table.path}:{lines[0]}",
                             f"{n_conf} of {t.size} rows repeat an rpi_time_us with other values "
                             f"(> {100 * max_conflict_fraction:g} %; first at lines {lines}): expected one row "
                             "per time stamp")
        table.log.append(f"order: {n_conf} rows repeating an rpi_time_us with other values dropped, none "
                         f"trusted (lines {lines})")
        keep = np.flatnonzero(~conflict)
        rows, t, line_no = rows[keep], t[keep], line_no[keep]
    # An isolated corrupt-but-numeric time stamp (its neighbours agree with each other but
    # it is more than the tolerance away from both) is a corrupt row, not a clock jump.
    tol_us = clock_jump_tol_s * _US
    n_iso = 0
    if t.size >= 3:
        far_prev = np.abs(t[1:-1] - t[:-2]) > tol_us
        far_next = np.abs(t[2:] - t[1:-1]) > tol_us
        close = np.abs(t[2:] - t[:-2]) <= tol_us
        iso = np.zeros(t.size, dtype=bool)
        iso[1:-1] = far_prev & far_next & close
        n_iso = int(iso.sum())
        if n_iso:
            table.log.append(
                f"order: {n_iso} isolated rows with a time stamp far from both neighbours "
                f"removed (lines {line_no[iso][:_N_LOGGED_LINES].tolist()})"
            )
            keep = np.flatnonzero(~iso)
            rows, t, line_no = rows[keep], t[keep], line_no[keep]
    table.counts["n_time_outliers"] = n_iso
    _check_backward_jump(table.path, line_no, t, clock_jump_tol_s, allow_block=True)
    run_max = np.maximum.accumulate(t)
    late = np.zeros(t.size, dtype=bool)
    late[1:] = t[1:] < run_max[:-1]
    n_late = int(late.sum())
    table.take(rows[np.argsort(t, kind="stable")])
    table.counts["n_duplicates"] = n_dup
    table.counts["n_time_conflicts"] = n_conf
    table.counts["n_out_of_order"] = n_late
    table.log.append(
        f"order: {n_dup} exact duplicate rows dropped, {n_conf} rows repeating a time stamp "
        f"with other values dropped, {n_late} out-of-order rows sorted"
    )


# ------------------------------------------------------------------------------ reading


def read_sonic_csv(
    path: str | os.PathLike[str] | RawRecord,
    max_corrupt_fraction: float = 0.05,
    clock_jump_tol_s: float = 1.0,
) -> tuple[dict[str, np.ndarray], dict[str, int], list[str]]:
    """Read a payload sonic CSV, remove corrupt and duplicate rows and sort by logger time.

    Parameters
    ----------
    path : str, Path or RawRecord
        CSV with header ``rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c``, or its in-memory record
        (:mod:`dronewind.core.raw`).
    max_corrupt_fraction : float, optional
        Largest tolerated fraction of corrupt data lines [1]; default 0.05.
    clock_jump_tol_s : float, optional
        Largest backward step of ``rpi_time_us`` in row order treated as a late row [s].

    Returns
    -------
    columns : dict of numpy.ndarray
        ``rpi_time_us`` (int64, sorted, unique), ``u_ms``, ``v_ms``, ``w_ms``, ``t_sonic_c``.
    counts : dict of int
        ``n_lines``, ``n_corrupt_lines``, ``n_blank_lines``, ``n_duplicates``,
        ``n_time_conflicts``, ``n_time_outliers``, ``n_out_of_order``.
    log : list of str
        Processing log lines.

    Raises
    ------
    InputError
        Missing file, wrong header, or more than `max_corrupt_fraction` corrupt lines.
    ClockJumpError
        A backward clock step larger than `clock_jump_tol_s`.
    """
    kinds = {"rpi_time_us": "int", "u_ms": "float", "v_ms": "float", "w_ms": "float",
             "t_sonic_c": "float"}  # fmt: skip
    table = _table(path, SONIC_COLUMNS, kinds, max_corrupt_fraction)
    _dedup_sort(table, list(SONIC_COLUMNS[1:]), clock_jump_tol_s)
    return table.columns, table.counts, table.log


def read_ins_csv(
    path: str | os.PathLike[str] | RawRecord,
    max_corrupt_fraction: float = 0.05,
    clock_jump_tol_s: float = 1.0,
) -> tuple[dict[str, np.ndarray], np.ndarray, dict[str, int], list[str]]:
    """Read an INS CSV, remove corrupt and duplicate rows and sort by logger time.

    Parameters
    ----------
    path : str, Path or RawRecord
        CSV with header ``rpi_time_us,utc,time_valid,ekf_valid,lat_deg,lon_deg,alt_m,``
        ``vel_n_ms,vel_e_ms,vel_d_ms,roll_deg,pitch_deg,yaw_deg``, or its in-memory record
        (:mod:`dronewind.core.raw`).
    max_corrupt_fraction : float, optional
        Largest tolerated fraction of corrupt data lines [1]; default 0.05.
    clock_jump_tol_s : float, optional
        Largest backward step of ``rpi_time_us`` in row order treated as a late row [s].

    Returns
    -------
    columns : dict of numpy.ndarray
        One array per column; ``utc`` is datetime64[ns] (NaT where empty), ``time_valid`` is
        forced to 0 where ``utc`` is empty.
    line_no : numpy.ndarray
        File line number of every kept row.
    counts : dict of int
        As :func:`read_sonic_csv`, plus ``n_time_valid_without_utc``.
    log : list of str
        Processing log lines.

    Raises
    ------
    InputError, ClockJumpError
        As :func:`read_sonic_csv`. A row with ``time_valid`` = 1 and an unparsable (not
        empty) ``utc`` is a corrupt line.
    """
    kinds = {c: "float" for c in INS_COLUMNS}
    kinds.update(rpi_time_us="int", utc="utc", time_valid="flag", ekf_valid="int")
    table = _table(path, INS_COLUMNS, kinds, max_corrupt_fraction)
    # time_valid = 1 with an empty utc field: GNSS time cannot be used on this row.
    no_utc = (table.columns["time_valid"] == 1) & np.isnat(table.columns["utc"])
    n_no_utc = int(no_utc.sum())
    table.columns["time_valid"] = np.where(no_utc, 0, table.columns["time_valid"])
    table.counts["n_time_valid_without_utc"] = n_no_utc
    if n_no_utc:
        table.log.append(f"parse: {n_no_utc} rows with time_valid=1 but empty utc treated as 0")
    value_cols = [c for c in INS_COLUMNS[1:] if c != "utc"]
    table.columns["_utc_i8"] = table.columns["utc"].astype(np.int64)
    _dedup_sort(table, [*value_cols, "_utc_i8"], clock_jump_tol_s)
    del table.columns["_utc_i8"]
    return table.columns, table.line_no, table.counts, table.log


# ---------------------------------------------------------------------------- clock fit


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


# --------------------------------------------------------------------------------- INS


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


@dataclass
class InsTable:
    """A parsed INS file from its stable valid GNSS time on, with the logger-clock fit.

    Attributes
    ----------
    columns : dict of numpy.ndarray
        INS columns (:data:`INS_COLUMNS`), rows sorted by logger time.
    line_no : numpy.ndarray
        File line number of every row.
    fit : ClockFit
        Logger clock to UTC.
    rpi_stable_us : int
        Logger time of the first row with a stable valid GNSS time [us].
    counts : dict of int
        ``n_*`` counts of the parsing.
    log : list of str
        Processing log lines.
    """

    columns: dict[str, np.ndarray]
    line_no: np.ndarray
    fit: ClockFit
    rpi_stable_us: int
    counts: dict[str, int]
    log: list[str]


def _load_ins(
    path: str | os.PathLike[str] | RawRecord,
    min_stable_s: float,
    clock_jump_tol_s: float,
    relation_jump_tol_s: float,
    max_corrupt_fraction: float,
) -> InsTable:
    cols, line_no, counts, log = read_ins_csv(path, max_corrupt_fraction, clock_jump_tol_s)
    t = cols["rpi_time_us"]
    start = _stable_valid_start(t, cols["time_valid"], min_stable_s)
    if start is None:
        raise InputError(
            path,
            f"no stable valid GNSS time: time_valid never stays 1 for >= {min_stable_s:g} s "
            "(Ghirardelli et al. 2025, Sect. 3.2: data before a stable valid GNSS time are discarded)",
        )
    counts["n_before_stable_time"] = int(start)
    log.append(
        f"gnss_time: stable valid GNSS time from line {int(line_no[start])} "
        f"(rpi_time_us={int(t[start])}); {start} earlier INS rows discarded"
    )
    # the rows from the stable start on: copies of the columns' ends (a gather of the same rows
    # by an index array would give the same arrays, at several times the cost)
    cols = {k: v[start:].copy() for k, v in cols.items()}
    line_no = line_no[start:].copy()
    t = cols["rpi_time_us"]
    fit_rows = np.flatnonzero((cols["time_valid"] == 1) & ~np.isnat(cols["utc"]))
    # Relation jumps: the offset utc - rpi_time, median-filtered over 11 rows so that a
    # single late stamp is not a jump, must not step by more than relation_jump_tol_s.
    off_s = (
        (cols["utc"][fit_rows] - cols["utc"][fit_rows[0]]).astype(np.int64) / 1e9
        - (t[fit_rows] - t[fit_rows[0]]) / _US
    )
    if off_s.size >= 3:
        w = min(11, off_s.size if off_s.size % 2 else off_s.size - 1)
        h = w // 2
        pad = np.concatenate([np.full(h, off_s[0]), off_s, np.full(h, off_s[-1])])
        smooth = bn.move_median(pad, window=w)[2 * h :]
        step = np.abs(np.diff(smooth))
        jumps = np.flatnonzero(step > relation_jump_tol_s)
        if jumps.size:
            j = int(fit_rows[jumps[0] + 1])
            raise ClockJumpError(
                f"{path}:{int(line_no[j])}",
                f"the relation utc - rpi_time steps by {step[jumps[0]]:.3f} s "
                f"(> {relation_jump_tol_s:g} s) near rpi_time_us={int(t[j])}: logger clock or "
                "GNSS time jump; not corrected, fix or split the flight",
            )
    # inside a forward flight's runs, an INS probe leaves the times alone: the fit is reused
    # (dronewind.core.reuse; a frozen dataclass)
    fit_t, fit_utc = t[fit_rows], cols["utc"][fit_rows]
    fit = reused("logger-clock fit", {"rpi_time_us": fit_t, "utc": fit_utc}, "",
                 lambda: fit_logger_clock(fit_t, fit_utc))
    log.append(
        f"clock_fit: utc = a + b*rpi_time on {fit.n_used} rows ({fit.n_outliers} outliers): "
        f"drift {fit.drift_ppm:.3f} ppm, residual std {fit.residual_std_s * 1e6:.2f} us"
    )
    return InsTable(cols, line_no, fit, int(t[0]), counts, log)


def load_ins_table(
    ins_path: str | os.PathLike[str] | RawRecord,
    min_stable_s: float = 10.0,
    clock_jump_tol_s: float = 1.0,
    relation_jump_tol_s: float = 0.1,
    max_corrupt_fraction: float = 0.05,
) -> InsTable:
    """Parse an INS file once: rows from the stable valid GNSS time and the logger-clock fit.

    Pass the result as ``ins_table`` to :func:`ins_l1` and :func:`payload_sonic_l1` so a
    flight's INS file is read once for both (it is the slowest file of a flight).
    Parameters are those of :func:`ins_l1`.
    """
    return _load_ins(ins_path, min_stable_s, clock_jump_tol_s, relation_jump_tol_s, max_corrupt_fraction)


def _fresh(table: InsTable) -> InsTable:
    """A copy whose counts and log can be extended without touching the original."""
    return InsTable(table.columns, table.line_no, table.fit, table.rpi_stable_us, dict(table.counts),
                     list(table.log))


def _utc_of_rows(ins: InsTable, counts: dict[str, int], log: list[str]) -> np.ndarray:
    """UTC of every INS row: the GNSS time, or the clock fit where it is not valid.

    Returns
    -------
    numpy.ndarray
        datetime64[ns] per row (rows after the stable start whose ``time_valid`` blinked to 0
        are stamped from the fit, whole microseconds; counted in ``n_time_from_clock_fit``).
    """
    cols = ins.columns
    utc = cols["utc"].copy()
    from_fit = (cols["time_valid"] != 1) | np.isnat(utc)
    utc[from_fit] = ins.fit.to_utc(cols["rpi_time_us"][from_fit], resolution_ns=1000)
    counts["n_time_from_clock_fit"] = int(from_fit.sum())
    if from_fit.any():
        log.append(f"gnss_time: {int(from_fit.sum())} rows after the stable start without "
                   "valid GNSS time stamped from the clock fit")  # fmt: skip
    return utc


def _increasing_utc(utc: np.ndarray, counts: dict[str, int], log: list[str]) -> tuple[np.ndarray, bool]:
    """Rows in UTC order with repeated UTC stamps dropped (a GNSS glitch): their indices, and
    whether those are all rows in their own order."""
    order = np.argsort(utc, kind="stable")
    n_utc_unsorted = int((order != np.arange(order.size)).sum())
    utc_sorted = utc[order]
    dup = np.zeros(order.size, dtype=bool)
    dup[1:] = utc_sorted[1:] == utc_sorted[:-1]
    counts["n_utc_duplicates"] = int(dup.sum())
    counts["n_utc_out_of_order"] = n_utc_unsorted
    if dup.any() or n_utc_unsorted:
        log.append(f"gnss_time: {int(dup.sum())} rows repeating a UTC stamp dropped, "
                   f"{n_utc_unsorted} rows re-ordered by UTC")  # fmt: skip
        return order[~dup], False
    return order, True


def _ins_qc(cols: dict[str, np.ndarray], fs_hz: float, despike: bool, counts: dict[str, int], log: list[str],
            path: str | os.PathLike[str] | RawRecord = "ins") -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Range, missing and (optional) spike flags of the INS; flagged rows set to NaN.

    A variable without a single valid value raises :class:`InputError` naming the file and
    the column (a flagged value flags its whole row, so later steps could not tell which
    column was empty).

    Parameters
    ----------
    cols : dict of numpy.ndarray
        INS columns (UTC order).
    fs_hz : float
        Nominal rate [Hz] (despiking window).
    despike : bool
        Apply the moving-MAD despiking to attitude, velocity and altitude.
    counts, log
        Receive ``n_out_of_range``, ``n_missing_values``, ``n_spikes``, ``n_flagged`` and
        the ``qc:`` line.

    Returns
    -------
    data : dict of numpy.ndarray
        Float INS variables, NaN where flagged.
    qc : numpy.ndarray
        int8 QC bitmask (:mod:`dronewind.core.qc`).
    """
    qc = np.zeros(cols["rpi_time_us"].size, dtype=np.int8)
    lim = INSTRUMENT_LIMITS["sbg_ellipse_d"]
    float_vars = {
        "roll_deg": lim["roll_deg"], "pitch_deg": lim["pitch_deg"], "yaw_deg": lim["yaw_deg"],
        "vel_n_ms": lim["vel_ms"], "vel_e_ms": lim["vel_ms"], "vel_d_ms": lim["vel_ms"],
        "lat_deg": lim["lat_deg"], "lon_deg": lim["lon_deg"], "alt_m": lim["alt_m"],
    }  # fmt: skip
    data: dict[str, np.ndarray] = {}
    n_range = n_nan = 0
    for name, (lo, hi) in float_vars.items():
        x = cols[name].astype(float)
        missing = ~np.isfinite(x)
        bad = range_mask(np.where(missing, np.nan, x), lo, hi)
        if (missing | bad).all():
            raise InputError(f"{path} [{name}]", f"column {name} holds no valid value in its {x.size} rows after the "
                             f"stable GNSS time ({int(missing.sum())} empty or NaN, {int(bad.sum())} outside "
                             f"[{lo:g}, {hi:g}]); expected the INS's {name}")
        n_range += int(bad.sum())
        n_nan += int(missing.sum())
        qc[bad] |= QC_OUT_OF_RANGE
        qc[missing] |= QC_MISSING
        data[name] = x
    n_spike = _despike_ins(data, qc, fs_hz) if despike else 0
    flagged = qc != 0
    for name in float_vars:
        data[name] = np.where(flagged, np.nan, data[name])
    counts["n_out_of_range"] = n_range
    counts["n_missing_values"] = n_nan
    counts["n_spikes"] = n_spike
    counts["n_flagged"] = int(flagged.sum())
    log.append(
        f"qc: {n_range} values out of range (SBG Ellipse-D limits), {n_nan} NaN values, "
        f"{n_spike} spikes{'' if despike else ' (despiking off)'}; {int(flagged.sum())} rows "
        "flagged and set to NaN"
    )
    return data, qc


def _despike_ins(data: dict[str, np.ndarray], qc: np.ndarray, fs_hz: float) -> int:
    """Moving-MAD spike flags (QC_SPIKE, set in ``qc``) of attitude, velocity, altitude and unwrapped yaw.

    Returns
    -------
    int
        Number of spike flags set (a sample may count once per variable).
    """
    n_spike = 0
    for name in ("roll_deg", "pitch_deg", "vel_n_ms", "vel_e_ms", "vel_d_ms", "alt_m"):
        x = np.where(qc == 0, data[name], np.nan)
        s = despike_moving_mad(x, fs_hz)
        qc[s] |= QC_SPIKE
        n_spike += int(s.sum())
    yaw_unwrapped = rad2deg(unwrap_rad(deg2rad(np.nan_to_num(data["yaw_deg"]))))
    s = despike_moving_mad(np.where(qc == 0, yaw_unwrapped, np.nan), fs_hz)
    qc[s] |= QC_SPIKE
    n_spike += int(s.sum())
    return n_spike


def _yaw_convention(yaw_deg: np.ndarray) -> str:
    """The range convention of the logged yaw, from its finite values."""
    yaw = yaw_deg[np.isfinite(yaw_deg)]
    if yaw.size and yaw.min() < 0:
        return "(-180, 180]"
    if yaw.size and yaw.max() > 180:
        return "[0, 360)"
    return "ambiguous: all values in [0, 180]"


def _ins_dataset(data: dict[str, np.ndarray], cols: dict[str, np.ndarray], qc: np.ndarray, utc: np.ndarray,
                 rpi_time_us: np.ndarray) -> xr.Dataset:
    """The INS L1 variables on ``time`` (see :func:`ins_l1`, Returns)."""
    yaw_conv = _yaw_convention(data["yaw_deg"])
    return xr.Dataset(
        {
            "roll_deg": ("time", data["roll_deg"], variable_attrs("degree", "platform_roll")),
            "pitch_deg": ("time", data["pitch_deg"], variable_attrs("degree", "platform_pitch")),
            "yaw_deg": ("time", data["yaw_deg"], variable_attrs(
                "degree", "platform_yaw", comment=f"clockwise from true north, as logged "
                f"(range {yaw_conv}); wrap not removed")),
            "vel_n_ms": ("time", data["vel_n_ms"], variable_attrs(
                "m s-1", long_name="northward velocity of the sonic measurement volume")),
            "vel_e_ms": ("time", data["vel_e_ms"], variable_attrs(
                "m s-1", long_name="eastward velocity of the sonic measurement volume")),
            "vel_d_ms": ("time", data["vel_d_ms"], variable_attrs(
                "m s-1", long_name="downward velocity of the sonic measurement volume")),
            "lat_deg": ("time", data["lat_deg"], variable_attrs("degrees_north", "latitude")),
            "lon_deg": ("time", data["lon_deg"], variable_attrs("degrees_east", "longitude")),
            "alt_m": ("time", data["alt_m"], variable_attrs(
                "m", "altitude", positive="up", comment="above mean sea level")),
            "ekf_valid": ("time", cols["ekf_valid"].astype(np.int32), variable_attrs(
                "1", long_name="INS extended Kalman filter solution valid (1) or not (0)")),
            "time_valid": ("time", cols["time_valid"].astype(np.int8), variable_attrs(
                "1", long_name="GNSS UTC valid (1) or not (0); 0 rows are stamped from the "
                "clock fit")),
            "rpi_time_us": ("time", rpi_time_us.astype(np.int64), variable_attrs(
                "us", long_name="logger (Raspberry Pi) clock time stamp")),
            "qc_ins": ("time", qc, qc_flag_attrs("INS quality control bitmask")),
        },
        coords={"time": ("time", utc.astype("datetime64[ns]"), {"long_name": "time (UTC)"})},
    )


def ins_l1(
    ins_path: str | os.PathLike[str] | RawRecord, min_stable_s: float = 10.0, clock_jump_tol_s: float = 1.0,
    relation_jump_tol_s: float = 0.1, max_corrupt_fraction: float = 0.05, despike: bool = False,
    ins_table: InsTable | None = None,
) -> xr.Dataset:
    """Build the L1 INS dataset (UTC time from the ``utc`` column, QC flags).

    Parameters
    ----------
    ins_path : str, Path or RawRecord
        INS CSV (DESIGN.md "INS file") or its in-memory record.
    min_stable_s : float, optional
        A stable valid GNSS time starts at the first row from which ``time_valid`` stays 1
        for at least this long [s]; default 10 s. Earlier rows are discarded (counted in
        ``n_before_stable_time``).
    clock_jump_tol_s : float, optional
        Backward step of ``rpi_time_us`` in row order above which :class:`ClockJumpError`
        is raised [s]; smaller steps are sorted.
    relation_jump_tol_s : float, optional
        Step of ``utc - rpi_time`` above which :class:`ClockJumpError` is raised [s].
    max_corrupt_fraction : float, optional
        Largest tolerated fraction of corrupt lines [1].
    despike : bool, optional
        Apply :func:`dronewind.core.filtering.despike_moving_mad` to attitude, velocity and
        altitude. Off by default: the EKF output is smooth, so in a steady hover its MAD is
        tiny and ordinary manoeuvres would be flagged as spikes.
    ins_table : InsTable, optional
        Output of :func:`load_ins_table` for ``ins_path`` (not parsed again).

    Returns
    -------
    xarray.Dataset
        dim ``time`` (UTC, datetime64[ns]); ``roll_deg``, ``pitch_deg``, ``yaw_deg`` (as
        logged, wrap not removed), ``vel_n_ms``, ``vel_e_ms``, ``vel_d_ms``, ``lat_deg``,
        ``lon_deg``, ``alt_m``, ``ekf_valid``, ``time_valid``, ``rpi_time_us``, ``qc_ins``.
        Rows after the stable start whose ``time_valid`` blinked to 0 get their time from
        the clock fit (``n_time_from_clock_fit``). attrs: ``n_*`` counts, clock fit
        (``clock_drift_ppm``, ``clock_residual_std_s``, ...), ``sampling_rate_hz``,
        ``processing_log``.

    Raises
    ------
    InputError
        Bad header, too many corrupt lines, or no stable valid GNSS time.
    ClockJumpError
        Logger clock or GNSS time jump.

    References
    ----------
    Ghirardelli et al. (2025), Sect. 3.2.
    """
    ins = _fresh(ins_table) if ins_table is not None else _load_ins(
        ins_path, min_stable_s, clock_jump_tol_s, relation_jump_tol_s, max_corrupt_fraction)
    counts, log = ins.counts, ins.log
    t_rpi = ins.columns["rpi_time_us"]
    utc = _utc_of_rows(ins, counts, log)
    sel, in_order = _increasing_utc(utc, counts, log)
    # rows already in UTC order, none dropped (the usual case), are copied without the gather
    cols = {k: v.copy() if in_order else v[sel] for k, v in ins.columns.items()}
    ins_steps = np.diff(t_rpi[sel])
    counts["n_gaps_over_1s"] = int((ins_steps > _US).sum())
    if counts["n_gaps_over_1s"]:
        log.append(f"gaps: {counts['n_gaps_over_1s']} INS gaps > 1 s (not filled; longest "
                   f"{ins_steps.max() / _US:.2f} s)")  # fmt: skip
    fs_hz = _nominal_rate(t_rpi)
    data, qc = _ins_qc(cols, fs_hz, despike, counts, log, ins_path)
    ds = _ins_dataset(data, cols, qc, utc[sel], t_rpi[sel])
    _finish_attrs(ds, counts, log, ins.fit, fs_hz, str(ins_path), t_rpi[sel])
    return ds


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


# ------------------------------------------------------------------------------- sonic


def _insert_missing(rpi_time_us: np.ndarray, gap_factor: float = 1.5
                    ) -> tuple[np.ndarray, np.ndarray, int, list[tuple[int, float]]]:  # fmt: skip
    """Insert evenly spaced missing samples into gaps longer than gap_factor median steps.

    Returns new times, index of the source row (-1 for inserted), number inserted, and
    the (time, length [s]) of gaps longer than 1 s.
    """
    t = rpi_time_us
    n = t.size
    if n < 3:
        return t.copy(), np.arange(n), 0, []
    d = np.diff(t)
    dt = median_of_steps(d)
    m = np.where(d > gap_factor * dt, np.rint(d / dt).astype(np.int64) - 1, 0)
    m = np.maximum(m, 0)
    total_missing = int(m.sum())
    long_gaps = [(int(t[i]), d[i] / _US) for i in np.flatnonzero(d > _US)]
    if total_missing == 0:
        return t.copy(), np.arange(n), 0, long_gaps
    rep = np.concatenate([m, [0]]) + 1
    src = np.repeat(np.arange(n), rep)
    first = np.repeat(np.cumsum(rep) - rep, rep)
    j = np.arange(src.size) - first
    step = np.concatenate([d / (m + 1), [0.0]])
    new_t = t[src] + np.rint(j * step[src]).astype(np.int64)
    src_idx = np.where(j == 0, src, -1)
    return new_t, src_idx, total_missing, long_gaps


def _after_stable_time(cols: dict[str, np.ndarray], rpi_stable_us: int, sonic_path: str | os.PathLike[str] | RawRecord,
                       counts: dict[str, int], log: list[str]) -> dict[str, np.ndarray]:
    """Sonic rows from the INS's stable valid GNSS time on (earlier rows discarded and counted)."""
    t = cols["rpi_time_us"]
    before = t < rpi_stable_us
    n_before = int(before.sum())
    if n_before == t.size:
        raise InputError(sonic_path, f"all {t.size} sonic rows precede the INS's stable valid GNSS time: the sonic's "
                         f"logger time ends {(rpi_stable_us - int(t.max())) / _US:.1f} s before it (rpi_time_us "
                         f"{int(t.max())} < {rpi_stable_us}); expected sonic rows after it (the sonic and INS files "
                         "of one flight, logging together)")
    cols = {k: v[~before] for k, v in cols.items()}
    counts["n_before_stable_time"] = n_before
    log.append(f"gnss_time: {n_before} sonic rows before the INS's stable GNSS time discarded")
    return cols


def _sonic_on_full_clock(cols: dict[str, np.ndarray], sonic_path: str | os.PathLike[str] | RawRecord, max_gap_s: float,
                         counts: dict[str, int], log: list[str],
                         ) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """The sonic with its logger-time gaps filled by missing samples.

    A forward step longer than ``max_gap_s`` [s] raises :class:`ClockJumpError`.

    Returns
    -------
    t_full : numpy.ndarray
        Logger times with the inserted samples [us].
    vals : dict of numpy.ndarray
        ``u_ms``, ``v_ms``, ``w_ms``, ``t_sonic_c``, NaN at inserted samples.
    have : numpy.ndarray
        True for logged (not inserted) samples.
    """
    steps = np.diff(cols["rpi_time_us"])
    if steps.size and steps.max() > max_gap_s * _US:
        i = int(np.argmax(steps))
        raise ClockJumpError(
            f"{sonic_path}", f"rpi_time_us steps forward by {steps[i] / _US:.1f} s "
            f"(> max_gap_s = {max_gap_s:g} s) after rpi_time_us={int(cols['rpi_time_us'][i])}: "
            "not a plausible data gap; clock jump or corrupt time stamps",
        )
    t_full, src, n_missing, long_gaps = _insert_missing(cols["rpi_time_us"])
    counts["n_missing"] = n_missing
    counts["n_gaps_over_1s"] = len(long_gaps)
    msg = f"gaps: {n_missing} missing samples inserted as NaN"
    if long_gaps:
        msg += "; gaps > 1 s (logger clock continuous per INS, so data gaps) at rpi_time_us " + \
            ", ".join(f"{tt} ({g:.2f} s)" for tt, g in long_gaps[:_N_LOGGED_LINES])  # fmt: skip
    log.append(msg)
    have = src >= 0
    vals = {}
    for name in ("u_ms", "v_ms", "w_ms", "t_sonic_c"):
        x = np.full(t_full.size, np.nan)
        x[have] = cols[name][src[have]]
        vals[name] = x
    return t_full, vals, have


def _sonic_qc(vals: dict[str, np.ndarray], have: np.ndarray, fs_hz: float, apply_elevation_limit: bool,
              despike_window_s: float, despike_n_mad: float, counts: dict[str, int], log: list[str],
              source: str | os.PathLike[str] | RawRecord = "sonic") -> np.ndarray:
    """Missing, range (RM Young 81000) and spike flags of the sonic; flagged samples set to NaN in ``vals``.

    A column without a single valid value raises :class:`InputError` naming the file and
    the column (a flag on one variable sets the whole sample to NaN, so later steps could
    not tell which column was empty).

    Parameters
    ----------
    vals : dict of numpy.ndarray
        ``u_ms``, ``v_ms``, ``w_ms`` [m s-1], ``t_sonic_c`` [degC]; modified in place.
    have : numpy.ndarray
        Logged (not inserted) samples.
    fs_hz : float
        Nominal rate [Hz].
    apply_elevation_limit : bool
        Also flag elevation angles beyond +/-60 deg.
    despike_window_s, despike_n_mad : float
        Moving-MAD window [s] and threshold [scaled MAD].
    counts, log
        Receive ``n_out_of_range``, ``n_missing_values``, ``n_spikes``, ``n_flagged`` and
        the ``qc:`` line.

    Returns
    -------
    numpy.ndarray
        int8 QC bitmask (:mod:`dronewind.core.qc`).
    """
    n = have.size
    empty = [name for name in ("u_ms", "v_ms", "w_ms", "t_sonic_c") if not np.isfinite(vals[name][have]).any()]
    if empty:
        raise InputError(f"{source} [{', '.join(empty)}]", f"column(s) {', '.join(empty)} hold no valid value in the "
                         f"{int(have.sum())} sonic rows after the INS's stable GNSS time; expected numbers in m s-1 "
                         "(speeds) and degC (temperature)")
    qc = np.zeros(n, dtype=np.int8)
    missing = ~(np.isfinite(vals["u_ms"]) & np.isfinite(vals["v_ms"])
                & np.isfinite(vals["w_ms"]) & np.isfinite(vals["t_sonic_c"]))  # fmt: skip
    qc[missing] |= QC_MISSING
    n_nan_values = int((missing & have).sum())
    lim = INSTRUMENT_LIMITS["rmyoung_81000"]
    with np.errstate(invalid="ignore"):
        speed = np.sqrt(vals["u_ms"] ** 2 + vals["v_ms"] ** 2 + vals["w_ms"] ** 2)
        out = range_mask(speed, *lim["speed_ms"]) | range_mask(vals["t_sonic_c"],
                                                               *lim["t_sonic_c"])  # fmt: skip
        if apply_elevation_limit:
            elev = rad2deg(np.arctan2(vals["w_ms"], np.hypot(vals["u_ms"], vals["v_ms"])))
            out |= range_mask(elev, *lim["elevation_deg"])
    qc[out] |= QC_OUT_OF_RANGE
    n_logged = max(int(have.sum()), 1)
    if out.sum() > 0.5 * n_logged:
        raise InputError(f"{source} [u_ms, v_ms, w_ms, t_sonic_c]",
                         f"{int(out.sum())} of {n_logged} sonic samples ({100 * out.sum() / n_logged:.0f} %) beyond "
                         f"the RM Young 81000 range (|V| <= {lim['speed_ms'][1]:g} m/s, {lim['t_sonic_c'][0]:g}.."
                         f"{lim['t_sonic_c'][1]:g} degC; median |V| {np.nanmedian(speed):.3g}): expected m s-1 and "
                         "degC, not another unit (cm/s, km/h, K)")
    spikes = np.zeros(n, dtype=bool)
    for name in ("u_ms", "v_ms", "w_ms", "t_sonic_c"):
        x = np.where(qc == 0, vals[name], np.nan)
        spikes |= despike_moving_mad(x, fs_hz, despike_window_s, despike_n_mad)
    qc[spikes] |= QC_SPIKE
    flagged = qc != 0
    for name in vals:
        vals[name] = np.where(flagged, np.nan, vals[name])
    counts["n_out_of_range"] = int(out.sum())
    counts["n_missing_values"] = n_nan_values
    counts["n_spikes"] = int(spikes.sum())
    counts["n_flagged"] = int(flagged.sum())
    log.append(
        f"qc: {int(out.sum())} samples out of range (RM Young 81000: |V| <= 40 m/s, "
        f"-50..50 degC), {n_nan_values} NaN values, {int(spikes.sum())} spikes (moving MAD, "
        f"{despike_window_s:g} s, {despike_n_mad:g} scaled MAD); {int(flagged.sum())} of "
        f"{n} samples flagged and set to NaN"
    )
    return qc


def _count_extrapolated(t_full: np.ndarray, fit: ClockFit, counts: dict[str, int], log: list[str]) -> None:
    """Count the sonic samples outside the span of the clock fit (their UTC is extrapolated)."""
    outside = (t_full < fit.rpi_first_us) | (t_full > fit.rpi_last_us)
    counts["n_time_extrapolated"] = int(outside.sum())
    if outside.any():
        log.append(f"clock_fit: {int(outside.sum())} sonic samples outside the INS time span, "
                   "UTC extrapolated from the fit")  # fmt: skip


def _sonic_dataset(vals: dict[str, np.ndarray], qc: np.ndarray, t_full: np.ndarray, time: np.ndarray) -> xr.Dataset:
    """The payload sonic L1 variables on ``time`` (see :func:`payload_sonic_l1`, Returns)."""
    return xr.Dataset(
        {
            "u_sensor_ms": ("time", vals["u_ms"], variable_attrs(
                "m s-1", long_name="air velocity along sensor x axis (sensor frame, as logged)")),
            "v_sensor_ms": ("time", vals["v_ms"], variable_attrs(
                "m s-1", long_name="air velocity along sensor y axis (sensor frame, as logged)")),
            "w_sensor_ms": ("time", vals["w_ms"], variable_attrs(
                "m s-1", long_name="air velocity along sensor z axis (sensor frame, as logged)")),
            "t_sonic_k": ("time", vals["t_sonic_c"] + ZERO_CELSIUS_K, variable_attrs(
                "K", "virtual_temperature", comment="sonic temperature (approximately the "
                "virtual temperature)", units_metadata="temperature: on_scale")),
            "rpi_time_us": ("time", t_full.astype(np.int64), variable_attrs(
                "us", long_name="logger (Raspberry Pi) clock time stamp; inserted missing "
                "samples are interpolated")),
            "qc_sonic": ("time", qc, qc_flag_attrs("payload sonic quality control bitmask")),
        },
        coords={"time": ("time", time, {"long_name": "time (UTC, from the logger clock "
                                                    "through the INS clock fit)"})},  # fmt: skip
    )


def payload_sonic_l1(
    sonic_path: str | os.PathLike[str] | RawRecord, ins_path: str | os.PathLike[str] | RawRecord,
    min_stable_s: float = 10.0,
    clock_jump_tol_s: float = 1.0, relation_jump_tol_s: float = 0.1, max_corrupt_fraction: float = 0.05,
    despike_window_s: float = 10.0, despike_n_mad: float = 7.0, apply_elevation_limit: bool = False,
    max_gap_s: float = 60.0, ins_table: InsTable | None = None,
) -> xr.Dataset:
    """Build the L1 payload sonic dataset: logger clock to UTC, range/spike/missing QC.

    Parameters
    ----------
    sonic_path : str, Path or RawRecord
        Sonic CSV (DESIGN.md "Payload sonic file") or its in-memory record.
    ins_path : str, Path or RawRecord
        INS CSV of the same flight (shares the logger clock) or its in-memory record.
    min_stable_s, clock_jump_tol_s, relation_jump_tol_s, max_corrupt_fraction : float
        As :func:`ins_l1`; `clock_jump_tol_s` applies to the sonic file too.
    despike_window_s : float, optional
        Moving-MAD window [s]; default 10 s.
    despike_n_mad : float, optional
        Moving-MAD threshold [scaled MAD]; default 7.
    apply_elevation_limit : bool, optional
        Also flag samples whose elevation angle exceeds the RM Young 81000's +/-60 deg.
    max_gap_s : float, optional
        Longest forward step of the sonic's logger time accepted as a data gap [s]; a
        longer one raises :class:`ClockJumpError` (default 60 s).
    ins_table : InsTable, optional
        Output of :func:`load_ins_table` for ``ins_path`` (not parsed again).

    Returns
    -------
    xarray.Dataset
        dim ``time`` (UTC from the clock fit); ``u_sensor_ms``, ``v_sensor_ms``,
        ``w_sensor_ms`` (sensor frame as logged), ``t_sonic_k``, ``rpi_time_us``,
        ``qc_sonic`` (1 out of range, 2 spike, 4 missing/corrupt). A flag on a sample sets
        all four variables of that sample to NaN (not filled). Gaps in the logger time are
        filled with missing samples (``n_missing``). Sonic rows logged before the INS's
        stable GNSS time are discarded (``n_before_stable_time``); rows outside the span
        of the clock fit are extrapolated and counted (``n_time_extrapolated``).

    Raises
    ------
    InputError, ClockJumpError
        See the module docstring.

    Notes
    -----
    Range limits: RM Young 81000 (Ghirardelli et al. 2025, Table 2) speed
    :math:`\\sqrt{u^2+v^2+w^2} \\le 40` m/s, sonic temperature -50..50 degC. Each of u, v,
    w and T is despiked separately (:func:`dronewind.core.filtering.despike_moving_mad`) after
    range-flagged and missing samples are removed; a spike in any flags the sample.

    References
    ----------
    Ghirardelli et al. (2025), Sect. 3.2.
    """
    ins = _fresh(ins_table) if ins_table is not None else _load_ins(
        ins_path, min_stable_s, clock_jump_tol_s, relation_jump_tol_s, max_corrupt_fraction)
    cols, counts, log = read_sonic_csv(sonic_path, max_corrupt_fraction, clock_jump_tol_s)
    cols = _after_stable_time(cols, ins.rpi_stable_us, sonic_path, counts, log)
    t_full, vals, have = _sonic_on_full_clock(cols, sonic_path, max_gap_s, counts, log)
    fs_hz = _nominal_rate(t_full)
    qc = _sonic_qc(vals, have, fs_hz, apply_elevation_limit, despike_window_s, despike_n_mad, counts, log,
                   sonic_path)
    _count_extrapolated(t_full, ins.fit, counts, log)
    log = [*log, *(f"ins {line}" for line in ins.log)]
    counts["n_ins_before_stable_time"] = ins.counts["n_before_stable_time"]
    time = ins.fit.to_utc(t_full, resolution_ns=1000)  # 1 us: far below the fit's scatter
    ds = _sonic_dataset(vals, qc, t_full, time)
    _finish_attrs(ds, counts, log, ins.fit, fs_hz, str(sonic_path), t_full)
    ds.attrs["ins_source_file"] = str(ins_path)
    return ds
