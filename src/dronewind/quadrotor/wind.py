r"""Wind from the attitude of a hovering quadrotor (the inversion of the drag balance).

:func:`wind_from_attitude` turns logged roll, pitch and yaw into the horizontal wind with
one of the drag laws of :mod:`dronewind.quadrotor.drag`; :func:`uav_wind_dataset` makes
the calibrated wind time series of one UAV's hover (Wetz et al. (2021), Sect. 6).

``pitch_offset_deg`` and ``yaw_offset_deg`` are logged minus true; corrections subtract
them. Wind is returned as speed, direction the wind blows *from*, and east/north
components of the vector the air moves *to*.

GNSS velocity correction (Kistner et al. (2024), Eq. 1): the drag balance gives the air velocity
relative to the vehicle; the wind is that plus the vehicle's GNSS velocity (Kistner et al. (2024)
writes a minus sign because its relative-velocity vector is defined the other way).

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F. (SWUF-3D), Wetz et al. (2021)
  , Sects. 4-6, Eqs. 12-17.
.. [2] Wind-tunnel calibration and verification of the SWUF-3D quadrotors, Kistner et al. (2024)
  , Eqs. 1-2.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import numpy.typing as npt
import pandas as pd
import xarray as xr

from dronewind.errors import InputError
from dronewind.quadrotor.drag import (
    DragLaw,
    body_accelerations_ms2,
    body_axis_relative_air,
    rotation_body_to_ned,
    speed_from_tilt,
    tilt_from_attitude,
)
from dronewind.quadrotor.hover import hover_segment

__all__ = ["corrected_attitude_rad", "drag_balance_direction", "relative_air_from_direction",
           "relative_air_drag_balance", "relative_air_body_axis",
           "wind_from_attitude", "block_average_log", "uav_wind_dataset"]


def corrected_attitude_rad(roll_deg: npt.ArrayLike, pitch_deg: npt.ArrayLike, yaw_deg: npt.ArrayLike,
                           roll_offset_deg: float | np.ndarray = 0.0,
                           pitch_offset_deg: float | np.ndarray = 0.0,
                           yaw_offset_deg: float | np.ndarray = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Logged attitude minus the offsets (logged minus true), in radians.

    Parameters
    ----------
    roll_deg, pitch_deg, yaw_deg : array_like
        Attitude as logged [degree].
    roll_offset_deg, pitch_offset_deg, yaw_offset_deg : float or array_like
        Logged minus true [degree].

    Returns
    -------
    roll_rad, pitch_rad, yaw_rad : numpy.ndarray
        True attitude [rad].
    """
    phi = np.radians(np.asarray(roll_deg, float) - roll_offset_deg)
    th = np.radians(np.asarray(pitch_deg, float) - pitch_offset_deg)
    psi = np.radians(np.asarray(yaw_deg, float) - yaw_offset_deg)
    return phi, th, psi


def relative_air_drag_balance(roll_rad: np.ndarray, pitch_rad: np.ndarray, yaw_rad: np.ndarray,
                              law: DragLaw, method: str = "tilt") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Air velocity relative to the vehicle from the ``rayleigh`` drag balance (Wetz et al. (2021), Eqs. 12-17).

    Parameters
    ----------
    roll_rad, pitch_rad, yaw_rad : numpy.ndarray
        True attitude [rad].
    law : DragLaw
        ``law="rayleigh"``.
    method : {"tilt", "pitch"}
        ``pitch``: Wetz et al. (2021), Eq. 13 literally (pitch only, direction = yaw); ``tilt``: the
        same balance on the total tilt from roll and pitch, direction from the lean
        direction.

    Returns
    -------
    air_n_ms, air_e_ms : numpy.ndarray
        North and east components of the air velocity relative to the vehicle [m s-1].
    relative_speed_ms : numpy.ndarray
        Signed speed from the drag balance [m s-1].

    Notes
    -----
    .. math:: V_{rel} = \sqrt{\frac{2 m g\sin\gamma}{\rho\,(c_{d,0}A_0+c_p\gamma)}},\qquad
              \mathbf{V}_{air} = -V_{rel}\,\hat{\mathbf{e}}(\psi_{lean})

    where :math:`\hat{\mathbf{e}}(\psi_{lean})` is the horizontal unit vector towards
    which the vehicle leans (into the wind).
    """
    return relative_air_from_direction(*drag_balance_direction(roll_rad, pitch_rad, yaw_rad, method), law)


def drag_balance_direction(roll_rad: np.ndarray, pitch_rad: np.ndarray, yaw_rad: np.ndarray, method: str = "tilt"
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The attitude part of :func:`relative_air_drag_balance`: the tilt and the lean direction.

    Parameters
    ----------
    roll_rad, pitch_rad, yaw_rad : numpy.ndarray
        True attitude [rad].
    method : {"tilt", "pitch"}
        As :func:`relative_air_drag_balance`.

    Returns
    -------
    tilt_rad : numpy.ndarray
        Tilt into the wind [rad] (``pitch``: minus the pitch).
    cos_lean, sin_lean : numpy.ndarray
        Cosine and sine of the direction the vehicle leans to, clockwise from north.
    """
    if method == "tilt":
        tilt, lean_rel = tilt_from_attitude(roll_rad, pitch_rad)
        lean = yaw_rad + lean_rel
    else:
        tilt, lean = -pitch_rad, yaw_rad
    return tilt, np.cos(lean), np.sin(lean)


def relative_air_from_direction(tilt_rad: np.ndarray, cos_lean: np.ndarray, sin_lean: np.ndarray, law: DragLaw
                                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The drag-law part of :func:`relative_air_drag_balance` (Wetz et al. (2021), Eqs. 12-17).

    Parameters
    ----------
    tilt_rad, cos_lean, sin_lean : numpy.ndarray
        :func:`drag_balance_direction` output.
    law : DragLaw
        ``law="rayleigh"``.

    Returns
    -------
    air_n_ms, air_e_ms, relative_speed_ms : numpy.ndarray
        As :func:`relative_air_drag_balance` [m s-1].
    """
    vrel = speed_from_tilt(tilt_rad, law.cd0a0_m2, law.cp_m2_per_rad, law.mass_kg, law.rho_kgm3)
    return -vrel * cos_lean, -vrel * sin_lean, vrel


def relative_air_body_axis(roll_rad: np.ndarray, pitch_rad: np.ndarray, yaw_rad: np.ndarray,
                           law: DragLaw) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Air velocity relative to the vehicle from the body-axis law (Kistner et al. (2024), Eq. 1).

    Parameters
    ----------
    roll_rad, pitch_rad, yaw_rad : numpy.ndarray
        True attitude [rad].
    law : DragLaw
        ``law="body_axis"``.

    Returns
    -------
    air_n_ms, air_e_ms : numpy.ndarray
        North and east components [m s-1].
    relative_speed_ms : numpy.ndarray
        Their magnitude [m s-1].

    Notes
    -----
    :math:`\mathbf{V}_{air} = R\,(u, v, 0)^T`, horizontal rows, with :math:`(u, v)` from
    :func:`dronewind.quadrotor.drag.body_axis_relative_air`.
    """
    ax, ay = body_accelerations_ms2(roll_rad, pitch_rad)
    u, v, _ = body_axis_relative_air(ax, ay, law)
    r = rotation_body_to_ned(roll_rad, pitch_rad, yaw_rad)
    air_n = r[..., 0, 0] * u + r[..., 0, 1] * v
    air_e = r[..., 1, 0] * u + r[..., 1, 1] * v
    return air_n, air_e, np.hypot(air_n, air_e)


def _check_method(method: str, law: DragLaw) -> None:
    """Raise InputError unless the method and the drag law go together."""
    if method in ("tilt", "pitch"):
        if law.law != "rayleigh":
            raise InputError("wind_from_attitude", f"method {method!r} needs law 'rayleigh'")
    elif method == "body_axis":
        if law.law != "body_axis":
            raise InputError("wind_from_attitude", "method 'body_axis' needs law 'body_axis'")
    else:
        raise InputError("wind_from_attitude", f"method {method!r}; expected tilt, pitch or body_axis")


def wind_from_attitude(roll_deg: npt.ArrayLike, pitch_deg: npt.ArrayLike, yaw_deg: npt.ArrayLike,
                       vel_n_ms: npt.ArrayLike = 0.0, vel_e_ms: npt.ArrayLike = 0.0,
                       law: DragLaw | None = None, pitch_offset_deg: float | np.ndarray = 0.0,
                       yaw_offset_deg: float | np.ndarray = 0.0, method: str = "tilt",
                       roll_offset_deg: float | np.ndarray = 0.0) -> dict[str, np.ndarray]:
    r"""Horizontal wind from the attitude of a hovering quadrotor.

    Parameters
    ----------
    roll_deg, pitch_deg, yaw_deg : array_like
        Attitude as logged [degree].
    vel_n_ms, vel_e_ms : array_like
        GNSS velocity of the vehicle [m s-1] (Kistner et al. (2024), Eq. 1 correction).
    law : DragLaw, optional
        Drag law (default: rayleigh with Wetz et al. (2021), Eq. 18).
    pitch_offset_deg, yaw_offset_deg : float
        Logged minus true pitch and yaw [degree]; subtracted before use.
    roll_offset_deg : float
        Logged minus true roll [degree] (accelerometer offset, Kistner et al. (2024), Sect. 3.2.1).
    method : {"tilt", "pitch", "body_axis"}
        ``pitch``: Wetz et al. (2021), Eq. 13 literally (pitch only, direction = corrected yaw);
        ``tilt``: the same balance on the total tilt from roll and pitch, direction from
        the lean direction (equal to ``pitch`` when the roll is zero); ``body_axis``:
        Kistner et al. (2024), Eq. 1 (forces law must be ``body_axis``).

    Returns
    -------
    dict of numpy.ndarray
        ``speed_ms``, ``wind_from_deg`` (0-360, from the corrected wind vector),
        ``u_east_ms``, ``v_north_ms`` (the air moves towards), ``relative_speed_ms``
        (speed from the drag balance alone, before the GNSS correction), ``yaw_from_deg``
        (corrected yaw, the weather-vane direction estimate, Wetz et al. (2021), Sect. 5.4).

    Notes
    -----
    :math:`\mathbf{V} = \mathbf{V}_{air} + \dot{\mathbf{x}}_{gnss}` with the relative air
    velocity of :func:`relative_air_drag_balance` (``pitch``/``tilt``, Wetz et al. (2021), Eqs.
    12-17) or :func:`relative_air_body_axis` (``body_axis``, Kistner et al. (2024), Eq. 1).
    """
    law = law or DragLaw()
    phi, th, psi = corrected_attitude_rad(roll_deg, pitch_deg, yaw_deg, roll_offset_deg,
                                          pitch_offset_deg, yaw_offset_deg)
    _check_method(method, law)
    if method == "body_axis":
        air_n, air_e, vrel = relative_air_body_axis(phi, th, psi, law)
    else:
        air_n, air_e, vrel = relative_air_drag_balance(phi, th, psi, law, method)
    wn = air_n + np.asarray(vel_n_ms, float)
    we = air_e + np.asarray(vel_e_ms, float)
    return {
        "speed_ms": np.hypot(wn, we),
        "wind_from_deg": np.degrees(np.arctan2(-we, -wn)) % 360.0,
        "u_east_ms": we,
        "v_north_ms": wn,
        "relative_speed_ms": np.asarray(vrel, float),
        "yaw_from_deg": np.degrees(psi) % 360.0,
    }


# --------------------------------------------------------------------------------------
# Calibrated wind series of one UAV
# --------------------------------------------------------------------------------------

_AVERAGED = ("roll_deg", "pitch_deg", "vel_n_ms", "vel_e_ms", "lat_deg", "lon_deg", "alt_m")


def block_average_log(log: xr.Dataset, average_s: float) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Block averages of a quadrotor log (yaw as a circular mean), stamped at the block centres.

    Parameters
    ----------
    log : xarray.Dataset
        Quadrotor log (hover samples).
    average_s : float
        Block length [s]; 0 keeps the log rate.

    Returns
    -------
    time : numpy.ndarray of datetime64[ns]
        Block centres (or the log's times).
    columns : dict of numpy.ndarray
        ``roll_deg``, ``pitch_deg``, ``yaw_deg`` (in (-180, 180]), ``vel_n_ms``,
        ``vel_e_ms``, ``lat_deg``, ``lon_deg``, ``alt_m`` (and, at the log rate, every
        other variable of the log).
    """
    if average_s <= 0:
        return log["time"].to_numpy(), {str(c): log[c].to_numpy() for c in log.data_vars}
    t0 = log["time"].to_numpy()[0]
    k = ((log["time"].to_numpy() - t0).astype("int64") // int(average_s * 1e9))
    frame = pd.DataFrame({v: log[v].to_numpy() for v in _AVERAGED})
    frame["sy"] = np.sin(np.radians(log["yaw_deg"].to_numpy()))
    frame["cy"] = np.cos(np.radians(log["yaw_deg"].to_numpy()))
    frame["k"] = k
    g = frame.groupby("k").mean()
    g["yaw_deg"] = np.degrees(np.arctan2(g["sy"], g["cy"]))
    time = t0 + (g.index.to_numpy() * int(average_s * 1e9) + int(average_s * 5e8)).astype("timedelta64[ns]")
    return time, {c: g[c].to_numpy() for c in g.columns}


def _wind_series_dataset(time: np.ndarray, wind: Mapping[str, np.ndarray],
                         columns: Mapping[str, np.ndarray]) -> xr.Dataset:
    """Wind and position variables of :func:`uav_wind_dataset` with their CF attributes."""
    return xr.Dataset(
        {"wind_speed_ms": ("time", wind["speed_ms"], {"units": "m s-1", "standard_name": "wind_speed"}),
         "wind_from_deg": ("time", wind["wind_from_deg"], {"units": "degree",
                                                           "standard_name": "wind_from_direction"}),
         "u_east_ms": ("time", wind["u_east_ms"], {"units": "m s-1", "standard_name": "eastward_wind"}),
         "v_north_ms": ("time", wind["v_north_ms"], {"units": "m s-1", "standard_name": "northward_wind"}),
         "yaw_from_deg": ("time", wind["yaw_from_deg"], {
             "units": "degree", "long_name": "wind-from direction from corrected yaw (weather vane)"}),
         "lat_deg": ("time", columns["lat_deg"], {"units": "degrees_north", "standard_name": "latitude"}),
         "lon_deg": ("time", columns["lon_deg"], {"units": "degrees_east", "standard_name": "longitude"}),
         "alt_m": ("time", columns["alt_m"], {"units": "m", "standard_name": "altitude"})},
        coords={"time": time})


def uav_wind_dataset(ds: xr.Dataset, law: DragLaw | None = None, pitch_offset_deg: float = 0.0,
                     yaw_offset_deg: float = 0.0, method: str = "tilt", average_s: float = 1.0,
                     hover_kwargs: Mapping | None = None) -> xr.Dataset:
    r"""Calibrated wind time series of one hovering UAV (Wetz et al. (2021), Sect. 6: 1 Hz series).

    Parameters
    ----------
    ds : xarray.Dataset
        Quadrotor log (:func:`dronewind.quadrotor.io.read_quadrotor`).
    law : DragLaw, optional
        Drag law (default Wetz et al. (2021), Eq. 18).
    pitch_offset_deg, yaw_offset_deg : float
        Calibrated offsets (logged minus true) [degree].
    method : str
        See :func:`wind_from_attitude`.
    average_s : float
        Block average of the output [s] (attitude averaged first, as in
        :func:`dronewind.quadrotor.windows.flight_windows`); 0 keeps the log rate.
    hover_kwargs : mapping, optional
        Passed to :func:`dronewind.quadrotor.hover.hover_segment`.

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
    time, cols = block_average_log(ds.isel(time=np.flatnonzero(mask)), average_s)
    w = wind_from_attitude(cols["roll_deg"], cols["pitch_deg"], cols["yaw_deg"], cols["vel_n_ms"],
                           cols["vel_e_ms"], law=law, pitch_offset_deg=pitch_offset_deg,
                           yaw_offset_deg=yaw_offset_deg, method=method)
    out = _wind_series_dataset(time, w, cols)
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
