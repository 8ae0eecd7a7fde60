r"""The drag balance of a hovering quadrotor: drag laws, attitude geometry, body-axis forces.

The SWUF-3D method (Wetz et al. (2021), Sects. 4-5; Kistner et al. (2024), Sect. 2.1): a quadrotor that holds
its position leans into the wind until the horizontal component of its thrust balances
the aerodynamic drag. Its tilt therefore measures the wind speed, and, in PX4's
weather-vane mode (the nose is yawed into the wind), its yaw measures the direction.
This module holds the physics the processing chain inverts (attitude to air speed); the
wind itself is assembled in :mod:`dronewind.quadrotor.wind`.

Conventions (``docs/data-contract.md``): roll :math:`\phi`, pitch :math:`\theta`, yaw
:math:`\psi` in degrees as logged (PX4: pitch negative nose-down, yaw clockwise from true
north); body-to-NED rotation :math:`R(\phi,\theta,\psi)` of Wetz et al. (2021), Eq. D1. A quadrotor
facing into the wind leans nose-down, so its *tilt* :math:`\gamma = -\theta > 0`.

Two drag laws are implemented:

``rayleigh`` (Wetz et al. (2021), Eqs. 12-17)
    :math:`m g \sin\gamma = \tfrac{\rho}{2} c_dA(\gamma) V^2`,
    :math:`c_dA = c_{d,0}A_0 + c_p\,\gamma`. Wetz et al. (2021), Eq. 18 gives
    :math:`c_dA = 0.03 - 0.047\,\theta`; we read its :math:`\theta` as the tilt
    magnitude, i.e. ``cp_m2_per_rad = -0.047`` with :math:`\gamma \ge 0`. The other
    reading (drag area growing with tilt) makes a 10 m/s wind need a 33 degree tilt and
    puts 15 m/s out of reach, while this one gives 11 degrees at 10 m/s and 18 degrees
    at 15 m/s, close to the Kistner et al. (2024) coefficients (Table 2: 10 degrees at 8 m/s).
``body_axis`` (Kistner et al. (2024), Eq. 1 and Table 2)
    body-axis wind accelerations :math:`a_x = F_{w,x}/m = g\sin\theta`,
    :math:`a_y = -g\cos\theta\sin\phi` (Wetz et al. (2021), Eqs. 9-10 at rest; the sign of the
    roll term in the published Eq. 10 is a typo, gravity in the body frame is
    :math:`+mg\cos\theta\sin\phi`), air velocity relative to the vehicle
    :math:`u = \operatorname{sgn}(a_x)\,c_x|a_x|^{b_x}`,
    :math:`v = \operatorname{sgn}(a_y)\,c_y|a_y|^{b_y}`, with :math:`(b_x, c_x)` chosen
    per speed range, rotated to the earth frame with :math:`R`.

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F. (SWUF-3D), Wetz et al. (2021)
  , Sects. 4-5, Eqs. 9-18, Table 1, D1.
.. [2] Wind-tunnel calibration and verification of the SWUF-3D quadrotors, Kistner et al. (2024)
  , Eqs. 1-2, Table 2.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from dronewind.core.constants import (
    AIR_DENSITY_KGM3,
    GRAVITY_MS2,
    KISTNER2024_RANGES,
    WETZ2021_AERO,
    WETZ2021_MASS_KG,
)
from dronewind.errors import InputError

__all__ = [
    "MIN_DRAG_AREA_M2", "DragLaw",
    "rotation_body_to_ned", "drag_area_m2", "speed_from_tilt", "tilt_from_attitude", "attitude_trig", "lean_from_trig",
    "body_accelerations_ms2", "body_axis_relative_air",
]

#: Floor of the drag area [m2] (see :func:`speed_from_tilt`).
MIN_DRAG_AREA_M2: float = 1e-4


@dataclass(frozen=True)
class DragLaw:
    """Parameters of the drag law that maps tilt to wind speed.

    Parameters
    ----------
    law : {"rayleigh", "body_axis"}
        Wetz et al. (2021), Eqs. 12-17 or Kistner et al. (2024), Eq. 1 with speed ranges (see module doc).
    cd0a0_m2 : float
        :math:`c_{d,0}A_0` [m2] (rayleigh).
    cp_m2_per_rad : float
        :math:`c_p` [m2 rad-1], slope of :math:`c_dA` on the tilt (rayleigh).
    edges_ms : tuple of float
        Upper edges of the longitudinal speed ranges [m s-1] (body_axis); ranges are
        (-inf, e1], (e1, e2), [e2, inf) as in Kistner et al. (2024), Table 2.
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
    r"""Body-to-NED rotation matrix :math:`R(\phi,\theta,\psi)` (Wetz et al. (2021), Eq. D1).

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

    (Kistner et al. (2024), Eq. 2 prints :math:`\cos\theta\sin\phi` in row 2, column 1: a typo.)
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
    r"""Drag area as a function of tilt (Wetz et al. (2021), Eqs. 16-17).

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
                    mass_kg: float = WETZ2021_MASS_KG, rho_kgm3: float = AIR_DENSITY_KGM3) -> np.ndarray:
    r"""Wind speed from tilt by the drag balance (Wetz et al. (2021), Eqs. 12-17).

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
    :math:`R`, Wetz et al. (2021), Eq. D1, with :math:`\psi=0`), so
    :math:`\gamma = \operatorname{atan2}(\sqrt{f^2+r^2},\,\cos\theta\cos\phi)` (atan2
    rather than arccos for accuracy at small tilt).
    """
    phi = np.asarray(roll_rad, float)
    th = np.asarray(pitch_rad, float)
    fwd = -np.sin(th) * np.cos(phi)
    right = np.sin(phi)
    tilt = np.arctan2(np.hypot(fwd, right), np.cos(th) * np.cos(phi))
    return tilt, np.arctan2(right, fwd)


def attitude_trig(roll_rad: np.ndarray, pitch_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Cosine and sine of roll and pitch, the first four arguments of :func:`lean_from_trig`.

    Parameters
    ----------
    roll_rad, pitch_rad : numpy.ndarray
        Roll and pitch [rad].

    Returns
    -------
    cos_roll, sin_roll, cos_pitch, sin_pitch : numpy.ndarray
    """
    return np.cos(roll_rad), np.sin(roll_rad), np.cos(pitch_rad), np.sin(pitch_rad)


def lean_from_trig(cos_roll: np.ndarray, sin_roll: np.ndarray, cos_pitch: np.ndarray, sin_pitch: np.ndarray,
                   cos_yaw: np.ndarray, sin_yaw: np.ndarray, pitch_offset: tuple[np.ndarray, np.ndarray] | None = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Tilt and lean direction (:func:`tilt_from_attitude`, turned by the heading) from the angles' cosines and sines.

    Parameters
    ----------
    cos_roll, sin_roll, cos_pitch, sin_pitch, cos_yaw, sin_yaw : numpy.ndarray
        Cosines and sines of roll :math:`\phi`, pitch :math:`\theta` and heading :math:`\psi`.
    pitch_offset : (numpy.ndarray, numpy.ndarray), optional
        Cosine and sine of a pitch offset :math:`p` (logged minus true): the pitch is then
        :math:`\theta - p`. None: no offset.

    Returns
    -------
    tilt_rad : numpy.ndarray
        Angle between the thrust axis and the vertical [rad], >= 0.
    cos_lean, sin_lean : numpy.ndarray
        Cosine and sine of the direction the thrust axis leans to, clockwise from north.

    Notes
    -----
    The thrust axis in the heading frame is :math:`(f, r, u) = (-\sin\theta\cos\phi,\ \sin\phi,\
    \cos\theta\cos\phi)` (:func:`tilt_from_attitude`, Wetz et al. (2021), Eq. D1), so with
    :math:`h = \sqrt{f^2 + r^2}`

    .. math:: \gamma = \operatorname{atan2}(h, u),\qquad
              \cos\lambda = \frac{f\cos\psi - r\sin\psi}{h},\qquad
              \sin\lambda = \frac{f\sin\psi + r\cos\psi}{h}

    for the lean :math:`\lambda = \psi + \operatorname{atan2}(r, f)`. Fits that move the pitch by an
    offset :math:`p` evaluate this thousands of times: with the blocks' cosines and sines made once
    and :math:`\sin(\theta - p) = \sin\theta\cos p - \cos\theta\sin p` (likewise the cosine),
    only the offsets' own trigonometric functions are evaluated again. An upright vehicle
    (:math:`h = 0`) leans as :math:`\operatorname{atan2}(0, \pm 0)`, along the heading or against it
    (its tilt, and the drag balance's speed, are 0 either way). Equal to
    :func:`tilt_from_attitude` to rounding (``tests/quadrotor/test_quadrotor.py``).
    """
    if pitch_offset is not None:
        cos_p, sin_p = pitch_offset
        cos_pitch, sin_pitch = cos_pitch * cos_p + sin_pitch * sin_p, sin_pitch * cos_p - cos_pitch * sin_p
    fwd = -sin_pitch * cos_roll
    up = cos_pitch * cos_roll
    horizontal = np.hypot(fwd, sin_roll)
    tilt = np.arctan2(horizontal, up)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_rel = np.where(horizontal > 0, fwd / horizontal, np.copysign(1.0, fwd))
        sin_rel = np.where(horizontal > 0, sin_roll / horizontal, 0.0)
    return tilt, cos_yaw * cos_rel - sin_yaw * sin_rel, sin_yaw * cos_rel + cos_yaw * sin_rel


def body_accelerations_ms2(roll_rad: np.ndarray, pitch_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Horizontal body-axis wind accelerations of a vehicle at rest (Wetz et al. (2021), Eqs. 9-10, 13).

    Parameters
    ----------
    roll_rad, pitch_rad : array_like
        Roll and pitch [rad].

    Returns
    -------
    ax_ms2, ay_ms2 : numpy.ndarray
        Wind force per unit mass along body x (forward) and y (right) [m s-2]: the
        "accelerations measured by the autopilot's avionics" that Kistner et al. (2024) (Sect. 3.1)
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
    r"""Air velocity relative to the vehicle in body axes from the wind forces (Kistner et al. (2024), Eq. 1).

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

    with :math:`a` in m s-2 (the coefficients of Kistner et al. (2024), Table 2 are for accelerations;
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

