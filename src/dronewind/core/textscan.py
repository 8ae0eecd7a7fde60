"""The byte-level scan shared by the raw-text readers (payload CSVs, quadrotor CSV, TOA5, AmeriFlux gold).

Each reader has one parser: :func:`text_body` splits the file's bytes into lines as
:func:`dronewind.core.rowfaults.text_lines` does, the scan finds the regular lines (plain
bytes, one field per column, values of a form proven to convert alike) and converts them
in bulk (``pandas.read_csv``'s C engine for the numbers, :func:`fixed_width_times` for time
stamps), and every other line is decoded and handed with its line number to the reader's
line-by-line fault handling, whose rows are joined back in line order. A file with a few
bad rows among a million thus keeps the speed of the scan, and names its bad lines as
the fault handling does.

The helpers are written by hand because no library call proves what the scan must prove
of a line before converting it in bulk: that the fault handling would split it into the
same fields and convert every value to the same bits. Converting every line one by one
costs 5 to 15 times as much CPU (400,000 rows: 2.3 s against 0.25 s for TOA5, 3.8 s
against 0.6 s for an INS CSV, 4 s against 0.3 s for the quadrotor CSV).

Facts the scan relies on (checked by ``tests/core/test_parsing_fast.py``):

* Splitting the bytes at ``\\n`` (after ``\\r\\n`` and ``\\r`` are turned into ``\\n``) gives
  the lines of the decoded text; invalid UTF-8 decoded with ``errors="replace"`` never
  swallows a line end, so a line's text is the decoding of its bytes.
* ``pandas.to_numeric`` (the fault handling) is not always correctly rounded (it scales by
  inexact powers of ten beyond 1e22 and keeps 17 digits), ``pandas.read_csv`` is. A decimal
  literal of at most 15 characters without exponent has at most 15 digits and at most 15
  decimals: both parsers then compute one correctly rounded division or product of exact
  doubles, so they agree bit for bit. Longer fields and fields with an exponent go to the
  fault handling.
"""

from __future__ import annotations

import io
import itertools

import numpy as np
import pandas as pd

__all__ = [
    "FLOAT_FAST_MAX_CHARS",
    "NAN_LITERALS",
    "PLAIN_CSV",
    "PRINTABLE_LINES",
    "comma_grid",
    "fixed_width_times",
    "line_bounds",
    "lines_holding",
    "read_numeric_columns",
    "first_line",
    "float_fields",
    "int_fields",
    "kept_lines",
    "line_text",
    "lines_with",
    "text_body",
]

_BOM = b"\xef\xbb\xbf"
_PRINTABLE = bytes(range(0x20, 0x7F)) + b"\n"
PRINTABLE_LINES = _PRINTABLE  # printable ASCII and the line end: the bytes of a plain text
FLOAT_FAST_MAX_CHARS = 15  # longest float field parsed by read_csv (see the module docstring)
NAN_LITERALS: tuple[str, ...] = tuple(
    sign + "".join(chars) for sign in ("", "+", "-") for chars in itertools.product("nN", "aA", "nN")
)  # every spelling the fault handling accepts as a NaN literal (case-insensitive nan, +nan, -nan)


#: Bytes of a plain line of a comma-separated file: printable ASCII except the quote (read_csv
#: would unquote, the line-by-line split keeps it) and the space (the fault handling strips it,
#: read_csv may not).
PLAIN_CSV = bytes(b for b in range(0x21, 0x7F) if b != ord('"'))


def line_bounds(buf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end (exclusive, without the ``\\n``) byte offsets of the lines of `buf`.

    Parameters
    ----------
    buf : numpy.ndarray
        uint8 bytes.

    Returns
    -------
    starts, ends : numpy.ndarray
        int64 offsets; like ``str.splitlines``, a final ``\\n`` does not open an empty line.
    """
    nl = np.flatnonzero(buf == 10)
    starts = np.concatenate([[0], nl + 1])
    ends = np.concatenate([nl, [buf.size]])
    if starts[-1] == buf.size:
        starts, ends = starts[:-1], ends[:-1]
    return starts, ends


def lines_holding(raw: bytes, buf: np.ndarray, starts: np.ndarray, allowed: bytes, unusual: bool) -> np.ndarray:
    """Mask of the lines holding a byte not in `allowed` (``\\n`` always allowed).

    Parameters
    ----------
    raw : bytes
        The text (the same bytes as `buf`).
    buf : numpy.ndarray
        uint8 view of `raw`.
    starts : numpy.ndarray
        Line start offsets (:func:`line_bounds`).
    allowed : bytes
        Printable ASCII bytes a plain line may hold.
    unusual : bool
        `raw` holds bytes other than printable ASCII and ``\\n`` (:func:`line_safe_bytes`).

    Returns
    -------
    numpy.ndarray
        bool, one per line.
    """
    odd = np.zeros(starts.size, dtype=bool)
    banned = bytes(b for b in _PRINTABLE if b not in allowed + b"\n")
    if not unusual and not (any(bytes([b]) in raw for b in banned) if len(banned) <= 4  # memchr per banned byte
                            else raw.translate(None, allowed + b"\n")):  # else one pass deleting the allowed ones
        return odd
    lut = np.ones(256, dtype=bool)
    lut[np.frombuffer(allowed + b"\n", dtype=np.uint8)] = False
    pos = np.flatnonzero(lut[buf])
    odd[np.searchsorted(starts, pos, side="right") - 1] = True
    return odd


def read_numeric_columns(buf: bytes, names: list[str], usecols: list[str], nan_columns: dict[str, tuple[str, ...]],
                         quoting: bool) -> pd.DataFrame:
    """``pandas.read_csv`` (C engine) of plain comma-separated lines, without NaN guessing.

    Parameters
    ----------
    buf : bytes
        Lines with exactly ``len(names)`` fields each, no blank line.
    names : list of str
        Field names.
    usecols : list of str
        Fields to read.
    nan_columns : dict
        Field -> the strings read as NaN in it; no other string becomes NaN (an empty
        field stays text, so its column comes back as text).
    quoting : bool
        Unquote ``"..."`` fields (TOA5); else quotes must not occur in `buf`.

    Returns
    -------
    pandas.DataFrame
        int64 or float64 for columns whose every field is a number, else text.
    """
    return pd.read_csv(
        io.BytesIO(buf), header=None, names=names, usecols=usecols, index_col=False, engine="c",
        low_memory=False, na_filter=True, keep_default_na=False, na_values={k: list(v) for k, v in nan_columns.items()},
        quoting=0 if quoting else 3, skip_blank_lines=False,
    )  # fmt: skip


_DAYS_IN_MONTH = np.array([0, 31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31])


def _number(digits: dict[int, np.ndarray], first: int, stop: int) -> np.ndarray:
    """Integer of the decimal digit columns ``first`` to ``stop - 1``."""
    value = digits[first]
    for j in range(first + 1, stop):
        value = value * 10 + digits[j]
    return value


def _days_from_civil(year: np.ndarray, month: np.ndarray, day: np.ndarray) -> np.ndarray:
    """Days since 1970-01-01 of proleptic Gregorian dates (H. Hinnant's algorithm; years >= 1)."""
    y = year - (month <= 2)
    era = y // 400
    yoe = y - era * 400
    doy = (153 * ((month + 9) % 12) + 2) // 5 + day - 1
    return era * 146097 + yoe * 365 + yoe // 4 - yoe // 100 + doy - 719468


def fixed_width_times(buf: np.ndarray, start: np.ndarray, length: np.ndarray, sep: bytes, suffix: bytes = b""
                      ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Vectorised parse of ``YYYY-MM-DD?HH:MM:SS[.f...]`` time stamps at byte offsets of `buf`.

    Hand-written because the stamps sit inside the lines (no ``datetime64`` string array to
    convert) and because every stamp must be proven to be read as the fault handling reads
    it: each one is checked against the fixed pattern of its length, and only those are
    converted (date and time digits by one matrix product, exact in float64).

    Parameters
    ----------
    buf : numpy.ndarray
        uint8 bytes.
    start, length : numpy.ndarray
        Offset and length of every time stamp (with `suffix`).
    sep : bytes
        Byte between date and time (``b"T"`` or ``b" "``).
    suffix : bytes, optional
        Required trailing bytes (``b"Z"``).

    Returns
    -------
    times : numpy.ndarray
        datetime64[ns] (NaT where not parsed).
    ok : numpy.ndarray
        True where the stamp has exactly this form with 0 to 9 decimals, a real calendar
        date of the years 1900-2199 and a time of day below 24:00:00 (the fault handling
        reads every such stamp to the same instant; the others are left to it).
    """
    ns = np.zeros(start.size, dtype=np.int64)
    ok = np.zeros(start.size, dtype=bool)
    core = length - len(suffix)
    counts = np.bincount(np.clip(core, 0, 30), minlength=31)
    windows = np.lib.stride_tricks.sliding_window_view(buf, 30 + len(suffix)) if buf.size >= 30 + len(suffix) \
        else None  # fmt: skip
    for n in [19, *range(21, 30)]:
        if counts[n] == 0:
            continue
        rows = np.flatnonzero(core == n)
        width = n + len(suffix)
        if windows is not None and int(start[rows].max()) < windows.shape[0]:
            mat = windows[start[rows], :width]
        else:
            mat = buf[start[rows, None] + np.arange(width)]
        pattern = b"0000-00-00" + sep + b"00:00:00" + (b"." + b"0" * (n - 20) if n > 19 else b"") + suffix
        good = np.ones(rows.size, dtype=bool)
        digits: dict[int, np.ndarray] = {}
        for j, ch in enumerate(pattern):  # column by column: fast on the long axis
            if ch == ord("0"):
                digits[j] = mat[:, j].astype(np.int64) - 48
                good &= (digits[j] >= 0) & (digits[j] <= 9)
            else:
                good &= mat[:, j] == ch
        year, month, day = _number(digits, 0, 4), _number(digits, 5, 7), _number(digits, 8, 10)
        hour, minute, second = _number(digits, 11, 13), _number(digits, 14, 16), _number(digits, 17, 19)
        frac_ns = _number(digits, 20, n) * 10 ** (29 - n) if n > 19 else np.zeros(rows.size, dtype=np.int64)
        leap = (year % 4 == 0) & ((year % 100 != 0) | (year % 400 == 0))
        month_days = _DAYS_IN_MONTH[np.clip(month, 0, 12)] + ((month == 2) & leap)
        good &= (year >= 1900) & (year <= 2199) & (month >= 1) & (month <= 12) & (day >= 1) & (day <= month_days)
        good &= (hour <= 23) & (minute <= 59) & (second <= 59)
        secs = ((_days_from_civil(year, month, day) * 24 + hour) * 60 + minute) * 60 + second
        ns[rows] = secs * 1_000_000_000 + frac_ns
        ok[rows] = good
    times = np.where(ok, ns, np.iinfo(np.int64).min).astype("datetime64[ns]")
    return times, ok


def comma_grid(commas: np.ndarray, starts: np.ndarray, ends: np.ndarray, candidate: np.ndarray, ncol: int,
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lines with ``ncol - 1`` commas among the `candidate` lines, and their comma offsets.

    Parameters
    ----------
    commas : numpy.ndarray
        Sorted byte offsets of all commas.
    starts, ends : numpy.ndarray
        Line bounds (:func:`line_bounds`).
    candidate : numpy.ndarray
        Lines that may count (bool).
    ncol : int
        Expected fields per line.

    Returns
    -------
    rows : numpy.ndarray
        Indices of those lines.
    cpos : numpy.ndarray
        (rows.size, ncol - 1) byte offsets of their commas.
    first_comma : numpy.ndarray
        Index in `commas` of the first comma at or after the start of every line.
    """
    if candidate.all() and commas.size == starts.size * (ncol - 1):  # the common file: one reshape
        cpos = commas.reshape(starts.size, ncol - 1)
        if ncol == 1 or (bool((cpos[:, 0] >= starts).all()) and bool((cpos[:, -1] < ends).all())):
            return np.arange(starts.size), cpos, np.arange(starts.size) * (ncol - 1)
    first_comma = np.searchsorted(commas, starts)
    rows = np.flatnonzero(candidate & (np.searchsorted(commas, ends) - first_comma == ncol - 1))
    return rows, commas[first_comma[rows, None] + np.arange(ncol - 1)], first_comma




def text_body(raw: bytes, n_header: int) -> tuple[list[str], bytes, np.ndarray, np.ndarray, np.ndarray, bool]:
    """The lines of a logger's text file as :func:`dronewind.core.rowfaults.text_lines` splits them.

    The header lines are decoded; the lines after them are given as byte offsets, so that a
    reader converts its regular lines in bulk and decodes only the irregular ones (one
    line's text is the UTF-8 decoding of its bytes, undecodable bytes replaced: a replaced
    sequence never swallows a line end).

    Parameters
    ----------
    raw : bytes
        The file's content.
    n_header : int
        Header lines (fewer when the file is shorter).

    Returns
    -------
    header : list of str
        The header lines found.
    body : bytes
        The lines after them: leading byte order marks dropped, ``\\r\\n`` and ``\\r``
        turned into ``\\n``.
    buf : numpy.ndarray
        uint8 view of `body`.
    starts, ends : numpy.ndarray
        Line bounds in `body` (:func:`line_bounds`).
    unusual : bool
        `body` holds a byte other than printable ASCII and ``\\n``.
    """
    while raw.startswith(_BOM):
        raw = raw[len(_BOM):]
    if b"\r" in raw:
        raw = raw.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    header: list[str] = []
    cut = 0
    while len(header) < n_header and cut < len(raw):
        end = raw.find(b"\n", cut)
        end = len(raw) if end < 0 else end
        header.append(raw[cut:end].decode("utf-8", errors="replace"))
        cut = end + 1
    body = raw[cut:]
    buf = np.frombuffer(body, dtype=np.uint8)
    starts, ends = line_bounds(buf)
    return header, body, buf, starts, ends, bool(body.translate(None, _PRINTABLE))


def line_text(raw: bytes, starts: np.ndarray, ends: np.ndarray, lines: np.ndarray) -> list[str]:
    """The decoded text of the lines `lines` (indices into `starts`, `ends`)."""
    return [raw[starts[i]:ends[i]].decode("utf-8", errors="replace") for i in lines.tolist()]


def lines_with(raw: bytes, buf: np.ndarray, starts: np.ndarray, chars: bytes) -> np.ndarray:
    """Mask of the lines holding one of the bytes `chars` (one memchr per byte when none occurs)."""
    out = np.zeros(starts.size, dtype=bool)
    if not any(bytes([c]) in raw for c in chars):
        return out
    hit = np.zeros(buf.size, dtype=bool)
    for c in chars:
        hit |= buf == c
    out[np.searchsorted(starts, np.flatnonzero(hit), side="right") - 1] = True
    return out


def int_fields(buf: np.ndarray, start: np.ndarray, end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vectorised parse of integer literals ``[+-]?[0-9]+`` at byte spans of `buf`.

    For an integer column that ``read_csv`` did not read as int64 (a field of another form
    in some line): the fields of this form are converted here, exactly as Python's ``int``
    converts them (up to 18 digits), and the others are left to the reader's line-by-line
    fault handling.

    Parameters
    ----------
    buf : numpy.ndarray
        uint8 bytes.
    start, end : numpy.ndarray
        Field spans.

    Returns
    -------
    values : numpy.ndarray
        int64 (0 where not parsed).
    ok : numpy.ndarray
        True where the field is such a literal.
    """
    length = end - start
    signed = (length >= 2) & np.isin(buf[np.minimum(start, buf.size - 1)], (ord("+"), ord("-")))
    first = start + signed
    n_dig = end - first
    ok = (length >= 1) & (n_dig >= 1) & (n_dig <= 18)
    value = np.zeros(start.size, dtype=np.int64)
    for k in range(int(n_dig[ok].max()) if ok.any() else 0):
        inside = ok & (k < n_dig)
        d = buf[np.minimum(first + k, buf.size - 1)].astype(np.int64) - 48
        ok &= ~inside | ((d >= 0) & (d <= 9))
        value = np.where(inside, value * 10 + d, value)
    neg = signed & (buf[np.minimum(start, buf.size - 1)] == ord("-"))
    return np.where(ok, np.where(neg, -value, value), 0), ok


def float_fields(values: pd.Series, length: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """float64 of a column as ``read_csv`` read it, and where that value is the fault handling's bit for bit.

    Parameters
    ----------
    values : pandas.Series
        The column of :func:`read_numeric_columns` (numbers, NaN from a NaN literal, or text
        when some field is not a number).
    length : numpy.ndarray
        Characters of every field.

    Returns
    -------
    values : numpy.ndarray
        float64.
    ok : numpy.ndarray
        True where the field is a finite number of at most :data:`FLOAT_FAST_MAX_CHARS`
        characters or a NaN literal; the other lines are left to the line-by-line fault
        handling (lines holding an exponent are left to it by the caller).
    """
    if values.dtype in (np.float64, np.int64):
        vals = values.to_numpy(dtype=float)
        ok = ~np.isinf(vals)
    else:  # text in some field: each field converted as the fault handling converts it
        vals = pd.to_numeric(values, errors="coerce").to_numpy(dtype=float)
        ok = ~np.isinf(vals) & ~(np.isnan(vals) & ~values.isna().to_numpy(dtype=bool))
    return vals, ok & (length <= FLOAT_FAST_MAX_CHARS)


def kept_lines(raw: bytes, starts: np.ndarray, keep: np.ndarray) -> bytes:
    """The lines `keep` (bool, one per line) of `raw` with their line ends, as one text.

    Copied run by run of consecutive kept lines: a few irregular lines among a million
    cost a few slices, not a pass over every byte.
    """
    if keep.all():
        return raw
    bounds = np.append(starts, len(raw))
    edge = np.diff(np.concatenate([[0], keep.astype(np.int8), [0]]))
    first, stop = np.flatnonzero(edge == 1), np.flatnonzero(edge == -1)
    return b"".join(raw[a:b] for a, b in zip(bounds[first].tolist(), bounds[stop].tolist(), strict=True))


def first_line(raw: bytes) -> str | None:
    """The first line of a text file as :func:`text_body` gives it, without scanning the rest; None when empty."""
    while raw.startswith(_BOM):
        raw = raw[len(_BOM):]
    if not raw:
        return None
    ends = [k for k in (raw.find(b"\n"), raw.find(b"\r")) if k >= 0]
    end = min(ends) if ends else len(raw)
    return raw[:end].decode("utf-8", errors="replace")
