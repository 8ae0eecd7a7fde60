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
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.core import textscan
from dronewind.core.raw import RawRecord
from dronewind.core.rowfaults import split_csv_line, split_csv_lines
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


def _irregular_rows(lines: list[str], line_no: np.ndarray, names: list[str]
                    ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, int]:
    """The fault handling of TOA5 data lines, one by one: ``csv.reader``'s split and pandas' conversions.

    A line cut short inside a quote does not swallow the next
    (:func:`dronewind.core.rowfaults.split_csv_lines`); a line with another number of
    fields than the header, or whose TIMESTAMP or RECORD cannot be parsed, is corrupt.

    Parameters
    ----------
    lines : list of str
        Data lines.
    line_no : numpy.ndarray
        Their 1-based file lines.
    names : list of str
        Field names.

    Returns
    -------
    columns : dict of numpy.ndarray
        ``time``, ``RECORD`` and every other field (float64; ``"NAN"`` and non-numeric ->
        NaN) of the good lines.
    good_lines : numpy.ndarray
        Their file lines.
    bad_lines : numpy.ndarray
        The file lines of the corrupt lines.
    n_nonnumeric : int
        Non-numeric values (other than NAN literals and empty fields) of the good lines.
    """
    ncol = len(names)
    split = split_csv_lines(lines)
    good_count = np.fromiter((r is not None and len(r) == ncol for r in split), dtype=bool, count=len(lines))
    raw = pd.DataFrame([r for r, g in zip(split, good_count, strict=True) if g], columns=names, dtype=object)
    counted = line_no[good_count]
    ts = pd.to_datetime(raw["TIMESTAMP"], format="ISO8601", errors="coerce").to_numpy().astype("datetime64[ns]")
    keep = ~np.isnat(ts) & _record_ok(raw["RECORD"])
    columns: dict[str, np.ndarray] = {"time": ts[keep], "RECORD": _record_values(raw.loc[keep, "RECORD"])}
    n_nonnumeric = 0
    for col in names:
        if col not in ("TIMESTAMP", "RECORD"):
            columns[col], n_bad = _float_values(raw.loc[keep, col])
            n_nonnumeric += n_bad
    return columns, counted[keep], np.sort(np.concatenate([line_no[~good_count], counted[~keep]])), n_nonnumeric


def _regular_rows(body: bytes, starts: np.ndarray, ends: np.ndarray, names: list[str]
                  ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The regular lines of a block of TOA5 data lines and their columns, by a byte-level scan.

    A line is regular when it is printable ASCII without an exponent, has one field per
    name, its TIMESTAMP is ``"YYYY-MM-DD HH:MM:SS[.f]"`` (quoted, fixed width: its one
    space is the line's only one), every other quote pair encloses a whole field, its
    RECORD is an integer literal and every other field a number of at most
    :data:`~dronewind.core.textscan.FLOAT_FAST_MAX_CHARS` characters or a NAN literal.
    ``csv.reader`` and ``read_csv`` split such a line alike, and its values converted here
    are the fault handling's (:func:`_irregular_rows`) bit for bit.

    Parameters
    ----------
    body : bytes
        Data lines (``\n`` line ends).
    starts, ends : numpy.ndarray
        Their bounds.
    names : list of str
        Field names.

    Returns
    -------
    regular : numpy.ndarray
        bool, one per line.
    columns : dict of numpy.ndarray
        ``time``, ``RECORD`` and the other fields of the regular lines.
    """
    buf = np.frombuffer(body, dtype=np.uint8)
    n, ncol = int(starts.size), len(names)
    j_ts, j_rec = names.index("TIMESTAMP"), names.index("RECORD")
    candidate = ~textscan.lines_holding(body, buf, starts, bytes(range(0x20, 0x7F)),
                                        bool(body.translate(None, textscan.PRINTABLE_LINES)))
    candidate &= ~textscan.lines_with(body, buf, starts, b"eE")
    space = np.flatnonzero(buf == ord(" "))
    quote = np.flatnonzero(buf == ord('"'))
    commas = np.flatnonzero(buf == ord(","))
    if not _common_quotes(buf, starts, ends, space, quote, j_ts):
        candidate &= np.bincount(np.searchsorted(starts, space, side="right") - 1, minlength=n) == 1
        q_line = np.searchsorted(starts, quote, side="right") - 1
        candidate &= np.bincount(q_line, minlength=n) % 2 == 0
        if quote.size:  # every quote pair of a line encloses one whole field
            rank = np.arange(quote.size) - np.searchsorted(quote, starts)[q_line]
            opening = np.flatnonzero((rank % 2 == 0) & candidate[q_line])
            qo, qc = quote[opening], quote[np.minimum(opening + 1, quote.size - 1)]
            line = q_line[opening]
            whole = (qc > qo) & (q_line[np.minimum(opening + 1, quote.size - 1)] == line) \
                & (np.searchsorted(commas, qo) == np.searchsorted(commas, qc)) \
                & ((qo == starts[line]) | (buf[np.maximum(qo - 1, 0)] == ord(","))) \
                & ((qc + 1 == ends[line]) | (buf[np.minimum(qc + 1, buf.size - 1)] == ord(",")))  # fmt: skip
            candidate[line[~whole]] = False
    rows, cpos, _ = textscan.comma_grid(commas, starts, ends, candidate, ncol)
    columns: dict[str, np.ndarray] = {}
    if rows.size == 0:
        return np.zeros(n, dtype=bool), columns

    def span(j: int) -> tuple[np.ndarray, np.ndarray]:
        """Byte span of field `j` of the scanned lines, without its quotes."""
        start = starts[rows] if j == 0 else cpos[:, j - 1] + 1
        end = cpos[:, j] if j < ncol - 1 else ends[rows]
        quoted = (end - start >= 2) & (buf[np.minimum(start, buf.size - 1)] == ord('"'))
        return start + quoted, end - quoted

    t0, t1 = span(j_ts)
    time, ok = textscan.fixed_width_times(buf, t0, t1 - t0, sep=b" ")
    # the TIMESTAMP quoted, its closing quote the one before the line's first comma (no comma inside)
    ok &= (buf[np.maximum(t0 - 1, 0)] == ord('"')) & (buf[np.minimum(t1, buf.size - 1)] == ord('"'))
    scanned = np.zeros(n, dtype=bool)
    scanned[rows] = True
    other = [c for c in names if c != "TIMESTAMP"]
    frame = textscan.read_numeric_columns(textscan.kept_lines(body, starts, scanned), names, other,
                                          {c: (*textscan.NAN_LITERALS, "") for c in other if c != "RECORD"},
                                          quoting=True)  # fmt: skip
    record = frame["RECORD"]
    if record.dtype == np.int64:
        rec = record.to_numpy(dtype=np.int64)
    else:
        rec, rec_ok = textscan.int_fields(buf, *span(j_rec))
        ok &= rec_ok
    columns["time"], columns["RECORD"] = time, rec
    for j, col in enumerate(names):
        if col not in ("TIMESTAMP", "RECORD"):
            f0, f1 = span(j)
            columns[col], col_ok = textscan.float_fields(frame[col], f1 - f0)
            ok &= col_ok
    regular = np.zeros(n, dtype=bool)
    regular[rows[ok]] = True
    return regular, {k: v[ok] for k, v in columns.items()}


def _common_quotes(buf: np.ndarray, starts: np.ndarray, ends: np.ndarray, space: np.ndarray, quote: np.ndarray,
                   j_ts: int) -> bool:
    """Whether every line's only quotes open it and close before a comma, its only space between them.

    The common file, checked with a few comparisons instead of the per-line counts
    (:func:`_regular_rows` then checks that the closing quote ends the first field, so no
    comma lies inside the quotes).
    """
    n = starts.size
    if j_ts != 0 or quote.size != 2 * n or space.size != n or n == 0:
        return False
    qo, qc = quote[0::2], quote[1::2]
    return bool((qo == starts).all() and (qc < ends).all()
                and (buf[np.minimum(qc + 1, buf.size - 1)] == ord(",")).all()
                and ((space > qo) & (space < qc)).all())


#: Data lines scanned at a time: the offsets and values of one block are held at once, so
#: a day of 20 Hz rows (1.7 million lines, 104 MB) is read with a peak of about 400 MB
#: (the text, the columns of every row and one block's scan).
_BLOCK_LINES = 100_000


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
    One parser: the regular lines are found and converted in bulk by a byte-level scan
    (:func:`_regular_rows`), every other line goes with its line number to the line-by-line
    fault handling (:func:`_irregular_rows`), and the rows are put back in line order; the
    data lines are scanned in blocks of :data:`_BLOCK_LINES`, so memory stays bounded on a
    long record. The scan is written by hand because the rows, counts and line numbers
    must be those of the line-by-line parse bit for bit (``csv.reader``'s split, pandas'
    ``to_numeric`` rounding, which ``read_csv`` does not share beyond 15 characters), at a
    fraction of its cost: 400,000 rows (25 MB) take 0.25 s of CPU by the scan, 2.3 s line by line.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(p, "file not found")
    head, body, _, starts, ends, _ = textscan.text_body(p.read_bytes(), 4)
    if len(head) < 4:
        raise InputError(p, f"only {len(head)} lines; a TOA5 file has 4 header lines")
    header, names, units = _check_header(p, head, required)
    n_lines, ncol = int(starts.size), len(names)
    if n_lines == 0:
        raise InputError(p, "no data rows after the 4 header lines")
    floats = [c for c in names if c not in ("TIMESTAMP", "RECORD")]
    # the rows of every block written in line order into columns of room for every line
    out = {"time": np.empty(n_lines, "datetime64[ns]"), "RECORD": np.empty(n_lines, np.int64),
           **{c: np.empty(n_lines, float) for c in floats}, "_line": np.empty(n_lines, np.int64)}
    filled = 0
    bad: list[np.ndarray] = []
    n_nonnumeric = 0
    bounds = np.append(starts, len(body))
    for first in range(0, n_lines, _BLOCK_LINES):
        stop = min(first + _BLOCK_LINES, n_lines)
        a, b = int(bounds[first]), int(bounds[stop])
        block = body[a:b]
        regular, cols = _regular_rows(block, starts[first:stop] - a, ends[first:stop] - a, names)
        line_no = first + 5 + np.flatnonzero(regular)
        irregular = np.flatnonzero(~regular)
        if irregular.size:
            text = textscan.line_text(block, starts[first:stop] - a, ends[first:stop] - a, irregular)
            cols_i, good_i, bad_i, n_bad = _irregular_rows(text, first + 5 + irregular, names)
            bad.append(bad_i)
            n_nonnumeric += n_bad
            if not cols:
                cols, line_no = cols_i, good_i
            elif good_i.size:
                line_no = np.concatenate([line_no, good_i])
                order = np.argsort(line_no, kind="stable")
                line_no = line_no[order]
                cols = {k: np.concatenate([cols[k], cols_i[k]])[order] for k in cols}
        m = int(line_no.size)
        if m:
            for k, v in cols.items():
                out[k][filled:filled + m] = v
            out["_line"][filled:filled + m] = line_no
        filled += m
    bad_lines = np.sort(np.concatenate(bad)) if bad else np.zeros(0, dtype=np.int64)
    n_corrupt = int(bad_lines.size)
    if n_corrupt > max_corrupt_fraction * n_lines:
        raise InputError(
            f"{p}:{int(bad_lines[0])}",
            f"{n_corrupt} of {n_lines} data rows corrupt (> {100 * max_corrupt_fraction:g} %): "
            f"unparsable TIMESTAMP or RECORD or not {ncol} fields; first at lines "
            f"{bad_lines[:_N_LOGGED].tolist()}",
        )
    frame = pd.DataFrame({k: v[:filled] for k, v in out.items()}, copy=False)
    info = {"header": header, "units": units, "n_lines": n_lines, "n_corrupt_lines": n_corrupt,
            "corrupt_lines": bad_lines[:_N_LOGGED].tolist(), "n_nonnumeric": n_nonnumeric}
    return frame, info
