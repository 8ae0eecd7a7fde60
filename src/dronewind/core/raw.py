"""L0 records held in memory: the columns a reader would parse from a raw file.

The forward model of the diagnosis simulates a flight many times (a baseline and every
probe of every mechanism). Writing each run's raw files as text and parsing them back costs
far more than the simulation itself, so the simulator can hand the chain a
:class:`RawRecord` instead: for every column exactly the values (and dtypes) that the
file's reader would have parsed from the text the simulator's writer prints (the same
rounding, the same rows in the same order with their defects, ``NaT`` for an empty UTC
field, ``NaN`` for a ``"NAN"``). The chain's L0 readers
(:func:`dronewind.payload.reader.read_sonic_csv`, :func:`dronewind.payload.reader.read_ins_csv`,
:func:`dronewind.mast.level1.mast_l1`) accept either a path or a record and then run the
same cleaning, QC and clock steps, so the L1 of a record equals the L1 of the file the
simulator would have written (tested by a round trip through the files).

A record has no corrupt text lines (those exist only in files); its rows are numbered as
the file's data lines would be (``first_line`` for the first row).
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import PurePath

import numpy as np

from dronewind.errors import InputError

__all__ = ["RawRecord", "content_digest"]


def content_digest(arrays: Mapping[str, object], prefix: str = "") -> str:
    """SHA-256 digest of named arrays' content: names, dtypes, shapes and bytes [hex].

    Equal digests mean equal names and bit-identical arrays (object arrays by their
    ``repr``). The arrays' memory is hashed in place, without a copy; with the processors'
    SHA instructions that is about twice as fast as BLAKE2b of a copy. It keys what is remembered across runs
    and processes: the measured atmosphere of a true state and the simulated field's
    coherence factors (within one forward flight, products and steps are found by comparing
    their inputs instead: :mod:`dronewind.core.reuse`).

    Parameters
    ----------
    arrays : mapping of str to array-like
        Named arrays, hashed in the mapping's order.
    prefix : str
        Text hashed first (e.g. scalar settings the arrays go with).

    Returns
    -------
    str
        64 hexadecimal digits.
    """
    h = hashlib.sha256(prefix.encode())
    for name, values in arrays.items():
        arr = np.ascontiguousarray(values)
        h.update(f"{name}:{arr.dtype.str}:{arr.shape}".encode())
        h.update(arr.view(np.uint8).data if arr.dtype.kind != "O" else repr(arr.tolist()).encode())
    return h.hexdigest()


@dataclass(frozen=True)
class RawRecord:
    """One raw file's content as parsed columns.

    Attributes
    ----------
    source : str
        Path of the file the record stands for (used in messages and provenance).
    columns : mapping of str to numpy.ndarray
        The file's columns in file order, one value per data row in row order (as
        logged: duplicates, late rows and out-of-range values included).
    units : mapping of str to str
        Units line of the file, where the format has one (TOA5), else empty.
    first_line : int
        File line number of the first data row (2 after a one-line header, 5 after a
        TOA5 header).
    meta : mapping of str to str
        Header fields that carry no data (e.g. the TOA5 ``table`` name).
    """

    source: str
    columns: Mapping[str, np.ndarray]
    units: Mapping[str, str] = field(default_factory=dict)
    first_line: int = 2
    meta: Mapping[str, str] = field(default_factory=dict)

    @property
    def name(self) -> str:
        """File name of the record (the last part of :attr:`source`)."""
        return PurePath(self.source).name

    @property
    def n_rows(self) -> int:
        """Number of data rows."""
        return int(next(iter(self.columns.values())).size) if self.columns else 0

    def __str__(self) -> str:
        return self.source

    def line_numbers(self) -> np.ndarray:
        """File line number of every row [1]."""
        return np.arange(self.first_line, self.first_line + self.n_rows)

    def checked(self, expected: Sequence[str], dtypes: Mapping[str, str]) -> dict[str, np.ndarray]:
        """The columns, checked against a reader's expectation.

        Parameters
        ----------
        expected : sequence of str
            Column names in file order.
        dtypes : mapping of str to str
            numpy dtype kind per column (``"i"`` integer, ``"f"`` float, ``"M"`` datetime64).

        Returns
        -------
        dict of numpy.ndarray
            The columns (datetimes as datetime64[ns]).

        Raises
        ------
        InputError
            Other column names, unequal lengths, no rows, or a dtype of another kind.
        """
        names = list(self.columns)
        if names != list(expected):
            raise InputError(self.source, f"in-memory record has columns {names}; expected {list(expected)}")
        sizes = {np.asarray(v).size for v in self.columns.values()}
        if len(sizes) != 1 or 0 in sizes:
            raise InputError(self.source, f"in-memory record has column lengths {sorted(sizes)}; expected one "
                             "common length > 0")
        out: dict[str, np.ndarray] = {}
        for name in expected:
            arr = np.asarray(self.columns[name])
            kind = dtypes[name]
            if arr.dtype.kind != kind:
                raise InputError(f"{self.source}: {name}", f"dtype {arr.dtype} in the in-memory record; expected "
                                 f"kind {kind!r}")
            if kind == "M":
                arr = arr.astype("datetime64[ns]")
            out[name] = arr
        return out
