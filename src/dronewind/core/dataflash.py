r"""ArduPilot DataFlash logs (``.bin``): attitude, EKF velocity, position, wind, barometer on one UTC axis.

ArduPilot, the autopilot of many research multicopters, writes a self-describing binary
log: ``FMT`` messages declare every message type, and each row carries ``TimeUS``
(microseconds since boot). :mod:`pymavlink` (``mavutil.mavlink_connection`` with its
``DFReader``) parses it; this module only picks the messages the wind measurement uses and
puts them on one time axis in UTC:

* ``ATT``: ``Roll``, ``Pitch``, ``Yaw`` [degree] and the controller's set points
  ``DesRoll``, ``DesPitch``, ``DesYaw``; its time stamps are the record's;
* ``XKF1`` (EKF3) or ``NKF1`` (EKF2), one row per EKF core ``C``: ``VN``, ``VE``, ``VD``
  [m s-1, NED] and ``PN``, ``PE``, ``PD`` [m, NED from the EKF origin ``ORGN``];
* ``XKF2`` / ``NKF2``: ``VWN``, ``VWE``, the EKF's own wind estimate (north and east
  components of the velocity of the air over ground [m s-1]); exactly zero until the EKF
  starts estimating wind, such rows are set to NaN and counted;
* ``POS`` (``Lat``, ``Lng``, ``Alt``): the position; without it, ``ORGN`` plus ``PN``,
  ``PE``, ``PD``;
* ``GPS``: ``GWk`` (GPS week) and ``GMS`` (milliseconds of the week) give UTC:
  :func:`gps_to_utc_ns` subtracts the leap seconds of :data:`GPS_UTC_LEAP_SECONDS`;
* ``BARO``: ``Alt`` [m above the arming point], ``Press`` [Pa], ``Temp`` [degC] (the
  sensor's temperature, inside the airframe: not the air's);
* ``PARM``: the parameters of :data:`KEPT_PARAMETERS` (attitude trims, the EKF's drag model,
  the frame) as ``attrs['param_<NAME>']``.

Every stream is linearly interpolated to the ``ATT`` times (NaN outside its own time span).
:func:`read_dataflash` gives the platform variables of the project (``roll_deg`` ... ``alt_m``)
plus the set points, the EKF wind, the barometer and the EKF position, with counts in
``attrs`` and a ``processing_log``; :mod:`dronewind.quadrotor.ardupilot` makes it a quadrotor
record, :mod:`dronewind.payload.rigid` reads it as the platform state of a rigid mount.

References
----------
.. [1] ArduPilot onboard log messages, https://ardupilot.org/copter/docs/logmessages.html
.. [2] IERS Bulletin C (leap seconds), https://hpiers.obspm.fr/iers/bul/bulc/bulletinc.dat
.. [3] Wetz, T., Wildmann, N., Beyrich, F. (2021): Distributed wind measurements with
   multiple quadrotor unmanned aerial vehicles in the atmospheric boundary layer
   (SWUF-3D), Sect. 2 (the attitude, velocity and position a tilt-based wind needs).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core.geo import from_local_tangent_plane
from dronewind.errors import InputError

__all__ = [
    "GPS_EPOCH", "GPS_UTC_LEAP_SECONDS", "LEAP_TABLE_VALID_UNTIL", "gps_utc_offset_s", "gps_to_utc_ns",
    "KEPT_PARAMETERS", "PLATFORM_VARIABLES", "read_dataflash_messages", "read_dataflash",
]

#: The platform variables (the names of the project's platform state).
PLATFORM_VARIABLES: tuple[str, ...] = (
    "roll_deg", "pitch_deg", "yaw_deg", "vel_n_ms", "vel_e_ms", "vel_d_ms", "lat_deg", "lon_deg", "alt_m")

#: Start of GPS time (GPS week 0), UTC.
GPS_EPOCH = np.datetime64("1980-01-06T00:00:00", "ns")

#: GPS minus UTC [s] from each UTC date on (IERS Bulletin C; GPS time has no leap seconds
#: and was equal to UTC at :data:`GPS_EPOCH`). 18 s since 2017-01-01.
GPS_UTC_LEAP_SECONDS: tuple[tuple[str, int], ...] = (
    ("1980-01-06", 0), ("1981-07-01", 1), ("1982-07-01", 2), ("1983-07-01", 3), ("1985-07-01", 4),
    ("1988-01-01", 5), ("1990-01-01", 6), ("1991-01-01", 7), ("1992-07-01", 8), ("1993-07-01", 9),
    ("1994-07-01", 10), ("1996-01-01", 11), ("1997-07-01", 12), ("1999-01-01", 13), ("2006-01-01", 14),
    ("2009-01-01", 15), ("2012-07-01", 16), ("2015-07-01", 17), ("2017-01-01", 18),
)
#: Last UTC day the table is known to hold for: IERS Bulletin C 70 (July 2025) announced no
#: leap second at the end of December 2025. Later times use the last offset and say so.
LEAP_TABLE_VALID_UNTIL = np.datetime64("2025-12-31T23:59:59", "ns")

_LEAP_STARTS = np.array([np.datetime64(d, "ns") for d, _ in GPS_UTC_LEAP_SECONDS])
_LEAP_VALUES = np.array([v for _, v in GPS_UTC_LEAP_SECONDS], dtype=np.int64)
_WEEK_NS = 7 * 86400 * 10**9

#: Messages read, with the fields kept.
_MESSAGES: dict[str, tuple[str, ...]] = {
    "ATT": ("TimeUS", "Roll", "Pitch", "Yaw", "DesRoll", "DesPitch", "DesYaw"),
    "XKF1": ("TimeUS", "C", "VN", "VE", "VD", "PN", "PE", "PD"),
    "NKF1": ("TimeUS", "VN", "VE", "VD", "PN", "PE", "PD"),
    "XKF2": ("TimeUS", "C", "VWN", "VWE"),
    "NKF2": ("TimeUS", "VWN", "VWE"),
    "POS": ("TimeUS", "Lat", "Lng", "Alt"),
    "ORGN": ("TimeUS", "Type", "Lat", "Lng", "Alt"),
    "GPS": ("TimeUS", "Status", "GWk", "GMS"),
    "BARO": ("TimeUS", "I", "Alt", "Press", "Temp"),
    "PARM": ("Name", "Value"),
}

#: Parameters kept in the dataset's attrs (``param_<NAME>``): the attitude trims, the EKF's
#: drag model (with which a multicopter's EKF3 estimates wind) and the frame.
KEPT_PARAMETERS: tuple[str, ...] = (
    "AHRS_TRIM_X", "AHRS_TRIM_Y", "AHRS_ORIENTATION", "EK3_DRAG_BCOEF_X", "EK3_DRAG_BCOEF_Y", "EK3_DRAG_MCOEF",
    "EK3_WIND_P_NSE", "EK3_WIND_PSCALE", "FRAME_CLASS", "FRAME_TYPE", "MOT_THST_HOVER")

_ATTRS: dict[str, dict[str, str]] = {
    "des_roll_deg": {"units": "degree", "long_name": "roll set point of the attitude controller (DesRoll)"},
    "des_pitch_deg": {"units": "degree", "long_name": "pitch set point of the attitude controller (DesPitch)"},
    "des_yaw_deg": {"units": "degree", "long_name": "yaw set point of the attitude controller (DesYaw)"},
    "ekf_wind_n_ms": {"units": "m s-1", "standard_name": "northward_wind",
                      "long_name": "EKF wind estimate, north component of the air velocity (VWN)"},
    "ekf_wind_e_ms": {"units": "m s-1", "standard_name": "eastward_wind",
                      "long_name": "EKF wind estimate, east component of the air velocity (VWE)"},
    "pos_n_m": {"units": "m", "long_name": "EKF position north of the EKF origin (PN)"},
    "pos_e_m": {"units": "m", "long_name": "EKF position east of the EKF origin (PE)"},
    "pos_d_m": {"units": "m", "long_name": "EKF position below the EKF origin (PD)"},
    "baro_alt_m": {"units": "m", "long_name": "barometric altitude above the arming point (BARO.Alt)"},
    "pressure_pa": {"units": "Pa", "standard_name": "air_pressure", "long_name": "barometer pressure (BARO.Press)"},
    "baro_temp_degc": {"units": "degC", "long_name": "barometer sensor temperature (BARO.Temp), inside the airframe"},
}


def gps_utc_offset_s(utc: np.ndarray) -> np.ndarray:
    """GPS minus UTC [s] at UTC times, from :data:`GPS_UTC_LEAP_SECONDS`.

    Parameters
    ----------
    utc : numpy.ndarray of datetime64
        Times (UTC).

    Returns
    -------
    numpy.ndarray of int64
        Leap seconds between GPS time and UTC.
    """
    k = np.searchsorted(_LEAP_STARTS, np.asarray(utc, dtype="datetime64[ns]"), side="right") - 1
    return _LEAP_VALUES[np.clip(k, 0, _LEAP_VALUES.size - 1)]


def gps_to_utc_ns(week: np.ndarray, ms_of_week: np.ndarray) -> np.ndarray:
    """UTC of GPS week and milliseconds of week.

    Parameters
    ----------
    week : array_like of int
        GPS week (``GWk``; weeks since :data:`GPS_EPOCH`, not rolled over).
    ms_of_week : array_like
        Milliseconds of the week (``GMS``).

    Returns
    -------
    numpy.ndarray of datetime64[ns]
        UTC = GPS time minus the leap seconds in force (:func:`gps_utc_offset_s`).
    """
    gps_ns = (np.asarray(week, dtype=np.int64) * _WEEK_NS
              + np.round(np.asarray(ms_of_week, dtype=float) * 1e6).astype(np.int64))
    gps = GPS_EPOCH + gps_ns.astype("timedelta64[ns]")
    # the offset is looked up at GPS time minus the current offset: right except within the
    # leap second itself
    approx = gps - np.timedelta64(int(_LEAP_VALUES[-1]), "s")
    return gps - gps_utc_offset_s(approx).astype("timedelta64[s]").astype("timedelta64[ns]")


def read_dataflash_messages(path: str | Path, types: Sequence[str] | None = None) -> dict[str, dict[str, np.ndarray]]:
    """Fields of the messages of a DataFlash log, as arrays per message type.

    Parameters
    ----------
    path : str or Path
        ArduPilot DataFlash ``.bin`` file.
    types : sequence of str, optional
        Message types to read (default: those of the wind measurement).

    Returns
    -------
    dict
        Message type -> field -> array (types absent from the log are absent here).

    Raises
    ------
    InputError
        Missing or unreadable file.
    """
    from pymavlink import mavutil  # the DataFlash parser: imported only where one is read

    path = Path(path)
    if not path.is_file():
        raise InputError(path, "ArduPilot DataFlash log not found")
    wanted = {t: _MESSAGES.get(t) for t in (types or _MESSAGES)}
    rows: dict[str, list[dict[str, Any]]] = {t: [] for t in wanted}
    try:
        conn = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
        while (msg := conn.recv_match(type=list(wanted))) is not None:
            rows[msg.get_type()].append(msg.to_dict())
    except Exception as exc:  # pymavlink raises plain exceptions on a corrupt file
        raise InputError(path, f"not a readable ArduPilot DataFlash log ({type(exc).__name__}: {exc})") from exc
    out: dict[str, dict[str, np.ndarray]] = {}
    for t, r in rows.items():
        if not r:
            continue
        fields = wanted[t] or tuple(k for k in r[0] if k != "mavpackettype")
        out[t] = {f: np.array([row.get(f, np.nan) for row in r]) for f in fields}
    return out


def _interp(t_us: np.ndarray, src_t_us: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Linear interpolation to ``t_us`` (NaN outside the source's span or with no source)."""
    ok = np.isfinite(values)
    if ok.sum() < 2:
        return np.full(t_us.size, np.nan)
    order = np.argsort(src_t_us[ok], kind="stable")
    return np.interp(t_us, src_t_us[ok][order].astype(float), values[ok][order].astype(float),
                     left=np.nan, right=np.nan)


def _one_core(msg: dict[str, np.ndarray], core: int) -> dict[str, np.ndarray]:
    """Rows of one EKF core (messages without a core column are returned whole)."""
    if "C" not in msg:
        return msg
    keep = msg["C"] == core
    return {k: v[keep] for k, v in msg.items()}


def _utc_offset_ns(msgs: dict[str, dict[str, np.ndarray]], path: Path, log: list[str]) -> tuple[int, int]:
    """UTC minus boot time [ns] from the GPS fixes (median) and whether it is valid (1/0)."""
    gps = msgs.get("GPS")
    if gps is not None:
        good = (gps["GWk"] > 0) & (gps["Status"] >= 3)
        if good.any():
            utc = gps_to_utc_ns(gps["GWk"][good], gps["GMS"][good])
            # to whole microseconds, the resolution of the boot clock
            diff_ns = utc.astype(np.int64) - gps["TimeUS"][good].astype(np.int64) * 1000
            off = 1000 * int(round(float(np.median(diff_ns)) / 1000))
            leap = int(gps_utc_offset_s(utc[:1])[0])
            log.append(f"utc: GPS week and ms of week of {int(good.sum())} 3-D fixes, minus {leap} leap seconds")
            if utc[-1] > LEAP_TABLE_VALID_UNTIL:
                log.append("utc: the log is later than the leap-second table is known to hold "
                           f"({np.datetime_as_string(LEAP_TABLE_VALID_UNTIL, 'D')}); {leap} s used")
            return off, 1
    log.append(f"utc: no GPS 3-D fix in {path.name}; times are boot time counted from 1970-01-01 (utc_valid = 0)")
    return 0, 0


def _position(msgs: dict[str, dict[str, np.ndarray]], ekf: dict[str, np.ndarray] | None,
              t_us: np.ndarray) -> tuple[dict[str, np.ndarray], str]:
    """Latitude, longitude, altitude at the attitude times: POS, else ORGN + EKF position."""
    nan = np.full(t_us.size, np.nan)
    pos = msgs.get("POS")
    if pos is not None and pos["TimeUS"].size >= 2:
        return {"lat_deg": _interp(t_us, pos["TimeUS"], pos["Lat"]),
                "lon_deg": _interp(t_us, pos["TimeUS"], pos["Lng"]),
                "alt_m": _interp(t_us, pos["TimeUS"], pos["Alt"])}, "POS"
    orgn = msgs.get("ORGN")
    if orgn is not None and ekf is not None and orgn["Lat"].size:
        k = int(np.flatnonzero(orgn["Type"] == 0)[0]) if np.any(orgn["Type"] == 0) else 0
        lat0, lon0, alt0 = float(orgn["Lat"][k]), float(orgn["Lng"][k]), float(orgn["Alt"][k])
        pn, pe, pd_ = (_interp(t_us, ekf["TimeUS"], ekf[f]) for f in ("PN", "PE", "PD"))
        lat, lon = from_local_tangent_plane(pe, pn, lat0, lon0)
        return {"lat_deg": lat, "lon_deg": lon, "alt_m": alt0 - pd_}, "ORGN + EKF position"
    return {"lat_deg": nan, "lon_deg": nan.copy(), "alt_m": nan.copy()}, "none"


def read_dataflash(path: str | Path, ekf_core: int = 0) -> xr.Dataset:
    """Read an ArduPilot DataFlash log: its attitude, EKF, position, barometer on the ``ATT`` times.

    Parameters
    ----------
    path : str or Path
        DataFlash ``.bin`` file.
    ekf_core : int
        EKF core (``C``) whose velocity, position and wind are read (0: the first).

    Returns
    -------
    xarray.Dataset
        Dimension ``time`` (UTC, at the ``ATT`` rows, as logged: not sorted): ``roll_deg``,
        ``pitch_deg``, ``yaw_deg`` (clockwise from north, [0, 360)), ``vel_n_ms``,
        ``vel_e_ms``, ``vel_d_ms``, ``lat_deg``, ``lon_deg``, ``alt_m``, and
        ``des_roll_deg``, ``des_pitch_deg``, ``des_yaw_deg``, ``ekf_wind_n_ms``,
        ``ekf_wind_e_ms``, ``pos_n_m``, ``pos_e_m``, ``pos_d_m``, ``baro_alt_m``,
        ``pressure_pa``, ``baro_temp_degc``. attrs: ``utc_valid``, ``utc_offset_us``,
        ``ekf`` (EKF3 or EKF2), ``ekf_core``, ``position_source``, ``n_ekf_wind_unset`` (rows
        whose EKF wind is exactly zero, before the EKF estimates it: NaN),
        ``n_position_missing``, ``param_<NAME>`` (:data:`KEPT_PARAMETERS`), ``source_file``,
        ``processing_log``.

    Raises
    ------
    InputError
        Unreadable file, or no ``ATT`` message (the attitude is what the tilt method needs).
    """
    path = Path(path)
    msgs = read_dataflash_messages(path)
    att = msgs.get("ATT")
    if att is None or att["TimeUS"].size == 0:
        raise InputError(f"{path} [ATT]", "the log holds no ATT message; the attitude is needed to measure "
                                          "wind from the multicopter's tilt (Wetz et al. 2021, Sect. 4.2)")
    log = [f"read: DataFlash {path.name}: " + ", ".join(f"{k} {next(iter(v.values())).size}" for k, v in msgs.items())]
    t_us = att["TimeUS"].astype(np.int64)
    ekf_name = "EKF3" if "XKF1" in msgs else ("EKF2" if "NKF1" in msgs else "none")
    kf1 = _one_core(msgs["XKF1"], ekf_core) if "XKF1" in msgs else msgs.get("NKF1")
    kf2 = _one_core(msgs["XKF2"], ekf_core) if "XKF2" in msgs else msgs.get("NKF2")
    data: dict[str, np.ndarray] = {
        "roll_deg": att["Roll"].astype(float), "pitch_deg": att["Pitch"].astype(float),
        "yaw_deg": att["Yaw"].astype(float) % 360.0, "des_roll_deg": att["DesRoll"].astype(float),
        "des_pitch_deg": att["DesPitch"].astype(float), "des_yaw_deg": att["DesYaw"].astype(float) % 360.0,
    }
    nan = np.full(t_us.size, np.nan)
    for key, field in (("vel_n_ms", "VN"), ("vel_e_ms", "VE"), ("vel_d_ms", "VD"),
                       ("pos_n_m", "PN"), ("pos_e_m", "PE"), ("pos_d_m", "PD")):
        data[key] = _interp(t_us, kf1["TimeUS"], kf1[field]) if kf1 is not None else nan.copy()
    n_unset = 0
    if kf2 is not None:
        vwn, vwe = kf2["VWN"].astype(float), kf2["VWE"].astype(float)
        unset = (vwn == 0.0) & (vwe == 0.0)
        n_unset = int(unset.sum())
        vwn, vwe = np.where(unset, np.nan, vwn), np.where(unset, np.nan, vwe)
        # interpolation only between estimated rows: a stretch of unset rows stays NaN
        data["ekf_wind_n_ms"] = _interp_masked(t_us, kf2["TimeUS"], vwn)
        data["ekf_wind_e_ms"] = _interp_masked(t_us, kf2["TimeUS"], vwe)
        log.append(f"ekf wind: {ekf_name} core {ekf_core}; {n_unset} of {unset.size} rows exactly zero "
                   "(the EKF not yet estimating wind) set to NaN")
    else:
        data["ekf_wind_n_ms"], data["ekf_wind_e_ms"] = nan.copy(), nan.copy()
        log.append("ekf wind: no XKF2/NKF2 message; EKF wind NaN")
    baro = msgs.get("BARO")
    if baro is not None:
        b = {k: v[baro["I"] == 0] for k, v in baro.items()} if "I" in baro else baro
        data["baro_alt_m"] = _interp(t_us, b["TimeUS"], b["Alt"])
        data["pressure_pa"] = _interp(t_us, b["TimeUS"], b["Press"])
        data["baro_temp_degc"] = _interp(t_us, b["TimeUS"], b["Temp"])
    else:
        for k in ("baro_alt_m", "pressure_pa", "baro_temp_degc"):
            data[k] = nan.copy()
    position, source = _position(msgs, kf1, t_us)
    data.update(position)
    n_pos_missing = int(np.sum(~np.isfinite(data["lat_deg"]) | ~np.isfinite(data["vel_n_ms"])))
    log.append(f"position: from {source}; velocity from {ekf_name} core {ekf_core}; {n_pos_missing} attitude "
               "samples without position or velocity (NaN)")
    utc_offset_ns, utc_valid = _utc_offset_ns(msgs, path, log)
    params = {}
    if "PARM" in msgs:  # the last value logged of each kept parameter
        for name, value in zip(msgs["PARM"]["Name"], msgs["PARM"]["Value"], strict=True):
            if str(name) in KEPT_PARAMETERS:
                params[f"param_{name}"] = float(value)
    time = (t_us * 1000 + utc_offset_ns).astype("datetime64[ns]")
    ds = xr.Dataset({k: ("time", v) for k, v in data.items()}, coords={"time": time})
    for name, attrs in _ATTRS.items():
        ds[name].attrs.update(attrs)
    ds.attrs.update({"utc_valid": utc_valid, "utc_offset_us": utc_offset_ns // 1000, "ekf": ekf_name,
                     "ekf_core": ekf_core, "position_source": source, "n_ekf_wind_unset": n_unset,
                     "n_position_missing": n_pos_missing, "n_nonfinite": 0, "format": "ardupilot_bin", **params,
                     "source_file": str(path), "processing_log": "\n".join(log)})
    return ds


def _interp_masked(t_us: np.ndarray, src_t_us: np.ndarray, values: np.ndarray) -> np.ndarray:
    """As :func:`_interp`, but NaN wherever the nearest source rows on either side include a NaN."""
    out = _interp(t_us, src_t_us, values)
    order = np.argsort(src_t_us, kind="stable")
    st, sv = src_t_us[order], values[order]
    k = np.clip(np.searchsorted(st, t_us, side="right"), 1, st.size - 1)
    bad = ~np.isfinite(sv[k - 1]) | ~np.isfinite(sv[k])
    out[bad] = np.nan
    return out
