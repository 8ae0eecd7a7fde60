"""Generic delimited text: a manifest's column mapping to UTC time and variables in SI units.

A record in a format no dedicated reader knows is described in its manifest entry
(``format: {name: delimited, ...}``, README "Input formats") instead of code:

* layout: ``delimiter`` (one character; fields may be double-quoted), ``header_line`` (the
  1-based line with the column names; 0 = no header, columns by 1-based number),
  ``skip_lines`` (lines between the header, or the top, and the first data row) and
  ``compression`` (``auto``: gzip when the name ends in ``.gz``; ``gzip``; ``none``);
* time: ``column`` and ``kind``: ``iso`` (ISO 8601; a zone suffix such as ``Z`` or
  ``-07:00`` is honoured, a time without one is the logger's clock at ``utc_offset_hours``
  from UTC: UTC = logged - offset), ``epoch_s`` or ``epoch_ms`` (since 1970-01-01 UTC);
* variables: per name its ``column``, ``scale``, ``offset`` and ``unit``: the value in
  ``unit`` is ``scale * logged + offset``, then converted to SI by :data:`UNITS` (m/s and
  cm/s to m s-1, degC and K to K, ``1`` for dimensionless words; for a platform record also
  degree and rad to degree, m).

Rows with a wrong number of fields or a time that does not parse are corrupt (removed,
counted, their line numbers kept); ``NAN``, empty and other non-numeric values become NaN.
Lines are split one by one (a quote never continues on the next line) and a gzip stream
that is cut short or damaged is read as far as it goes (:mod:`dronewind.core.rowfaults`).
Every error names the file and line and what was expected.
"""

from __future__ import annotations

import os
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from dronewind.core.constants import ZERO_CELSIUS_K
from dronewind.core.rowfaults import gunzip_readable, split_csv_lines, text_lines
from dronewind.errors import InputError

__all__ = ["UNITS", "ColumnMap", "DelimitedLayout", "DelimitedTable", "GZIP_MAGIC", "delimited_layout",
           "compression_problem", "read_text_lines", "split_fields", "resolve_columns", "parse_times",
           "to_si", "read_delimited", "check_delimited_head"]

#: Unit -> (SI unit, factor, offset): value [SI] = value [unit] * factor + offset.
UNITS: dict[str, tuple[str, float, float]] = {
    "m/s": ("m s-1", 1.0, 0.0),
    "m s-1": ("m s-1", 1.0, 0.0),
    "cm/s": ("m s-1", 0.01, 0.0),
    "cm s-1": ("m s-1", 0.01, 0.0),
    "K": ("K", 1.0, 0.0),
    "degC": ("K", 1.0, ZERO_CELSIUS_K),
    "1": ("1", 1.0, 0.0),
    "degree": ("degree", 1.0, 0.0),
    "rad": ("degree", 180.0 / 3.141592653589793, 0.0),
    "m": ("m", 1.0, 0.0),
    "Pa": ("Pa", 1.0, 0.0),
    "hPa": ("Pa", 100.0, 0.0),
}
#: The SI unit each variable of a sonic mapping must convert to.
SONIC_QUANTITIES: dict[str, str] = {"u": "m s-1", "v": "m s-1", "w": "m s-1", "t": "K", "diag": "1"}
#: First bytes of a gzip stream.
GZIP_MAGIC = b"\x1f\x8b"
_NAN_LITERALS = ("NAN", "-NAN", "+NAN", "NA", "")
_ZONE_RE = r"(?:Z|[+-]\d{2}:?\d{2})\s*$"
_N_LOGGED = 5
_FIELD_QUOTE_LIMIT = 12


@dataclass(frozen=True)
class ColumnMap:
    """Where one variable is and how it converts.

    Attributes
    ----------
    column : str or int
        Column name in the header line, or its 1-based number.
    unit : str
        Unit after ``scale`` and ``offset`` (a key of :data:`UNITS`).
    scale, offset : float
        value [unit] = scale * logged + offset.
    """

    column: str | int
    unit: str
    scale: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class DelimitedLayout:
    """A delimited-text mapping (see the module docstring)."""

    time_column: str | int
    time_kind: str
    variables: dict[str, ColumnMap]
    delimiter: str = ","
    header_line: int = 1
    skip_lines: int = 0
    compression: str = "auto"
    utc_offset_hours: float = 0.0

    @property
    def first_data_line(self) -> int:
        """1-based number of the first data row."""
        return self.header_line + self.skip_lines + 1

    def columns(self) -> dict[str, str | int]:
        """Variable (``time`` first) -> column as declared."""
        return {"time": self.time_column, **{k: m.column for k, m in self.variables.items()}}


def delimited_layout(spec: Mapping[str, Any], where: str,
                     quantities: Mapping[str, str] = SONIC_QUANTITIES) -> DelimitedLayout:
    """The layout of a ``delimited`` format mapping (validated by the campaign schema first).

    Parameters
    ----------
    spec : mapping
        The manifest's ``format`` mapping (``delimiter``, ``header_line``, ``skip_lines``,
        ``compression``, ``time``, ``variables``).
    where : str
        Key path for messages (e.g. ``masts[0].sonics[0].format``).
    quantities : mapping
        Variable -> SI unit its declared unit must convert to.

    Returns
    -------
    DelimitedLayout

    Raises
    ------
    InputError
        A unit of the wrong quantity (e.g. ``degC`` for ``u``), a column number below 1, or
        a column name with no header line.
    """
    variables: dict[str, ColumnMap] = {}
    for name, m in (spec.get("variables") or {}).items():
        unit = str(m["unit"])
        si = UNITS.get(unit, ("?", 0.0, 0.0))[0]
        if name in quantities and si != quantities[name]:
            allowed = ", ".join(u for u, (s, _, _) in UNITS.items() if s == quantities[name])
            raise InputError(f"{where}.variables.{name}.unit", f"unit {unit!r} is not a unit of {name}; expected one "
                             f"of {allowed}")
        variables[str(name)] = ColumnMap(m["column"], unit, float(m.get("scale", 1.0)), float(m.get("offset", 0.0)))
    time = spec["time"]
    layout = DelimitedLayout(time["column"], str(time["kind"]), variables, str(spec.get("delimiter", ",")),
                             int(spec.get("header_line", 1)), int(spec.get("skip_lines", 0)),
                             str(spec.get("compression", "auto")), float(time.get("utc_offset_hours", 0.0)))
    for var, col in layout.columns().items():
        key = f"{where}.time.column" if var == "time" else f"{where}.variables.{var}.column"
        if isinstance(col, int) and col < 1:
            raise InputError(key, f"column number {col}; expected 1 or more (1-based)")
        if isinstance(col, str) and layout.header_line == 0:
            raise InputError(key, f"column name {col!r} but header_line is 0 (no header); expected a 1-based "
                             "column number, or the header_line holding the names")
    return layout


def _gzipped(path: Path, compression: str) -> bool:
    """Whether the file is read as gzip: declared, or by its ``.gz`` suffix (``auto``)."""
    if compression == "auto":
        return path.name.lower().endswith(".gz")
    return compression == "gzip"


def compression_problem(path: str | os.PathLike[str], compression: str = "auto") -> str | None:
    """Whether the first bytes of a file contradict its declared compression.

    Parameters
    ----------
    path : str or Path
        The file.
    compression : str
        ``auto`` (gzip when the name ends in ``.gz``), ``gzip`` or ``none``.

    Returns
    -------
    str or None
        What was found and what was expected, or None.
    """
    p = Path(path)
    with open(p, "rb") as fh:
        head = fh.read(2)
    want_gzip = _gzipped(p, compression)
    declared = "compression: gzip" if compression == "gzip" else (
        "the .gz name" if compression == "auto" else "compression: none")
    if want_gzip and head != GZIP_MAGIC:
        return (f"plain data (first bytes {head.hex(' ') or 'none'}), expected gzip-compressed data (bytes 1f 8b) "
                f"as {declared} says; declare compression: none or name the file without .gz")
    if not want_gzip and head == GZIP_MAGIC:
        return (f"gzip-compressed data (bytes 1f 8b), expected plain text as {declared} says; declare "
                "compression: gzip (or auto with a .gz file name)")
    return None


def read_text_lines(path: str | os.PathLike[str], compression: str = "auto", n: int | None = None) -> list[str]:
    """The text lines of a file, gunzipped when it is gzip (declared or by name).

    Parameters
    ----------
    path : str or Path
        The file.
    compression : str
        ``auto``, ``gzip`` or ``none``.
    n : int, optional
        Read only the first ``n`` lines.

    Returns
    -------
    list of str
        Lines without line ends (:func:`dronewind.core.rowfaults.text_lines`); of a gzip
        stream that is cut short or damaged, the lines before the damage.

    Raises
    ------
    InputError
        The file is missing, the compression contradicts the first bytes, or no byte of a
        gzip stream can be decompressed.
    """
    return _read_lines(Path(path), compression, n)[0]


def _read_lines(p: Path, compression: str, n: int | None = None) -> tuple[list[str], str | None]:
    """:func:`read_text_lines` and what stopped a damaged gzip stream (None if intact)."""
    if not p.is_file():
        raise InputError(p, "file not found")
    problem = compression_problem(p, compression)
    if problem:
        raise InputError(f"{p}:1", problem)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise InputError(p, f"cannot read ({exc})") from exc
    gz_problem = None
    if _gzipped(p, compression):
        raw, gz_problem = gunzip_readable(raw)
        if gz_problem and not raw:
            raise InputError(p, f"cannot read: {gz_problem}")
    lines = text_lines(raw)
    return (lines[:n] if n is not None else lines), gz_problem


def split_fields(lines: Sequence[str], delimiter: str = ",") -> list[list[str]]:
    """Fields of each line (double quotes honoured), stripped of blanks.

    Parameters
    ----------
    lines : sequence of str
        Text lines.
    delimiter : str
        One character.

    Returns
    -------
    list of list of str
        One per line (:func:`dronewind.core.rowfaults.split_csv_lines`: a quote never
        continues on the next line); ``[]`` for a line that cannot be split.
    """
    return [[f.strip() for f in row] if row is not None else [] for row in split_csv_lines(lines, delimiter)]


def _quote_fields(fields: Sequence[str]) -> str:
    """A header line for a message: at most a few fields, each shortened."""
    shown = [repr(f[:40]) for f in fields[:_FIELD_QUOTE_LIMIT]]
    more = f", ... ({len(fields)} fields)" if len(fields) > _FIELD_QUOTE_LIMIT else ""
    return "[" + ", ".join(shown) + more + "]"


def resolve_columns(header: Sequence[str] | None, n_fields: int, layout: DelimitedLayout,
                    where: str) -> dict[str, int]:
    """0-based field index of every mapped column.

    Parameters
    ----------
    header : sequence of str or None
        Fields of the header line (None without one).
    n_fields : int
        Fields per row.
    layout : DelimitedLayout
    where : str
        ``file:line`` of the header (or of the first data row) for messages.

    Returns
    -------
    dict
        Variable (``time`` included) -> field index.

    Raises
    ------
    InputError
        A named column absent from the header (naming the column and quoting the header
        found) or a column number beyond the fields of a row.
    """
    out: dict[str, int] = {}
    for var, col in layout.columns().items():
        if isinstance(col, int):
            if col > n_fields:
                raise InputError(where, f"column {col} of {var} beyond the {n_fields} fields of a row; expected a "
                                 f"column number 1 to {n_fields}")
            out[var] = col - 1
        else:
            names = list(header or [])
            if col not in names:
                raise InputError(where, f"column {col!r} of {var} not in the header line, which has "
                                 f"{_quote_fields(names)}; expected a field named {col!r} (or a 1-based number)")
            if names.count(col) > 1:
                raise InputError(where, f"column {col!r} of {var} appears {names.count(col)} times in the header "
                                 "line; expected it once (or give its 1-based number)")
            out[var] = names.index(col)
    return out


def parse_times(values: Sequence[str] | pd.Series, kind: str, utc_offset_hours: float = 0.0) -> np.ndarray:
    """Parse time stamps to UTC.

    Parameters
    ----------
    values : sequence of str
        Time fields as logged.
    kind : str
        ``iso`` (ISO 8601; a zone suffix is honoured), ``epoch_s`` or ``epoch_ms``.
    utc_offset_hours : float
        For ``iso`` times without a zone: offset of the logger clock from UTC [h];
        UTC = logged - offset.

    Returns
    -------
    numpy.ndarray
        datetime64[ns], naive UTC; NaT where a value does not parse.
    """
    s = pd.Series(values, dtype=object).astype(str).str.strip()
    if kind == "iso":
        zoned = s.str.contains(_ZONE_RE, regex=True).to_numpy(dtype=bool)
        t = np.full(s.size, np.datetime64("NaT"), dtype="datetime64[ns]")
        if zoned.any():
            parsed = pd.to_datetime(s[zoned], format="ISO8601", errors="coerce", utc=True)
            t[zoned] = parsed.dt.tz_convert(None).to_numpy().astype("datetime64[ns]")
        if (~zoned).any():
            local = pd.to_datetime(s[~zoned], format="ISO8601", errors="coerce").to_numpy().astype("datetime64[ns]")
            t[~zoned] = local - np.timedelta64(int(round(utc_offset_hours * 3600e9)), "ns")
        return t
    digits = {"epoch_s": 9, "epoch_ms": 6}.get(kind)
    if digits is None:
        raise ValueError(f"time kind {kind!r}; expected iso, epoch_s or epoch_ms")
    scale_ns = 10**digits
    # integer and fraction apart: a float holds an epoch in ns to about 0.2 us only
    parts = s.str.extract(r"^([+-]?)(\d{1,13})(?:\.(\d*))?$")
    exact = parts[1].notna().to_numpy(dtype=bool).copy()
    exact[exact] = parts.loc[exact, 1].astype(np.int64).to_numpy() < 9_200_000_000_000_000_000 // scale_ns
    ns = np.zeros(s.size, dtype=np.int64)
    ok = exact.copy()
    if exact.any():
        whole = parts.loc[exact, 1].astype(np.int64).to_numpy()
        frac = parts.loc[exact, 2].fillna("").str.slice(0, digits).str.pad(digits, side="right", fillchar="0")
        sign = np.where(parts.loc[exact, 0].to_numpy() == "-", -1, 1)
        ns[exact] = sign * (whole * scale_ns + frac.astype(np.int64).to_numpy())
    x = pd.to_numeric(s[~exact], errors="coerce").to_numpy(dtype=float)  # exponents: float precision
    fine = np.isfinite(x) & (np.abs(x * scale_ns) < 9.2e18)
    ns[np.flatnonzero(~exact)[fine]] = np.rint(x[fine] * scale_ns).astype(np.int64)
    ok[np.flatnonzero(~exact)[fine]] = True
    out = ns.astype("datetime64[ns]")
    out[~ok] = np.datetime64("NaT")
    return out


def to_si(logged: np.ndarray, m: ColumnMap) -> np.ndarray:
    """A logged column in SI units: ``(scale * logged + offset)`` in ``m.unit``, converted by :data:`UNITS`.

    Parameters
    ----------
    logged : numpy.ndarray
        Values as logged.
    m : ColumnMap

    Returns
    -------
    numpy.ndarray
        [SI unit of ``m.unit``].
    """
    _, factor, off = UNITS[m.unit]
    x = np.asarray(logged, dtype=float)
    if m.scale != 1.0 or m.offset != 0.0:
        x = m.scale * x + m.offset
    if factor != 1.0 or off != 0.0:
        x = x * factor + off
    return x


def _numeric(fields: pd.Series) -> tuple[np.ndarray, np.ndarray]:
    """Values and the mask of non-numeric fields that are not NaN literals."""
    s = fields.astype(str).str.strip()
    v = pd.to_numeric(s, errors="coerce").to_numpy(dtype=float)
    literal = s.str.upper().isin(_NAN_LITERALS).to_numpy(dtype=bool)
    return v, np.isnan(v) & ~literal


@dataclass
class DelimitedTable:
    """Rows of a delimited file after the mapping.

    Attributes
    ----------
    time : numpy.ndarray
        datetime64[ns] UTC of the good rows.
    values : dict
        Variable -> values in SI units (NaN where not numeric).
    line_no : numpy.ndarray
        1-based file line of each good row.
    n_lines, n_corrupt, n_nonnumeric : int
        Data rows, corrupt rows removed, non-numeric values set to NaN.
    corrupt_lines : list of int
        The first few corrupt lines.
    problem : str or None
        Where a damaged gzip stream stopped (its readable lines are read), else None.
    """

    time: np.ndarray
    values: dict[str, np.ndarray]
    line_no: np.ndarray
    n_lines: int
    n_corrupt: int
    n_nonnumeric: int
    corrupt_lines: list[int]
    problem: str | None = None


def _header_and_rows(p: Path, lines: list[str], layout: DelimitedLayout, split_body: bool = True,
                     ) -> tuple[list[str] | None, list[list[str]]]:
    """The header fields (None without a header) and the data rows, split (unless ``split_body`` is False)."""
    if len(lines) < layout.first_data_line - (0 if split_body else 1):
        raise InputError(p, f"only {len(lines)} lines; expected the header on line {layout.header_line} and data "
                         f"from line {layout.first_data_line}")
    header = split_fields([lines[layout.header_line - 1]], layout.delimiter)[0] if layout.header_line else None
    body = lines[layout.first_data_line - 1:]
    return header, split_fields(body, layout.delimiter) if split_body else []


def read_delimited(path: str | os.PathLike[str], layout: DelimitedLayout,
                   max_corrupt_fraction: float = 0.05) -> DelimitedTable:
    """Read a delimited-text file by its mapping.

    Parameters
    ----------
    path : str or Path
        The file (plain or gzip, see ``layout.compression``).
    layout : DelimitedLayout
    max_corrupt_fraction : float
        Largest tolerated fraction of corrupt rows (wrong field count, time that does not
        parse) [1].

    Returns
    -------
    DelimitedTable

    Raises
    ------
    InputError
        See :func:`read_text_lines` and :func:`resolve_columns`; no data rows; too many
        corrupt rows (naming the first).
    """
    p = Path(path)
    lines, gz_problem = _read_lines(p, layout.compression)
    header, _ = _header_and_rows(p, lines[:layout.first_data_line - 1], layout, split_body=False)
    split = split_csv_lines(lines[layout.first_data_line - 1:], layout.delimiter)
    # a line csv cannot split (None) is corrupt, a blank one is skipped
    rows_all = [[f.strip() for f in r] if r is not None else None for r in split]
    rows_line = np.arange(layout.first_data_line, layout.first_data_line + len(rows_all))
    keep_nonblank = np.fromiter((r is None or (bool(r) and any(r)) for r in rows_all), dtype=bool,
                                count=len(rows_all))
    rows = [r for r, k in zip(rows_all, keep_nonblank, strict=True) if k]
    rows_line = rows_line[keep_nonblank]
    if not rows:
        raise InputError(p, f"no data rows from line {layout.first_data_line}")
    # without a header, a row has the number of fields most rows have (the first may be damaged)
    n_fields = len(header) if header is not None else Counter(
        len(r) for r in rows[:1000] if r is not None).most_common(1)[0][0] if any(
        r is not None for r in rows[:1000]) else 0
    where = f"{p}:{layout.header_line or layout.first_data_line}"
    index = resolve_columns(header, n_fields, layout, where)
    good = np.fromiter((r is not None and len(r) == n_fields for r in rows), dtype=bool, count=len(rows))
    frame = pd.DataFrame([r for r, g in zip(rows, good, strict=True) if g], dtype=object)
    time = parse_times(frame[index["time"]] if len(frame) else [], layout.time_kind, layout.utc_offset_hours)
    t_ok = ~np.isnat(time)
    line_good = rows_line[good]
    bad_lines = np.sort(np.concatenate([rows_line[~good], line_good[~t_ok]]))
    if bad_lines.size > max_corrupt_fraction * len(rows):
        raise InputError(f"{p}:{int(bad_lines[0])}", f"{bad_lines.size} of {len(rows)} data rows corrupt "
                         f"(> {100 * max_corrupt_fraction:g} %): not {n_fields} fields or a {layout.time_kind} time "
                         f"that does not parse; first at lines {bad_lines[:_N_LOGGED].tolist()}")
    values: dict[str, np.ndarray] = {}
    n_nonnumeric = 0
    for var, m in layout.variables.items():
        v, nonnum = _numeric(frame.loc[t_ok, index[var]])
        n_nonnumeric += int(nonnum.sum())
        values[var] = to_si(v, m)
    return DelimitedTable(time[t_ok], values, line_good[t_ok], len(rows), int(bad_lines.size), n_nonnumeric,
                          bad_lines[:_N_LOGGED].tolist(), gz_problem)


def check_delimited_head(path: str | os.PathLike[str], layout: DelimitedLayout, n_rows: int = 5) -> None:
    """Check the first lines of a file against its mapping, before any job runs.

    Parameters
    ----------
    path : str or Path
        The file.
    layout : DelimitedLayout
    n_rows : int
        Data rows checked.

    Raises
    ------
    InputError
        ``<file>:<line>``: compression that contradicts the first bytes, too few lines, a
        mapped column absent from the header (naming the column and quoting the header
        found), a row with another number of fields than the header, a time that does not
        parse as ``layout.time_kind``, or a mapped value that is not a number.
    """
    p = Path(path)
    lines = read_text_lines(p, layout.compression, n=layout.first_data_line - 1 + n_rows)
    header, rows = _header_and_rows(p, lines, layout)
    if not rows:
        raise InputError(p, f"no data rows from line {layout.first_data_line}")
    n_fields = len(header) if header is not None else len(rows[0])
    index = resolve_columns(header, n_fields, layout, f"{p}:{layout.header_line or layout.first_data_line}")
    for k, row in enumerate(rows):
        line = layout.first_data_line + k
        if len(row) != n_fields:
            basis = f"the header line {layout.header_line}" if header is not None else f"line {layout.first_data_line}"
            raise InputError(f"{p}:{line}", f"{len(row)} fields, expected {n_fields} (as {basis}; delimiter "
                             f"{layout.delimiter!r})")
        t = parse_times([row[index["time"]]], layout.time_kind, layout.utc_offset_hours)
        if np.isnat(t[0]):
            shown = row[index["time"]][:40]
            expected = {"iso": "an ISO 8601 date and time (e.g. 2012-06-07 12:45:00.05 or 2023-04-19T14:10:05Z)",
                        "epoch_s": "seconds since 1970-01-01 UTC (a number)",
                        "epoch_ms": "milliseconds since 1970-01-01 UTC (a number)"}[layout.time_kind]
            raise InputError(f"{p}:{line}", f"time column {layout.time_column!r} holds {shown!r}, expected "
                             f"{expected}")
        for var in layout.variables:
            field = row[index[var]]
            if re.fullmatch(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", field) is None \
                    and field.upper() not in _NAN_LITERALS:
                raise InputError(f"{p}:{line}", f"column {layout.variables[var].column!r} of {var} holds "
                                 f"{field[:40]!r}, expected a number (or NAN)")
