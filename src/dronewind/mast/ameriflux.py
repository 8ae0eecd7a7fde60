r"""Reader for the AmeriFlux open-path "gold" raw files (Gill WindMaster Pro, 10 Hz).

Layout found in the files (``G<DDD><HHMM>.RAW.gz``, gzip-compressed ASCII, CRLF line ends,
no header): 21 comma-separated fields per line, of which the first six hold numbers and the
last fifteen are empty::

    +0.110,-0.930,+0.600,20.82,2.992,2.246,,,,,,,,,,,,,,,

The source notes (``Gold_processing_openpath_notes_0410.doc``) name the six columns:
vertical wind W [m/s], horizontal wind U [m/s], cross wind V [m/s], sonic temperature
[degC], H2O signal [V] (0 V = 0, 5 V = 1000 mmol m-3) and CO2 signal [V] (0 V = 10,
5 V = 25 mmol m-3). ``DDD`` is the day of year and ``HHMM`` the start of the half hour
("G1040000 = 10 Hz data from midnight 0000 to 0030 on day of year 104"). The 96 files in
``ameriflux_gold_openpath`` (days 104 and 181) hold 17999 rows (93 files)
or 17998 rows (3 files: G1040500, G1041330, G1810430), not 18000: the sample times are not logged, so rows are
assumed to start at the half hour at 10 Hz and the shortfall is counted
(``n_missing_rows``), position unknown. Neither the year nor the time zone is stated;
AmeriFlux logs local standard time, for this site (38.4067 N, 120.9507 W, California)
UTC-8, used by default; the year defaults to a nominal 2000 and is a parameter.

Sonic frame and conversion to east/north: the notes say the sonic's N (its reference
spar) faced 240 deg, "U is positive for flow from south to north, and V is positive for
flow from east to west (convention for Gill Windmaster Pro)", the south/north and east/west
being the sonic's own axes. So U is the air velocity towards the sonic's N, azimuth
:math:`\beta` = 240 deg, and V the air velocity towards the sonic's W, azimuth
:math:`\beta - 90` deg = 150 deg (with W up this frame is right-handed). Projecting on east
(:math:`\sin` of the azimuth) and north (:math:`\cos`):

.. math::

    u_E = U \sin\beta - V \cos\beta, \qquad v_N = U \cos\beta + V \sin\beta,
    \qquad w = W,

i.e. for :math:`\beta` = 240 deg: :math:`u_E = -0.866\,U + 0.5\,V`,
:math:`v_N = -0.5\,U - 0.866\,V`. Check: for :math:`\beta = 0` (sonic N on true north)
:math:`v_N = U` and :math:`u_E = -V` (flow to the west is negative east).

Caveat (not resolved from the files): with this literal reading the half-hour mean wind
blows from 35-140 deg in the daytime and from 240-290 deg at night. If the site's daytime
flow is the westerly up-slope flow one may expect in the Sierra foothills, the notes'
azimuth refers to the opposite end of the U axis; ``north_azimuth_deg=60`` gives that
alternative (all horizontal components change sign).
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.core import textscan
from dronewind.core.angles import deg2rad
from dronewind.core.cf import variable_attrs
from dronewind.core.constants import ZERO_CELSIUS_K
from dronewind.core.filtering import INSTRUMENT_LIMITS, despike_moving_mad, range_mask
from dronewind.core.qc import QC_MISSING, QC_OUT_OF_RANGE, QC_SPIKE, qc_flag_attrs
from dronewind.core.rowfaults import gunzip_readable
from dronewind.errors import InputError
from dronewind.mast.columns import AMERIFLUX_GOLD_COLUMNS
from dronewind.mast.level1 import _on_grid, _regular_grid  # the regular grid of the TOA5 mast record
from dronewind.mast.toa5 import UNREADABLE_PREFIX

__all__ = [
    "AMERIFLUX_GOLD_COLUMNS",
    "gill_to_enu",
    "read_ameriflux_gold",
    "read_ameriflux_gold_blocks",
    "mast_l1_gill",
]


_NAME_RE = re.compile(r"^G(\d{3})(\d{2})(\d{2})\.RAW(\.gz)?$", re.IGNORECASE)
_FS_HZ = 10.0
_BLOCK_S = 1800.0
_N_FIELDS = 21


def gill_to_enu(
    u_ms: np.ndarray, v_ms: np.ndarray, north_azimuth_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """Rotate Gill U (towards sonic N) and V (towards sonic W) to east and north.

    Parameters
    ----------
    u_ms, v_ms : numpy.ndarray
        Gill components [m s-1].
    north_azimuth_deg : float
        Azimuth the sonic's N spar faces [degree clockwise from true north].

    Returns
    -------
    u_east_ms, v_north_ms : numpy.ndarray
        [m s-1].

    Notes
    -----
    .. math:: u_E = U \\sin\\beta - V \\cos\\beta, \\qquad v_N = U \\cos\\beta + V \\sin\\beta .
    """
    b = deg2rad(north_azimuth_deg)
    u = np.asarray(u_ms, dtype=float)
    v = np.asarray(v_ms, dtype=float)
    return u * np.sin(b) - v * np.cos(b), u * np.cos(b) + v * np.sin(b)


def _block_start(path: Path, year: int, utc_offset_hours: float) -> np.datetime64:
    m = _NAME_RE.match(path.name)
    if not m:
        raise InputError(path, "file name is not G<DDD><HHMM>.RAW[.gz]; cannot date the block")
    doy, hh, mm = int(m.group(1)), int(m.group(2)), int(m.group(3))
    if not (1 <= doy <= 366 and hh < 24 and mm < 60):
        raise InputError(path, f"day of year {doy} or time {hh:02d}{mm:02d} out of range")
    local = (np.datetime64(f"{year:04d}-01-01T00:00", "ns")
             + np.timedelta64(doy - 1, "D") + np.timedelta64(hh * 60 + mm, "m"))  # fmt: skip
    return local - np.timedelta64(int(round(utc_offset_hours * 3600e9)), "ns")


def _read_gold_values(p: Path, max_corrupt_fraction: float, columns: Sequence[str] = AMERIFLUX_GOLD_COLUMNS,
                      gzipped: bool | None = None, with_lines: bool = False) -> tuple[np.ndarray, ...]:
    """The six numeric columns of a gold file and the mask of corrupt samples.

    Parameters
    ----------
    p : Path
        The file.
    max_corrupt_fraction : float
        Largest tolerated fraction of corrupt lines [1].
    columns : sequence of str
        The numeric fields in file order: names of :data:`AMERIFLUX_GOLD_COLUMNS` or
        ``unused``; the fields after them must be empty.
    gzipped : bool, optional
        Read as gzip; default: when the name ends in ``.gz``.
    with_lines : bool, optional
        Also return the file line of every sample.

    Returns
    -------
    values : numpy.ndarray
        (n_samples, 6) w, u, v, T, H2O, CO2 as logged (NaN where not a number or not among
        ``columns``).
    corrupt : numpy.ndarray
        True for samples whose line does not hold the declared numbers and empty fields.
    line_no : numpy.ndarray
        1-based file line of every sample (only with ``with_lines``).

    Raises
    ------
    InputError
        See :func:`_gold_values`.
    """
    got = _gold_values(p, max_corrupt_fraction, columns, gzipped)
    return (got.values, got.corrupt, got.line_no) if with_lines else (got.values, got.corrupt)


@dataclass
class _GoldValues:
    """What :func:`_gold_values` read: values, corrupt samples, their lines and what stopped a damaged stream."""

    values: np.ndarray
    corrupt: np.ndarray
    line_no: np.ndarray
    n_joined: int = 0
    problem: str | None = None


def _gold_values(p: Path, max_corrupt_fraction: float, columns: Sequence[str] = AMERIFLUX_GOLD_COLUMNS,
                 gzipped: bool | None = None) -> _GoldValues:
    """The samples of a gold file: the parser of the format (see :func:`_read_gold_values`).

    The regular lines are found and converted in bulk by a byte-level scan
    (:func:`_regular_gold_rows`); every other line goes with its line number to the
    line-by-line fault handling (:func:`_irregular_gold_rows`), and the samples of both are
    put back in line order. A line is one sample. It is corrupt (NaN, flagged missing) when a declared field is not a
    number or a field after the declared ones is not empty. A line with more than 21 fields
    holds several samples whose line ends were lost (a logger's torn write): it stands for
    ``ceil(fields / 21)`` corrupt samples, so that the samples after it keep their times
    (the file has no time stamps; a sample's time is its position). A gzip stream that is
    cut short or damaged is read as far as it goes (:func:`dronewind.core.rowfaults.gunzip_readable`).

    Raises
    ------
    InputError
        Unreadable file (not one byte of its gzip stream readable), no data lines, or more
        than ``max_corrupt_fraction`` of the lines corrupt (naming the first).
    """
    if gzipped is None:
        gzipped = p.suffix.lower() == ".gz"
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise InputError(p, f"cannot read ({exc})") from exc
    problem = None
    if gzipped:
        raw, problem = gunzip_readable(raw)
        if problem and not raw:
            raise InputError(p, f"cannot read: {problem}")
    _, body, buf, starts, ends, unusual = textscan.text_body(raw, 0)
    regular, reg_vals = _regular_gold_rows(body, buf, starts, ends, unusual, columns)
    irregular = np.flatnonzero(~regular)
    irr = _irregular_gold_rows(textscan.line_text(body, starts, ends, irregular), irregular + 1, columns)
    n_cols = len(columns)
    n_lines = int(regular.sum()) + irr.line_no.size
    if n_lines == 0:
        raise InputError(p, "no data lines" + (f" ({problem})" if problem else ""))
    declared = [j for j, name in enumerate(AMERIFLUX_GOLD_COLUMNS) if name in columns]
    lines = np.concatenate([np.flatnonzero(regular) + 1, irr.line_no])
    n_reg = int(regular.sum())
    vals = np.concatenate([reg_vals, irr.values]) if irr.line_no.size else reg_vals
    corrupt = np.concatenate([np.zeros(n_reg, dtype=bool), irr.corrupt])
    beyond_a = np.concatenate([np.zeros(n_reg, dtype=bool), irr.beyond])
    if irr.line_no.size and n_reg:  # the samples of both in line order (a joined line's samples stay together)
        order = np.argsort(lines, kind="stable")
        lines, vals, corrupt, beyond_a = lines[order], vals[order], corrupt[order], beyond_a[order]
    n_corrupt = int(corrupt.sum())
    if n_corrupt > max_corrupt_fraction * n_lines:
        if beyond_a.any():
            i = int(np.flatnonzero(beyond_a)[0])
            raise InputError(f"{p}:{int(lines[i])}", f"non-empty field beyond column {n_cols} ({n_corrupt} of "
                             f"{n_lines} lines corrupt, {int(beyond_a.sum())} with such fields); expected "
                             f"{','.join(columns)} followed by empty fields")  # fmt: skip
        i = int(np.flatnonzero(corrupt)[0])
        raise InputError(f"{p}:{int(lines[i])}", f"{n_corrupt} of {n_lines} lines do not hold {len(declared)} "
                         f"numbers ({','.join(columns)})")  # fmt: skip
    return _GoldValues(vals, corrupt, lines, irr.n_joined, problem)


@dataclass
class _IrregularGold:
    """Samples of the lines left to the fault handling (:func:`_irregular_gold_rows`)."""

    values: np.ndarray
    corrupt: np.ndarray
    beyond: np.ndarray
    line_no: np.ndarray
    n_joined: int


def _irregular_gold_rows(lines: list[str], line_no: np.ndarray, columns: Sequence[str]) -> _IrregularGold:
    """The fault handling of gold-file lines, one by one (``str.split``: the format has no quotes).

    A blank line is skipped. A line is one sample, corrupt (NaN) when a declared field is
    not a number or a field after the declared ones is not empty. A line with more than 21
    fields holds several samples whose line ends were lost (a logger's torn write): it
    stands for ``ceil(fields / 21)`` corrupt samples, so that the samples after it keep
    their times (the file has no time stamps; a sample's time is its position).

    Parameters
    ----------
    lines : list of str
        Data lines.
    line_no : numpy.ndarray
        Their 1-based file lines.
    columns : sequence of str
        As :func:`_read_gold_values`.

    Returns
    -------
    _IrregularGold
        (n_samples, 6) values, corrupt and beyond-the-declared-fields masks, the file line
        of every sample and the samples of joined lines.
    """
    n_cols = len(columns)
    cells: list[list[str]] = []
    sample_line: list[int] = []
    beyond: list[bool] = []
    joined: list[bool] = []
    for ln, line in zip(line_no.tolist(), lines, strict=True):
        if not line.strip():
            continue
        fields = line.split(",")
        if len(fields) > _N_FIELDS:
            k = -(-len(fields) // _N_FIELDS)
            cells.extend([[""] * n_cols] * k)
            sample_line.extend([ln] * k)
            beyond.extend([False] * k)
            joined.extend([True] * k)
            continue
        cells.append((fields + [""] * n_cols)[:n_cols])
        sample_line.append(ln)
        beyond.append(any(f.strip() for f in fields[n_cols:]))
        joined.append(False)
    frame = pd.DataFrame(cells, dtype=object)
    vals = np.full((len(cells), 6), np.nan)
    declared = [j for j, name in enumerate(AMERIFLUX_GOLD_COLUMNS) if name in columns]
    for j in declared:
        k = list(columns).index(AMERIFLUX_GOLD_COLUMNS[j])
        if cells:
            vals[:, j] = pd.to_numeric(frame[k].astype(str).str.strip(), errors="coerce").to_numpy(dtype=float)
    beyond_a, joined_a = np.asarray(beyond, dtype=bool), np.asarray(joined, dtype=bool)
    corrupt = np.asarray(~np.isfinite(vals[:, declared]).all(axis=1)) | beyond_a | joined_a
    vals[corrupt] = np.nan
    return _IrregularGold(vals, corrupt, beyond_a, np.asarray(sample_line, dtype=np.int64), int(joined_a.sum()))


#: Bytes of a regular gold line: digits, signs, points, commas.
_GOLD_PLAIN = b"0123456789+-.,"


def _regular_gold_rows(body: bytes, buf: np.ndarray, starts: np.ndarray, ends: np.ndarray, unusual: bool,
                       columns: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """The regular lines of a gold file and their samples, by a byte-level scan.

    A line is regular when it holds only :data:`_GOLD_PLAIN` bytes, 21 comma-separated
    fields, every declared field a finite number of 1 to
    :data:`~dronewind.core.textscan.FLOAT_FAST_MAX_CHARS` characters (no exponent: see
    :mod:`dronewind.core.textscan`) and every field after the declared ones empty: one good
    sample, whose numbers ``pandas.read_csv`` reads bit for bit as the fault handling's
    ``pandas.to_numeric`` does. Written by hand because converting the 10 million short
    fields of a day's files one by one was 80 % of the parse.

    Returns
    -------
    regular : numpy.ndarray
        bool, one per line.
    values : numpy.ndarray
        (regular lines, 6) w, u, v, T, H2O, CO2 (NaN where not declared).
    """
    n, n_cols = int(starts.size), len(columns)
    regular = np.zeros(n, dtype=bool)
    if n == 0 or n_cols > _N_FIELDS:
        return regular, np.zeros((0, 6))
    candidate = (ends > starts) & ~textscan.lines_holding(body, buf, starts, _GOLD_PLAIN, unusual)
    rows, cpos, _ = textscan.comma_grid(np.flatnonzero(buf == ord(",")), starts, ends, candidate, _N_FIELDS)
    if rows.size == 0:
        return regular, np.zeros((0, 6))
    line_end = ends[rows]
    # the fields after the declared ones empty: their commas consecutive, the last one ending the line
    ok = (cpos[:, -1] + 1 == line_end) & (cpos[:, -1] - cpos[:, n_cols - 1] == _N_FIELDS - 1 - n_cols) \
        if n_cols < _N_FIELDS else np.ones(rows.size, dtype=bool)  # fmt: skip

    def length(k: int) -> np.ndarray:
        """Characters of field `k` of the scanned lines."""
        return (cpos[:, k] if k < _N_FIELDS - 1 else line_end) - (starts[rows] if k == 0 else cpos[:, k - 1] + 1)

    names = [str(k) for k in range(_N_FIELDS)]
    declared = {j: list(columns).index(name) for j, name in enumerate(AMERIFLUX_GOLD_COLUMNS) if name in columns}
    scanned = np.zeros(n, dtype=bool)
    scanned[rows] = True
    frame = textscan.read_numeric_columns(textscan.kept_lines(body, starts, scanned), names,
                                          [names[k] for k in sorted(set(declared.values()))], {}, quoting=False)
    vals = np.full((rows.size, 6), np.nan)
    for j, k in declared.items():
        chars = length(k)
        vals[:, j], col_ok = textscan.float_fields(frame[names[k]], chars)
        ok &= col_ok & (chars >= 1) & np.isfinite(vals[:, j])
    regular[rows[ok]] = True
    return regular, vals[ok]


def _gold_qc(u: np.ndarray, v: np.ndarray, w: np.ndarray, t_c: np.ndarray, corrupt: np.ndarray,
             despike: bool, window_s: float = 10.0, n_mad: float = 7.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Missing, range (Gill WindMaster Pro) and spike flags.

    Returns
    -------
    qc : numpy.ndarray
        int8 QC bitmask (:mod:`dronewind.core.qc`).
    out, spikes : numpy.ndarray
        The out-of-range and spike masks.
    """
    qc = np.zeros(corrupt.size, dtype=np.int8)
    qc[corrupt] |= QC_MISSING
    lim = INSTRUMENT_LIMITS["gill_windmaster_pro"]
    speed = np.sqrt(u**2 + v**2 + w**2)
    out = range_mask(speed, *lim["speed_ms"]) | range_mask(t_c, *lim["t_sonic_c"])
    qc[out] |= QC_OUT_OF_RANGE
    spikes = np.zeros(corrupt.size, dtype=bool)
    if despike:
        for x in (u, v, w, t_c):
            spikes |= despike_moving_mad(np.where(qc == 0, x, np.nan), _FS_HZ, window_s, n_mad)
    qc[spikes] |= QC_SPIKE
    return qc, out, spikes


def _gold_dataset(vals: np.ndarray, qc: np.ndarray, time: np.ndarray, north_azimuth_deg: float) -> xr.Dataset:
    """The gold-file variables on ``time`` (see :func:`read_ameriflux_gold`, Returns)."""
    w, u, v, t_c, h2o, co2 = (vals[:, j] for j in range(6))
    nanf = np.where(qc != 0, np.nan, 1.0)
    u_e, v_n = gill_to_enu(u, v, north_azimuth_deg)
    return xr.Dataset(
        {
            "u_east_ms": ("time", u_e * nanf, variable_attrs("m s-1", "eastward_wind")),
            "v_north_ms": ("time", v_n * nanf, variable_attrs("m s-1", "northward_wind")),
            "w_up_ms": ("time", w * nanf, variable_attrs("m s-1", "upward_air_velocity")),
            "t_sonic_k": ("time", (t_c + ZERO_CELSIUS_K) * nanf, variable_attrs(
                "K", "virtual_temperature", comment="Gill sonic temperature",
                units_metadata="temperature: on_scale")),
            "u_gill_ms": ("time", u, variable_attrs("m s-1", long_name="Gill U as logged (towards sonic N)")),
            "v_gill_ms": ("time", v, variable_attrs("m s-1", long_name="Gill V as logged (towards sonic W)")),
            "w_gill_ms": ("time", w, variable_attrs("m s-1", long_name="Gill W as logged (up)")),
            "t_sonic_c": ("time", t_c, variable_attrs("degC", long_name="sonic temperature as logged",
                                                      units_metadata="temperature: on_scale")),
            "h2o_v": ("time", h2o, variable_attrs("V", long_name="open-path H2O signal")),
            "co2_v": ("time", co2, variable_attrs("V", long_name="open-path CO2 signal")),
            "h2o_mmol_m3": ("time", 200.0 * h2o, variable_attrs(
                "mmol m-3", long_name="H2O molar density (0 V = 0, 5 V = 1000 mmol m-3)")),
            "co2_mmol_m3": ("time", 10.0 + 3.0 * co2, variable_attrs(
                "mmol m-3", long_name="CO2 molar density (0 V = 10, 5 V = 25 mmol m-3)")),
            "qc_sonic": ("time", qc, qc_flag_attrs("sonic QC bitmask", (QC_OUT_OF_RANGE, QC_SPIKE, QC_MISSING))),
        },
        coords={"time": ("time", time, {"long_name": "time (UTC)"})},
    )


def _gold_attrs(p: Path, n_lines: int, n_expected: int, n_corrupt: int, out: np.ndarray, spikes: np.ndarray,
                qc: np.ndarray, despike: bool, north_azimuth_deg: float, height_m: float, year: int,
                utc_offset_hours: float) -> dict[str, Any]:
    """Dataset attributes of a gold file: counts, site, time assumptions and the processing log."""
    n_missing = max(0, n_expected - n_lines)
    return dict(
        sampling_rate_hz=_FS_HZ,
        n_rows=int(n_lines),
        n_missing_rows=int(n_missing),
        n_corrupt_lines=n_corrupt,
        n_out_of_range=int(out.sum()),
        n_spikes=int(spikes.sum()),
        n_flagged=int((qc != 0).sum()),
        north_azimuth_deg=float(north_azimuth_deg),
        height_m=float(height_m),
        site_latitude=38.4067,
        site_longitude=-120.9507,
        source_file=str(p),
        time_comment=f"times assumed: half-hour start from the file name + i/10 s; year "
        f"{year} nominal (not stated in the source); clock UTC{utc_offset_hours:+g} h",
        processing_log="\n".join([
            f"read: {p.name}: {n_lines} rows ({n_missing} short of {n_expected}, position "
            f"unknown), {n_corrupt} lines without six numbers flagged",
            f"qc: {int(out.sum())} out of Gill WindMaster Pro range, {int(spikes.sum())} spikes"
            f"{'' if despike else ' (despiking off)'}; {int((qc != 0).sum())} samples set to NaN",
            f"frame: sonic N at {north_azimuth_deg:g} deg; u_E = U sin b - V cos b, "
            "v_N = U cos b + V sin b, w = W",
        ]),
    )  # fmt: skip

def read_ameriflux_gold(
    path: str | os.PathLike[str], north_azimuth_deg: float = 240.0, year: int = 2000, utc_offset_hours: float = -8.0,
    height_m: float = 2.0, despike: bool = True, max_corrupt_fraction: float = 0.05,
    columns: Sequence[str] = AMERIFLUX_GOLD_COLUMNS, gzipped: bool | None = None, despike_window_s: float = 10.0,
    despike_n_mad: float = 7.0,
) -> xr.Dataset:
    """Read one AmeriFlux open-path gold half-hour file.

    Parameters
    ----------
    path : str or Path
        ``G<DDD><HHMM>.RAW`` or ``.RAW.gz`` file.
    north_azimuth_deg : float, optional
        Azimuth of the sonic's N spar [degree]; 240 per the source notes.
    year : int, optional
        Year of the record (not stated in the source; nominal default 2000).
    utc_offset_hours : float, optional
        Offset of the logger's clock from UTC [h]; default -8 (local standard time,
        California, the AmeriFlux convention).
    height_m : float, optional
        Measurement height [m]; 2 m per the source notes.
    despike : bool, optional
        Flag spikes with the moving MAD (QC 2).
    max_corrupt_fraction : float, optional
        Largest tolerated fraction of lines that do not hold six numbers [1].
    columns : sequence of str, optional
        The numeric fields in file order (default :data:`AMERIFLUX_GOLD_COLUMNS`); must
        include w, u, v and t_sonic_c; ``unused`` skips a field; gas columns not declared
        are NaN.
    gzipped : bool, optional
        Read as gzip; default: when the name ends in ``.gz``.
    despike_window_s, despike_n_mad : float, optional
        Moving-MAD despiking window [s] and threshold [scaled MAD].

    Returns
    -------
    xarray.Dataset
        dim ``time`` (UTC, start of the half hour + i/10 s); ``u_east_ms``, ``v_north_ms``,
        ``w_up_ms``, ``t_sonic_k`` (NaN where ``qc_sonic`` != 0), raw ``u_gill_ms``,
        ``v_gill_ms``, ``w_gill_ms``, ``t_sonic_c``, ``h2o_v``, ``co2_v`` and the
        calibrated ``h2o_mmol_m3`` = 200 V, ``co2_mmol_m3`` = 10 + 3 V; ``qc_sonic``.
        attrs ``sampling_rate_hz`` = 10, ``n_rows``, ``n_missing_rows`` (18000 - rows),
        ``n_corrupt_lines``, ``n_out_of_range``, ``n_spikes``, ``processing_log``.

    Raises
    ------
    InputError
        Unreadable file, bad file name, a line with numbers beyond field 6, or too many
        corrupt lines.

    Notes
    -----
    Conversion to east/north: see the module docstring and :func:`gill_to_enu`.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(p, "file not found")
    start = _block_start(p, year, utc_offset_hours)
    missing = [c for c in ("w", "u", "v", "t_sonic_c") if c not in columns]
    if missing:
        raise InputError(p, f"columns {list(columns)} lack {', '.join(missing)}; expected w, u, v and t_sonic_c")
    got = _gold_values(p, max_corrupt_fraction, columns, gzipped)
    vals, corrupt = got.values, got.corrupt
    n_lines = corrupt.size
    n_expected = int(round(_FS_HZ * _BLOCK_S))
    qc, out, spikes = _gold_qc(vals[:, 1], vals[:, 2], vals[:, 0], vals[:, 3], corrupt, despike, despike_window_s,
                               despike_n_mad)
    time = start + (np.arange(n_lines, dtype=np.int64) * int(1e9 / _FS_HZ)).astype("timedelta64[ns]")
    ds = _gold_dataset(vals, qc, time, north_azimuth_deg)
    ds.attrs.update(_gold_attrs(p, n_lines, n_expected, int(corrupt.sum()), out, spikes, qc, despike,
                                north_azimuth_deg, height_m, year, utc_offset_hours))
    if corrupt.any():  # where the damage is: file and lines
        bad = np.unique(got.line_no[corrupt])
        ds.attrs["processing_log"] += (f"\nread: corrupt lines of {p.name}: {bad[:5].tolist()}"
                                       + (f" ({bad.size} lines)" if bad.size > 5 else "")
                                       + (f"; {got.n_joined} samples on lines with more than {_N_FIELDS} fields "
                                          "(line ends lost)" if got.n_joined else ""))
    ds.attrs["n_damaged_streams"] = int(got.problem is not None)
    if got.problem:
        ds.attrs["processing_log"] += f"\nread: {p.name}: {got.problem}; the samples before it read"
    return ds


def _sort_key(path: Path) -> tuple[int, str]:
    m = _NAME_RE.match(path.name)
    return (int(m.group(1) + m.group(2) + m.group(3)), path.name) if m else (10**9, path.name)


def read_ameriflux_gold_blocks(
    paths: Iterable[str | os.PathLike[str]], **kwargs: Any
) -> Iterator[xr.Dataset]:
    """Iterate over half-hour gold files lazily, in time order, one dataset at a time.

    Parameters
    ----------
    paths : iterable of str or Path
        Gold files (a directory is expanded to its ``G*.RAW*`` files).
    **kwargs
        Passed to :func:`read_ameriflux_gold`.

    Yields
    ------
    xarray.Dataset
        One half-hour block; only one is held in memory at a time by this generator.
    """
    files: list[Path] = []
    for item in paths if not isinstance(paths, (str, os.PathLike)) else [paths]:
        pth = Path(item)
        if pth.is_dir():
            files.extend(f for f in pth.iterdir() if _NAME_RE.match(f.name))
        else:
            files.append(pth)
    for f in sorted(files, key=_sort_key):
        yield read_ameriflux_gold(f, **kwargs)


_L1_VARIABLES = ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k", "u_gill_ms", "v_gill_ms", "w_gill_ms", "t_sonic_c")
_SUMMED_COUNTS = ("n_rows", "n_missing_rows", "n_corrupt_lines", "n_out_of_range", "n_spikes", "n_damaged_streams")


def mast_l1_gill(
    paths: Sequence[str | os.PathLike[str]], spec: Mapping[str, Any], sonic: Mapping[str, Any],
    despike_window_s: float = 10.0, despike_n_mad: float = 7.0, despike: bool = True,
    max_corrupt_fraction: float = 0.05, max_gap_s: float = 60.0,
) -> xr.Dataset:
    """Mast L1 dataset of a Gill sonic logged as AmeriFlux/Gill RAW half-hour files.

    Each file is read by :func:`read_ameriflux_gold` (its QC, its frame conversion); the
    blocks are concatenated in time order on the regular 10 Hz grid (absent samples inserted
    as missing, gaps longer than ``max_gap_s`` kept as breaks), with the variables and
    attributes of the mast L1 of :func:`dronewind.mast.level1.mast_l1`.

    Parameters
    ----------
    paths : sequence of path
        ``G<DDD><HHMM>.RAW[.gz]`` files of the sonic.
    spec : mapping
        The manifest's ``format`` (``name: gill_raw``): ``columns``, ``north_azimuth_deg``
        [degree] (default the sonic's ``azimuth_deg``), ``year`` (default 2000),
        ``utc_offset_hours`` [h] (default 0), ``compression`` (``auto``, ``gzip``, ``none``).
    sonic : mapping
        Manifest entry of the sonic: ``id``, ``height_m`` [m], ``azimuth_deg`` [degree].
    despike_window_s, despike_n_mad : float
        Moving-MAD despiking window [s] and threshold [scaled MAD].
    despike : bool
        Apply the despiking (QC 2).
    max_corrupt_fraction : float
        Largest tolerated fraction of corrupt lines per file [1].
    max_gap_s : float
        Longer gaps between blocks are breaks of the time axis [s].

    Returns
    -------
    xarray.Dataset
        ``u_east_ms``, ``v_north_ms``, ``w_up_ms``, ``t_sonic_k`` (NaN where ``qc_mast``
        != 0), ``u_gill_ms``, ``v_gill_ms``, ``w_gill_ms``, ``t_sonic_c`` as logged,
        ``qc_mast``; attrs ``azimuth_deg``, ``north_azimuth_deg``, ``height_m``,
        ``sensor_id``, ``sampling_rate_hz``, ``n_*`` counts, ``input_format``,
        ``processing_log``.

    Raises
    ------
    InputError
        See :func:`read_ameriflux_gold`; no file given.
    """
    files = sorted((Path(p) for p in paths), key=_sort_key)
    if not files:
        raise InputError("format", "no gill_raw file given")
    north = float(spec.get("north_azimuth_deg", sonic["azimuth_deg"]))
    year, utc_offset = int(spec.get("year", 2000)), float(spec.get("utc_offset_hours", 0.0))
    compression = str(spec.get("compression", "auto"))
    frames, log = [], []
    counts = dict.fromkeys(_SUMMED_COUNTS, 0)
    errors: list[InputError] = []
    for k, f in enumerate(files):
        try:
            block = read_ameriflux_gold(
                f, north_azimuth_deg=north, year=year, utc_offset_hours=utc_offset,
                height_m=float(sonic["height_m"]), despike=despike, max_corrupt_fraction=max_corrupt_fraction,
                columns=tuple(spec.get("columns", AMERIFLUX_GOLD_COLUMNS)),
                gzipped=None if compression == "auto" else compression == "gzip",
                despike_window_s=despike_window_s, despike_n_mad=despike_n_mad)
        except InputError as exc:  # left out if others can be read (see dronewind.mast.level1._read_files)
            if len(files) == 1:
                raise
            errors.append(exc)
            log.append(f"{UNREADABLE_PREFIX}{exc}")
            continue
        for key in _SUMMED_COUNTS:
            counts[key] += int(block.attrs[key])
        log.extend(ln for ln in str(block.attrs["processing_log"]).split("\n") if ln.startswith("read:"))
        frame = pd.DataFrame({v: block[v].values for v in _L1_VARIABLES})
        frame["qc"] = block["qc_sonic"].values.astype(float)
        frame.insert(0, "time", block["time"].values.astype("datetime64[ns]"))
        frame["_file"], frame["_line"] = k, np.arange(1, block.sizes["time"] + 1)
        frames.append(frame)
    if not frames:
        raise errors[0]
    counts["n_unreadable_files"] = len(errors)
    data = pd.concat(frames, ignore_index=True).sort_values("time", kind="stable")
    dup = data.duplicated(subset=["time"], keep="first").to_numpy()
    counts["n_time_conflicts"] = int(dup.sum())
    data, grid = _regular_grid(data.loc[~dup].reset_index(drop=True), files, max_gap_s, counts)
    qc = _on_grid(data, grid, "qc")
    qc = np.where(np.isfinite(qc), qc, QC_MISSING).astype(np.int8)
    ds = xr.Dataset(
        {v: ("time", _on_grid(data, grid, v)) for v in _L1_VARIABLES},
        coords={"time": ("time", grid.time, {"long_name": "time (UTC)"})},
    )
    template = _gold_dataset(np.zeros((1, 6)), np.zeros(1, dtype=np.int8), grid.time[:1], north)
    for v in _L1_VARIABLES:
        ds[v].attrs.update(template[v].attrs)
    ds["qc_mast"] = ("time", qc, qc_flag_attrs("mast sonic QC bitmask", (QC_OUT_OF_RANGE, QC_SPIKE, QC_MISSING)))
    counts["n_flagged"] = int((qc != 0).sum())
    log.append(f"grid: {grid.fs_hz:g} Hz, {counts['n_missing']} absent time stamps inserted as missing; "
               f"{counts['n_record_breaks']} record breaks (gaps > {max_gap_s:g} s kept as breaks, not filled)")
    log.append(f"qc: {counts['n_out_of_range']} out of Gill WindMaster Pro range, {counts['n_spikes']} spikes "
               f"(moving MAD {despike_window_s:g} s, {despike_n_mad:g} scaled MAD{'' if despike else ', off'}); "
               f"{counts['n_flagged']} of {grid.time.size} samples set to NaN")
    log.append(f"frame: sonic N at {north:g} deg; u_E = U sin b - V cos b, v_N = U cos b + V sin b, w = W; "
               f"clock UTC{utc_offset:+g} h, year {year} (the file names hold the day of year)")
    ds.attrs.update({k: int(v) for k, v in counts.items()})
    ds.attrs.update(azimuth_deg=float(sonic["azimuth_deg"]), north_azimuth_deg=north,
                    height_m=float(sonic["height_m"]), sensor_id=str(sonic["id"]),
                    sampling_rate_hz=float(round(grid.fs_hz, 6)), source_files=", ".join(f.name for f in files),
                    input_format="gill_raw", processing_log="\n".join(log))
    return ds
