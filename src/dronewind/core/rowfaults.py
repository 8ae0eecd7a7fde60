"""Row-level logger faults shared by the text readers: lines split one by one, gzip read as far as it goes.

A logger that loses power while writing leaves a line cut short (a quoted field that never
closes, a line without its line end); an SD card leaves a block of NUL bytes or garbage;
a copy stopped early leaves a gzip member without its end. Each such fault must cost the
rows it damaged and nothing more:

* :func:`split_csv_lines` splits text lines into fields like :class:`csv.reader`, but never
  lets one line's unclosed quote swallow the lines after it (``csv.reader`` would join them
  into one row, so the rows no longer match the lines), and turns a line ``csv.reader``
  refuses (a field beyond its size limit) into ``None`` (a corrupt line) instead of an
  exception;
* :func:`gunzip_readable` decompresses the gzip members of a file as far as they are
  readable and says where and why it stopped, so that a truncated or damaged member costs
  only its unreadable tail.

Hand-written around the standard library (``csv``, ``zlib``) because neither gives the
per-line or per-byte accounting a reader needs to name the damaged lines.
"""

from __future__ import annotations

import csv
import gzip
import zlib
from collections.abc import Sequence

_GZIP_STEP = 256  # compressed bytes per step of a damaged stream

__all__ = ["gunzip_readable", "split_csv_line", "split_csv_lines", "text_lines"]


def text_lines(raw: bytes) -> list[str]:
    """The lines of a logger's text file: split at ``\\n``, ``\\r\\n`` and ``\\r`` only.

    Parameters
    ----------
    raw : bytes
        The file's content.

    Returns
    -------
    list of str
        UTF-8 text (undecodable bytes replaced, leading byte order marks dropped), one
        entry per line; a final line end does not open an empty line.

    Notes
    -----
    A logger ends its lines with ``\\n``, ``\\r\\n`` or (old Mac text) ``\\r``. Other
    bytes that :meth:`str.splitlines` takes for line breaks (``\\v``, ``\\f``,
    ``\\x1c``-``\\x1e``, NEL, LS, PS) turn up in a file only inside garbage (a damaged SD
    card sector); splitting there would make one damaged line several and move the
    numbers of every line after it, so they stay inside their line, which is then
    corrupt. An invalid UTF-8 sequence never swallows a ``\\n`` when replaced.
    """
    text = raw.decode("utf-8", errors="replace").lstrip("\ufeff")
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    lines = text.split("\n")
    if lines[-1] == "":
        lines.pop()
    return lines


def split_csv_line(line: str, delimiter: str = ",") -> list[str] | None:
    """Fields of one line on its own (an unclosed quote ends with the line), or None if csv refuses it.

    Parameters
    ----------
    line : str
        One text line.
    delimiter : str
        One character.

    Returns
    -------
    list of str or None
    """
    try:
        rows = list(csv.reader([line], delimiter=delimiter))
    except csv.Error:
        return None
    return rows[0] if rows else []


def split_csv_lines(lines: Sequence[str], delimiter: str = ",") -> list[list[str] | None]:
    """Fields of every line, one list per line, as ``csv.reader`` splits a well-formed line.

    Parameters
    ----------
    lines : sequence of str
        Text lines without line ends (e.g. ``str.splitlines``).
    delimiter : str
        One character.

    Returns
    -------
    list
        One entry per line: its fields (double quotes honoured; an empty line gives
        ``[]``), or None for a line ``csv.reader`` cannot split (a field beyond
        :func:`csv.field_size_limit`). A quoted field never continues on the next line:
        the lines of a row that ``csv.reader`` would join are split one by one, so a line
        cut short inside a quote is one corrupt line and the line after it is read as it is.

    Notes
    -----
    Fast for the common file: one ``csv.reader`` pass, checking per row that it took one
    line (:attr:`csv.reader.line_num`); only rows that took more, and lines where the
    reader stopped with an error, are split again on their own.
    """
    out: list[list[str] | None] = []
    n = len(lines)
    pos = 0
    while pos < n:
        reader = csv.reader(iter(lines[pos:]) if pos else iter(lines), delimiter=delimiter)
        done = 0  # lines of this pass accounted for in `out`
        try:
            for row in reader:
                span = reader.line_num - done
                if span == 1:
                    out.append(row)
                else:  # an unclosed quote joined lines: each one on its own
                    out.extend(split_csv_line(lines[pos + k], delimiter) for k in range(done, reader.line_num))
                done = reader.line_num
            pos = n
        except csv.Error:
            stop = max(reader.line_num, done + 1)
            out.extend(split_csv_line(lines[pos + k], delimiter) for k in range(done, stop))
            pos += stop
    return out


def gunzip_readable(raw: bytes) -> tuple[bytes, str | None]:
    """The decompressed content of gzip data as far as it is readable.

    Parameters
    ----------
    raw : bytes
        gzip data: one or more members (``1f 8b ...``).

    Returns
    -------
    data : bytes
        The content of every member up to the first byte that cannot be decompressed.
    problem : str or None
        None for intact data; else where it stopped and why (``"gzip data end before the
        end of its member (truncated) after 1234 bytes of content"``, ``"corrupt gzip data
        ..."``). The last line of ``data`` may then be cut short: the reader counts it as
        it counts any line cut short.
    """
    try:
        return gzip.decompress(raw), None  # the intact stream in one call
    except (OSError, EOFError, zlib.error):
        pass
    parts: list[bytes] = []
    rest = raw
    n_member = 0
    while rest:
        d = zlib.decompressobj(wbits=31)  # 31: a gzip header and trailer
        for k in range(0, len(rest), _GZIP_STEP):  # in small steps: an error loses only its step's output
            try:
                parts.append(d.decompress(rest[k:k + _GZIP_STEP]))
            except zlib.error as exc:
                got = sum(len(p) for p in parts)
                return b"".join(parts), (f"corrupt gzip data in member {n_member + 1} ({exc}); "
                                         f"{got} bytes of content read before it")
            if d.eof:
                break
        if not d.eof:
            got = sum(len(p) for p in parts)
            return b"".join(parts), (f"gzip member {n_member + 1} ends before its end marker (truncated); "
                                     f"{got} bytes of content read")
        n_member += 1
        rest = d.unused_data + rest[k + _GZIP_STEP:]
        if rest and not rest.startswith(b"\x1f\x8b"):
            if rest.strip(b"\x00"):  # padding NULs after the last member are harmless
                got = sum(len(p) for p in parts)
                return b"".join(parts), (f"{len(rest)} bytes after gzip member {n_member} that are not gzip "
                                         f"data; {got} bytes of content read")
            break
    return b"".join(parts), None
