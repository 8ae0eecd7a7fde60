"""The payload on a line under a position-holding drone: a spherical pendulum with drag and yaw.

Physics (the world's own; the project's simulator moves its payload differently):

* the line is taut and straight, of length L, from the hook (the drone, moving with its
  position-hold jitter) to the payload (a point mass m); Cartesian coordinates with the
  constraint |r| = L enforced by the tension (the Lagrange multiplier of the constraint,
  r . r'' = -|r'|^2) and held against drift by Baumgarte stabilisation
  (Baumgarte 1972, Comput. Methods Appl. Mech. Eng. 1, 1-16);
* quadratic drag on the payload, F = rho/2 C_D A |v_rel| v_rel with the air velocity
  relative to it;
* distributed drag on the line: the force per unit length rho/2 C_D d |v_n| v_n on the
  velocity normal to the line (cross-flow principle, Hoerner 1965, Fluid-Dynamic Drag,
  Ch. 3), evaluated on segments; a segment at distance s from the hook acts on the
  payload's swing as s/L of its force (moment balance of a massless straight line);
* yaw: the payload turns towards the drone's heading and weathervanes into the relative
  wind. The two ropes (spacing d, both of length L) form a bifilar suspension, whose
  restoring torque m g d^2 / (4 L) per radian of twist gives the frequency
  sqrt(m g d^2 / (4 L I_z)) (0.23 Hz for 4 kg, 1 m, 18 m, I_z = 0.25 kg m2); the vane (area
  S, lift slope a of a low-aspect-ratio plate, about pi A / 2 = 2 per radian, Hoerner and
  Borst 1985, Fluid-Dynamic Lift, Ch. 17; arm l) adds rho/2 S a l |v_h|^2 sin(beta) / I_z and
  the aerodynamic damping rho/2 S a l^2 |v_h| psi' / I_z; a small structural damping.

Integrated by :func:`scipy.integrate.solve_ivp` (RK45).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from scipy.signal import butter, sosfiltfilt

GRAVITY_ENU = np.array([0.0, 0.0, -9.81])


@dataclass(frozen=True)
class LineSettings:
    """Line, payload and yaw settings (SI units)."""

    length_m: float = 18.0
    mass_kg: float = 4.0
    payload_cda_m2: float = 0.08
    line_diameter_m: float = 0.004
    line_cd: float = 1.2
    air_density_kgm3: float = 1.2
    n_segments: int = 6
    rope_spacing_m: float = 1.0
    yaw_inertia_kgm2: float = 0.25
    yaw_damping_ratio: float = 0.05
    vane_area_m2: float = 0.04
    vane_lift_slope_per_rad: float = 2.0
    vane_arm_m: float = 0.45
    baumgarte_per_s: float = 2.0

    @property
    def yaw_frequency_hz(self) -> float:
        """Bifilar twist frequency sqrt(m g d^2 / (4 L I_z)) / (2 pi) [Hz]."""
        return math.sqrt(self.mass_kg * 9.81 * self.rope_spacing_m**2
                         / (4 * self.length_m * self.yaw_inertia_kgm2)) / (2 * math.pi)

    @property
    def vane_gain_per_m2(self) -> float:
        """rho/2 S a l / I_z: yaw acceleration per (m/s)^2 of relative wind and sine of sideslip [m-2]."""
        return 0.5 * self.air_density_kgm3 * self.vane_area_m2 * self.vane_lift_slope_per_rad * self.vane_arm_m \
            / self.yaw_inertia_kgm2

    @property
    def vane_damping_per_m(self) -> float:
        """rho/2 S a l^2 / I_z: yaw damping per m/s of relative wind [m-1]."""
        return self.vane_gain_per_m2 * self.vane_arm_m


def hook_motion(t_s: np.ndarray, rng: np.random.Generator, sigma_h_m: float, sigma_v_m: float,
                cutoff_hz: float = 0.15) -> CubicSpline:
    """Position-hold jitter of the hook about its set point: low-passed white noise per axis
    (4th-order Butterworth, zero phase), scaled to the standard deviations (east, north, up).

    Returns
    -------
    scipy.interpolate.CubicSpline
        Offset [m] of time; its derivatives give velocity and acceleration.
    """
    fs = 1.0 / float(t_s[1] - t_s[0])
    sos = butter(4, cutoff_hz, fs=fs, output="sos")
    noise = sosfiltfilt(sos, rng.standard_normal((3, t_s.size)), axis=1)
    noise /= noise.std(axis=1, keepdims=True)
    offsets = noise * np.array([[sigma_h_m], [sigma_h_m], [sigma_v_m]])
    return CubicSpline(t_s, offsets.T, axis=0)


def pendulum_rhs(settings: LineSettings, t0_s: float, fs_hz: float, hook: np.ndarray, wind_payload: np.ndarray,
                 wind_line: np.ndarray, heading_rad: np.ndarray):  # noqa: ANN201 (a closure for solve_ivp)
    """Right-hand side of the pendulum and yaw ODE on forcing tables sampled at ``fs_hz``.

    State: r (3, payload minus hook, east/north/up), r' (3), heading psi (rad, clockwise
    from north), psi'. ``hook`` is (n, 9): position, velocity, acceleration; ``wind_payload``
    (n, 3); ``wind_line`` (n, n_segments, 3); ``heading_rad`` (n,) the drone's heading.
    """
    s = settings
    n_seg = s.n_segments
    frac = (np.arange(n_seg) + 0.5) / n_seg                    # s/L of the segments
    k_payload = 0.5 * s.air_density_kgm3 * s.payload_cda_m2 / s.mass_kg
    k_line = 0.5 * s.air_density_kgm3 * s.line_cd * s.line_diameter_m * s.length_m / n_seg / s.mass_kg
    omega = 2 * math.pi * s.yaw_frequency_hz
    vane_gain, vane_damping = s.vane_gain_per_m2, s.vane_damping_per_m
    beta = s.baumgarte_per_s
    length2 = s.length_m**2
    last = hook.shape[0] - 1

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        x = (t - t0_s) * fs_hz
        i = min(max(int(x), 0), last - 1)
        f = min(max(x - i, 0.0), 1.0)
        hk = hook[i] * (1 - f) + hook[i + 1] * f
        wp = wind_payload[i] * (1 - f) + wind_payload[i + 1] * f
        wl = wind_line[i] * (1 - f) + wind_line[i + 1] * f
        hd = heading_rad[i] * (1 - f) + heading_rad[i + 1] * f
        r, rd, psi, psid = y[0:3], y[3:6], y[6], y[7]
        vh, ah = hk[3:6], hk[6:9]
        rel = wp - (vh + rd)
        acc = GRAVITY_ENU + k_payload * math.sqrt(rel @ rel) * rel - ah
        rr = r @ r
        e = r / math.sqrt(rr)
        rel_line = wl - (vh + frac[:, None] * rd)
        normal = rel_line - np.outer(rel_line @ e, e)
        speed_n = np.sqrt(np.einsum("ij,ij->i", normal, normal))
        acc = acc + k_line * ((frac * speed_n)[:, None] * normal).sum(axis=0)
        lam = (r @ acc + rd @ rd) / rr
        stab = (2 * beta * (r @ rd) + beta**2 * (rr - length2)) / rr
        rdd = acc - (lam + stab) * r
        air_from = math.atan2(-rel[0], -rel[1])
        speed_h2 = rel[0] ** 2 + rel[1] ** 2
        vane = vane_gain * speed_h2 * math.sin(air_from - psi) - vane_damping * math.sqrt(speed_h2) * psid
        twist = math.remainder(psi - hd, 2 * math.pi)
        psidd = -omega**2 * twist - 2 * s.yaw_damping_ratio * omega * psid + vane
        return np.concatenate([rd, rdd, [psid, psidd]])

    return rhs


def solve_pendulum(settings: LineSettings, t_forcing_s: np.ndarray, hook: np.ndarray, wind_payload: np.ndarray,
                   wind_line: np.ndarray, heading_rad: np.ndarray, t_out_s: np.ndarray,
                   y0: np.ndarray | None = None, max_step_s: float = 0.1, rtol: float = 1e-4) -> np.ndarray:
    """Integrate the pendulum from rest (hanging straight, facing the drone's heading).

    Parameters
    ----------
    settings : LineSettings
    t_forcing_s : numpy.ndarray
        Regular times of the forcing tables [s].
    hook, wind_payload, wind_line, heading_rad : numpy.ndarray
        Forcing tables (:func:`pendulum_rhs`).
    t_out_s : numpy.ndarray
        Times of the returned states (within ``t_forcing_s``).
    y0 : numpy.ndarray, optional
        Initial state (8,); default at rest under the hook.
    max_step_s : float
        Largest step of the solver (the forcing is linear between samples).
    rtol : float
        Relative tolerance of the solver (1e-4: millimetres on the line's 18 m; the
        absolute tolerance is 1e-6).

    Returns
    -------
    numpy.ndarray
        (len(t_out_s), 8) states.
    """
    fs = 1.0 / float(t_forcing_s[1] - t_forcing_s[0])
    if y0 is None:
        y0 = np.array([0.0, 0.0, -settings.length_m, 0.0, 0.0, 0.0, float(heading_rad[0]), 0.0])
    rhs = pendulum_rhs(settings, float(t_forcing_s[0]), fs, hook, wind_payload, wind_line, heading_rad)
    sol = solve_ivp(rhs, (float(t_out_s[0]), float(t_out_s[-1])), y0, method="RK45", t_eval=t_out_s,
                    rtol=rtol, atol=1e-6, max_step=max_step_s)
    if not sol.success:
        raise RuntimeError(f"pendulum integration failed: {sol.message}")
    return sol.y.T


def body_axes_enu(r_enu: np.ndarray, heading_rad: np.ndarray) -> np.ndarray:
    """Body axes (forward, right, down) in east/north/up of a payload hanging along ``r``.

    Down is the line's direction (hook to payload); forward is the heading's horizontal
    direction made normal to it; right completes the right-handed frame. (n, 3, 3), axes as
    columns.
    """
    down = r_enu / np.linalg.norm(r_enu, axis=1, keepdims=True)
    fwd_h = np.stack([np.sin(heading_rad), np.cos(heading_rad), np.zeros_like(heading_rad)], axis=1)
    fwd = fwd_h - np.einsum("ij,ij->i", fwd_h, down)[:, None] * down
    fwd /= np.linalg.norm(fwd, axis=1, keepdims=True)
    right = np.cross(down, fwd)
    return np.stack([fwd, right, down], axis=2)


ENU_TO_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def euler_deg(axes_enu: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw [degree] of body axes (columns, east/north/up) as the contract's
    R(phi, theta, psi) = Rz(psi) Ry(theta) Rx(phi) (body to NED); yaw in [0, 360). (n, 3)."""
    r = np.einsum("ij,njk->nik", ENU_TO_NED, axes_enu)
    pitch = -np.arcsin(np.clip(r[:, 2, 0], -1.0, 1.0))
    roll = np.arctan2(r[:, 2, 1], r[:, 2, 2])
    yaw = np.arctan2(r[:, 1, 0], r[:, 0, 0])
    return np.stack([np.degrees(roll), np.degrees(pitch), np.degrees(yaw) % 360.0], axis=1)


def body_to_ned(roll_deg: np.ndarray, pitch_deg: np.ndarray, yaw_deg: np.ndarray) -> np.ndarray:
    """R(phi, theta, psi) = Rz(psi) Ry(theta) Rx(phi), (n, 3, 3): the aerospace sequence
    written out (Ghirardelli et al. 2025, Appendix A, as its transpose)."""
    p, t, y = (np.radians(np.asarray(a, dtype=float)) for a in (roll_deg, pitch_deg, yaw_deg))
    cp, sp, ct, st, cy, sy = np.cos(p), np.sin(p), np.cos(t), np.sin(t), np.cos(y), np.sin(y)
    return np.stack([np.stack([cy * ct, cy * st * sp - sy * cp, cy * st * cp + sy * sp], -1),
                     np.stack([sy * ct, sy * st * sp + cy * cp, sy * st * cp - cy * sp], -1),
                     np.stack([-st, ct * sp, ct * cp], -1)], -2)
