r"""Forward flight physics of a quadrotor held in place by its autopilot (the simulator's truth).

The simulators of the quadrotor fleet (:mod:`dronewind.simulate.quadrotor`) and of the wind
tunnel (:mod:`dronewind.simulate.tunnel`) need the attitude a quadrotor takes in a given
relative air velocity. The thrust of a vehicle that holds its position balances gravity
and the aerodynamic drag, so the vehicle leans into the wind:

* ``rayleigh`` drag (Wetz et al. 2021, Eqs. 12-17): :math:`m g \sin\gamma = \tfrac{\rho}{2}
  (c_{d,0}A_0 + c_p\gamma) V^2`, solved for the tilt :math:`\gamma`
  (:func:`rayleigh_tilt_rad`), or a power law per speed range,
  :math:`g\sin\gamma = (V/c_k)^{1/b_k}` (Kistner et al. 2024, Table 2 form; :func:`regime_tilt`);
* body-axis drag (Kistner et al. 2024, Eq. 1): wind accelerations along body x and y from the air
  velocity in the heading frame, solved for roll and pitch (:func:`attitude_from_relative_air`);
* the lean direction and the heading give roll and pitch (:func:`attitude_from_tilt`); in
  weather-vane mode the heading turns into the wind (:func:`weathervane_heading_deg`).

This is the forward direction only (air velocity to attitude), written for the simulator:
the processing chain's inversion (attitude to wind, :mod:`dronewind.quadrotor`) is not
used, so a closed-loop test (simulate, then process) checks that inversion against an
independent model. Gravity is :data:`dronewind.core.constants.GRAVITY_MS2`.

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F. (SWUF-3D), Wetz et al. (2021)
  , Sects. 2, 4.2, Eqs. 9-18, D1.
.. [2] Wind-tunnel calibration and verification of the SWUF-3D quadrotors, Kistner et al. (2024)
  , Eqs. 1-2, Table 2.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from dronewind.core.constants import (
    AIR_DENSITY_KGM3,
    GRAVITY_MS2,
    KISTNER2024_RANGES,
    WETZ2021_AERO,
    WETZ2021_MASS_KG,
)
from dronewind.errors import InputError, ProcessingError

__all__ = ["AirframeDrag", "rayleigh_tilt_rad", "regime_tilt", "attitude_from_tilt",
           "attitude_from_relative_air", "weathervane_heading_deg"]

@dataclass(frozen=True)
class AirframeDrag:
    """Mass and drag of a simulated quadrotor.

    Parameters
    ----------
    law : {"rayleigh", "body_axis"}
        Wetz et al. (2021) Eqs. 12-17 or Kistner et al. (2024) Eq. 1 with speed ranges.
    cd0a0_m2 : float
        :math:`c_{d,0}A_0` [m2] (rayleigh; Wetz et al. (2021), Eq. 18: 0.03).
    cp_m2_per_rad : float
        :math:`c_p` [m2 rad-1], slope of the drag area on the tilt magnitude (rayleigh;
        Wetz et al. (2021), Eq. 18 read on the tilt: -0.047).
    edges_ms : tuple of float
        Upper edges of the longitudinal speed ranges [m s-1] (body_axis); ranges
        (-inf, e1], (e1, e2), [e2, inf).
    b_x, c_x : tuple of float
        Exponent [-] and factor [m s-1 (m s-2)^-b] per range (body_axis).
    b_y, c_y : float
        Lateral exponent and factor (body_axis).
    mass_kg : float
        Vehicle mass [kg].
    rho_kgm3 : float
        Air density [kg m-3].
    """

    law: str = "rayleigh"
    cd0a0_m2: float = WETZ2021_AERO["cd0a0_m2"]
    cp_m2_per_rad: float = WETZ2021_AERO["cp_m2_per_rad"]
    edges_ms: tuple[float, ...] = tuple(KISTNER2024_RANGES["edges_ms"])
    b_x: tuple[float, ...] = tuple(KISTNER2024_RANGES["b_x"])
    c_x: tuple[float, ...] = tuple(KISTNER2024_RANGES["c_x"])
    b_y: float = float(KISTNER2024_RANGES["b_y"])
    c_y: float = float(KISTNER2024_RANGES["c_y"])
    mass_kg: float = WETZ2021_MASS_KG
    rho_kgm3: float = AIR_DENSITY_KGM3

    def __post_init__(self) -> None:
        if self.law not in ("rayleigh", "body_axis"):
            raise InputError("drag law", f"law {self.law!r}; expected 'rayleigh' or 'body_axis'")
        if self.law == "body_axis" and not (len(self.b_x) == len(self.c_x) == len(self.edges_ms) + 1):
            raise InputError("drag law", "body_axis needs len(b_x) == len(c_x) == len(edges_ms) + 1")
        if self.mass_kg <= 0 or self.rho_kgm3 <= 0:
            raise InputError("drag law", "mass_kg and rho_kgm3 must be > 0")

    @classmethod
    def from_settings(cls, d: Mapping[str, Any] | None) -> AirframeDrag:
        """Build from a settings mapping (unknown keys raise InputError)."""
        d = dict(d or {})
        names = set(cls.__dataclass_fields__)
        unknown = set(d) - names
        if unknown:
            raise InputError("drag law", f"unknown key(s) {sorted(unknown)}; allowed {sorted(names)}")
        for k in ("edges_ms", "b_x", "c_x"):
            if k in d:
                d[k] = tuple(float(v) for v in np.atleast_1d(d[k]))
        return cls(**d)


def rayleigh_tilt_rad(speed_ms: np.ndarray, cd0a0_m2: float, cp_m2_per_rad: float,
                      mass_kg: float = 0.65, rho_kgm3: float = 1.2) -> np.ndarray:
    r"""Tilt at which the thrust balances the drag of a relative air speed (Wetz et al. 2021, Eqs. 12-17).

    Parameters
    ----------
    speed_ms : array_like
        Relative air speed [m s-1] (sign carried over to the tilt).
    cd0a0_m2 : float
        Drag area at zero tilt :math:`c_{d,0}A_0` [m2].
    cp_m2_per_rad : float
        Slope of the drag area on the tilt :math:`c_p` [m2 rad-1].
    mass_kg, rho_kgm3 : float
        Mass [kg] and air density [kg m-3].

    Returns
    -------
    numpy.ndarray
        Tilt [rad] that balances the drag.

    Notes
    -----
    Solves :math:`m g\sin\gamma - \tfrac{\rho}{2}(c_{d,0}A_0 + c_p\gamma)V^2 = 0` for
    :math:`\gamma\in[0,\pi/2)` by vectorised Newton iterations from the small-angle
    solution, finished by bisection safeguards (hand-written because scipy's root
    finders are scalar; the arrays have 10^5-10^6 samples). Raises
    :class:`ProcessingError` if a speed exceeds what a 80 degree tilt can balance.
    """
    v = np.asarray(speed_ms, float)
    a = np.abs(v)
    mg = mass_kg * GRAVITY_MS2
    q = 0.5 * rho_kgm3 * a**2

    def f(x):
        return mg * np.sin(x) - q * (cd0a0_m2 + cp_m2_per_rad * x)

    lo = np.zeros_like(a)
    hi = np.full_like(a, np.radians(80.0))
    bad = np.isfinite(a) & (f(hi) < 0)
    if bad.any():
        raise ProcessingError(f"speed {a[bad].max():.3g} m/s cannot be balanced by a tilt "
                              "below 80 degrees with this drag law")
    x = np.clip(q * cd0a0_m2 / np.maximum(mg - q * cp_m2_per_rad, 1e-9), 0.0, hi)
    for _ in range(60):
        fx = f(x)
        lo = np.where(fx < 0, x, lo)
        hi = np.where(fx > 0, x, hi)
        dfx = mg * np.cos(x) - q * cp_m2_per_rad
        step = np.where(dfx > 0, fx / np.where(dfx > 0, dfx, 1.0), np.inf)
        xn = x - step
        outside = ~((xn > lo) & (xn < hi))
        xn = np.where(outside, 0.5 * (lo + hi), xn)
        if np.all(np.abs(xn - x)[np.isfinite(x)] < 1e-16):
            x = xn
            break
        x = xn
    return np.sign(v) * x


def regime_tilt(speed_ms: np.ndarray, regime: list[Mapping]) -> np.ndarray:
    r"""Tilt from a piecewise power drag law (Kistner et al. 2024, Eq. 1 and Table 2, inverted).

    Parameters
    ----------
    speed_ms : array_like
        Relative air speed (>= 0) [m s-1].
    regime : list of mapping
        Ranges ``min_speed_ms``, ``max_speed_ms``, ``b`` [-], ``c`` [m s-1 (m s-2)^-b];
        speeds outside every range use the nearest one.

    Returns
    -------
    numpy.ndarray
        Tilt [rad].

    Notes
    -----
    .. math:: a = (U/c_k)^{1/b_k},\qquad \gamma = \arcsin(a/g)

    with :math:`a` the wind force per unit mass [m s-2].
    """
    u = np.abs(np.asarray(speed_ms, float))
    mids = np.array([0.5 * (r["min_speed_ms"] + r["max_speed_ms"]) for r in regime])
    k = np.zeros(u.shape, dtype=int)
    for j, r in enumerate(regime):
        k = np.where((u >= r["min_speed_ms"]) & (u < r["max_speed_ms"]), j, k)
    inside = np.zeros(u.shape, dtype=bool)
    for r in regime:
        inside |= (u >= r["min_speed_ms"]) & (u < r["max_speed_ms"])
    k = np.where(inside, k, np.argmin(np.abs(u[..., None] - mids), axis=-1))
    b = np.array([r["b"] for r in regime])[k]
    c = np.array([r["c"] for r in regime])[k]
    accel = (u / c) ** (1.0 / b)
    return np.arcsin(np.clip(accel / GRAVITY_MS2, 0.0, 0.99))


def attitude_from_tilt(tilt_rad: np.ndarray, lean_rel_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Roll and pitch that lean the thrust axis by ``tilt`` towards ``lean_rel``.

    Parameters
    ----------
    tilt_rad : array_like
        Tilt [rad], in [0, pi/2).
    lean_rel_rad : array_like
        Lean direction clockwise from the nose [rad].

    Returns
    -------
    roll_rad, pitch_rad : numpy.ndarray
        Attitude [rad] (yaw is the heading, unchanged).

    Notes
    -----
    The upward thrust axis of a body with roll :math:`\phi` and pitch :math:`\theta` is
    :math:`(-\sin\theta\cos\phi,\ \sin\phi,\ \cos\theta\cos\phi)` in the heading frame
    (forward, right, up; third column of Wetz et al. (2021), Eq. D1); setting its horizontal part to
    :math:`\sin\gamma\,(\cos\beta, \sin\beta)` gives

    .. math:: \sin\phi = \sin\gamma\sin\beta,\qquad
              \sin\theta = -\sin\gamma\cos\beta/\cos\phi
    """
    g = np.asarray(tilt_rad, float)
    b = np.asarray(lean_rel_rad, float)
    phi = np.arcsin(np.sin(g) * np.sin(b))
    th = np.arcsin(np.clip(-np.sin(g) * np.cos(b) / np.cos(phi), -1, 1))
    return phi, th


def _inverse_power(x: np.ndarray, b: np.ndarray | float, c: np.ndarray | float) -> np.ndarray:
    return np.sign(x) * (np.abs(x) / c) ** (1.0 / b)


def attitude_from_relative_air(air_fwd_ms: np.ndarray, air_right_ms: np.ndarray, law: AirframeDrag,
                               drag_scale: float = 1.0, n_iter: int = 40) -> tuple[np.ndarray, np.ndarray]:
    r"""Roll and pitch of a UAS whose body-axis drag law balances a relative air velocity.

    Parameters
    ----------
    air_fwd_ms, air_right_ms : array_like
        Horizontal air velocity relative to the UAS in the heading frame [m s-1]
        (a head wind has ``air_fwd_ms < 0``).
    law : AirframeDrag
        ``body_axis`` coefficients (Kistner et al. 2024, Eq. 1, Table 2).
    drag_scale : float
        Factor on the drag force of this UAS (portability, Sect. 3.2.1).
    n_iter : int
        Fixed-point iterations.

    Returns
    -------
    roll_rad, pitch_rad : numpy.ndarray

    Notes
    -----
    Inverts :math:`(a_f, a_r) = R(\phi,\theta,0)_{1:2,1:2}(u, v)` with
    :math:`u = \operatorname{sgn}a_x\,c_x|a_x|^{b_x}`, :math:`a_x = g\sin\theta`,
    :math:`a_y = -g\cos\theta\sin\phi` (Kistner et al. 2024, Eqs. 1-2), iterating
    :math:`v = a_r/\cos\phi`, :math:`u = (a_f - \sin\theta\sin\phi\,v)/\cos\theta`; the
    range :math:`k` is chosen by the head-wind speed :math:`-u`. Converges because the
    coupling terms are second order in the (small) angles.
    """
    af = np.asarray(air_fwd_ms, float)
    ar = np.asarray(air_right_ms, float)
    g = GRAVITY_MS2  # the body-axis law maps accelerations (force per unit mass)
    edges = np.asarray(law.edges_ms)
    bx, cx = np.asarray(law.b_x), np.asarray(law.c_x)
    phi = np.zeros_like(af)
    th = np.zeros_like(af)
    for _ in range(n_iter):
        v = ar / np.cos(phi)
        u = (af - np.sin(th) * np.sin(phi) * v) / np.cos(th)
        head = -u  # ranges (-inf, e1], (e1, e2), [e2, inf) as in Kistner et al. (2024), Table 2
        k = (head > edges[0]).astype(int) + np.sum(head[..., None] >= edges[1:], axis=-1)
        fx = _inverse_power(u, bx[k], cx[k]) * drag_scale
        th = np.arcsin(np.clip(fx / g, -0.95, 0.95))
        fy = _inverse_power(v, law.b_y, law.c_y) * drag_scale
        phi = np.arcsin(np.clip(-fy / (g * np.cos(th)), -0.95, 0.95))
    return phi, th


def weathervane_heading_deg(from_deg: np.ndarray, tilt_rad: np.ndarray, tau_s: float, min_roll_deg: float,
                            fs_hz: float, psi0_deg: float) -> np.ndarray:
    """Heading that turns towards ``from_deg`` (first order) while |roll| > min_roll_deg.

    PX4's weather-vane mode (Wetz et al. 2021, Sect. 2): the nose turns into the wind only while
    the roll exceeds a threshold (1 degree), i.e. while the wind is off the nose.

    Parameters
    ----------
    from_deg : numpy.ndarray
        Direction the relative wind blows from [degree].
    tilt_rad : numpy.ndarray
        Tilt [rad].
    tau_s : float
        Time constant of the turn [s].
    min_roll_deg : float
        Dead band of the roll [degree].
    fs_hz : float
        Sampling rate [Hz].
    psi0_deg : float
        Initial heading [degree].

    Returns
    -------
    numpy.ndarray
        Heading [degree] (not wrapped).

    Notes
    -----

    Hand-written loop: the dead band makes the response state-dependent, which a linear
    filter cannot express.
    """
    n = from_deg.size
    psi = np.empty(n)
    p = psi0_deg
    a = 1.0 - np.exp(-1.0 / (fs_hz * max(tau_s, 1e-9)))
    sin_min = np.sin(np.radians(min_roll_deg))
    st = np.sin(tilt_rad)
    for i in range(n):
        d = (from_deg[i] - p + 180.0) % 360.0 - 180.0
        roll_sin = st[i] * np.sin(np.radians(d))
        if abs(roll_sin) > sin_min:
            p = p + a * d
        psi[i] = p
    return psi
