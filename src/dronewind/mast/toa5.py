r"""Campbell Scientific TOA5 reader for CSAT3 mast sonics, with its fault handling.

TOA5 (``docs/data-contract.md``, "Mast sonic file"): four header lines (environment, field names, units,
processing), then quoted-timestamp CSV rows with at least
``TIMESTAMP, RECORD, Ux, Uy, Uz, Ts, diag_csat``. Handled details:

* TIMESTAMP ``YYYY-MM-DD HH:MM:SS[.f]`` (UTC): Campbell drops trailing zeros of the
  fraction (``12:45:00.1``, ``12:45:01``), parsed as ISO 8601;
* ``"NAN"`` values -> NaN, flagged missing (QC 4);
* non-zero ``diag_csat`` -> flagged (QC 16) and the sample set to NaN;
* RECORD skips are counted (``n_record_skips``), as are RECORD restarts;
* several files are concatenated in time order, duplicated time stamps dropped and the
  record put on its regular grid by :mod:`dronewind.mast.level1`;
* a changed header (required column missing) -> :class:`~dronewind.errors.InputError` naming
  the file and the column; a row whose TIMESTAMP or RECORD cannot be parsed is corrupt
  (counted; more than 5 % corrupt -> InputError);
* a row cut short (even inside its quoted TIMESTAMP), NUL bytes or binary garbage make
  their own lines corrupt and nothing more: lines are split one by one
  (:mod:`dronewind.core.rowfaults`), at ``\n``, ``\r\n`` or ``\r`` only;
* of several files, one that cannot be read is left out of the record, counted
  (``n_unreadable_files``) and named with its error in the log (:func:`unreadable_files`).

The QC bitmask ``qc_mast`` is set by :mod:`dronewind.mast.level1`.
"""

from __future__ import annotations

import glob
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.core import textscan
from dronewind.core.raw import RawRecord
from dronewind.core.rowfaults import split_csv_line, split_csv_lines, text_lines
from dronewind.errors import InputError
from dronewind.mast.columns import REQUIRED_TOA5_COLUMNS

__all__ = [
    "UNREADABLE_PREFIX",
    "read_toa5",
    "unreadable_files",
]


_N_LOGGED = 5
#: Start of a processing-log line naming a file of a record that could not be read, and why.
UNREADABLE_PREFIX = "unreadable file left out: "
_TIMESTAMP_RE = re.compile(r"\d{4}-\d{2}-\d{2}[ T]\d{1,2}:\d{2}")


TOA5Source = str | os.PathLike[str] | RawRecord
"""A TOA5 file (path or glob pattern) or its in-memory record (:mod:`dronewind.core.raw`)."""


def unreadable_files(ds: xr.Dataset) -> list[str]:
    """The files of a mast record left out because they could not be read, each with its error.

    Parameters
    ----------
    ds : xarray.Dataset
        A mast L1 (its ``processing_log``).

    Returns
    -------
    list of str
        ``"<file>:<line>: <what>"`` per file left out (empty when every file was read).
    """
    return [ln[len(UNREADABLE_PREFIX):] for ln in str(ds.attrs.get("processing_log", "")).split("\n")
            if ln.startswith(UNREADABLE_PREFIX)]


def _expand_paths(paths: TOA5Source | Sequence[TOA5Source]) -> list[Path | RawRecord]:
    items = [paths] if isinstance(paths, (str, os.PathLike, RawRecord)) else list(paths)
    out: list[Path | RawRecord] = []
    for item in items:
        if isinstance(item, RawRecord):
            out.append(item)
            continue
        s = str(item)
        if any(ch in s for ch in "*?[") and not Path(s).exists():
            matches = sorted(glob.glob(s))
            if not matches:
                raise InputError(s, "glob pattern matches no file")
            out.extend(Path(m) for m in matches)
        else:
            out.append(Path(s))
    if not out:
        raise InputError("paths", "no TOA5 file given")
    return out


def _read_header(p: Path, required: Sequence[str]) -> tuple[list[str], list[list[str]], list[str], dict[str, str]]:
    """Lines of a TOA5 file and its checked header.

    Returns
    -------
    lines : list of str
        All lines.
    header : list of list of str
        The four header lines, split.
    names : list of str
        Field names (line 2).
    units : dict
        Field name -> unit (line 3).
    """
    if not p.is_file():
        raise InputError(p, "file not found")
    lines = text_lines(p.read_bytes())
    if len(lines) < 4:
        raise InputError(p, f"only {len(lines)} lines; a TOA5 file has 4 header lines")
    header, names, units = _check_header(p, lines[:4], required)
    return lines, header, names, units


def _check_header(p: Path, head: list[str], required: Sequence[str],
                  ) -> tuple[list[list[str]], list[str], dict[str, str]]:
    """Split and check the four header lines `head` (see :func:`_read_header`)."""
    header = [split_csv_line(ln) or [] for ln in head]
    if not header[0] or header[0][0] != "TOA5":
        raise InputError(f"{p}:1", "line 1 does not start with the field \"TOA5\"; expected a Campbell TOA5 file "
                         "(4 header lines: environment, field names, units, processing)")
    names = [h.strip() for h in header[1]]
    missing = [col for col in required if col not in names]
    if missing:
        raise InputError(f"{p}:2", f"required column(s) {', '.join(missing)} missing from the TOA5 field-name line "
                         f"({len(names)} fields; required: {', '.join(required)})")
    dup = sorted({n for n in names if names.count(n) > 1 and n in required})
    if len(set(names)) != len(names):
        raise InputError(f"{p}:2", f"repeated field names{': ' + ', '.join(dup) if dup else ''}; "
                         f"expected each of {', '.join(required)} once")
    for k in (2, 3):  # units and processing lines: a data row there means a header line is missing
        if header[k] and _TIMESTAMP_RE.match(header[k][0].strip()):
            raise InputError(f"{p}:{k + 1}", f"line {k + 1} is a data row (it starts with a TIMESTAMP); expected "
                             f"header line {k + 1} of 4 ({'units' if k == 2 else 'processing'}): the file has "
                             f"only {k} header lines, restore the missing one")
        if len(header[k]) != len(names):
            raise InputError(f"{p}:{k + 1}", f"header line {k + 1} ({'units' if k == 2 else 'processing'}) has "
                             f"{len(header[k])} fields, expected {len(names)} (one per field name of line 2)")
    units = dict(zip(names, (h.strip() for h in header[2]), strict=False))
    return header, names, units


def _numeric_frame(raw: pd.DataFrame, keep: np.ndarray, ts: pd.Series, names: list[str]) -> tuple[pd.DataFrame, int]:
    """``time``, ``RECORD`` (int64) and every other field as float64 of the kept rows.

    Returns
    -------
    frame : pandas.DataFrame
        The columns (``"NAN"`` and non-numeric -> NaN).
    n_nonnumeric : int
        Non-numeric values (other than NAN literals and empty fields) set to NaN.
    """
    frame = pd.DataFrame({"time": ts[keep].to_numpy().astype("datetime64[ns]")})
    frame["RECORD"] = _record_values(raw.loc[keep, "RECORD"])
    n_nonnumeric = 0
    for col in names:
        if col in ("TIMESTAMP", "RECORD"):
            continue
        frame[col], n_bad = _float_values(raw.loc[keep, col])
        n_nonnumeric += n_bad
    return frame, n_nonnumeric


def _record_values(s: pd.Series) -> np.ndarray:
    """int64 RECORD numbers of fields that passed :func:`_record_ok`."""
    return s.astype(str).str.strip().astype(np.int64).to_numpy()


def _record_ok(s: pd.Series) -> np.ndarray:
    """True where a RECORD field is an integer literal (spaces allowed)."""
    return s.astype(str).str.fullmatch(r"\s*[+-]?\d+\s*").to_numpy(dtype=bool)


def _float_values(s: pd.Series) -> tuple[np.ndarray, int]:
    """float64 values of numeric fields (NAN literals and empty -> NaN) and the count of non-numeric ones."""
    s = s.astype(str).str.strip()
    v = pd.to_numeric(s, errors="coerce").to_numpy(dtype=float)
    nan_literal = s.str.upper().isin(["NAN", "-NAN", "+NAN", ""]).to_numpy(dtype=bool)
    return v, int((np.isnan(v) & ~nan_literal).sum())


@dataclass
class _Toa5Rows:
    """The data lines of a TOA5 file split into fields, before the corrupt ones are removed.

    Attributes
    ----------
    header, names, units
        As :func:`_read_header`.
    n_lines : int
        Data lines (all lines after the header).
    good_count : numpy.ndarray
        True for the data lines with one field per name.
    ts : numpy.ndarray
        datetime64[ns] TIMESTAMP of those lines (NaT where unparsable).
    rec_ok : numpy.ndarray
        True where their RECORD is an integer literal.
    numeric : callable
        ``numeric(keep)`` -> (frame, n_nonnumeric) of :func:`_numeric_frame` for the lines
        ``keep`` (a mask over the lines with one field per name).
    """

    header: list[list[str]]
    names: list[str]
    units: dict[str, str]
    n_lines: int
    good_count: np.ndarray
    ts: np.ndarray
    rec_ok: np.ndarray
    numeric: Callable[[np.ndarray], tuple[pd.DataFrame, int]]


def _toa5_careful(p: Path, required: Sequence[str]) -> _Toa5Rows:
    """Split the TOA5 lines with ``csv.reader`` and convert the columns with pandas (the reference)."""
    lines, header, names, units = _read_header(p, required)
    body = lines[4:]
    n_lines = len(body)
    if n_lines == 0:
        raise InputError(p, "no data rows after the 4 header lines")
    ncol = len(names)
    # csv.reader's split of the quoted TIMESTAMP, one row per line (a line cut short inside a
    # quote does not swallow the next), so rows with a wrong field count are counted instead
    # of being skipped silently and every row keeps its line number.
    split = split_csv_lines(body)
    good_count = np.fromiter((r is not None and len(r) == ncol for r in split), dtype=bool, count=n_lines)
    raw = pd.DataFrame([r for r, g in zip(split, good_count, strict=True) if g], columns=names, dtype=object)
    ts = pd.to_datetime(raw["TIMESTAMP"], format="ISO8601", errors="coerce")
    return _Toa5Rows(header, names, units, n_lines, good_count, ts.to_numpy().astype("datetime64[ns]"),
                     _record_ok(raw["RECORD"]), lambda keep: _numeric_frame(raw, keep, ts, names))


def _toa5_fast(p: Path, required: Sequence[str]) -> _Toa5Rows | None:
    """The same as :func:`_toa5_careful` from a byte-level scan, or None when it cannot vouch for that.

    Hand-written for the reasons of :mod:`dronewind.core.textscan`: the careful reader's
    line numbers, corrupt rows, NAN literals, non-numeric counts and float rounding must be
    reproduced exactly. Lines with a byte outside printable ASCII are split by
    ``csv.reader`` one by one (a wrong field count: corrupt; the right one: the whole file
    goes the careful way). A quote must enclose a whole field and spaces may only occur
    inside a quoted TIMESTAMP, else the whole file goes the careful way (``csv.reader`` and
    ``read_csv`` could split it differently). TIMESTAMP is parsed at fixed width per length,
    the other fields by ``read_csv``; a column that is not plain is converted by the
    careful functions from the same strings.
    """
    scanned = textscan.line_safe_bytes(p)
    if scanned is None:
        return None
    raw, unusual = scanned
    head_end = -1
    for _ in range(4):
        head_end = raw.find(b"\n", head_end + 1)
        if head_end < 0:
            return None
    head = [ln.decode("utf-8", errors="replace") for ln in raw[:head_end].split(b"\n")]
    header, names, units = _check_header(p, head, required)
    raw = raw[head_end + 1:]
    buf = np.frombuffer(raw, dtype=np.uint8)
    starts, ends = textscan.line_bounds(buf)
    n_lines, ncol = int(starts.size), len(names)
    if n_lines == 0 or b"\x00" in raw:  # csv.reader raises on NUL: leave the error to the careful path
        return None
    odd = textscan.lines_holding(raw, buf, starts, bytes(range(0x20, 0x7F)), unusual)
    for i in np.flatnonzero(odd):
        line = raw[starts[i]:ends[i]].decode("utf-8", errors="replace")
        if '"' in line or len(split_csv_line(line) or []) == ncol:
            return None
    commas = np.flatnonzero(buf == ord(","))
    rows, cpos, first_comma = textscan.comma_grid(commas, starts, ends, ~odd, ncol)
    good = np.zeros(n_lines, dtype=bool)
    good[rows] = True
    if rows.size == 0 or not _plain_quotes(buf, starts, ends, commas, first_comma, rows, cpos,
                                           names.index("TIMESTAMP")):  # fmt: skip
        return None
    if rows.size == n_lines:
        plain = raw
    else:
        plain = buf[np.repeat(good, np.concatenate([starts[1:], [buf.size]]) - starts)].tobytes()
    other = [c for c in names if c != "TIMESTAMP"]
    frame = textscan.read_numeric_columns(plain, names, other, {c: (*textscan.NAN_LITERALS, "") for c in other
                                                                if c != "RECORD"}, quoting=True)  # fmt: skip
    if len(frame) != rows.size:
        return None
    spans = {}
    for j, name in enumerate(names):
        start = starts[rows] if j == 0 else cpos[:, j - 1] + 1
        end = cpos[:, j] if j < ncol - 1 else ends[rows]
        quoted = (end - start >= 2) & (buf[np.minimum(start, buf.size - 1)] == ord('"'))
        spans[name] = (start + quoted, end - quoted, end - start)
    start, end, _ = spans["TIMESTAMP"]
    ts, ts_ok = textscan.fixed_width_times(buf, start, end - start, sep=b" ")
    if not ts_ok.all():  # not plain: the careful conversion of all TIMESTAMP strings
        text = pd.Series(textscan.field_strings(raw, start, end), dtype=object)
        ts = pd.to_datetime(text, format="ISO8601", errors="coerce").to_numpy().astype("datetime64[ns]")
    record = frame["RECORD"]
    rec_text = None if record.dtype == np.int64 else pd.Series(
        textscan.field_strings(raw, *spans["RECORD"][:2]), dtype=object)  # fmt: skip
    rec_ok = np.ones(rows.size, dtype=bool) if rec_text is None else _record_ok(rec_text)
    exponent = textscan.exponent_fields(raw, buf, commas, starts, first_comma, good)

    def numeric(keep: np.ndarray) -> tuple[pd.DataFrame, int]:
        out = {"time": ts[keep],
               "RECORD": record.to_numpy()[keep] if rec_text is None else _record_values(rec_text[keep])}
        n_nonnumeric = 0
        for j, col in enumerate(names):
            if col in ("TIMESTAMP", "RECORD"):
                continue
            v = frame[col]
            if v.dtype in (np.float64, np.int64) and j not in exponent \
                    and int(spans[col][2].max()) <= textscan.FLOAT_FAST_MAX_CHARS \
                    and not np.isinf(vals := v.to_numpy(dtype=float)).any():  # fmt: skip
                out[col] = vals[keep]
            else:
                out[col], n_bad = _float_values(pd.Series(textscan.field_strings(raw, *spans[col][:2]),
                                                          dtype=object)[keep])  # fmt: skip
                n_nonnumeric += n_bad
        return pd.DataFrame(out), n_nonnumeric

    return _Toa5Rows(header, names, units, n_lines, good, ts, rec_ok, numeric)


def _plain_quotes(buf: np.ndarray, starts: np.ndarray, ends: np.ndarray, commas: np.ndarray, first_comma: np.ndarray,
                  rows: np.ndarray, cpos: np.ndarray, ts_col: int) -> bool:
    """Every quote pair encloses a whole field of one line and spaces occur only inside quoted TIMESTAMPs.

    `rows`, `cpos`: the lines with the right field count and their commas
    (:func:`dronewind.core.textscan.comma_grid`).
    """
    q = np.flatnonzero(buf == ord('"'))
    sp = np.flatnonzero(buf == ord(" "))
    if q.size % 2:
        return False
    qo, qc = q[0::2], q[1::2]
    if ts_col == 0 and qo.size == rows.size == starts.size and sp.size <= rows.size:  # the common file
        first_end = cpos[:, 0] if cpos.shape[1] else ends
        if (qo == starts).all() and (qc + 1 == first_end).all():
            if sp.size == 0 or sp.size == rows.size and bool(((sp > qo) & (sp < qc)).all()):
                return True
    line = np.searchsorted(starts, qo, side="right") - 1
    if q.size and not (
        (np.searchsorted(starts, qc, side="right") - 1 == line).all()
        and (np.searchsorted(commas, qo) == np.searchsorted(commas, qc)).all()
        and ((qo == starts[line]) | (buf[np.maximum(qo - 1, 0)] == ord(","))).all()
        and ((qc + 1 == ends[line]) | (buf[np.minimum(qc + 1, buf.size - 1)] == ord(","))).all()
    ):
        return False
    if sp.size == 0:
        return True
    if not (np.searchsorted(q, sp) % 2 == 1).all():
        return False
    sp_line = np.searchsorted(starts, sp, side="right") - 1
    return bool((np.searchsorted(commas, sp) - first_comma[sp_line] == ts_col).all())


def read_toa5(
    path: str | os.PathLike[str],
    required: Sequence[str] = REQUIRED_TOA5_COLUMNS,
    max_corrupt_fraction: float = 0.05,
) -> tuple[pd.DataFrame, dict[str, Any]]:
    """Read one TOA5 file into a DataFrame.

    Parameters
    ----------
    path : str or Path
        TOA5 file.
    required : sequence of str, optional
        Field names that must be in the header (line 2).
    max_corrupt_fraction : float, optional
        Largest tolerated fraction of rows with an unparsable TIMESTAMP or RECORD or a wrong
        number of fields [1].

    Returns
    -------
    frame : pandas.DataFrame
        Columns ``time`` (datetime64[ns]), ``RECORD`` (int64) and every other field as
        float64 (``"NAN"`` and non-numeric -> NaN); corrupt rows removed.
    info : dict
        ``header`` (the four header lines as lists), ``units`` (field -> unit),
        ``n_lines``, ``n_corrupt_lines``, ``corrupt_lines`` (first few line numbers),
        ``n_nonnumeric`` (non-numeric values in numeric fields, set NaN).

    Raises
    ------
    InputError
        Missing file, not a TOA5 file (line 1), a required column missing (line 2), or too
        many corrupt rows.

    Notes
    -----
    Plain files take a byte-level fast path (:func:`_toa5_fast`), large plain files a chunked
    C-parser path that bounds the memory (:func:`_read_toa5_chunked`), anything else the
    careful ``csv.reader`` one (:func:`_toa5_careful`); all give the same result.
    """
    p = Path(path)
    if p.is_file() and p.stat().st_size >= _CHUNKED_MIN_BYTES:
        chunked = _read_toa5_chunked(p, required)
        if chunked is not None:
            return chunked
    rows = _toa5_fast(p, required) or _toa5_careful(p, required)
    n_lines, good_count = rows.n_lines, rows.good_count
    ncol = len(rows.names)
    line_no = np.arange(5, 5 + n_lines)
    line_no_ok = line_no[good_count]
    bad_ok = np.isnat(rows.ts) | ~rows.rec_ok
    bad_lines = np.sort(np.concatenate([line_no[~good_count], line_no_ok[bad_ok]]))
    n_corrupt = int(bad_lines.size)
    if n_corrupt > max_corrupt_fraction * n_lines:
        raise InputError(
            f"{p}:{int(bad_lines[0])}",
            f"{n_corrupt} of {n_lines} data rows corrupt (> {100 * max_corrupt_fraction:g} %): "
            f"unparsable TIMESTAMP or RECORD or not {ncol} fields; first at lines "
            f"{bad_lines[:_N_LOGGED].tolist()}",
        )
    keep = ~bad_ok
    frame, n_nonnumeric = rows.numeric(keep)
    frame["_line"] = line_no_ok[keep]
    info = {"header": rows.header, "units": rows.units, "n_lines": n_lines, "n_corrupt_lines": n_corrupt,
            "corrupt_lines": bad_lines[:_N_LOGGED].tolist(), "n_nonnumeric": n_nonnumeric}
    return frame, info


#: The NAN literals of the row-by-row path (it compares upper-cased text with "NAN", "-NAN", "+NAN", "").
_FAST_NA_VALUES = ["NAN", "NaN", "nan", "Nan", "-NAN", "-NaN", "-nan", "+NAN", "+NaN", "+nan", ""]
#: A body that holds anything but printable ASCII, CR and LF takes the row-by-row path.
_FAST_UNSAFE_BYTES = re.compile(rb"[^\x20-\x7e\r\n]")
#: Rows parsed at a time by the C-parser path.
_FAST_CHUNK_ROWS = 200_000
#: Files from this size on are read by :func:`_read_toa5_chunked` [bytes].
_CHUNKED_MIN_BYTES = 32_000_000
#: Number text whose conversion read_csv and the careful path's pd.to_numeric may round
#: differently in the last bit (an exponent, or 16 or more digits; see dronewind.core.textscan).
_FLOAT_TEXT_UNSAFE = re.compile(rb"[eE]|[0-9.]{16,}")


def _read_toa5_chunked(p: Path, required: Sequence[str]) -> tuple[pd.DataFrame, dict[str, Any]] | None:
    """:func:`read_toa5` of a large clean file with pandas' C parser in chunks, or ``None``.

    For files of at least :data:`_CHUNKED_MIN_BYTES` (a day of 20 Hz rows is 1.7 million
    rows, about 100 MB): the byte-level path (:func:`_toa5_fast`) holds field offsets of the
    whole file at once (about 1.2 GB for such a day), this one the numbers of one chunk of
    rows at a time, so a long record's memory stays bounded. It is used only when the
    result must equal the careful path's: the header passes the same checks, the body is
    printable ASCII with CR/LF line ends, every row has exactly the header's number of
    fields (the C parser stops on a row with more, and the total comma count rules out
    rows with fewer), every TIMESTAMP parses, RECORD is an integer, and every other field
    is a number or a NAN literal. Anything else (a corrupt row, text in a numeric field, a
    blank line) returns ``None`` and the file is read row by row, which counts and reports
    what it finds.

    Returns
    -------
    tuple or None
        As :func:`read_toa5`, or ``None``.
    """
    if not p.is_file():
        return None
    data = p.read_bytes()
    start = 3 if data.startswith(b"\xef\xbb\xbf") else 0
    cut = start
    for _ in range(4):
        cut = data.find(b"\n", cut) + 1
        if cut == 0:
            return None
    head_lines = data[start:cut].decode("utf-8", errors="replace").splitlines()
    if len(head_lines) != 4:
        return None
    header = [split_csv_line(ln) or [] for ln in head_lines]
    names = [h.strip() for h in header[1]]
    if (not header[0] or header[0][0] != "TOA5" or any(c not in names for c in required)
            or len(set(names)) != len(names) or any(len(header[k]) != len(names) for k in (2, 3))
            or any(header[k] and _TIMESTAMP_RE.match(header[k][0].strip()) for k in (2, 3))):
        return None  # the row-by-row path raises the error that names the line
    if cut == len(data) or _FAST_UNSAFE_BYTES.search(data, cut) is not None:
        return None
    n_cr, n_lf = data.count(b"\r", cut), data.count(b"\n", cut)
    if n_cr and (n_cr != n_lf or data.count(b"\r\n", cut) != n_cr):
        return None
    if _FLOAT_TEXT_UNSAFE.search(data, cut) is not None:
        return None  # an exponent or 16+ digits: pd.to_numeric and read_csv may round such text differently
    n_lines = n_lf + (0 if data.endswith(b"\n") else 1)
    if data.count(b",", cut) != n_lines * (len(names) - 1):
        return None
    del data  # the parser reads the file itself: one copy of the text at a time
    numeric = {n: np.float64 for n in names if n not in ("TIMESTAMP", "RECORD")}
    columns: dict[str, np.ndarray] = {"time": np.empty(n_lines, "datetime64[ns]"),
                                      "RECORD": np.empty(n_lines, np.int64),
                                      **{n: np.empty(n_lines, float) for n in numeric}}
    done = 0
    try:  # in chunks: the TIMESTAMP texts of one chunk at a time, not of the whole file
        with pd.read_csv(p, skiprows=4, header=None, names=names, engine="c", skip_blank_lines=False,
                         dtype={"TIMESTAMP": str, "RECORD": np.int64, **numeric}, keep_default_na=False,
                         na_values={n: _FAST_NA_VALUES for n in numeric}, encoding="utf-8-sig",
                         chunksize=_FAST_CHUNK_ROWS) as reader:
            for chunk in reader:
                m = len(chunk)
                if done + m > n_lines:
                    return None
                ts = pd.to_datetime(chunk["TIMESTAMP"], format="ISO8601", errors="coerce")
                if ts.isna().any():
                    return None
                columns["time"][done:done + m] = ts.to_numpy().astype("datetime64[ns]")
                columns["RECORD"][done:done + m] = chunk["RECORD"].to_numpy(dtype=np.int64)
                for col in numeric:
                    columns[col][done:done + m] = chunk[col].to_numpy(dtype=float)
                done += m
    except (ValueError, pd.errors.ParserError):
        return None
    if done != n_lines:
        return None
    columns["_line"] = np.arange(5, 5 + n_lines)
    frame = pd.DataFrame(columns, copy=False)
    units = dict(zip(names, (h.strip() for h in header[2]), strict=False))
    info = {"header": header, "units": units, "n_lines": n_lines, "n_corrupt_lines": 0, "corrupt_lines": [],
            "n_nonnumeric": 0}
    return frame, info


