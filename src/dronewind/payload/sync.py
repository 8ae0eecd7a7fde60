"""Synchronisation: sonic-to-INS lag (L2 payload) and drone-to-mast alignment (L3).

Two builders of the data levels of DESIGN.md live here:

* :func:`payload_l2` -- hover window, gap filling, sonic-INS lag by minimum TKE
  (seed 000, Sect. 3.3), motion correction (:mod:`dronewind.payload.motion`), east/north/up wind at
  the sonic rate;
* :func:`align_drone_mast` -- advection lag by maximum cross-correlation of the horizontal
  wind fluctuations, common 32 Hz base, FIR anti-alias filter and decimation to 8 Hz,
  rotation into streamline coordinates (seed 000, Sect. 4.4; :mod:`dronewind.core.rotation`).

Sign conventions (DESIGN.md):

* ``lag_sonic_ins_s`` is the time ADDED to the sonic's clock to align it with the INS: the
  sonic sample stamped ``t`` is combined with the INS state at ``t + lag``;
* ``lag_drone_mast_s`` is the time ADDED to the drone's stamps to align them with the mast;
  it is positive when the drone sees a structure first (drone upwind of the mast).

Times are handled as float seconds since the first time stamp of the inputs (int64
nanoseconds are subtracted before conversion, so a flight keeps sub-microsecond
resolution).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import scipy.signal
import xarray as xr

from dronewind.core import filtering
from dronewind.payload import motion
from dronewind.core import rotation as _rotation
from dronewind.errors import InputError, ProcessingError

__all__ = [
    "interpolate_ins",
    "tke_vs_lag",
    "find_sonic_ins_lag",
    "payload_l2",
    "design_antialias_fir",
    "fir_response",
    "fir_decimate",
    "drone_mast_lag",
    "align_drone_mast",
]

_NS = 1_000_000_000
_INS_VARS = ("roll_deg", "pitch_deg", "yaw_deg", "vel_n_ms", "vel_e_ms", "vel_d_ms", "lat_deg", "lon_deg", "alt_m")
_SONIC_VARS = ("u_sensor_ms", "v_sensor_ms", "w_sensor_ms", "t_sonic_k")
_ENU_VARS = ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k")


# ----------------------------------------------------------------------------- helpers


def _time_ns(ds: xr.Dataset, where: str) -> np.ndarray:
    if "time" not in ds.coords and "time" not in ds.variables:
        raise InputError(where, "dataset has no 'time' coordinate")
    t = np.asarray(ds["time"].values).astype("datetime64[ns]").astype(np.int64)
    if t.size < 2:
        raise InputError(f"{where}:time", f"need at least 2 samples, got {t.size}")
    if np.any(np.diff(t) <= 0):
        raise InputError(f"{where}:time", "time must be strictly increasing (L1 removes duplicates and sorts)")
    return t


def _require(ds: xr.Dataset, names: Sequence[str], where: str) -> None:
    missing = [n for n in names if n not in ds.variables]
    if missing:
        raise InputError(where, f"missing variables {missing}; expected {list(names)}")


def _fill_nan_by_time(t_s: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, int]:
    """Linear interpolation in time over NaNs (ends held); returns (filled, n_filled)."""
    bad = ~np.isfinite(x)
    n_bad = int(bad.sum())
    if n_bad == 0:
        return x, 0
    if n_bad == x.size:
        return x, 0
    out = x.copy()
    out[bad] = np.interp(t_s[bad], t_s[~bad], x[~bad])
    return out, n_bad


def _longest_true_run(mask: np.ndarray) -> tuple[int, int, int]:
    """(start, stop_exclusive, n_runs) of the longest run of True; (0, 0, 0) if none."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    d = np.diff(m.astype(np.int8))
    starts = np.flatnonzero(d == 1)
    stops = np.flatnonzero(d == -1)
    if starts.size == 0:
        return 0, 0, 0
    k = int(np.argmax(stops - starts))
    return int(starts[k]), int(stops[k]), int(starts.size)


def interpolate_ins(time_ins_s: np.ndarray, ins: dict[str, np.ndarray], time_target_s: np.ndarray,
                    ) -> dict[str, np.ndarray]:
    """Linear interpolation of INS series onto target times (yaw unwrapped, then wrapped).

    Parameters
    ----------
    time_ins_s : numpy.ndarray
        Strictly increasing INS times [s].
    ins : dict of numpy.ndarray
        Finite INS series on ``time_ins_s``; a key ``yaw_deg`` [degree] is unwrapped
        before and wrapped to [0, 360) after interpolation; other keys are interpolated as
        they are (angles other than yaw never approach +/-180 degree on a hovering payload).
    time_target_s : numpy.ndarray
        Target times [s]; must lie within ``[time_ins_s[0], time_ins_s[-1]]``.

    Returns
    -------
    dict of numpy.ndarray
        Series on ``time_target_s``.

    Notes
    -----
    Seed 000, Sect. 3.2: the 50 Hz EKF output is brought to the 32 Hz sonic times by linear
    interpolation.
    """
    tt = np.asarray(time_target_s, dtype=float)
    ti = np.asarray(time_ins_s, dtype=float)
    if tt.size and (tt.min() < ti[0] - 1e-9 or tt.max() > ti[-1] + 1e-9):
        raise InputError("ins:time", f"target times [{tt.min():.3f}, {tt.max():.3f}] s exceed the INS record "
                         f"[{ti[0]:.3f}, {ti[-1]:.3f}] s")
    out: dict[str, np.ndarray] = {}
    for key, val in ins.items():
        arr = np.asarray(val, dtype=float)
        if arr.ndim == 2:
            out[key] = np.stack([np.interp(tt, ti, arr[:, k]) for k in range(arr.shape[1])], axis=-1)
        elif key == "yaw_deg":
            unwrapped = np.rad2deg(np.unwrap(np.deg2rad(arr)))
            out[key] = np.mod(np.interp(tt, ti, unwrapped), 360.0)
        else:
            out[key] = np.interp(tt, ti, arr)
    return out


# ----------------------------------------------------------------------- sonic-INS lag


def tke_vs_lag(
    time_sonic_s: np.ndarray,
    sonic_sensor_ms: np.ndarray,
    time_ins_s: np.ndarray,
    attitude_deg: np.ndarray,
    vel_ned_ms: np.ndarray,
    mount: str,
    lever_arm_m: Sequence[float] | None = None,
    max_lag_s: float = 2.0,
    lag_step_s: float = 1.0 / 32.0,
    misalignment_deg: Sequence[float] | None = None,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Mean TKE of the motion-corrected wind as a function of the sonic-INS lag.

    Parameters
    ----------
    time_sonic_s : numpy.ndarray
        Sonic sample times [s], strictly increasing, shape (n,).
    sonic_sensor_ms : numpy.ndarray
        (n, 3) finite sonic reading in the sensor frame [m s-1].
    time_ins_s : numpy.ndarray
        INS times [s], strictly increasing, shape (m,).
    attitude_deg : numpy.ndarray
        (m, 3) finite roll, pitch, yaw [degree].
    vel_ned_ms : numpy.ndarray
        (m, 3) finite INS velocity north, east, down [m s-1].
    mount : str
        Sonic mount, see :func:`dronewind.payload.motion.mount_matrix`.
    lever_arm_m : (x, y, z) [m], optional
        INS reference point relative to the sonic (body frame).
    max_lag_s : float
        Half-width of the search range [s]; default 2 s (seed 000, Sect. 3.3).
    lag_step_s : float
        Step of the search [s]; default 1/32 s (seed 000, Sect. 3.3).
    misalignment_deg : (roll, pitch, yaw) [degree], optional
        Mount misalignment, see :func:`dronewind.payload.motion.sensor_to_body_matrix`.

    Returns
    -------
    lag_s : numpy.ndarray
        The lags [s], ``-max_lag_s ... +max_lag_s`` (129 values by default); the sonic
        sample at ``t`` is combined with the INS state at ``t + lag``.
    tke_m2s2 : numpy.ndarray
        Mean TKE of the corrected wind at each lag [m2 s-2].
    n_samples : int
        Number of sonic grid samples the TKE is computed from (the same for all lags).

    Notes
    -----
    Seed 000, Sect. 3.3 and Eq. 3, :math:`TKE = \\tfrac12(\\sigma_u^2 + \\sigma_v^2 +
    \\sigma_w^2)`, of :math:`W_j(t) = R(t + j\\Delta) b(t) + V(t + j\\Delta)` with
    :math:`b = M V_{sensor}` and :math:`V` the sonic velocity (INS velocity minus the
    lever-arm term). Because R is a rotation, :math:`|R b| = |b|`, so

    .. math::

        2\\,TKE_j = \\overline{|b|^2} + \\overline{|V_j|^2}
            + 2\\,\\overline{(R_j^T V_j)\\cdot b}
            - \\left|\\overline{R_j b} + \\overline{V_j}\\right|^2 ,

    and every lag-dependent mean is a cross-correlation (9 + 3 series) or a sliding sum.
    All 2J+1 lags are evaluated at once with FFT correlations
    (:func:`scipy.signal.fftconvolve`), O(n log n) instead of O(n J). For this, the sonic is
    placed on a regular grid of step ``lag_step_s`` starting at its first sample inside
    the INS coverage (exact for a regular sonic at 1/``lag_step_s``, else linear
    interpolation), and the INS (yaw unwrapped) is interpolated linearly onto the grid
    extended by ``max_lag_s`` on each side: lag ``j * lag_step_s`` is then a shift by j
    samples. Variances use the population normalisation (1/n).

    References
    ----------
    Seed 000 (Ghirardelli et al.), Sect. 3.3, Eq. 3 and Fig. 4.
    """
    ts = np.asarray(time_sonic_s, dtype=float)
    ti = np.asarray(time_ins_s, dtype=float)
    sonic = np.asarray(sonic_sensor_ms, dtype=float)
    att = np.asarray(attitude_deg, dtype=float)
    vel = np.asarray(vel_ned_ms, dtype=float)
    if sonic.shape != (ts.size, 3):
        raise InputError("sonic_sensor_ms", f"expected shape ({ts.size}, 3), got {sonic.shape}")
    if att.shape != (ti.size, 3) or vel.shape != (ti.size, 3):
        raise InputError("ins", f"attitude and velocity must have shape ({ti.size}, 3)")
    for name, arr in (("sonic_sensor_ms", sonic), ("attitude_deg", att), ("vel_ned_ms", vel)):
        if not np.all(np.isfinite(arr)):
            raise InputError(name, "non-finite values: fill gaps before the lag search")
    if not (lag_step_s > 0 and max_lag_s >= 0):
        raise InputError("max_lag_s/lag_step_s", "expected max_lag_s >= 0 and lag_step_s > 0")
    n_half = int(round(max_lag_s / lag_step_s))
    if abs(n_half * lag_step_s - max_lag_s) > 1e-6 * max(1.0, max_lag_s):
        raise InputError("max_lag_s", f"max_lag_s={max_lag_s} is not a multiple of lag_step_s={lag_step_s}")
    dt = float(lag_step_s)
    # sonic grid: first sonic sample whose whole lag range is inside the INS record
    lo = ti[0] + n_half * dt
    hi = ti[-1] - n_half * dt
    inside = np.flatnonzero((ts >= lo - 1e-9) & (ts <= hi + 1e-9))
    if inside.size == 0:
        raise InputError("ins:time", "the INS record does not cover the sonic record +/- max_lag_s")
    t0 = ts[inside[0]]
    n = int(np.floor((min(ts[-1], hi) - t0) / dt + 1e-9)) + 1
    if n < 8 * n_half + 16:
        raise InputError("sonic:time", f"record too short for a +/-{max_lag_s} s lag search ({n} grid samples)")
    grid = t0 + dt * np.arange(n)
    m_mount = motion.sensor_to_body_matrix(mount, misalignment_deg)
    b = np.stack([np.interp(grid, ts, sonic[:, k]) for k in range(3)], axis=-1) @ m_mount.T
    grid_ext = t0 + dt * np.arange(-n_half, n + n_half)
    ins_keys = {"roll_deg": att[:, 0], "pitch_deg": att[:, 1], "yaw_deg": att[:, 2], "vel": vel}
    if lever_arm_m is not None:
        ins_keys["rates"] = motion.body_rates_from_euler(att[:, 0], att[:, 1], att[:, 2], ti)
    ins_g = interpolate_ins(ti, ins_keys, np.clip(grid_ext, ti[0], ti[-1]))
    rot = motion.rotation_matrix_body_to_ned(ins_g["roll_deg"], ins_g["pitch_deg"], ins_g["yaw_deg"])
    v_sonic = ins_g["vel"]
    if lever_arm_m is not None:
        v_sonic = v_sonic - motion.lever_arm_velocity_ned(rot, ins_g["rates"], lever_arm_m)
    c_body = np.einsum("nji,nj->ni", rot, v_sonic)  # R^T V
    # correlations: column pairs (R_il, b_l) for i, l and (c_l, b_l)
    long_cols = np.concatenate([rot.reshape(-1, 9), c_body], axis=1)
    short_cols = np.concatenate([np.tile(b, (1, 3)), b], axis=1)
    corr = scipy.signal.fftconvolve(long_cols, short_cols[::-1], mode="valid", axes=0)  # (2J+1, 12)
    sum_rb = corr[:, :9].reshape(-1, 3, 3).sum(axis=2)  # (2J+1, 3): sum_k R(k+j) b(k)
    sum_cb = corr[:, 9:].sum(axis=1)
    cs_v = np.concatenate([np.zeros((1, 3)), np.cumsum(v_sonic, axis=0)])
    cs_v2 = np.concatenate([[0.0], np.cumsum(np.sum(v_sonic ** 2, axis=1))])
    j = np.arange(2 * n_half + 1)
    sum_v = cs_v[j + n] - cs_v[j]
    sum_v2 = cs_v2[j + n] - cs_v2[j]
    sum_b2 = float(np.sum(b * b))
    mean_w = (sum_rb + sum_v) / n
    tke = 0.5 * ((sum_b2 + sum_v2 + 2.0 * sum_cb) / n - np.sum(mean_w ** 2, axis=1))
    lag_s = dt * np.arange(-n_half, n_half + 1)
    return lag_s, tke, n


def find_sonic_ins_lag(lag_s: np.ndarray, tke_m2s2: np.ndarray) -> tuple[float, bool]:
    """Lag of minimum TKE (seed 000, Sect. 3.3).

    Parameters
    ----------
    lag_s, tke_m2s2 : numpy.ndarray
        Output of :func:`tke_vs_lag`.

    Returns
    -------
    lag_sonic_ins_s : float
        The lag on the search grid with the smallest TKE [s] (time added to the sonic clock).
    at_edge : bool
        True if the minimum is at either end of the search range (search failed).
    """
    k = int(np.nanargmin(tke_m2s2))
    return float(lag_s[k]), bool(k == 0 or k == len(lag_s) - 1)


def _var(values: np.ndarray, dims: tuple[str, ...], units: str, std: str | None = None,
         long: str | None = None, **extra: Any) -> xr.Variable:
    attrs: dict[str, Any] = {"units": units}
    if std:
        attrs["standard_name"] = std
    if long:
        attrs["long_name"] = long
    attrs.update(extra)
    return xr.Variable(dims, values, attrs=attrs)


def payload_l2(
    sonic_l1: xr.Dataset,
    ins_l1: xr.Dataset,
    mount: str,
    lever_arm_m: tuple[float, float, float] | None = None,
    max_lag_s: float = 2.0,
    lag_step_s: float = 1.0 / 32.0,
    *,
    misalignment_deg: tuple[float, float, float] | None = None,
    window: tuple[Any, Any] | None = None,
    min_hover_s: float = 600.0,
    hover_alt_tol_m: float = 3.0,
    hover_horiz_tol_m: float = 4.0,
    max_missing_fraction: float = 0.02,
    fixed_lag_s: float | None = None,
    site_altitude_m: float | None = None,
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
        Sonic mount (DESIGN.md).
    lever_arm_m : (x, y, z) [m], optional
        INS reference point relative to the sonic, body frame; None = INS outputs at the
        sonic (seed 000, Sect. 3.2).
    max_lag_s, lag_step_s : float
        Sonic-INS lag search range and step [s] (seed 000, Sect. 3.3: 2 s and 1/32 s).
    misalignment_deg : (roll, pitch, yaw) [degree], optional
        Known mount misalignment, see :func:`dronewind.payload.motion.sensor_to_body_matrix`.
    window : (start, end), optional
        UTC limits (anything ``numpy.datetime64`` accepts) applied before the hover
        search, e.g. the manifest's flight window.
    min_hover_s : float
        Shortest usable hover [s]; default 600 s (seed 000, Sect. 5: at least 10 min).
    hover_alt_tol_m, hover_horiz_tol_m : float
        Hover window: median altitude +/- ``hover_alt_tol_m``, then +/- ``hover_horiz_tol_m``
        horizontally (seed 000, Sect. 3.2: 3 m and 4 m) [m].
    max_missing_fraction : float
        Largest fraction of missing sonic samples that is gap-filled; default 0.02
        (seed 000, Sect. 3.2).
    fixed_lag_s : float, optional
        Apply this sonic-INS lag [s] instead of the TKE minimum (the TKE curve is still
        computed and stored); attrs ``lag_tke_min_s`` keeps the search result.
    site_altitude_m : float, optional
        Ground altitude above mean sea level [m]; if given, attrs ``height_m`` = median INS
        altitude in the output minus it (read by :func:`align_drone_mast`).

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
    Steps: (1) INS gaps (NaN or ``ekf_valid == 0``) filled linearly in time; (2) hover
    window = longest contiguous run of :func:`dronewind.core.filtering.hover_window_mask`
    (seed 000, Sect. 3.2); (3) sonic gaps filled with
    :func:`dronewind.core.filtering.gap_fill_linear` on the hover window +/- ``max_lag_s``
    (> 2 % missing: ``usable = 0``, data not filled and the NaN samples are
    interpolated only for the lag search); (4) lag of minimum TKE (:func:`tke_vs_lag`,
    seed 000, Sect. 3.3); (5) INS interpolated to the shifted sonic times and the wind
    corrected (:func:`dronewind.payload.motion.motion_correct`, seed 000, Eqs. 1-2).

    References
    ----------
    Seed 000, Sects. 3.1-3.3, Eqs. 1-3.
    """
    _require(sonic_l1, _SONIC_VARS, "sonic_l1")
    _require(ins_l1, _INS_VARS, "ins_l1")
    motion.mount_matrix(mount)  # validates the name early
    log: list[str] = []
    counts: dict[str, int] = {}
    reasons: list[str] = []
    ts_ns = _time_ns(sonic_l1, "sonic_l1")
    ti_ns = _time_ns(ins_l1, "ins_l1")
    if window is not None:
        w0, w1 = (np.datetime64(w.rstrip("Z") if isinstance(w, str) else w, "ns").astype(np.int64)
                  for w in window)
        keep_s = (ts_ns >= w0) & (ts_ns <= w1)
        keep_i = (ti_ns >= w0) & (ti_ns <= w1)
        counts["n_sonic_outside_window"] = int((~keep_s).sum())
        counts["n_ins_outside_window"] = int((~keep_i).sum())
        sonic_l1 = sonic_l1.isel(time=np.flatnonzero(keep_s))
        ins_l1 = ins_l1.isel(time=np.flatnonzero(keep_i))
        ts_ns, ti_ns = ts_ns[keep_s], ti_ns[keep_i]
        log.append(f"window: kept {keep_s.sum()} sonic and {keep_i.sum()} INS samples in the flight window")
        if ts_ns.size < 2 or ti_ns.size < 2:
            raise InputError("window", "the flight window holds fewer than 2 sonic or INS samples")
    t_ref = int(min(ts_ns[0], ti_ns[0]))
    ts = (ts_ns - t_ref) / _NS
    ti = (ti_ns - t_ref) / _NS

    # (1) INS gaps
    ins = {k: np.asarray(ins_l1[k].values, dtype=float) for k in _INS_VARS}
    invalid = np.zeros(ti.size, dtype=bool)
    if "ekf_valid" in ins_l1.variables:
        invalid = np.asarray(ins_l1["ekf_valid"].values) == 0
    counts["n_ins_ekf_invalid"] = int(invalid.sum())
    ins_missing = invalid.copy()
    for k in _INS_VARS:
        x = np.where(invalid, np.nan, ins[k])
        ins_missing |= ~np.isfinite(x)
        if k == "yaw_deg":  # unwrap over the valid samples only, so gaps are bridged the short way
            ok = np.isfinite(x)
            x[ok] = np.rad2deg(np.unwrap(np.deg2rad(x[ok])))
        if not np.isfinite(x).any():
            raise InputError(f"ins_l1:{k}", "no valid sample")
        ins[k], _ = _fill_nan_by_time(ti, x)
    counts["n_ins_filled"] = int(ins_missing.sum())
    log.append(f"ins_gaps: filled {int(ins_missing.sum())} INS samples (NaN or ekf_valid=0) by linear "
               "interpolation in time")

    # (2) hover window
    hover = filtering.hover_window_mask(ins["alt_m"], ins["lat_deg"], ins["lon_deg"],
                                        alt_tol_m=hover_alt_tol_m, horiz_tol_m=hover_horiz_tol_m)
    i0, i1, n_runs = _longest_true_run(hover)
    if i1 - i0 < 2:
        raise InputError("ins_l1:alt_m/lat_deg/lon_deg",
                         f"no hover window found (median altitude +/-{hover_alt_tol_m:g} m, "
                         f"+/-{hover_horiz_tol_m:g} m horizontally)")
    h0, h1 = ti[i0], ti[i1 - 1]
    counts["n_ins_hover"] = i1 - i0
    counts["n_ins_hover_runs"] = n_runs
    counts["n_ins_in_hover_mask_outside_window"] = int(hover.sum()) - (i1 - i0)
    log.append(f"hover: longest of {n_runs} hover runs, {h1 - h0:.1f} s "
               f"({int(hover.sum()) - (i1 - i0)} hover-mask INS samples outside it dropped)")
    if h1 - h0 < min_hover_s:
        reasons.append(f"hover window {h1 - h0:.1f} s shorter than {min_hover_s:.0f} s")
    bad_hover = int(ins_missing[i0:i1].sum())
    counts["n_ins_filled_in_hover"] = bad_hover
    if bad_hover > max_missing_fraction * (i1 - i0):
        reasons.append(f"{bad_hover} of {i1 - i0} INS samples in the hover window missing or ekf_valid=0")

    # (3) sonic segment and gap filling
    seg = np.flatnonzero((ts >= h0 - max_lag_s - 1.0) & (ts <= h1 + max_lag_s + 1.0))
    if seg.size < 16:
        raise InputError("sonic_l1:time", "the sonic record does not overlap the hover window")
    ts_seg = ts[seg]
    dt_nom = float(np.median(np.diff(ts_seg)))
    fs_hz = float(sonic_l1.attrs.get("sampling_rate_hz", 1.0 / dt_nom))
    n_expected = int(round((ts_seg[-1] - ts_seg[0]) / dt_nom)) + 1
    counts["n_sonic_missing_rows"] = max(0, n_expected - ts_seg.size)
    raw = {k: np.asarray(sonic_l1[k].values, dtype=float)[seg] for k in _SONIC_VARS}
    nan_any = np.zeros(seg.size, dtype=bool)
    usable_fill = True
    filled = {}
    for k in _SONIC_VARS:
        nan_any |= ~np.isfinite(raw[k])
        filled[k], _, ok = filtering.gap_fill_linear(raw[k], max_missing_fraction)
        usable_fill &= ok
    n_missing_total = int(nan_any.sum()) + counts["n_sonic_missing_rows"]
    frac = n_missing_total / max(n_expected, 1)
    sonic_filled_ok = usable_fill and frac <= max_missing_fraction
    if not sonic_filled_ok:
        reasons.append(f"{100 * frac:.2f} % of the sonic samples missing (limit {100 * max_missing_fraction:.0f} %)")
        # fill anyway for the lag search only; the returned data keep their NaNs
        search = {k: _fill_nan_by_time(ts_seg, raw[k])[0] for k in _SONIC_VARS}
        counts["n_sonic_filled"] = 0
        log.append(f"sonic_gaps: {n_missing_total} missing samples ({100 * frac:.2f} %): not filled, unusable")
    else:
        search = filled
        counts["n_sonic_filled"] = int(nan_any.sum())
        log.append(f"sonic_gaps: filled {int(nan_any.sum())} NaN samples linearly; "
                   f"{counts['n_sonic_missing_rows']} missing rows bridged ({100 * frac:.2f} % missing)")
    if not all(np.isfinite(search[k]).all() for k in _SONIC_VARS[:3]):
        raise InputError("sonic_l1", "no valid sonic wind sample in the hover window")

    # (4) lag search over the hover window
    in_hover = (ts_seg >= h0) & (ts_seg <= h1)
    sonic_xyz = np.stack([search[k] for k in _SONIC_VARS[:3]], axis=-1)
    att = np.stack([ins["roll_deg"], ins["pitch_deg"], ins["yaw_deg"]], axis=-1)
    vel = np.stack([ins["vel_n_ms"], ins["vel_e_ms"], ins["vel_d_ms"]], axis=-1)
    lag_grid, tke, n_tke = tke_vs_lag(ts_seg[in_hover], sonic_xyz[in_hover], ti, att, vel, mount,
                                      lever_arm_m, max_lag_s, lag_step_s, misalignment_deg)
    lag, at_edge = find_sonic_ins_lag(lag_grid, tke)
    lag_tke_min = lag
    counts["n_lag_search_samples"] = n_tke
    log.append(f"sync: TKE minimum {tke.min():.4f} m2 s-2 at lag {lag:+.5f} s ({lag_grid.size} lags, "
               f"{n_tke} samples)")
    if fixed_lag_s is not None:
        lag, at_edge = float(fixed_lag_s), False
        log.append(f"sync: fixed lag {lag:+.5f} s applied instead")
    if at_edge:
        reasons.append(f"sonic-INS lag {lag:+.3f} s at the edge of the +/-{max_lag_s} s search range")

    # (5) motion correction on the shifted sonic times inside the hover window
    t_al = ts_seg + lag
    sel = (t_al >= h0) & (t_al <= h1) & (t_al >= ti[0]) & (t_al <= ti[-1])
    counts["n_sonic_outside_hover"] = int(ts.size - sel.sum())
    t_out = t_al[sel]
    ins_keys: dict[str, np.ndarray] = {k: ins[k] for k in _INS_VARS}
    if lever_arm_m is not None:
        ins_keys["rates"] = motion.body_rates_from_euler(ins["roll_deg"], ins["pitch_deg"], ins["yaw_deg"], ti)
    ins_s = interpolate_ins(ti, ins_keys, t_out)
    data = filled if sonic_filled_ok else raw
    u_e, v_n, w_u = motion.motion_correct(
        data["u_sensor_ms"][sel], data["v_sensor_ms"][sel], data["w_sensor_ms"][sel],
        ins_s["roll_deg"], ins_s["pitch_deg"], ins_s["yaw_deg"],
        ins_s["vel_n_ms"], ins_s["vel_e_ms"], ins_s["vel_d_ms"], mount,
        lever_arm_m=lever_arm_m, body_rates_rad_s=ins_s.get("rates"), misalignment_deg=misalignment_deg)
    log.append(f"motion: corrected {int(sel.sum())} samples (mount {mount}, lever arm "
               f"{'none' if lever_arm_m is None else tuple(float(x) for x in lever_arm_m)})")

    time_out = (ts_ns[seg][sel] + int(round(lag * _NS))).astype("datetime64[ns]")
    dims = ("time",)
    ds = xr.Dataset(
        {
            "u_east_ms": _var(u_e, dims, "m s-1", "eastward_wind"),
            "v_north_ms": _var(v_n, dims, "m s-1", "northward_wind"),
            "w_up_ms": _var(w_u, dims, "m s-1", "upward_air_velocity"),
            "t_sonic_k": _var(data["t_sonic_k"][sel], dims, "K", "virtual_temperature",
                              comment="sonic temperature, approximately the virtual temperature"),
            "roll_deg": _var(ins_s["roll_deg"], dims, "degree", "platform_roll"),
            "pitch_deg": _var(ins_s["pitch_deg"], dims, "degree", "platform_pitch"),
            "yaw_deg": _var(ins_s["yaw_deg"], dims, "degree", "platform_yaw",
                            comment="clockwise from true north, wrapped to [0, 360)"),
            "lat_deg": _var(ins_s["lat_deg"], dims, "degrees_north", "latitude"),
            "lon_deg": _var(ins_s["lon_deg"], dims, "degrees_east", "longitude"),
            "alt_m": _var(ins_s["alt_m"], dims, "m", "altitude", comment="above mean sea level", positive="up"),
            "lag_s": _var(lag_grid, ("lag",), "s", long="sonic-INS lag added to the sonic clock"),
            "tke_m2s2": _var(tke, ("lag",), "m2 s-2", "specific_turbulent_kinetic_energy_of_air",
                             long="mean TKE of the motion-corrected wind versus sonic-INS lag"),
        },
        coords={"time": ("time", time_out), "lag": ("lag", lag_grid)},
    )
    if "qc_sonic" in sonic_l1.variables:
        qc = np.asarray(sonic_l1["qc_sonic"].values).astype(np.int32)[seg][sel]
        if counts["n_sonic_filled"]:
            qc = np.where(nan_any[sel], qc | 8, qc)
        ds["qc_sonic"] = xr.Variable(dims, qc, attrs={
            "long_name": "payload sonic quality flags", "standard_name": "status_flag",
            "flag_masks": np.array([1, 2, 4, 8], dtype=np.int32),
            "flag_meanings": "out_of_range spike missing_or_corrupt gap_filled"})
    ds["time"].attrs.update({"standard_name": "time", "long_name": "time (UTC) on the INS clock"})
    ds["lag"].attrs.update({"units": "s", "long_name": "sonic-INS lag added to the sonic clock"})
    usable = not reasons
    ds.attrs.update({
        "lag_sonic_ins_s": float(lag),
        "lag_tke_min_s": float(lag_tke_min),
        "usable": int(usable),
        "unusable_reason": "; ".join(reasons),
        "mount": mount,
        "lever_arm_m": "none" if lever_arm_m is None else ", ".join(f"{float(x):g}" for x in lever_arm_m),
        "sampling_rate_hz": fs_hz,
        "lag_search_max_s": float(max_lag_s),
        "lag_search_step_s": float(lag_step_s),
        "n_samples": int(sel.sum()),
        **{k: int(v) for k, v in counts.items()},
        "processing_log": "\n".join(log),
    })
    if site_altitude_m is not None:
        ds.attrs["height_m"] = float(np.median(ins_s["alt_m"]) - float(site_altitude_m))
    if misalignment_deg is not None:
        ds.attrs["misalignment_deg"] = ", ".join(f"{float(x):g}" for x in misalignment_deg)
    return ds


# ------------------------------------------------------------------ drone-mast alignment


def design_antialias_fir(
    fs_in_hz: float = 32.0,
    decimate: int = 4,
    passband_edge_hz: float | None = None,
    stopband_edge_hz: float | None = None,
    attenuation_db: float = 60.0,
) -> np.ndarray:
    """Linear-phase FIR low-pass used before decimation (Kaiser-window design).

    Parameters
    ----------
    fs_in_hz : float
        Input rate [Hz]; default 32 Hz.
    decimate : int
        Decimation factor; default 4 (seed 000, Sect. 4.4: 32 Hz -> 8 Hz).
    passband_edge_hz : float, optional
        End of the passband [Hz]; default 0.75 x the output Nyquist (3 Hz at 8 Hz).
    stopband_edge_hz : float, optional
        Start of the stopband [Hz]; default the output Nyquist (4 Hz at 8 Hz).
    attenuation_db : float
        Stopband attenuation and passband ripple specification [dB]; default 60 dB.

    Returns
    -------
    numpy.ndarray
        Odd number of symmetric taps (123 for the defaults), unit DC gain.

    Notes
    -----
    Design (defaults): Kaiser window, beta = 5.65 from :func:`scipy.signal.kaiserord` for
    60 dB and the 1 Hz transition 3-4 Hz, cutoff at the transition centre (3.5 Hz, gain
    0.5 = -6 dB), :func:`scipy.signal.firwin`; the length from Kaiser's formula (119) is
    increased by 2 taps until the stopband maximum measured with
    :func:`scipy.signal.freqz` meets the specification: 123 taps (3.8 s). Measured:
    passband (0-3 Hz) deviation <= 0.094 %, stopband (4-16 Hz) attenuation >= 60.4 dB. Applied as a
    centred convolution (group delay removed), i.e. zero phase in a single pass. The band
    3-4 Hz of the 8 Hz output is the transition band: spectra there are attenuated
    (and 4-5 Hz partly aliases into it). Seed 000 mentions an "FIR filter of order 4";
    a 4th-order FIR cannot give a useful anti-alias stopband, so this design replaces it.

    References
    ----------
    Seed 000, Sect. 4.4; Kaiser (1974); scipy.signal.kaiserord / firwin.
    """
    if decimate < 1 or int(decimate) != decimate:
        raise InputError("decimate", f"expected a positive integer, got {decimate!r}")
    nyq_out = fs_in_hz / decimate / 2.0
    f_stop = nyq_out if stopband_edge_hz is None else float(stopband_edge_hz)
    f_pass = 0.75 * nyq_out if passband_edge_hz is None else float(passband_edge_hz)
    if not (0 < f_pass < f_stop <= fs_in_hz / 2):
        raise InputError("design_antialias_fir", f"need 0 < passband edge {f_pass} < stopband edge {f_stop} <= "
                         f"{fs_in_hz / 2} Hz")
    numtaps, beta = scipy.signal.kaiserord(attenuation_db, (f_stop - f_pass) / (fs_in_hz / 2.0))
    numtaps |= 1  # odd length: integer group delay, type I linear phase
    f_check = np.linspace(f_stop, fs_in_hz / 2.0, 2049)
    limit = 10.0 ** (-attenuation_db / 20.0)
    for _ in range(50):  # Kaiser's formula is approximate: lengthen until the spec is met
        taps = scipy.signal.firwin(numtaps, 0.5 * (f_pass + f_stop), window=("kaiser", beta), fs=fs_in_hz)
        if fir_response(taps, fs_in_hz, f_check).max() <= limit:
            break
        numtaps += 2
    return taps


def fir_response(taps: np.ndarray, fs_hz: float, freq_hz: np.ndarray) -> np.ndarray:
    """Amplitude response |H(f)| of an FIR filter at the given frequencies.

    Parameters
    ----------
    taps : numpy.ndarray
        Filter coefficients.
    fs_hz : float
        Sampling rate [Hz].
    freq_hz : numpy.ndarray
        Frequencies [Hz].

    Returns
    -------
    numpy.ndarray
        |H(f)| [-].
    """
    _, h = scipy.signal.freqz(taps, worN=np.asarray(freq_hz, dtype=float), fs=fs_hz)
    return np.abs(h)


def fir_decimate(x: np.ndarray, taps: np.ndarray, factor: int, phase: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Zero-phase FIR low-pass and decimation, without padding (edges trimmed).

    Parameters
    ----------
    x : numpy.ndarray
        (n, ...) regularly sampled, finite series (filtered along axis 0).
    taps : numpy.ndarray
        Odd-length symmetric FIR taps (:func:`design_antialias_fir`).
    factor : int
        Decimation factor.
    phase : int
        Output samples are the input indices ``k`` with ``k % factor == phase``.

    Returns
    -------
    y : numpy.ndarray
        Filtered, decimated series.
    index : numpy.ndarray
        Input indices of the output samples (all at least ``(len(taps) - 1) / 2`` from either
        end, so no output depends on padding).

    Notes
    -----
    .. math:: y_m = \\sum_{k=-K}^{K} h_k\\, x_{i_m - k}, \\qquad K = (N_{taps} - 1)/2 .
    """
    taps = np.asarray(taps, dtype=float)
    if taps.size % 2 != 1:
        raise InputError("taps", "expected an odd number of FIR taps")
    half = taps.size // 2
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    first = half + ((phase - half) % factor)
    index = np.arange(first, n - half, factor)
    if index.size == 0:
        raise InputError("x", f"series of {n} samples shorter than the FIR filter ({taps.size} taps)")
    kernel = taps.reshape((-1,) + (1,) * (x.ndim - 1))
    full = scipy.signal.fftconvolve(x, kernel, mode="valid", axes=0)  # full[i] centred on x[i + half]
    return full[index - half], index


def drone_mast_lag(
    drone_u_ms: np.ndarray,
    drone_v_ms: np.ndarray,
    mast_u_ms: np.ndarray,
    mast_v_ms: np.ndarray,
    fs_hz: float,
    max_lag_s: float = 6.0,
) -> tuple[float, np.ndarray, np.ndarray, bool]:
    """Advection lag between drone and mast from the horizontal wind fluctuations.

    Parameters
    ----------
    drone_u_ms, drone_v_ms, mast_u_ms, mast_v_ms : numpy.ndarray
        East and north wind of both sensors on the same regular time base [m s-1],
        finite, equal length n.
    fs_hz : float
        Sampling rate of the common base [Hz].
    max_lag_s : float
        Largest lag searched [s]; default 6 s (seed 000, Sect. 4.4).

    Returns
    -------
    lag_drone_mast_s : float
        Time to add to the drone's stamps to align them with the mast [s], positive when
        the drone sees a structure first; parabolic refinement of the correlation peak,
        so it is not restricted to the grid.
    lag_grid_s : numpy.ndarray
        Lags of the search grid [s].
    xcorr : numpy.ndarray
        Normalised cross-correlation of the horizontal fluctuation vector at each lag [-].
    at_edge : bool
        True if the maximum is at the edge of the search range.

    Notes
    -----
    Fluctuations are linearly detrended per component. Both horizontal components
    enter (a vector correlation, independent of the wind direction and of the sign of
    the mean), with the drone's central part (ends of ``max_lag_s`` removed) held fixed
    so every lag uses the same drone samples:

    .. math::

        r(\\tau_j) = \\frac{\\sum_k u'_d(t_k) u'_m(t_k+\\tau_j) + v'_d(t_k) v'_m(t_k+\\tau_j)}
        {\\sqrt{\\sum_k (u'^2_d + v'^2_d)(t_k)\\; \\sum_k (u'^2_m + v'^2_m)(t_k + \\tau_j)}} .

    The peak is refined by a parabola through its two neighbours.

    References
    ----------
    Seed 000, Sect. 4.4 ("maximises the cross-correlation of the horizontal velocity
    fluctuations", up to 6 s).
    """
    arrays = [np.asarray(a, dtype=float) for a in (drone_u_ms, drone_v_ms, mast_u_ms, mast_v_ms)]
    n = arrays[0].size
    if any(a.shape != (n,) for a in arrays) or not all(np.isfinite(a).all() for a in arrays):
        raise InputError("drone_mast_lag", "expected four finite 1-D series of equal length on a common base")
    n_half = int(round(max_lag_s * fs_hz))
    if n <= 4 * n_half + 8:
        raise InputError("drone_mast_lag",
                         f"common record of {n / fs_hz:.1f} s too short for a +/-{max_lag_s} s search")
    du, dv, mu, mv = (scipy.signal.detrend(a, type="linear") for a in arrays)
    core = slice(n_half, n - n_half)
    d = np.stack([du[core], dv[core]], axis=-1)
    m = np.stack([mu, mv], axis=-1)
    num = scipy.signal.fftconvolve(m, d[::-1], mode="valid", axes=0).sum(axis=1)  # index k <-> lag k - n_half
    m2 = np.concatenate([[0.0], np.cumsum(np.sum(m * m, axis=1))])
    k = np.arange(2 * n_half + 1)
    den = np.sqrt(np.sum(d * d) * (m2[k + d.shape[0]] - m2[k]))
    xcorr = num / np.where(den > 0, den, np.nan)
    lag_grid = (k - n_half) / fs_hz
    if not np.isfinite(xcorr).any():
        raise ProcessingError("drone-mast cross-correlation undefined (constant wind series)")
    kk = int(np.nanargmax(xcorr))
    at_edge = kk == 0 or kk == xcorr.size - 1
    delta = 0.0
    if not at_edge:
        y0, y1, y2 = xcorr[kk - 1], xcorr[kk], xcorr[kk + 1]
        curv = y0 - 2.0 * y1 + y2
        if curv < 0:
            delta = float(np.clip(0.5 * (y0 - y2) / curv, -0.5, 0.5))
    return float((kk - n_half + delta) / fs_hz), lag_grid, xcorr, bool(at_edge)


def _sensor_arrays(ds: xr.Dataset, where: str) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    _require(ds, _ENU_VARS, where)
    t = _time_ns(ds, where)
    return t, {k: np.asarray(ds[k].values, dtype=float) for k in _ENU_VARS}


def _interp_finite(t_target: np.ndarray, t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, int]:
    """Linear interpolation using finite samples only; returns values and the number of
    target samples whose bracketing source interval contained a missing sample."""
    ok = np.isfinite(x)
    if ok.sum() < 2:
        raise InputError("align_drone_mast", "fewer than 2 finite samples in a series")
    y = np.interp(t_target, t[ok], x[ok])
    if ok.all():
        return y, 0
    # targets that fall next to a missing source sample: count them (they were bridged)
    idx = np.clip(np.searchsorted(t, t_target), 1, t.size - 1)
    bridged = ~ok[idx] | ~ok[idx - 1]
    return y, int(bridged.sum())


def align_drone_mast(
    drone_l2: xr.Dataset,
    mast_l2: xr.Dataset,
    max_lag_s: float = 6.0,
    decimate: int = 4,
    rotation: str = "double",
    *,
    fs_common_hz: float = 32.0,
    drone_height_m: float | None = None,
    planar_fit: dict[str, _rotation.PlanarFit] | None = None,
    min_overlap_s: float = 60.0,
) -> xr.Dataset:
    """Build the L3 dataset: drone and mast aligned, decimated and in streamline coordinates.

    Parameters
    ----------
    drone_l2 : xarray.Dataset
        Payload L2 (:func:`payload_l2`): ``u_east_ms``, ``v_north_ms``, ``w_up_ms`` [m s-1],
        ``t_sonic_k`` [K] on ``time`` (UTC).
    mast_l2 : xarray.Dataset
        Mast sonic in east/north/up with the same variable names, 10 or 20 Hz, NaN
        where flagged; attrs ``height_m``.
    max_lag_s : float
        Largest drone-mast lag searched [s]; default 6 s (seed 000, Sect. 4.4).
    decimate : int
        Decimation factor from the common base; default 4 (32 Hz -> 8 Hz).
    rotation : {"none", "single", "double", "triple", "planar_fit"}
        Rotation into streamline coordinates, per sensor over the common window; default
        "double" (seed 000, Sect. 4.4).
    fs_common_hz : float
        Common base rate before decimation [Hz]; default 32 Hz.
    drone_height_m : float, optional
        Drone height above ground [m]; default ``drone_l2.attrs["height_m"]`` (or
        ``target_height_m``), else NaN.
    planar_fit : dict, optional
        ``{"drone": PlanarFit, "mast": PlanarFit}`` for ``rotation="planar_fit"``.
    min_overlap_s : float
        Shortest usable overlap beyond the lag search margins [s].

    Returns
    -------
    xarray.Dataset
        Dims ``sensor`` = ["drone", "mast"] and ``time`` (8 Hz, common window, stamps on
        the mast clock at multiples of 1/8 s): ``u_ms``, ``v_ms``, ``w_ms`` [m s-1]
        (streamline; means kept, not detrended), ``theta_v_k`` [K], ``wind_from_deg(sensor)``
        (mean direction before rotation), ``height_m(sensor)``,
        ``rotation_yaw_deg/pitch_deg/roll_deg(sensor)``, and on ``lag``: ``lag_s``,
        ``xcorr`` (drone-mast correlation curve). attrs: ``lag_drone_mast_s``,
        ``lag_xcorr_max``, ``rotation_method``, ``sampling_rate_hz``, FIR design, counts
        ``n_*`` and ``processing_log``.

    Notes
    -----
    Design:

    1. Both sensors are linearly interpolated onto a 32 Hz grid over their overlap
       (mast gaps bridged linearly and counted) and the lag is found with
       :func:`drone_mast_lag` (seed 000, Sect. 4.4).
    2. A new 32 Hz grid, phase-locked to multiples of 1/8 s of UTC, spans the common
       window of the mast and the lag-shifted drone; the drone is interpolated at
       ``t - lag`` and the mast at ``t`` (linear, as in seed 000). Linear interpolation of a
       record sampled at :math:`f_s` acts on average as a low-pass with a power gain of
       :math:`(2 + \\cos 2\\pi f/f_s)/3` (mean over the interpolation phase): at 3 Hz
       0.94 for the 32 Hz drone, 0.86 for a 20 Hz mast and 0.56 for a 10 Hz mast (whose
       own Nyquist is 5 Hz); at 1 Hz 0.99, 0.98 and 0.94.
    3. Low-pass with :func:`design_antialias_fir` (123 taps, Kaiser, 3-4 Hz transition,
       60 dB) applied centred (zero phase), then every 4th sample (8 Hz); the first and
       last 61 samples of the 32 Hz grid (1.9 s) are dropped instead of padded.
    4. Wind-from direction from the mean (east, north) vector, then
       :func:`dronewind.core.rotation.rotate` per sensor; theta_v is the sonic temperature
       (the dry-adiabatic height correction g z / c_p is not applied).

    References
    ----------
    Seed 000, Sect. 4.4; McMillen (1988); Wilczak et al. (2001).
    """
    if rotation not in _rotation.ROTATION_METHODS:
        raise InputError("rotation", f"unknown rotation method {rotation!r}")
    td_ns, drone = _sensor_arrays(drone_l2, "drone_l2")
    tm_ns, mast = _sensor_arrays(mast_l2, "mast_l2")
    log: list[str] = []
    counts: dict[str, int] = {}
    t_ref = int(min(td_ns[0], tm_ns[0]))
    td = (td_ns - t_ref) / _NS
    tm = (tm_ns - t_ref) / _NS
    dt = 1.0 / fs_common_hz
    for name, arrs in (("drone", drone), ("mast", mast)):
        counts[f"n_{name}_nan"] = int(sum((~np.isfinite(arrs[k])).sum() for k in _ENU_VARS[:3]))

    # 1. lag on the overlap
    o0, o1 = max(td[0], tm[0]), min(td[-1], tm[-1])
    if o1 - o0 < 2 * max_lag_s + min_overlap_s:
        raise InputError("align_drone_mast", f"drone and mast overlap {max(o1 - o0, 0):.1f} s, need at least "
                         f"{2 * max_lag_s + min_overlap_s:.0f} s")
    g = o0 + dt * np.arange(int(np.floor((o1 - o0) / dt)) + 1)
    uv = [_interp_finite(g, t, src[k])[0] for t, src in ((td, drone), (tm, mast)) for k in ("u_east_ms", "v_north_ms")]
    lag, lag_grid, xcorr, at_edge = drone_mast_lag(uv[0], uv[1], uv[2], uv[3], fs_common_hz, max_lag_s)
    log.append(f"lag: lag_drone_mast_s = {lag:+.4f} s (max correlation {np.nanmax(xcorr):.3f}"
               f"{', AT SEARCH EDGE' if at_edge else ''})")

    # 2. common window on a 32 Hz grid locked to multiples of the output step
    step_ns = int(round(_NS / fs_common_hz))
    out_step_ns = step_ns * decimate
    c0 = max(td[0] + lag, tm[0])
    c1 = min(td[-1] + lag, tm[-1])
    c0_ns = int(np.ceil((t_ref + c0 * _NS) / out_step_ns)) * out_step_ns
    n_grid = int(np.floor(((t_ref + c1 * _NS) - c0_ns) / step_ns)) + 1
    grid_ns = c0_ns + step_ns * np.arange(n_grid, dtype=np.int64)
    grid = (grid_ns - t_ref) / _NS
    cols = []
    for name, t, src, shift in (("drone", td, drone, lag), ("mast", tm, mast, 0.0)):
        n_bridged = 0
        for k in _ENU_VARS:
            y, nb = _interp_finite(grid - shift, t, src[k])
            cols.append(y)
            n_bridged = max(n_bridged, nb)
        counts[f"n_{name}_bridged_32hz"] = n_bridged
    x32 = np.stack(cols, axis=-1)  # (n, 8): drone u v w T, mast u v w T
    log.append(f"common: {n_grid} samples at {fs_common_hz:g} Hz over {(n_grid - 1) * dt:.1f} s "
               f"(mast bridged {counts['n_mast_bridged_32hz']}, drone bridged {counts['n_drone_bridged_32hz']})")

    # 3. anti-alias FIR + decimation
    taps = design_antialias_fir(fs_common_hz, decimate)
    x8, idx = fir_decimate(x32, taps, decimate, phase=0)
    counts["n_fir_edge_dropped_32hz"] = int(n_grid - (idx[-1] - idx[0] + 1))
    counts["n_fir_taps"] = int(taps.size)
    time8 = grid_ns[idx].astype("datetime64[ns]")
    fs_out = fs_common_hz / decimate
    log.append(f"decimate: FIR {taps.size} taps (Kaiser, 3-4 Hz transition, 60 dB), x{decimate} -> {fs_out:g} Hz, "
               f"{time8.size} samples")

    # 4. direction and rotation per sensor
    u_r, v_r, w_r, wdir, ang = [], [], [], [], {"yaw_deg": [], "pitch_deg": [], "roll_deg": []}
    methods: list[str] = []
    for s, name in enumerate(("drone", "mast")):
        ue, vn, wu = x8[:, 4 * s], x8[:, 4 * s + 1], x8[:, 4 * s + 2]
        wdir.append(float(np.rad2deg(np.arctan2(-ue.mean(), -vn.mean())) % 360.0))
        pf = None if planar_fit is None else planar_fit.get(name)
        # planar fit only where one is given (a fixed mast sonic); a sensor without one
        # (the drone, re-levelled every flight) gets the double rotation
        method = "double" if rotation == "planar_fit" and pf is None else rotation
        a, b, c, angles = _rotation.rotate(ue, vn, wu, method, planar_fit=pf)
        methods.append(method)
        u_r.append(a)
        v_r.append(b)
        w_r.append(c)
        for key in ang:
            ang[key].append(angles[key])
    log.append(f"rotation: drone {methods[0]}, mast {methods[1]}; wind from drone {wdir[0]:.1f} deg, "
               f"mast {wdir[1]:.1f} deg")

    if drone_height_m is None:
        drone_height_m = drone_l2.attrs.get("height_m", drone_l2.attrs.get("target_height_m", np.nan))
    mast_height = float(mast_l2.attrs.get("height_m", np.nan))
    dims = ("sensor", "time")
    ds = xr.Dataset(
        {
            "u_ms": _var(np.stack(u_r), dims, "m s-1", long="streamwise wind component"),
            "v_ms": _var(np.stack(v_r), dims, "m s-1", long="cross-stream wind component (positive to the left)"),
            "w_ms": _var(np.stack(w_r), dims, "m s-1", long="vertical wind component in streamline coordinates"),
            "theta_v_k": _var(np.stack([x8[:, 3], x8[:, 7]]), dims, "K", "virtual_temperature",
                              comment="sonic temperature used as (virtual potential) temperature; no g z/c_p term"),
            "wind_from_deg": _var(np.array(wdir), ("sensor",), "degree", "wind_from_direction",
                                  comment="mean wind direction before rotation"),
            "height_m": _var(np.array([float(drone_height_m), mast_height]), ("sensor",), "m",
                             "height", comment="above ground", positive="up"),
            "rotation_yaw_deg": _var(np.array(ang["yaw_deg"]), ("sensor",), "degree",
                                     long="streamline rotation: yaw (counter-clockwise from east)"),
            "rotation_pitch_deg": _var(np.array(ang["pitch_deg"]), ("sensor",), "degree",
                                       long="streamline rotation: pitch"),
            "rotation_roll_deg": _var(np.array(ang["roll_deg"]), ("sensor",), "degree",
                                      long="streamline rotation: roll"),
            "lag_s": _var(lag_grid, ("lag",), "s", long="drone-mast lag added to the drone time stamps"),
            "xcorr": _var(xcorr, ("lag",), "1", long="cross-correlation of horizontal wind fluctuations"),
        },
        coords={"sensor": ("sensor", np.array(["drone", "mast"])), "time": ("time", time8),
                "lag": ("lag", lag_grid)},
    )
    ds["lag"].attrs.update({"units": "s", "long_name": "drone-mast lag added to the drone time stamps"})
    ds["time"].attrs.update({"standard_name": "time", "long_name": "time (UTC) on the mast clock"})
    ds.attrs.update({
        "lag_drone_mast_s": float(lag),
        "lag_xcorr_max": float(np.nanmax(xcorr)),
        "lag_at_search_edge": int(at_edge),
        "rotation_method": rotation,
        "rotation_method_drone": methods[0],
        "rotation_method_mast": methods[1],
        "sampling_rate_hz": float(fs_out),
        "fir_design": (f"Kaiser-window FIR, {taps.size} taps, cutoff {fs_out * 0.4375:g} Hz, transition "
                       f"{0.375 * fs_out:g}-{0.5 * fs_out:g} Hz, 60 dB, centred (zero phase)"),
        "n_samples": int(time8.size),
        **{k: int(v) for k, v in counts.items()},
        "processing_log": "\n".join(log),
    })
    return ds
