"""Commanded-motion segments of a rigid-mount sonic's flight: straight legs, climbs, descents and turnarounds.

Step 1 of the commanded-motion diagnosis (:mod:`dronewind.diagnose.platform_commanded`):
from the set points where logged, else from the track, straight legs (horizontal speed at
least ``min_leg_speed_ms``, course within ``max_course_change_deg`` of the leg's, at least
``min_leg_s``), climbs and descents (vertical speed at least ``min_climb_speed_ms`` and
horizontal speed below the leg limit, at least ``min_climb_s``), and turnarounds (the
stretch between two legs of opposite course) (:func:`commanded_segments`). ``trim_s`` is cut
from both ends of every leg; climbs and descents are padded by ``climb_pad_s`` instead.
:func:`earth_reading` gives the sonic's earth-frame reading and the platform velocity the
segments are averaged on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dronewind.errors import InputError

__all__ = [
    "CommandedSegment",
    "commanded_segments",
    "earth_reading",
]


_KINDS_H = ("leg",)


_KINDS_V = ("climb", "descent")


@dataclass(frozen=True)
class CommandedSegment:
    """One stretch of commanded platform motion.

    Attributes
    ----------
    kind : str
        ``leg``, ``climb``, ``descent`` or ``turnaround``.
    start, stop : int
        Sample indices [start, stop) after trimming.
    t_start_s, t_stop_s : float
        Their times [s from the record start].
    speed_ms : float
        Mean horizontal speed (legs, turnarounds) or mean vertical speed (climbs > 0, descents < 0)
        [m s-1].
    course_deg : float
        Mean course over ground, clockwise from north [degree] (NaN for climbs and descents).
    source : str
        ``setpoint`` or ``track``.
    """

    kind: str
    start: int
    stop: int
    t_start_s: float
    t_stop_s: float
    speed_ms: float
    course_deg: float
    source: str


def _smooth(x: np.ndarray, n: int) -> np.ndarray:
    """Centred moving mean over ``n`` samples along axis 0 (edges: shorter windows)."""
    if n <= 1:
        return np.asarray(x, float)
    k = np.ones(n) / n
    x = np.asarray(x, float)
    if x.ndim == 1:
        num = np.convolve(x, k, mode="same")
        den = np.convolve(np.ones_like(x), k, mode="same")
        return num / den
    return np.stack([_smooth(x[:, j], n) for j in range(x.shape[1])], axis=-1)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of the runs of True."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True))


def _course_deg(ve: np.ndarray, vn: np.ndarray) -> float:
    return float(np.mod(np.degrees(np.arctan2(np.mean(ve), np.mean(vn))), 360.0))


def commanded_segments(t_s: np.ndarray, vel_enu: np.ndarray, *, setpoint_vel_enu: np.ndarray | None = None,
                       min_leg_speed_ms: float = 0.8, max_course_change_deg: float = 25.0, min_leg_s: float = 8.0,
                       min_climb_speed_ms: float = 0.3, min_climb_s: float = 1.6, trim_s: float = 1.0,
                       climb_pad_s: float = 2.0, max_turnaround_s: float = 30.0, smooth_s: float = 1.0
                       ) -> list[CommandedSegment]:
    """Legs, climbs, descents and turnarounds of a flight, from its set points or its track.

    Parameters
    ----------
    t_s : numpy.ndarray
        Sample times [s], regular.
    vel_enu : numpy.ndarray
        (n, 3) platform velocity east, north, up [m s-1] (gap-filled).
    setpoint_vel_enu : numpy.ndarray, optional
        (n, 3) commanded velocity; when given, segments are found from it instead of the track.
    min_leg_speed_ms, max_course_change_deg, min_leg_s : float
        A leg: horizontal speed at least this [m s-1], course within this of the leg's running
        course [degree], lasting at least this after trimming [s].
    min_climb_speed_ms, min_climb_s : float
        A climb or descent: vertical speed at least this [m s-1] (horizontal speed below
        ``min_leg_speed_ms``), lasting at least this [s].
    trim_s : float
        Cut from both ends of legs [s].
    climb_pad_s : float
        Added to both ends of climbs and descents [s]: a multicopter's climb lasts a few
        seconds, so its window takes in the whole vertical excursion and some level flight on
        either side; the means of the reading and of the platform velocity over it then hold
        the whole excursion whatever the error of the sonic-platform lag (up to the pad), and
        the vertical fit does not depend on it. :func:`diagnose_commanded` sets it to three
        standard errors of the lag unless given.
    max_turnaround_s : float
        Longest gap between two legs of opposite course counted as a turnaround [s].
    smooth_s : float
        Moving mean applied to the velocity before the thresholds [s].

    Returns
    -------
    list of CommandedSegment
        In time order.
    """
    t = np.asarray(t_s, float)
    v = np.asarray(vel_enu if setpoint_vel_enu is None else setpoint_vel_enu, float)
    if v.ndim != 2 or v.shape != (t.size, 3) or not np.all(np.isfinite(v)):
        raise InputError("commanded segments", f"velocity {v.shape} for {t.size} times; expected a finite (n, 3) "
                         "east, north, up array on the time axis")
    source = "track" if setpoint_vel_enu is None else "setpoint"
    dt = float(np.median(np.diff(t)))
    vs = _smooth(v, max(1, int(round(smooth_s / dt))))
    hs = np.hypot(vs[:, 0], vs[:, 1])
    trim = int(round(trim_s / dt))
    out: list[CommandedSegment] = []
    raw_legs: list[tuple[int, int]] = []
    cos_tol = np.cos(np.radians(max_course_change_deg))
    for a, b in _runs(hs >= min_leg_speed_ms):
        # split where the course leaves the running course of the leg
        start = a
        ref = vs[a, :2] / hs[a]
        for k in range(a + 1, b + 1):
            if k == b or float(np.dot(vs[k, :2] / hs[k], ref)) < cos_tol:
                raw_legs.append((start, k))
                start = k
                if k < b:
                    ref = vs[k, :2] / hs[k]
            else:
                ref = 0.98 * ref + 0.02 * vs[k, :2] / hs[k]
                ref /= np.linalg.norm(ref)

    def add(kind: str, a: int, b: int, min_s: float) -> bool:
        if kind == "leg":
            a2, b2 = a + trim, b - trim
            if b2 - a2 < 2 or (b2 - a2) * dt < min_s:
                return False
        else:
            if b - a < 2 or (b - a) * dt < min_s:
                return False
            pad = int(round(climb_pad_s / dt))
            a2, b2 = max(a - pad, 0), min(b + pad, t.size)
        sl = slice(a2, b2)
        if kind == "leg":
            spd, course = float(np.mean(np.hypot(v[sl, 0], v[sl, 1]))), _course_deg(v[sl, 0], v[sl, 1])
        else:
            spd, course = float(np.mean(v[sl, 2])), float("nan")
        out.append(CommandedSegment(kind, a2, b2, float(t[a2]), float(t[b2 - 1]), spd, course, source))
        return True

    legs = [(a, b) for a, b in raw_legs if add("leg", a, b, min_leg_s)]
    vert = (np.abs(vs[:, 2]) >= min_climb_speed_ms) & (hs < min_leg_speed_ms)
    for a, b in _runs(vert):
        kind = "climb" if float(np.mean(vs[a:b, 2])) > 0 else "descent"
        add(kind, a, b, min_climb_s)
    for (a0, b0), (a1, b1) in zip(legs[:-1], legs[1:], strict=True):
        c0 = np.mean(v[a0:b0, :2], axis=0)
        c1 = np.mean(v[a1:b1, :2], axis=0)
        gap = (a1 - b0) * dt
        if float(np.dot(c0, c1)) < 0 and gap <= max_turnaround_s:
            sl = slice(max(b0 - trim, 0), a1 + trim)
            out.append(CommandedSegment("turnaround", sl.start, sl.stop, float(t[sl.start]), float(t[sl.stop - 1]),
                                        float(np.mean(np.hypot(v[sl, 0], v[sl, 1]))), float("nan"), source))
    out.sort(key=lambda s: s.start)
    return out


def earth_reading(sensor_xyz: np.ndarray, roll_deg: np.ndarray, pitch_deg: np.ndarray, yaw_deg: np.ndarray,
                  mount: np.ndarray) -> np.ndarray:
    r"""The sonic reading in the earth frame, :math:`R(\phi, \theta, \psi) M V_{sensor}`, east/north/up.

    Ghirardelli et al. (2025), Eqs. 1-2 without the platform velocity: the air relative to
    the sonic, rotated to the earth frame (the rotation of :mod:`dronewind.payload.motion`).

    Parameters
    ----------
    sensor_xyz : numpy.ndarray
        (n, 3) sonic u, v, w in the sensor frame [m s-1].
    roll_deg, pitch_deg, yaw_deg : numpy.ndarray
        Attitude at the sonic's times [degree].
    mount : numpy.ndarray
        (3, 3) sensor-to-body matrix M (:func:`dronewind.payload.rigid.mount_matrix_of`).

    Returns
    -------
    numpy.ndarray
        (n, 3) east, north, up [m s-1].
    """
    from dronewind.payload.motion import rotation_matrix_body_to_ned

    body = np.asarray(sensor_xyz, float) @ np.asarray(mount, float).T
    ned = np.einsum("nij,nj->ni", rotation_matrix_body_to_ned(roll_deg, pitch_deg, yaw_deg), body)
    return np.stack([ned[:, 1], ned[:, 0], -ned[:, 2]], axis=-1)
