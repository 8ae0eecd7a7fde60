"""Motion correction of the payload sonic: body frame -> earth frame (east, north, up).

Frames and signs follow ``docs/data-contract.md`` ("Frames and signs"):

* body frame b1 forward, b2 right, b3 down, origin at the sonic's measurement volume;
* INS Euler angles roll phi, pitch theta, yaw psi (degrees, yaw clockwise from true
  north) give the body-to-NED rotation :math:`R = [R_3(\\phi) R_2(\\theta) R_1(\\psi)]^T`
  (Ghirardelli et al. (2025), Appendix A);
* the sonic measures the air velocity relative to the sensor in the sensor frame; the
  ``mount`` maps it to the body frame (``upside_down``: body = sensor; ``upright``:
  body = diag(1, -1, -1) sensor);
* INS velocity (NED) is the velocity of the sonic's measurement volume (or of a point at a
  lever arm from it, see :func:`motion_correct`);
* wind NED = R V_body + V_sonic (Ghirardelli et al. (2025), Eq. 1, with the sign of its relative velocity
  vector flipped as explained in ``docs/data-contract.md``), then east = V_E, north = V_N, up = -V_D
  (Ghirardelli et al. (2025), Eq. 2).

All functions are vectorised over time (leading axis ``n``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from dronewind.core.angles import deg2rad
from dronewind.core.reuse import reused
from dronewind.core.timeseries import unwrap_rad
from dronewind.errors import InputError

__all__ = [
    "MOUNTS",
    "rotation_matrix_body_to_ned",
    "mount_matrix",
    "sensor_to_body_matrix",
    "euler_rates_to_body_rates",
    "body_rates_from_euler",
    "lever_arm_velocity_ned",
    "ned_to_enu",
    "motion_correct",
]

#: Mount names and their sensor-to-body matrices (``docs/data-contract.md``, "Frames and signs").
MOUNTS: dict[str, np.ndarray] = {
    "upside_down": np.eye(3),
    "upright": np.diag([1.0, -1.0, -1.0]),
}


def rotation_matrix_body_to_ned(
    roll_deg: np.ndarray | float, pitch_deg: np.ndarray | float, yaw_deg: np.ndarray | float
) -> np.ndarray:
    """Body-to-NED rotation matrix from INS Euler angles (Ghirardelli et al. (2025), Appendix A).

    Parameters
    ----------
    roll_deg, pitch_deg, yaw_deg : array_like
        Roll phi, pitch theta and yaw psi [degree]; broadcastable to a common shape
        ``s``. Yaw is clockwise from true north; any wrap is fine.

    Returns
    -------
    numpy.ndarray
        Shape ``s + (3, 3)``; ``R @ v_body`` gives the vector in north, east, down.

    Notes
    -----
    .. math::

        R(\\phi,\\theta,\\psi) = [R_3(\\phi) R_2(\\theta) R_1(\\psi)]^T =
        \\begin{pmatrix}
        c_\\theta c_\\psi & s_\\phi s_\\theta c_\\psi - c_\\phi s_\\psi &
            c_\\phi s_\\theta c_\\psi + s_\\phi s_\\psi \\\\
        c_\\theta s_\\psi & s_\\phi s_\\theta s_\\psi + c_\\phi c_\\psi &
            c_\\phi s_\\theta s_\\psi - s_\\phi c_\\psi \\\\
        -s_\\theta & s_\\phi c_\\theta & c_\\phi c_\\theta
        \\end{pmatrix}

    with :math:`R_1, R_2, R_3` the elementary frame rotations about the third, second
    and first axis given in Ghirardelli et al. (2025), Appendix A (yaw-pitch-roll, z-y-x sequence).

    References
    ----------
    Ghirardelli et al. (2025) (Ghirardelli et al., SAMURAI-S), Appendix A; Beard and McLain (2012).
    """
    phi, theta, psi = np.broadcast_arrays(
        deg2rad(np.asarray(roll_deg, dtype=float)),
        deg2rad(np.asarray(pitch_deg, dtype=float)),
        deg2rad(np.asarray(yaw_deg, dtype=float)),
    )
    sf, cf = np.sin(phi), np.cos(phi)
    st, ct = np.sin(theta), np.cos(theta)
    sp, cp = np.sin(psi), np.cos(psi)
    out = np.empty(phi.shape + (3, 3))
    out[..., 0, 0] = ct * cp
    out[..., 0, 1] = sf * st * cp - cf * sp
    out[..., 0, 2] = cf * st * cp + sf * sp
    out[..., 1, 0] = ct * sp
    out[..., 1, 1] = sf * st * sp + cf * cp
    out[..., 1, 2] = cf * st * sp - sf * cp
    out[..., 2, 0] = -st
    out[..., 2, 1] = sf * ct
    out[..., 2, 2] = cf * ct
    return out


def mount_matrix(mount: str) -> np.ndarray:
    """Sensor-to-body matrix of a named sonic mount (``docs/data-contract.md``, "Frames and signs").

    Parameters
    ----------
    mount : {"upside_down", "upright"}
        ``upside_down``: body = sensor (sensor x forward, y right, z down);
        ``upright``: body = diag(1, -1, -1) sensor (sensor x forward, y left, z up).

    Returns
    -------
    numpy.ndarray
        (3, 3) matrix M with ``v_body = M @ v_sensor``.

    Notes
    -----
    Ghirardelli et al. (2025), Sect. 3.2: the RM Young 81000 was mounted upside down, so its frame is
    already the body frame.
    """
    try:
        return MOUNTS[mount].copy()
    except KeyError:
        raise InputError("mount", f"unknown sonic mount {mount!r}; expected one of {sorted(MOUNTS)}") from None


def sensor_to_body_matrix(mount: str, misalignment_deg: Sequence[float] | None = None) -> np.ndarray:
    """Sensor-to-body matrix including an optional mount misalignment.

    Parameters
    ----------
    mount : str
        Mount name, see :func:`mount_matrix`.
    misalignment_deg : (roll, pitch, yaw) [degree], optional
        Misalignment angles: the true sensor-to-body rotation is
        ``M_mount @ R(roll, pitch, yaw)`` with R as in :func:`rotation_matrix_body_to_ned`
        (``docs/data-contract.md``, mechanism ``mount_misalignment``). None means perfectly aligned.

    Returns
    -------
    numpy.ndarray
        (3, 3) matrix with ``v_body = M @ v_sensor``.
    """
    m = mount_matrix(mount)
    if misalignment_deg is not None:
        mis = np.asarray(misalignment_deg, dtype=float)
        if mis.shape != (3,) or not np.all(np.isfinite(mis)):
            raise InputError("misalignment_deg",
                             f"expected three finite angles (roll, pitch, yaw), got {misalignment_deg!r}")
        m = m @ rotation_matrix_body_to_ned(*mis)
    return m


def euler_rates_to_body_rates(
    roll_rad: np.ndarray,
    pitch_rad: np.ndarray,
    roll_rate_rad_s: np.ndarray,
    pitch_rate_rad_s: np.ndarray,
    yaw_rate_rad_s: np.ndarray,
) -> np.ndarray:
    """Body angular rates from Euler angle rates (z-y-x yaw-pitch-roll sequence).

    Parameters
    ----------
    roll_rad, pitch_rad : numpy.ndarray
        Roll phi and pitch theta [rad].
    roll_rate_rad_s, pitch_rate_rad_s, yaw_rate_rad_s : numpy.ndarray
        Time derivatives of roll, pitch and (unwrapped) yaw [rad s-1].

    Returns
    -------
    numpy.ndarray
        Shape (n, 3): body rates (p, q, r) about b1, b2, b3 [rad s-1], defined by
        :math:`\\dot R = R\\,[\\omega_b]_\\times` for R of Ghirardelli et al. (2025), Appendix A.

    Notes
    -----
    .. math::

        p = \\dot\\phi - \\dot\\psi \\sin\\theta, \\quad
        q = \\dot\\theta \\cos\\phi + \\dot\\psi \\cos\\theta \\sin\\phi, \\quad
        r = -\\dot\\theta \\sin\\phi + \\dot\\psi \\cos\\theta \\cos\\phi .

    References
    ----------
    Beard and McLain (2012), Small Unmanned Aircraft, Ch. 3 (attitude kinematics, inverted); Ghirardelli et al. (2025),
    Appendix A for the rotation sequence.
    """
    sf, cf = np.sin(roll_rad), np.cos(roll_rad)
    st, ct = np.sin(pitch_rad), np.cos(pitch_rad)
    p = roll_rate_rad_s - yaw_rate_rad_s * st
    q = pitch_rate_rad_s * cf + yaw_rate_rad_s * ct * sf
    r = -pitch_rate_rad_s * sf + yaw_rate_rad_s * ct * cf
    return np.stack([p, q, r], axis=-1)


def body_rates_from_euler(
    roll_deg: np.ndarray, pitch_deg: np.ndarray, yaw_deg: np.ndarray, time_s: np.ndarray
) -> np.ndarray:
    """Body angular rates from an Euler-angle time series by finite differences.

    Parameters
    ----------
    roll_deg, pitch_deg, yaw_deg : numpy.ndarray
        Attitude series [degree], shape (n,); yaw may be wrapped (it is unwrapped here).
    time_s : numpy.ndarray
        Strictly increasing sample times [s], shape (n,).

    Returns
    -------
    numpy.ndarray
        (n, 3) body rates (p, q, r) [rad s-1], see :func:`euler_rates_to_body_rates`.

    Notes
    -----
    Angle rates by second-order central differences on the (possibly irregular) time
    base (``numpy.gradient``); the INS's own gyro rates are not in the L0 contract.
    """
    t = np.asarray(time_s, dtype=float)
    if t.ndim != 1 or t.size < 3 or np.any(np.diff(t) <= 0):
        raise InputError("time_s", "expected at least 3 strictly increasing sample times")
    phi = deg2rad(np.asarray(roll_deg, dtype=float))
    theta = deg2rad(np.asarray(pitch_deg, dtype=float))
    psi = unwrap_rad(deg2rad(np.asarray(yaw_deg, dtype=float)))
    return euler_rates_to_body_rates(
        phi, theta, np.gradient(phi, t), np.gradient(theta, t), np.gradient(psi, t)
    )


def lever_arm_velocity_ned(rot_body_to_ned: np.ndarray, body_rates_rad_s: np.ndarray,
                           lever_arm_m: Sequence[float]) -> np.ndarray:
    """Velocity of the INS reference point relative to the sonic, in NED.

    Parameters
    ----------
    rot_body_to_ned : numpy.ndarray
        (n, 3, 3) body-to-NED rotation matrices.
    body_rates_rad_s : numpy.ndarray
        (n, 3) body angular rates (p, q, r) [rad s-1].
    lever_arm_m : (x, y, z) [m]
        Body-frame position of the INS reference point relative to the sonic's
        measurement volume (``docs/data-contract.md``, mechanism ``lever_arm``).

    Returns
    -------
    numpy.ndarray
        (n, 3) :math:`R(\\omega_b \\times r)` [m s-1] in north, east, down.

    Notes
    -----
    With :math:`p_{ins} = p_{sonic} + R r` and :math:`\\dot R = R[\\omega_b]_\\times`,

    .. math:: V_{ins} = V_{sonic} + R(\\omega_b \\times r).
    """
    r = np.asarray(lever_arm_m, dtype=float)
    if r.shape != (3,) or not np.all(np.isfinite(r)):
        raise InputError("lever_arm_m", f"expected three finite body-frame offsets [m], got {lever_arm_m!r}")
    w_cross_r = np.cross(np.asarray(body_rates_rad_s, dtype=float), r)
    return np.einsum("nij,nj->ni", rot_body_to_ned, w_cross_r)


def ned_to_enu(v_ned: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """North-east-down vector -> (east, north, up) components (Ghirardelli et al. (2025), Eq. 2).

    Parameters
    ----------
    v_ned : numpy.ndarray
        (..., 3) vectors in north, east, down [any unit].

    Returns
    -------
    tuple of numpy.ndarray
        (east, north, up) components, same unit.

    Notes
    -----
    .. math:: U = \\begin{pmatrix}0&1&0\\\\1&0&0\\\\0&0&-1\\end{pmatrix} V_i
    """
    v = np.asarray(v_ned, dtype=float)
    return v[..., 1].copy(), v[..., 0].copy(), -v[..., 2]


def motion_correct(
    u_sensor_ms: np.ndarray, v_sensor_ms: np.ndarray, w_sensor_ms: np.ndarray, roll_deg: np.ndarray,
    pitch_deg: np.ndarray, yaw_deg: np.ndarray, vel_n_ms: np.ndarray, vel_e_ms: np.ndarray, vel_d_ms: np.ndarray,
    mount: str, lever_arm_m: Sequence[float] | None = None, body_rates_rad_s: np.ndarray | None = None,
    time_s: np.ndarray | None = None, misalignment_deg: Sequence[float] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Earth-frame wind (east, north, up) from the payload sonic and the INS.

    All series must already be on one time base (synchronised, see
    :func:`dronewind.payload.lag_search.find_sonic_ins_lag`).

    Parameters
    ----------
    u_sensor_ms, v_sensor_ms, w_sensor_ms : numpy.ndarray
        Sonic reading in the sensor frame [m s-1], shape (n,).
    roll_deg, pitch_deg, yaw_deg : numpy.ndarray
        INS attitude [degree], shape (n,).
    vel_n_ms, vel_e_ms, vel_d_ms : numpy.ndarray
        INS velocity (north, east, down) [m s-1] of the INS reference point.
    mount : {"upside_down", "upright"}
        Sonic mount, see :func:`mount_matrix`.
    lever_arm_m : (x, y, z) [m], optional
        Body-frame offset of the INS reference point from the sonic; None (default)
        means the INS outputs at the sonic (Ghirardelli et al. (2025), Sect. 3.2).
    body_rates_rad_s : numpy.ndarray, optional
        (n, 3) body rates [rad s-1] for the lever-arm term; if None and a lever arm is
        given, they are computed from the Euler angles and ``time_s``.
    time_s : numpy.ndarray, optional
        Sample times [s]; needed only to derive body rates.
    misalignment_deg : (roll, pitch, yaw) [degree], optional
        Mount misalignment, see :func:`sensor_to_body_matrix`.

    Returns
    -------
    tuple of numpy.ndarray
        ``(u_east_ms, v_north_ms, w_up_ms)`` [m s-1].

    Notes
    -----
    Ghirardelli et al. (2025), Eqs. 1 and 2 with the sign convention of ``docs/data-contract.md``:

    .. math::

        V_b = M_{mount} V_{sensor}, \\qquad
        V_{sonic} = V_{ins} - R(\\omega_b \\times r), \\qquad
        V_{wind,NED} = R(\\phi,\\theta,\\psi) V_b + V_{sonic},

    then :math:`(u_E, v_N, w_{up}) = (V_E, V_N, -V_D)`.

    References
    ----------
    Ghirardelli et al. (2025), Sect. 3.1, Eqs. 1-2 and Appendix A.
    """
    arrays = _series_1d(u_sensor_ms, v_sensor_ms, w_sensor_ms, roll_deg, pitch_deg, yaw_deg,
                        vel_n_ms, vel_e_ms, vel_d_ms)
    m = sensor_to_body_matrix(mount, misalignment_deg)
    v_sensor = np.stack(arrays[:3], axis=-1)
    v_body = v_sensor @ m.T
    # inside a forward flight's runs, the attitude a sonic probe left unchanged is not turned into
    # matrices again (dronewind.core.reuse; read-only, only read here)
    rot = reused("body-to-NED rotation", {"roll": arrays[3], "pitch": arrays[4], "yaw": arrays[5]}, "",
                 lambda: rotation_matrix_body_to_ned(arrays[3], arrays[4], arrays[5]))
    v_ins = np.stack(arrays[6:9], axis=-1)
    wind_ned = np.einsum("nij,nj->ni", rot, v_body) + v_ins
    if lever_arm_m is not None:
        rates = _body_rates(arrays[3], arrays[4], arrays[5], body_rates_rad_s, time_s)
        wind_ned -= lever_arm_velocity_ned(rot, rates, lever_arm_m)
    return ned_to_enu(wind_ned)


_SERIES = ("u_sensor_ms", "v_sensor_ms", "w_sensor_ms", "roll_deg", "pitch_deg", "yaw_deg",
           "vel_n_ms", "vel_e_ms", "vel_d_ms")


def _series_1d(*series: np.ndarray) -> list[np.ndarray]:
    """The nine input series of :func:`motion_correct` as float arrays, checked to be 1-D of one shape."""
    arrays = [np.asarray(a, dtype=float) for a in series]
    n = arrays[0].shape
    for name, a in zip(_SERIES, arrays, strict=True):
        if a.shape != n or a.ndim != 1:
            raise InputError(name, f"expected a 1-D array of shape {n}, got {a.shape}")
    return arrays


def _body_rates(roll_deg: np.ndarray, pitch_deg: np.ndarray, yaw_deg: np.ndarray,
                body_rates_rad_s: np.ndarray | None, time_s: np.ndarray | None) -> np.ndarray:
    """Body rates for the lever-arm term [rad s-1]: as given, or derived from the Euler angles.

    Raises
    ------
    InputError
        Neither rates nor times given, or rates of the wrong shape (n, 3).
    """
    n = roll_deg.shape
    if body_rates_rad_s is None:
        if time_s is None:
            raise InputError("lever_arm_m", "a lever arm needs body_rates_rad_s or time_s to derive them")
        body_rates_rad_s = body_rates_from_euler(roll_deg, pitch_deg, yaw_deg, time_s)
    rates = np.asarray(body_rates_rad_s, dtype=float)
    if rates.shape != n + (3,):
        raise InputError("body_rates_rad_s", f"expected shape {n + (3,)}, got {rates.shape}")
    return rates
