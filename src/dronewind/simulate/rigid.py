r"""Rigid-mount multicopter records: a sonic bolted to a hovering (or slowly flying) multicopter.

The record the rigid-mount chain reads (:mod:`dronewind.payload.rigid`, through a
``delimited`` mapping): one CSV with the sonic (sensor frame) and the vehicle's velocity
(east, north, up), attitude and position on one time axis, and the mapping that declares it
(:attr:`RigidRecord.format`).

Model
-----
* Wind: :func:`dronewind.simulate.atmosphere.simulate_wind` at the hover point (Kaimal
  spectra, Monin-Obukhov profile), east/north/up :math:`V_{wind}` [m s-1].
* Platform: a position-hold multicopter. Its displacement about the hover point in each
  axis is a damped oscillator driven by white noise,

  .. math:: \ddot x + 2 \zeta \omega_0 \dot x + \omega_0^2 x = \omega_0^2\, \sigma_x \sqrt{4 \zeta / \omega_0}\, \xi(t),

  (stationary standard deviation :math:`\sigma_x` [m], natural frequency
  :math:`f_0 = \omega_0 / 2\pi` [Hz], damping ratio :math:`\zeta`), optionally plus
  straight legs back and forth at ``leg_speed_ms`` along ``leg_heading_deg``. The logged
  velocity :math:`V_{platform}` is the time derivative of the displacement; the logged
  position is the hover point plus the displacement (so the two agree).
* Platform, ``platform_model = "position_hold"``: a position-hold controller flying a
  survey plan and carried by the wind, as a real multicopter is. The set points are a hover
  of ``hover_s``, then repeated straight legs of ``leg_s`` at ``leg_speed_ms`` along
  ``leg_heading_deg`` and back, with turnarounds of ``turn_s`` between them, and after every
  second leg a climb or descent (alternately) of ``climb_m`` at ``climb_speed_ms`` (so legs
  both ways are flown at both heights); set-point velocity ramps are acceleration-limited
  (``accel_ms2``). About its set point the vehicle's error :math:`e = x - x_{sp}` in each axis
  obeys

  .. math:: \ddot e = k_a (V_{wind} - \bar V_{wind}) - c\, \dot e - K_p e - K_i \int e\, dt,

  a PID loop on position (:math:`K_p = \omega_0^2`, :math:`c = 2 \zeta \omega_0`,
  :math:`K_i = 0.1\, \omega_0^3`) with the set point's velocity and the tilt holding the mean
  wind fed forward, and the gusts coupled in through the linear drag of the airframe and
  rotors, :math:`k_a` = ``drag_per_s`` (horizontal) and ``drag_vertical_per_s`` (vertical).
  The logged velocity is :math:`V_{sp} + \dot e`: in a hover it follows the gusts
  (correlated with the wind), on the legs, climbs and descents it is dominated by the
  commanded velocity (independent of the wind).
* Attitude: the vehicle leans into the air flowing past it, pitch
  :math:`\theta = k\, a_{fwd}` and roll :math:`\phi = -k\, a_{right}` with
  :math:`a = V_{wind} - V_{platform}` projected on the body's forward and right axes and
  :math:`k` = ``tilt_deg_per_ms``, plus Ornstein-Uhlenbeck wander; yaw = heading + wander.
* Sonic: the mount matrix M (sensor-to-body, each sensor axis named as a body direction)
  and the body-to-NED rotation :math:`R(\phi, \theta, \psi)` (Ghirardelli et al. 2025, Appendix A). The
  sonic measures the air relative to itself in its own frame,

  .. math:: V_{sensor} = (R M)^{\mathsf T} \left(V_{wind} - G\, V_{platform}\right), \qquad
            G = \mathrm{diag}(g_h, g_h, g_v)

  (east/north/up; the same diagonal in north/east/down). Without mechanisms
  :math:`G = I`: the model the chain inverts (:math:`V_{wind} = R M V_{sensor} +
  V_{platform}`). The catalog mechanism ``platform_velocity_response`` (``gain_h``,
  ``gain_v``) sets :math:`g_h, g_v`: airframe and rotor flow distortion make the sonic see
  only part (or more than all) of the platform's own velocity. White noise
  (``sonic_noise_ms``) is added to each sensor component. Two installation errors the chain
  does not know of: the sonic yawed on the airframe by ``sonic_yaw_offset_deg`` (clockwise
  seen from above: the true sensor-to-body matrix is :math:`R_z(\delta) M`), and its clock
  offset from the platform's by ``sonic_lag_s`` (the sonic sample stamped :math:`t` was
  taken at platform time :math:`t + L`, the convention of the chain's ``lag_sonic_ins_s``).

Sling load
----------
There is no sling-load analogue: the SAMURAI-S payload's sonic hangs below the drone, and
the velocity it sees is the air relative to the payload itself, which the payload INS
measures (:mod:`dronewind.simulate.payload`); the carrier's rotor flow reaching it is the
``downwash`` mechanism already. A response to the payload's own velocity different from one
would need flow distortion by the payload body moving through the air, which no measurement
of this project documents; none is built.

The simulator imports no chain code (import-linter contract): the rotation and the mount
are written here independently of :mod:`dronewind.payload`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import scipy.signal

from dronewind.core.angles import deg2rad, rad2deg
from dronewind.core.constants import ZERO_CELSIUS_K
from dronewind.errors import InputError
from dronewind.mechanisms import validate_parameters
from dronewind.simulate.atmosphere import simulate_wind
from dronewind.simulate.common import ornstein_uhlenbeck
from dronewind.simulate.payload_motion import body_to_ned

__all__ = ["RigidSettings", "RigidRecord", "mount_matrix", "platform_gains", "sensor_reading",
           "survey_setpoints", "position_hold_error", "simulate_rigid_record", "RIGID_FORMAT"]

_EARTH_RADIUS_M = 6_371_000.0
_BODY = {"forward": (1.0, 0.0, 0.0), "back": (-1.0, 0.0, 0.0), "right": (0.0, 1.0, 0.0),
         "left": (0.0, -1.0, 0.0), "down": (0.0, 0.0, 1.0), "up": (0.0, 0.0, -1.0)}

#: The ``delimited`` mapping of the CSV :func:`simulate_rigid_record` writes (a manifest's
#: ``record.format``).
RIGID_FORMAT: dict[str, Any] = {
    "name": "delimited",
    "time": {"column": "time_utc", "kind": "iso"},
    "variables": {
        "u": {"column": "u_ms", "unit": "m/s"}, "v": {"column": "v_ms", "unit": "m/s"},
        "w": {"column": "w_ms", "unit": "m/s"}, "t": {"column": "t_degc", "unit": "degC"},
        "vel_e": {"column": "vel_e_ms", "unit": "m/s"}, "vel_n": {"column": "vel_n_ms", "unit": "m/s"},
        "vel_u": {"column": "vel_u_ms", "unit": "m/s"},
        "roll": {"column": "roll_deg", "unit": "degree"}, "pitch": {"column": "pitch_deg", "unit": "degree"},
        "yaw": {"column": "yaw_deg", "unit": "degree"},
        "lat": {"column": "lat_deg", "unit": "degree"}, "lon": {"column": "lon_deg", "unit": "degree"},
        "alt": {"column": "alt_m", "unit": "m"},
    },
}


@dataclass(frozen=True)
class RigidSettings:
    """Conditions of one simulated rigid-mount flight.

    Attributes
    ----------
    duration_s, fs_hz : float
        Length [s] and sampling rate [Hz].
    mean_speed_ms, wind_from_deg : float
        Mean wind at the hover height [m s-1] and where it blows from [degree].
    height_m : float
        Hover height above ground [m].
    obukhov_length_m, roughness_length_m : float
        Stability [m] (``inf``: neutral) and z0 [m].
    position_sd_m : (float, float, float)
        Standard deviation of the position-hold displacement east, north, up [m].
    hover_frequency_hz, hover_damping : float
        Natural frequency f0 [Hz] and damping ratio of the position hold.
    leg_speed_ms, leg_s, leg_heading_deg : float
        Back-and-forth legs: speed [m s-1] (0: hover only), duration of one leg [s], heading
        of the first leg [degree].
    heading_deg, tilt_deg_per_ms, attitude_sd_deg : float
        Mean yaw [degree], lean into the relative air [degree per m s-1], wander of roll,
        pitch and yaw [degree].
    mount_axes : mapping
        Each sensor axis as a body direction (``{"u": "right", "v": "forward", "w": "up"}``).
    sonic_noise_ms : float
        White noise on each sensor component [m s-1].
    platform_model : str
        ``noise`` (the damped oscillator driven by white noise) or ``position_hold`` (the
        controller driven by the wind, flying the survey plan).
    drag_per_s, drag_vertical_per_s : float
        Gust coupling :math:`k_a` of the position hold, horizontal and vertical [s-1].
    hover_s, turn_s, climb_m, climb_speed_ms, accel_ms2 : float
        Survey plan of the position hold: initial hover [s], turnaround [s], climb or descent
        after every second leg [m] (0: none), its speed [m s-1], set-point acceleration [m s-2].
    sonic_yaw_offset_deg : float
        Yaw of the sonic on the airframe off the declared mount [degree, clockwise from above].
    sonic_lag_s : float
        Sonic clock offset [s]: the sample stamped t was taken at platform time t + lag.
    temperature_c : float
        Mean sonic temperature [degC].
    latitude_deg, longitude_deg, site_altitude_m : float
        Hover point and ground altitude [degree, degree, m].
    start_utc : str
        First time stamp (ISO 8601, UTC).
    """

    duration_s: float = 900.0
    fs_hz: float = 10.0
    mean_speed_ms: float = 5.0
    wind_from_deg: float = 200.0
    height_m: float = 40.0
    obukhov_length_m: float = float("inf")
    roughness_length_m: float = 0.05
    position_sd_m: tuple[float, float, float] = (0.7, 0.7, 0.3)
    hover_frequency_hz: float = 0.15
    hover_damping: float = 0.4
    leg_speed_ms: float = 0.0
    leg_s: float = 60.0
    leg_heading_deg: float = 90.0
    heading_deg: float = 180.0
    tilt_deg_per_ms: float = 1.5
    attitude_sd_deg: float = 1.0
    mount_axes: Mapping[str, str] = field(default_factory=lambda: {"u": "right", "v": "forward", "w": "up"})
    sonic_noise_ms: float = 0.03
    platform_model: str = "noise"
    drag_per_s: float = 0.4
    drag_vertical_per_s: float = 0.2
    hover_s: float = 60.0
    turn_s: float = 6.0
    climb_m: float = 0.0
    climb_speed_ms: float = 1.0
    accel_ms2: float = 1.0
    sonic_yaw_offset_deg: float = 0.0
    sonic_lag_s: float = 0.0
    temperature_c: float = 20.0
    latitude_deg: float = 32.69
    longitude_deg: float = -103.07
    site_altitude_m: float = 1150.0
    start_utc: str = "2024-05-01T12:00:00Z"


@dataclass(frozen=True)
class RigidRecord:
    """A simulated rigid-mount record and its truth.

    Attributes
    ----------
    path : Path
        The CSV written.
    format : dict
        Its ``delimited`` mapping (:data:`RIGID_FORMAT`).
    truth : pandas.DataFrame
        Per sample: ``time_s`` [s], true wind ``u_east_ms, v_north_ms, w_up_ms`` and the
        platform velocity ``vel_e_ms, vel_n_ms, vel_u_ms`` [m s-1].
    gains : (float, float)
        The :math:`(g_h, g_v)` applied.
    """

    path: Path
    format: dict[str, Any]
    truth: pd.DataFrame
    gains: tuple[float, float]


def mount_matrix(axes: Mapping[str, str]) -> np.ndarray:
    """Sensor-to-body matrix M (``v_body = M v_sensor``) from the sensor axes named as body directions.

    Parameters
    ----------
    axes : mapping
        ``{"u": dir, "v": dir, "w": dir}``, each one of forward, back, right, left, down, up.

    Returns
    -------
    numpy.ndarray
        (3, 3) M; columns are the body-frame unit vectors of the sensor axes.

    Raises
    ------
    InputError
        An unknown direction, or axes that do not form a right-handed frame.
    """
    cols = []
    for k in ("u", "v", "w"):
        if axes.get(k) not in _BODY:
            raise InputError(f"mount_axes.{k}", f"{axes.get(k)!r}; expected one of {', '.join(_BODY)}")
        cols.append(_BODY[axes[k]])
    m = np.array(cols, dtype=float).T
    if not np.allclose(m @ m.T, np.eye(3)) or np.linalg.det(m) < 0:
        raise InputError("mount_axes", f"{dict(axes)} is not a right-handed frame; expected three different axes")
    return m


def platform_gains(mechanisms: Sequence[Mapping[str, Any]] | None) -> tuple[float, float]:
    """The :math:`(g_h, g_v)` of the ``platform_velocity_response`` mechanism, (1, 1) without it.

    Parameters
    ----------
    mechanisms : sequence of mapping
        ``{"mechanism": name, "parameters": {...}}`` entries; mechanisms of other platforms
        are rejected (a rigid-mount record has none of them).

    Returns
    -------
    (float, float)
        ``gain_h``, ``gain_v`` [1].
    """
    gains = (1.0, 1.0)
    for k, m in enumerate(mechanisms or []):
        name = m.get("mechanism")
        if name == "none":
            continue
        if name != "platform_velocity_response":
            raise InputError(f"mechanisms[{k}].mechanism", f"{name!r}; the rigid-mount simulator applies "
                             "platform_velocity_response (or none)")
        p = validate_parameters(name, m.get("parameters"), f"mechanisms[{k}].parameters")
        gains = (float(p["gain_h"]), float(p["gain_v"]))
    return gains


def sensor_reading(wind_enu: np.ndarray, vel_enu: np.ndarray, rot_body_to_ned: np.ndarray, mount: np.ndarray,
                   gain_h: float = 1.0, gain_v: float = 1.0) -> np.ndarray:
    r"""What the sonic measures: air relative to the sensor, sensor frame.

    Parameters
    ----------
    wind_enu, vel_enu : numpy.ndarray
        (n, 3) wind and platform velocity, east/north/up [m s-1].
    rot_body_to_ned : numpy.ndarray
        (n, 3, 3) :math:`R(\phi, \theta, \psi)`.
    mount : numpy.ndarray
        (3, 3) sensor-to-body M.
    gain_h, gain_v : float
        :math:`g_h, g_v` of ``platform_velocity_response`` [1].

    Returns
    -------
    numpy.ndarray
        (n, 3) :math:`V_{sensor} = (R M)^{\mathsf T} (V_{wind} - G V_{platform})` [m s-1].
    """
    g = np.array([gain_h, gain_h, gain_v])
    rel = np.asarray(wind_enu, float) - g * np.asarray(vel_enu, float)
    rel_ned = np.stack([rel[:, 1], rel[:, 0], -rel[:, 2]], axis=-1)
    body = np.einsum("nji,nj->ni", rot_body_to_ned, rel_ned)
    return body @ mount


def _hover_displacement(rng: np.random.Generator, n: int, fs_hz: float, sd_m: float, f0_hz: float,
                        damping: float) -> np.ndarray:
    """Position-hold displacement [m]: a damped oscillator driven by white noise, scaled to ``sd_m``."""
    if sd_m <= 0:
        return np.zeros(n)
    w0 = 2 * np.pi * f0_hz
    b, a = scipy.signal.bilinear([w0 ** 2], [1.0, 2 * damping * w0, w0 ** 2], fs=fs_hz)
    spin = int(10 * fs_hz / max(f0_hz * damping, 1e-3))
    x = scipy.signal.lfilter(b, a, rng.standard_normal(n + spin))[spin:]
    return x * (sd_m / float(np.std(x)))


def _legs(n: int, fs_hz: float, speed_ms: float, leg_s: float) -> np.ndarray:
    """Distance along the leg heading [m] of back-and-forth legs (a triangle wave)."""
    if speed_ms <= 0:
        return np.zeros(n)
    t = np.arange(n) / fs_hz
    phase = np.mod(t, 2 * leg_s)
    return speed_ms * np.where(phase < leg_s, phase, 2 * leg_s - phase)


def survey_setpoints(n: int, fs_hz: float, s: RigidSettings) -> tuple[np.ndarray, np.ndarray]:
    """Set-point displacement and velocity of the survey plan (east, north, up about the hover point).

    Parameters
    ----------
    n : int
        Samples.
    fs_hz : float
        Sampling rate [Hz].
    s : RigidSettings
        ``hover_s``, ``leg_s``, ``leg_speed_ms``, ``leg_heading_deg``, ``turn_s``, ``climb_m``,
        ``climb_speed_ms``, ``accel_ms2``.

    Returns
    -------
    position_m, velocity_ms : numpy.ndarray
        (n, 3) each; the position is the integral of the velocity.
    """
    v = np.zeros((n, 3))
    hd = deg2rad(s.leg_heading_deg)
    along = np.array([np.sin(hd), np.cos(hd), 0.0])
    k = int(round(s.hover_s * fs_hz))
    n_leg, n_turn = int(round(s.leg_s * fs_hz)), int(round(s.turn_s * fs_hz))
    climb_s = s.climb_m / s.climb_speed_ms if s.climb_m > 0 and s.climb_speed_ms > 0 else 0.0
    n_climb = int(round(climb_s * fs_hz))
    sign, up, legs = 1.0, 1.0, 0
    while s.leg_speed_ms > 0 and n_leg > 0 and k < n:
        v[k:k + n_leg] = sign * s.leg_speed_ms * along
        k += n_leg + n_turn
        sign, legs = -sign, legs + 1
        if n_climb and legs % 2 == 0 and k < n:
            v[k:k + n_climb, 2] = up * s.climb_speed_ms
            k += n_climb + n_turn
            up = -up
    # acceleration-limited ramps: a moving mean as long as the largest speed change takes
    ramp = max(s.leg_speed_ms, s.climb_speed_ms if n_climb else 0.0) / max(s.accel_ms2, 1e-6)
    m = max(1, int(round(ramp * fs_hz)))
    if m > 1:
        kern = np.ones(m) / m
        v = np.stack([np.convolve(v[:, j], kern, mode="full")[:n] for j in range(3)], axis=-1)
    return np.cumsum(v, axis=0) / fs_hz, v


def position_hold_error(t_s: np.ndarray, gust_ms: np.ndarray, drag_per_s: float, f0_hz: float, damping: float
                        ) -> tuple[np.ndarray, np.ndarray]:
    r"""Position-hold error of one axis driven by the gusts through the airframe's drag.

    :math:`\ddot e = k_a u' - 2\zeta\omega_0 \dot e - \omega_0^2 e - 0.1\,\omega_0^3 \int e\, dt`
    (a PID position loop with the mean wind and the set point's motion fed forward), solved as
    a linear state-space system by :func:`scipy.signal.lsim`.

    Parameters
    ----------
    t_s : numpy.ndarray
        Regular times [s].
    gust_ms : numpy.ndarray
        Wind minus its mean along the axis [m s-1].
    drag_per_s : float
        :math:`k_a` [s-1].
    f0_hz, damping : float
        Natural frequency [Hz] and damping ratio of the loop.

    Returns
    -------
    e_m, de_ms : numpy.ndarray
        Displacement [m] and velocity [m s-1] about the set point.
    """
    w0 = 2 * np.pi * f0_hz
    a = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-0.1 * w0 ** 3, -w0 ** 2, -2 * damping * w0]])
    b = np.array([[0.0], [0.0], [drag_per_s]])
    c = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    _, y, _ = scipy.signal.lsim((a, b, c, np.zeros((2, 1))), np.asarray(gust_ms, float), np.asarray(t_s, float))
    return y[:, 0], y[:, 1]


def simulate_rigid_record(path: str | os.PathLike[str], settings: RigidSettings | None = None, *,
                          mechanisms: Sequence[Mapping[str, Any]] | None = None, seed: int = 0) -> RigidRecord:
    """Simulate one rigid-mount flight and write it as the CSV the rigid-mount chain reads.

    Parameters
    ----------
    path : str or Path
        CSV to write (columns of :data:`RIGID_FORMAT`; times ISO 8601 with ``Z``).
    settings : RigidSettings, optional
        Conditions (defaults: a 15-min hover at 40 m in a 5 m s-1 wind).
    mechanisms : sequence of mapping, optional
        Catalog mechanisms (:func:`platform_gains`).
    seed : int
        Seed of the random generator; the wind field uses ``seed`` too.

    Returns
    -------
    RigidRecord
    """
    s = settings or RigidSettings()
    gh, gv = platform_gains(mechanisms)
    fs = float(s.fs_hz)
    n = int(round(s.duration_s * fs))
    if n < 100:
        raise InputError("duration_s", f"{s.duration_s} s at {fs} Hz is {n} samples; expected at least 100")
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 7]))
    t = np.arange(n) / fs
    wind = simulate_wind(np.array([[0.0, 0.0, s.height_m]]), s.duration_s, fs, s.mean_speed_ms, s.wind_from_deg,
                         s.height_m, s.obukhov_length_m, s.roughness_length_m, seed=int(seed),
                         theta_mean_k=s.temperature_c + ZERO_CELSIUS_K)
    wind_enu = np.stack([wind[k].values[0, :n] for k in ("u_east_ms", "v_north_ms", "w_up_ms")], axis=-1)
    theta = wind["theta_v_k"].values[0, :n] - ZERO_CELSIUS_K
    if s.platform_model == "noise":
        disp = np.stack([_hover_displacement(rng, n, fs, sd, s.hover_frequency_hz, s.hover_damping)
                         for sd in s.position_sd_m], axis=-1)
        along = _legs(n, fs, s.leg_speed_ms, s.leg_s)
        hd = deg2rad(s.leg_heading_deg)
        disp[:, 0] += along * np.sin(hd)
        disp[:, 1] += along * np.cos(hd)
        vel = np.gradient(disp, 1.0 / fs, axis=0)
    elif s.platform_model == "position_hold":
        pos_sp, vel_sp = survey_setpoints(n, fs, s)
        disp, vel = pos_sp.copy(), vel_sp.copy()
        for j, k_a in enumerate((s.drag_per_s, s.drag_per_s, s.drag_vertical_per_s)):
            e, de = position_hold_error(t, wind_enu[:, j] - wind_enu[:, j].mean(), k_a, s.hover_frequency_hz,
                                        s.hover_damping)
            disp[:, j] += e
            vel[:, j] += de
    else:
        raise InputError("platform_model", f"{s.platform_model!r}; expected 'noise' or 'position_hold'")
    yaw = s.heading_deg + ornstein_uhlenbeck(rng, n, s.attitude_sd_deg, 5.0, fs)
    psi = deg2rad(yaw)
    air = wind_enu - vel
    a_fwd = air[:, 0] * np.sin(psi) + air[:, 1] * np.cos(psi)
    a_right = air[:, 0] * np.cos(psi) - air[:, 1] * np.sin(psi)
    pitch = s.tilt_deg_per_ms * a_fwd + ornstein_uhlenbeck(rng, n, s.attitude_sd_deg, 1.0, fs)
    roll = -s.tilt_deg_per_ms * a_right + ornstein_uhlenbeck(rng, n, s.attitude_sd_deg, 1.0, fs)
    rot = body_to_ned(roll, pitch, yaw)
    dz = deg2rad(s.sonic_yaw_offset_deg)
    yaw_mount = np.array([[np.cos(dz), -np.sin(dz), 0.0], [np.sin(dz), np.cos(dz), 0.0], [0.0, 0.0, 1.0]])
    sensor = sensor_reading(wind_enu, vel, rot, yaw_mount @ mount_matrix(s.mount_axes), gh, gv)
    if s.sonic_lag_s:
        # the sample stamped t was taken at platform time t + lag
        sensor = np.stack([np.interp(t + s.sonic_lag_s, t, sensor[:, j]) for j in range(3)], axis=-1)
    sensor += rng.standard_normal(sensor.shape) * s.sonic_noise_ms
    lat = s.latitude_deg + rad2deg(disp[:, 1] / _EARTH_RADIUS_M)
    lon = s.longitude_deg + rad2deg(disp[:, 0] / (_EARTH_RADIUS_M * np.cos(deg2rad(s.latitude_deg))))
    start = np.datetime64(s.start_utc.rstrip("Z"), "ns")
    stamps = pd.DatetimeIndex(start + np.rint(t * 1e9).astype("timedelta64[ns]"))
    table = pd.DataFrame({
        "time_utc": stamps.strftime("%Y-%m-%dT%H:%M:%S.%f").str[:-3] + "Z",
        "u_ms": sensor[:, 0], "v_ms": sensor[:, 1], "w_ms": sensor[:, 2], "t_degc": theta,
        "vel_e_ms": vel[:, 0], "vel_n_ms": vel[:, 1], "vel_u_ms": vel[:, 2],
        "roll_deg": roll, "pitch_deg": pitch, "yaw_deg": np.mod(yaw, 360.0),
        "lat_deg": lat, "lon_deg": lon, "alt_m": s.site_altitude_m + s.height_m + disp[:, 2],
    })
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(out, index=False, float_format="%.6f")
    truth = pd.DataFrame({"time_s": t, "u_east_ms": wind_enu[:, 0], "v_north_ms": wind_enu[:, 1],
                          "w_up_ms": wind_enu[:, 2], "vel_e_ms": vel[:, 0], "vel_n_ms": vel[:, 1],
                          "vel_u_ms": vel[:, 2]})
    return RigidRecord(out, {k: (dict(v) if isinstance(v, dict) else v) for k, v in RIGID_FORMAT.items()},
                       truth, (gh, gv))
