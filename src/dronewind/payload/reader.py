"""Reader of the SAMURAI-S-type payload's L0 files (sonic CSV, INS CSV) with its fault handling.

L0 formats (``docs/data-contract.md``, "Payload sonic file" and "INS file")::

    rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c
    rpi_time_us,utc,time_valid,ekf_valid,lat_deg,lon_deg,alt_m,vel_n_ms,vel_e_ms,vel_d_ms,roll_deg,pitch_deg,yaw_deg

Both files are stamped by the logger's clock (``rpi_time_us``, not UTC). The INS also logs
GNSS UTC, so the logger clock is converted to UTC by a robust straight-line fit
``utc = a + b * rpi_time`` over the INS rows with a stable valid GNSS time (Ghirardelli et al. 2025,
Sect. 3.2), which is then applied to the sonic (:mod:`dronewind.payload.clock`; the L1 datasets are
made in :mod:`dronewind.payload.ins` and :mod:`dronewind.payload.sonic`).

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

import numpy as np
import pandas as pd

from dronewind.core import textscan
from dronewind.core.columns import INS_COLUMNS, SONIC_COLUMNS
from dronewind.core.raw import RawRecord
from dronewind.errors import InputError, describe_header

__all__ = [
    "ClockJumpError",
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


def _rows(path: str | os.PathLike[str], expected: tuple[str, ...], kinds: dict[str, str]) -> _Rows:
    """Split and parse the data lines of a fixed-header CSV: the parser of the payload CSVs.

    The regular lines (printable ASCII without spaces or quotes, one field per column,
    numbers of at most :data:`~dronewind.core.textscan.FLOAT_FAST_MAX_CHARS` characters
    without exponent, time stamps of the fixed ISO 8601 form) are found and converted in
    bulk by a byte-level scan; every other line goes, with its line number, to the
    line-by-line fault handling (:func:`_irregular_rows`), and the rows of both are put
    back in line order.

    The scan is written by hand because the result must be that of the line-by-line
    parse bit for bit (line numbers, blank and corrupt lines, NaN literals, corrupt fields
    per column, float rounding: :mod:`dronewind.core.textscan`), which no single
    ``pandas.read_csv`` call gives, while converting every line one by one costs most of
    a long record's parse (an INS record of 400,000 rows, 47 MB: 0.6 s of CPU by the scan,
    3.8 s line by line).

    Raises
    ------
    InputError
        Missing or empty file, a header other than `expected` (line 1), no data lines.
    """
    header, raw, buf, starts, ends, unusual = textscan.text_body(_read_text(path), 1)
    if not header:
        raise InputError(path, f"empty file; expected header {','.join(expected)!r}")
    got = tuple(h.strip() for h in header[0].split(","))
    if got != expected:
        raise InputError(f"{path}:1", describe_header(got, expected))
    ncol, n = len(expected), int(starts.size)
    blank = ends == starts
    candidate = ~blank & ~textscan.lines_holding(raw, buf, starts, textscan.PLAIN_CSV, unusual) \
        & ~textscan.lines_with(raw, buf, starts, b"eE")  # fmt: skip
    commas = np.flatnonzero(buf == ord(","))
    rows, cpos, _ = textscan.comma_grid(commas, starts, ends, candidate, ncol)
    fields: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    provable = np.ones(rows.size, dtype=bool)
    if rows.size:
        scanned = np.zeros(n, dtype=bool)
        scanned[rows] = True
        plain = textscan.kept_lines(raw, starts, scanned)
        numeric = [c for c in expected if kinds[c] != "utc"]
        frame = textscan.read_numeric_columns(plain, list(expected), numeric,
                                              {c: textscan.NAN_LITERALS for c in numeric if kinds[c] == "float"},
                                              quoting=False)  # fmt: skip
        for j, name in enumerate(expected):
            fstart = starts[rows] if j == 0 else cpos[:, j - 1] + 1
            fend = cpos[:, j] if j < ncol - 1 else ends[rows]
            fields[name] = _regular_field(frame[name] if name in frame else None, kinds[name], buf, fstart, fend)
            provable &= fields[name][1]
    regular = np.zeros(n, dtype=bool)
    regular[rows[provable]] = True
    irregular = np.flatnonzero(~regular & ~blank)
    text = textscan.line_text(raw, starts, ends, irregular)
    more_blank = np.fromiter((not ln.strip() for ln in text), dtype=bool, count=len(text))
    blank[irregular[more_blank]] = True
    irregular = irregular[~more_blank]
    good_count, cols, bad, per_column = _irregular_rows([t for t, b in zip(text, more_blank, strict=True) if not b],
                                                        expected, kinds)
    if not (~blank).any():
        raise InputError(path, "no data lines after the header")
    # the rows of both in line order: the regular lines and the irregular ones with the expected field count
    nonblank = np.flatnonzero(~blank)
    count_ok = regular.copy()
    count_ok[irregular[good_count]] = True
    good_lines = np.flatnonzero(count_ok)
    from_lines = np.isin(good_lines, irregular)
    merged: dict[str, np.ndarray] = {}
    for name in expected:
        if from_lines.all():
            merged[name] = cols[name]
        elif not from_lines.any():
            merged[name] = fields[name][0][provable]
        else:
            merged[name] = np.empty(good_lines.size, dtype=fields[name][0].dtype)
            merged[name][~from_lines] = fields[name][0][provable]
            merged[name][from_lines] = cols[name]
    all_bad = np.zeros(good_lines.size, dtype=bool)
    all_bad[from_lines] = bad
    regular_bad = np.zeros(int(provable.sum()), dtype=bool)
    for name in expected:
        if kinds[name] == "flag" and rows.size:
            flag_bad = fields[name][2][provable]
            regular_bad |= flag_bad
            if flag_bad.any():
                per_column[name] = per_column.get(name, 0) + int(flag_bad.sum())
    all_bad[~from_lines] = regular_bad
    return _Rows(np.arange(2, n + 2)[nonblank], int(blank.sum()), count_ok[nonblank], merged, all_bad,
                 dict(sorted(per_column.items(), key=lambda kv: expected.index(kv[0]))))


def _irregular_rows(lines: list[str], expected: tuple[str, ...], kinds: dict[str, str],
                    ) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray, dict[str, int]]:
    """The fault handling of the lines the scan of :func:`_rows` leaves: split and parsed one by one.

    Parameters
    ----------
    lines : list of str
        Non-blank data lines.
    expected, kinds
        As :func:`_parse_csv`.

    Returns
    -------
    good_count : numpy.ndarray
        True for the lines with the expected number of fields.
    cols : dict of numpy.ndarray
        Values of those lines, per column.
    bad : numpy.ndarray
        True for those lines with a corrupt field.
    per_column : dict of int
        Corrupt fields per column (columns without any left out).
    """
    split = [ln.split(",") for ln in lines]
    good_count = np.fromiter((len(f) == len(expected) for f in split), dtype=bool, count=len(lines))
    cols, bad, per_column = _parse_rows([f for f, g in zip(split, good_count, strict=True) if g], expected, kinds)
    return good_count, cols, bad, per_column


def _regular_field(values: pd.Series | None, kind: str, buf: np.ndarray, start: np.ndarray, end: np.ndarray,
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Values of one column of the scanned lines, where they are :func:`_parse_field`'s, and its corrupt flags.

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

    Returns
    -------
    values : numpy.ndarray
        int64, float64 or datetime64[ns].
    ok : numpy.ndarray
        True where the value is proven to be the line-by-line parse's (the other lines go
        to :func:`_irregular_rows`).
    bad : numpy.ndarray
        A ``flag`` other than 0 or 1 (a corrupt field of a regular line).
    """
    n = start.size
    no = np.zeros(n, dtype=bool)
    if kind == "utc":
        length = end - start
        times, ok = textscan.fixed_width_times(buf, start, length, sep=b"T", suffix=b"Z")
        return times, ok | (length == 0), no
    assert values is not None
    if kind in ("int", "flag"):
        if values.dtype == np.int64:
            vals, ok = values.to_numpy(dtype=np.int64), np.ones(n, dtype=bool)
        else:
            vals, ok = textscan.int_fields(buf, start, end)
        return vals, ok, (~((vals == 0) | (vals == 1)) if kind == "flag" else no)
    fvals, ok = textscan.float_fields(values, end - start)
    return fvals, ok, no


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
    The lines are split and parsed by :func:`_rows`.
    """
    parsed = _rows(path, expected, kinds)
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
    hashing at a fifth of its cost for an INS record (0.8 against 3.9 ms for 94,000 rows);
    a forward run reads its INS and sonic
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
