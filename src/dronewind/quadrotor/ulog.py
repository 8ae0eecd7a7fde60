"""PX4 ULog reader for quadrotor (SWUF-3D) flight logs.

A ``.ulg`` file is read with :mod:`pyulog`: attitude from the ``vehicle_attitude``
quaternion (:func:`quaternion_to_euler_deg`), velocity (NED) and position from
``vehicle_global_position`` (if logged) or ``vehicle_local_position`` (NED position relative
to ``ref_lat``/``ref_lon``/``ref_alt``); UTC from the GNSS receiver (``vehicle_gps_position``
or ``sensor_gps``, field ``time_utc_usec``). The result is the same dataset as the quadrotor
CSV gives (:mod:`dronewind.quadrotor.io`).

References
----------
.. [1] PX4 ULog file format, https://docs.px4.io/main/en/dev_log/ulog_file_format.html
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core.geo import from_local_tangent_plane
from dronewind.errors import InputError
from dronewind.quadrotor.columns import QUADROTOR_COLUMNS
from dronewind.quadrotor.io import _finish, _sort_dedupe, parse_time_utc

__all__ = [
    "quaternion_to_euler_deg",
    "read_quadrotor_ulog",
]


def quaternion_to_euler_deg(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Convert PX4 attitude quaternions (body to NED, Hamilton, ``[w, x, y, z]``) to Euler angles.

    Parameters
    ----------
    q : numpy.ndarray, shape (n, 4)
        Quaternion components ``q[0]`` (scalar) to ``q[3]``.

    Returns
    -------
    roll_deg, pitch_deg, yaw_deg : numpy.ndarray
        Z-Y-X (yaw, pitch, roll) Euler angles [degree]; yaw in (-180, 180], clockwise
        from north.

    Notes
    -----
    The rotation matrix is that of Wetz et al. (2021), Eq. D1, so that

    .. math::
        \phi = \operatorname{atan2}(2(q_0q_1+q_2q_3),\,1-2(q_1^2+q_2^2)),\quad
        \theta = \arcsin(2(q_0q_2-q_3q_1)),\quad
        \psi = \operatorname{atan2}(2(q_0q_3+q_1q_2),\,1-2(q_2^2+q_3^2)).

    The quaternion is normalised first.
    """
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    q0, q1, q2, q3 = q.T
    roll = np.arctan2(2 * (q0 * q1 + q2 * q3), 1 - 2 * (q1**2 + q2**2))
    pitch = np.arcsin(np.clip(2 * (q0 * q2 - q3 * q1), -1.0, 1.0))
    yaw = np.arctan2(2 * (q0 * q3 + q1 * q2), 1 - 2 * (q2**2 + q3**2))
    return np.degrees(roll), np.degrees(pitch), np.degrees(yaw)


def _topic(ulog: Any, name: str) -> dict[str, np.ndarray] | None:
    """Fields of the first instance of a ULog topic, or None."""
    for d in ulog.data_list:
        if d.name == name and d.multi_id == 0:
            return d.data
    return None


def _open_ulog(path: Path) -> Any:
    """Parse a ULog file with :mod:`pyulog` (errors name the file)."""
    from pyulog import ULog  # imported here: only needed for .ulg files

    if not path.is_file():
        raise InputError(path, "ULog file not found")
    try:
        return ULog(str(path))
    except Exception as exc:  # pyulog raises plain exceptions on corrupt files
        raise InputError(path, f"not a readable PX4 ULog file ({exc})") from exc


def _ulog_attitude(ulog: Any, path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Boot-time stamps [us] and roll, pitch, yaw [degree] of ``vehicle_attitude``."""
    att = _topic(ulog, "vehicle_attitude")
    if att is None or len(att["timestamp"]) == 0:
        raise InputError(f"{path} [vehicle_attitude]",
                         "the log holds no vehicle_attitude topic; attitude is needed to "
                         "measure wind from the quadrotor's tilt (Wetz et al. (2021), Sect. 4.2)")
    t_us = att["timestamp"].astype(np.int64)
    q = np.column_stack([att[f"q[{i}]"] for i in range(4)])
    roll, pitch, yaw = quaternion_to_euler_deg(q)
    return t_us, roll, pitch, yaw


def _ulog_utc_offset_us(ulog: Any, utc_start: str | None, log: list[str]) -> tuple[int, int]:
    """UTC minus boot time [us] (median over GNSS fixes) and whether it is a real UTC (1/0)."""
    for name in ("vehicle_gps_position", "sensor_gps"):
        gps = _topic(ulog, name)
        if gps is not None and "time_utc_usec" in gps:
            good = gps["time_utc_usec"] > 0
            if good.any():
                offset = int(np.median(gps["time_utc_usec"][good].astype(np.int64)
                                       - gps["timestamp"][good].astype(np.int64)))
                log.append(f"utc: from {name}.time_utc_usec ({int(good.sum())} fixes)")
                return offset, 1
    if utc_start is not None:
        origin = parse_time_utc([utc_start], "utc_start")[0]
        log.append(f"utc: no GNSS time in log; origin set to {utc_start}")
        return int(origin.astype("datetime64[us]").astype(np.int64)), 1
    log.append("utc: no GNSS time in log and no utc_start; times are boot time "
               "counted from 1970-01-01 (utc_valid = 0)")
    return 0, 0


def _interp_at(t_us: np.ndarray, src_t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Linear interpolation of a topic field to the attitude times (NaN outside its span)."""
    src_t = src_t.astype(np.int64)
    return np.interp(t_us, src_t, values.astype(float), left=np.nan, right=np.nan)


def _ulog_track(ulog: Any, t_us: np.ndarray) -> tuple[dict[str, np.ndarray], str]:
    """GNSS/EKF velocity (NED) and position at the attitude times, and where they came from.

    Local NED position is converted to latitude/longitude with a local flat-earth
    approximation about (``ref_lat``, ``ref_lon``) (error < 1 mm over a few hundred
    metres); altitude is ``ref_alt - z``.
    """
    nan = np.full(t_us.size, np.nan)
    tr = {k: nan.copy() for k in ("vel_n_ms", "vel_e_ms", "vel_d_ms", "lat_deg", "lon_deg", "alt_m")}
    source = "none"
    lpos = _topic(ulog, "vehicle_local_position")
    gpos = _topic(ulog, "vehicle_global_position")
    if lpos is not None and len(lpos["timestamp"]):
        for key, field in (("vel_n_ms", "vx"), ("vel_e_ms", "vy"), ("vel_d_ms", "vz")):
            tr[key] = _interp_at(t_us, lpos["timestamp"], lpos[field])
        ref_lat = float(np.median(lpos["ref_lat"]))
        ref_lon = float(np.median(lpos["ref_lon"]))
        ref_alt = float(np.median(lpos["ref_alt"]))
        x_n, y_e, z_d = (_interp_at(t_us, lpos["timestamp"], lpos[k]) for k in ("x", "y", "z"))
        tr["lat_deg"], tr["lon_deg"] = from_local_tangent_plane(y_e, x_n, ref_lat, ref_lon)
        tr["alt_m"] = ref_alt - z_d
        source = "vehicle_local_position"
    if gpos is not None and len(gpos["timestamp"]):
        for key, field in (("lat_deg", "lat"), ("lon_deg", "lon"), ("alt_m", "alt")):
            tr[key] = _interp_at(t_us, gpos["timestamp"], gpos[field])
        source = "vehicle_global_position" + ("+local velocity" if lpos is not None else "")
        if lpos is None and "vel_n" in gpos:
            for key, field in (("vel_n_ms", "vel_n"), ("vel_e_ms", "vel_e"), ("vel_d_ms", "vel_d")):
                tr[key] = _interp_at(t_us, gpos["timestamp"], gpos[field])
    lpos_global = lpos is not None and "xy_global" in lpos and bool(np.any(lpos["xy_global"]))
    if gpos is None and not lpos_global:
        source = _ulog_receiver_position(ulog, t_us, tr, source)
    return tr, source


def _ulog_receiver_position(ulog: Any, t_us: np.ndarray, track: dict[str, np.ndarray], source: str) -> str:
    """Position from the raw GNSS receiver (lat/lon in 1e-7 degree, alt in mm above MSL), if it
    has a fix: for a local frame without a global reference. Updates ``track``; returns the source."""
    for name in ("vehicle_gps_position", "sensor_gps"):
        gps = _topic(ulog, name)
        if gps is not None and "lat" in gps and np.any(gps["lat"] != 0):
            fix = gps["lat"] != 0
            track["lat_deg"] = _interp_at(t_us, gps["timestamp"][fix], gps["lat"][fix] * 1e-7)
            track["lon_deg"] = _interp_at(t_us, gps["timestamp"][fix], gps["lon"][fix] * 1e-7)
            track["alt_m"] = _interp_at(t_us, gps["timestamp"][fix], gps["alt"][fix] * 1e-3)
            return f"{name} position + {source} velocity"
    return source


def read_quadrotor_ulog(path: str | Path, utc_start: str | None = None) -> xr.Dataset:
    """Read a PX4 ULog file into the quadrotor dataset (same layout as the CSV reader).

    Parameters
    ----------
    path : str or Path
        ``.ulg`` file.
    utc_start : str, optional
        ISO 8601 UTC time of the log's boot-time origin, used only if the log holds no
        GNSS UTC time (bench logs). Without either, times count from 1970-01-01 and
        ``attrs['utc_valid'] = 0``.

    Returns
    -------
    xarray.Dataset
        As :func:`read_quadrotor_csv`, at the ``vehicle_attitude`` time stamps. Velocity
        and position are linearly interpolated from their topics to those times (NaN
        outside their time span). attrs: ``utc_valid`` (0/1), ``utc_offset_us``,
        ``position_source``, ``n_position_missing`` (attitude samples without position).

    Raises
    ------
    InputError
        Unreadable file, or no ``vehicle_attitude`` topic.

    Notes
    -----
    UTC is the median offset between the GNSS receiver's ``time_utc_usec`` and boot
    time. Position: ``vehicle_global_position`` if logged, else ``vehicle_local_position``
    about its reference point, else the raw receiver (see :func:`_ulog_track`).
    """
    path = Path(path)
    ulog = _open_ulog(path)
    log = [f"read: ULog {path.name} ({len(ulog.data_list)} topics)"]
    t_us, roll, pitch, yaw = _ulog_attitude(ulog, path)
    utc_offset_us, utc_valid = _ulog_utc_offset_us(ulog, utc_start, log)
    track, source = _ulog_track(ulog, t_us)
    n_pos_missing = int(np.sum(~np.isfinite(track["lat_deg"]) | ~np.isfinite(track["vel_n_ms"])))
    log.append(f"position: from {source}; {n_pos_missing} attitude samples without "
               "position or velocity (NaN)")
    time = (t_us + utc_offset_us).astype("datetime64[us]").astype("datetime64[ns]")
    data = {"roll_deg": roll, "pitch_deg": pitch, "yaw_deg": yaw, **track}
    ds = xr.Dataset({k: ("time", data[k]) for k in QUADROTOR_COLUMNS[1:]}, coords={"time": time})
    ds = _sort_dedupe(ds, log)
    ds.attrs.update({"utc_valid": utc_valid, "utc_offset_us": utc_offset_us,
                     "position_source": source, "n_position_missing": n_pos_missing,
                     "n_nonfinite": 0})
    return _finish(ds, path, log)
