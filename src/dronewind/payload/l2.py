"""The payload's L2: hover window, gap filling, sonic-INS lag, motion-corrected wind and checks.

:func:`payload_l2` builds the L2 data level (``docs/design.md``) in five steps, each a
function of this module:

1. INS gaps (NaN or ``ekf_valid == 0``) filled linearly in time (:func:`_fill_ins_gaps`);
2. hover window = longest contiguous run of
   :func:`dronewind.core.filtering.hover_window_mask` (Ghirardelli et al. (2025), Sect. 3.2;
   :func:`_hover_window`); the 2 % rule applies to the INS too, counting filled samples
   and absent rows (gaps in time) against the samples expected at the INS rate
   (:func:`_ins_coverage`);
3. sonic gaps filled with :func:`dronewind.core.filtering.gap_fill_linear` on the hover
   window +/- ``max_lag_s`` (> 2 % missing: ``usable = 0``, data not filled and the NaN
   samples interpolated only for the lag search; :func:`_sonic_segment`); missing samples
   are counted against the samples the hover window should hold at the sonic rate, so a
   sonic record that ends early counts what it lacks;
4. lag of minimum TKE (:func:`dronewind.payload.lag_search.tke_vs_lag`, Ghirardelli et al. (2025), Sect. 3.3;
   :func:`_sonic_ins_lag`);
5. INS interpolated to the shifted sonic times and the wind corrected
   (:func:`dronewind.payload.motion.motion_correct`, Ghirardelli et al. (2025), Eqs. 1-2;
   :func:`_correct_motion`), east/north/up wind at the sonic rate; the duration is measured
   on the sonic samples used (:func:`_used_duration`), and the plausibility checks of
   :mod:`dronewind.payload.checks` run (hover height, INS velocity against the GNSS position,
   sonic range; :func:`_plausibility`).

Every failed check adds a reason (``usable = 0``); errors name the flight and its files
(the L1 ``source_file`` attributes), the variable and the numbers.

The drone-to-mast alignment (L3) is :mod:`dronewind.compare.align`.

Sign convention (``docs/data-contract.md``): ``lag_sonic_ins_s`` is the time ADDED to the sonic's clock to
align it with the INS: the sonic sample stamped ``t`` is combined with the INS state at
``t + lag``.

Times are handled as float seconds since the first time stamp of the inputs (int64
nanoseconds are subtracted before conversion, so a flight keeps sub-microsecond
resolution).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core import filtering
from dronewind.core.angles import deg2rad, rad2deg
from dronewind.core.cf import variable
from dronewind.core.qc import QC_GAP_FILLED, QC_OUT_OF_RANGE, qc_flag_attrs
from dronewind.core.reuse import reused
from dronewind.core.timeseries import (
    fill_nan_by_time,
    longest_true_run,
    median_step,
    require_variables,
    time_ns,
    unwrap_rad,
)
from dronewind.errors import InputError
from dronewind.payload import checks, motion
from dronewind.payload.lag_search import (
    _INS_VARS,
    _NS,
    _SONIC_VARS,
    _tke_curves,
    find_sonic_ins_lag,
    interpolate_ins,
    subgrid_minimum,
)

__all__ = [
    "payload_l2",
]


# -------------------------------------------------------------------------- L2 builder


@dataclass
class _Trace:
    """What the L2 steps report: processing-log lines, counts ``n_*`` and reasons for ``usable = 0``."""

    log: list[str] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)
    reasons: list[str] = field(default_factory=list)
    where: str = "payload flight"  # flight and files, for messages


def _describe_flight(sonic_l1: xr.Dataset, ins_l1: xr.Dataset, flight_id: str | None) -> str:
    """``flight s01 (sonic flights/s01/sonic.csv, INS flights/s01/ins.csv)`` for messages."""
    files = [f"{kind} {ds.attrs['source_file']}" for kind, ds in (("sonic", sonic_l1), ("INS", ins_l1))
             if ds.attrs.get("source_file")]
    label = f"flight {flight_id}" if flight_id else "payload flight"
    return f"{label} ({', '.join(files)})" if files else label


def _utc(t_ns: int | np.integer) -> str:
    """A time [ns since 1970] as ISO 8601 UTC to the second."""
    return str(np.datetime_as_string(np.datetime64(int(t_ns), "ns"), unit="s")) + "Z"


def _span(t0_ns: int, t1_ns: int) -> str:
    """A duration [ns] in words (s, min, h or days)."""
    s = abs(int(t1_ns) - int(t0_ns)) / _NS
    return f"{s:.1f} s" if s < 120 else f"{s / 60:.1f} min" if s < 7200 else f"{s / 3600:.1f} h" if s < 172800 \
        else f"{s / 86400:.1f} days"


@dataclass
class _SonicSegment:
    """The sonic around the hover window (step 3 of :func:`payload_l2`)."""

    index: np.ndarray  # indices of the segment's samples in the (windowed) sonic record
    time_s: np.ndarray  # their times [s]
    fs_hz: float  # sampling rate [Hz]
    raw: dict[str, np.ndarray]  # variables as in L1 (NaN where flagged)
    filled: dict[str, np.ndarray]  # gap-filled variables
    search: dict[str, np.ndarray]  # variables used for the lag search (always filled)
    nan_any: np.ndarray  # sample had a NaN in any variable
    filled_ok: bool  # few enough samples missing: ``filled`` is the output


def _check_l2_inputs(sonic_l1: xr.Dataset, ins_l1: xr.Dataset, mount: str) -> None:
    """Required variables of both L1 datasets and the mount name, checked early."""
    require_variables(sonic_l1, _SONIC_VARS, "sonic_l1")
    require_variables(ins_l1, _INS_VARS, "ins_l1")
    motion.mount_matrix(mount)  # validates the name early


def _apply_window(sonic_l1: xr.Dataset, ins_l1: xr.Dataset, window: tuple[Any, Any] | None, tr: _Trace,
                  ) -> tuple[xr.Dataset, xr.Dataset, np.ndarray, np.ndarray]:
    """Keep the samples inside the flight window (UTC limits), if one is given.

    Returns
    -------
    sonic_l1, ins_l1 : xarray.Dataset
        The datasets within the window.
    ts_ns, ti_ns : numpy.ndarray
        Their times [ns].
    """
    ts_ns = time_ns(sonic_l1, "sonic_l1")
    ti_ns = time_ns(ins_l1, "ins_l1")
    if window is None:
        return sonic_l1, ins_l1, ts_ns, ti_ns
    w0, w1 = (np.datetime64(w.rstrip("Z") if isinstance(w, str) else w, "ns").astype(np.int64)
              for w in window)
    keep_s = (ts_ns >= w0) & (ts_ns <= w1)
    keep_i = (ti_ns >= w0) & (ti_ns <= w1)
    tr.counts["n_sonic_outside_window"] = int((~keep_s).sum())
    tr.counts["n_ins_outside_window"] = int((~keep_i).sum())
    if keep_s.sum() < 2 or keep_i.sum() < 2:
        raise InputError(f"{tr.where} [window]", _window_miss(int(w0), int(w1), ts_ns, ti_ns, int(keep_s.sum()),
                                                               int(keep_i.sum())))
    sonic_l1 = sonic_l1.isel(time=_kept(keep_s))
    ins_l1 = ins_l1.isel(time=_kept(keep_i))
    ts_ns, ti_ns = ts_ns[keep_s], ti_ns[keep_i]
    tr.log.append(f"window: kept {keep_s.sum()} sonic and {keep_i.sum()} INS samples in the flight window")
    return sonic_l1, ins_l1, ts_ns, ti_ns


def _kept(keep: np.ndarray) -> slice | np.ndarray:
    """The samples ``keep`` marks, as a slice where they are one run (the usual case: sorted times
    in a window), else as indices.

    A slice selects views of the L1's arrays instead of copies of every variable (a forward
    run windows its L1 in every probe). The L2 never writes into its inputs; the L1 of a
    forward flight's cache is read-only besides (:class:`dronewind.diagnose.forward.ForwardCache`).
    """
    index = np.flatnonzero(keep)
    if index.size and index[-1] - index[0] + 1 == index.size:
        return slice(int(index[0]), int(index[-1]) + 1)
    return index


def _window_miss(w0: int, w1: int, ts_ns: np.ndarray, ti_ns: np.ndarray, n_s: int, n_i: int) -> str:
    """Why the manifest window holds (almost) no data: where it lies relative to the data."""
    lo = int(min(ts_ns.min(), ti_ns.min())) if ts_ns.size and ti_ns.size else int(w0)
    hi = int(max(ts_ns.max(), ti_ns.max())) if ts_ns.size and ti_ns.size else int(w1)
    if w0 > hi:
        where = f"the window starts {_span(hi, w0)} after the data end"
    elif w1 < lo:
        where = f"the window ends {_span(w1, lo)} before the data start"
    else:
        where = "the window overlaps the data span but holds almost no samples"
    return (f"the manifest window {_utc(w0)} to {_utc(w1)} holds {n_s} sonic and {n_i} INS samples (at least 2 "
            f"of each expected); the data span {_utc(lo)} to {_utc(hi)}: {where}. Check the window's date and "
            "time zone (UTC)")


def _ins_steps(ins_l1: xr.Dataset, ti: np.ndarray, hover_settings: tuple[float, float, float, float], tr: _Trace,
               ) -> tuple[dict[str, np.ndarray], np.ndarray, tuple[float, float]]:
    """Steps 1 and 2, which read the INS only: :func:`_fill_ins_gaps`, then :func:`_hover_window`.

    Inside a forward flight's runs (:mod:`dronewind.core.reuse`), a probe that leaves the INS
    alone reuses them: the filled INS (read-only), the missing samples and the hover window,
    with the counts, log lines and reasons they added to ``tr``.

    ``ins_l1``, ``ti`` and ``tr`` are those of :func:`_fill_ins_gaps`; ``hover_settings``
    are ``alt_tol_m``, ``horiz_tol_m``, ``min_hover_s`` and ``max_missing_fraction`` of
    :func:`_hover_window`. Returns ``ins``, ``ins_missing`` (as :func:`_fill_ins_gaps`) and
    the hover window (as :func:`_hover_window`).
    """
    def make() -> tuple[dict[str, np.ndarray], np.ndarray, tuple[float, float], _Trace]:
        own = _Trace(where=tr.where)
        ins, ins_missing = _fill_ins_gaps(ins_l1, ti, own)
        hover = _hover_window(ins, ti, ins_missing, *hover_settings, own)
        return ins, ins_missing, hover, own

    arrays = {"ti": ti, **{k: ins_l1[k].values for k in _INS_VARS}}
    if "ekf_valid" in ins_l1.variables:
        arrays["ekf_valid"] = ins_l1["ekf_valid"].values
    ins, ins_missing, hover, own = reused("INS gaps and hover window", arrays, repr((hover_settings, tr.where)), make)
    tr.log.extend(own.log)
    tr.counts.update(own.counts)
    tr.reasons.extend(own.reasons)
    return ins, ins_missing, hover


def _fill_ins_gaps(ins_l1: xr.Dataset, ti: np.ndarray, tr: _Trace) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Step 1: INS gaps (NaN or ``ekf_valid == 0``) filled linearly in time.

    Yaw is unwrapped over the valid samples first, so gaps are bridged the short way.

    Parameters
    ----------
    ins_l1 : xarray.Dataset
        INS L1 (within the window).
    ti : numpy.ndarray
        Its times [s].
    tr : _Trace
        Receives ``n_ins_ekf_invalid``, ``n_ins_filled`` and the ``ins_gaps:`` line.

    Returns
    -------
    ins : dict of numpy.ndarray
        The filled INS variables (yaw unwrapped) [degree, m s-1, m].
    ins_missing : numpy.ndarray
        True where a sample was missing or invalid.
    """
    ins = {k: np.asarray(ins_l1[k].values, dtype=float) for k in _INS_VARS}
    invalid = np.zeros(ti.size, dtype=bool)
    if "ekf_valid" in ins_l1.variables:
        invalid = np.asarray(ins_l1["ekf_valid"].values) == 0
    tr.counts["n_ins_ekf_invalid"] = int(invalid.sum())
    ins_missing = invalid.copy()
    for k in _INS_VARS:
        x = np.where(invalid, np.nan, ins[k])
        ins_missing |= ~np.isfinite(x)
        if k == "yaw_deg":  # unwrap over the valid samples only, so gaps are bridged the short way
            ok = np.isfinite(x)
            x[ok] = rad2deg(unwrap_rad(deg2rad(x[ok])))
        if not np.isfinite(x).any():
            raise InputError(f"{tr.where} [INS {k}]", f"no valid {k} sample among the {ti.size} INS samples "
                             f"({int(invalid.sum())} with ekf_valid=0)")
        ins[k], _ = fill_nan_by_time(ti, x)
    tr.counts["n_ins_filled"] = int(ins_missing.sum())
    tr.log.append(f"ins_gaps: filled {int(ins_missing.sum())} INS samples (NaN or ekf_valid=0) by linear "
                  "interpolation in time")
    return ins, ins_missing


def _hover_window(ins: dict[str, np.ndarray], ti: np.ndarray, ins_missing: np.ndarray, alt_tol_m: float,
                  horiz_tol_m: float, min_hover_s: float, max_missing_fraction: float, tr: _Trace,
                  ) -> tuple[float, float]:
    """Step 2: the hover window, longest contiguous run of the hover mask (Ghirardelli et al. (2025), Sect. 3.2).

    Parameters
    ----------
    ins : dict of numpy.ndarray
        Filled INS (:func:`_fill_ins_gaps`).
    ti : numpy.ndarray
        INS times [s].
    ins_missing : numpy.ndarray
        Samples that were filled.
    alt_tol_m, horiz_tol_m : float
        Hover tolerances [m] (:func:`dronewind.core.filtering.hover_window_mask`).
    min_hover_s : float
        Shortest usable hover [s].
    max_missing_fraction : float
        Largest fraction of filled INS samples in the window.
    tr : _Trace
        Receives the ``n_ins_hover*`` counts, the ``hover:`` line and unusable reasons.

    Returns
    -------
    h0, h1 : float
        First and last INS time of the window [s].
    """
    hover = filtering.hover_window_mask(ins["alt_m"], ins["lat_deg"], ins["lon_deg"],
                                        alt_tol_m=alt_tol_m, horiz_tol_m=horiz_tol_m)
    i0, i1, n_runs = longest_true_run(hover)
    if i1 - i0 < 2:
        raise InputError(f"{tr.where} [INS alt_m, lat_deg, lon_deg]",
                         f"no hover window found among {ti.size} INS samples over {ti[-1] - ti[0]:.1f} s (median "
                         f"altitude +/-{alt_tol_m:g} m, +/-{horiz_tol_m:g} m horizontally)")
    h0, h1 = ti[i0], ti[i1 - 1]
    tr.counts["n_ins_hover"] = i1 - i0
    tr.counts["n_ins_hover_runs"] = n_runs
    tr.counts["n_ins_in_hover_mask_outside_window"] = int(hover.sum()) - (i1 - i0)
    tr.log.append(f"hover: longest of {n_runs} hover runs, {h1 - h0:.1f} s "
                  f"({int(hover.sum()) - (i1 - i0)} hover-mask INS samples outside it dropped)")
    if h1 - h0 < min_hover_s:
        tr.reasons.append(f"hover window {h1 - h0:.1f} s shorter than {min_hover_s:.0f} s")
    _ins_coverage(ti[i0:i1], ins_missing[i0:i1], ti, max_missing_fraction, tr)
    return h0, h1


def _ins_coverage(t_hover: np.ndarray, missing: np.ndarray, ti: np.ndarray, max_missing_fraction: float,
                  tr: _Trace) -> None:
    """The 2 % rule on the INS in the hover window: filled samples plus absent rows (gaps in time).

    Parameters
    ----------
    t_hover : numpy.ndarray
        INS times in the hover window [s].
    missing : numpy.ndarray
        Their samples that were missing or ``ekf_valid = 0`` (filled).
    ti : numpy.ndarray
        All INS times [s] (the nominal step is their median step).
    max_missing_fraction : float
        Largest fraction of missing samples [1] (Ghirardelli et al. (2025), Sect. 3.2: 2 %).
    tr : _Trace
        Receives ``n_ins_filled_in_hover``, ``n_ins_absent_in_hover``, the ``ins_gaps:`` line
        and the unusable reason.
    """
    dt = median_step(ti)
    steps = np.diff(t_hover)
    absent = int(np.sum(np.maximum(np.rint(steps / dt).astype(np.int64) - 1, 0))) if steps.size else 0
    n_expected = t_hover.size + absent
    bad = int(missing.sum())
    longest = float(steps.max()) if steps.size else 0.0
    tr.counts["n_ins_filled_in_hover"] = bad
    tr.counts["n_ins_absent_in_hover"] = absent
    frac = (bad + absent) / max(n_expected, 1)
    tr.log.append(f"ins_gaps: hover window {bad} INS samples NaN or ekf_valid=0 and {absent} absent (longest step "
                  f"{longest:.2f} s) of {n_expected} expected at {1 / dt:.3g} Hz: {100 * frac:.2f} % missing "
                  f"(limit {100 * max_missing_fraction:g} %)")
    if frac > max_missing_fraction:
        tr.reasons.append(f"{100 * frac:.2f} % of the INS samples in the hover window missing ({bad} NaN or "
                          f"ekf_valid=0, {absent} absent, longest gap {longest:.1f} s; limit "
                          f"{100 * max_missing_fraction:g} %)")


def _sonic_segment(sonic_l1: xr.Dataset, ts: np.ndarray, h0: float, h1: float, max_lag_s: float,
                   max_missing_fraction: float, tr: _Trace) -> _SonicSegment:
    """Step 3: the sonic over the hover window +/- ``max_lag_s`` (+ 1 s), gaps filled.

    Gaps are filled with :func:`dronewind.core.filtering.gap_fill_linear`; with more than
    ``max_missing_fraction`` missing the flight is unusable and the data are not filled
    (the NaN samples are interpolated only for the lag search).

    Parameters
    ----------
    sonic_l1 : xarray.Dataset
        Sonic L1 (within the window).
    ts : numpy.ndarray
        Its times [s].
    h0, h1 : float
        Hover window [s].
    max_lag_s : float
        Lag search half-width [s].
    max_missing_fraction : float
        Largest fraction of missing samples that is filled.
    tr : _Trace
        Receives ``n_sonic_missing_rows``, ``n_sonic_filled``, the ``sonic_gaps:`` line and
        unusable reasons.

    Returns
    -------
    _SonicSegment
    """
    seg = np.flatnonzero((ts >= h0 - max_lag_s - 1.0) & (ts <= h1 + max_lag_s + 1.0))
    if seg.size < 16:
        raise InputError(f"{tr.where} [sonic time]",
                         f"the sonic record ({ts.size} samples, {ts[0] - h0:+.1f} s to {ts[-1] - h0:+.1f} s from the "
                         f"hover start) does not overlap the {h1 - h0:.1f} s hover window found in the INS")
    ts_seg = ts[seg]
    dt_nom = median_step(ts_seg)
    fs_hz = float(sonic_l1.attrs.get("sampling_rate_hz", 1.0 / dt_nom))
    raw = {k: np.asarray(sonic_l1[k].values, dtype=float)[seg] for k in _SONIC_VARS}
    nan_any = np.zeros(seg.size, dtype=bool)
    usable_fill = True
    filled = {}
    for k in _SONIC_VARS:
        nan_any |= ~np.isfinite(raw[k])
        filled[k], _, ok = filtering.gap_fill_linear(raw[k], max_missing_fraction)
        usable_fill &= ok
    # Coverage of the hover window by the sonic data actually there: rows absent inside the
    # record, and the parts of the hover window the record does not reach (a file cut short).
    in_hover = (ts_seg >= h0) & (ts_seg <= h1)
    n_expected = int(np.floor((h1 - h0) / dt_nom + 1e-6)) + 1
    n_in_hover = int(in_hover.sum())
    tr.counts["n_sonic_missing_rows"] = max(0, n_expected - n_in_hover)
    tr.counts["n_sonic_expected_in_hover"] = n_expected
    n_missing_total = int((nan_any & in_hover).sum()) + tr.counts["n_sonic_missing_rows"]
    frac = n_missing_total / max(n_expected, 1)
    _sonic_span_log(ts_seg[in_hover], h0, h1, n_in_hover, n_expected, tr)
    filled_ok = usable_fill and frac <= max_missing_fraction
    search = _lag_search_input(raw, filled, ts_seg, nan_any, n_missing_total, frac, filled_ok,
                               max_missing_fraction, tr)
    return _SonicSegment(seg, ts_seg, fs_hz, raw, filled, search, nan_any, filled_ok)


def _sonic_span_log(t_used: np.ndarray, h0: float, h1: float, n_in_hover: int, n_expected: int, tr: _Trace) -> None:
    """Log where the sonic data lie in the hover window (a record that starts late or ends early)."""
    if t_used.size == 0:
        tr.log.append(f"sonic_coverage: no sonic sample in the {h1 - h0:.1f} s hover window")
        return
    tr.log.append(f"sonic_coverage: {n_in_hover} of {n_expected} sonic samples of the {h1 - h0:.1f} s hover window "
                  f"present, from {t_used[0] - h0:.1f} s to {t_used[-1] - h0:.1f} s after its start")


def _lag_search_input(raw: dict[str, np.ndarray], filled: dict[str, np.ndarray], ts_seg: np.ndarray,
                      nan_any: np.ndarray, n_missing_total: int, frac: float, filled_ok: bool,
                      max_missing_fraction: float, tr: _Trace) -> dict[str, np.ndarray]:
    """The sonic series of the lag search: the filled ones, or (too many missing) NaNs interpolated.

    Returns
    -------
    dict of numpy.ndarray
        Finite sonic variables of the segment.
    """
    if not filled_ok:
        tr.reasons.append(f"{100 * frac:.2f} % of the sonic samples missing "
                          f"(limit {100 * max_missing_fraction:.0f} %)")
        # fill anyway for the lag search only; the returned data keep their NaNs
        search = {k: fill_nan_by_time(ts_seg, raw[k])[0] for k in _SONIC_VARS}
        tr.counts["n_sonic_filled"] = 0
        tr.log.append(f"sonic_gaps: {n_missing_total} missing samples ({100 * frac:.2f} %): not filled, unusable")
    else:
        search = filled
        tr.counts["n_sonic_filled"] = int(nan_any.sum())
        tr.log.append(f"sonic_gaps: filled {int(nan_any.sum())} NaN samples linearly; "
                      f"{tr.counts['n_sonic_missing_rows']} missing rows bridged ({100 * frac:.2f} % missing)")
    empty = [k for k in _SONIC_VARS[:3] if not np.isfinite(search[k]).all()]
    if empty:
        raise InputError(f"{tr.where} [sonic {', '.join(empty)}]",
                         f"no valid sonic sample of {', '.join(empty)} among the {ts_seg.size} samples around the "
                         f"hover window ({ts_seg[-1] - ts_seg[0]:.1f} s; {n_missing_total} missing or flagged)")
    return search


def _sonic_ins_lag(seg: _SonicSegment, hover_s: tuple[float, float], ti: np.ndarray, ins: dict[str, np.ndarray],
                   mount: str, lever_arm_m: tuple[float, float, float] | None, max_lag_s: float, lag_step_s: float,
                   misalignment_deg: tuple[float, float, float] | None, fixed_lag_s: float | None, tr: _Trace,
                   halves: bool = False) -> tuple[float, float, np.ndarray, np.ndarray, tuple[float, float] | None]:
    """Step 4: lag of minimum TKE over the hover window (Ghirardelli et al. (2025), Sect. 3.3), or the fixed lag.

    Returns
    -------
    lag_s : float
        Applied lag [s].
    lag_tke_min_s : float
        Lag of minimum TKE [s].
    lag_grid_s, tke_m2s2 : numpy.ndarray
        The TKE curve (:func:`tke_vs_lag`).
    halves_s : tuple of float or None
        With ``halves``: the lags of minimum TKE on the search grid's samples in the first
        and the second half of the hover window, between the grid's lags
        (:func:`~dronewind.payload.lag_search.subgrid_minimum`; NaN for a half too short to
        search) [s].
    """
    h0, h1 = hover_s
    in_hover = (seg.time_s >= h0) & (seg.time_s <= h1)
    sonic_xyz = np.stack([seg.search[k] for k in _SONIC_VARS[:3]], axis=-1)
    att = np.stack([ins["roll_deg"], ins["pitch_deg"], ins["yaw_deg"]], axis=-1)
    vel = np.stack([ins["vel_n_ms"], ins["vel_e_ms"], ins["vel_d_ms"]], axis=-1)
    lag_grid, tke, n_tke, parts = _tke_curves(seg.time_s[in_hover], sonic_xyz[in_hover], ti, att, vel, mount,
                                              lever_arm_m, max_lag_s, lag_step_s, misalignment_deg,
                                              h0 + (h1 - h0) / 2.0 if halves else None)
    halves_s = None
    if halves:
        # between the grid's lags: their difference measures a clock drift, which whole grid
        # steps would quantise (lag_search.subgrid_minimum)
        first, second = (float("nan") if c is None else subgrid_minimum(lag_grid, c) for c in parts)
        halves_s = (first, second)
        tr.log.append(f"sync: lags of minimum TKE on the hover window's halves {first:+.5f} s and {second:+.5f} s")
    lag, at_edge = find_sonic_ins_lag(lag_grid, tke)
    lag_tke_min = lag
    tr.counts["n_lag_search_samples"] = n_tke
    tr.log.append(f"sync: TKE minimum {tke.min():.4f} m2 s-2 at lag {lag:+.5f} s ({lag_grid.size} lags, "
                  f"{n_tke} samples)")
    if fixed_lag_s is not None:
        lag, at_edge = float(fixed_lag_s), False
        tr.log.append(f"sync: fixed lag {lag:+.5f} s applied instead")
    if at_edge:
        tr.reasons.append(f"sonic-INS lag {lag:+.3f} s at the edge of the +/-{max_lag_s} s search range")
    return lag, lag_tke_min, lag_grid, tke, halves_s


def _correct_motion(seg: _SonicSegment, lag: float, hover_s: tuple[float, float], n_sonic: int, ti: np.ndarray,
                    ins: dict[str, np.ndarray], mount: str, lever_arm_m: tuple[float, float, float] | None,
                    misalignment_deg: tuple[float, float, float] | None, tr: _Trace,
                    ) -> tuple[np.ndarray, dict[str, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Step 5: INS at the shifted sonic times inside the hover window, wind motion-corrected.

    :func:`dronewind.payload.motion.motion_correct` (Ghirardelli et al. (2025), Eqs. 1-2) of the filled
    sonic (or of the raw one when the flight is unusable).

    Returns
    -------
    sel : numpy.ndarray
        Segment samples kept (shifted time inside the hover window and the INS record).
    ins_s : dict of numpy.ndarray
        INS at the kept samples (yaw wrapped to [0, 360)).
    wind : tuple of numpy.ndarray
        East, north, up wind [m s-1].
    """
    h0, h1 = hover_s
    t_al = seg.time_s + lag
    sel = (t_al >= h0) & (t_al <= h1) & (t_al >= ti[0]) & (t_al <= ti[-1])
    tr.counts["n_sonic_outside_hover"] = int(n_sonic - sel.sum())
    t_out = t_al[sel]
    ins_keys: dict[str, np.ndarray] = {k: ins[k] for k in _INS_VARS}
    if lever_arm_m is not None:
        ins_keys["rates"] = motion.body_rates_from_euler(ins["roll_deg"], ins["pitch_deg"], ins["yaw_deg"], ti)
    # inside a forward flight's runs, reused where the INS and the shifted sonic times are unchanged
    # (dronewind.core.reuse); a fresh copy of each series, as the caller may change them
    ins_s = {k: v.copy() for k, v in reused(
        "INS at the sonic samples", {"ti": ti, "t_out": t_out, **ins_keys}, repr(sorted(ins_keys)),
        lambda: interpolate_ins(ti, ins_keys, t_out)).items()}
    data = seg.filled if seg.filled_ok else seg.raw
    wind = motion.motion_correct(
        data["u_sensor_ms"][sel], data["v_sensor_ms"][sel], data["w_sensor_ms"][sel],
        ins_s["roll_deg"], ins_s["pitch_deg"], ins_s["yaw_deg"],
        ins_s["vel_n_ms"], ins_s["vel_e_ms"], ins_s["vel_d_ms"], mount,
        lever_arm_m=lever_arm_m, body_rates_rad_s=ins_s.get("rates"), misalignment_deg=misalignment_deg)
    tr.log.append(f"motion: corrected {int(sel.sum())} samples (mount {mount}, lever arm "
                  f"{'none' if lever_arm_m is None else tuple(float(x) for x in lever_arm_m)})")
    return sel, ins_s, wind


def _used_duration(time_out: np.ndarray, hover_s: tuple[float, float], min_hover_s: float, tr: _Trace) -> None:
    """The hover duration measured on the sonic samples actually used (not on the INS hover)."""
    h0, h1 = hover_s
    span = float((time_out[-1] - time_out[0]) / np.timedelta64(1, "s")) if time_out.size >= 2 else 0.0
    tr.log.append(f"duration: {time_out.size} sonic samples used over {span:.1f} s of the {h1 - h0:.1f} s hover "
                  "window")
    if span < min_hover_s:
        tr.reasons.append(f"the sonic data used span {span:.1f} s of the {h1 - h0:.1f} s hover window (shorter than "
                          f"{min_hover_s:.0f} s): sonic record cut short or sparse")


def _plausibility(sonic_l1: xr.Dataset, seg: _SonicSegment, hover_s: tuple[float, float], ti: np.ndarray,
                  ins: dict[str, np.ndarray], ins_missing: np.ndarray, alt_used_m: np.ndarray,
                  site_altitude_m: float | None, target_height_m: float | None, max_missing_fraction: float,
                  tr: _Trace) -> None:
    """Unit and convention checks (:mod:`dronewind.payload.checks`); a failure is an unusable reason."""
    results = []
    if site_altitude_m is not None and alt_used_m.size:
        height = float(np.median(alt_used_m) - float(site_altitude_m))
        results.append(checks.height_check(height, target_height_m))
    keys = ("lat_deg", "lon_deg", "alt_m", "vel_n_ms", "vel_e_ms", "vel_d_ms")

    def velocity_position() -> checks.CheckResult:
        good = ~ins_missing
        return checks.velocity_position_check(ti[good], *(ins[k][good] for k in keys))

    # the INS's own check: reused inside a forward flight's runs where the INS is unchanged
    # (found by the whole series and the mask, so a reused check selects nothing)
    results.append(reused("velocity-position check", {"t": ti, "missing": ins_missing, **{k: ins[k] for k in keys}},
                          "", velocity_position))
    if "qc_sonic" in sonic_l1.variables:
        h0, h1 = hover_s
        in_hover = (seg.time_s >= h0) & (seg.time_s <= h1)
        qc = np.asarray(sonic_l1["qc_sonic"].values).astype(np.int32)[seg.index]
        n_out = int(((qc & QC_OUT_OF_RANGE) != 0)[in_hover].sum())
        results.append(checks.sonic_range_check(n_out, int(in_hover.sum()), max_missing_fraction,
                                                "RM Young 81000: |V| <= 40 m/s, -50..50 degC"))
    for result in results:
        tr.log.append(result.log)
        if result.reason:
            tr.reasons.append(result.reason)


def l2_variables(time_out: np.ndarray, wind: tuple[np.ndarray, np.ndarray, np.ndarray], t_sonic_k: np.ndarray,
                 platform: Mapping[str, np.ndarray], lag_grid: np.ndarray, tke: np.ndarray,
                 clock: str = "INS") -> xr.Dataset:
    """The variables and coordinates every drone L2 shares (sling load and rigid mount).

    Parameters
    ----------
    time_out : numpy.ndarray
        Sample times (UTC on the platform's clock), datetime64[ns].
    wind : tuple of numpy.ndarray
        Motion-corrected wind east, north, up [m s-1].
    t_sonic_k : numpy.ndarray
        Sonic temperature [K].
    platform : mapping
        ``roll_deg``, ``pitch_deg``, ``yaw_deg`` (wrapped to [0, 360)) [degree], ``lat_deg``,
        ``lon_deg`` [degree] and ``alt_m`` [m] at the samples.
    lag_grid, tke : numpy.ndarray
        The lag search's lags [s] and mean TKE [m2 s-2].
    clock : str
        Name of the clock the sonic is aligned to (``INS``, ``platform``), for the long names.

    Returns
    -------
    xarray.Dataset
    """
    u_e, v_n, w_u = wind
    dims = ("time",)
    ds = xr.Dataset(
        {
            "u_east_ms": variable(dims, u_e, "m s-1", "eastward_wind"),
            "v_north_ms": variable(dims, v_n, "m s-1", "northward_wind"),
            "w_up_ms": variable(dims, w_u, "m s-1", "upward_air_velocity"),
            "t_sonic_k": variable(dims, t_sonic_k, "K", "virtual_temperature",
                                  comment="sonic temperature, approximately the virtual temperature"),
            "roll_deg": variable(dims, platform["roll_deg"], "degree", "platform_roll"),
            "pitch_deg": variable(dims, platform["pitch_deg"], "degree", "platform_pitch"),
            "yaw_deg": variable(dims, platform["yaw_deg"], "degree", "platform_yaw",
                                comment="clockwise from true north, wrapped to [0, 360)"),
            "lat_deg": variable(dims, platform["lat_deg"], "degrees_north", "latitude"),
            "lon_deg": variable(dims, platform["lon_deg"], "degrees_east", "longitude"),
            "alt_m": variable(dims, platform["alt_m"], "m", "altitude", comment="above mean sea level",
                              positive="up"),
            "lag_s": variable(("lag",), lag_grid, "s", long_name=f"sonic-{clock} lag added to the sonic clock"),
            "tke_m2s2": variable(("lag",), tke, "m2 s-2", "specific_turbulent_kinetic_energy_of_air",
                                 long_name=f"mean TKE of the motion-corrected wind versus sonic-{clock} lag"),
        },
        coords={"time": ("time", time_out), "lag": ("lag", lag_grid)},
    )
    ds["time"].attrs.update({"standard_name": "time", "long_name": f"time (UTC) on the {clock} clock"})
    ds["lag"].attrs.update({"units": "s", "long_name": f"sonic-{clock} lag added to the sonic clock"})
    return ds


def _l2_dataset(seg: _SonicSegment, sel: np.ndarray, ins_s: dict[str, np.ndarray],
                wind: tuple[np.ndarray, np.ndarray, np.ndarray], time_out: np.ndarray, lag_grid: np.ndarray,
                tke: np.ndarray) -> xr.Dataset:
    """The L2 variables and coordinates (see :func:`payload_l2`, Returns)."""
    data = seg.filled if seg.filled_ok else seg.raw
    return l2_variables(time_out, wind, data["t_sonic_k"][sel], ins_s, lag_grid, tke, clock="INS")


def _add_qc_sonic(ds: xr.Dataset, sonic_l1: xr.Dataset, seg: _SonicSegment, sel: np.ndarray, n_filled: int) -> None:
    """Carry the L1 ``qc_sonic`` over (int32), with the gap-filled bit where samples were filled."""
    if "qc_sonic" not in sonic_l1.variables:
        return
    qc = np.asarray(sonic_l1["qc_sonic"].values).astype(np.int32)[seg.index][sel]
    if n_filled:
        qc = np.where(seg.nan_any[sel], qc | QC_GAP_FILLED, qc)
    # The L2 qc_sonic has int32 masks, no flag_values and no units attribute.
    attrs = qc_flag_attrs("payload sonic quality flags", dtype=np.int32, with_values=False)
    del attrs["units"]
    ds["qc_sonic"] = xr.Variable(("time",), qc, attrs=attrs)


def _l2_attrs(lag: float, lag_tke_min: float, mount: str, lever_arm_m: tuple[float, float, float] | None,
              misalignment_deg: tuple[float, float, float] | None, fs_hz: float, max_lag_s: float,
              lag_step_s: float, n_samples: int, alt_m: np.ndarray, site_altitude_m: float | None, tr: _Trace,
              ) -> dict[str, Any]:
    """The L2 dataset attributes (see :func:`payload_l2`, Returns); ``height_m`` [m] = median
    altitude ``alt_m`` minus ``site_altitude_m`` when the latter is given."""
    attrs: dict[str, Any] = {
        "lag_sonic_ins_s": float(lag),
        "lag_tke_min_s": float(lag_tke_min),
        "usable": int(not tr.reasons),
        "unusable_reason": "; ".join(tr.reasons),
        "mount": mount,
        "lever_arm_m": "none" if lever_arm_m is None else ", ".join(f"{float(x):g}" for x in lever_arm_m),
        "sampling_rate_hz": fs_hz,
        "lag_search_max_s": float(max_lag_s),
        "lag_search_step_s": float(lag_step_s),
        "n_samples": int(n_samples),
        **{k: int(v) for k, v in tr.counts.items()},
        "processing_log": "\n".join(tr.log),
    }
    if site_altitude_m is not None:
        attrs["height_m"] = float(np.median(alt_m) - float(site_altitude_m))
    if misalignment_deg is not None:
        attrs["misalignment_deg"] = ", ".join(f"{float(x):g}" for x in misalignment_deg)
    return attrs


def payload_l2(
    sonic_l1: xr.Dataset, ins_l1: xr.Dataset, mount: str, lever_arm_m: tuple[float, float, float] | None = None,
    max_lag_s: float = 2.0, lag_step_s: float = 1.0 / 32.0, *,
    misalignment_deg: tuple[float, float, float] | None = None, window: tuple[Any, Any] | None = None,
    min_hover_s: float = 600.0, hover_alt_tol_m: float = 3.0, hover_horiz_tol_m: float = 4.0,
    max_missing_fraction: float = 0.02, fixed_lag_s: float | None = None, site_altitude_m: float | None = None,
    target_height_m: float | None = None, flight_id: str | None = None, plausibility: bool = True,
    lag_only: bool = False, lag_halves: bool = False,
) -> xr.Dataset:
    """Build the L2 payload dataset: synchronised, motion-corrected wind in east/north/up.

    Parameters
    ----------
    sonic_l1 : xarray.Dataset
        L1 payload sonic (interfaces.md): ``u_sensor_ms``, ``v_sensor_ms``, ``w_sensor_ms``
        [m s-1], ``t_sonic_k`` [K] on ``time`` (UTC); flagged samples NaN.
    ins_l1 : xarray.Dataset
        L1 INS: ``roll_deg``, ``pitch_deg``, ``yaw_deg`` [degree], ``vel_n_ms``,
        ``vel_e_ms``, ``vel_d_ms`` [m s-1], ``lat_deg``, ``lon_deg`` [degree], ``alt_m`` [m],
        optionally ``ekf_valid`` (0 = invalid, treated as missing).
    mount : {"upside_down", "upright"}
        Sonic mount (``docs/data-contract.md``).
    lever_arm_m : (x, y, z) [m], optional
        INS reference point relative to the sonic, body frame; None = INS outputs at the
        sonic (Ghirardelli et al. (2025), Sect. 3.2).
    max_lag_s, lag_step_s : float
        Sonic-INS lag search range and step [s] (Ghirardelli et al. (2025), Sect. 3.3: 2 s and 1/32 s).
    misalignment_deg : (roll, pitch, yaw) [degree], optional
        Known mount misalignment, see :func:`dronewind.payload.motion.sensor_to_body_matrix`.
    window : (start, end), optional
        UTC limits (anything ``numpy.datetime64`` accepts) applied before the hover
        search, e.g. the manifest's flight window.
    min_hover_s : float
        Shortest usable hover [s]; default 600 s (Ghirardelli et al. (2025), Sect. 5: at least 10 min).
    hover_alt_tol_m, hover_horiz_tol_m : float
        Hover window: median altitude +/- ``hover_alt_tol_m``, then +/- ``hover_horiz_tol_m``
        horizontally (Ghirardelli et al. (2025), Sect. 3.2: 3 m and 4 m) [m].
    max_missing_fraction : float
        Largest fraction of missing sonic samples that is gap-filled; default 0.02
        (Ghirardelli et al. (2025), Sect. 3.2).
    fixed_lag_s : float, optional
        Apply this sonic-INS lag [s] instead of the TKE minimum (the TKE curve is still
        computed and stored); attrs ``lag_tke_min_s`` keeps the search result.
    site_altitude_m : float, optional
        Ground altitude above mean sea level [m]; if given, attrs ``height_m`` = median INS
        altitude in the output minus it (read by :func:`dronewind.compare.align.align_drone_mast`).
    target_height_m : float, optional
        The flight's target height above ground [m]; the hover height is checked against it
        (:func:`dronewind.payload.checks.height_check`).
    flight_id : str, optional
        Flight id, named in messages with the L1 ``source_file`` attributes.
    plausibility : bool
        Run the unit and convention checks of :mod:`dronewind.payload.checks` (hover height,
        INS velocity against the GNSS position derivative, sonic range); a failed check
        marks the flight unusable with its reason.
    lag_only : bool
        Stop after step 4 (the lag): return a dataset without variables whose attributes
        are ``lag_sonic_ins_s``, ``lag_tke_min_s``, ``usable`` and ``unusable_reason`` (the
        reasons found up to the lag search).
    lag_halves : bool
        Also find the lag on each half of the hover window (the search grid's samples
        before and after the window's middle, with the same sonic and INS): attrs
        ``lag_first_half_s`` and ``lag_second_half_s`` [s] (between the grid's lags:
        :func:`dronewind.payload.lag_search.subgrid_minimum`), NaN for a half too short to
        search. Their difference shows a drift of the sonic clock against the INS.

    Returns
    -------
    xarray.Dataset
        On ``time`` = sonic stamps + lag (i.e. on the INS/UTC clock), within the hover
        window: ``u_east_ms``, ``v_north_ms``, ``w_up_ms``, ``t_sonic_k``, ``roll_deg``,
        ``pitch_deg``, ``yaw_deg`` (in [0, 360)), ``lat_deg``, ``lon_deg``, ``alt_m``; on
        ``lag``: ``lag_s``, ``tke_m2s2``. attrs: ``lag_sonic_ins_s``, ``usable`` (0/1),
        ``unusable_reason``, ``mount``, ``lever_arm_m``, ``sampling_rate_hz``, counts
        ``n_*`` and ``processing_log``. When unusable the data are still returned.

    Notes
    -----
    Steps 1-5 of the module docstring. References: Ghirardelli et al. (2025), Sects. 3.1-3.3, Eqs. 1-3.
    """
    _check_l2_inputs(sonic_l1, ins_l1, mount)
    tr = _Trace(where=_describe_flight(sonic_l1, ins_l1, flight_id))
    sonic_l1, ins_l1, ts_ns, ti_ns = _apply_window(sonic_l1, ins_l1, window, tr)
    t_ref = int(min(ts_ns[0], ti_ns[0]))
    ts, ti = (ts_ns - t_ref) / _NS, (ti_ns - t_ref) / _NS
    ins, ins_missing, hover = _ins_steps(ins_l1, ti, (hover_alt_tol_m, hover_horiz_tol_m, min_hover_s,
                                                       max_missing_fraction), tr)
    seg = _sonic_segment(sonic_l1, ts, hover[0], hover[1], max_lag_s, max_missing_fraction, tr)
    lag, lag_tke_min, lag_grid, tke, halves_s = _sonic_ins_lag(seg, hover, ti, ins, mount, lever_arm_m, max_lag_s,
                                                               lag_step_s, misalignment_deg, fixed_lag_s, tr,
                                                               lag_halves)
    halves = {} if halves_s is None else {"lag_first_half_s": halves_s[0], "lag_second_half_s": halves_s[1]}
    if lag_only:
        return xr.Dataset(attrs={"lag_sonic_ins_s": float(lag), "lag_tke_min_s": float(lag_tke_min),
                                 "usable": int(not tr.reasons), "unusable_reason": "; ".join(tr.reasons), **halves})
    sel, ins_s, wind = _correct_motion(seg, lag, hover, ts.size, ti, ins, mount, lever_arm_m, misalignment_deg, tr)
    time_out = (ts_ns[seg.index][sel] + int(round(lag * _NS))).astype("datetime64[ns]")
    _used_duration(time_out, hover, min_hover_s, tr)
    if plausibility:
        _plausibility(sonic_l1, seg, hover, ti, ins, ins_missing, ins_s["alt_m"], site_altitude_m, target_height_m,
                      max_missing_fraction, tr)
    ds = _l2_dataset(seg, sel, ins_s, wind, time_out, lag_grid, tke)
    _add_qc_sonic(ds, sonic_l1, seg, sel, tr.counts["n_sonic_filled"])
    ds.attrs.update(_l2_attrs(lag, lag_tke_min, mount, lever_arm_m, misalignment_deg, seg.fs_hz, max_lag_s,
                              lag_step_s, int(sel.sum()), ins_s["alt_m"], site_altitude_m, tr))
    ds.attrs.update(halves)
    return ds
