"""Sonic L1 of the SAMURAI-S-type payload: wind and sonic temperature on the full UTC clock.

The sonic rows (:func:`dronewind.payload.reader.read_sonic_csv`) are put on UTC with the
logger clock fit (:mod:`dronewind.payload.clock`); a forward step of the logger clock with no
step in the INS relation is a data gap whose samples are inserted as missing (up to
``max_gap_s``). Values out of the instrument's range
(:data:`dronewind.core.filtering.INSTRUMENT_LIMITS`), NaN values and spikes are flagged in
the ``qc_sonic`` bitmask (bits of :mod:`dronewind.core.qc`) and set to NaN.
"""

from __future__ import annotations

import os

import numpy as np
import xarray as xr

from dronewind.core.angles import rad2deg
from dronewind.core.cf import variable_attrs
from dronewind.core.constants import ZERO_CELSIUS_K
from dronewind.core.filtering import INSTRUMENT_LIMITS, despike_moving_mad, range_mask
from dronewind.core.qc import QC_MISSING, QC_OUT_OF_RANGE, QC_SPIKE, qc_flag_attrs
from dronewind.core.raw import RawRecord
from dronewind.core.timeseries import median_of_steps
from dronewind.errors import InputError
from dronewind.payload.clock import ClockFit, _finish_attrs, _nominal_rate
from dronewind.payload.ins import InsTable, _fresh, _load_ins
from dronewind.payload.reader import _N_LOGGED_LINES, _US, ClockJumpError, read_sonic_csv

__all__ = [
    "payload_sonic_l1",
]


def _insert_missing(rpi_time_us: np.ndarray, gap_factor: float = 1.5
                    ) -> tuple[np.ndarray, np.ndarray, int, list[tuple[int, float]]]:  # fmt: skip
    """Insert evenly spaced missing samples into gaps longer than gap_factor median steps.

    Returns new times, index of the source row (-1 for inserted), number inserted, and
    the (time, length [s]) of gaps longer than 1 s.
    """
    t = rpi_time_us
    n = t.size
    if n < 3:
        return t.copy(), np.arange(n), 0, []
    d = np.diff(t)
    dt = median_of_steps(d)
    m = np.where(d > gap_factor * dt, np.rint(d / dt).astype(np.int64) - 1, 0)
    m = np.maximum(m, 0)
    total_missing = int(m.sum())
    long_gaps = [(int(t[i]), d[i] / _US) for i in np.flatnonzero(d > _US)]
    if total_missing == 0:
        return t.copy(), np.arange(n), 0, long_gaps
    rep = np.concatenate([m, [0]]) + 1
    src = np.repeat(np.arange(n), rep)
    first = np.repeat(np.cumsum(rep) - rep, rep)
    j = np.arange(src.size) - first
    step = np.concatenate([d / (m + 1), [0.0]])
    new_t = t[src] + np.rint(j * step[src]).astype(np.int64)
    src_idx = np.where(j == 0, src, -1)
    return new_t, src_idx, total_missing, long_gaps


def _after_stable_time(cols: dict[str, np.ndarray], rpi_stable_us: int, sonic_path: str | os.PathLike[str] | RawRecord,
                       counts: dict[str, int], log: list[str]) -> dict[str, np.ndarray]:
    """Sonic rows from the INS's stable valid GNSS time on (earlier rows discarded and counted)."""
    t = cols["rpi_time_us"]
    before = t < rpi_stable_us
    n_before = int(before.sum())
    if n_before == t.size:
        raise InputError(sonic_path, f"all {t.size} sonic rows precede the INS's stable valid GNSS time: the sonic's "
                         f"logger time ends {(rpi_stable_us - int(t.max())) / _US:.1f} s before it (rpi_time_us "
                         f"{int(t.max())} < {rpi_stable_us}); expected sonic rows after it (the sonic and INS files "
                         "of one flight, logging together)")
    cols = {k: v[~before] for k, v in cols.items()}
    counts["n_before_stable_time"] = n_before
    log.append(f"gnss_time: {n_before} sonic rows before the INS's stable GNSS time discarded")
    return cols


def _sonic_on_full_clock(cols: dict[str, np.ndarray], sonic_path: str | os.PathLike[str] | RawRecord, max_gap_s: float,
                         counts: dict[str, int], log: list[str],
                         ) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """The sonic with its logger-time gaps filled by missing samples.

    A forward step longer than ``max_gap_s`` [s] raises :class:`ClockJumpError`.

    Returns
    -------
    t_full : numpy.ndarray
        Logger times with the inserted samples [us].
    vals : dict of numpy.ndarray
        ``u_ms``, ``v_ms``, ``w_ms``, ``t_sonic_c``, NaN at inserted samples.
    have : numpy.ndarray
        True for logged (not inserted) samples.
    """
    steps = np.diff(cols["rpi_time_us"])
    if steps.size and steps.max() > max_gap_s * _US:
        i = int(np.argmax(steps))
        raise ClockJumpError(
            f"{sonic_path}", f"rpi_time_us steps forward by {steps[i] / _US:.1f} s "
            f"(> max_gap_s = {max_gap_s:g} s) after rpi_time_us={int(cols['rpi_time_us'][i])}: "
            "not a plausible data gap; clock jump or corrupt time stamps",
        )
    t_full, src, n_missing, long_gaps = _insert_missing(cols["rpi_time_us"])
    counts["n_missing"] = n_missing
    counts["n_gaps_over_1s"] = len(long_gaps)
    msg = f"gaps: {n_missing} missing samples inserted as NaN"
    if long_gaps:
        msg += "; gaps > 1 s (logger clock continuous per INS, so data gaps) at rpi_time_us " + \
            ", ".join(f"{tt} ({g:.2f} s)" for tt, g in long_gaps[:_N_LOGGED_LINES])  # fmt: skip
    log.append(msg)
    have = src >= 0
    vals = {}
    for name in ("u_ms", "v_ms", "w_ms", "t_sonic_c"):
        x = np.full(t_full.size, np.nan)
        x[have] = cols[name][src[have]]
        vals[name] = x
    return t_full, vals, have


def _sonic_qc(vals: dict[str, np.ndarray], have: np.ndarray, fs_hz: float, apply_elevation_limit: bool,
              despike_window_s: float, despike_n_mad: float, counts: dict[str, int], log: list[str],
              source: str | os.PathLike[str] | RawRecord = "sonic") -> np.ndarray:
    """Missing, range (RM Young 81000) and spike flags of the sonic; flagged samples set to NaN in ``vals``.

    A column without a single valid value raises :class:`InputError` naming the file and
    the column (a flag on one variable sets the whole sample to NaN, so later steps could
    not tell which column was empty).

    Parameters
    ----------
    vals : dict of numpy.ndarray
        ``u_ms``, ``v_ms``, ``w_ms`` [m s-1], ``t_sonic_c`` [degC]; modified in place.
    have : numpy.ndarray
        Logged (not inserted) samples.
    fs_hz : float
        Nominal rate [Hz].
    apply_elevation_limit : bool
        Also flag elevation angles beyond +/-60 deg.
    despike_window_s, despike_n_mad : float
        Moving-MAD window [s] and threshold [scaled MAD].
    counts, log
        Receive ``n_out_of_range``, ``n_missing_values``, ``n_spikes``, ``n_flagged`` and
        the ``qc:`` line.

    Returns
    -------
    numpy.ndarray
        int8 QC bitmask (:mod:`dronewind.core.qc`).
    """
    n = have.size
    empty = [name for name in ("u_ms", "v_ms", "w_ms", "t_sonic_c") if not np.isfinite(vals[name][have]).any()]
    if empty:
        raise InputError(f"{source} [{', '.join(empty)}]", f"column(s) {', '.join(empty)} hold no valid value in the "
                         f"{int(have.sum())} sonic rows after the INS's stable GNSS time; expected numbers in m s-1 "
                         "(speeds) and degC (temperature)")
    qc = np.zeros(n, dtype=np.int8)
    missing = ~(np.isfinite(vals["u_ms"]) & np.isfinite(vals["v_ms"])
                & np.isfinite(vals["w_ms"]) & np.isfinite(vals["t_sonic_c"]))  # fmt: skip
    qc[missing] |= QC_MISSING
    n_nan_values = int((missing & have).sum())
    lim = INSTRUMENT_LIMITS["rmyoung_81000"]
    with np.errstate(invalid="ignore"):
        speed = np.sqrt(vals["u_ms"] ** 2 + vals["v_ms"] ** 2 + vals["w_ms"] ** 2)
        out = range_mask(speed, *lim["speed_ms"]) | range_mask(vals["t_sonic_c"],
                                                               *lim["t_sonic_c"])  # fmt: skip
        if apply_elevation_limit:
            elev = rad2deg(np.arctan2(vals["w_ms"], np.hypot(vals["u_ms"], vals["v_ms"])))
            out |= range_mask(elev, *lim["elevation_deg"])
    qc[out] |= QC_OUT_OF_RANGE
    n_logged = max(int(have.sum()), 1)
    if out.sum() > 0.5 * n_logged:
        raise InputError(f"{source} [u_ms, v_ms, w_ms, t_sonic_c]",
                         f"{int(out.sum())} of {n_logged} sonic samples ({100 * out.sum() / n_logged:.0f} %) beyond "
                         f"the RM Young 81000 range (|V| <= {lim['speed_ms'][1]:g} m/s, {lim['t_sonic_c'][0]:g}.."
                         f"{lim['t_sonic_c'][1]:g} degC; median |V| {np.nanmedian(speed):.3g}): expected m s-1 and "
                         "degC, not another unit (cm/s, km/h, K)")
    spikes = np.zeros(n, dtype=bool)
    for name in ("u_ms", "v_ms", "w_ms", "t_sonic_c"):
        x = np.where(qc == 0, vals[name], np.nan)
        spikes |= despike_moving_mad(x, fs_hz, despike_window_s, despike_n_mad)
    qc[spikes] |= QC_SPIKE
    flagged = qc != 0
    for name in vals:
        vals[name] = np.where(flagged, np.nan, vals[name])
    counts["n_out_of_range"] = int(out.sum())
    counts["n_missing_values"] = n_nan_values
    counts["n_spikes"] = int(spikes.sum())
    counts["n_flagged"] = int(flagged.sum())
    log.append(
        f"qc: {int(out.sum())} samples out of range (RM Young 81000: |V| <= 40 m/s, "
        f"-50..50 degC), {n_nan_values} NaN values, {int(spikes.sum())} spikes (moving MAD, "
        f"{despike_window_s:g} s, {despike_n_mad:g} scaled MAD); {int(flagged.sum())} of "
        f"{n} samples flagged and set to NaN"
    )
    return qc


def _count_extrapolated(t_full: np.ndarray, fit: ClockFit, counts: dict[str, int], log: list[str]) -> None:
    """Count the sonic samples outside the span of the clock fit (their UTC is extrapolated)."""
    outside = (t_full < fit.rpi_first_us) | (t_full > fit.rpi_last_us)
    counts["n_time_extrapolated"] = int(outside.sum())
    if outside.any():
        log.append(f"clock_fit: {int(outside.sum())} sonic samples outside the INS time span, "
                   "UTC extrapolated from the fit")  # fmt: skip


def _sonic_dataset(vals: dict[str, np.ndarray], qc: np.ndarray, t_full: np.ndarray, time: np.ndarray) -> xr.Dataset:
    """The payload sonic L1 variables on ``time`` (see :func:`payload_sonic_l1`, Returns)."""
    return xr.Dataset(
        {
            "u_sensor_ms": ("time", vals["u_ms"], variable_attrs(
                "m s-1", long_name="air velocity along sensor x axis (sensor frame, as logged)")),
            "v_sensor_ms": ("time", vals["v_ms"], variable_attrs(
                "m s-1", long_name="air velocity along sensor y axis (sensor frame, as logged)")),
            "w_sensor_ms": ("time", vals["w_ms"], variable_attrs(
                "m s-1", long_name="air velocity along sensor z axis (sensor frame, as logged)")),
            "t_sonic_k": ("time", vals["t_sonic_c"] + ZERO_CELSIUS_K, variable_attrs(
                "K", "virtual_temperature", comment="sonic temperature (approximately the "
                "virtual temperature)", units_metadata="temperature: on_scale")),
            "rpi_time_us": ("time", t_full.astype(np.int64), variable_attrs(
                "us", long_name="logger (Raspberry Pi) clock time stamp; inserted missing "
                "samples are interpolated")),
            "qc_sonic": ("time", qc, qc_flag_attrs("payload sonic quality control bitmask")),
        },
        coords={"time": ("time", time, {"long_name": "time (UTC, from the logger clock "
                                                    "through the INS clock fit)"})},  # fmt: skip
    )


def payload_sonic_l1(
    sonic_path: str | os.PathLike[str] | RawRecord, ins_path: str | os.PathLike[str] | RawRecord,
    min_stable_s: float = 10.0,
    clock_jump_tol_s: float = 1.0, relation_jump_tol_s: float = 0.1, max_corrupt_fraction: float = 0.05,
    despike_window_s: float = 10.0, despike_n_mad: float = 7.0, apply_elevation_limit: bool = False,
    max_gap_s: float = 60.0, ins_table: InsTable | None = None,
) -> xr.Dataset:
    """Build the L1 payload sonic dataset: logger clock to UTC, range/spike/missing QC.

    Parameters
    ----------
    sonic_path : str, Path or RawRecord
        Sonic CSV (``docs/data-contract.md`` "Payload sonic file") or its in-memory record.
    ins_path : str, Path or RawRecord
        INS CSV of the same flight (shares the logger clock) or its in-memory record.
    min_stable_s, clock_jump_tol_s, relation_jump_tol_s, max_corrupt_fraction : float
        As :func:`ins_l1`; `clock_jump_tol_s` applies to the sonic file too.
    despike_window_s : float, optional
        Moving-MAD window [s]; default 10 s.
    despike_n_mad : float, optional
        Moving-MAD threshold [scaled MAD]; default 7.
    apply_elevation_limit : bool, optional
        Also flag samples whose elevation angle exceeds the RM Young 81000's +/-60 deg.
    max_gap_s : float, optional
        Longest forward step of the sonic's logger time accepted as a data gap [s]; a
        longer one raises :class:`ClockJumpError` (default 60 s).
    ins_table : InsTable, optional
        Output of :func:`load_ins_table` for ``ins_path`` (not parsed again).

    Returns
    -------
    xarray.Dataset
        dim ``time`` (UTC from the clock fit); ``u_sensor_ms``, ``v_sensor_ms``,
        ``w_sensor_ms`` (sensor frame as logged), ``t_sonic_k``, ``rpi_time_us``,
        ``qc_sonic`` (1 out of range, 2 spike, 4 missing/corrupt). A flag on a sample sets
        all four variables of that sample to NaN (not filled). Gaps in the logger time are
        filled with missing samples (``n_missing``). Sonic rows logged before the INS's
        stable GNSS time are discarded (``n_before_stable_time``); rows outside the span
        of the clock fit are extrapolated and counted (``n_time_extrapolated``).

    Raises
    ------
    InputError, ClockJumpError
        See the module docstring.

    Notes
    -----
    Range limits: RM Young 81000 (Ghirardelli et al. 2025, Table 2) speed
    :math:`\\sqrt{u^2+v^2+w^2} \\le 40` m/s, sonic temperature -50..50 degC. Each of u, v,
    w and T is despiked separately (:func:`dronewind.core.filtering.despike_moving_mad`) after
    range-flagged and missing samples are removed; a spike in any flags the sample.

    References
    ----------
    Ghirardelli et al. (2025), Sect. 3.2.
    """
    ins = _fresh(ins_table) if ins_table is not None else _load_ins(
        ins_path, min_stable_s, clock_jump_tol_s, relation_jump_tol_s, max_corrupt_fraction)
    cols, counts, log = read_sonic_csv(sonic_path, max_corrupt_fraction, clock_jump_tol_s)
    cols = _after_stable_time(cols, ins.rpi_stable_us, sonic_path, counts, log)
    t_full, vals, have = _sonic_on_full_clock(cols, sonic_path, max_gap_s, counts, log)
    fs_hz = _nominal_rate(t_full)
    qc = _sonic_qc(vals, have, fs_hz, apply_elevation_limit, despike_window_s, despike_n_mad, counts, log,
                   sonic_path)
    _count_extrapolated(t_full, ins.fit, counts, log)
    log = [*log, *(f"ins {line}" for line in ins.log)]
    counts["n_ins_before_stable_time"] = ins.counts["n_before_stable_time"]
    time = ins.fit.to_utc(t_full, resolution_ns=1000)  # 1 us: far below the fit's scatter
    ds = _sonic_dataset(vals, qc, t_full, time)
    _finish_attrs(ds, counts, log, ins.fit, fs_hz, str(sonic_path), t_full)
    ds.attrs["ins_source_file"] = str(ins_path)
    return ds
