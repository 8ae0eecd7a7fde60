"""Mast sonic L1: CSAT3 records from TOA5 files on their regular grid, in ENU, quality-controlled.

Several files of one mast sonic (read by :func:`dronewind.mast.toa5.read_toa5`) are
concatenated in time order, duplicated time stamps dropped and the record put on its
regular 10 Hz or 20 Hz grid, absent grid points inserted as missing samples
(``n_missing``); the CSAT3 sonic axes are turned to east, north, up with the boom's
orientation (:func:`csat3_to_enu`).

QC bitmask ``qc_mast`` (bits of :mod:`dronewind.core.qc`): 1 out of range (CSAT3 limits in
:data:`dronewind.core.filtering.INSTRUMENT_LIMITS`), 2 spike (moving MAD), 4 missing/corrupt,
8 gap-filled (later stages), 16 CSAT3 diagnostic word non-zero (the sample set to NaN).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.core.angles import deg2rad
from dronewind.core.cf import variable_attrs
from dronewind.core.constants import ZERO_CELSIUS_K
from dronewind.core.filtering import INSTRUMENT_LIMITS, despike_moving_mad, range_mask
from dronewind.core.qc import QC_DIAG, QC_GAP_FILLED, QC_MISSING, QC_OUT_OF_RANGE, QC_SPIKE, qc_flag_attrs
from dronewind.core.raw import RawRecord
from dronewind.errors import InputError
from dronewind.mast.columns import REQUIRED_TOA5_COLUMNS
from dronewind.mast.toa5 import _N_LOGGED, UNREADABLE_PREFIX, TOA5Source, _expand_paths, read_toa5

__all__ = [
    "csat3_to_enu",
    "mast_l1",
]


def csat3_to_enu(
    ux_ms: np.ndarray, uy_ms: np.ndarray, azimuth_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """Rotate CSAT3 horizontal components to east and north.

    Parameters
    ----------
    ux_ms, uy_ms : numpy.ndarray
        CSAT3 components [m s-1]; Ux > 0 for wind blowing from the azimuth the sensor head
        points to into the head, right-handed with z up.
    azimuth_deg : float
        Azimuth the sensor head points to [degree, clockwise from true north].

    Returns
    -------
    u_east_ms, v_north_ms : numpy.ndarray
        [m s-1].

    Notes
    -----
    ``docs/data-contract.md``, "Frames and signs", with :math:`\\alpha` the azimuth:

    .. math::

        u_E = -U_x \\sin\\alpha + U_y \\cos\\alpha, \\qquad
        u_N = -U_x \\cos\\alpha - U_y \\sin\\alpha .
    """
    a = deg2rad(azimuth_deg)
    ux = np.asarray(ux_ms, dtype=float)
    uy = np.asarray(uy_ms, dtype=float)
    return -ux * np.sin(a) + uy * np.cos(a), -ux * np.cos(a) - uy * np.sin(a)


@dataclass
class _Grid:
    """The regular time grid of a mast record (one grid per segment between record breaks)."""

    fs_hz: float  # sampling rate [Hz]
    time: np.ndarray  # grid times, datetime64[ns]
    index: np.ndarray  # grid index of every kept row
    segments: list[tuple[int, int]]  # (start, stop) grid indices of the segments
    n_breaks: int  # number of record breaks


def _record_frame(rec: RawRecord,
                  required: Sequence[str] = REQUIRED_TOA5_COLUMNS) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The :func:`read_toa5` result of an in-memory record (no text: no corrupt rows)."""
    missing = [col for col in required if col not in rec.columns]
    if missing:
        raise InputError(rec.source, f"in-memory TOA5 record lacks column(s) {', '.join(missing)}")
    names = list(rec.columns)
    cols = rec.checked(names, {name: "f" for name in names} | {"TIMESTAMP": "M", "RECORD": "i", "diag_csat": "i"})
    frame = pd.DataFrame({"time": cols["TIMESTAMP"], "RECORD": cols["RECORD"]})
    for name in names:
        if name not in ("TIMESTAMP", "RECORD"):
            frame[name] = cols[name].astype(float)
    frame["_line"] = rec.line_numbers()
    header = [[], names, [rec.units.get(n, "") for n in names], ["" for _ in names]]
    info = {"header": header, "units": dict(rec.units), "n_lines": rec.n_rows, "n_corrupt_lines": 0,
            "corrupt_lines": [], "n_nonnumeric": 0}
    return frame, info


def _read_files(files: list[Path | RawRecord], max_corrupt_fraction: float, counts: dict[str, int],
                log: list[str]) -> list[pd.DataFrame]:
    """Read every TOA5 file or record (Ts in degC), count RECORD skips and restarts; sorted by first time.

    A file that cannot be read (:class:`InputError`: a damaged header, too many corrupt rows)
    is left out when others can be read: counted in ``n_unreadable_files`` and named with
    its error in the log, so that only the flights its time span covers lose their
    reference (:func:`unreadable_files`); when no file can be read, the first error is raised.
    """
    frames: list[pd.DataFrame] = []
    errors: list[InputError] = []
    for k, f in enumerate(files):
        try:
            if isinstance(f, RawRecord):
                frame, info = _record_frame(f)
            else:
                frame, info = read_toa5(f, max_corrupt_fraction=max_corrupt_fraction)
        except InputError as exc:
            if len(files) == 1:
                raise
            errors.append(exc)
            log.append(f"{UNREADABLE_PREFIX}{exc}")
            continue
        ts_unit = info["units"].get("Ts", "C")
        if ts_unit.strip().upper() in ("K", "KELVIN"):
            frame["Ts"] = frame["Ts"] - ZERO_CELSIUS_K
        rec = frame["RECORD"].to_numpy()
        d = np.diff(rec)
        skips = int(np.sum(np.where(d > 1, d - 1, 0)))
        restarts = int(np.sum(d <= 0))
        counts["n_lines"] += info["n_lines"]
        counts["n_corrupt_lines"] += info["n_corrupt_lines"]
        counts["n_nonnumeric"] += info["n_nonnumeric"]
        counts["n_record_skips"] += skips
        counts["n_record_restarts"] += restarts
        msg = (f"read: {f.name}: {len(frame)} rows, {info['n_corrupt_lines']} corrupt removed, "
               f"{skips} RECORD numbers skipped, {restarts} RECORD restarts")  # fmt: skip
        if info["n_corrupt_lines"]:
            msg += f" (corrupt lines {info['corrupt_lines']})"
        log.append(msg)
        frame["_file"] = k
        frames.append(frame)
    if not frames:
        raise errors[0]
    counts["n_unreadable_files"] = len(errors)
    frames.sort(key=lambda fr: fr["time"].iloc[0] if len(fr) else np.datetime64("NaT"))
    return frames


def _merge_records(frames: list[pd.DataFrame], files: Sequence[Path | RawRecord], counts: dict[str, int],
                   log: list[str], max_corrupt_fraction: float) -> pd.DataFrame:
    """Concatenate the files in time order, dropping exact duplicate rows and conflicting time stamps.

    Rows that repeat a TIMESTAMP with other values conflict: no rule says which one is
    right, so every row of such a time stamp is dropped (the sample becomes missing on the
    grid), counted in ``n_time_conflicts`` (rows) and reported with its file and line.
    More than ``max_corrupt_fraction`` of the rows in conflict raises :class:`InputError`.
    """
    data = pd.concat(frames, ignore_index=True)
    cols = ["time", "RECORD", "Ux", "Uy", "Uz", "Ts", "diag_csat"]
    exact_dup = data.duplicated(subset=cols, keep="first").to_numpy()
    data = data.loc[~exact_dup]
    data = data.sort_values("time", kind="stable")
    conflict = data.duplicated(subset=["time"], keep=False).to_numpy()
    n_conflict = int(conflict.sum())
    if n_conflict:
        where = [f"{files[int(f)].name}:{int(ln)}" for f, ln in
                 zip(data["_file"].to_numpy()[conflict][:_N_LOGGED], data["_line"].to_numpy()[conflict][:_N_LOGGED],
                     strict=True)]
        n_rows = len(data)
        if n_conflict > max_corrupt_fraction * n_rows:
            first = int(np.flatnonzero(conflict)[0])
            raise InputError(f"{files[int(data['_file'].iloc[first])]}:{int(data['_line'].iloc[first])}",
                             f"{n_conflict} of {n_rows} rows repeat a TIMESTAMP with other values "
                             f"(> {100 * max_corrupt_fraction:g} %; first at {', '.join(where)}): "
                             "expected one row per time stamp")
        log.append(f"order: {n_conflict} rows at {int(data.loc[conflict, 'time'].nunique())} time stamps repeated "
                   f"with other values dropped, none trusted (first at {', '.join(where)})")
    data = data.loc[~conflict].reset_index(drop=True)
    counts["n_duplicates"] = int(exact_dup.sum())
    counts["n_time_conflicts"] = n_conflict
    log.append(f"order: {len(files)} files concatenated in time order, "
               f"{int(exact_dup.sum())} exact duplicate rows dropped, {n_conflict} rows with a conflicting "
               "TIMESTAMP dropped")  # fmt: skip
    return data


def _regular_grid(data: pd.DataFrame, files: Sequence[Path | RawRecord], max_gap_s: float, counts: dict[str, int],
                  ) -> tuple[pd.DataFrame, _Grid]:
    """Put the rows on their regular grid, segment by segment between record breaks (> ``max_gap_s``).

    Returns
    -------
    data : pandas.DataFrame
        Rows kept (a row falling on the grid point of the previous one is dropped).
    _Grid
        The grid; ``n_missing`` = grid points without a row is counted in ``counts``.
    """
    t = data["time"].to_numpy().astype("datetime64[ns]")
    if t.size < 2:
        raise InputError(files[0], f"only {t.size} valid rows")
    dt_ns = int(np.median(np.diff(t).astype(np.int64)))
    if dt_ns <= 0:
        raise InputError(files[0], "TIMESTAMP does not increase")
    fs_hz = 1e9 / dt_ns
    # segments: breaks where the time stamps jump by more than max_gap_s
    jumps = np.flatnonzero(np.diff(t).astype(np.int64) > max_gap_s * 1e9) + 1
    keep_rows = np.ones(t.size, dtype=bool)
    grid_index = np.zeros(t.size, dtype=np.int64)
    time_parts = []
    offset = 0
    for a, b in zip(np.r_[0, jumps], np.r_[jumps, t.size], strict=True):
        k_float = (t[a:b] - t[a]).astype(np.int64) / dt_ns
        k = np.rint(k_float).astype(np.int64)
        off_grid = np.abs(k_float - k) > 0.25
        if off_grid.any():
            i = a + int(np.flatnonzero(off_grid)[0])
            raise InputError(
                f"{files[int(data['_file'].iloc[i])]}:{int(data['_line'].iloc[i])}",
                f"TIMESTAMP {t[i]} is off the {fs_hz:g} Hz sampling grid; expected a constant "
                "sampling interval",
            )
        dup = np.zeros(k.size, dtype=bool)
        dup[1:] = k[1:] == k[:-1]
        keep_rows[a:b] = ~dup
        grid_index[a:b] = offset + k
        n_seg = int(k[-1]) + 1
        time_parts.append(t[a] + (np.arange(n_seg, dtype=np.int64) * dt_ns).astype("timedelta64[ns]"))
        offset += n_seg
    counts["n_time_conflicts"] += int((~keep_rows).sum())
    counts["n_record_breaks"] = int(jumps.size)
    bounds = np.cumsum([0] + [p.size for p in time_parts])
    grid = _Grid(fs_hz, np.concatenate(time_parts), grid_index[keep_rows],
                 list(zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True)), int(jumps.size))
    counts["n_missing"] = int(offset - grid.index.size)
    return data.loc[keep_rows].reset_index(drop=True), grid


def _on_grid(data: pd.DataFrame, grid: _Grid, col: str) -> np.ndarray:
    """One column on the grid, NaN where no row."""
    out = np.full(grid.time.size, np.nan)
    out[grid.index] = data[col].to_numpy(dtype=float)
    return out


def _mast_qc(ux: np.ndarray, uy: np.ndarray, uz: np.ndarray, ts_c: np.ndarray, diag: np.ndarray, grid: _Grid,
             despike: bool, despike_window_s: float, despike_n_mad: float, counts: dict[str, int]) -> np.ndarray:
    """Missing, CSAT3 diagnostic, range (CSAT3) and spike flags.

    Returns
    -------
    numpy.ndarray
        int8 QC bitmask (:mod:`dronewind.core.qc`); counts ``n_nan_values``,
        ``n_diag_flagged``, ``n_out_of_range``, ``n_spikes``, ``n_flagged``.
    """
    n = grid.time.size
    present = np.zeros(n, dtype=bool)
    present[grid.index] = True
    qc = np.zeros(n, dtype=np.int8)
    missing = ~(np.isfinite(ux) & np.isfinite(uy) & np.isfinite(uz) & np.isfinite(ts_c))
    qc[missing] |= QC_MISSING
    diag_bad = np.isfinite(diag) & (diag != 0)
    qc[diag_bad] |= QC_DIAG
    lim = INSTRUMENT_LIMITS["csat3"]
    out = (range_mask(ux, *lim["ux_ms"]) | range_mask(uy, *lim["uy_ms"])
           | range_mask(uz, *lim["uz_ms"]) | range_mask(ts_c, *lim["t_sonic_c"]))  # fmt: skip
    qc[out] |= QC_OUT_OF_RANGE
    spikes = np.zeros(n, dtype=bool)
    if despike:
        for a, b in grid.segments:  # the moving window never spans a record break
            for x in (ux, uy, uz, ts_c):
                spikes[a:b] |= despike_moving_mad(np.where(qc[a:b] == 0, x[a:b], np.nan), grid.fs_hz,
                                                  despike_window_s, despike_n_mad)  # fmt: skip
    qc[spikes] |= QC_SPIKE
    counts["n_nan_values"] = int((missing & present).sum())
    counts["n_diag_flagged"] = int(diag_bad.sum())
    counts["n_out_of_range"] = int(out.sum())
    counts["n_spikes"] = int(spikes.sum())
    counts["n_flagged"] = int((qc != 0).sum())
    return qc


def _mast_dataset(ux: np.ndarray, uy: np.ndarray, uz: np.ndarray, ts_c: np.ndarray, diag: np.ndarray,
                  qc: np.ndarray, time: np.ndarray, azimuth_deg: float) -> xr.Dataset:
    """The mast L1 variables on ``time`` (see :func:`mast_l1`, Returns); flagged samples NaN in east/north/up."""
    u_e, v_n = csat3_to_enu(ux, uy, azimuth_deg)
    nanf = np.where(qc != 0, np.nan, 1.0)
    diag_i = np.where(np.isfinite(diag), diag, -1).astype(np.int32)
    return xr.Dataset(
        {
            "u_east_ms": ("time", u_e * nanf, variable_attrs("m s-1", "eastward_wind")),
            "v_north_ms": ("time", v_n * nanf, variable_attrs("m s-1", "northward_wind")),
            "w_up_ms": ("time", uz * nanf, variable_attrs("m s-1", "upward_air_velocity")),
            "t_sonic_k": ("time", (ts_c + ZERO_CELSIUS_K) * nanf, variable_attrs(
                "K", "virtual_temperature", comment="CSAT3 sonic temperature (approximately "
                "the virtual temperature)", units_metadata="temperature: on_scale")),
            "ux_ms": ("time", ux, variable_attrs(
                "m s-1", long_name="CSAT3 Ux as logged (positive into the sensor head)")),
            "uy_ms": ("time", uy, variable_attrs("m s-1", long_name="CSAT3 Uy as logged")),
            "uz_ms": ("time", uz, variable_attrs("m s-1", long_name="CSAT3 Uz as logged (up)")),
            "diag_csat": ("time", diag_i, variable_attrs(
                "1", long_name="CSAT3 diagnostic word as logged (-1: not available)")),
            "qc_mast": ("time", qc, qc_flag_attrs(
                "mast sonic QC bitmask", (QC_OUT_OF_RANGE, QC_SPIKE, QC_MISSING, QC_GAP_FILLED, QC_DIAG))),
        },
        coords={"time": ("time", time, {"long_name": "time (UTC)"})},
    )


def mast_l1(
    paths: TOA5Source | Sequence[TOA5Source], azimuth_deg: float, height_m: float,
    sensor_id: str, max_corrupt_fraction: float = 0.05, despike_window_s: float = 10.0, despike_n_mad: float = 7.0,
    despike: bool = True, max_gap_s: float = 60.0,
) -> xr.Dataset:
    """Build the L1 mast sonic dataset from one or more CSAT3 TOA5 files.

    Parameters
    ----------
    paths : str, Path, RawRecord or sequence of them
        TOA5 files (glob patterns allowed) or their in-memory records
        (:mod:`dronewind.core.raw`); concatenated in time order.
    azimuth_deg : float
        Azimuth the CSAT3 head points to [degree, clockwise from true north].
    height_m : float
        Measurement height above ground [m].
    sensor_id : str
        Identifier of the sonic (manifest ``sonics[].id``).
    max_corrupt_fraction : float, optional
        Largest tolerated fraction of corrupt rows per file [1].
    despike_window_s, despike_n_mad : float, optional
        Moving-MAD despiking window [s] and threshold [scaled MAD].
    despike : bool, optional
        Apply the moving-MAD despiking (QC 2).
    max_gap_s : float, optional
        Gaps in the time stamps up to this length [s] are filled with missing samples on
        the regular grid; longer gaps (separate records, e.g. one file per flight on
        different days) are kept as breaks of the time axis, so that a record of a few
        flights over months does not become months of NaN. The grid phase and the
        despiking window restart after a break.

    Returns
    -------
    xarray.Dataset
        dim ``time`` (UTC, regular grid within each segment, see ``max_gap_s``); ``u_east_ms``,
        ``v_north_ms``, ``w_up_ms``, ``t_sonic_k`` (NaN where ``qc_mast`` != 0), raw ``ux_ms``,
        ``uy_ms``, ``uz_ms`` (as logged), ``diag_csat`` (int32, -1 where absent), ``qc_mast``.
        attrs ``azimuth_deg``, ``height_m``, ``sensor_id``, ``sampling_rate_hz``, ``n_*``
        counts, ``processing_log``.

    Raises
    ------
    InputError
        See :func:`read_toa5`; also a sampling interval that is not constant.

    Notes
    -----
    East/north by :func:`csat3_to_enu`, :math:`w = U_z`, :math:`T_s[K] = T_s[^\\circ C] +
    273.15`. Range limits (CSAT3): :math:`|U_x|, |U_y| \\le 65` m/s, :math:`|U_z| \\le 8`
    m/s, :math:`-30 \\le T_s \\le 50` degC.

    References
    ----------
    Ghirardelli et al. (2025), Sect. 3.2 and 4.4 (same filtering for the mast sonics).
    """
    files = _expand_paths(paths)
    log: list[str] = []
    counts = {"n_lines": 0, "n_corrupt_lines": 0, "n_nonnumeric": 0, "n_record_skips": 0,
              "n_record_restarts": 0}  # fmt: skip
    data = _merge_records(_read_files(files, max_corrupt_fraction, counts, log), files, counts, log,
                          max_corrupt_fraction)
    data, grid = _regular_grid(data, files, max_gap_s, counts)
    ux, uy, uz, ts_c, diag = (_on_grid(data, grid, c) for c in ("Ux", "Uy", "Uz", "Ts", "diag_csat"))
    del data  # the rows are on the grid now; a day of 20 Hz rows is 120 MB
    qc = _mast_qc(ux, uy, uz, ts_c, diag, grid, despike, despike_window_s, despike_n_mad, counts)
    log.append(f"grid: {grid.fs_hz:g} Hz, {counts['n_missing']} absent time stamps inserted as missing; "
               f"{counts['n_record_breaks']} record breaks (gaps > {max_gap_s:g} s kept as breaks, not filled)")
    log.append(
        f"qc: {counts['n_nan_values']} NAN samples, {counts['n_diag_flagged']} non-zero "
        f"diag_csat, {counts['n_out_of_range']} out of CSAT3 range, {counts['n_spikes']} spikes "
        f"(moving MAD {despike_window_s:g} s, {despike_n_mad:g} scaled MAD"
        f"{'' if despike else ', off'}); {counts['n_flagged']} of {grid.time.size} samples set to NaN"
    )
    ds = _mast_dataset(ux, uy, uz, ts_c, diag, qc, grid.time, azimuth_deg)
    ds.attrs.update({k: int(v) for k, v in counts.items()})
    ds.attrs.update(azimuth_deg=float(azimuth_deg), height_m=float(height_m), sensor_id=str(sensor_id),
                    sampling_rate_hz=float(round(grid.fs_hz, 6)), source_files=", ".join(f.name for f in files),
                    processing_log="\n".join(log))
    return ds
