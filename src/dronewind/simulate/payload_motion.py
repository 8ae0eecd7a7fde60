r"""Motion of the simulated SAMURAI-S payload: hovering drone, pendulum, attitude.

Physics (Ghirardelli et al. 2025, Sects. 2-3):

* Drone: hovers ``pendulum_length_m`` above the payload with smooth position jitter
  (second-order low-passed noise, ``hover_jitter_m``, ``hover_jitter_time_s``).
* Payload: a simple pendulum (Sect. 2.3: "treated as a simple pendulum", period
  2 pi sqrt(l/g) = 8.5 s for l = 18 m) hanging from the drone, forced by the moving
  pivot and by the drag of the turbulent wind, linearised about the mean wind U:

  .. math::
      \ddot p_a + \frac{\rho C_dA U}{m}\dot p_a + \omega_0^2 (p_a - d_a - \delta) =
          \frac{\rho C_dA U}{m} u',\qquad
      \ddot p_c + \frac{\rho C_dA U}{2m}\dot p_c + \omega_0^2 (p_c - d_c) =
          \frac{\rho C_dA U}{2m} v'

  (a along, c across the wind; omega_0^2 = g/l; delta = l rho C_dA U^2 / (2 m g) the
  mean downwind trail; damping at least ``min_damping_ratio``). Its height is
  z_drone - sqrt(l^2 - r^2).
* Attitude: roll transferred from the drone, which banks into lateral gusts
  (phi = rho C_dA,drone U v' / (m_drone g), 0.5 s lag) plus jitter; pitch = balance trim
  plus jitter; a share ``rope_pitch_fraction`` and ``rope_roll_fraction`` (0 by default) of
  the line's swing angle added to pitch and roll (:func:`rope_attitude_deg`, a payload hung
  rigidly from its line); yaw weathervanes to the direction the relative air comes from
  (first order, ``yaw_time_constant_s``) plus jitter (Sect. 2.3).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy import signal
from scipy.interpolate import CubicSpline

from dronewind.core.angles import deg2rad, rad2deg
from dronewind.core.constants import AIR_DENSITY_KGM3
from dronewind.core.timeseries import unwrap_rad
from dronewind.simulate import atmosphere as atm
from dronewind.simulate.payload_flight import _G
from dronewind.simulate.payload_wind import _AirAtPayload, _FieldPoints, _wind_up_at_sonic
from dronewind.simulate.settings import (
    PayloadFlightConditions,
)

__all__ = [
    "body_to_ned",
    "pendulum_period_s",
    "rope_attitude_deg",
]


def body_to_ned(roll_deg: np.ndarray | float, pitch_deg: np.ndarray | float,
                yaw_deg: np.ndarray | float) -> np.ndarray:
    """Body-to-NED rotation R(phi, theta, psi) = [R3(phi) R2(theta) R1(psi)]^T.

    Parameters
    ----------
    roll_deg, pitch_deg, yaw_deg : numpy.ndarray or float
        Euler angles [degree], same shape s.

    Returns
    -------
    numpy.ndarray
        Shape s + (3, 3).

    Notes
    -----
    Ghirardelli et al. (2025), Appendix A; written independently of the processing chain's
    ``dronewind.payload.motion`` (the simulator must not use it).
    """
    f, t, p = (deg2rad(np.asarray(a, float)) for a in (roll_deg, pitch_deg, yaw_deg))
    cf, sf, ct, st, cp, sp = np.cos(f), np.sin(f), np.cos(t), np.sin(t), np.cos(p), np.sin(p)
    r = np.empty(np.shape(f) + (3, 3))
    r[..., 0, 0] = ct * cp
    r[..., 0, 1] = sf * st * cp - cf * sp
    r[..., 0, 2] = cf * st * cp + sf * sp
    r[..., 1, 0] = ct * sp
    r[..., 1, 1] = sf * st * sp + cf * cp
    r[..., 1, 2] = cf * st * sp - sf * cp
    r[..., 2, 0] = -st
    r[..., 2, 1] = sf * ct
    r[..., 2, 2] = cf * ct
    return r


def pendulum_period_s(length_m: float) -> float:
    """Small-amplitude period of a simple pendulum, T = 2 pi sqrt(l/g) (Ghirardelli et al. 2025, Sect. 2.3).

    Parameters
    ----------
    length_m : float
        Rope length [m].

    Returns
    -------
    float
        Period [s] (8.51 s for 18 m).
    """
    return 2 * math.pi * math.sqrt(length_m / _G)


@functools.lru_cache(maxsize=64)
def _butter_sos(order: int, cutoff_hz: float, fs_hz: float) -> np.ndarray:
    """Butterworth low-pass sections (read-only), designed once per order, cut-off and rate.

    A flight's noise streams use a few filters again and again (every forward run draws
    the INS errors anew): a flight's forward runs would design 3 filters 240 times. The
    same arguments give the same sections, so nothing else changes.
    """
    sos = signal.butter(order, cutoff_hz, fs=fs_hz, output="sos")
    sos.setflags(write=False)
    return sos


def _lowpass_noise(rng: np.random.Generator, n: int, fs_hz: float, time_s: float, sigma: float,
                   order: int = 2) -> np.ndarray:
    """Smooth random signal: white noise through a Butterworth low-pass at 1/(2 pi tau), scaled."""
    if sigma == 0 or n == 0:
        return np.zeros(n)
    fc = min(1.0 / (2 * np.pi * time_s), 0.45 * fs_hz)
    sos = _butter_sos(order, fc, fs_hz).copy()  # sosfilt wants a writable array
    pad = int(min(10 * time_s * fs_hz, 20 * fs_hz * 60))
    x = signal.sosfilt(sos, rng.standard_normal(n + pad))[pad:]
    sd = np.std(x)
    return x * (sigma / sd) if sd > 0 else x


def _oscillator(force: np.ndarray, omega0: float, damping: float, fs_hz: float) -> np.ndarray:
    """Response p of p'' + c p' + w0^2 p = force (bilinear-discretised, starts at rest)."""
    b, a = signal.bilinear([1.0], [1.0, damping, omega0**2], fs=fs_hz)
    return signal.lfilter(b, a, force)


def _first_order(x: np.ndarray, tau_s: float, fs_hz: float, x0: float | None = None) -> np.ndarray:
    """First-order low-pass (time constant tau) starting at x0 (default x[0])."""
    alpha = 1.0 - math.exp(-1.0 / (tau_s * fs_hz))
    zi = [(1 - alpha) * (x[0] if x0 is None else x0)]
    y, _ = signal.lfilter([alpha], [1.0, -(1 - alpha)], x, zi=zi)
    return y


@dataclass(frozen=True)
class _Motion:
    """True path (cubic splines of flight time) and attitude of the payload on the sonic grid."""

    t_s: np.ndarray
    east_m: CubicSpline
    north_m: CubicSpline
    up_m: CubicSpline
    roll_deg: np.ndarray
    pitch_deg: np.ndarray
    yaw_deg: np.ndarray
    #: body-to-NED rotation R(roll, pitch, yaw), (n, 3, 3)
    rotation: np.ndarray


class _Jitter(NamedTuple):
    """The drone's random jitter (:func:`_jitter`): hover position [m] and attitude [degree]."""

    along_m: np.ndarray
    across_m: np.ndarray
    vertical_m: np.ndarray
    roll_deg: np.ndarray
    pitch_deg: np.ndarray
    yaw_deg: np.ndarray


#: Payload settings the jitter depends on (:func:`_jitter`).
_JITTER_KEYS: tuple[str, ...] = ("hover_jitter_time_s", "hover_jitter_m", "attitude_jitter_time_s",
                                 "drone_roll_jitter_deg", "pitch_jitter_deg", "yaw_jitter_deg")


def _jitter(p: Mapping[str, float], rng: np.random.Generator, n: int, fs_hz: float) -> _Jitter:
    """The drone's hover and attitude jitter: low-passed noise drawn from ``rng`` (the motion stream).

    Drawn in the order hover jitter along, across and vertical, then roll, pitch and yaw
    jitter (Ghirardelli et al. 2025, Sect. 2.3). It depends on the stream, the settings of
    :data:`_JITTER_KEYS`, ``n`` and ``fs_hz`` only, not on the air: the truths of one seed
    at other hover heights (``height_offset``) draw the same (:func:`_truth`).
    """
    hover, attitude = p["hover_jitter_time_s"], p["attitude_jitter_time_s"]
    return _Jitter(_lowpass_noise(rng, n, fs_hz, hover, p["hover_jitter_m"]),
                   _lowpass_noise(rng, n, fs_hz, hover, p["hover_jitter_m"]),
                   _lowpass_noise(rng, n, fs_hz, hover, 0.5 * p["hover_jitter_m"]),
                   _lowpass_noise(rng, n, fs_hz, attitude, p["drone_roll_jitter_deg"]),
                   _lowpass_noise(rng, n, fs_hz, attitude, p["pitch_jitter_deg"]),
                   _lowpass_noise(rng, n, fs_hz, attitude, p["yaw_jitter_deg"]))


def _pendulum(p: Mapping[str, float], air: _AirAtPayload, field: _FieldPoints, e_u: np.ndarray,
              e_v: np.ndarray, jitter: _Jitter,
              fs_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Payload position: linearised pendulum under a jittering drone, forced by the turbulent drag.

    Ghirardelli et al. (2025), Sect. 2.3 (see the module docstring); the drone's hover jitter is ``jitter``'s.

    Returns
    -------
    east_m, north_m, up_m : numpy.ndarray
        Payload position (ENU from the site) [m].
    line_east_m, line_north_m : numpy.ndarray
        Horizontal offset of the payload from the drone [m] (the line's swing).
    """
    airborne = air.airborne
    l_m = p["pendulum_length_m"]
    omega0 = math.sqrt(_G / l_m)
    u_mean = max(air.mean_hover_ms, 0.1)
    k_drag = AIR_DENSITY_KGM3 * p["drag_area_m2"] * u_mean / p["mass_kg"]
    c_a = max(k_drag, 2 * p["min_damping_ratio"] * omega0)
    c_c = max(0.5 * k_drag, 2 * p["min_damping_ratio"] * omega0)
    trail = l_m * 0.5 * AIR_DENSITY_KGM3 * p["drag_area_m2"] * u_mean**2 / (p["mass_kg"] * _G)
    jit_a, jit_c, jit_z = jitter.along_m, jitter.across_m, jitter.vertical_m
    d_a, d_c = airborne * jit_a, airborne * jit_c
    p_a = _oscillator(omega0**2 * (d_a + airborne * trail) + airborne * k_drag * air.u_fluct_ms, omega0, c_a, fs_hz)
    p_c = _oscillator(omega0**2 * d_c + airborne * 0.5 * k_drag * air.v_fluct_ms, omega0, c_c, fs_hz)
    r_h = np.hypot(p_a - d_a, p_c - d_c)
    z_pay = air.z_nominal_m + airborne * (jit_z + l_m - np.sqrt(np.maximum(l_m**2 - r_h**2, 0.0)))
    pos_e = field.hover_e_m + p_a * e_u[0] + p_c * e_v[0]
    pos_n = field.hover_n_m + p_a * e_u[1] + p_c * e_v[1]
    line_a, line_c = p_a - d_a, p_c - d_c
    return pos_e, pos_n, z_pay, line_a * e_u[0] + line_c * e_v[0], line_a * e_u[1] + line_c * e_v[1]


def rope_attitude_deg(line_north_m: np.ndarray, line_east_m: np.ndarray, length_m: float,
                      yaw_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Roll and pitch of a payload whose vertical axis lies along its line [degree].

    A payload hung rigidly from its line turns with the line's swing. With the payload's
    horizontal offset :math:`\mathbf h = (h_N, h_E)` from the drone, :math:`l` the line's
    length and :math:`\psi` the heading, its body z axis (down) along the line has the
    horizontal components :math:`\mathbf h / l`; for small angles the third column of the
    body-to-NED rotation (Ghirardelli et al. 2025, Appendix A) then gives

    .. math::
        \theta = \frac{h_N \cos\psi + h_E \sin\psi}{l}, \qquad
        \phi = \frac{h_N \sin\psi - h_E \cos\psi}{l}

    (nose down when the payload trails behind the drone, right wing down when it hangs to
    the left).

    Parameters
    ----------
    line_north_m, line_east_m : numpy.ndarray
        Horizontal offset of the payload from the drone [m].
    length_m : float
        Line length [m].
    yaw_deg : numpy.ndarray
        Heading of the body x axis [degree].

    Returns
    -------
    roll_deg, pitch_deg : numpy.ndarray
        Roll and pitch [degree].
    """
    psi = deg2rad(np.asarray(yaw_deg, dtype=float))
    h_n, h_e = np.asarray(line_north_m, dtype=float) / length_m, np.asarray(line_east_m, dtype=float) / length_m
    cos_psi, sin_psi = np.cos(psi), np.sin(psi)
    return rad2deg(h_n * sin_psi - h_e * cos_psi), rad2deg(h_n * cos_psi + h_e * sin_psi)


def _slope_at_knots(spline: CubicSpline) -> np.ndarray:
    r"""``spline(spline.x, 1)`` bit for bit: the first derivative at the spline's own knots.

    At knot :math:`x_i` of interval :math:`i` scipy evaluates the derivative as
    :math:`0 + c_{1,i} + c_{2,i} \cdot 0 \cdot 2 + c_{3,i} \cdot 0 \cdot 3 = c_{1,i}` (``0.0 +``
    keeps the sign of a zero as that sum does); the last knot, the end of the last interval,
    is evaluated. The payload's velocity on its own grid (the motion's time axis) is taken
    five times per truth, at a small fraction of the cost of the spline's general
    evaluation.
    """
    out = np.empty(spline.x.size)
    out[:-1] = 0.0 + spline.c[-2]
    out[-1:] = spline(spline.x[-1:], 1)
    return out


def _payload_motion(p: Mapping[str, float], air: _AirAtPayload, field: _FieldPoints, spec: atm.FieldSpec,
                    jitter: _Jitter, fs_hz: float) -> _Motion:
    """Pendulum path and attitude (Ghirardelli et al. 2025, Sect. 2.3).

    Roll: the drone banks into lateral gusts (0.5 s lag) plus jitter; pitch: trim plus
    jitter; shares of the line's swing angle added to both (:func:`rope_attitude_deg`); yaw
    weathervanes to the direction the relative air comes from (first order) plus jitter
    (:func:`_jitter`).
    """
    t = air.t_s
    pos_e, pos_n, z_pay, line_e, line_n = _pendulum(p, air, field, spec.e_u, spec.e_v, jitter, fs_hz)
    u_mean = max(air.mean_hover_ms, 0.1)
    roll_k = AIR_DENSITY_KGM3 * p["drone_drag_area_m2"] * u_mean / (p["drone_mass_kg"] * _G)
    roll = rad2deg(_first_order(roll_k * air.v_fluct_ms, 0.5, fs_hz)) * air.airborne + jitter.roll_deg
    pitch = p["pitch_trim_deg"] + jitter.pitch_deg
    spl_e, spl_n, spl_z = (CubicSpline(t, x) for x in (pos_e, pos_n, z_pay))
    rel_e, rel_n = air.wind_e_ms - _slope_at_knots(spl_e), air.wind_n_ms - _slope_at_knots(spl_n)
    from_dir = unwrap_rad(np.arctan2(-rel_e, -rel_n))          # direction the relative air comes from
    yaw = rad2deg(_first_order(from_dir, p["yaw_time_constant_s"], fs_hz)) + jitter.yaw_deg
    if p["rope_pitch_fraction"] > 0 or p["rope_roll_fraction"] > 0:
        # the swing about the mean trail (the balance trim holds the mean attitude)
        airborne = air.airborne > 0
        swing = [np.where(airborne, x - (x[airborne].mean() if airborne.any() else 0.0), 0.0) for x in (line_n, line_e)]
        rope_roll, rope_pitch = rope_attitude_deg(swing[0], swing[1], p["pendulum_length_m"], yaw)
        roll = roll + p["rope_roll_fraction"] * rope_roll
        pitch = pitch + p["rope_pitch_fraction"] * rope_pitch
    return _Motion(t, spl_e, spl_n, spl_z, roll, pitch, yaw, body_to_ned(roll, pitch, yaw))


def _air_in_body(cond: PayloadFlightConditions, air: _AirAtPayload, motion: _Motion) -> np.ndarray:
    """The air relative to the payload in its body frame, R^T (V_wind - V_ins) [m s-1], (n, 3), read-only.

    Depends on the true state and ``downwash`` (the w the sonic sees) only, so a truth's
    other sonic probes share it (:func:`payload_records`).
    """
    vel_e, vel_n, vel_up = (_slope_at_knots(spl) for spl in (motion.east_m, motion.north_m, motion.up_m))
    rel_ned = np.stack([air.wind_n_ms - vel_n, air.wind_e_ms - vel_e, -(_wind_up_at_sonic(cond, air) - vel_up)],
                       axis=-1)
    v_body = np.einsum("tji,tj->ti", motion.rotation, rel_ned)
    v_body.setflags(write=False)
    return v_body
