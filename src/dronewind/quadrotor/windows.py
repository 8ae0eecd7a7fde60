r"""Averaging windows of the hover paired with the tower reference: the calibration data set.

Wetz et al. (2021) compares 10-min means (Sect. 5) and 2-min means (Appendix C) of the UAV wind
with the tower. :func:`flight_windows` cuts one UAV's hover into such windows; within a
window the attitude is averaged in short blocks (1 s) before the non-linear drag law is
applied, and each window is paired with the tower records at the nearest height.
:func:`campaign_windows` does this for every UAV log of a campaign, listing the logs that
cannot be used. :class:`WindowArrays` holds blocks and windows as arrays for the repeated
model evaluations of the calibrations.

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F. (SWUF-3D), Wetz et al. (2021)
  , Sects. 4.3, 5, Appendix C.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.errors import InputError
from dronewind.quadrotor.drag import DragLaw, attitude_trig, lean_from_trig
from dronewind.quadrotor.ekf_wind import air_density_kgm3
from dronewind.quadrotor.hover import hover_segment
from dronewind.quadrotor.io import read_quadrotor
from dronewind.quadrotor.reference import read_tower_reference
from dronewind.quadrotor.wind import (
    corrected_attitude_rad,
    drag_balance_direction,
    relative_air_from_direction,
    wind_from_attitude,
)

__all__ = ["circular_mean_deg", "flight_windows", "flight_windows_with_gaps", "record_gaps", "SKIPPED_COLUMNS",
           "campaign_windows", "WindowArrays", "select_windows"]


def circular_mean_deg(angles_deg: np.ndarray, weights: np.ndarray | None = None) -> float:
    r"""Weighted circular mean of angles [degree], in [0, 360); NaN if no finite pair.

    Parameters
    ----------
    angles_deg : array_like
        Angles [degree].
    weights : array_like, optional
        Weights (e.g. wind speed for a vector-mean direction); default 1.

    Returns
    -------
    float
        :math:`\operatorname{atan2}(\sum w\sin a, \sum w\cos a)` [degree].
    """
    a = np.radians(np.asarray(angles_deg, float))
    w = np.ones_like(a) if weights is None else np.asarray(weights, float)
    ok = np.isfinite(a) & np.isfinite(w)
    if not ok.any():
        return float("nan")
    return float(np.degrees(np.arctan2(np.sum(w[ok] * np.sin(a[ok])),
                                       np.sum(w[ok] * np.cos(a[ok])))) % 360.0)


# --------------------------------------------------------------------------------------
# Windows of one UAV log
# --------------------------------------------------------------------------------------

def _reference_source(reference: xr.Dataset) -> str:
    return f"{reference.attrs.get('source_file', 'tower reference')}"


def reference_at_height(reference: xr.Dataset, height_m: float, height_tol_m: float,
                        where: str) -> tuple[xr.Dataset, float]:
    """Tower records at the reference height nearest to the hover height.

    Parameters
    ----------
    reference : xarray.Dataset
        Tower reference (:func:`dronewind.quadrotor.reference.read_tower_reference`).
    height_m : float
        Hover height above ground [m].
    height_tol_m : float
        Largest accepted height difference [m].
    where : str
        Flight and UAV, for the error message.

    Returns
    -------
    records : xarray.Dataset
        ``reference`` at that height (dimension ``time``).
    ref_height_m : float
        Its height [m].

    Raises
    ------
    InputError
        No reference height within ``height_tol_m``.
    """
    ref_h = reference["height_m"].to_numpy()
    k_h = int(np.argmin(np.abs(ref_h - height_m)))
    if abs(ref_h[k_h] - height_m) > height_tol_m:
        raise InputError(f"{_reference_source(reference)} [height_m]",
                         f"{where}: no reference height within {height_tol_m} m of the hover "
                         f"height {height_m:.1f} m (available {list(np.round(ref_h, 1))})")
    return reference.isel(height=k_h), ref_h[k_h]


def window_edges(hover: Mapping[str, Any], window_s: float, where: str) -> tuple[list[np.datetime64], int]:
    """Edges of the averaging windows of a hover.

    Parameters
    ----------
    hover : mapping
        ``start``, ``end``, ``duration_s`` of :func:`dronewind.quadrotor.hover.hover_segment`.
    window_s : float
        Averaging time [s]. The hover is cut into ``floor(duration / window_s)`` windows;
        a hover shorter than one window but at least half of it gives one window over the
        whole hover.
    where : str
        Flight and UAV, for the error message.

    Returns
    -------
    edges : list of numpy.datetime64
        ``n + 1`` edges of ``n`` windows.
    n_full : int
        Number of full windows (0 for the one short window).

    Raises
    ------
    InputError
        Hover shorter than half a window.
    """
    dur = hover["duration_s"]
    n_win = int(dur // window_s)
    if n_win == 0 and dur >= 0.5 * window_s:
        return [hover["start"], hover["end"] + np.timedelta64(1, "ns")], n_win
    if n_win == 0:
        raise InputError(where, f"hover of {dur:.0f} s is shorter than half the averaging "
                                f"window ({window_s:.0f} s)")
    step = np.timedelta64(int(round(window_s * 1e9)), "ns")
    return [hover["start"] + k * step for k in range(n_win + 1)], n_win


def reference_coverage(ref_time: np.ndarray, ref_speed_ms: np.ndarray, t0: np.datetime64,
                       t1: np.datetime64, interval_s: float) -> tuple[np.ndarray, int]:
    """Tower records inside a window and the number expected.

    Parameters
    ----------
    ref_time, ref_speed_ms : numpy.ndarray
        Record times and speeds at the reference height.
    t0, t1 : numpy.datetime64
        Window start (inclusive) and end (exclusive).
    interval_s : float
        Spacing of the records [s].

    Returns
    -------
    selected : numpy.ndarray of bool
        Finite records inside the window.
    expected : int
        Records expected at ``interval_s``.
    """
    rsel = (ref_time >= t0) & (ref_time < t1) & np.isfinite(ref_speed_ms)
    expected = max(1, int(round((t1 - t0).astype("int64") / 1e9 / interval_s)))
    return rsel, expected


def block_means(sub: xr.Dataset, t0: np.datetime64, block_s: float) -> tuple[pd.DataFrame, int]:
    """Attitude and GNSS velocity averaged in blocks of ``block_s`` from ``t0``.

    Parameters
    ----------
    sub : xarray.Dataset
        Hover samples of one window.
    t0 : numpy.datetime64
        Window start.
    block_s : float
        Block length [s].

    Returns
    -------
    blocks : pandas.DataFrame
        ``roll_deg``, ``pitch_deg``, ``vel_n_ms``, ``vel_e_ms``, ``yaw_deg`` (circular mean,
        0-360) per block with all values finite, and ``rho_kgm3`` (:func:`logged_air_density`;
        NaN when the record has no pressure and temperature).
    n_all : int
        Number of blocks before those without a finite sample were left out.
    """
    tb = ((sub["time"].to_numpy() - t0).astype("int64") // int(block_s * 1e9)).astype(np.int64)
    frame = pd.DataFrame({
        "b": tb, "roll_deg": sub["roll_deg"].to_numpy(), "pitch_deg": sub["pitch_deg"].to_numpy(),
        "sy": np.sin(np.radians(sub["yaw_deg"].to_numpy())),
        "cy": np.cos(np.radians(sub["yaw_deg"].to_numpy())),
        "vel_n_ms": sub["vel_n_ms"].to_numpy(), "vel_e_ms": sub["vel_e_ms"].to_numpy()})
    g = frame.groupby("b").mean()
    g["yaw_deg"] = np.degrees(np.arctan2(g["sy"], g["cy"])) % 360.0
    n_all_blocks = len(g)
    g = g.drop(columns=["sy", "cy"]).dropna()  # blocks without any finite sample: counted
    rho = logged_air_density(sub)
    g["rho_kgm3"] = (pd.Series(rho).groupby(tb).mean().reindex(g.index).to_numpy() if rho is not None
                     else np.nan)
    return g, n_all_blocks


def logged_air_density(ds: xr.Dataset) -> np.ndarray | None:
    """Air density of each sample from the logged pressure and temperature, or None without them.

    The temperature is the record's air temperature (``air_temp_degc``) or else its barometer's
    (``baro_temp_degc``, an autopilot's sensor inside the airframe); the density is that of dry
    air (:func:`dronewind.quadrotor.ekf_wind.air_density_kgm3`), the :math:`\rho` of the drag
    balance (Wetz et al. 2021, Eq. 12).
    """
    temp = next((ds[n].to_numpy() for n in ("air_temp_degc", "baro_temp_degc") if n in ds), None)
    if temp is None or "pressure_pa" not in ds:
        return None
    return air_density_kgm3(ds["pressure_pa"].to_numpy(), temp)


def record_gaps(time: np.ndarray, max_gap_s: float, start: np.datetime64 | None = None,
                end: np.datetime64 | None = None) -> list[tuple[np.datetime64, np.datetime64]]:
    """Stretches without samples longer than ``max_gap_s`` in a record.

    Parameters
    ----------
    time : numpy.ndarray of datetime64
        Sample times (sorted).
    max_gap_s : float
        Longest spacing that is not a gap [s].
    start, end : numpy.datetime64, optional
        Span to look at: a record that begins later than ``start`` + ``max_gap_s`` or ends
        earlier than ``end`` - ``max_gap_s`` has a gap there too.

    Returns
    -------
    list of (numpy.datetime64, numpy.datetime64)
        ``(last sample before, first sample after)`` of each gap (the span's edges where
        the record does not reach them).
    """
    t = np.sort(np.asarray(time, dtype="datetime64[ns]"))
    lim = np.timedelta64(int(round(max_gap_s * 1e9)), "ns")
    t0 = None if start is None else np.asarray(start, dtype="datetime64[ns]")
    t1 = None if end is None else np.asarray(end, dtype="datetime64[ns]")
    if t0 is not None:
        t = np.concatenate([t0[None], t[t >= t0]])
    if t1 is not None:
        t = np.concatenate([t[t <= t1], t1[None]])
    if t.size < 2:
        return [] if t0 is None or t1 is None else [(t0.reshape(1)[0], t1.reshape(1)[0])]
    k = np.flatnonzero(np.diff(t) > lim)
    return [(t[i], t[i + 1]) for i in k]


def _touching(gaps: list[tuple[np.datetime64, np.datetime64]], t0: np.datetime64, t1: np.datetime64,
              spacing_s: float) -> list[tuple[np.datetime64, np.datetime64]]:
    """Gaps that take samples from the window [t0, t1).

    A gap from its last sample ``a`` to its next ``b`` misses the samples after ``a`` and
    before ``b``: it touches the window unless ``a`` is the window's last sample or ``b``
    its first (``spacing_s``, the record's sample spacing, is the slack).
    """
    slack = np.timedelta64(int(round(spacing_s * 1e9)), "ns")
    return [(a, b) for a, b in gaps if a + slack < t1 and b > t0]


def _gap_text(kind: str, gaps: list[tuple[np.datetime64, np.datetime64]], spacing_s: float) -> str:
    """The reason for a skipped window: its gaps and the longest time without records (spacing less one sample)."""
    longest = max((b - a).astype("int64") / 1e9 for a, b in gaps) - spacing_s
    return (f"the {kind} does not cover it: {len(gaps)} gap{'s' if len(gaps) > 1 else ''}, the longest "
            f"{longest:.0f} s without records")


#: Column order of the table of skipped windows of :func:`flight_windows_with_gaps`.
SKIPPED_COLUMNS: tuple[str, ...] = ("window_key", "flight", "uav", "window", "start", "end", "reason",
                                    "n_uav_s", "n_ref", "n_ref_expected")


def flight_windows_with_gaps(ds: xr.Dataset, reference: xr.Dataset, site_altitude_m: float,
                             flight: str, uav: str, window_s: float = 600.0, block_s: float = 1.0,
                             height_tol_m: float = 5.0, min_coverage: float = 0.8, max_gap_s: float = 10.0,
                             hover_kwargs: Mapping | None = None) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    r"""Averaging windows of a UAV's hover wherever the UAV record and the reference cover them.

    The hover (:func:`dronewind.quadrotor.hover.hover_segment`) is cut into windows of
    ``window_s`` from its start (Wetz et al. 2021, Sect. 5: 10-min means; App. C: 2-min). A
    window is kept when the UAV record has no gap longer than ``max_gap_s`` in it, the
    reference has no gap longer than ``max(max_gap_s, 2 x its record interval)`` in it, and
    the reference holds at least ``min_coverage`` of the records expected. Every other window
    is skipped and listed with its reason: a gap ends no search, the windows after it are
    taken as those before.

    Parameters
    ----------
    ds, reference, site_altitude_m, flight, uav, window_s, block_s, height_tol_m, min_coverage, hover_kwargs
        As :func:`flight_windows`.
    max_gap_s : float
        Longest time without UAV samples (or reference records) that is not a gap [s].

    Returns
    -------
    blocks, windows : pandas.DataFrame
        As :func:`flight_windows` (kept windows only; ``window`` numbers the windows of the
        hover, kept or skipped, so the numbers of kept windows may jump).
    skipped : pandas.DataFrame
        One row per skipped window: :data:`SKIPPED_COLUMNS` (``reason`` names the gaps or
        the coverage; ``n_uav_s`` seconds with UAV samples, ``n_ref`` and
        ``n_ref_expected`` reference records found and expected).

    Raises
    ------
    InputError
        UAV never hovers; no reference height within ``height_tol_m``.
    """
    where = f"flight {flight}, uav {uav}"
    mask, info = hover_segment(ds, where=where, **dict(hover_kwargs or {}))
    height = info["alt_m"] - site_altitude_m
    ref, ref_height = reference_at_height(reference, height, height_tol_m, where)
    edges, n_win = window_edges(info, window_s, where)
    t = ds["time"].to_numpy()
    ref_sp = ref["wind_speed_ms"].to_numpy()
    ref_t = ref["time"].to_numpy()
    interval = float(reference.attrs.get("sampling_interval_s") or 60.0)
    hover_t = t[mask & np.isfinite(ds["roll_deg"].to_numpy()) & np.isfinite(ds["pitch_deg"].to_numpy())]
    uav_gaps = record_gaps(hover_t, max_gap_s, edges[0], edges[-1])
    uav_spacing_s = float(np.median(np.diff(hover_t.astype("int64")))) / 1e9 if hover_t.size > 1 else 0.0
    # a record stamped at the start of its interval covers up to one interval after it
    ref_gaps = record_gaps(ref_t[np.isfinite(ref_sp)], max(max_gap_s, 2.0 * interval), edges[0],
                           edges[-1] - np.timedelta64(int(round(interval * 1e9)), "ns"))
    dur = info["duration_s"]
    common = {"flight": flight, "uav": uav, "height_m": height, "ref_height_m": float(ref_height),
              "sigma_h_m": info["sigma_h_m"], "sigma_v_m": info["sigma_v_m"], "hover_s": dur,
              "n_dropped_s": float(dur - (edges[-1] - edges[0]).astype("int64") / 1e9) if n_win else 0.0}
    blocks_out: list[pd.DataFrame] = []
    windows_out: list[dict[str, Any]] = []
    skipped: list[dict[str, Any]] = []
    for k in range(len(edges) - 1):
        key = f"{flight}/{uav}/{k}"
        t0, t1 = edges[k], edges[k + 1]
        rsel, expected = reference_coverage(ref_t, ref_sp, t0, t1, interval)
        sel = np.flatnonzero(mask & (t >= t0) & (t < t1))
        reasons = []
        if g := _touching(uav_gaps, t0, t1, uav_spacing_s):
            reasons.append(_gap_text("UAV record", g, uav_spacing_s))
        if g := _touching(ref_gaps, t0, t1, interval):
            reasons.append(_gap_text("reference", g, interval))
        if rsel.sum() < min_coverage * expected:
            reasons.append(f"the reference does not cover it: {int(rsel.sum())} of {expected} records at "
                           f"{ref_height:g} m (at least {min_coverage:.0%} needed)")
        means, n_all_blocks = block_means(ds.isel(time=sel), t0, block_s)
        if not reasons and len(means) == 0:
            reasons.append("no UAV block with finite attitude and velocity")
        if reasons:
            skipped.append({"window_key": key, "flight": flight, "uav": uav, "window": k, "start": t0, "end": t1,
                            "reason": "; ".join(reasons), "n_uav_s": int(np.unique(
                                (t[sel] - t0).astype("int64") // 1_000_000_000).size),
                            "n_ref": int(rsel.sum()), "n_ref_expected": expected})
            continue
        means["window_key"] = key
        blocks_out.append(means.reset_index(drop=True))
        windows_out.append({
            "window_key": key, "window": k, "start": t0, "end": t1,
            "ref_speed_ms": float(np.mean(ref_sp[rsel])),
            "ref_from_deg": circular_mean_deg(ref["wind_from_deg"].to_numpy()[rsel], ref_sp[rsel]),
            "n_blocks": len(means), "n_blocks_nan": n_all_blocks - len(means), "n_ref": int(rsel.sum()), **common})
    blocks = (pd.concat(blocks_out, ignore_index=True) if blocks_out
              else pd.DataFrame(columns=["roll_deg", "pitch_deg", "vel_n_ms", "vel_e_ms", "yaw_deg", "window_key"]))
    windows = _window_table(windows_out) if windows_out else pd.DataFrame(columns=list(WINDOW_COLUMNS))
    return blocks, windows, pd.DataFrame(skipped, columns=list(SKIPPED_COLUMNS))


def flight_windows(ds: xr.Dataset, reference: xr.Dataset, site_altitude_m: float,
                   flight: str, uav: str, window_s: float = 600.0, block_s: float = 1.0,
                   height_tol_m: float = 5.0, min_coverage: float = 0.8, max_gap_s: float = 10.0,
                   hover_kwargs: Mapping | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    r"""Cut a UAV's hover into averaging windows and pair each with the tower reference.

    Parameters
    ----------
    ds : xarray.Dataset
        Quadrotor log (:func:`dronewind.quadrotor.io.read_quadrotor`).
    reference : xarray.Dataset
        Tower reference (:func:`dronewind.quadrotor.reference.read_tower_reference`).
    site_altitude_m : float
        Ground altitude above MSL [m]; height above ground is ``alt_m - site_altitude_m``.
    flight, uav : str
        Identifiers stored in the tables.
    window_s : float
        Averaging time [s]: 600 (Wetz et al. (2021), Sect. 5) or 120 (Appendix C); see
        :func:`window_edges`.
    block_s : float
        The attitude is averaged in blocks of this length [s] before the (non-linear)
        wind computation (:func:`block_means`).
    height_tol_m : float
        Largest difference between hover height and the nearest reference height [m].
    min_coverage : float
        Smallest fraction of the expected reference records inside a window.
    max_gap_s : float
        Longest time without samples that is not a gap [s] (:func:`flight_windows_with_gaps`).
    hover_kwargs : mapping, optional
        Passed to :func:`dronewind.quadrotor.hover.hover_segment`.

    Returns
    -------
    blocks : pandas.DataFrame
        One row per block: ``window_key``, ``roll_deg``, ``pitch_deg``, ``yaw_deg``
        (circular mean), ``vel_n_ms``, ``vel_e_ms``.
    windows : pandas.DataFrame
        One row per window: ``window_key`` (``flight/uav/k``), ``flight``, ``uav``,
        ``window``, ``start``, ``end``, ``height_m``, ``ref_height_m``, ``ref_speed_ms``
        (scalar mean), ``ref_from_deg`` (speed-weighted vector mean), ``n_blocks``,
        ``n_blocks_nan`` (blocks left out for a missing value), ``n_ref``, ``sigma_h_m``,
        ``sigma_v_m``, ``hover_s``, ``n_dropped_s`` (hover seconds outside any window).
        Windows touching a gap of either record are left out
        (:func:`flight_windows_with_gaps` lists them with their reasons).

    Raises
    ------
    InputError
        UAV never hovers; no reference height within ``height_tol_m``; no window covered
        by both records (names the first skipped window and why).
    """
    blocks, windows, skipped = flight_windows_with_gaps(
        ds, reference, site_altitude_m, flight, uav, window_s=window_s, block_s=block_s,
        height_tol_m=height_tol_m, min_coverage=min_coverage, max_gap_s=max_gap_s, hover_kwargs=hover_kwargs)
    if windows.empty:
        first = skipped.iloc[0]
        raise InputError(_reference_source(reference),
                         f"flight {flight}, uav {uav}: no window covered by the UAV record and the reference; "
                         f"{len(skipped)} skipped, the first ({pd.Timestamp(first['start']):%Y-%m-%dT%H:%M:%SZ} to "
                         f"{pd.Timestamp(first['end']):%Y-%m-%dT%H:%M:%SZ}): {first['reason']}")
    return blocks, windows


#: Column order of the window table of :func:`flight_windows`.
WINDOW_COLUMNS: tuple[str, ...] = (
    "window_key", "flight", "uav", "window", "start", "end", "height_m", "ref_height_m", "ref_speed_ms",
    "ref_from_deg", "n_blocks", "n_blocks_nan", "n_ref", "sigma_h_m", "sigma_v_m", "hover_s", "n_dropped_s",
)


def _window_table(rows: list[dict[str, Any]]) -> pd.DataFrame:
    return pd.DataFrame(rows)[list(WINDOW_COLUMNS)]


# --------------------------------------------------------------------------------------
# Every UAV log of a campaign
# --------------------------------------------------------------------------------------

def campaign_windows(campaign: Mapping, manifest_dir: str | Path, window_s: float = 600.0,
                     strict: bool = False, **kwargs) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Read every quadrotor flight of a campaign and build its averaging windows.

    Parameters
    ----------
    campaign : mapping
        Parsed manifest (``site.altitude_m``, ``quadrotor_flights``).
    manifest_dir : str or Path
        Folder the manifest's paths are relative to.
    window_s : float
        Averaging time [s] (600 or 120).
    strict : bool
        Raise on the first bad UAV log instead of recording it.
    **kwargs
        Passed to :func:`flight_windows`.

    Returns
    -------
    blocks, windows : pandas.DataFrame
        Concatenated :func:`flight_windows` output.
    problems : pandas.DataFrame
        ``flight``, ``uav``, ``file``, ``error``: UAV logs left out (e.g. a UAV that
        never hovers, a reference that does not cover the flight), so that nothing is
        dropped silently.

    Raises
    ------
    InputError
        With ``strict``, or when no window at all could be built.
    """
    root = Path(manifest_dir)
    site_alt = float(campaign["site"]["altitude_m"])
    blocks, windows, problems = [], [], []
    for flight in campaign.get("quadrotor_flights") or []:
        try:
            ref = read_tower_reference(root / flight["reference"])
        except InputError as exc:
            if strict:
                raise
            problems += [{"flight": flight["id"], "uav": u["id"], "file": flight["reference"], "error": str(exc)}
                         for u in flight["uavs"]]
            continue
        for uav in flight["uavs"]:
            try:
                b, w = flight_windows(read_quadrotor(root / uav["file"]), ref, site_alt, flight["id"],
                                      uav["id"], window_s=window_s, **kwargs)
            except InputError as exc:
                if strict:
                    raise
                problems.append({"flight": flight["id"], "uav": uav["id"], "file": uav["file"], "error": str(exc)})
                continue
            blocks.append(b)
            windows.append(w)
    if not windows:
        raise InputError("quadrotor_flights", "no usable quadrotor window in the campaign"
                         + (f"; first problem: {problems[0]['error']}" if problems else ""))
    return (pd.concat(blocks, ignore_index=True), pd.concat(windows, ignore_index=True),
            pd.DataFrame(problems, columns=["flight", "uav", "file", "error"]))


# --------------------------------------------------------------------------------------
# The calibration data set as arrays
# --------------------------------------------------------------------------------------

class WindowArrays:
    """Blocks and windows as arrays, for fast repeated model evaluation.

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        :func:`flight_windows` output (blocks of windows not in ``windows`` are ignored).

    Raises
    ------
    InputError
        Duplicated ``window_key`` values.
    """

    def __init__(self, blocks: pd.DataFrame, windows: pd.DataFrame) -> None:
        keys = pd.Index(windows["window_key"])
        if not keys.is_unique:
            raise InputError("windows", "window_key values must be unique")
        idx = keys.get_indexer(blocks["window_key"])
        keep = idx >= 0
        self.win = idx[keep]
        self.roll = blocks["roll_deg"].to_numpy(float)[keep]
        self.pitch = blocks["pitch_deg"].to_numpy(float)[keep]
        self.yaw = blocks["yaw_deg"].to_numpy(float)[keep]
        self.vn = blocks["vel_n_ms"].to_numpy(float)[keep]
        self.ve = blocks["vel_e_ms"].to_numpy(float)[keep]
        self.nwin = len(windows)
        self.count = np.bincount(self.win, minlength=self.nwin).astype(float)
        self.ref = windows["ref_speed_ms"].to_numpy(float)
        self.uav = windows["uav"].astype(str).to_numpy()
        self.block_uav = self.uav[self.win]
        # the drag balance's direction of the last pitch offsets (the calibration's fits change
        # the drag law far more often than the offsets): key -> (tilt, cos lean, sin lean)
        self._direction: dict[tuple[str, bytes], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def speed(self, law: DragLaw, pitch_offset_deg: np.ndarray | float, method: str,
              signed: bool = False) -> np.ndarray:
        """Window-mean wind speed [m s-1].

        ``signed``: the speed of a block is negative when the wind comes from behind the
        nose (negative head-wind component). Under weather-vane mode that only happens
        with a wrong pitch offset, so the calibration uses it to rule out the mirror
        solution (tilt reflected through zero gives the same unsigned speed).

        The numbers are those of :func:`~dronewind.quadrotor.wind.wind_from_attitude`; for the
        drag balance its attitude part (:func:`~dronewind.quadrotor.wind.drag_balance_direction`)
        is kept for the last few pitch offsets.
        """
        if method in ("tilt", "pitch") and law.law == "rayleigh":
            air_n, air_e, _ = relative_air_from_direction(*self._balance_direction(pitch_offset_deg, method), law)
            wn, we = air_n + self.vn, air_e + self.ve
            sp = np.hypot(wn, we)
        else:
            w = wind_from_attitude(self.roll, self.pitch, self.yaw, self.vn, self.ve, law=law,
                                   pitch_offset_deg=pitch_offset_deg, method=method)
            sp, wn, we = w["speed_ms"], w["v_north_ms"], w["u_east_ms"]
        if signed:
            cos_yaw, sin_yaw = self._yaw_cos_sin
            head = -(wn * cos_yaw + we * sin_yaw)
            sp = np.where(head < 0, -sp, sp)
        s = np.bincount(self.win, weights=sp, minlength=self.nwin)
        with np.errstate(invalid="ignore", divide="ignore"):
            return s / self.count

    @functools.cached_property
    def _yaw_cos_sin(self) -> tuple[np.ndarray, np.ndarray]:
        """Cosine and sine of the logged yaw (the nose direction of :meth:`speed`'s sign), once."""
        psi = np.radians(self.yaw)
        return np.cos(psi), np.sin(psi)

    def _balance_direction(self, pitch_offset_deg: np.ndarray | float, method: str
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:func:`~dronewind.quadrotor.wind.drag_balance_direction` of the blocks at these pitch offsets."""
        offset = np.asarray(pitch_offset_deg, dtype=float)
        key = (method, offset.dtype.str.encode() + str(offset.shape).encode() + offset.tobytes())
        if key not in self._direction:
            if len(self._direction) >= 8:  # bounded: the oldest goes
                del self._direction[next(iter(self._direction))]
            if method == "tilt":
                # the pitch theta - p by the angle-sum formulas on the blocks' cosines and sines,
                # made once (lean_from_trig's Notes): the fits change the offsets thousands of times
                p = np.radians(offset)
                self._direction[key] = lean_from_trig(*self._attitude_trig, *self._yaw_cos_sin,
                                                      pitch_offset=(np.cos(p), np.sin(p)))
            else:
                phi, th, psi = corrected_attitude_rad(self.roll, self.pitch, self.yaw,
                                                      pitch_offset_deg=pitch_offset_deg)
                self._direction[key] = drag_balance_direction(phi, th, psi, method)
        return self._direction[key]

    @functools.cached_property
    def _attitude_trig(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Cosine and sine of the logged roll and pitch, once (:meth:`_balance_direction`)."""
        return attitude_trig(np.radians(self.roll), np.radians(self.pitch))


def select_windows(blocks: pd.DataFrame, windows: pd.DataFrame, flights: Iterable[str] | None,
                   uavs: Iterable[str] | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Windows of the given flights and UAVs (all when None) and their blocks."""
    w = windows
    if flights is not None:
        w = w[w["flight"].astype(str).isin([str(f) for f in flights])]
    if uavs is not None:
        w = w[w["uav"].astype(str).isin([str(u) for u in uavs])]
    b = blocks[blocks["window_key"].isin(w["window_key"])]
    return b, w.reset_index(drop=True)
