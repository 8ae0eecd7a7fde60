r"""Wind from the attitude of hovering quadrotors and its calibration against a tower.

The SWUF-3D method (seed 001, Sects. 4-5; seed 002, Sect. 2.1): a quadrotor that holds
its position leans into the wind until the horizontal component of its thrust balances
the aerodynamic drag. Its tilt therefore measures the wind speed, and, in PX4's
weather-vane mode (the nose is yawed into the wind), its yaw measures the direction.

Conventions (``../shared/DESIGN.md``): roll :math:`\phi`, pitch :math:`\theta`, yaw
:math:`\psi` in degrees as logged (PX4: pitch negative nose-down, yaw clockwise from true
north); body-to-NED rotation :math:`R(\phi,\theta,\psi)` of seed 001, Eq. D1. A quadrotor
facing into the wind leans nose-down, so its *tilt* :math:`\gamma = -\theta > 0`.
``pitch_offset_deg`` and ``yaw_offset_deg`` are logged minus true; corrections subtract
them. Wind is returned as speed, direction the wind blows *from*, and east/north
components of the vector the air moves *to*.

Two drag laws are implemented:

``rayleigh`` (seed 001, Eqs. 12-17)
    :math:`m g \sin\gamma = \tfrac{\rho}{2} c_dA(\gamma) V^2`,
    :math:`c_dA = c_{d,0}A_0 + c_p\,\gamma`. Seed 001, Eq. 18 gives
    :math:`c_dA = 0.03 - 0.047\,\theta`; we read its :math:`\theta` as the tilt
    magnitude, i.e. ``cp_m2_per_rad = -0.047`` with :math:`\gamma \ge 0`. The other
    reading (drag area growing with tilt) makes a 10 m/s wind need a 33 degree tilt and
    puts 15 m/s out of reach, while this one gives 11 degrees at 10 m/s and 18 degrees
    at 15 m/s, close to the seed 002 coefficients (Table 2: 10 degrees at 8 m/s).
``body_axis`` (seed 002, Eq. 1 and Table 2)
    body-axis wind accelerations :math:`a_x = F_{w,x}/m = g\sin\theta`,
    :math:`a_y = -g\cos\theta\sin\phi` (seed 001, Eqs. 9-10 at rest; the sign of the
    roll term in the published Eq. 10 is a typo, gravity in the body frame is
    :math:`+mg\cos\theta\sin\phi`), air velocity relative to the vehicle
    :math:`u = \operatorname{sgn}(a_x)\,c_x|a_x|^{b_x}`,
    :math:`v = \operatorname{sgn}(a_y)\,c_y|a_y|^{b_y}`, with :math:`(b_x, c_x)` chosen
    per speed range, rotated to the earth frame with :math:`R`.

GNSS velocity correction (seed 002, Eq. 1): the drag balance gives the air velocity
relative to the vehicle; the wind is that plus the vehicle's GNSS velocity (seed 002
writes a minus sign because its relative-velocity vector is defined the other way).

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F. (SWUF-3D), seed 001
   (``../shared/papers/001_*.txt``), Sects. 4-5, Eqs. 9-18, Tables 2, 3, C1, C2, D1.
.. [2] Wind-tunnel calibration and verification of the SWUF-3D quadrotors, seed 002
   (``../shared/papers/002_*.txt``), Eqs. 1-3, Table 2.
.. [3] Branch, M. A., Coleman, T. F., Li, Y.: A subspace, interior, and conjugate
   gradient method for large-scale bound-constrained minimization problems, SIAM J.
   Sci. Comput. 21, 1-23, 1999 (scipy.optimize.least_squares, method 'trf').
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.optimize
import xarray as xr

from dronewind.errors import InputError, ProcessingError

__all__ = [
    "GRAVITY_MS2", "RHO_KGM3", "MASS_KG", "SEED001_AERO", "SEED002_RANGES",
    "DragLaw", "rotation_body_to_ned", "drag_area_m2", "speed_from_tilt",
    "tilt_from_speed", "tilt_from_attitude", "attitude_from_tilt", "body_accelerations_ms2",
    "body_axis_relative_air", "wind_from_attitude", "hover_segment", "hover_accuracy",
    "flight_windows", "campaign_windows", "uav_wind_dataset", "calibrate_individual",
    "calibrate_universal", "calibrate_fleet_speed_ranges",
    "calibrate_pitch_offsets", "calibrate_yaw_offsets", "calibrate_speed_ranges",
    "predict_windows", "accuracy_table", "calibration_scenarios", "seed001_scenarios",
    "seed001_tables", "calibration_table", "flight_number",
]

#: Gravitational acceleration [m s-2].
GRAVITY_MS2: float = 9.81
#: Air density assumed constant in seed 001, Sect. 4.2 [kg m-3].
RHO_KGM3: float = 1.2
#: Take-off mass of the Holybro QAV250 quadrotor, seed 001 Table 1 [kg].
MASS_KG: float = 0.65
#: Universal aerodynamic parameters of seed 001, Eq. 18 (slope on the tilt, see module doc).
SEED001_AERO: dict[str, float] = {"cd0a0_m2": 0.03, "cp_m2_per_rad": -0.047}
#: Floor of the drag area [m2] (see :func:`speed_from_tilt`).
MIN_DRAG_AREA_M2: float = 1e-4
#: Longitudinal speed-range coefficients of seed 002, Table 2: (upper edge [m s-1], b_x, c_x);
#: lateral (b_y, c_y) = (0.860, 5.600).
SEED002_RANGES: dict[str, object] = {
    "edges_ms": [4.0, 12.0],
    "b_x": [0.784, 0.882, 0.635],
    "c_x": [6.338, 7.604, 8.600],
    "b_y": 0.860,
    "c_y": 5.600,
}


@dataclass(frozen=True)
class DragLaw:
    """Parameters of the drag law that maps tilt to wind speed.

    Parameters
    ----------
    law : {"rayleigh", "body_axis"}
        Seed 001 Eqs. 12-17 or seed 002 Eq. 1 with speed ranges (see module doc).
    cd0a0_m2 : float
        :math:`c_{d,0}A_0` [m2] (rayleigh).
    cp_m2_per_rad : float
        :math:`c_p` [m2 rad-1], slope of :math:`c_dA` on the tilt (rayleigh).
    edges_ms : tuple of float
        Upper edges of the longitudinal speed ranges [m s-1] (body_axis); ranges are
        (-inf, e1], (e1, e2), [e2, inf) as in seed 002, Table 2.
    b_x, c_x : tuple of float
        Exponent [-] and factor [m s-1 N^-b] per range (body_axis).
    b_y, c_y : float
        Lateral exponent and factor (body_axis).
    mass_kg : float
        Vehicle mass [kg].
    rho_kgm3 : float
        Air density [kg m-3].
    """

    law: str = "rayleigh"
    cd0a0_m2: float = SEED001_AERO["cd0a0_m2"]
    cp_m2_per_rad: float = SEED001_AERO["cp_m2_per_rad"]
    edges_ms: tuple[float, ...] = tuple(SEED002_RANGES["edges_ms"])  # type: ignore[arg-type]
    b_x: tuple[float, ...] = tuple(SEED002_RANGES["b_x"])  # type: ignore[arg-type]
    c_x: tuple[float, ...] = tuple(SEED002_RANGES["c_x"])  # type: ignore[arg-type]
    b_y: float = float(SEED002_RANGES["b_y"])  # type: ignore[arg-type]
    c_y: float = float(SEED002_RANGES["c_y"])  # type: ignore[arg-type]
    mass_kg: float = MASS_KG
    rho_kgm3: float = RHO_KGM3

    def __post_init__(self) -> None:
        if self.law not in ("rayleigh", "body_axis"):
            raise InputError("drag law", f"law {self.law!r}; expected 'rayleigh' or 'body_axis'")
        if self.law == "body_axis" and not (len(self.b_x) == len(self.c_x) == len(self.edges_ms) + 1):
            raise InputError("drag law", "body_axis needs len(b_x) == len(c_x) == len(edges_ms) + 1")
        if self.mass_kg <= 0 or self.rho_kgm3 <= 0:
            raise InputError("drag law", "mass_kg and rho_kgm3 must be > 0")

    @classmethod
    def from_dict(cls, d: Mapping | None) -> DragLaw:
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


# --------------------------------------------------------------------------------------
# Rotation and drag balance
# --------------------------------------------------------------------------------------

def rotation_body_to_ned(roll_rad: np.ndarray, pitch_rad: np.ndarray,
                         yaw_rad: np.ndarray) -> np.ndarray:
    r"""Body-to-NED rotation matrix :math:`R(\phi,\theta,\psi)` (seed 001, Eq. D1).

    Parameters
    ----------
    roll_rad, pitch_rad, yaw_rad : array_like
        Euler angles [rad], broadcastable.

    Returns
    -------
    numpy.ndarray
        Shape ``(..., 3, 3)``.

    Notes
    -----
    .. math::
        R = \begin{bmatrix}
        c_\theta c_\psi & c_\psi s_\theta s_\phi - c_\phi s_\psi & c_\psi s_\theta c_\phi + s_\phi s_\psi\\
        c_\theta s_\psi & c_\phi c_\psi + s_\theta s_\phi s_\psi & -s_\phi c_\psi + s_\theta c_\phi s_\psi\\
        -s_\theta & c_\theta s_\phi & c_\theta c_\phi \end{bmatrix}

    (Seed 002, Eq. 2 prints :math:`\cos\theta\sin\phi` in row 2, column 1: a typo.)
    """
    phi, th, psi = np.broadcast_arrays(np.asarray(roll_rad, float), np.asarray(pitch_rad, float),
                                       np.asarray(yaw_rad, float))
    cf, sf, ct, st, cp, sp = np.cos(phi), np.sin(phi), np.cos(th), np.sin(th), np.cos(psi), np.sin(psi)
    r = np.empty(phi.shape + (3, 3))
    r[..., 0, 0] = ct * cp
    r[..., 0, 1] = cp * st * sf - cf * sp
    r[..., 0, 2] = cp * st * cf + sf * sp
    r[..., 1, 0] = ct * sp
    r[..., 1, 1] = cf * cp + st * sf * sp
    r[..., 1, 2] = -sf * cp + st * cf * sp
    r[..., 2, 0] = -st
    r[..., 2, 1] = ct * sf
    r[..., 2, 2] = ct * cf
    return r


def drag_area_m2(tilt_rad: np.ndarray, cd0a0_m2: float, cp_m2_per_rad: float) -> np.ndarray:
    r"""Drag area as a function of tilt (seed 001, Eqs. 16-17).

    Parameters
    ----------
    tilt_rad : array_like
        Tilt :math:`\gamma = -\theta` [rad] (its magnitude is used).
    cd0a0_m2 : float
        :math:`c_{d,0}A_0` [m2].
    cp_m2_per_rad : float
        :math:`c_p` [m2 rad-1].

    Returns
    -------
    numpy.ndarray
        :math:`c_dA` [m2].

    Notes
    -----
    .. math:: c_dA = c_{d,0}A_0 + c_p\,|\gamma|
    """
    return cd0a0_m2 + cp_m2_per_rad * np.abs(np.asarray(tilt_rad, float))


def speed_from_tilt(tilt_rad: np.ndarray, cd0a0_m2: float, cp_m2_per_rad: float,
                    mass_kg: float = MASS_KG, rho_kgm3: float = RHO_KGM3) -> np.ndarray:
    r"""Wind speed from tilt by the drag balance (seed 001, Eqs. 12-17).

    Parameters
    ----------
    tilt_rad : array_like
        Tilt into the wind [rad]; negative means leaning away (tail wind), giving a
        negative speed.
    cd0a0_m2, cp_m2_per_rad : float
        Drag-area parameters (Eq. 17).
    mass_kg, rho_kgm3 : float
        Mass [kg] and air density [kg m-3].

    Returns
    -------
    numpy.ndarray
        Signed relative air speed along the lean direction [m s-1].

    Notes
    -----
    .. math:: V = \operatorname{sgn}\gamma\sqrt{\frac{2 m g |\sin\gamma|}{\rho\, c_dA(\gamma)}}

    :math:`c_dA` is floored at :data:`MIN_DRAG_AREA_M2` (a linear law can cross zero at
    large tilt; the floor keeps the calibration's residuals finite and large there).
    """
    g = np.asarray(tilt_rad, float)
    cda = np.maximum(drag_area_m2(g, cd0a0_m2, cp_m2_per_rad), MIN_DRAG_AREA_M2)
    v2 = 2.0 * mass_kg * GRAVITY_MS2 * np.abs(np.sin(g)) / (rho_kgm3 * cda)
    return np.sign(g) * np.sqrt(v2)


def tilt_from_speed(speed_ms: np.ndarray, cd0a0_m2: float, cp_m2_per_rad: float,
                    mass_kg: float = MASS_KG, rho_kgm3: float = RHO_KGM3) -> np.ndarray:
    r"""Tilt that balances the drag of a given relative air speed (inverse of Eqs. 12-17).

    Parameters
    ----------
    speed_ms : array_like
        Relative air speed [m s-1] (sign carried over to the tilt).
    cd0a0_m2, cp_m2_per_rad, mass_kg, rho_kgm3 : float
        As in :func:`speed_from_tilt`.

    Returns
    -------
    numpy.ndarray
        Tilt [rad] with ``speed_from_tilt(tilt) == speed`` to rounding.

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


def tilt_from_attitude(roll_rad: np.ndarray, pitch_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Tilt angle and lean direction relative to the nose from roll and pitch.

    Parameters
    ----------
    roll_rad, pitch_rad : array_like
        Roll and pitch [rad].

    Returns
    -------
    tilt_rad : numpy.ndarray
        Angle between the thrust axis and the vertical [rad], >= 0.
    lean_rel_rad : numpy.ndarray
        Direction the thrust axis leans to, clockwise from the nose [rad] (0: nose-down).

    Notes
    -----
    The upward thrust axis :math:`-b_3` in the heading frame (forward, right, up) is
    :math:`(-\sin\theta\cos\phi,\ \sin\phi,\ \cos\theta\cos\phi)` (third column of
    :math:`R`, seed 001 Eq. D1, with :math:`\psi=0`), so
    :math:`\gamma = \operatorname{atan2}(\sqrt{f^2+r^2},\,\cos\theta\cos\phi)` (atan2
    rather than arccos for accuracy at small tilt).
    """
    phi = np.asarray(roll_rad, float)
    th = np.asarray(pitch_rad, float)
    fwd = -np.sin(th) * np.cos(phi)
    right = np.sin(phi)
    tilt = np.arctan2(np.hypot(fwd, right), np.cos(th) * np.cos(phi))
    return tilt, np.arctan2(right, fwd)


def attitude_from_tilt(tilt_rad: np.ndarray, lean_rel_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Roll and pitch that lean the thrust axis by ``tilt`` towards ``lean_rel`` (inverse of
    :func:`tilt_from_attitude`).

    Parameters
    ----------
    tilt_rad : array_like
        Tilt [rad], in [0, pi/2).
    lean_rel_rad : array_like
        Lean direction clockwise from the nose [rad].

    Returns
    -------
    roll_rad, pitch_rad : numpy.ndarray

    Notes
    -----
    .. math:: \sin\phi = \sin\gamma\sin\beta,\qquad
              \sin\theta = -\sin\gamma\cos\beta/\cos\phi
    """
    g = np.asarray(tilt_rad, float)
    b = np.asarray(lean_rel_rad, float)
    phi = np.arcsin(np.sin(g) * np.sin(b))
    th = np.arcsin(np.clip(-np.sin(g) * np.cos(b) / np.cos(phi), -1, 1))
    return phi, th


def body_accelerations_ms2(roll_rad: np.ndarray, pitch_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Horizontal body-axis wind accelerations of a vehicle at rest (seed 001, Eqs. 9-10, 13).

    Parameters
    ----------
    roll_rad, pitch_rad : array_like
        Roll and pitch [rad].

    Returns
    -------
    ax_ms2, ay_ms2 : numpy.ndarray
        Wind force per unit mass along body x (forward) and y (right) [m s-2]: the
        "accelerations measured by the autopilot's avionics" that seed 002 (Sect. 3.1)
        relates to the wind speed.

    Notes
    -----
    .. math:: a_x = F_{w,x}/m = g\sin\theta,\qquad a_y = F_{w,y}/m = -g\cos\theta\sin\phi
    """
    th = np.asarray(pitch_rad, float)
    phi = np.asarray(roll_rad, float)
    return GRAVITY_MS2 * np.sin(th), -GRAVITY_MS2 * np.cos(th) * np.sin(phi)


def _power(f: np.ndarray, b, c) -> np.ndarray:
    return np.sign(f) * c * np.abs(f) ** b


def body_axis_relative_air(ax_ms2: np.ndarray, ay_ms2: np.ndarray,
                           law: DragLaw) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Air velocity relative to the vehicle in body axes from the wind forces (seed 002, Eq. 1).

    Parameters
    ----------
    ax_ms2, ay_ms2 : array_like
        Body-axis wind accelerations [m s-2] (:func:`body_accelerations_ms2`).
    law : DragLaw
        ``law="body_axis"`` coefficients.

    Returns
    -------
    u_ms, v_ms : numpy.ndarray
        Relative air velocity along body x and y [m s-1].
    range_index : numpy.ndarray of int
        Longitudinal speed range used per sample.

    Notes
    -----
    .. math:: u = \operatorname{sgn}(a_x)\,c_{x,k}|a_x|^{b_{x,k}},\qquad
              v = \operatorname{sgn}(a_y)\,c_y|a_y|^{b_y}

    with :math:`a` in m s-2 (the coefficients of seed 002, Table 2 are for accelerations;
    with forces in N they would need 36 degree of tilt at 16 m/s).

    The range :math:`k` is chosen by the acceleration: range :math:`k` ends where its
    own law reaches the range's upper speed edge, :math:`|a_k| = (e_k/c_k)^{1/b_k}`, and
    :math:`k` is the number of such thresholds :math:`|a_x|` exceeds (for head wind;
    tail wind, :math:`a_x > 0`, uses the first range, whose interval in Table 2 of seed
    002 extends to -18 m/s). Table 2 is not continuous at the edges, so the speed jumps
    slightly where the range changes.
    """
    fx = np.asarray(ax_ms2, float)
    fy = np.asarray(ay_ms2, float)
    edges = np.asarray(law.edges_ms, float)
    bx = np.asarray(law.b_x, float)
    cx = np.asarray(law.c_x, float)
    thresholds = (edges / cx[:-1]) ** (1.0 / bx[:-1])
    head = -fx  # positive for a head wind (nose down)
    idx = np.sum(head[..., None] > thresholds, axis=-1) if thresholds.size else np.zeros(fx.shape, int)
    idx = np.where(head > 0, idx, 0)
    u = _power(fx, bx[idx], cx[idx])
    v = _power(fy, law.b_y, law.c_y)
    return u, v, idx


def wind_from_attitude(roll_deg, pitch_deg, yaw_deg, vel_n_ms=0.0, vel_e_ms=0.0,
                       law: DragLaw | None = None, pitch_offset_deg: float = 0.0,
                       yaw_offset_deg: float = 0.0, method: str = "tilt",
                       roll_offset_deg: float = 0.0) -> dict[str, np.ndarray]:
    r"""Horizontal wind from the attitude of a hovering quadrotor.

    Parameters
    ----------
    roll_deg, pitch_deg, yaw_deg : array_like
        Attitude as logged [degree].
    vel_n_ms, vel_e_ms : array_like
        GNSS velocity of the vehicle [m s-1] (seed 002, Eq. 1 correction).
    law : DragLaw, optional
        Drag law (default: rayleigh with seed 001, Eq. 18).
    pitch_offset_deg, yaw_offset_deg : float
        Logged minus true pitch and yaw [degree]; subtracted before use.
    roll_offset_deg : float
        Logged minus true roll [degree] (accelerometer offset, seed 002 Sect. 3.2.1).
    method : {"tilt", "pitch", "body_axis"}
        ``pitch``: seed 001, Eq. 13 literally (pitch only, direction = corrected yaw);
        ``tilt``: the same balance on the total tilt from roll and pitch, direction from
        the lean direction (equal to ``pitch`` when the roll is zero); ``body_axis``:
        seed 002, Eq. 1 (forces law must be ``body_axis``).

    Returns
    -------
    dict of numpy.ndarray
        ``speed_ms``, ``wind_from_deg`` (0-360, from the corrected wind vector),
        ``u_east_ms``, ``v_north_ms`` (the air moves towards), ``relative_speed_ms``
        (speed from the drag balance alone, before the GNSS correction), ``yaw_from_deg``
        (corrected yaw, the weather-vane direction estimate, seed 001 Sect. 5.4).

    Notes
    -----
    Seed 001, Eqs. 12-17 (``pitch``/``tilt``):

    .. math:: V_{rel} = \sqrt{\frac{2 m g\sin\gamma}{\rho\,(c_{d,0}A_0+c_p\gamma)}},\qquad
              \mathbf{V} = -V_{rel}\,\hat{\mathbf{e}}(\psi_{lean}) + \dot{\mathbf{x}}_{gnss}

    where :math:`\hat{\mathbf{e}}(\psi_{lean})` is the horizontal unit vector towards
    which the vehicle leans (into the wind). Seed 002, Eq. 1 (``body_axis``):
    :math:`\mathbf{V} = R\,(u, v, 0)^T + \dot{\mathbf{x}}_{gnss}`, horizontal rows.
    """
    law = law or DragLaw()
    phi = np.radians(np.asarray(roll_deg, float) - roll_offset_deg)
    th = np.radians(np.asarray(pitch_deg, float) - pitch_offset_deg)
    psi = np.radians(np.asarray(yaw_deg, float) - yaw_offset_deg)
    vn = np.asarray(vel_n_ms, float)
    ve = np.asarray(vel_e_ms, float)
    if method in ("tilt", "pitch"):
        if law.law != "rayleigh":
            raise InputError("wind_from_attitude", f"method {method!r} needs law 'rayleigh'")
        if method == "tilt":
            tilt, lean_rel = tilt_from_attitude(phi, th)
            lean = psi + lean_rel
        else:
            tilt, lean = -th, psi
        vrel = speed_from_tilt(tilt, law.cd0a0_m2, law.cp_m2_per_rad, law.mass_kg, law.rho_kgm3)
        air_n = -vrel * np.cos(lean)
        air_e = -vrel * np.sin(lean)
    elif method == "body_axis":
        if law.law != "body_axis":
            raise InputError("wind_from_attitude", "method 'body_axis' needs law 'body_axis'")
        ax, ay = body_accelerations_ms2(phi, th)
        u, v, _ = body_axis_relative_air(ax, ay, law)
        r = rotation_body_to_ned(phi, th, psi)
        air_n = r[..., 0, 0] * u + r[..., 0, 1] * v
        air_e = r[..., 1, 0] * u + r[..., 1, 1] * v
        vrel = np.hypot(air_n, air_e)
    else:
        raise InputError("wind_from_attitude", f"method {method!r}; expected tilt, pitch or body_axis")
    wn = air_n + vn
    we = air_e + ve
    return {
        "speed_ms": np.hypot(wn, we),
        "wind_from_deg": np.degrees(np.arctan2(-we, -wn)) % 360.0,
        "u_east_ms": we,
        "v_north_ms": wn,
        "relative_speed_ms": np.asarray(vrel, float),
        "yaw_from_deg": np.degrees(psi) % 360.0,
    }


# --------------------------------------------------------------------------------------
# Hover state
# --------------------------------------------------------------------------------------

def _longest_run(mask: np.ndarray) -> tuple[int, int]:
    """Start and stop (exclusive) of the longest run of True values (0, 0 if none)."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    starts = np.flatnonzero(d == 1)
    stops = np.flatnonzero(d == -1)
    if starts.size == 0:
        return 0, 0
    k = int(np.argmax(stops - starts))
    return int(starts[k]), int(stops[k])


def _close_gaps(mask: np.ndarray, max_gap: int) -> np.ndarray:
    """Fill False gaps of at most ``max_gap`` samples between True samples."""
    if max_gap <= 0 or not mask.any():
        return mask
    m = mask.copy()
    idx = np.flatnonzero(mask)
    gaps = np.diff(idx) - 1
    for i in np.flatnonzero((gaps > 0) & (gaps <= max_gap)):
        m[idx[i] + 1: idx[i + 1]] = True
    return m


def _local_en_m(lat_deg, lon_deg, lat0, lon0):
    r = 6_371_000.0
    north = np.radians(lat_deg - lat0) * r
    east = np.radians(lon_deg - lon0) * r * np.cos(np.radians(lat0))
    return east, north


def hover_segment(ds: xr.Dataset, horiz_tol_m: float = 4.0, alt_tol_m: float = 3.0,
                  max_speed_ms: float = 1.5, max_gap_s: float = 2.0,
                  min_duration_s: float = 60.0, where: str = "quadrotor log") -> tuple[np.ndarray, dict]:
    r"""Select the hover state of a quadrotor flight (seed 001, Sect. 4.3).

    Parameters
    ----------
    ds : xarray.Dataset
        Quadrotor log (:func:`dronewind.quadrotor.io.read_quadrotor`).
    horiz_tol_m, alt_tol_m : float
        Largest horizontal / vertical distance from the hover position [m].
    max_speed_ms : float
        Largest horizontal and vertical GNSS speed while hovering [m s-1].
    max_gap_s : float
        Excursions shorter than this inside the hover are kept [s].
    min_duration_s : float
        Shortest acceptable hover [s].
    where : str
        Name used in error messages (file or UAV id).

    Returns
    -------
    mask : numpy.ndarray of bool
        True inside the hover segment (the longest contiguous run).
    info : dict
        ``start``, ``end`` (datetime64), ``duration_s``, ``lat_deg``, ``lon_deg``,
        ``alt_m`` (median hover position), ``sigma_h_m``, ``sigma_v_m`` (see
        :func:`hover_accuracy`), ``n_hover``, ``n_excluded`` (samples outside the hover).

    Raises
    ------
    InputError
        If the vehicle never hovers (no still sample, or the longest hover is shorter than
        ``min_duration_s``).
    """
    t = ds["time"].to_numpy()
    n = t.size
    vn, ve, vd = (ds[k].to_numpy() for k in ("vel_n_ms", "vel_e_ms", "vel_d_ms"))
    lat, lon, alt = (ds[k].to_numpy() for k in ("lat_deg", "lon_deg", "alt_m"))
    still = (np.hypot(vn, ve) < max_speed_ms) & (np.abs(vd) < max_speed_ms) & np.isfinite(lat) \
        & np.isfinite(alt)
    if not still.any():
        raise InputError(where, "the UAV never hovers: no sample with GNSS speed below "
                                f"{max_speed_ms} m/s and a valid position")
    lat0, lon0, alt0 = (float(np.median(x[still])) for x in (lat, lon, alt))
    east, north = _local_en_m(lat, lon, lat0, lon0)
    inbox = still & (np.hypot(east, north) <= horiz_tol_m) & (np.abs(alt - alt0) <= alt_tol_m)
    fs = float(ds.attrs.get("sampling_rate_hz") or (1e9 / np.median(np.diff(t.astype("int64")))))
    inbox = _close_gaps(inbox, int(round(max_gap_s * fs)))
    i0, i1 = _longest_run(inbox)
    duration = (t[i1 - 1] - t[i0]).astype("int64") / 1e9 if i1 > i0 else 0.0
    if duration < min_duration_s:
        raise InputError(where, f"the UAV never hovers: longest hover {duration:.0f} s within "
                                f"{horiz_tol_m} m horizontally and {alt_tol_m} m vertically; "
                                f"at least {min_duration_s:.0f} s expected")
    mask = np.zeros(n, dtype=bool)
    mask[i0:i1] = True
    acc = hover_accuracy(ds, mask)
    info = {"start": t[i0], "end": t[i1 - 1], "duration_s": float(duration),
            "lat_deg": float(np.nanmedian(lat[mask])), "lon_deg": float(np.nanmedian(lon[mask])),
            "alt_m": float(np.nanmedian(alt[mask])), "n_hover": int(mask.sum()),
            "n_excluded": int(n - mask.sum()), **acc}
    return mask, info


def hover_accuracy(ds: xr.Dataset, mask: np.ndarray) -> dict[str, float]:
    r"""Position standard deviations during hover (seed 001, Sect. 4.3).

    Parameters
    ----------
    ds : xarray.Dataset
        Quadrotor log with ``lat_deg``, ``lon_deg``, ``alt_m``.
    mask : numpy.ndarray of bool
        Hover samples.

    Returns
    -------
    dict
        ``sigma_h_m``: horizontal standard deviation per axis,
        :math:`\sqrt{(\sigma_E^2+\sigma_N^2)/2}` [m] (seed 001 reports 0.19 m);
        ``sigma_v_m``: vertical standard deviation [m] (seed 001: 0.85 m).
    """
    lat = ds["lat_deg"].to_numpy()[mask]
    lon = ds["lon_deg"].to_numpy()[mask]
    alt = ds["alt_m"].to_numpy()[mask]
    e, nn = _local_en_m(lat, lon, np.nanmedian(lat), np.nanmedian(lon))
    return {"sigma_h_m": float(np.sqrt(0.5 * (np.nanvar(e) + np.nanvar(nn)))),
            "sigma_v_m": float(np.nanstd(alt))}


# --------------------------------------------------------------------------------------
# Windows (10-min / 2-min averages) and the calibration data set
# --------------------------------------------------------------------------------------

def _circmean_deg(angles_deg: np.ndarray, weights: np.ndarray | None = None) -> float:
    a = np.radians(np.asarray(angles_deg, float))
    w = np.ones_like(a) if weights is None else np.asarray(weights, float)
    ok = np.isfinite(a) & np.isfinite(w)
    if not ok.any():
        return float("nan")
    return float(np.degrees(np.arctan2(np.sum(w[ok] * np.sin(a[ok])),
                                       np.sum(w[ok] * np.cos(a[ok])))) % 360.0)


def flight_windows(ds: xr.Dataset, reference: xr.Dataset, site_altitude_m: float,
                   flight: str, uav: str, window_s: float = 600.0, block_s: float = 1.0,
                   height_tol_m: float = 5.0, min_coverage: float = 0.8,
                   hover_kwargs: Mapping | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    r"""Cut a UAV's hover into averaging windows and pair each with the tower reference.

    Parameters
    ----------
    ds : xarray.Dataset
        Quadrotor log (:func:`dronewind.quadrotor.io.read_quadrotor`).
    reference : xarray.Dataset
        Tower reference (:func:`dronewind.quadrotor.io.read_tower_reference`).
    site_altitude_m : float
        Ground altitude above MSL [m]; height above ground is ``alt_m - site_altitude_m``.
    flight, uav : str
        Identifiers stored in the tables.
    window_s : float
        Averaging time [s]: 600 (seed 001, Sect. 5) or 120 (Appendix C). The hover is cut
        into ``floor(duration / window_s)`` windows; a hover shorter than one window but
        at least half of it gives one window over the whole hover.
    block_s : float
        The attitude is averaged in blocks of this length [s] before the (non-linear)
        wind computation; the wind of a window is the mean over its blocks.
    height_tol_m : float
        Largest difference between hover height and the nearest reference height [m].
    min_coverage : float
        Smallest fraction of the expected reference records inside a window.
    hover_kwargs : mapping, optional
        Passed to :func:`hover_segment`.

    Returns
    -------
    blocks : pandas.DataFrame
        One row per block: ``window_key``, ``roll_deg``, ``pitch_deg``, ``yaw_deg``
        (circular mean), ``vel_n_ms``, ``vel_e_ms``.
    windows : pandas.DataFrame
        One row per window: ``window_key`` (``flight/uav/k``), ``flight``, ``uav``,
        ``window``, ``start``, ``end``, ``height_m``, ``ref_height_m``, ``ref_speed_ms``
        (scalar mean), ``ref_from_deg`` (speed-weighted vector mean), ``n_blocks``,
        ``n_blocks_nan`` (blocks left out for a missing value), ``n_ref``, ``sigma_h_m``, ``sigma_v_m``, ``hover_s``, ``n_dropped_s`` (hover
        seconds outside any window).

    Raises
    ------
    InputError
        UAV never hovers; no reference height within ``height_tol_m``; reference not
        covering a window.
    """
    where = f"flight {flight}, uav {uav}"
    mask, info = hover_segment(ds, where=where, **dict(hover_kwargs or {}))
    height = info["alt_m"] - site_altitude_m
    ref_h = reference["height_m"].to_numpy()
    k_h = int(np.argmin(np.abs(ref_h - height)))
    if abs(ref_h[k_h] - height) > height_tol_m:
        raise InputError(f"{reference.attrs.get('source_file', 'tower reference')} [height_m]",
                         f"{where}: no reference height within {height_tol_m} m of the hover "
                         f"height {height:.1f} m (available {list(np.round(ref_h, 1))})")
    ref = reference.isel(height=k_h)
    dur = info["duration_s"]
    n_win = int(dur // window_s)
    if n_win == 0 and dur >= 0.5 * window_s:
        edges = [info["start"], info["end"] + np.timedelta64(1, "ns")]
    elif n_win == 0:
        raise InputError(where, f"hover of {dur:.0f} s is shorter than half the averaging "
                                f"window ({window_s:.0f} s)")
    else:
        step = np.timedelta64(int(round(window_s * 1e9)), "ns")
        edges = [info["start"] + k * step for k in range(n_win + 1)]
    t = ds["time"].to_numpy()
    ref_t = ref["time"].to_numpy()
    ref_sp = ref["wind_speed_ms"].to_numpy()
    ref_dir = ref["wind_from_deg"].to_numpy()
    interval = float(reference.attrs.get("sampling_interval_s") or 60.0)
    blocks_out, windows_out = [], []
    for k in range(len(edges) - 1):
        key = f"{flight}/{uav}/{k}"
        t0, t1 = edges[k], edges[k + 1]
        inw = mask & (t >= t0) & (t < t1)
        rsel = (ref_t >= t0) & (ref_t < t1) & np.isfinite(ref_sp)
        expected = max(1, int(round((t1 - t0).astype("int64") / 1e9 / interval)))
        if rsel.sum() < min_coverage * expected:
            raise InputError(f"{reference.attrs.get('source_file', 'tower reference')}",
                             f"{where}: the reference does not cover window {k} "
                             f"({np.datetime_as_string(t0, 's')}Z to "
                             f"{np.datetime_as_string(t1, 's')}Z): {int(rsel.sum())} of "
                             f"{expected} records at {ref_h[k_h]:g} m")
        sub = ds.isel(time=np.flatnonzero(inw))
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
        g["window_key"] = key
        blocks_out.append(g.reset_index(drop=True))
        windows_out.append({
            "window_key": key, "flight": flight, "uav": uav, "window": k,
            "start": t0, "end": t1, "height_m": height, "ref_height_m": float(ref_h[k_h]),
            "ref_speed_ms": float(np.mean(ref_sp[rsel])),
            "ref_from_deg": _circmean_deg(ref_dir[rsel], ref_sp[rsel]),
            "n_blocks": len(g), "n_blocks_nan": n_all_blocks - len(g), "n_ref": int(rsel.sum()),
            "sigma_h_m": info["sigma_h_m"], "sigma_v_m": info["sigma_v_m"],
            "hover_s": dur,
            "n_dropped_s": float(dur - (edges[-1] - edges[0]).astype("int64") / 1e9) if n_win else 0.0,
        })
    blocks = pd.concat(blocks_out, ignore_index=True)
    return blocks, pd.DataFrame(windows_out)


# --------------------------------------------------------------------------------------
# Calibration (seed 001, Sect. 5; seed 002, Sect. 3.1)
# --------------------------------------------------------------------------------------

#: Physical bounds of the calibration parameters (Sect. 5.1: "bounds were chosen in order
#: to guideline the minimization in physical plausible values").
BOUNDS: dict[str, tuple[float, float]] = {
    "cd0a0_m2": (0.003, 0.2),
    "cp_m2_per_rad": (-0.2, 0.2),
    "pitch_offset_deg": (-10.0, 10.0),
}


class _Data:
    """Blocks and windows as arrays, for fast repeated model evaluation."""

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

    def speed(self, law: DragLaw, pitch_offset_deg: np.ndarray | float, method: str,
              signed: bool = False) -> np.ndarray:
        """Window-mean wind speed [m s-1].

        ``signed``: the speed of a block is negative when the wind comes from behind the
        nose (negative head-wind component). Under weather-vane mode that only happens
        with a wrong pitch offset, so the calibration uses it to rule out the mirror
        solution (tilt reflected through zero gives the same unsigned speed).
        """
        w = wind_from_attitude(self.roll, self.pitch, self.yaw, self.vn, self.ve, law=law,
                               pitch_offset_deg=pitch_offset_deg, method=method)
        sp = w["speed_ms"]
        if signed:
            psi = np.radians(self.yaw)
            head = -(w["v_north_ms"] * np.cos(psi) + w["u_east_ms"] * np.sin(psi))
            sp = np.where(head < 0, -sp, sp)
        s = np.bincount(self.win, weights=sp, minlength=self.nwin)
        with np.errstate(invalid="ignore", divide="ignore"):
            return s / self.count


def _subset(blocks: pd.DataFrame, windows: pd.DataFrame, flights: Iterable[str] | None,
            uavs: Iterable[str] | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    w = windows
    if flights is not None:
        w = w[w["flight"].astype(str).isin([str(f) for f in flights])]
    if uavs is not None:
        w = w[w["uav"].astype(str).isin([str(u) for u in uavs])]
    b = blocks[blocks["window_key"].isin(w["window_key"])]
    return b, w.reset_index(drop=True)


def _param_se(res, n_obs: int) -> np.ndarray:
    """Standard errors from the Jacobian at the optimum (Gauss-Newton covariance)."""
    n_par = res.x.size
    dof = n_obs - n_par
    if dof <= 0:
        return np.full(n_par, np.nan)
    s2 = 2.0 * res.cost / dof
    try:
        cov = np.linalg.pinv(res.jac.T @ res.jac) * s2
    except np.linalg.LinAlgError:
        return np.full(n_par, np.nan)
    return np.sqrt(np.clip(np.diag(cov), 0, None))


def _solve(fun, x0, lo, hi, where: str):
    x0 = np.clip(np.asarray(x0, float), np.asarray(lo) + 1e-9, np.asarray(hi) - 1e-9)
    res = scipy.optimize.least_squares(fun, x0, bounds=(lo, hi), method="trf",
                                       x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12,
                                       max_nfev=2000)
    at_bound = np.isclose(res.x, lo, rtol=0, atol=1e-6) | np.isclose(res.x, hi, rtol=0, atol=1e-6)
    converged = bool(res.success and res.status > 0 and np.all(np.isfinite(res.fun)))
    return res, converged, at_bound


def calibrate_individual(blocks: pd.DataFrame, windows: pd.DataFrame,
                         flights: Iterable[str] | None = None, method: str = "tilt",
                         mass_kg: float = MASS_KG, rho_kgm3: float = RHO_KGM3,
                         bounds: Mapping[str, tuple[float, float]] | None = None) -> pd.DataFrame:
    r"""Calibrate :math:`c_{d,0}A_0`, :math:`c_p` and :math:`\Delta\theta` per UAV (seed 001, Sect. 5.1).

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        Output of :func:`flight_windows`, concatenated over flights and UAVs.
    flights : iterable of str, optional
        Calibration flights (default all).
    method : {"tilt", "pitch"}
        See :func:`wind_from_attitude`.
    mass_kg, rho_kgm3 : float
        Vehicle mass [kg] and air density [kg m-3].
    bounds : mapping, optional
        Parameter bounds (default :data:`BOUNDS`).

    Returns
    -------
    pandas.DataFrame
        One row per UAV: ``uav``, ``cd0a0_m2``, ``cp_m2_per_rad``, ``pitch_offset_deg``,
        their standard errors ``*_se``, ``n_windows``, ``converged`` (bool), ``at_bound``
        (a parameter ended on a bound), ``cost``, ``status`` (text).

    Notes
    -----
    Minimises :math:`\sum_j (\bar V_j - \bar V_{ref,j})^2` over the UAV's windows
    :math:`j` with ``scipy.optimize.least_squares(method="trf")`` inside physical bounds
    (seed 001, Sect. 5.1: Trust Region Reflective, Branch et al. 1999). UAVs with fewer
    than 3 windows are not fitted (``status = "too few windows"``).
    """
    bd = {**BOUNDS, **dict(bounds or {})}
    b, w = _subset(blocks, windows, flights)
    rows = []
    names = ("cd0a0_m2", "cp_m2_per_rad", "pitch_offset_deg")
    lo = [bd[k][0] for k in names]
    hi = [bd[k][1] for k in names]
    for uav in sorted(w["uav"].astype(str).unique()):
        bu, wu = _subset(b, w, None, [uav])
        row = {"uav": uav, "n_windows": len(wu)}
        if len(wu) < 3:
            rows.append({**row, **{k: np.nan for k in names}, "converged": False,
                         "at_bound": False, "cost": np.nan, "status": "too few windows"})
            continue
        data = _Data(bu, wu)

        def fun(x, data=data):
            law = DragLaw(cd0a0_m2=x[0], cp_m2_per_rad=x[1], mass_kg=mass_kg, rho_kgm3=rho_kgm3)
            return data.speed(law, x[2], method, signed=True) - data.ref

        # Multi-start over the pitch offset: the three-parameter problem has poor local
        # minima when the offset is far from the start (trade-off c_d0A0 <-> offset).
        fits = [_solve(fun, [0.03, -0.047, x0], lo, hi, f"uav {uav}") for x0 in (-5.0, 0.0, 5.0)]
        res, conv, atb = min(fits, key=lambda f: f[0].cost)
        se = _param_se(res, len(wu))
        rows.append({**row, **dict(zip(names, res.x)), **{f"{k}_se": s for k, s in zip(names, se)},
                     "converged": conv, "at_bound": bool(atb.any()), "cost": float(res.cost),
                     "status": res.message})
    return pd.DataFrame(rows)


def calibrate_universal(blocks: pd.DataFrame, windows: pd.DataFrame,
                        flights: Iterable[str] | None = None, method: str = "tilt",
                        mass_kg: float = MASS_KG, rho_kgm3: float = RHO_KGM3,
                        bounds: Mapping[str, tuple[float, float]] | None = None) -> tuple[dict, pd.DataFrame]:
    r"""Common aerodynamic parameters with per-UAV pitch offsets (seed 001, Sect. 5.2, Eq. 18).

    Parameters
    ----------
    blocks, windows, flights, method, mass_kg, rho_kgm3, bounds
        As in :func:`calibrate_individual`.

    Returns
    -------
    aero : dict
        ``cd0a0_m2``, ``cp_m2_per_rad`` (and ``*_se``), ``converged``, ``cost``.
    offsets : pandas.DataFrame
        ``uav``, ``pitch_offset_deg``, ``pitch_offset_deg_se``, ``n_windows``.

    Notes
    -----
    One joint least-squares fit (TRF, bounded) of :math:`c_{d,0}A_0`, :math:`c_p` and one
    :math:`\Delta\theta_i` per UAV to all windows, which "minimize[s] the overall error"
    (seed 001, Sect. 5.2). The common level of the offsets and :math:`c_{d,0}A_0` are
    only weakly separable; their standard errors say how well.
    """
    bd = {**BOUNDS, **dict(bounds or {})}
    b, w = _subset(blocks, windows, flights)
    if len(w) < 3:
        raise InputError("calibration data", f"{len(w)} windows; at least 3 are needed")
    data = _Data(b, w)
    uavs = sorted(set(data.uav))
    k_uav = np.searchsorted(uavs, data.block_uav)

    def fun(x):
        law = DragLaw(cd0a0_m2=x[0], cp_m2_per_rad=x[1], mass_kg=mass_kg, rho_kgm3=rho_kgm3)
        return data.speed(law, x[2:][k_uav], method, signed=True) - data.ref

    lo = [bd["cd0a0_m2"][0], bd["cp_m2_per_rad"][0]] + [bd["pitch_offset_deg"][0]] * len(uavs)
    hi = [bd["cd0a0_m2"][1], bd["cp_m2_per_rad"][1]] + [bd["pitch_offset_deg"][1]] * len(uavs)
    # Start values: offsets fitted per UAV with fixed aero parameters (1-D problems),
    # from two aero starts; the joint fit from the start with the lower cost wins. A
    # single start can end in a local minimum that trades c_d0A0 against the offsets.
    fits = []
    for c0, cp in ((0.03, -0.047), (0.05, 0.0)):
        start = DragLaw(cd0a0_m2=c0, cp_m2_per_rad=cp, mass_kg=mass_kg, rho_kgm3=rho_kgm3)
        x0 = [c0, cp]
        for uav in uavs:
            sel = data.uav == uav
            sub = _Data(b[b["window_key"].isin(w.loc[sel, "window_key"])], w[sel].reset_index(drop=True))
            r1, _, _ = _solve(lambda x, d=sub: d.speed(start, x[0], method, True) - d.ref, [0.0],
                              [bd["pitch_offset_deg"][0]], [bd["pitch_offset_deg"][1]], uav)
            x0.append(float(r1.x[0]))
        fits.append(_solve(fun, x0, lo, hi, "universal"))
    res, conv, atb = min(fits, key=lambda f: f[0].cost)
    se = _param_se(res, len(w))
    aero = {"cd0a0_m2": float(res.x[0]), "cp_m2_per_rad": float(res.x[1]),
            "cd0a0_m2_se": float(se[0]), "cp_m2_per_rad_se": float(se[1]),
            "converged": conv, "at_bound": bool(atb[:2].any()), "cost": float(res.cost),
            "n_windows": len(w)}
    counts = pd.Series(data.uav).value_counts()
    offsets = pd.DataFrame({"uav": uavs, "pitch_offset_deg": res.x[2:],
                            "pitch_offset_deg_se": se[2:],
                            "n_windows": [int(counts[u]) for u in uavs]})
    return aero, offsets


def calibrate_pitch_offsets(blocks: pd.DataFrame, windows: pd.DataFrame, aero: Mapping,
                            flights: Iterable[str] | None = None, method: str = "tilt",
                            mass_kg: float = MASS_KG, rho_kgm3: float = RHO_KGM3,
                            bounds: tuple[float, float] = BOUNDS["pitch_offset_deg"]) -> pd.DataFrame:
    r"""Per-UAV pitch offset with fixed aerodynamic parameters (seed 001, Sect. 5.3).

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        From :func:`flight_windows`.
    aero : mapping
        ``cd0a0_m2`` and ``cp_m2_per_rad`` (e.g. from :func:`calibrate_universal`).
    flights : iterable of str, optional
        Calibration flights (scenarios a-d).
    method, mass_kg, rho_kgm3 : see :func:`calibrate_individual`.
    bounds : (float, float)
        Bounds on the offset [degree].

    Returns
    -------
    pandas.DataFrame
        ``uav``, ``pitch_offset_deg``, ``pitch_offset_deg_se``, ``n_windows``,
        ``converged``, ``at_bound``.
    """
    law = DragLaw(cd0a0_m2=float(aero["cd0a0_m2"]), cp_m2_per_rad=float(aero["cp_m2_per_rad"]),
                  mass_kg=mass_kg, rho_kgm3=rho_kgm3)
    b, w = _subset(blocks, windows, flights)
    rows = []
    for uav in sorted(w["uav"].astype(str).unique()):
        bu, wu = _subset(b, w, None, [uav])
        data = _Data(bu, wu)
        res, conv, atb = _solve(lambda x, d=data: d.speed(law, x[0], method, True) - d.ref,
                                [0.0], [bounds[0]], [bounds[1]], f"uav {uav}")
        se = _param_se(res, len(wu))
        rows.append({"uav": uav, "pitch_offset_deg": float(res.x[0]),
                     "pitch_offset_deg_se": float(se[0]), "n_windows": len(wu),
                     "converged": conv, "at_bound": bool(atb.any())})
    return pd.DataFrame(rows, columns=["uav", "pitch_offset_deg", "pitch_offset_deg_se",
                                       "n_windows", "converged", "at_bound"])


def calibrate_yaw_offsets(blocks: pd.DataFrame, windows: pd.DataFrame,
                          flights: Iterable[str] | None = None,
                          min_speed_ms: float = 2.0) -> pd.DataFrame:
    r"""Per-UAV yaw (magnetometer) offset under weather-vane mode (seed 001, Sect. 5.4).

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        From :func:`flight_windows`.
    flights : iterable of str, optional
        Calibration flights (seed 001 uses #31 and #56).
    min_speed_ms : float
        Windows with a reference speed below this are not used: the weather-vane mode
        needs roll above 1 degree to turn the nose into the wind (Sect. 5.4) [m s-1].

    Returns
    -------
    pandas.DataFrame
        ``uav``, ``yaw_offset_deg`` (in (-180, 180]), ``yaw_offset_deg_se``,
        ``n_windows``, ``n_low_wind`` (windows left out).

    Notes
    -----
    The offset is the speed-weighted circular mean of logged yaw minus reference
    direction; it minimises :math:`\sum_j w_j\,[1-\cos(\psi_j-\Delta\psi-\psi_{ref,j})]`
    in closed form (no iterative solver needed).

    .. math:: \Delta\psi = \operatorname{atan2}\Big(\sum w_j\sin(\bar\psi_j-\psi_{ref,j}),
              \sum w_j\cos(\bar\psi_j-\psi_{ref,j})\Big)
    """
    b, w = _subset(blocks, windows, flights)
    mean_yaw = b.assign(s=np.sin(np.radians(b["yaw_deg"])), c=np.cos(np.radians(b["yaw_deg"]))) \
        .groupby("window_key")[["s", "c"]].mean()
    yaw = np.degrees(np.arctan2(mean_yaw["s"], mean_yaw["c"]))
    w = w.assign(yaw_deg=w["window_key"].map(yaw))
    rows = []
    for uav, wu in w.groupby(w["uav"].astype(str)):
        ok = wu["ref_speed_ms"] >= min_speed_ms
        d = (wu.loc[ok, "yaw_deg"] - wu.loc[ok, "ref_from_deg"]).to_numpy()
        wt = wu.loc[ok, "ref_speed_ms"].to_numpy()
        if d.size == 0:
            off, se = np.nan, np.nan
        else:
            off = _circmean_deg(d, wt)
            off = (off + 180.0) % 360.0 - 180.0
            resid = (d - off + 180.0) % 360.0 - 180.0
            se = float(np.sqrt(np.sum(wt * resid**2) / np.sum(wt)) / np.sqrt(d.size)) if d.size > 1 else np.nan
        rows.append({"uav": uav, "yaw_offset_deg": off, "yaw_offset_deg_se": se,
                     "n_windows": int(ok.sum()), "n_low_wind": int((~ok).sum())})
    return pd.DataFrame(rows, columns=["uav", "yaw_offset_deg", "yaw_offset_deg_se",
                                       "n_windows", "n_low_wind"])


def calibrate_speed_ranges(force_n: np.ndarray, ref_speed_ms: np.ndarray,
                           edges_ms: Sequence[float] = (4.0, 12.0),
                           group: np.ndarray | None = None,
                           b_bounds: tuple[float, float] = (0.2, 2.0),
                           c_bounds: tuple[float, float] = (0.5, 50.0),
                           edge_tol_ms: float = 0.5, scale: np.ndarray | None = None) -> pd.DataFrame:
    r"""Power-law coefficients per speed range (seed 002, Sect. 3.1, Eq. 1, Table 2).

    Parameters
    ----------
    force_n : array_like
        Magnitude of the body-axis wind acceleration (force per unit mass) per sample
        [m s-2] (:func:`body_accelerations_ms2`), or a force [N].
    ref_speed_ms : array_like
        Reference (CTA or tower) speed per sample, or per group when ``group`` is given
        [m s-1].
    edges_ms : sequence of float
        Upper edges of the speed ranges [m s-1]; ranges (-inf, e1], (e1, e2), ...
    group : array_like of int, optional
        Index of the averaging interval of each sample; the model speed is averaged
        per group before it is compared with ``ref_speed_ms[group]`` (seed 002: averages
        over each constant-speed step).
    b_bounds, c_bounds : (float, float)
        Physical bounds of the exponent [-] and factor [m s-1 (m s-2)^-b].
    edge_tol_ms : float
        Intervals within this distance of a range's edges are used for that range too
        [m s-1]; a negative value keeps only intervals at least that far inside.
    scale : array_like, optional
        Factor per sample applied to the model speed, e.g. :math:`\cos\theta` to
        project the body-axis speed of Eq. 1 onto the horizontal, as
        :func:`wind_from_attitude` does with :math:`R` (default 1).

    Returns
    -------
    pandas.DataFrame
        One row per range: ``lower_ms``, ``upper_ms``, ``b``, ``c``, ``n``, ``rmse_ms``,
        ``converged``.

    Notes
    -----
    :math:`V = c\,F^{b}`; each range is fitted separately to the intervals whose
    reference speed lies in it, with ``scipy.optimize.least_squares(method="trf")``
    (the algorithm named by seed 002, Sect. 3.1).
    """
    f = np.abs(np.asarray(force_n, float))
    ref = np.asarray(ref_speed_ms, float)
    proj = np.ones_like(f) if scale is None else np.broadcast_to(np.asarray(scale, float), f.shape)
    if group is None:
        group = np.arange(f.size)
        ref_g = ref
    else:
        group = np.asarray(group, int)
        ref_g = ref
    ng = ref_g.size
    cnt = np.bincount(group, minlength=ng).astype(float)
    edges = list(edges_ms)
    lo_e = [-np.inf] + edges
    hi_e = edges + [np.inf]
    rows = []
    for k in range(len(lo_e)):
        # intervals whose speed lies in the range, widened by edge_tol_ms so that the
        # steps at an edge (e.g. 4 m/s) constrain both neighbouring laws
        in_r = (ref_g >= lo_e[k] - edge_tol_ms) & (ref_g <= hi_e[k] + edge_tol_ms)
        gsel = np.flatnonzero(in_r & (cnt > 0))
        row = {"lower_ms": lo_e[k], "upper_ms": hi_e[k], "n": int(gsel.size)}
        if gsel.size < 3:
            rows.append({**row, "b": np.nan, "c": np.nan, "rmse_ms": np.nan, "converged": False})
            continue
        smask = np.isin(group, gsel)
        fs, gs, ps = f[smask], group[smask], proj[smask]

        def fun(x, fs=fs, gs=gs, ps=ps, gsel=gsel):
            s = np.bincount(gs, weights=ps * x[1] * fs ** x[0], minlength=ng)
            return s[gsel] / cnt[gsel] - ref_g[gsel]

        res, conv, _ = _solve(fun, [0.8, 7.0], [b_bounds[0], c_bounds[0]],
                              [b_bounds[1], c_bounds[1]], f"speed range {k}")
        rows.append({**row, "b": float(res.x[0]), "c": float(res.x[1]),
                     "rmse_ms": float(np.sqrt(np.mean(res.fun**2))), "converged": conv})
    return pd.DataFrame(rows)


def calibrate_fleet_speed_ranges(blocks: pd.DataFrame, windows: pd.DataFrame,
                                 pitch_offsets: pd.DataFrame | None = None,
                                 edges_ms: Sequence[float] = (4.0, 12.0),
                                 flights: Iterable[str] | None = None,
                                 edge_tol_ms: float = 0.5) -> pd.DataFrame:
    r"""Speed-range power laws (seed 002, Table 2 form) fitted to field "drone tower" windows.

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        From :func:`flight_windows`.
    pitch_offsets : pandas.DataFrame, optional
        ``uav``, ``pitch_offset_deg`` subtracted first (default none).
    edges_ms : sequence of float
        Upper edges of the speed ranges [m s-1].
    flights : iterable of str, optional
        Calibration flights (default all).
    edge_tol_ms : float
        See :func:`calibrate_speed_ranges`.

    Returns
    -------
    pandas.DataFrame
        As :func:`calibrate_speed_ranges`, on the wind acceleration
        :math:`a = g\sin\gamma` of each block (tilt :math:`\gamma` from roll and the
        corrected pitch) averaged per window against the window's reference speed.
    """
    b, w = _subset(blocks, windows, flights)
    data = _Data(b, w)
    off = 0.0
    if pitch_offsets is not None:
        m = pitch_offsets.set_index(pitch_offsets["uav"].astype(str))["pitch_offset_deg"]
        off = pd.Series(data.block_uav).map(m).fillna(0.0).to_numpy()
    tilt, _ = tilt_from_attitude(np.radians(data.roll), np.radians(data.pitch - off))
    return calibrate_speed_ranges(GRAVITY_MS2 * np.sin(tilt), data.ref, edges_ms, group=data.win,
                                  edge_tol_ms=edge_tol_ms)


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
    from dronewind.quadrotor.io import read_quadrotor, read_tower_reference  # io is upstream

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


def uav_wind_dataset(ds: xr.Dataset, law: DragLaw | None = None, pitch_offset_deg: float = 0.0,
                     yaw_offset_deg: float = 0.0, method: str = "tilt", average_s: float = 1.0,
                     hover_kwargs: Mapping | None = None) -> xr.Dataset:
    r"""Calibrated wind time series of one hovering UAV (seed 001, Sect. 6: 1 Hz series).

    Parameters
    ----------
    ds : xarray.Dataset
        Quadrotor log (:func:`dronewind.quadrotor.io.read_quadrotor`).
    law : DragLaw, optional
        Drag law (default seed 001, Eq. 18).
    pitch_offset_deg, yaw_offset_deg : float
        Calibrated offsets (logged minus true) [degree].
    method : str
        See :func:`wind_from_attitude`.
    average_s : float
        Block average of the output [s] (attitude averaged first, as in
        :func:`flight_windows`); 0 keeps the log rate.
    hover_kwargs : mapping, optional
        Passed to :func:`hover_segment`.

    Returns
    -------
    xarray.Dataset
        Dimension ``time`` (hover only): ``wind_speed_ms`` (wind_speed),
        ``wind_from_deg`` (wind_from_direction), ``u_east_ms`` (eastward_wind),
        ``v_north_ms`` (northward_wind), ``yaw_from_deg``; ``lat_deg``, ``lon_deg``,
        ``alt_m``. attrs: hover accuracy ``sigma_h_m``, ``sigma_v_m``, ``n_excluded``
        (samples outside the hover), offsets, ``processing_log``.
    """
    mask, info = hover_segment(ds, **dict(hover_kwargs or {}))
    sub = ds.isel(time=np.flatnonzero(mask))
    if average_s > 0:
        t0 = sub["time"].to_numpy()[0]
        k = ((sub["time"].to_numpy() - t0).astype("int64") // int(average_s * 1e9))
        frame = pd.DataFrame({v: sub[v].to_numpy() for v in ("roll_deg", "pitch_deg", "vel_n_ms", "vel_e_ms",
                                                             "lat_deg", "lon_deg", "alt_m")})
        frame["sy"] = np.sin(np.radians(sub["yaw_deg"].to_numpy()))
        frame["cy"] = np.cos(np.radians(sub["yaw_deg"].to_numpy()))
        frame["k"] = k
        g = frame.groupby("k").mean()
        g["yaw_deg"] = np.degrees(np.arctan2(g["sy"], g["cy"]))
        time = t0 + (g.index.to_numpy() * int(average_s * 1e9) + int(average_s * 5e8)).astype("timedelta64[ns]")
        cols = {c: g[c].to_numpy() for c in g.columns}
    else:
        time = sub["time"].to_numpy()
        cols = {c: sub[c].to_numpy() for c in sub.data_vars}
    w = wind_from_attitude(cols["roll_deg"], cols["pitch_deg"], cols["yaw_deg"], cols["vel_n_ms"],
                           cols["vel_e_ms"], law=law, pitch_offset_deg=pitch_offset_deg,
                           yaw_offset_deg=yaw_offset_deg, method=method)
    out = xr.Dataset(
        {"wind_speed_ms": ("time", w["speed_ms"], {"units": "m s-1", "standard_name": "wind_speed"}),
         "wind_from_deg": ("time", w["wind_from_deg"], {"units": "degree", "standard_name": "wind_from_direction"}),
         "u_east_ms": ("time", w["u_east_ms"], {"units": "m s-1", "standard_name": "eastward_wind"}),
         "v_north_ms": ("time", w["v_north_ms"], {"units": "m s-1", "standard_name": "northward_wind"}),
         "yaw_from_deg": ("time", w["yaw_from_deg"], {"units": "degree",
                                                      "long_name": "wind-from direction from corrected yaw (weather vane)"}),
         "lat_deg": ("time", cols["lat_deg"], {"units": "degrees_north", "standard_name": "latitude"}),
         "lon_deg": ("time", cols["lon_deg"], {"units": "degrees_east", "standard_name": "longitude"}),
         "alt_m": ("time", cols["alt_m"], {"units": "m", "standard_name": "altitude"})},
        coords={"time": time})
    law = law or DragLaw()
    out.attrs.update({
        "sigma_h_m": info["sigma_h_m"], "sigma_v_m": info["sigma_v_m"], "n_excluded": info["n_excluded"],
        "pitch_offset_deg": pitch_offset_deg, "yaw_offset_deg": yaw_offset_deg, "method": method,
        "drag_law": law.law, "averaging_s": average_s,
        "processing_log": "\n".join([
            f"hover: {info['n_hover']} samples kept, {info['n_excluded']} outside the hover excluded",
            f"offsets: pitch {pitch_offset_deg:+.2f} deg, yaw {yaw_offset_deg:+.2f} deg subtracted",
            f"wind: drag balance ({law.law}, method {method}), GNSS velocity added"])})
    return out


# --------------------------------------------------------------------------------------
# Validation tables
# --------------------------------------------------------------------------------------

def predict_windows(blocks: pd.DataFrame, windows: pd.DataFrame, params: pd.DataFrame,
                    aero: Mapping | None = None, flights: Iterable[str] | None = None,
                    method: str = "tilt", mass_kg: float = MASS_KG,
                    rho_kgm3: float = RHO_KGM3) -> pd.DataFrame:
    r"""Calibrated UAV wind speed and direction per window.

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        From :func:`flight_windows`.
    params : pandas.DataFrame
        Per-UAV ``uav``, ``pitch_offset_deg`` and, unless ``aero`` is given, ``cd0a0_m2``
        and ``cp_m2_per_rad``; optional ``yaw_offset_deg`` (default 0).
    aero : mapping, optional
        Common ``cd0a0_m2``, ``cp_m2_per_rad``.
    flights : iterable of str, optional
        Validation flights (default all).
    method, mass_kg, rho_kgm3 : see :func:`calibrate_individual`.

    Returns
    -------
    pandas.DataFrame
        ``windows`` columns plus ``uav_speed_ms``, ``uav_from_deg`` (circular mean of
        corrected yaw), ``error_ms`` (UAV minus reference), ``dir_error_deg``. UAVs
        without parameters are left out (counted in ``attrs['n_uncalibrated']``).
    """
    b, w = _subset(blocks, windows, flights)
    p = params.set_index(params["uav"].astype(str))
    have = w["uav"].astype(str).isin(p.index[np.isfinite(p["pitch_offset_deg"].to_numpy(float))])
    n_uncal = int((~have).sum())
    b, w = _subset(b, w[have], None)
    out = []
    for uav, wu in w.groupby(w["uav"].astype(str)):
        bu = b[b["window_key"].isin(wu["window_key"])]
        pu = p.loc[uav]
        a = aero if aero is not None else pu
        law = DragLaw(cd0a0_m2=float(a["cd0a0_m2"]), cp_m2_per_rad=float(a["cp_m2_per_rad"]),
                      mass_kg=mass_kg, rho_kgm3=rho_kgm3)
        wu = wu.reset_index(drop=True)
        data = _Data(bu, wu)
        yaw_off = float(pu["yaw_offset_deg"]) if "yaw_offset_deg" in pu and np.isfinite(pu["yaw_offset_deg"]) else 0.0
        sp = data.speed(law, float(pu["pitch_offset_deg"]), method)
        ys = np.bincount(data.win, weights=np.sin(np.radians(data.yaw - yaw_off)), minlength=data.nwin)
        yc = np.bincount(data.win, weights=np.cos(np.radians(data.yaw - yaw_off)), minlength=data.nwin)
        wu = wu.assign(uav_speed_ms=sp, uav_from_deg=np.degrees(np.arctan2(ys, yc)) % 360.0)
        out.append(wu)
    res = pd.concat(out, ignore_index=True) if out else w.assign(uav_speed_ms=[], uav_from_deg=[])
    res["error_ms"] = res["uav_speed_ms"] - res["ref_speed_ms"]
    res["dir_error_deg"] = (res["uav_from_deg"] - res["ref_from_deg"] + 180.0) % 360.0 - 180.0
    res.attrs["n_uncalibrated"] = n_uncal
    return res


def accuracy_table(predicted: pd.DataFrame, label: str = "") -> pd.DataFrame:
    r"""Bias and RMS deviation per UAV and their mean (seed 001, Tables 2, 3, C1, C2; seed 002, Eq. 3).

    Parameters
    ----------
    predicted : pandas.DataFrame
        Output of :func:`predict_windows`.
    label : str
        Suffix for the column names (e.g. ``"_individual"``).

    Returns
    -------
    pandas.DataFrame
        Index ``uav`` plus a last row ``mean``; columns ``bias_ms``, ``rmse_ms``,
        ``rmse_dir_deg``, ``n`` (each with ``label`` appended).

    Notes
    -----
    .. math:: \Delta V_w = \frac1n\sum(\bar V_{UAV}-\bar V_{ref}),\qquad
              \sigma_{rms} = \sqrt{\frac1n\sum(\bar V_{UAV}-\bar V_{ref})^2}

    The ``mean`` row averages the per-UAV values (as in the tables of seed 001).
    """
    g = predicted.groupby(predicted["uav"].astype(str))
    t = pd.DataFrame({
        "bias_ms": g["error_ms"].mean(),
        "rmse_ms": g["error_ms"].apply(lambda e: float(np.sqrt(np.mean(e**2)))),
        "rmse_dir_deg": g["dir_error_deg"].apply(lambda e: float(np.sqrt(np.mean(e**2)))),
        "n": g.size(),
    })
    t.index.name = "uav"
    mean = t.mean(numeric_only=True)
    mean["n"] = t["n"].sum()
    t.loc["mean"] = mean
    t["n"] = t["n"].astype(int)
    return t.add_suffix(label)


def flight_number(flight_id: str) -> int:
    """Number in a flight id (``"f31"`` -> 31); raises InputError if there is none."""
    m = re.search(r"(\d+)", str(flight_id))
    if not m:
        raise InputError("flight id", f"{flight_id!r} holds no flight number")
    return int(m.group(1))


def seed001_scenarios(flight_ids: Iterable[str]) -> tuple[dict[str, list[str]], list[str]]:
    r"""Calibration scenarios a-d and validation flights of seed 001, Sect. 5.3.

    Parameters
    ----------
    flight_ids : iterable of str
        "Drone tower" flight ids whose number is the FESST@MOL flight number.

    Returns
    -------
    scenarios : dict
        ``a_all``: all flights; ``b_first_week``: flights 1-37 (Table E1);
        ``c_flight31``: flight 31; ``d_flights31_56``: flights 31 and 56.
    validation : list of str
        Second-week flights (number >= 38, Table E2).
    """
    ids = [str(f) for f in flight_ids]
    num = {f: flight_number(f) for f in ids}
    scen = {
        "a_all": ids,
        "b_first_week": [f for f in ids if num[f] <= 37],
        "c_flight31": [f for f in ids if num[f] == 31],
        "d_flights31_56": [f for f in ids if num[f] in (31, 56)],
    }
    return scen, [f for f in ids if num[f] >= 38]


def calibration_scenarios(blocks: pd.DataFrame, windows: pd.DataFrame, aero: Mapping,
                          scenarios: Mapping[str, Sequence[str]], validation: Sequence[str],
                          method: str = "tilt") -> pd.DataFrame:
    r"""Table 3 / C2 of seed 001: pitch-offset-only calibration on several flight subsets.

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        From :func:`flight_windows` (10-min or 2-min windows).
    aero : mapping
        Common aerodynamic parameters (Eq. 18 or :func:`calibrate_universal`).
    scenarios : mapping
        Scenario name to calibration flight ids (:func:`seed001_scenarios`).
    validation : sequence of str
        Validation flight ids.
    method : str
        See :func:`wind_from_attitude`.

    Returns
    -------
    pandas.DataFrame
        Index ``uav`` (+ ``mean``); columns ``bias_ms_<scenario>``, ``rmse_ms_<scenario>``,
        ``pitch_offset_deg_<scenario>``. A UAV absent from a scenario's calibration flights
        has NaN (the "-" of Table 3).
    """
    parts = []
    for name, flights in scenarios.items():
        off = calibrate_pitch_offsets(blocks, windows, aero, flights=flights, method=method)
        pred = predict_windows(blocks, windows, off, aero=aero, flights=validation, method=method)
        acc = accuracy_table(pred)[["bias_ms", "rmse_ms"]].add_suffix(f"_{name}")
        acc[f"pitch_offset_deg_{name}"] = off.set_index("uav")["pitch_offset_deg"]
        parts.append(acc)
    return pd.concat(parts, axis=1)


def seed001_tables(blocks: pd.DataFrame, windows: pd.DataFrame, method: str = "tilt",
                   scenarios: Mapping[str, Sequence[str]] | None = None,
                   validation: Sequence[str] | None = None) -> dict[str, object]:
    r"""Seed 001, Tables 2 and 3 (10-min windows) or C1 and C2 (2-min windows), and the
    contract table ``quadrotor_calibration.csv``.

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        From :func:`flight_windows` / :func:`campaign_windows` for all "drone tower"
        flights.
    method : str
        See :func:`wind_from_attitude`.
    scenarios, validation : optional
        Default :func:`seed001_scenarios` of the flights present. Flight ids without a
        number, or no second-week flight, give one scenario ``a_all`` validated on the
        calibration flights themselves (flag ``independent_validation`` False).

    Returns
    -------
    dict
        ``individual`` (per-UAV parameters, Sect. 5.1), ``aero`` and
        ``universal_offsets`` (:func:`calibrate_universal`, Sect. 5.2), ``table2``
        (columns ``*_individual`` and ``*_universal``), ``table3``
        (:func:`calibration_scenarios`, Sect. 5.3), ``yaw_offsets`` (on the scenario-d
        flights 31 and 56 if present, else all flights, Sect. 5.4), ``direction``
        (validation accuracy of speed and direction with scenario-d offsets),
        ``calibration_table`` (:func:`calibration_table`: universal aero parameters and
        pitch offsets from all flights, yaw offsets as above, accuracy on the validation
        flights), ``independent_validation`` (bool), ``scenarios``, ``validation``,
        ``hover_accuracy`` (mean horizontal and vertical position standard deviation over
        all UAV logs, Sect. 4.3).
    """
    flights = sorted(windows["flight"].astype(str).unique())
    try:
        flights = sorted(flights, key=flight_number)
        s, v = seed001_scenarios(flights)
    except InputError:
        s, v = {"a_all": flights}, []
    scenarios = dict(scenarios or s)
    validation = list(validation if validation is not None else v)
    independent = bool(validation)
    if not validation:
        validation = flights
    ind = calibrate_individual(blocks, windows, method=method)
    aero, uoff = calibrate_universal(blocks, windows, method=method)
    t_ind = accuracy_table(predict_windows(blocks, windows, ind, method=method), "_individual")
    t_uni = accuracy_table(predict_windows(blocks, windows, uoff, aero=aero, method=method), "_universal")
    table2 = pd.concat([t_ind, t_uni], axis=1)
    scen = {k: f for k, f in scenarios.items() if len(f)}
    table3 = calibration_scenarios(blocks, windows, aero, scen, validation, method=method)
    yaw_flights = scenarios.get("d_flights31_56") or flights
    yaw = calibrate_yaw_offsets(blocks, windows, flights=yaw_flights)
    p = calibrate_pitch_offsets(blocks, windows, aero, flights=yaw_flights, method=method) \
        .merge(yaw[["uav", "yaw_offset_deg"]], on="uav", how="left")
    direction = accuracy_table(predict_windows(blocks, windows, p, aero=aero, flights=validation, method=method))
    contract_params = uoff.merge(yaw[["uav", "yaw_offset_deg"]], on="uav", how="left")
    acc = accuracy_table(predict_windows(blocks, windows, contract_params, aero=aero, flights=validation,
                                         method=method))
    table = calibration_table(uoff.assign(converged=aero["converged"]), yaw, acc, aero)
    per_log = windows.drop_duplicates(["flight", "uav"])
    hover = {"sigma_h_m": float(per_log["sigma_h_m"].mean()), "sigma_v_m": float(per_log["sigma_v_m"].mean()),
             "n_logs": len(per_log)} if "sigma_h_m" in windows else {}
    return {"individual": ind, "aero": aero, "universal_offsets": uoff, "table2": table2,
            "table3": table3, "yaw_offsets": yaw, "direction": direction, "calibration_table": table,
            "independent_validation": independent, "scenarios": scenarios, "validation": validation,
            "hover_accuracy": hover}


def calibration_table(pitch_offsets: pd.DataFrame, yaw_offsets: pd.DataFrame,
                      accuracy: pd.DataFrame, aero: Mapping | None = None) -> pd.DataFrame:
    """The contract table ``tables/quadrotor_calibration.csv`` (one row per UAV).

    Parameters
    ----------
    pitch_offsets : pandas.DataFrame
        ``uav``, ``pitch_offset_deg`` (and optionally ``cd0a0_m2``, ``cp_m2_per_rad``,
        ``pitch_offset_deg_se``, ``converged``).
    yaw_offsets : pandas.DataFrame
        :func:`calibrate_yaw_offsets`.
    accuracy : pandas.DataFrame
        :func:`accuracy_table` without label (index ``uav``; the ``mean`` row is dropped).
    aero : mapping, optional
        Common ``cd0a0_m2`` and ``cp_m2_per_rad`` written to every row.

    Returns
    -------
    pandas.DataFrame
        Columns ``uav, pitch_offset_deg, yaw_offset_deg, rmse_ms, bias_ms`` first, then
        ``rmse_dir_deg, n_windows, cd0a0_m2, cp_m2_per_rad, pitch_offset_deg_se,
        yaw_offset_deg_se, converged`` where available.
    """
    t = pitch_offsets.copy()
    t["uav"] = t["uav"].astype(str)
    t = t.merge(yaw_offsets[["uav", "yaw_offset_deg", "yaw_offset_deg_se"]].astype({"uav": str}),
                on="uav", how="outer")
    acc = accuracy.drop(index="mean", errors="ignore").reset_index()
    acc["uav"] = acc["uav"].astype(str)
    t = t.merge(acc[["uav", "rmse_ms", "bias_ms", "rmse_dir_deg", "n"]].rename(columns={"n": "n_windows_validation"}),
                on="uav", how="left")
    if aero is not None:
        t["cd0a0_m2"] = float(aero["cd0a0_m2"])
        t["cp_m2_per_rad"] = float(aero["cp_m2_per_rad"])
    first = ["uav", "pitch_offset_deg", "yaw_offset_deg", "rmse_ms", "bias_ms"]
    extra = [c for c in ("rmse_dir_deg", "n_windows", "n_windows_validation", "cd0a0_m2", "cp_m2_per_rad",
                         "pitch_offset_deg_se", "yaw_offset_deg_se", "converged") if c in t.columns]
    return t[first + extra].sort_values("uav").reset_index(drop=True)
