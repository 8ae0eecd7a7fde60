r"""Sling-load payload files in one's own layout: a manifest's column mapping to the contract tables.

The payload chain reads a sonic file and an INS file that share a logger clock (``docs/data-contract.md``
"Payload sonic file" and "INS file"). Files logged otherwise are declared in the manifest
with ``format: {name: delimited, ...}``, the mapping of :mod:`dronewind.core.delimited`
(layout, per-variable column, scale, offset and unit) extended to what the payload needs,
and converted here to the contract's columns as an in-memory record
(:class:`dronewind.core.raw.RawRecord`), which :mod:`dronewind.payload.reader` then cleans,
checks and turns into L1 exactly as it does a contract file:

* the **logger clock** shared by the two files (``time``): ``kind`` ``clock_s``,
  ``clock_ms`` or ``clock_us`` (a counter of the logger, any origin), or ``iso``,
  ``epoch_s``, ``epoch_ms`` when the logger stamps UTC itself; it becomes ``rpi_time_us``
  (integer microseconds, rounded to the nearest);
* the **sonic**: ``variables`` ``u``, ``v``, ``w`` (velocity units) and ``t`` (``degC``
  or ``K``), and ``axes``: each contract component (``u``, ``v``, ``w``, the frame of the
  SAMURAI-S sonic that ``mount`` refers to) as a signed logged component, e.g.
  ``{u: v, v: u, w: -w}`` for a sonic whose axes are swapped and whose w points down;
* the **INS**: ``utc`` (``column``, ``kind`` ``iso``/``epoch_s``/``epoch_ms``,
  ``utc_offset_hours``): GNSS UTC, empty or unparsable where there is none yet; ``variables``
  ``lat``, ``lon`` (``degree``/``rad``), ``alt`` (``m`` above mean sea level), the velocity
  over ground as ``vel_n``, ``vel_e``, ``vel_d`` or ``vel_e``, ``vel_n``, ``vel_u``,
  ``roll``, ``pitch``, ``yaw`` (``degree``/``rad``, aerospace z-y-x Euler angles, yaw
  clockwise from true north) and, optionally, ``time_valid`` and ``ekf_valid`` (non-zero:
  valid; default: valid where ``utc`` parses, and always valid).

Rows whose logger time does not parse and rows with another number of fields are corrupt:
removed and counted (``n_corrupt_lines``, their first line numbers in the processing log), as
for a contract file; a value that is not a number becomes NaN and is flagged by the QC of L1.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from dronewind.core.columns import INS_COLUMNS, SONIC_COLUMNS
from dronewind.core.constants import ZERO_CELSIUS_K
from dronewind.core.delimited import DelimitedLayout, DelimitedTable, delimited_layout, read_delimited
from dronewind.core.raw import RawRecord
from dronewind.errors import InputError

__all__ = ["MappedRecord", "CLOCK_KINDS", "sonic_layout", "ins_layouts", "sonic_record", "ins_record",
           "payload_source"]

#: Logger-clock kinds -> (kind :func:`dronewind.core.delimited.parse_times` reads the column
#: as, nanoseconds of that reading per logger microsecond). A counter is read as an epoch:
#: its integer and fraction parts are parsed exactly (a float would round a large counter).
CLOCK_KINDS: dict[str, tuple[str, int]] = {
    "clock_s": ("epoch_s", 1000), "clock_ms": ("epoch_ms", 1000), "clock_us": ("epoch_ms", 1_000_000),
    "iso": ("iso", 1000), "epoch_s": ("epoch_s", 1000), "epoch_ms": ("epoch_ms", 1000),
}
_SONIC_QUANTITIES = {"u": "m s-1", "v": "m s-1", "w": "m s-1", "t": "K"}
_INS_QUANTITIES = {"lat": "degree", "lon": "degree", "alt": "m", "vel_n": "m s-1", "vel_e": "m s-1",
                   "vel_d": "m s-1", "vel_u": "m s-1", "roll": "degree", "pitch": "degree", "yaw": "degree",
                   "time_valid": "1", "ekf_valid": "1"}
_SIGNED = {"u": ("u", 1.0), "-u": ("u", -1.0), "+u": ("u", 1.0), "v": ("v", 1.0), "-v": ("v", -1.0),
           "+v": ("v", 1.0), "w": ("w", 1.0), "-w": ("w", -1.0), "+w": ("w", 1.0)}


@dataclass(frozen=True)
class MappedRecord(RawRecord):
    """A payload file read by its manifest mapping, as the contract columns.

    Attributes
    ----------
    counts : mapping of str to int
        ``n_lines``, ``n_corrupt_lines``, ``n_blank_lines``, ``n_nonnumeric`` of the parsing.
    log : tuple of str
        Processing log lines of the parsing.
    lines : numpy.ndarray
        File line number of every row (corrupt lines removed leave gaps).
    """

    counts: Mapping[str, int] = field(default_factory=dict)
    log: tuple[str, ...] = ()
    lines: np.ndarray | None = None

    def line_numbers(self) -> np.ndarray:
        """File line number of every row [1]."""
        return np.asarray(self.lines) if self.lines is not None else super().line_numbers()


def _logger_layout(fmt: Mapping[str, Any], where: str, quantities: Mapping[str, str]) -> DelimitedLayout:
    """The mapping's layout with its logger-clock kind as the kind the time column is parsed as."""
    kind = str(fmt["time"]["kind"])
    if kind not in CLOCK_KINDS:
        raise InputError(f"{where}.time.kind", f"{kind!r}; expected one of {', '.join(CLOCK_KINDS)}")
    spec = {**fmt, "time": {**fmt["time"], "kind": CLOCK_KINDS[kind][0]}}
    layout = delimited_layout(spec, where, quantities)
    unknown = sorted(set(layout.variables) - set(quantities))
    if unknown:
        raise InputError(f"{where}.variables.{unknown[0]}", f"not a variable of this record; expected "
                         f"{', '.join(quantities)}")
    return layout


def sonic_layout(fmt: Mapping[str, Any], where: str = "sonic.format") -> DelimitedLayout:
    """The delimited layout of a payload sonic mapping (time column parsed as :data:`CLOCK_KINDS` says).

    Parameters
    ----------
    fmt : mapping
        The manifest's ``sonic.format`` (``name: delimited``).
    where : str
        Key path for messages.

    Returns
    -------
    DelimitedLayout
    """
    layout = _logger_layout(fmt, where, _SONIC_QUANTITIES)
    missing = [k for k in ("u", "v", "w", "t") if k not in layout.variables]
    if missing:
        raise InputError(f"{where}.variables", f"no {missing[0]}; expected u, v, w and t")
    return layout


def ins_layouts(fmt: Mapping[str, Any], where: str = "ins.format") -> tuple[DelimitedLayout, DelimitedLayout]:
    """The layouts of a payload INS mapping: logger clock and variables, and the GNSS UTC column.

    Parameters
    ----------
    fmt : mapping
        The manifest's ``ins.format`` (``name: delimited``).
    where : str
        Key path for messages.

    Returns
    -------
    main, utc : DelimitedLayout
        ``main`` reads the logger clock and the variables; ``utc`` the ``utc`` column as
        its time (rows without a UTC fail to parse there, which is what they mean).
    """
    layout = _logger_layout(fmt, where, _INS_QUANTITIES)
    have = set(layout.variables)
    need = {"lat", "lon", "alt", "roll", "pitch", "yaw"} - have
    if need:
        raise InputError(f"{where}.variables", f"no {sorted(need)[0]}; expected lat, lon, alt, roll, pitch, yaw "
                         "and vel_n, vel_e with vel_d or vel_u")
    if not {"vel_n", "vel_e"} <= have or len(have & {"vel_d", "vel_u"}) != 1:
        raise InputError(f"{where}.variables", "expected vel_n, vel_e and one of vel_d, vel_u")
    utc = fmt.get("utc")
    if not isinstance(utc, Mapping) or "column" not in utc or "kind" not in utc:
        raise InputError(f"{where}.utc", "expected {column, kind} of the GNSS UTC column")
    if str(utc["kind"]) not in ("iso", "epoch_s", "epoch_ms"):
        raise InputError(f"{where}.utc.kind", f"{utc['kind']!r}; expected iso, epoch_s or epoch_ms")
    utc_layout = replace(layout, time_column=utc["column"], time_kind=str(utc["kind"]), variables={},
                         utc_offset_hours=float(utc.get("utc_offset_hours", 0.0)))
    return layout, utc_layout


def _logger_us(table: DelimitedTable, kind: str) -> np.ndarray:
    """Logger times [us], rounded to the nearest, from the parsed time column."""
    per_us = CLOCK_KINDS[kind][1]
    ns = table.time.astype("datetime64[ns]").astype(np.int64)
    return np.floor_divide(ns + per_us // 2, per_us)


def _parse_record(path: Path, table: DelimitedTable, what: str) -> tuple[dict[str, int], tuple[str, ...]]:
    """Counts and log line of one mapped file (as the contract parser reports them)."""
    counts = {"n_lines": table.n_lines, "n_corrupt_lines": table.n_corrupt, "n_blank_lines": 0,
              "n_nonnumeric": table.n_nonnumeric}
    line = f"parse: {path.name} ({what} by its manifest mapping): {table.n_lines} data lines, {table.n_corrupt} " \
           "corrupt removed"
    if table.n_corrupt:
        line += f" (first at lines {table.corrupt_lines})"
    if table.n_nonnumeric:
        line += f", {table.n_nonnumeric} non-numeric values set to NaN"
    return counts, (line,)


def sonic_record(path: str | os.PathLike[str], fmt: Mapping[str, Any], where: str = "sonic.format",
                 max_corrupt_fraction: float = 0.05) -> MappedRecord:
    """A payload sonic file in its declared layout, as the contract sonic columns.

    Parameters
    ----------
    path : str or Path
        The sonic file.
    fmt : mapping
        The manifest's ``sonic.format`` (see the module docstring).
    where : str
        Key path for messages.
    max_corrupt_fraction : float
        Largest tolerated fraction of corrupt rows [1].

    Returns
    -------
    MappedRecord
        Columns ``rpi_time_us`` (int64), ``u_ms``, ``v_ms``, ``w_ms`` [m s-1] in the contract
        sensor frame (``axes`` applied) and ``t_sonic_c`` [degC], one per good row in file order.
    """
    p = Path(path)
    layout = sonic_layout(fmt, where)
    table = read_delimited(p, layout, max_corrupt_fraction)
    axes = fmt.get("axes") or {"u": "u", "v": "v", "w": "w"}
    comps = {}
    for name in ("u", "v", "w"):
        logged = str(axes.get(name, name)).replace(" ", "")
        if logged not in _SIGNED:
            raise InputError(f"{where}.axes.{name}", f"{logged!r}; expected a logged component u, v, w with an "
                             "optional sign (e.g. -w)")
        comp, sign = _SIGNED[logged]
        comps[name] = sign * table.values[comp] if sign != 1.0 else table.values[comp]
    if sorted(_SIGNED[str(axes.get(n, n)).replace(" ", "")][0] for n in "uvw") != ["u", "v", "w"]:
        raise InputError(f"{where}.axes", f"{dict(axes)}; expected each logged component once")
    columns = {"rpi_time_us": _logger_us(table, str(fmt["time"]["kind"])), "u_ms": comps["u"], "v_ms": comps["v"],
               "w_ms": comps["w"], "t_sonic_c": table.values["t"] - ZERO_CELSIUS_K}
    assert tuple(columns) == SONIC_COLUMNS
    counts, log = _parse_record(p, table, "payload sonic")
    return MappedRecord(source=str(path), columns=columns, first_line=layout.first_data_line,
                        counts=counts, log=log, lines=table.line_no)


def ins_record(path: str | os.PathLike[str], fmt: Mapping[str, Any], where: str = "ins.format",
               max_corrupt_fraction: float = 0.05) -> MappedRecord:
    """A payload INS file in its declared layout, as the contract INS columns.

    Parameters
    ----------
    path : str or Path
        The INS file.
    fmt : mapping
        The manifest's ``ins.format`` (see the module docstring).
    where : str
        Key path for messages.
    max_corrupt_fraction : float
        Largest tolerated fraction of corrupt rows [1] (rows whose logger time does not
        parse; a missing UTC is not corrupt).

    Returns
    -------
    MappedRecord
        The columns of :data:`dronewind.core.columns.INS_COLUMNS`: ``utc`` datetime64[ns]
        (NaT without one), ``time_valid`` 0 or 1, ``ekf_valid`` 0 or 1, angles [degree],
        velocities north, east, down [m s-1].
    """
    p = Path(path)
    layout, utc_layout = ins_layouts(fmt, where)
    table = read_delimited(p, layout, max_corrupt_fraction)
    # the UTC column read on its own: rows without a GNSS time fail to parse there, as they should
    utc_table = read_delimited(p, utc_layout, 1.0)
    at = np.searchsorted(utc_table.line_no, table.line_no)
    at_ok = at < utc_table.line_no.size
    found = np.zeros(table.line_no.size, dtype=bool)
    found[at_ok] = utc_table.line_no[at[at_ok]] == table.line_no[at_ok]
    utc = np.full(table.line_no.size, np.datetime64("NaT"), dtype="datetime64[ns]")
    utc[found] = utc_table.time[at[found]]
    v = table.values
    n = table.line_no.size
    valid = (np.nan_to_num(v["time_valid"]) != 0) & found if "time_valid" in v else found
    ekf = np.nan_to_num(v["ekf_valid"]) != 0 if "ekf_valid" in v else np.ones(n, dtype=bool)
    vel_d = v["vel_d"] if "vel_d" in v else -v["vel_u"]
    columns = {"rpi_time_us": _logger_us(table, str(fmt["time"]["kind"])), "utc": utc,
               "time_valid": valid.astype(np.int64), "ekf_valid": ekf.astype(np.int64), "lat_deg": v["lat"],
               "lon_deg": v["lon"], "alt_m": v["alt"], "vel_n_ms": v["vel_n"], "vel_e_ms": v["vel_e"],
               "vel_d_ms": vel_d, "roll_deg": v["roll"], "pitch_deg": v["pitch"], "yaw_deg": v["yaw"]}
    assert tuple(columns) == INS_COLUMNS
    counts, log = _parse_record(p, table, "INS")
    return MappedRecord(source=str(path), columns=columns, first_line=layout.first_data_line,
                        counts=counts, log=log, lines=table.line_no)


def payload_source(path: str | Path, fmt: Mapping[str, Any] | str | None, part: str,
                   where: str | None = None) -> str | Path | MappedRecord:
    """What the payload chain reads for one file: the path (contract CSV) or its mapped record.

    Parameters
    ----------
    path : str or Path
        The sonic or INS file.
    fmt : mapping, str or None
        The record's format (:func:`dronewind.manifest.record_format`); ``None`` or
        ``contract_csv``: the contract CSV.
    part : str
        ``sonic`` or ``ins``.
    where : str, optional
        Key path of the format for messages (default ``<part>.format``).

    Returns
    -------
    path or MappedRecord
    """
    name = fmt if isinstance(fmt, str) or fmt is None else fmt.get("name")
    if name in (None, "contract_csv"):
        return path
    where = where or f"{part}.format"
    if name != "delimited" or not isinstance(fmt, Mapping):
        raise InputError(where, f"format {name!r}; expected contract_csv or a delimited mapping")
    return sonic_record(path, fmt, where) if part == "sonic" else ins_record(path, fmt, where)
