"""INS L1 of the SAMURAI-S-type payload: position, velocity and attitude on UTC, quality-controlled.

The INS rows (:func:`dronewind.payload.reader.read_ins_csv`) are put on UTC with the logger
clock fit (:mod:`dronewind.payload.clock`), checked against the instrument's ranges,
despiked, and flagged in the ``qc_ins`` bitmask (bits of :mod:`dronewind.core.qc`); values
removed are set to NaN, not filled.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import bottleneck as bn
import numpy as np
import xarray as xr

from dronewind.core.angles import deg2rad, rad2deg
from dronewind.core.cf import variable_attrs
from dronewind.core.filtering import INSTRUMENT_LIMITS, despike_moving_mad, range_mask
from dronewind.core.qc import QC_MISSING, QC_OUT_OF_RANGE, QC_SPIKE, qc_flag_attrs
from dronewind.core.raw import RawRecord
from dronewind.core.reuse import reused
from dronewind.core.timeseries import unwrap_rad
from dronewind.errors import InputError
from dronewind.payload.clock import ClockFit, _finish_attrs, _nominal_rate, _stable_valid_start, fit_logger_clock
from dronewind.payload.reader import _US, ClockJumpError, read_ins_csv

__all__ = [
    "InsTable",
    "ins_l1",
    "load_ins_table",
]


@dataclass
class InsTable:
    """A parsed INS file from its stable valid GNSS time on, with the logger-clock fit.

    Attributes
    ----------
    columns : dict of numpy.ndarray
        INS columns (:data:`INS_COLUMNS`), rows sorted by logger time.
    line_no : numpy.ndarray
        File line number of every row.
    fit : ClockFit
        Logger clock to UTC.
    rpi_stable_us : int
        Logger time of the first row with a stable valid GNSS time [us].
    counts : dict of int
        ``n_*`` counts of the parsing.
    log : list of str
        Processing log lines.
    """

    columns: dict[str, np.ndarray]
    line_no: np.ndarray
    fit: ClockFit
    rpi_stable_us: int
    counts: dict[str, int]
    log: list[str]


def _load_ins(
    path: str | os.PathLike[str] | RawRecord,
    min_stable_s: float,
    clock_jump_tol_s: float,
    relation_jump_tol_s: float,
    max_corrupt_fraction: float,
) -> InsTable:
    cols, line_no, counts, log = read_ins_csv(path, max_corrupt_fraction, clock_jump_tol_s)
    t = cols["rpi_time_us"]
    start = _stable_valid_start(t, cols["time_valid"], min_stable_s)
    if start is None:
        raise InputError(
            path,
            f"no stable valid GNSS time: time_valid never stays 1 for >= {min_stable_s:g} s "
            "(Ghirardelli et al. 2025, Sect. 3.2: data before a stable valid GNSS time are discarded)",
        )
    counts["n_before_stable_time"] = int(start)
    log.append(
        f"gnss_time: stable valid GNSS time from line {int(line_no[start])} "
        f"(rpi_time_us={int(t[start])}); {start} earlier INS rows discarded"
    )
    # the rows from the stable start on: copies of the columns' ends (a gather of the same rows
    # by an index array would give the same arrays, at several times the cost)
    cols = {k: v[start:].copy() for k, v in cols.items()}
    line_no = line_no[start:].copy()
    t = cols["rpi_time_us"]
    fit_rows = np.flatnonzero((cols["time_valid"] == 1) & ~np.isnat(cols["utc"]))
    # Relation jumps: the offset utc - rpi_time, median-filtered over 11 rows so that a
    # single late stamp is not a jump, must not step by more than relation_jump_tol_s.
    off_s = (
        (cols["utc"][fit_rows] - cols["utc"][fit_rows[0]]).astype(np.int64) / 1e9
        - (t[fit_rows] - t[fit_rows[0]]) / _US
    )
    if off_s.size >= 3:
        w = min(11, off_s.size if off_s.size % 2 else off_s.size - 1)
        h = w // 2
        pad = np.concatenate([np.full(h, off_s[0]), off_s, np.full(h, off_s[-1])])
        smooth = bn.move_median(pad, window=w)[2 * h :]
        step = np.abs(np.diff(smooth))
        jumps = np.flatnonzero(step > relation_jump_tol_s)
        if jumps.size:
            j = int(fit_rows[jumps[0] + 1])
            raise ClockJumpError(
                f"{path}:{int(line_no[j])}",
                f"the relation utc - rpi_time steps by {step[jumps[0]]:.3f} s "
                f"(> {relation_jump_tol_s:g} s) near rpi_time_us={int(t[j])}: logger clock or "
                "GNSS time jump; not corrected, fix or split the flight",
            )
    # inside a forward flight's runs, an INS probe leaves the times alone: the fit is reused
    # (dronewind.core.reuse; a frozen dataclass)
    fit_t, fit_utc = t[fit_rows], cols["utc"][fit_rows]
    fit = reused("logger-clock fit", {"rpi_time_us": fit_t, "utc": fit_utc}, "",
                 lambda: fit_logger_clock(fit_t, fit_utc))
    log.append(
        f"clock_fit: utc = a + b*rpi_time on {fit.n_used} rows ({fit.n_outliers} outliers): "
        f"drift {fit.drift_ppm:.3f} ppm, residual std {fit.residual_std_s * 1e6:.2f} us"
    )
    return InsTable(cols, line_no, fit, int(t[0]), counts, log)


def load_ins_table(
    ins_path: str | os.PathLike[str] | RawRecord,
    min_stable_s: float = 10.0,
    clock_jump_tol_s: float = 1.0,
    relation_jump_tol_s: float = 0.1,
    max_corrupt_fraction: float = 0.05,
) -> InsTable:
    """Parse an INS file once: rows from the stable valid GNSS time and the logger-clock fit.

    Pass the result as ``ins_table`` to :func:`ins_l1` and :func:`payload_sonic_l1` so a
    flight's INS file is read once for both (it is the slowest file of a flight).
    Parameters are those of :func:`ins_l1`.
    """
    return _load_ins(ins_path, min_stable_s, clock_jump_tol_s, relation_jump_tol_s, max_corrupt_fraction)


def _fresh(table: InsTable) -> InsTable:
    """A copy whose counts and log can be extended without touching the original."""
    return InsTable(table.columns, table.line_no, table.fit, table.rpi_stable_us, dict(table.counts),
                     list(table.log))


def _utc_of_rows(ins: InsTable, counts: dict[str, int], log: list[str]) -> np.ndarray:
    """UTC of every INS row: the GNSS time, or the clock fit where it is not valid.

    Returns
    -------
    numpy.ndarray
        datetime64[ns] per row (rows after the stable start whose ``time_valid`` blinked to 0
        are stamped from the fit, whole microseconds; counted in ``n_time_from_clock_fit``).
    """
    cols = ins.columns
    utc = cols["utc"].copy()
    from_fit = (cols["time_valid"] != 1) | np.isnat(utc)
    utc[from_fit] = ins.fit.to_utc(cols["rpi_time_us"][from_fit], resolution_ns=1000)
    counts["n_time_from_clock_fit"] = int(from_fit.sum())
    if from_fit.any():
        log.append(f"gnss_time: {int(from_fit.sum())} rows after the stable start without "
                   "valid GNSS time stamped from the clock fit")  # fmt: skip
    return utc


def _increasing_utc(utc: np.ndarray, counts: dict[str, int], log: list[str]) -> tuple[np.ndarray, bool]:
    """Rows in UTC order with repeated UTC stamps dropped (a GNSS glitch): their indices, and
    whether those are all rows in their own order."""
    order = np.argsort(utc, kind="stable")
    n_utc_unsorted = int((order != np.arange(order.size)).sum())
    utc_sorted = utc[order]
    dup = np.zeros(order.size, dtype=bool)
    dup[1:] = utc_sorted[1:] == utc_sorted[:-1]
    counts["n_utc_duplicates"] = int(dup.sum())
    counts["n_utc_out_of_order"] = n_utc_unsorted
    if dup.any() or n_utc_unsorted:
        log.append(f"gnss_time: {int(dup.sum())} rows repeating a UTC stamp dropped, "
                   f"{n_utc_unsorted} rows re-ordered by UTC")  # fmt: skip
        return order[~dup], False
    return order, True


def _ins_qc(cols: dict[str, np.ndarray], fs_hz: float, despike: bool, counts: dict[str, int], log: list[str],
            path: str | os.PathLike[str] | RawRecord = "ins") -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Range, missing and (optional) spike flags of the INS; flagged rows set to NaN.

    A variable without a single valid value raises :class:`InputError` naming the file and
    the column (a flagged value flags its whole row, so later steps could not tell which
    column was empty).

    Parameters
    ----------
    cols : dict of numpy.ndarray
        INS columns (UTC order).
    fs_hz : float
        Nominal rate [Hz] (despiking window).
    despike : bool
        Apply the moving-MAD despiking to attitude, velocity and altitude.
    counts, log
        Receive ``n_out_of_range``, ``n_missing_values``, ``n_spikes``, ``n_flagged`` and
        the ``qc:`` line.

    Returns
    -------
    data : dict of numpy.ndarray
        Float INS variables, NaN where flagged.
    qc : numpy.ndarray
        int8 QC bitmask (:mod:`dronewind.core.qc`).
    """
    qc = np.zeros(cols["rpi_time_us"].size, dtype=np.int8)
    lim = INSTRUMENT_LIMITS["sbg_ellipse_d"]
    float_vars = {
        "roll_deg": lim["roll_deg"], "pitch_deg": lim["pitch_deg"], "yaw_deg": lim["yaw_deg"],
        "vel_n_ms": lim["vel_ms"], "vel_e_ms": lim["vel_ms"], "vel_d_ms": lim["vel_ms"],
        "lat_deg": lim["lat_deg"], "lon_deg": lim["lon_deg"], "alt_m": lim["alt_m"],
    }  # fmt: skip
    data: dict[str, np.ndarray] = {}
    n_range = n_nan = 0
    for name, (lo, hi) in float_vars.items():
        x = cols[name].astype(float)
        missing = ~np.isfinite(x)
        bad = range_mask(np.where(missing, np.nan, x), lo, hi)
        if (missing | bad).all():
            raise InputError(f"{path} [{name}]", f"column {name} holds no valid value in its {x.size} rows after the "
                             f"stable GNSS time ({int(missing.sum())} empty or NaN, {int(bad.sum())} outside "
                             f"[{lo:g}, {hi:g}]); expected the INS's {name}")
        n_range += int(bad.sum())
        n_nan += int(missing.sum())
        qc[bad] |= QC_OUT_OF_RANGE
        qc[missing] |= QC_MISSING
        data[name] = x
    n_spike = _despike_ins(data, qc, fs_hz) if despike else 0
    flagged = qc != 0
    for name in float_vars:
        data[name] = np.where(flagged, np.nan, data[name])
    counts["n_out_of_range"] = n_range
    counts["n_missing_values"] = n_nan
    counts["n_spikes"] = n_spike
    counts["n_flagged"] = int(flagged.sum())
    log.append(
        f"qc: {n_range} values out of range (SBG Ellipse-D limits), {n_nan} NaN values, "
        f"{n_spike} spikes{'' if despike else ' (despiking off)'}; {int(flagged.sum())} rows "
        "flagged and set to NaN"
    )
    return data, qc


def _despike_ins(data: dict[str, np.ndarray], qc: np.ndarray, fs_hz: float) -> int:
    """Moving-MAD spike flags (QC_SPIKE, set in ``qc``) of attitude, velocity, altitude and unwrapped yaw.

    Returns
    -------
    int
        Number of spike flags set (a sample may count once per variable).
    """
    n_spike = 0
    for name in ("roll_deg", "pitch_deg", "vel_n_ms", "vel_e_ms", "vel_d_ms", "alt_m"):
        x = np.where(qc == 0, data[name], np.nan)
        s = despike_moving_mad(x, fs_hz)
        qc[s] |= QC_SPIKE
        n_spike += int(s.sum())
    yaw_unwrapped = rad2deg(unwrap_rad(deg2rad(np.nan_to_num(data["yaw_deg"]))))
    s = despike_moving_mad(np.where(qc == 0, yaw_unwrapped, np.nan), fs_hz)
    qc[s] |= QC_SPIKE
    n_spike += int(s.sum())
    return n_spike


def _yaw_convention(yaw_deg: np.ndarray) -> str:
    """The range convention of the logged yaw, from its finite values."""
    yaw = yaw_deg[np.isfinite(yaw_deg)]
    if yaw.size and yaw.min() < 0:
        return "(-180, 180]"
    if yaw.size and yaw.max() > 180:
        return "[0, 360)"
    return "ambiguous: all values in [0, 180]"


def _ins_dataset(data: dict[str, np.ndarray], cols: dict[str, np.ndarray], qc: np.ndarray, utc: np.ndarray,
                 rpi_time_us: np.ndarray) -> xr.Dataset:
    """The INS L1 variables on ``time`` (see :func:`ins_l1`, Returns)."""
    yaw_conv = _yaw_convention(data["yaw_deg"])
    return xr.Dataset(
        {
            "roll_deg": ("time", data["roll_deg"], variable_attrs("degree", "platform_roll")),
            "pitch_deg": ("time", data["pitch_deg"], variable_attrs("degree", "platform_pitch")),
            "yaw_deg": ("time", data["yaw_deg"], variable_attrs(
                "degree", "platform_yaw", comment=f"clockwise from true north, as logged "
                f"(range {yaw_conv}); wrap not removed")),
            "vel_n_ms": ("time", data["vel_n_ms"], variable_attrs(
                "m s-1", long_name="northward velocity of the sonic measurement volume")),
            "vel_e_ms": ("time", data["vel_e_ms"], variable_attrs(
                "m s-1", long_name="eastward velocity of the sonic measurement volume")),
            "vel_d_ms": ("time", data["vel_d_ms"], variable_attrs(
                "m s-1", long_name="downward velocity of the sonic measurement volume")),
            "lat_deg": ("time", data["lat_deg"], variable_attrs("degrees_north", "latitude")),
            "lon_deg": ("time", data["lon_deg"], variable_attrs("degrees_east", "longitude")),
            "alt_m": ("time", data["alt_m"], variable_attrs(
                "m", "altitude", positive="up", comment="above mean sea level")),
            "ekf_valid": ("time", cols["ekf_valid"].astype(np.int32), variable_attrs(
                "1", long_name="INS extended Kalman filter solution valid (1) or not (0)")),
            "time_valid": ("time", cols["time_valid"].astype(np.int8), variable_attrs(
                "1", long_name="GNSS UTC valid (1) or not (0); 0 rows are stamped from the "
                "clock fit")),
            "rpi_time_us": ("time", rpi_time_us.astype(np.int64), variable_attrs(
                "us", long_name="logger (Raspberry Pi) clock time stamp")),
            "qc_ins": ("time", qc, qc_flag_attrs("INS quality control bitmask")),
        },
        coords={"time": ("time", utc.astype("datetime64[ns]"), {"long_name": "time (UTC)"})},
    )


def ins_l1(
    ins_path: str | os.PathLike[str] | RawRecord, min_stable_s: float = 10.0, clock_jump_tol_s: float = 1.0,
    relation_jump_tol_s: float = 0.1, max_corrupt_fraction: float = 0.05, despike: bool = False,
    ins_table: InsTable | None = None,
) -> xr.Dataset:
    """Build the L1 INS dataset (UTC time from the ``utc`` column, QC flags).

    Parameters
    ----------
    ins_path : str, Path or RawRecord
        INS CSV (``docs/data-contract.md`` "INS file") or its in-memory record.
    min_stable_s : float, optional
        A stable valid GNSS time starts at the first row from which ``time_valid`` stays 1
        for at least this long [s]; default 10 s. Earlier rows are discarded (counted in
        ``n_before_stable_time``).
    clock_jump_tol_s : float, optional
        Backward step of ``rpi_time_us`` in row order above which :class:`ClockJumpError`
        is raised [s]; smaller steps are sorted.
    relation_jump_tol_s : float, optional
        Step of ``utc - rpi_time`` above which :class:`ClockJumpError` is raised [s].
    max_corrupt_fraction : float, optional
        Largest tolerated fraction of corrupt lines [1].
    despike : bool, optional
        Apply :func:`dronewind.core.filtering.despike_moving_mad` to attitude, velocity and
        altitude. Off by default: the EKF output is smooth, so in a steady hover its MAD is
        tiny and ordinary manoeuvres would be flagged as spikes.
    ins_table : InsTable, optional
        Output of :func:`load_ins_table` for ``ins_path`` (not parsed again).

    Returns
    -------
    xarray.Dataset
        dim ``time`` (UTC, datetime64[ns]); ``roll_deg``, ``pitch_deg``, ``yaw_deg`` (as
        logged, wrap not removed), ``vel_n_ms``, ``vel_e_ms``, ``vel_d_ms``, ``lat_deg``,
        ``lon_deg``, ``alt_m``, ``ekf_valid``, ``time_valid``, ``rpi_time_us``, ``qc_ins``.
        Rows after the stable start whose ``time_valid`` blinked to 0 get their time from
        the clock fit (``n_time_from_clock_fit``). attrs: ``n_*`` counts, clock fit
        (``clock_drift_ppm``, ``clock_residual_std_s``, ...), ``sampling_rate_hz``,
        ``processing_log``.

    Raises
    ------
    InputError
        Bad header, too many corrupt lines, or no stable valid GNSS time.
    ClockJumpError
        Logger clock or GNSS time jump.

    References
    ----------
    Ghirardelli et al. (2025), Sect. 3.2.
    """
    ins = _fresh(ins_table) if ins_table is not None else _load_ins(
        ins_path, min_stable_s, clock_jump_tol_s, relation_jump_tol_s, max_corrupt_fraction)
    counts, log = ins.counts, ins.log
    t_rpi = ins.columns["rpi_time_us"]
    utc = _utc_of_rows(ins, counts, log)
    sel, in_order = _increasing_utc(utc, counts, log)
    # rows already in UTC order, none dropped (the usual case), are copied without the gather
    cols = {k: v.copy() if in_order else v[sel] for k, v in ins.columns.items()}
    ins_steps = np.diff(t_rpi[sel])
    counts["n_gaps_over_1s"] = int((ins_steps > _US).sum())
    if counts["n_gaps_over_1s"]:
        log.append(f"gaps: {counts['n_gaps_over_1s']} INS gaps > 1 s (not filled; longest "
                   f"{ins_steps.max() / _US:.2f} s)")  # fmt: skip
    fs_hz = _nominal_rate(t_rpi)
    data, qc = _ins_qc(cols, fs_hz, despike, counts, log, ins_path)
    ds = _ins_dataset(data, cols, qc, utc[sel], t_rpi[sel])
    _finish_attrs(ds, counts, log, ins.fit, fs_hz, str(ins_path), t_rpi[sel])
    return ds
