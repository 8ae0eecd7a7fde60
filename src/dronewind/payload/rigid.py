r"""Rigid-mount multicopter records: a sonic fixed to the airframe, platform state from the vehicle's own log.

A payload flight with ``platform: rigid_mount`` (README "Rigid-mount flights") has one
record holding the sonic and the vehicle's velocity, attitude and position on one time
axis, declared by a ``delimited`` mapping (:mod:`dronewind.core.delimited`) extended to the
platform variables, and the sonic's mount in the manifest (``sonic.axes``: each sensor axis
as a body direction, or a ``matrix``; ``misalignment_deg``; ``lever_arm_m``). No pendulum
is assumed: the attitude and velocity are those of the airframe the sonic is bolted to.

L1 (:func:`rigid_l1`): the record on its regular grid (missing rows NaN), sonic in the
sensor frame, platform velocity as north/east/down, yaw wrapped to [0, 360); QC bits for
missing, out-of-range and spike samples, counted.

L2 (:func:`rigid_l2`):

1. platform gaps filled linearly in time;
2. steady segments (:func:`steady_segments`): altitude inside a band around the target
   altitude (site altitude + ``target_height_m``, else the record's median altitude) and
   horizontal speed at most a limit, for at least ``min_segment_s``: a drone that hovers
   and one that flies slow legs both pass; the longest segment is processed, every run
   that is rejected is counted with the criterion it failed;
3. the sonic-platform lag of minimum TKE (Ghirardelli et al. (2025), Sect. 3.3, Eq. 3;
   :func:`dronewind.payload.lag_search.tke_vs_lag`) with its step at the sampling interval
   (1/fs) and its range in seconds (``max_lag_s``), after checking the segment holds the
   samples the search needs (:func:`lag_search_min_samples`);
4. motion correction (Ghirardelli et al. (2025), Eqs. 1-2 with the data contract's sign):
   :math:`V_{wind} = R(\phi, \theta, \psi)\, M\, V_{sensor} + V_{platform}` (minus the
   lever-arm term :math:`R\,(\omega \times r)` when ``lever_arm_m`` is given), M the mount's
   sensor-to-body matrix (:func:`mount_matrix_of`);
5. the plausibility checks of :mod:`dronewind.payload.checks` (height, platform velocity
   against the GNSS position, sonic range).

The L2 has the variables and attributes of the sling-load L2
(:func:`dronewind.payload.l2.payload_l2`), so L3 and L4 read both alike; it adds the
platform velocity (``platform_vel_*_ms``) and the segment selection (``steady_*``).
Every rejection names the criterion and the numbers that failed it.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core import filtering
from dronewind.core.angles import deg2rad, rad2deg
from dronewind.core.cf import variable
from dronewind.core.columns import RIGID_QUANTITIES, log_platform_variables, rigid_layout
from dronewind.core.constants import ZERO_CELSIUS_K
from dronewind.core.delimited import read_delimited
from dronewind.core.qc import QC_GAP_FILLED, QC_MISSING, QC_OUT_OF_RANGE, QC_SPIKE, qc_flag_attrs
from dronewind.core.timeseries import NS_PER_S, fill_nan_by_time, time_ns, unwrap_rad
from dronewind.errors import InputError
from dronewind.payload import checks, l2, lag_search, motion
from dronewind.payload.platform_log import merge_platform_state, read_platform_state

__all__ = ["RIGID_QUANTITIES", "BODY_DIRECTIONS", "RigidMount", "mount_matrix_of", "rigid_mount", "rigid_layout",
           "rigid_l1", "Segment", "SegmentSelection", "steady_segments", "lag_search_min_samples", "rigid_l2",
           "read_platform_state"]

#: Body-frame unit vector of each direction name (body: x forward, y right, z down).
BODY_DIRECTIONS: dict[str, tuple[float, float, float]] = {
    "forward": (1.0, 0.0, 0.0), "back": (-1.0, 0.0, 0.0), "right": (0.0, 1.0, 0.0), "left": (0.0, -1.0, 0.0),
    "down": (0.0, 0.0, 1.0), "up": (0.0, 0.0, -1.0)}
_SONIC = ("u_sensor_ms", "v_sensor_ms", "w_sensor_ms", "t_sonic_k")
_PLATFORM = ("roll_deg", "pitch_deg", "yaw_deg", "vel_n_ms", "vel_e_ms", "vel_d_ms", "lat_deg", "lon_deg", "alt_m")
_NS = NS_PER_S


# ----------------------------------------------------------------------------- mount


@dataclass(frozen=True)
class RigidMount:
    """The sonic's mount on the airframe.

    Attributes
    ----------
    matrix : numpy.ndarray
        (3, 3) sensor-to-body matrix M (``v_body = M @ v_sensor``), misalignment included.
    lever_arm_m : tuple of float or None
        Point whose velocity the vehicle logs, relative to the sonic, body frame [m]; None:
        the logged velocity is the sonic's.
    description : str
        The mount in words (stored in the L2 ``mount`` attribute).
    """

    matrix: np.ndarray
    lever_arm_m: tuple[float, float, float] | None
    description: str


def mount_matrix_of(axes: Mapping[str, Any] | None, matrix: Sequence[Sequence[float]] | None = None,
                    where: str = "sonic") -> np.ndarray:
    """Sensor-to-body matrix from the sensor axes named as body directions, or given whole.

    Parameters
    ----------
    axes : mapping or None
        ``{"u": dir, "v": dir, "w": dir}``, each a key of :data:`BODY_DIRECTIONS` (the body
        direction the sensor axis points to), e.g. ``{u: right, v: forward, w: up}``.
    matrix : 3 x 3 numbers, optional
        M itself (rows body forward, right, down), used when ``axes`` is None.
    where : str
        Key path for messages.

    Returns
    -------
    numpy.ndarray
        (3, 3) M with ``v_body = M @ v_sensor``.

    Raises
    ------
    InputError
        An unknown direction, two axes along one line, or a matrix that is not a rotation
        (orthonormal, determinant +1: a right-handed sensor).
    """
    if axes is not None:
        cols = []
        for k in ("u", "v", "w"):
            name = axes.get(k)
            if name not in BODY_DIRECTIONS:
                raise InputError(f"{where}.axes.{k}", f"{name!r}; expected one of {', '.join(BODY_DIRECTIONS)}")
            cols.append(BODY_DIRECTIONS[name])
        m = np.array(cols, dtype=float).T
        key = f"{where}.axes"
    elif matrix is not None:
        m = np.asarray(matrix, dtype=float)
        key = f"{where}.matrix"
    else:
        raise InputError(where, "no sonic axes; expected axes: {u: <direction>, v: ..., w: ...} or a 3 x 3 matrix")
    if m.shape != (3, 3) or not np.allclose(m @ m.T, np.eye(3), atol=1e-6):
        raise InputError(key, f"{m.tolist()} is not orthonormal; expected each sensor axis along a different body "
                         "axis (a rotation)")
    det = float(np.linalg.det(m))
    if det < 0:
        raise InputError(key, f"determinant {det:+.0f}: the axes form a left-handed frame; expected a right-handed "
                         "sensor frame (check the sign of one axis)")
    return m


def rigid_mount(sonic: Mapping[str, Any], where: str = "sonic") -> RigidMount:
    """The mount of a rigid-mount flight's sonic from its manifest entry.

    Parameters
    ----------
    sonic : mapping
        ``axes`` or ``matrix``; optional ``misalignment_deg`` (roll, pitch, yaw [degree]:
        the true sensor-to-body matrix is ``M @ R(roll, pitch, yaw)``, ``docs/data-contract.md``
        ``mount_misalignment``) and ``lever_arm_m`` (x, y, z [m], body frame).
    where : str
        Key path for messages.

    Returns
    -------
    RigidMount
    """
    m = mount_matrix_of(sonic.get("axes"), sonic.get("matrix"), where)
    words = (", ".join(f"{k} {sonic['axes'][k]}" for k in ("u", "v", "w")) if sonic.get("axes")
             else f"matrix {m.tolist()}")
    mis = sonic.get("misalignment_deg")
    if mis is not None:
        m = m @ motion.rotation_matrix_body_to_ned(*(float(x) for x in mis))
        words += f"; misalignment roll, pitch, yaw {', '.join(f'{float(x):g}' for x in mis)} degree"
    arm = sonic.get("lever_arm_m")
    lever = None if arm is None or not np.any(np.asarray(arm, dtype=float)) else tuple(float(x) for x in arm)
    return RigidMount(m, lever, "rigid mount: sensor " + words)  # type: ignore[arg-type]


# ----------------------------------------------------------------------------- L1


def _grid(t: np.ndarray, where: str) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Rows onto their regular grid: grid index per row, grid times, rate [Hz], largest stamp offset [s]."""
    if t.size < 2:
        raise InputError(where, f"only {t.size} rows with a valid time; expected a record")
    t64 = t.astype("datetime64[ns]").astype(np.int64)
    dt_ns = int(np.median(np.diff(t64)))
    if dt_ns <= 0:
        raise InputError(where, "time does not increase; expected rows in time order (after sorting)")
    k = np.rint((t64 - t64[0]) / dt_ns).astype(np.int64)
    offset = float(np.max(np.abs(t64 - (t64[0] + k * dt_ns)))) / _NS
    times = (t64[0] + np.arange(int(k[-1]) + 1, dtype=np.int64) * dt_ns).astype("datetime64[ns]")
    return k, times, 1e9 / dt_ns, offset


def rigid_l1(path: str | os.PathLike[str], fmt: Mapping[str, Any], *, despike_window_s: float = 10.0,
             despike_n_mad: float = 7.0, limits: str = "trisonica_mini", where: str = "record.format",
             max_corrupt_fraction: float = 0.05, platform_state: xr.Dataset | None = None,
             max_log_gap_s: float = 1.0) -> xr.Dataset:
    """L1 of a rigid-mount record: sonic and platform on one regular time axis, QC counted.

    Parameters
    ----------
    path : str or Path
        The record.
    fmt : mapping
        Its ``format`` mapping (:func:`rigid_layout`).
    despike_window_s, despike_n_mad : float
        Moving-MAD despiking of the sonic (``processing.despike``) [s], [1].
    limits : str
        Key of :data:`dronewind.core.filtering.INSTRUMENT_LIMITS` for the sonic range QC.
    where : str
        Key path of the format for messages.
    max_corrupt_fraction : float
        Largest fraction of corrupt rows [1].
    platform_state : xarray.Dataset, optional
        The vehicle's own log (:func:`read_platform_state`, the flight's ``platform_log``):
        gives every platform variable the mapping does not declare (the record's columns
        win, :func:`dronewind.core.columns.log_platform_variables`), interpolated to the
        record's times (:func:`dronewind.payload.platform_log.merge_platform_state`).
    max_log_gap_s : float
        Longest gap of the platform log interpolated across [s].

    Returns
    -------
    xarray.Dataset
        On ``time`` (UTC, regular): ``u_sensor_ms``, ``v_sensor_ms``, ``w_sensor_ms``
        [m s-1], ``t_sonic_k`` [K] (NaN where flagged), ``qc_sonic``; ``roll_deg``,
        ``pitch_deg``, ``yaw_deg`` ([0, 360)), ``vel_n_ms``, ``vel_e_ms``, ``vel_d_ms``,
        ``lat_deg``, ``lon_deg``, ``alt_m`` (NaN where missing). attrs: ``sampling_rate_hz``,
        counts ``n_*``, ``processing_log``, ``platform = "rigid_mount"``. With a platform
        log also ``platform_outside_log`` (1 where the sample lies outside the log's
        coverage: no platform state) and the attrs ``platform_log_format``,
        ``platform_log_sha256``, ``platform_log_variables`` (taken from the log),
        ``platform_log_start``, ``platform_log_end`` (UTC) and ``n_platform_outside_log``.
    """
    layout = rigid_layout(fmt, where, platform_log=platform_state is not None)
    table = read_delimited(path, layout, max_corrupt_fraction)
    log = [f"read: {Path(path).name}: {table.n_lines} data rows, {table.n_corrupt} corrupt removed, "
           f"{table.n_nonnumeric} non-numeric values"]
    order = np.argsort(table.time, kind="stable")
    t = table.time[order]
    vals = {k: v[order] for k, v in table.values.items()}
    k, times, fs, offset = _grid(t, str(path))
    first = np.r_[True, np.diff(k) > 0]
    n_dup = int((~first).sum())
    k = k[first]
    vals = {name: v[first] for name, v in vals.items()}
    n = times.size
    counts = {"n_lines": table.n_lines, "n_corrupt_lines": table.n_corrupt, "n_nonnumeric": table.n_nonnumeric,
              "n_duplicate_stamps": n_dup, "n_missing_rows": int(n - k.size)}
    log.append(f"grid: {n} samples at {fs:.4g} Hz, {counts['n_missing_rows']} missing rows, {n_dup} rows on an "
               f"occupied grid point dropped, largest stamp offset from the grid {1e3 * offset:.1f} ms")

    def on_grid(name: str) -> np.ndarray:
        out = np.full(n, np.nan)
        out[k] = vals[name]
        return out

    u, v, w, t_k = (on_grid(name) for name in ("u", "v", "w", "t"))
    qc = np.zeros(n, dtype=np.int8)
    missing = ~(np.isfinite(u) & np.isfinite(v) & np.isfinite(w) & np.isfinite(t_k))
    qc[missing] |= QC_MISSING
    if "diag" in vals:
        diag = on_grid("diag")
        qc[np.isfinite(diag) & (diag != 0)] |= QC_MISSING
    lim = filtering.INSTRUMENT_LIMITS[limits]
    speed = np.sqrt(u ** 2 + v ** 2 + w ** 2)
    rng = filtering.range_mask(speed, *lim["speed_ms"]) | filtering.range_mask(t_k - ZERO_CELSIUS_K,
                                                                              *lim["t_sonic_c"])
    qc[rng & ~missing] |= QC_OUT_OF_RANGE
    spike = np.zeros(n, dtype=bool)
    for x in (u, v, w, t_k):
        spike |= filtering.despike_moving_mad(np.where(qc != 0, np.nan, x), fs, despike_window_s, despike_n_mad)
    qc[spike] |= QC_SPIKE
    counts.update(n_sonic_missing=int(missing.sum()), n_out_of_range=int((rng & ~missing).sum()),
                  n_spikes=int(spike.sum()), n_flagged=int((qc != 0).sum()))
    log.append(f"qc: {counts['n_sonic_missing']} sonic samples missing, {counts['n_out_of_range']} out of range "
               f"({limits}: speed {lim['speed_ms'][0]:g}..{lim['speed_ms'][1]:g} m/s, "
               f"{lim['t_sonic_c'][0]:g}..{lim['t_sonic_c'][1]:g} degC), {counts['n_spikes']} spikes "
               f"(moving MAD, {despike_window_s:g} s, {despike_n_mad:g} MAD)")
    bad = qc != 0
    sonic = {"u_sensor_ms": u, "v_sensor_ms": v, "w_sensor_ms": w, "t_sonic_k": t_k}
    sonic = {name: np.where(bad, np.nan, x) for name, x in sonic.items()}
    from_log = log_platform_variables(layout.variables) if platform_state is not None else ()
    vel: dict[str, np.ndarray] = {}
    if "vel_e" in vals and "vel_n" in vals and "vel_u" in vals:
        vel = {"vel_n_ms": on_grid("vel_n"), "vel_e_ms": on_grid("vel_e"), "vel_d_ms": -on_grid("vel_u")}
        log.append("platform velocity: east, north, up in the record, stored as north, east, down")
    elif "vel_d" in vals:
        vel = {"vel_n_ms": on_grid("vel_n"), "vel_e_ms": on_grid("vel_e"), "vel_d_ms": on_grid("vel_d")}
    names = {"roll_deg": "roll", "pitch_deg": "pitch", "yaw_deg": "yaw", "lat_deg": "lat", "lon_deg": "lon",
             "alt_m": "alt"}
    plat = {k: vel[k] if k in vel else on_grid(names[k]) for k in _PLATFORM if k not in from_log}
    outside = np.zeros(n, dtype=bool)
    if platform_state is not None:
        merged = merge_platform_state(times, platform_state, from_log, max_gap_s=max_log_gap_s)
        plat.update(merged.values)
        outside = merged.outside
        counts["n_platform_outside_log"] = merged.n_outside
        own = [k for k in _PLATFORM if k not in from_log]
        log.append(merged.log + (f"; from the record's columns (they win): {', '.join(own)}" if own else ""))
    plat["yaw_deg"] = np.mod(plat["yaw_deg"], 360.0)
    counts["n_platform_missing"] = int((~np.all([np.isfinite(plat[k]) for k in _PLATFORM], axis=0)).sum())
    dims = ("time",)
    ds = xr.Dataset(
        {
            "u_sensor_ms": variable(dims, sonic["u_sensor_ms"], "m s-1", long_name="sonic u, sensor frame"),
            "v_sensor_ms": variable(dims, sonic["v_sensor_ms"], "m s-1", long_name="sonic v, sensor frame"),
            "w_sensor_ms": variable(dims, sonic["w_sensor_ms"], "m s-1", long_name="sonic w, sensor frame"),
            "t_sonic_k": variable(dims, sonic["t_sonic_k"], "K", "virtual_temperature",
                                  comment="sonic temperature, approximately the virtual temperature"),
            "qc_sonic": xr.Variable(dims, qc, attrs=qc_flag_attrs("sonic quality flags",
                                                                   (QC_OUT_OF_RANGE, QC_SPIKE, QC_MISSING))),
            "roll_deg": variable(dims, plat["roll_deg"], "degree", "platform_roll"),
            "pitch_deg": variable(dims, plat["pitch_deg"], "degree", "platform_pitch"),
            "yaw_deg": variable(dims, plat["yaw_deg"], "degree", "platform_yaw",
                                comment="clockwise from true north, wrapped to [0, 360)"),
            "vel_n_ms": variable(dims, plat["vel_n_ms"], "m s-1", long_name="platform velocity north"),
            "vel_e_ms": variable(dims, plat["vel_e_ms"], "m s-1", long_name="platform velocity east"),
            "vel_d_ms": variable(dims, plat["vel_d_ms"], "m s-1", long_name="platform velocity down"),
            "lat_deg": variable(dims, plat["lat_deg"], "degrees_north", "latitude"),
            "lon_deg": variable(dims, plat["lon_deg"], "degrees_east", "longitude"),
            "alt_m": variable(dims, plat["alt_m"], "m", "altitude", comment="above mean sea level", positive="up"),
        },
        coords={"time": ("time", times)},
    )
    ds["time"].attrs.update({"standard_name": "time", "long_name": "time (UTC) of the record"})
    ds.attrs.update({"platform": "rigid_mount", "sampling_rate_hz": float(fs), "sonic_limits": limits,
                     **counts, "processing_log": "\n".join(log)})
    if platform_state is not None:
        ds["platform_outside_log"] = xr.Variable(dims, outside.astype(np.int8), attrs={
            "long_name": "sample outside the platform log's coverage (no platform state)", "units": "1",
            "flag_values": np.array([0, 1], dtype=np.int8), "flag_meanings": "covered outside_log"})
        t_log = platform_state["time"].values
        ds.attrs.update({"platform_log_format": str(platform_state.attrs.get("format", "")),
                         "platform_log_sha256": str(platform_state.attrs.get("sha256", "")),
                         "platform_log_variables": ", ".join(from_log),
                         "platform_log_start": str(t_log[0].astype("datetime64[ms]")) + "Z",
                         "platform_log_end": str(t_log[-1].astype("datetime64[ms]")) + "Z",
                         "platform_log_max_gap_s": float(max_log_gap_s)})
    return ds


# ----------------------------------------------------------------------------- steady segments


@dataclass(frozen=True)
class Segment:
    """A run of samples [start, stop) of the platform record."""

    start: int
    stop: int
    duration_s: float


@dataclass
class SegmentSelection:
    """Steady segments of a record and what the others failed.

    Attributes
    ----------
    accepted : list of Segment
        Runs that passed every criterion, longest first.
    rejected : list of str
        Runs long enough in the band and speed limit that failed ``min_segment_s`` (counted).
    alt_centre_m : float
        Centre of the altitude band [m above mean sea level].
    n_outside_band, n_too_fast : int
        Samples outside the altitude band, faster than the speed limit.
    alt_range_m : (float, float)
        Smallest and largest altitude of the record [m].
    max_speed_ms : float
        Largest horizontal speed of the record [m s-1].
    log : str
        The selection in one line.
    """

    accepted: list[Segment]
    rejected: list[str]
    alt_centre_m: float
    n_outside_band: int
    n_too_fast: int
    alt_range_m: tuple[float, float]
    max_speed_ms: float
    longest_candidate_s: float
    log: str = field(default="")


def steady_segments(t_s: np.ndarray, alt_m: np.ndarray, vel_e_ms: np.ndarray, vel_n_ms: np.ndarray, *,
                    alt_band_m: float, max_horizontal_speed_ms: float, min_segment_s: float,
                    alt_centre_m: float | None = None) -> SegmentSelection:
    """Runs of a record where the platform is steady: inside an altitude band, horizontally slow.

    Parameters
    ----------
    t_s : numpy.ndarray
        Sample times [s], increasing.
    alt_m : numpy.ndarray
        Altitude [m].
    vel_e_ms, vel_n_ms : numpy.ndarray
        Platform velocity east and north [m s-1].
    alt_band_m : float
        Half-width of the altitude band [m].
    max_horizontal_speed_ms : float
        Largest horizontal speed [m s-1] (a hover is near 0; slow legs pass).
    min_segment_s : float
        Shortest accepted segment [s].
    alt_centre_m : float, optional
        Centre of the band [m]; default the median altitude of the record.

    Returns
    -------
    SegmentSelection
    """
    alt = np.asarray(alt_m, dtype=float)
    speed = np.hypot(np.asarray(vel_e_ms, dtype=float), np.asarray(vel_n_ms, dtype=float))
    centre = float(np.nanmedian(alt)) if alt_centre_m is None else float(alt_centre_m)
    in_band = np.abs(alt - centre) <= alt_band_m
    slow = speed <= max_horizontal_speed_ms
    ok = in_band & slow
    m = np.concatenate([[False], ok, [False]]).astype(np.int8)
    starts, stops = np.flatnonzero(np.diff(m) == 1), np.flatnonzero(np.diff(m) == -1)
    accepted: list[Segment] = []
    rejected: list[str] = []
    dt = float(np.median(np.diff(t_s))) if t_s.size > 1 else 0.0
    longest = 0.0
    for a, b in zip(starts, stops, strict=True):
        dur = float(t_s[b - 1] - t_s[a]) + dt
        longest = max(longest, dur)
        if dur >= min_segment_s:
            accepted.append(Segment(int(a), int(b), dur))
        else:
            rejected.append(f"{dur:.1f} s at {t_s[a]:.1f} s")
    accepted.sort(key=lambda s: -s.duration_s)
    sel = SegmentSelection(accepted, rejected, centre, int((~in_band).sum()), int((~slow).sum()),
                           (float(np.nanmin(alt)), float(np.nanmax(alt))), float(np.nanmax(speed)), longest)
    sel.log = (f"steady: altitude band {centre:.1f} +/- {alt_band_m:g} m (record {sel.alt_range_m[0]:.1f} to "
               f"{sel.alt_range_m[1]:.1f} m; {sel.n_outside_band} samples outside), horizontal speed <= "
               f"{max_horizontal_speed_ms:g} m/s (record max {sel.max_speed_ms:.2f} m/s; {sel.n_too_fast} samples "
               f"faster), min_segment_s {min_segment_s:g} s: {len(accepted)} segments accepted "
               f"({', '.join(f'{s.duration_s:.1f} s' for s in accepted) or 'none'}), {len(rejected)} runs shorter")
    return sel


def _no_segment_message(sel: SegmentSelection, alt_band_m: float, max_speed: float, min_segment_s: float) -> str:
    """Why no steady segment was accepted, with the numbers of each criterion."""
    return (f"no steady segment of at least min_segment_s = {min_segment_s:g} s: the longest run inside the "
            f"altitude band and under the speed limit lasts {sel.longest_candidate_s:.1f} s. Criteria: altitude "
            f"within {sel.alt_centre_m:.1f} +/- {alt_band_m:g} m (alt_band_m; the record spans "
            f"{sel.alt_range_m[0]:.1f} to {sel.alt_range_m[1]:.1f} m, {sel.n_outside_band} samples outside), "
            f"horizontal speed <= {max_speed:g} m/s (max_horizontal_speed_ms; record max {sel.max_speed_ms:.2f} m/s, "
            f"{sel.n_too_fast} samples faster); {len(sel.rejected)} shorter runs rejected"
            + (f" (longest first: {', '.join(sorted(sel.rejected, key=lambda r: -float(r.split()[0]))[:5])})"
               if sel.rejected else "")
            + ". Widen processing.rigid_mount.alt_band_m or max_horizontal_speed_ms, or lower min_segment_s")


def lag_search_min_samples(max_lag_s: float, fs_hz: float) -> tuple[int, int]:
    """Samples a lag search needs at this rate and range.

    Parameters
    ----------
    max_lag_s : float
        Half-width of the search [s].
    fs_hz : float
        Sampling rate [Hz]; the step is 1/fs.

    Returns
    -------
    n_half : int
        Half-width in steps (``round(max_lag_s * fs_hz)``).
    n_min : int
        Fewest samples of the segment: ``8 n_half + 16``, the rule of
        :func:`dronewind.payload.lag_search.tke_vs_lag` (the TKE of every lag averages at least
        four times the search width).
    """
    n_half = int(round(max_lag_s * fs_hz))
    return n_half, 8 * n_half + 16


# ----------------------------------------------------------------------------- L2


def _fill_platform(l1: xr.Dataset, t: np.ndarray, where: str) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Platform variables with gaps filled linearly in time (yaw unwrapped first); the missing mask."""
    out: dict[str, np.ndarray] = {}
    missing = np.zeros(t.size, dtype=bool)
    for k in _PLATFORM:
        x = np.asarray(l1[k].values, dtype=float).copy()
        ok = np.isfinite(x)
        if ok.sum() < 2:
            raise InputError(f"{where} [{k}]", f"{int(ok.sum())} finite samples of {t.size}; expected a platform "
                             "record")
        missing |= ~ok
        if k == "yaw_deg":
            x[ok] = rad2deg(unwrap_rad(deg2rad(x[ok])))
        out[k], _ = fill_nan_by_time(t, x)
    return out, missing


def rigid_l2(l1: xr.Dataset, mount: RigidMount, *, alt_band_m: float, max_horizontal_speed_ms: float,
             min_segment_s: float, max_lag_s: float, max_missing_fraction: float = 0.02,
             site_altitude_m: float | None = None, target_height_m: float | None = None,
             flight_id: str | None = None) -> xr.Dataset:
    """Rigid-mount L2: steady segment, sonic-platform lag, motion-corrected wind east/north/up.

    Parameters
    ----------
    l1 : xarray.Dataset
        :func:`rigid_l1` output.
    mount : RigidMount
        The sonic's mount (:func:`rigid_mount`).
    alt_band_m, max_horizontal_speed_ms, min_segment_s : float
        ``processing.rigid_mount``: altitude band half-width [m] around site altitude +
        ``target_height_m`` (or the record's median altitude), horizontal speed limit
        [m s-1], shortest steady segment [s] (:func:`steady_segments`).
    max_lag_s : float
        Half-width of the lag search [s]; the step is the sampling interval.
    max_missing_fraction : float
        Largest fraction of missing sonic samples in the segment that is gap-filled [1].
    site_altitude_m : float, optional
        Ground altitude above mean sea level [m] (attrs ``height_m``).
    target_height_m : float, optional
        Nominal height above ground [m]: centres the altitude band, checked against.
    flight_id : str, optional
        For messages.

    Returns
    -------
    xarray.Dataset
        The variables and attributes of the sling-load L2
        (:func:`dronewind.payload.l2.payload_l2`) plus ``platform_vel_e_ms``,
        ``platform_vel_n_ms``, ``platform_vel_u_ms`` and the attributes ``platform``,
        ``steady_*``.

    Raises
    ------
    InputError
        No steady segment (naming each criterion, its setting and the record's numbers), or
        a segment with fewer samples than the lag search needs (samples and seconds).
    """
    src = l1.attrs.get("source_file", "")
    where = f"flight {flight_id}" + (f" ({src})" if src else "") if flight_id else (src or "rigid-mount record")
    t_ns = time_ns(l1, "rigid l1")
    t = (t_ns - t_ns[0]) / _NS
    fs = float(l1.attrs.get("sampling_rate_hz", 1.0 / float(np.median(np.diff(t)))))
    reasons: list[str] = []
    log: list[str] = []
    plat, plat_missing = _fill_platform(l1, t, where)
    log.append(f"platform_gaps: filled {int(plat_missing.sum())} platform samples linearly in time")
    # samples outside the platform log's coverage have no platform state: never in a steady segment
    outside = (np.asarray(l1["platform_outside_log"].values) != 0 if "platform_outside_log" in l1
               else np.zeros(t.size, dtype=bool))
    if outside.any():
        log.append(f"platform_log: {int(outside.sum())} samples outside the log's coverage left out of the steady "
                   "segments")
    centre = None if target_height_m is None or site_altitude_m is None else site_altitude_m + target_height_m
    sel = steady_segments(t, np.where(outside, np.nan, plat["alt_m"]), plat["vel_e_ms"], plat["vel_n_ms"],
                          alt_band_m=alt_band_m,
                          max_horizontal_speed_ms=max_horizontal_speed_ms, min_segment_s=min_segment_s,
                          alt_centre_m=centre)
    log.append(sel.log)
    if not sel.accepted:
        raise InputError(f"{where} [processing.rigid_mount]",
                         _no_segment_message(sel, alt_band_m, max_horizontal_speed_ms, min_segment_s))
    seg = sel.accepted[0]
    n_half, n_min = lag_search_min_samples(max_lag_s, fs)
    n_seg = seg.stop - seg.start
    if n_seg < n_min:
        raise InputError(f"{where} [processing.rigid_mount.max_lag_s]",
                         f"the longest steady segment holds {n_seg} samples ({seg.duration_s:.1f} s at {fs:.4g} Hz); "
                         f"a +/-{max_lag_s:g} s lag search in steps of 1/fs = {1 / fs:.4g} s needs at least {n_min} "
                         f"samples ({n_min / fs:.1f} s): 8 x {n_half} steps + 16. Lower max_lag_s or widen the "
                         "steady-segment criteria (alt_band_m, max_horizontal_speed_ms)")
    idx = np.arange(seg.start, seg.stop)
    raw = {k: np.asarray(l1[k].values, dtype=float)[idx] for k in _SONIC}
    nan_any = ~np.all([np.isfinite(x) for x in raw.values()], axis=0)
    frac = float(nan_any.mean())
    filled = {k: filtering.gap_fill_linear(x, 1.0)[0] for k, x in raw.items()}
    if frac > max_missing_fraction:
        reasons.append(f"{100 * frac:.2f} % of the sonic samples in the steady segment missing or flagged "
                       f"({int(nan_any.sum())} of {n_seg}; limit {100 * max_missing_fraction:g} %)")
    log.append(f"sonic_gaps: {int(nan_any.sum())} of {n_seg} samples filled linearly ({100 * frac:.2f} %)")
    sensor = np.stack([filled["u_sensor_ms"], filled["v_sensor_ms"], filled["w_sensor_ms"]], axis=-1)
    body = sensor @ mount.matrix.T
    lo, hi = max(0, seg.start - n_half - 1), min(t.size, seg.stop + n_half + 1)
    att = np.stack([plat["roll_deg"], plat["pitch_deg"], plat["yaw_deg"]], axis=-1)
    vel = np.stack([plat["vel_n_ms"], plat["vel_e_ms"], plat["vel_d_ms"]], axis=-1)
    step = 1.0 / fs
    lag_grid, tke, n_tke = lag_search.tke_vs_lag(t[idx], body, t[lo:hi], att[lo:hi], vel[lo:hi], "upside_down",
                                           lever_arm_m=mount.lever_arm_m, max_lag_s=n_half * step, lag_step_s=step)
    lag, at_edge = lag_search.find_sonic_ins_lag(lag_grid, tke)
    log.append(f"sync: lag of minimum TKE {lag:+.3f} s (search +/-{n_half * step:g} s in steps of {step:.4g} s = "
               f"1/fs, {n_tke} samples); TKE {float(np.min(tke)):.3f} m2 s-2 at the minimum, "
               f"{float(tke[n_half]):.3f} at lag 0")
    if at_edge:
        reasons.append(f"sonic-platform lag {lag:+.3f} s at the edge of the +/-{n_half * step:g} s search range")
    t_al = t[idx] + lag
    keep = (t_al >= t[0]) & (t_al <= t[-1])
    keys: dict[str, np.ndarray] = dict(plat)
    if mount.lever_arm_m is not None:
        keys["rates"] = motion.body_rates_from_euler(plat["roll_deg"], plat["pitch_deg"], plat["yaw_deg"], t)
    p = lag_search.interpolate_ins(t, keys, t_al[keep])
    b = body[keep]
    u_e, v_n, w_u = motion.motion_correct(b[:, 0], b[:, 1], b[:, 2], p["roll_deg"], p["pitch_deg"], p["yaw_deg"],
                                          p["vel_n_ms"], p["vel_e_ms"], p["vel_d_ms"], "upside_down",
                                          lever_arm_m=mount.lever_arm_m, body_rates_rad_s=p.get("rates"))
    log.append(f"motion: V_wind = R M V_sensor + V_platform on {int(keep.sum())} samples ({mount.description}; "
               f"lever arm {'none' if mount.lever_arm_m is None else mount.lever_arm_m} m)")
    gnss = ~plat_missing
    results = [checks.velocity_position_check(t[gnss], plat["lat_deg"][gnss], plat["lon_deg"][gnss],
                                              plat["alt_m"][gnss], plat["vel_n_ms"][gnss], plat["vel_e_ms"][gnss],
                                              plat["vel_d_ms"][gnss])]
    height = float(np.median(p["alt_m"]) - site_altitude_m) if site_altitude_m is not None else float("nan")
    if site_altitude_m is not None:
        results.append(checks.height_check(height, target_height_m))
    qc = np.asarray(l1["qc_sonic"].values).astype(np.int32)[idx] if "qc_sonic" in l1 else np.zeros(n_seg, np.int32)
    n_out = int(((qc & QC_OUT_OF_RANGE) != 0).sum())
    results.append(checks.sonic_range_check(n_out, n_seg, max_missing_fraction, str(l1.attrs.get("sonic_limits", ""))))
    for r in results:
        log.append(r.log)
        if r.reason:
            reasons.append(r.reason)
    time_out = (t_ns[idx][keep] + int(round(lag * _NS))).astype("datetime64[ns]")
    dims = ("time",)
    ds = l2.l2_variables(time_out, (u_e, v_n, w_u), filled["t_sonic_k"][keep],
                           {**p, "yaw_deg": np.mod(p["yaw_deg"], 360.0)}, lag_grid, tke, clock="platform")
    for name, values, direction in (("platform_vel_e_ms", p["vel_e_ms"], "east"),
                                    ("platform_vel_n_ms", p["vel_n_ms"], "north"),
                                    ("platform_vel_u_ms", -p["vel_d_ms"], "up")):
        ds[name] = variable(dims, values, "m s-1", long_name=f"platform velocity {direction}")
    qc_out = np.where(nan_any, qc | QC_GAP_FILLED, qc)[keep]
    attrs = qc_flag_attrs("sonic quality flags", dtype=np.int32, with_values=False)
    del attrs["units"]
    ds["qc_sonic"] = xr.Variable(dims, qc_out, attrs=attrs)
    ds.attrs.update({
        "platform": "rigid_mount", "lag_sonic_ins_s": float(lag), "lag_tke_min_s": float(lag),
        "usable": int(not reasons), "unusable_reason": "; ".join(reasons), "mount": mount.description,
        "lever_arm_m": "none" if mount.lever_arm_m is None else ", ".join(f"{x:g}" for x in mount.lever_arm_m),
        "sampling_rate_hz": fs, "lag_search_max_s": float(n_half * step), "lag_search_step_s": float(step),
        "n_samples": int(keep.sum()), "n_sonic_filled": int(nan_any.sum()),
        "n_platform_filled": int(plat_missing.sum()), "n_platform_outside_log": int(outside.sum()),
        "steady_alt_centre_m": sel.alt_centre_m, "steady_alt_band_m": float(alt_band_m),
        "steady_max_horizontal_speed_ms": float(max_horizontal_speed_ms), "steady_min_segment_s": float(min_segment_s),
        "steady_n_segments": len(sel.accepted), "steady_segment_durations_s": ", ".join(
            f"{s.duration_s:.1f}" for s in sel.accepted),
        "steady_segment_used_s": float(seg.duration_s), "steady_n_runs_too_short": len(sel.rejected),
        "processing_log": "\n".join(log),
    })
    if site_altitude_m is not None:
        ds.attrs["height_m"] = height
    return ds
