"""Quadrotor records in any delimited text, by a column mapping (``format: delimited``).

A multicopter record that is neither the contract CSV nor an autopilot log (e.g. a vehicle
log exported at 1 Hz, or attitude merged with a tower's speed and direction by hand) is
read with the mapping the mast sonics use (:mod:`dronewind.core.delimited`: time column and
kind, per variable its column, scale, offset and unit), extended to the variables of the
quadrotor dataset. Only ``time``, ``roll`` and ``pitch`` are required (Wetz et al. 2021,
Sect. 4.2: the tilt gives the speed):

* ``yaw`` absent: yaw is set to 0 and ``attrs['yaw_known'] = 0``; the speed is right for a
  hovering vehicle, the direction is relative to the nose, not to north;
* velocities absent (``vel_n``, ``vel_e`` with ``vel_d`` or ``vel_u``): the vehicle is taken
  as hovering still (velocities 0, ``attrs['hover_assumed'] = 1``);
* position absent: ``lat``/``lon`` 0 and ``alt`` the format's ``altitude_m`` (metres above
  mean sea level of the hover, required then); ``attrs['position_known'] = 0``;
* ``ref_speed`` and ``ref_from`` (optional): a reference wind in the same record
  (:func:`reference_from_record` turns them into the tower reference dataset);
* ``temperature`` and ``pressure`` (optional): the air's, for the density of the drag balance
  (``air_temp_degc``, ``pressure_pa``).

Rates down to 1 Hz (averaged values) are accepted. Each assumption is logged in
``processing_log``.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core.constants import ZERO_CELSIUS_K
from dronewind.core.delimited import delimited_layout, read_delimited
from dronewind.errors import InputError
from dronewind.quadrotor.columns import QUADROTOR_QUANTITIES

__all__ = ["QUADROTOR_QUANTITIES", "read_quadrotor_delimited", "reference_from_record"]



def read_quadrotor_delimited(path: str | Path, fmt: Mapping[str, Any], where: str = "format") -> xr.Dataset:
    """Read a delimited quadrotor record into the quadrotor dataset.

    Parameters
    ----------
    path : str or Path
        The file.
    fmt : mapping
        ``name: delimited``, the delimited settings (``delimiter``, ``header_line``,
        ``skip_lines``, ``time``), ``variables`` (:data:`QUADROTOR_QUANTITIES`; ``roll`` and
        ``pitch`` required) and ``altitude_m`` when ``alt`` is not mapped.
    where : str
        Key path of the format, for messages.

    Returns
    -------
    xarray.Dataset
        As :func:`dronewind.quadrotor.io.read_quadrotor_csv`, with ``ref_speed_ms`` and
        ``ref_from_deg`` when mapped; attrs ``yaw_known``, ``hover_assumed``,
        ``position_known`` (1/0), ``n_corrupt``, ``n_nonfinite``.

    Raises
    ------
    InputError
        ``roll`` or ``pitch`` not mapped, an incomplete velocity set, no ``alt`` and no
        ``altitude_m``, a rate below 1 Hz, or a reader error.
    """
    from dronewind.quadrotor.io import _finish, _sort_dedupe  # the layout every quadrotor reader shares

    path = Path(path)
    layout = delimited_layout(fmt, where, QUADROTOR_QUANTITIES)
    have = set(layout.variables)
    missing = [k for k in ("roll", "pitch") if k not in have]
    if missing:
        raise InputError(f"{where}.variables", f"missing {', '.join(missing)}; a quadrotor record needs at least "
                         "time, roll and pitch (the tilt gives the wind speed)")
    velocity = have & {"vel_n", "vel_e", "vel_d", "vel_u"}
    if velocity and not ({"vel_n", "vel_e"} <= velocity and velocity & {"vel_d", "vel_u"}):
        raise InputError(f"{where}.variables", f"velocity incomplete (found {sorted(velocity)}); expected vel_n, "
                         "vel_e and vel_d (down) or vel_u (up), or none (hover assumed)")
    if "alt" not in have and "altitude_m" not in fmt:
        raise InputError(f"{where}.altitude_m", "no alt column and no altitude_m; the hover altitude above mean sea "
                         "level is needed to pair the record with the reference height")
    table = read_delimited(path, layout)
    v = table.values
    n = table.time.size
    log = [f"read: {n} rows from {path.name} (delimited; {table.n_corrupt} corrupt rows removed, "
           f"{table.n_nonnumeric} non-numeric values set to NaN)"]
    zeros = np.zeros(n)
    data = {"roll_deg": v["roll"], "pitch_deg": v["pitch"]}
    yaw_known = int("yaw" in v)
    data["yaw_deg"] = v["yaw"] % 360.0 if yaw_known else zeros.copy()
    if not yaw_known:
        log.append("yaw: not in the record; set to 0: the wind speed holds, its direction is relative to the nose")
    hover_assumed = int(not velocity)
    if velocity:
        data["vel_n_ms"], data["vel_e_ms"] = v["vel_n"], v["vel_e"]
        data["vel_d_ms"] = v["vel_d"] if "vel_d" in v else -v["vel_u"]
    else:
        data["vel_n_ms"], data["vel_e_ms"], data["vel_d_ms"] = zeros.copy(), zeros.copy(), zeros.copy()
        log.append("velocity: not in the record; the vehicle is taken as hovering still (velocities 0)")
    position_known = int("lat" in v and "lon" in v)
    data["lat_deg"] = v["lat"] if position_known else zeros.copy()
    data["lon_deg"] = v["lon"] if position_known else zeros.copy()
    data["alt_m"] = v["alt"] if "alt" in v else np.full(n, float(fmt["altitude_m"]))
    if not position_known:
        log.append("position: not in the record; latitude and longitude 0 (unknown), the hover taken as still")
    if "alt" not in v:
        log.append(f"altitude: not in the record; {float(fmt['altitude_m']):g} m (format altitude_m) throughout")
    if "temperature" in v:
        data["air_temp_degc"] = v["temperature"] - ZERO_CELSIUS_K
    if "pressure" in v:
        data["pressure_pa"] = v["pressure"]
    for ref in ("ref_speed", "ref_from"):
        if ref in v:
            data[f"{ref}_{'ms' if ref == 'ref_speed' else 'deg'}"] = v[ref]
    ds = xr.Dataset({k: ("time", np.asarray(x, float)) for k, x in data.items()}, coords={"time": table.time})
    n_nonfinite = int(sum(int((~np.isfinite(x)).sum()) for x in data.values()))
    ds.attrs.update({"yaw_known": yaw_known, "hover_assumed": hover_assumed, "position_known": position_known,
                     "n_corrupt": table.n_corrupt, "n_nonfinite": n_nonfinite, "format": "delimited"})
    ds = _sort_dedupe(ds, log)
    ds = _finish(ds, path, log)
    if ds.sizes["time"] > 1 and ds.attrs["sampling_rate_hz"] < 0.99:
        raise InputError(path, f"median sampling rate {ds.attrs['sampling_rate_hz']:.3g} Hz; expected at least "
                               "1 Hz (averaged values)")
    return ds


def reference_from_record(ds: xr.Dataset, height_m: float) -> xr.Dataset:
    """The reference wind held in a quadrotor record, as the tower reference dataset.

    Parameters
    ----------
    ds : xarray.Dataset
        A record with ``ref_speed_ms`` (and ``ref_from_deg``) (:func:`read_quadrotor_delimited`).
    height_m : float
        Height of the reference above ground [m].

    Returns
    -------
    xarray.Dataset
        As :func:`dronewind.quadrotor.reference.read_tower_reference`: ``wind_speed_ms``,
        ``wind_from_deg`` on (``time``, ``height``), ``sampling_interval_s``; times whose
        speed is missing are left out (counted in ``n_nonfinite``).

    Raises
    ------
    InputError
        The record holds no reference speed.
    """
    if "ref_speed_ms" not in ds:
        raise InputError(str(ds.attrs.get("source_file", "record")), "no ref_speed column mapped: the record holds "
                         "no reference wind")
    sp = ds["ref_speed_ms"].to_numpy()
    di = ds["ref_from_deg"].to_numpy() if "ref_from_deg" in ds else np.full(sp.size, np.nan)
    ok = np.isfinite(sp)
    t = ds["time"].to_numpy()[ok]
    out = xr.Dataset({"wind_speed_ms": (("time", "height"), sp[ok, None]),
                      "wind_from_deg": (("time", "height"), di[ok, None] % 360.0)},
                     coords={"time": t, "height_m": ("height", [float(height_m)])})
    out["wind_speed_ms"].attrs.update({"units": "m s-1", "standard_name": "wind_speed"})
    out["wind_from_deg"].attrs.update({"units": "degree", "standard_name": "wind_from_direction"})
    dt = np.diff(t.astype("int64")) / 1e9
    out.attrs.update({"sampling_interval_s": float(np.median(dt)) if dt.size else float("nan"),
                      "n_nonfinite": int((~ok).sum()), "n_duplicates": 0, "form": "record columns",
                      "source_file": str(ds.attrs.get("source_file", "")),
                      "processing_log": f"reference: {int(ok.sum())} rows of the UAV record's ref_speed column"})
    return out
