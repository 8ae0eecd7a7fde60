"""Plausibility checks of a payload flight: units and conventions that the readers cannot see.

A file in the right format may still hold the wrong numbers: an altitude in feet, INS
velocities in km/h, a sonic logging in cm/s. Each check here compares a quantity with an
independent one and returns a reason when they disagree; :func:`dronewind.payload.l2.payload_l2`
marks the flight unusable with that reason (``usable = 0``, ``unusable_reason``), never
silently. Every check also returns its numbers for the processing log.

* :func:`height_check` -- hover height above ground (median INS altitude minus the site
  altitude) against the flight's target height;
* :func:`velocity_position_check` -- INS velocity against the derivative of the GNSS
  position, horizontally and vertically (a gain of 3.6 is km/h, 0.3 an altitude in feet,
  a negative correlation a sign convention);
* :func:`sonic_range_check` -- fraction of sonic samples beyond the instrument's range
  (RM Young 81000, Ghirardelli et al. (2025), Table 2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dronewind.core.geo import local_tangent_plane_m

__all__ = ["CheckResult", "HEIGHT_TOL_M", "HEIGHT_TOL_FRACTION", "VELOCITY_GAIN_RANGE", "height_check",
           "velocity_position_check", "sonic_range_check"]

#: Largest accepted difference between hover height and target height: the larger of
#: ``HEIGHT_TOL_M`` [m] and ``HEIGHT_TOL_FRACTION`` times the target height.
HEIGHT_TOL_M: float = 10.0
HEIGHT_TOL_FRACTION: float = 0.5
#: Accepted ratio of INS velocity to GNSS position derivative [1]: (low, high).
VELOCITY_GAIN_RANGE: tuple[float, float] = (0.67, 1.5)
#: Smallest RMS platform speed [m s-1] over the comparison interval for the velocity check
#: to decide (a still platform gives only GNSS noise).
MIN_RMS_SPEED_MS: float = 0.15


@dataclass(frozen=True)
class CheckResult:
    """Outcome of one plausibility check.

    Attributes
    ----------
    reason : str or None
        Why the flight is not plausible (``None``: it passed or could not be decided).
    log : str
        One processing-log line with the numbers.
    """

    reason: str | None
    log: str


def height_check(height_m: float, target_height_m: float | None, *, tol_m: float = HEIGHT_TOL_M,
                 tol_fraction: float = HEIGHT_TOL_FRACTION) -> CheckResult:
    """Hover height above ground against the target height.

    Parameters
    ----------
    height_m : float
        Median INS altitude in the hover minus the site altitude [m].
    target_height_m : float or None
        The flight's target height above ground (manifest ``target_height_m``) [m].
    tol_m, tol_fraction : float
        Accepted difference: ``max(tol_m, tol_fraction * target_height_m)`` [m].

    Returns
    -------
    CheckResult
        A reason when the difference exceeds the tolerance (e.g. an altitude in feet, a
        wrong site altitude or an altitude above the ellipsoid instead of mean sea level).
    """
    if target_height_m is None or not np.isfinite(target_height_m) or not np.isfinite(height_m):
        return CheckResult(None, f"plausibility: hover height {height_m:.1f} m above ground (no target height to "
                                 "compare with)")
    tol = max(tol_m, tol_fraction * float(target_height_m))
    diff = float(height_m) - float(target_height_m)
    log = (f"plausibility: hover height {height_m:.1f} m above ground, target {target_height_m:g} m "
           f"(difference {diff:+.1f} m, tolerance {tol:.1f} m)")
    if abs(diff) > tol:
        return CheckResult(f"hover height {height_m:.1f} m above ground (median alt_m minus site altitude) differs "
                           f"from the target height {target_height_m:g} m by {diff:+.1f} m (> {tol:.1f} m): "
                           "altitude in another unit (feet?), above the ellipsoid, or a wrong site altitude", log)
    return CheckResult(None, log)


def _interval_pairs(t_s: np.ndarray, interval_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j) with ``t[j] - t[i]`` within 10 % of ``interval_s``, one pair per interval."""
    i = np.arange(t_s.size)
    j = np.searchsorted(t_s, t_s + interval_s)
    ok = j < t_s.size
    i, j = i[ok], j[ok]
    span = t_s[j] - t_s[i]
    ok = np.abs(span - interval_s) <= 0.1 * interval_s
    i, j = i[ok], j[ok]
    if i.size == 0:
        return i, j
    # non-overlapping intervals: keep every pair starting at or after the end of the previous one;
    # the next kept pair after k is the first one starting at or after t[j[k]] (the starts are
    # sorted), so only the kept chain is walked, not every sample
    nxt = np.searchsorted(t_s[i], t_s[j], side="left")
    keep = [0]
    while (k := int(nxt[keep[-1]])) < i.size:
        keep.append(k)
    return i[keep], j[keep]


def _cumulative_trapezoid(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Integral of ``v`` over ``t`` from the first sample, trapezoid rule (same length as ``t``)."""
    return np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])


def _gain(v_int: np.ndarray, dp: np.ndarray) -> tuple[float, float, float]:
    """Ratio of RMS velocity displacement to RMS position displacement, their correlation and RMS position speed."""
    rms_p = float(np.sqrt(np.mean(dp ** 2)))
    rms_v = float(np.sqrt(np.mean(v_int ** 2)))
    denom = float(np.sqrt(np.sum(v_int ** 2) * np.sum(dp ** 2)))
    corr = float(np.sum(v_int * dp) / denom) if denom > 0 else float("nan")
    return (rms_v / rms_p if rms_p > 0 else float("nan")), corr, rms_p


def velocity_position_check(t_s: np.ndarray, lat_deg: np.ndarray, lon_deg: np.ndarray, alt_m: np.ndarray,
                            vel_n_ms: np.ndarray, vel_e_ms: np.ndarray, vel_d_ms: np.ndarray, *,
                            interval_s: float = 1.0, gain_range: tuple[float, float] = VELOCITY_GAIN_RANGE,
                            min_rms_speed_ms: float = MIN_RMS_SPEED_MS) -> CheckResult:
    """INS velocity against the derivative of the GNSS position (horizontal and vertical).

    Parameters
    ----------
    t_s : numpy.ndarray
        INS times [s], increasing.
    lat_deg, lon_deg, alt_m : numpy.ndarray
        GNSS/INS position [degree, degree, m]; NaN where missing.
    vel_n_ms, vel_e_ms, vel_d_ms : numpy.ndarray
        INS velocity north, east, down [m s-1]; NaN where missing.
    interval_s : float
        Length of the comparison intervals [s].
    gain_range : (float, float)
        Accepted ratio of velocity to position derivative [1].
    min_rms_speed_ms : float
        The check decides only if the platform moved at least this RMS speed [m s-1].

    Returns
    -------
    CheckResult
        A reason when, for a platform that moved, the ratio is outside ``gain_range``
        (velocities or altitude in another unit) or the two are anti-correlated (a sign
        convention, e.g. ``vel_d`` positive up).

    Notes
    -----
    Over non-overlapping intervals of ``interval_s`` the displacement integrated from the
    velocity (trapezoid rule), :math:`\\int v\\,dt`, is compared with the GNSS displacement
    :math:`\\Delta p` (east/north on the WGS84 tangent plane, up from ``alt_m``):
    gain :math:`= \\mathrm{rms}(\\int v\\,dt) / \\mathrm{rms}(\\Delta p)` and correlation
    :math:`r = \\sum (\\int v\\,dt)\\,\\Delta p / \\sqrt{\\sum(\\int v\\,dt)^2 \\sum \\Delta p^2}`.
    An interval with a missing sample is not used.
    """
    t = np.asarray(t_s, dtype=float)
    arrays = [np.asarray(a, dtype=float) for a in (lat_deg, lon_deg, alt_m, vel_n_ms, vel_e_ms, vel_d_ms)]
    ok = np.all([np.isfinite(a) for a in arrays], axis=0)
    if ok.sum() < 10:
        return CheckResult(None, "plausibility: velocity against GNSS position not checked (fewer than 10 samples)")
    lat, lon, alt, vn, ve, vd = (a[ok] for a in arrays)
    t = t[ok]
    east, north = local_tangent_plane_m(lat, lon, float(np.median(lat)), float(np.median(lon)))
    i, j = _interval_pairs(t, interval_s)
    if i.size < 10:
        return CheckResult(None, "plausibility: velocity against GNSS position not checked (fewer than 10 intervals)")
    parts = []
    reasons = []
    for label, pos, vel in (("horizontal", (east, north), (ve, vn)), ("vertical", (alt,), (-vd,))):
        cum = [_cumulative_trapezoid(v, t) for v in vel]
        v_int = np.concatenate([c[j] - c[i] for c in cum])
        dp = np.concatenate([p[j] - p[i] for p in pos])
        gain, corr, rms_p = _gain(v_int, dp)
        speed = rms_p / interval_s
        parts.append(f"{label} gain {gain:.2f}, correlation {corr:.2f} (RMS GNSS speed {speed:.2f} m/s)")
        if speed < min_rms_speed_ms:
            parts[-1] += " not decided: too little motion"
            continue
        if corr < 0:
            reasons.append(f"INS {label} velocity anti-correlated with the GNSS position derivative (r = {corr:.2f}): "
                           "sign convention (NED expected)")
        elif not gain_range[0] <= gain <= gain_range[1]:
            unit = (" (km/h?)" if 3.0 < gain < 4.2 else " (altitude in feet?)" if 0.25 < gain < 0.36 and
                    label == "vertical" else "")
            reasons.append(f"INS {label} velocity is {gain:.2f} times the GNSS position derivative (accepted "
                           f"{gain_range[0]:g}-{gain_range[1]:g}){unit}: velocity or position in another unit")
    log = f"plausibility: INS velocity against the GNSS position over {i.size} intervals of {interval_s:g} s: " + \
        "; ".join(parts)
    return CheckResult("; ".join(reasons) or None, log)


def sonic_range_check(n_out_of_range: int, n_samples: int, max_fraction: float, instrument: str) -> CheckResult:
    """Fraction of sonic samples beyond the instrument range in the hover window.

    Parameters
    ----------
    n_out_of_range : int
        Samples flagged out of range (QC bit 1) in the hover window.
    n_samples : int
        Samples in the hover window.
    max_fraction : float
        Largest accepted fraction [1] (the gap-filling limit, Ghirardelli et al. (2025), Sect. 3.2: 2 %).
    instrument : str
        Range description for the message (e.g. ``RM Young 81000: |V| <= 40 m/s``).

    Returns
    -------
    CheckResult
        A reason when more than ``max_fraction`` of the samples are out of range (speeds
        logged in another unit, e.g. cm/s, or a sensor fault).
    """
    frac = n_out_of_range / max(n_samples, 1)
    log = f"plausibility: {n_out_of_range} of {n_samples} sonic samples in the hover window out of range ({instrument})"
    if frac > max_fraction:
        return CheckResult(f"{100 * frac:.1f} % of the sonic samples in the hover window beyond the instrument range "
                           f"({instrument}; limit {100 * max_fraction:g} %): speeds in another unit or a sensor fault",
                           log)
    return CheckResult(None, log)
